# Generates C++ for the IDL files under idl/ with fastddsgen at build time (nothing generated is
# committed: the output is tied to the Fast DDS / Fast CDR version found) and builds it as two
# libraries.
#
#   mlmap_idl_library(<target> CDR_TARGET <cdr_target> IDL_ROOT <dir>)
#
# <cdr_target> holds the types and their CDR (de)serialisation (<Name>_.cxx) and links Fast CDR
# only: what decodes recorded bytes (the bag reader) needs no more, and loading Fast DDS costs a
# process about 7 MB resident. <target> adds the PubSubTypes (<Name>_PubSubTypes.cxx, the
# types as Fast DDS topics) and links Fast DDS.
#
# Each <dir>/<pkg>/msg/<Name>_.idl yields <build>/idl_gen/<pkg>/msg/<Name>_{.h,.cxx,PubSubTypes.h,
# PubSubTypes.cxx}, and each service <dir>/<pkg>/srv/<Name>_.idl (its <Name>_Request_ and
# <Name>_Response_ structs) the same four files under <pkg>/srv/; the generated headers include
# each other as "<pkg>/msg/<Name>_.h", so the target exports <build>/idl_gen as its include
# directory.
#
# fastddsgen 2.3 pitfalls handled here (see ../shared/reference/dds-ros2-wire.md): -cs (member
# `pose_` vs type `Pose_`), absolute paths (relative ones silently give empty headers), one run
# over every file (it writes the code of included files too; a run per file would race in
# parallel builds), and outputs moved into <pkg>/msg/ afterwards because it writes them flat.
# RunFastddsgen.cmake runs it: a temporary directory of this build's own (its default, /tmp, is
# shared by every build on the machine), its errors fail the build, outputs land by rename.
find_program(FASTDDSGEN_EXECUTABLE fastddsgen REQUIRED)  # found already by MlmapDdsSupport
set(MLMAP_RUN_FASTDDSGEN "${CMAKE_CURRENT_LIST_DIR}/RunFastddsgen.cmake")

function(mlmap_idl_library target)
  cmake_parse_arguments(ARG "" "IDL_ROOT;CDR_TARGET" "" ${ARGN})
  get_filename_component(root "${ARG_IDL_ROOT}" ABSOLUTE)
  file(GLOB idl_files CONFIGURE_DEPENDS "${root}/*/msg/*_.idl" "${root}/*/srv/*_.idl")
  set(gen_dir "${CMAKE_CURRENT_BINARY_DIR}/idl_gen")
  set(outputs "")
  set(cdr_sources "")
  set(dds_sources "")
  set(seen "")
  foreach(idl IN LISTS idl_files)
    get_filename_component(name "${idl}" NAME_WE)
    get_filename_component(kind_dir "${idl}" DIRECTORY)  # <pkg>/msg or <pkg>/srv
    get_filename_component(kind "${kind_dir}" NAME)
    get_filename_component(pkg_dir "${kind_dir}" DIRECTORY)
    get_filename_component(pkg "${pkg_dir}" NAME)
    if(name IN_LIST seen)
      message(FATAL_ERROR "IDL type name ${name} appears in two packages; fastddsgen writes flat")
    endif()
    list(APPEND seen "${name}")
    foreach(suffix .h .cxx PubSubTypes.h PubSubTypes.cxx)
      set(out "${gen_dir}/${pkg}/${kind}/${name}${suffix}")
      list(APPEND outputs "${out}")
      if(suffix STREQUAL ".cxx")
        list(APPEND cdr_sources "${out}")
      elseif(suffix STREQUAL "PubSubTypes.cxx")
        list(APPEND dds_sources "${out}")
      endif()
    endforeach()
  endforeach()
  string(REPLACE ";" "|" idl_list "${idl_files}")  # one -D value
  add_custom_command(
    OUTPUT ${outputs}
    COMMAND ${CMAKE_COMMAND} "-DFASTDDSGEN=${FASTDDSGEN_EXECUTABLE}" "-DIDL_ROOT=${root}"
            "-DIDL_FILES=${idl_list}" "-DGEN_DIR=${gen_dir}"
            "-DWORK_DIR=${CMAKE_CURRENT_BINARY_DIR}/idl_work" -P "${MLMAP_RUN_FASTDDSGEN}"
    DEPENDS ${idl_files} "${MLMAP_RUN_FASTDDSGEN}"
    COMMENT "Generating Fast DDS types from ${root} with fastddsgen"
    VERBATIM)
  # The types' headers include Fast DDS's header-only fixed_size_string.hpp: its include
  # directory, not its library.
  add_library(${ARG_CDR_TARGET} ${cdr_sources})
  target_include_directories(${ARG_CDR_TARGET} SYSTEM PUBLIC "${gen_dir}"
                             $<TARGET_PROPERTY:fastrtps,INTERFACE_INCLUDE_DIRECTORIES>)
  target_link_libraries(${ARG_CDR_TARGET} PUBLIC fastcdr)
  target_compile_features(${ARG_CDR_TARGET} PUBLIC cxx_std_17)
  set_target_properties(${ARG_CDR_TARGET} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  add_library(${target} ${dds_sources})
  target_link_libraries(${target} PUBLIC ${ARG_CDR_TARGET} fastrtps)
  set_target_properties(${target} PROPERTIES POSITION_INDEPENDENT_CODE ON)
endfunction()
