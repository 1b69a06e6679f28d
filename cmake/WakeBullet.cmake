# Wraps Debian's Bullet once, in one imported target `wake::bullet3` that carries the
# include directories, the libraries and the precision define together (Debian's
# BulletConfig.cmake only exports relative-path variables).
find_path(WAKE_BULLET_INCLUDE_DIR btBulletDynamicsCommon.h PATH_SUFFIXES bullet REQUIRED)
if(WAKE_BULLET_DOUBLE)
  set(_wake_bt_suffix "-float64")
else()
  set(_wake_bt_suffix "")
endif()
set(_wake_bt_libs)
foreach(_lib BulletDynamics BulletCollision LinearMath)
  find_library(WAKE_BULLET_${_lib}_LIBRARY NAMES ${_lib}${_wake_bt_suffix} REQUIRED)
  list(APPEND _wake_bt_libs ${WAKE_BULLET_${_lib}_LIBRARY})
endforeach()
if(NOT TARGET wake::bullet3)
  add_library(wake::bullet3 INTERFACE IMPORTED GLOBAL)
  set_target_properties(wake::bullet3 PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${WAKE_BULLET_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${_wake_bt_libs}")
  if(WAKE_BULLET_DOUBLE)
    set_property(TARGET wake::bullet3 APPEND PROPERTY INTERFACE_COMPILE_DEFINITIONS BT_USE_DOUBLE_PRECISION)
  endif()
endif()
message(STATUS "Wake: Bullet ${_wake_bt_suffix} from ${WAKE_BULLET_INCLUDE_DIR}")
