# OpenVDB (Debian libopenvdb-dev) as the imported target wake::openvdb. Debian's
# FindOpenVDB.cmake also asks for Boost.Iostreams, which nothing of Wake's needs; the
# library, its headers, TBB and Imath (which its headers include) are found directly.
function(wake_find_openvdb)
  if(TARGET wake::openvdb)
    return()
  endif()
  find_package(TBB REQUIRED)
  find_package(Imath REQUIRED)
  find_path(WAKE_OPENVDB_INCLUDE_DIR openvdb/openvdb.h)
  find_library(WAKE_OPENVDB_LIBRARY NAMES openvdb)
  mark_as_advanced(WAKE_OPENVDB_INCLUDE_DIR WAKE_OPENVDB_LIBRARY)
  if(NOT WAKE_OPENVDB_INCLUDE_DIR OR NOT WAKE_OPENVDB_LIBRARY)
    message(FATAL_ERROR "OpenVDB not found (Debian: apt-get install libopenvdb-dev)")
  endif()
  add_library(wake::openvdb UNKNOWN IMPORTED GLOBAL)
  set_target_properties(wake::openvdb PROPERTIES
    IMPORTED_LOCATION "${WAKE_OPENVDB_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${WAKE_OPENVDB_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "TBB::tbb;Imath::Imath")
endfunction()
