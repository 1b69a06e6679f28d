#!/usr/bin/env bash
# Installs dependencies, builds Wake (Release) and runs the whole test suite (including the
# package test: install, then build an outside project with find_package(Wake)); then
# builds against double-precision Bullet (build-f64) and runs the Bullet and package tests
# there; then runs the fast unit and end-to-end tests again under AddressSanitizer + UBSan.
# WAKE_SKIP_BULLET_DOUBLE=1 skips the double-precision part, WAKE_SKIP_SANITIZERS=1 the last;
# WAKE_ALL_TESTS=1 also runs the tests labelled "slow" (not run by default, see below).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh --clients
# Through ccache, its cache in build/: the double-precision build below then takes the
# objects of the sources that do not include Bullet (sph, geometry, coupling, surface:
# the same compiler command in both builds) from the first instead of compiling them
# again (depend mode: no preprocessor run on a miss).
export CCACHE_DIR="$PWD/build/ccache" CCACHE_DEPEND=1
launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
# Each test program compiled as one source (WAKE_UNITY_TESTS): the test sources' compile
# time 240 s -> 137 s (the headers they share parsed once per program).
unity=(-DWAKE_UNITY_TESTS=ON)
BUILD_DIR=build bash scripts/build.sh "${launcher[@]}" "${unity[@]}"
# One test per core, each on one thread: the physics tests and scene runs scale better
# that way than one test at a time on every core (results are the same bits on any
# number of threads).
start=$SECONDS
# Tests labelled "slow" repeat checks that faster tests already make (another coupling
# method or density of the same physics); WAKE_ALL_TESTS=1 runs them too.
exclude=(-LE slow)
if [ "${WAKE_ALL_TESTS:-0}" = 1 ]; then exclude=(); fi
(cd build && OMP_NUM_THREADS=1 ctest --output-on-failure -j "$(nproc)" --timeout 1200 "${exclude[@]}")
echo "[wake] tests: $((SECONDS - start)) s"
if [ "${WAKE_SKIP_BULLET_DOUBLE:-0}" != 1 ]; then
  # Only what the tests below need: the installed targets and the Bullet test program.
  start=$SECONDS
  cmake -S . -B build-f64 -G Ninja -DCMAKE_BUILD_TYPE=Release -DWAKE_BULLET_DOUBLE=ON \
    -DWAKE_BUILD_BENCH=OFF "${launcher[@]}" "${unity[@]}" >/dev/null
  cmake --build build-f64 --parallel "$(nproc)" --target wake_installed wake_bullet_tests
  (cd build-f64 && ctest --output-on-failure -j 1 --timeout 1200 -L 'bullet|package')
  echo "[wake] double-precision Bullet build and tests: $((SECONDS - start)) s"
fi
if [ "${WAKE_SKIP_SANITIZERS:-0}" != 1 ]; then
  # Only the test programs of the quick ("sanitize") tests and what they need, with line
  # tables for the reports (-g1). The code these tests spend their time in (the
  # simulation's libraries, I/O, the geometry tests' brute-force checks:
  # WAKE_SIMULATION_FLAGS) at -O1, ASan's recommended optimisation; the rest (the other
  # tests, surfaces, render, the CLI's driver) at -O0, which compiles in about half the
  # time under the sanitizers (OpenVDB's templates in surface/fluid_surface.cpp: 50 s
  # instead of 101 s). Measured: this build 658 s of compiler time instead of 1,155 s,
  # its tests 395 s instead of 347 s.
  BUILD_DIR=build-asan WAKE_BUILD_TARGETS="wake_sph_tests wake_geometry_tests wake_surface_tests wake_coupling_tests wake_bullet_tests wake_io_tests wake_render_tests" \
    bash scripts/build.sh -DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O0 -g1 -DNDEBUG" \
      -DWAKE_SIMULATION_FLAGS=-O1 -DWAKE_SANITIZE=ON -DWAKE_BUILD_BENCH=OFF "${unity[@]}"
  (cd build-asan && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
     OMP_NUM_THREADS=1 ctest --output-on-failure -j "$(nproc)" --timeout 1200 -L sanitize)
fi
