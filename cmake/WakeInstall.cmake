# Installation and CMake package export of Wake.
#
#   find_package(Wake CONFIG REQUIRED)
#   target_link_libraries(app PRIVATE wake::coupling wake::bullet)
#
# Installed layout (GNUInstallDirs):
#   <libdir>/libwake_<module>.a             the libraries (static unless BUILD_SHARED_LIBS)
#   <includedir>/wake/<module>/*.hpp        headers, included as "sph/fluid.hpp" etc.
#   <bindir>/wake                           the command-line tool (also wake::wake)
#   <libdir>/cmake/Wake/                    WakeConfig.cmake, version, targets, WakeBullet.cmake,
#                                           WakeOpenVDB.cmake
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(WAKE_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/Wake"
    CACHE STRING "Where WakeConfig.cmake is installed, relative to the prefix")
mark_as_advanced(WAKE_INSTALL_CMAKEDIR)

# With BUILD_SHARED_LIBS, installed programs and libraries find Wake's libraries beside them.
function(wake_install_rpath target)
  if(BUILD_SHARED_LIBS)
    get_target_property(type ${target} TYPE)
    if(type STREQUAL "EXECUTABLE")
      file(RELATIVE_PATH rel "/${CMAKE_INSTALL_BINDIR}" "/${CMAKE_INSTALL_LIBDIR}")
      set_target_properties(${target} PROPERTIES INSTALL_RPATH "$ORIGIN/${rel}")
    else()
      set_target_properties(${target} PROPERTIES INSTALL_RPATH "$ORIGIN")
    endif()
  endif()
endfunction()

# wake_install_library(<target> <name>): installs the library <target> as wake::<name> (the
# in-tree alias name) into the export set, and the headers of the calling directory <dir>
# (<dir>/*.hpp, e.g. bullet_bridge/) as <includedir>/wake/<dir>/*.hpp. Headers are matched
# when installing, so new ones are picked up without touching this list.
function(wake_install_library target name)
  set_property(GLOBAL APPEND PROPERTY WAKE_INSTALLED_TARGETS ${target})
  wake_install_rpath(${target})
  get_filename_component(dir "${CMAKE_CURRENT_SOURCE_DIR}" NAME)
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${name})
  # Consumers compile Wake's headers as C++17 too.
  target_compile_features(${target} PUBLIC cxx_std_17)
  install(TARGETS ${target} EXPORT WakeTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT Wake_Development
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT Wake_Runtime
            NAMELINK_COMPONENT Wake_Development
    RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT Wake_Runtime
    INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/wake)
  install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/
    DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/wake/${dir}
    COMPONENT Wake_Development
    FILES_MATCHING PATTERN "*.hpp" PATTERN "*.h"
    PATTERN "cli" EXCLUDE)
endfunction()

# wake_install_executable(<target>): installs a program to <bindir>, exported as wake::<target>.
function(wake_install_executable target)
  set_property(GLOBAL APPEND PROPERTY WAKE_INSTALLED_TARGETS ${target})
  wake_install_rpath(${target})
  install(TARGETS ${target} EXPORT WakeTargets
    RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT Wake_Runtime)
endfunction()

# Called once at the end of the top-level CMakeLists.txt, after every module is added.
# Also adds the target `wake_installed`: builds everything that `cmake --install` installs
# (and nothing else), for builds that only run some tests and the package test.
function(wake_install_package)
  get_property(installed GLOBAL PROPERTY WAKE_INSTALLED_TARGETS)
  add_custom_target(wake_installed)
  add_dependencies(wake_installed ${installed})

  # A static library's PRIVATE dependencies are part of its link interface
  # ($<LINK_ONLY:...>), so the package config must find them as well.
  # tinyobjloader (wake::geometry's OBJ reader) and stb (PNG output of wake::render's
  # renderer, found again from the hints below).
  foreach(_need "wake_geometry;TINYOBJLOADER" "wake_render;STB")
    list(GET _need 0 _target)
    list(GET _need 1 _what)
    get_target_property(_type ${_target} TYPE)
    if(_type STREQUAL "STATIC_LIBRARY")
      set(WAKE_PACKAGE_NEEDS_${_what} ON)
    else()
      set(WAKE_PACKAGE_NEEDS_${_what} OFF)
    endif()
  endforeach()
  get_filename_component(WAKE_PACKAGE_STB_LIBRARY_HINT "${WAKE_STB_LIBRARY}" DIRECTORY)
  if(WAKE_BULLET_DOUBLE)
    set(WAKE_PACKAGE_BULLET_DOUBLE ON)
  else()
    set(WAKE_PACKAGE_BULLET_DOUBLE OFF)
  endif()

  # Hints for the package's own HDF5 search (used when the consumer does not enable C).
  set(include_hints ${HDF5_C_INCLUDE_DIRS} ${HDF5_INCLUDE_DIRS})
  set(library_hints)
  foreach(lib IN LISTS HDF5_C_LIBRARIES HDF5_LIBRARIES)
    if(lib MATCHES "/lib(hdf5|hdf5_serial)\\.")
      get_filename_component(dir "${lib}" DIRECTORY)
      list(APPEND library_hints "${dir}")
    endif()
  endforeach()
  foreach(kind INCLUDE LIBRARY)
    string(TOLOWER ${kind} lower)
    list(REMOVE_DUPLICATES ${lower}_hints)
    set(WAKE_PACKAGE_HDF5_${kind}_HINTS "")
    foreach(dir IN LISTS ${lower}_hints)
      string(APPEND WAKE_PACKAGE_HDF5_${kind}_HINTS " \"${dir}\"")
    endforeach()
  endforeach()

  install(EXPORT WakeTargets
    NAMESPACE wake::
    FILE WakeTargets.cmake
    DESTINATION ${WAKE_INSTALL_CMAKEDIR}
    COMPONENT Wake_Development)
  configure_package_config_file(
    ${PROJECT_SOURCE_DIR}/cmake/WakeConfig.cmake.in
    ${PROJECT_BINARY_DIR}/cmake/WakeConfig.cmake
    INSTALL_DESTINATION ${WAKE_INSTALL_CMAKEDIR}
    NO_SET_AND_CHECK_MACRO)
  # 0.x: a minor version may break the interface.
  write_basic_package_version_file(
    ${PROJECT_BINARY_DIR}/cmake/WakeConfigVersion.cmake
    VERSION ${PROJECT_VERSION}
    COMPATIBILITY SameMinorVersion)
  install(FILES
    ${PROJECT_BINARY_DIR}/cmake/WakeConfig.cmake
    ${PROJECT_BINARY_DIR}/cmake/WakeConfigVersion.cmake
    ${PROJECT_SOURCE_DIR}/cmake/WakeBullet.cmake
    ${PROJECT_SOURCE_DIR}/cmake/WakeOpenVDB.cmake
    DESTINATION ${WAKE_INSTALL_CMAKEDIR}
    COMPONENT Wake_Development)
endfunction()
