#!/usr/bin/env bash
# Installs dependencies, builds Wake (Release) and runs the whole test suite, then runs the
# fast unit and end-to-end tests again under AddressSanitizer + UBSan.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
BUILD_DIR=build bash scripts/build.sh
(cd build && ctest --output-on-failure -j 1 --timeout 1200)
if [ "${WAKE_SKIP_SANITIZERS:-0}" != 1 ]; then
  BUILD_DIR=build-asan bash scripts/build.sh -DCMAKE_BUILD_TYPE=RelWithDebInfo -DWAKE_SANITIZE=ON -DWAKE_BUILD_BENCH=OFF
  (cd build-asan && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
     ctest --output-on-failure -j 1 --timeout 1200 -L sanitize)
fi
