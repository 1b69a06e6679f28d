# Package test (ctest label "package"): installs Wake from a build directory into a fresh
# prefix, then configures, builds and runs the outside project in this folder against it.
# Everything it writes is under WORK_DIR (in the build directory). Any failing step is fatal.
#
#   cmake -DWAKE_BUILD_DIR=<build> -DWORK_DIR=<dir> [-DCONFIG=<cfg>] [-DGENERATOR=<gen>]
#         [-DMAKE_PROGRAM=<ninja>] [-DCXX_COMPILER=<c++>] [-DCXX_FLAGS=<flags>]
#         -P run_package_test.cmake
cmake_minimum_required(VERSION 3.18)

foreach(var WAKE_BUILD_DIR WORK_DIR)
  if(NOT ${var})
    message(FATAL_ERROR "package test: -D${var}=... is required")
  endif()
endforeach()
if(NOT CONFIG)
  set(CONFIG Release)
endif()
set(source_dir "${CMAKE_CURRENT_LIST_DIR}")
set(prefix "${WORK_DIR}/prefix")
set(consumer_build "${WORK_DIR}/consumer")

# Runs one step; stops the test with its output when it fails.
function(step name)
  string(TIMESTAMP t0 "%s")
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  string(TIMESTAMP t1 "%s")
  math(EXPR seconds "${t1} - ${t0}")
  if(NOT rc EQUAL 0)
    string(REPLACE ";" " " cmd "${ARGN}")
    message(FATAL_ERROR "package test: ${name} FAILED (exit ${rc})\n  command: ${cmd}\n${out}")
  endif()
  message(STATUS "package test: ${name}: ok (${seconds} s)")
  set(step_output "${out}" PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${WORK_DIR}")

step("install" "${CMAKE_COMMAND}" --install "${WAKE_BUILD_DIR}" --config "${CONFIG}"
     --prefix "${prefix}")
foreach(f lib/cmake/Wake/WakeConfig.cmake lib/cmake/Wake/WakeConfigVersion.cmake
          lib/cmake/Wake/WakeTargets.cmake lib/cmake/Wake/WakeBullet.cmake
          include/wake/sph/fluid.hpp include/wake/coupling/simulation.hpp
          include/wake/bullet_bridge/bullet_info.hpp bin/wake)
  # GNUInstallDirs may pick lib64 or a multiarch libdir: look under both.
  string(REPLACE "lib/" "lib*/" pattern "${f}")
  file(GLOB found "${prefix}/${pattern}" "${prefix}/lib/*/${f}")
  if(NOT found)
    message(FATAL_ERROR "package test: the install is missing ${f} (under ${prefix})")
  endif()
endforeach()

set(configure_args -S "${source_dir}" -B "${consumer_build}"
    "-DCMAKE_PREFIX_PATH=${prefix}"
    "-DCMAKE_BUILD_TYPE=${CONFIG}"
    # Only the fresh prefix may provide Wake, not a build tree or a user registry.
    -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF
    -DCMAKE_FIND_USE_SYSTEM_PACKAGE_REGISTRY=OFF)
if(GENERATOR)
  list(APPEND configure_args -G "${GENERATOR}")
endif()
if(MAKE_PROGRAM)
  list(APPEND configure_args "-DCMAKE_MAKE_PROGRAM=${MAKE_PROGRAM}")
endif()
if(CXX_COMPILER)
  list(APPEND configure_args "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}")
endif()
if(CXX_FLAGS)
  list(APPEND configure_args "-DCMAKE_CXX_FLAGS=${CXX_FLAGS}" "-DCMAKE_EXE_LINKER_FLAGS=${CXX_FLAGS}")
endif()
step("configure the outside project" "${CMAKE_COMMAND}" ${configure_args})
file(STRINGS "${consumer_build}/CMakeCache.txt" wake_dir REGEX "^Wake_DIR:")
string(REGEX REPLACE "^Wake_DIR:[A-Z]+=" "" wake_dir "${wake_dir}")
get_filename_component(real_prefix "${prefix}" REALPATH)
get_filename_component(wake_dir "${wake_dir}" REALPATH)
string(FIND "${wake_dir}" "${real_prefix}/" at)
if(NOT at EQUAL 0)
  message(FATAL_ERROR "package test: Wake was found in '${wake_dir}', not in the prefix ${prefix}")
endif()

step("build the outside project" "${CMAKE_COMMAND}" --build "${consumer_build}" --config "${CONFIG}")
set(exe "${consumer_build}/wake_consumer")
if(NOT EXISTS "${exe}" AND EXISTS "${consumer_build}/${CONFIG}/wake_consumer")
  set(exe "${consumer_build}/${CONFIG}/wake_consumer")
endif()
step("run wake_consumer" "${exe}")
string(REPLACE "wake_consumer" "wake_surface_consumer" surface_exe "${exe}")
step("run wake_surface_consumer" "${surface_exe}")
message(STATUS "${step_output}")
message(STATUS "package test: passed")
