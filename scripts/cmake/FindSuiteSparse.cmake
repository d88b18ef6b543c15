# SuiteSparse 5.x on Debian ships neither a CMake config nor a .pc file: find the headers and the
# libraries by hand and wrap them in imported targets SuiteSparse::cholmod (which carries the
# ordering libraries it needs) and SuiteSparse::ccolamd / SuiteSparse::colamd.
find_path(SuiteSparse_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse)
foreach(lib cholmod ccolamd colamd amd camd suitesparseconfig)
  find_library(SuiteSparse_${lib}_LIBRARY ${lib})
  list(APPEND SuiteSparse_REQUIRED_VARS SuiteSparse_${lib}_LIBRARY)
endforeach()
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(SuiteSparse REQUIRED_VARS SuiteSparse_INCLUDE_DIR ${SuiteSparse_REQUIRED_VARS})
if(SuiteSparse_FOUND)
  foreach(lib cholmod ccolamd colamd amd camd suitesparseconfig)
    if(NOT TARGET SuiteSparse::${lib})
      add_library(SuiteSparse::${lib} UNKNOWN IMPORTED)
      set_target_properties(SuiteSparse::${lib} PROPERTIES
        IMPORTED_LOCATION "${SuiteSparse_${lib}_LIBRARY}"
        INTERFACE_INCLUDE_DIRECTORIES "${SuiteSparse_INCLUDE_DIR}")
    endif()
  endforeach()
  set_property(TARGET SuiteSparse::cholmod APPEND PROPERTY INTERFACE_LINK_LIBRARIES
    SuiteSparse::amd SuiteSparse::camd SuiteSparse::colamd SuiteSparse::ccolamd SuiteSparse::suitesparseconfig)
endif()
