# Finds the OpenCV 4 core, imgproc and imgcodecs libraries without the OpenCV CMake package,
# which Debian ships only in the 825 MB libopencv-dev meta-package (it pulls every module).
# Defines the imported targets OpenCVLite::OpenCVLite (core and imgproc: what the programs use)
# and OpenCVLite::imgcodecs (the tests' independent PNG reader and writer only: Debian's
# imgcodecs loads about 120 shared libraries, GDAL and HEIF among them, at every program start,
# so the programs encode and decode PNG with libpng, mlmap/pictures/png_codec.h).
find_path(OpenCVLite_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4)
foreach(module core imgproc imgcodecs)
  find_library(OpenCVLite_${module}_LIBRARY opencv_${module})
  list(APPEND OpenCVLite_LIBRARIES ${OpenCVLite_${module}_LIBRARY})
endforeach()
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(OpenCVLite REQUIRED_VARS OpenCVLite_INCLUDE_DIR
  OpenCVLite_core_LIBRARY OpenCVLite_imgproc_LIBRARY)
if(OpenCVLite_FOUND AND NOT TARGET OpenCVLite::OpenCVLite)
  add_library(OpenCVLite::OpenCVLite INTERFACE IMPORTED)
  set_target_properties(OpenCVLite::OpenCVLite PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${OpenCVLite_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${OpenCVLite_core_LIBRARY};${OpenCVLite_imgproc_LIBRARY}")
endif()
if(OpenCVLite_FOUND AND OpenCVLite_imgcodecs_LIBRARY AND NOT TARGET OpenCVLite::imgcodecs)
  add_library(OpenCVLite::imgcodecs INTERFACE IMPORTED)
  set_target_properties(OpenCVLite::imgcodecs PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${OpenCVLite_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${OpenCVLite_imgcodecs_LIBRARY};${OpenCVLite_core_LIBRARY}")
endif()
