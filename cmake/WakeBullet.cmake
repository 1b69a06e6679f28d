# Wraps Debian's Bullet once, in one imported target `wake::bullet3` that carries the
# include directories, the libraries and the precision define together (Debian's
# BulletConfig.cmake only exports relative-path variables).
#
# Used twice: by Wake's own build (top-level CMakeLists.txt) and by the installed package
# config (WakeConfig.cmake), which passes the precision Wake was built with, so that
# consumers link the same Bullet libraries and compile with the same BT_USE_DOUBLE_PRECISION.
#
#   wake_find_bullet3([DOUBLE] [GLOBAL] [QUIET] [RESULT_VARIABLE <var>])
#
# DOUBLE picks Debian's -float64 libraries and adds BT_USE_DOUBLE_PRECISION. Without
# RESULT_VARIABLE a missing Bullet is a fatal error; with it, <var> is set to TRUE or FALSE
# and <var>_MESSAGE says what is missing.
function(wake_find_bullet3)
  cmake_parse_arguments(ARG "DOUBLE;GLOBAL;QUIET" "RESULT_VARIABLE" "" ${ARGN})
  if(TARGET wake::bullet3)
    # Found before (e.g. a second find_package(Wake)): keep the first definition.
    if(ARG_RESULT_VARIABLE)
      set(${ARG_RESULT_VARIABLE} TRUE PARENT_SCOPE)
    endif()
    return()
  endif()
  if(ARG_DOUBLE)
    set(suffix "-float64")
    set(var_suffix "_FLOAT64")
  else()
    set(suffix "")
    set(var_suffix "")
  endif()
  set(missing)
  find_path(WAKE_BULLET_INCLUDE_DIR btBulletDynamicsCommon.h PATH_SUFFIXES bullet)
  if(NOT WAKE_BULLET_INCLUDE_DIR)
    list(APPEND missing "btBulletDynamicsCommon.h")
  endif()
  set(libs)
  foreach(lib BulletDynamics BulletCollision LinearMath)
    # The cache variable names the precision, so switching WAKE_BULLET_DOUBLE in an
    # existing build directory does not keep the other precision's library.
    find_library(WAKE_BULLET_${lib}${var_suffix}_LIBRARY NAMES ${lib}${suffix})
    if(WAKE_BULLET_${lib}${var_suffix}_LIBRARY)
      list(APPEND libs "${WAKE_BULLET_${lib}${var_suffix}_LIBRARY}")
    else()
      list(APPEND missing "lib${lib}${suffix}")
    endif()
  endforeach()
  if(missing)
    string(REPLACE ";" ", " missing "${missing}")
    set(msg "Wake: Bullet${suffix} not found (missing ${missing}; Debian: apt-get install libbullet-dev)")
    if(ARG_RESULT_VARIABLE)
      set(${ARG_RESULT_VARIABLE} FALSE PARENT_SCOPE)
      set(${ARG_RESULT_VARIABLE}_MESSAGE "${msg}" PARENT_SCOPE)
      return()
    endif()
    message(FATAL_ERROR "${msg}")
  endif()
  if(ARG_GLOBAL)
    add_library(wake::bullet3 INTERFACE IMPORTED GLOBAL)
  else()
    add_library(wake::bullet3 INTERFACE IMPORTED)
  endif()
  set_target_properties(wake::bullet3 PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${WAKE_BULLET_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${libs}")
  if(ARG_DOUBLE)
    set_property(TARGET wake::bullet3 APPEND PROPERTY INTERFACE_COMPILE_DEFINITIONS BT_USE_DOUBLE_PRECISION)
  endif()
  if(ARG_RESULT_VARIABLE)
    set(${ARG_RESULT_VARIABLE} TRUE PARENT_SCOPE)
  endif()
  if(NOT ARG_QUIET)
    if(ARG_DOUBLE)
      message(STATUS "Wake: Bullet (double precision, -float64) from ${WAKE_BULLET_INCLUDE_DIR}")
    else()
      message(STATUS "Wake: Bullet (single precision) from ${WAKE_BULLET_INCLUDE_DIR}")
    endif()
  endif()
endfunction()
