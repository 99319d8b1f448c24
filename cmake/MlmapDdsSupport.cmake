# Decides whether the DDS component (IDL types, mlmap_node, the bag reader) is built, and finds
# what it needs.
#
#   mlmap_resolve_dds_support()
#
# MLMAP_BUILD_DDS (cache) is ON, OFF or AUTO. ON requires Fast DDS and Fast CDR (CMake packages
# fastrtps and fastcdr) and fastddsgen, and stops with an error naming what is missing. AUTO (the
# default) builds the component when they are found and the Fast DDS is one mlmap supports, and
# otherwise turns it off with a message saying why: so a plain `colcon build` of a ROS 2 Jazzy
# workspace holding this repository (where Fast DDS is ROS's 2.14 and there is no fastddsgen)
# builds the mapping core and the offline programs instead of failing. The result is set as a
# normal variable MLMAP_BUILD_DDS (ON or OFF) in the caller's scope, which every `if()` then sees.
#
# Supported: Fast DDS 2.9.x, Debian 12's (the generated code follows fastddsgen 2.x; the wire and
# the behaviour are checked with that version, see docs/dds-and-ros2.md).
set(MLMAP_FASTDDS_SUPPORTED_MIN 2.9)
set(MLMAP_FASTDDS_SUPPORTED_BELOW 2.10)

macro(mlmap_resolve_dds_support)
  string(TOUPPER "${MLMAP_BUILD_DDS}" _mlmap_dds_mode)
  if(_mlmap_dds_mode STREQUAL "AUTO")
    find_package(fastcdr QUIET)
    find_package(fastrtps QUIET)
    find_program(FASTDDSGEN_EXECUTABLE fastddsgen)
    set(_mlmap_dds_missing "")
    if(NOT fastrtps_FOUND OR NOT fastcdr_FOUND)
      set(_mlmap_dds_missing "Fast DDS / Fast CDR not found (Debian: libfastrtps-dev)")
    elseif(fastrtps_VERSION VERSION_LESS MLMAP_FASTDDS_SUPPORTED_MIN OR
           NOT fastrtps_VERSION VERSION_LESS MLMAP_FASTDDS_SUPPORTED_BELOW)
      set(_mlmap_dds_missing
          "Fast DDS ${fastrtps_VERSION} found at ${fastrtps_DIR} (ROS 2 Jazzy's is 2.14); mlmap_node "
          "is built with Fast DDS ${MLMAP_FASTDDS_SUPPORTED_MIN}.x, Debian 12's (tools/install_deps.sh, "
          "or docker/onboard.Dockerfile); it talks to Jazzy's rmw_fastrtps_cpp over the wire")
    elseif(NOT FASTDDSGEN_EXECUTABLE)
      set(_mlmap_dds_missing "fastddsgen not found (Debian: fastddsgen), needed for the IDL types")
    endif()
    if(_mlmap_dds_missing STREQUAL "")
      set(MLMAP_BUILD_DDS ON)
    else()
      message(STATUS "mlmap: the DDS component (mlmap_node, the IDL types, the bag reader) is off: "
                     "${_mlmap_dds_missing}. The mapping core and the offline programs are built. "
                     "-DMLMAP_BUILD_DDS=ON makes this an error.")
      set(MLMAP_BUILD_DDS OFF)
    endif()
  elseif(MLMAP_BUILD_DDS)
    find_package(fastcdr REQUIRED)
    find_package(fastrtps REQUIRED)
    find_program(FASTDDSGEN_EXECUTABLE fastddsgen REQUIRED)
    if(fastrtps_VERSION VERSION_LESS MLMAP_FASTDDS_SUPPORTED_MIN OR
       NOT fastrtps_VERSION VERSION_LESS MLMAP_FASTDDS_SUPPORTED_BELOW)
      message(WARNING "mlmap: Fast DDS ${fastrtps_VERSION} (${fastrtps_DIR}) is not the "
                      "${MLMAP_FASTDDS_SUPPORTED_MIN}.x mlmap is built and checked with; building "
                      "anyway because MLMAP_BUILD_DDS is ON")
    endif()
    set(MLMAP_BUILD_DDS ON)
  else()
    set(MLMAP_BUILD_DDS OFF)
  endif()
endmacro()
