# Runs fastddsgen for mlmap_idl_library() (cmake -P), so that a failed or disturbed run fails the
# build instead of leaving broken headers behind:
#   cmake -DFASTDDSGEN=<exe> -DIDL_ROOT=<dir> -DIDL_FILES=<a|b|...> -DGEN_DIR=<dir> -DWORK_DIR=<dir>
#         -P RunFastddsgen.cmake
#
# - fastddsgen preprocesses every file into its temporary directory, /tmp by default, under the
#   file's own name: two builds on one machine overwrote each other's files there and one of them
#   generated truncated code. Each build gets its own (<WORK_DIR>/tmp).
# - It writes flat into <WORK_DIR>/flat, which is emptied first.
# - Its exit status, any "error" it prints and any expected output that is missing or empty fail
#   the step, with what it printed.
# - Each output then lands as <GEN_DIR>/<pkg>/<msg|srv>/<Name>_<suffix> by a rename (a reader never
#   sees half a file), and only when its content changed (unchanged types are not rebuilt).
foreach(var FASTDDSGEN IDL_ROOT IDL_FILES GEN_DIR WORK_DIR)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "RunFastddsgen.cmake: ${var} is not set")
  endif()
endforeach()

string(REPLACE "|" ";" IDL_FILES "${IDL_FILES}")
set(flat_dir "${WORK_DIR}/flat")
set(tmp_dir "${WORK_DIR}/tmp")
file(REMOVE_RECURSE "${flat_dir}" "${tmp_dir}")
file(MAKE_DIRECTORY "${flat_dir}" "${tmp_dir}")
execute_process(
  COMMAND "${FASTDDSGEN}" -cs -replace -t "${tmp_dir}" -d "${flat_dir}" -I "${IDL_ROOT}" ${IDL_FILES}
  RESULT_VARIABLE status
  OUTPUT_VARIABLE printed
  ERROR_VARIABLE printed)
string(TOLOWER "${printed}" printed_lower)
if(NOT status EQUAL 0 OR printed_lower MATCHES "error" OR printed_lower MATCHES "exception")
  message(FATAL_ERROR "fastddsgen failed (exit status ${status}); nothing generated was kept:\n${printed}")
endif()

set(suffixes .h .cxx PubSubTypes.h PubSubTypes.cxx)
set(landed 0)
foreach(idl IN LISTS IDL_FILES)
  get_filename_component(name "${idl}" NAME_WE)
  get_filename_component(kind_dir "${idl}" DIRECTORY)
  get_filename_component(kind "${kind_dir}" NAME)
  get_filename_component(pkg_dir "${kind_dir}" DIRECTORY)
  get_filename_component(pkg "${pkg_dir}" NAME)
  foreach(suffix IN LISTS suffixes)
    set(made "${flat_dir}/${name}${suffix}")
    file(SIZE "${made}" size)  # fails the step, naming the file, when it is missing
    if(size EQUAL 0)
      message(FATAL_ERROR "fastddsgen wrote an empty ${made}:\n${printed}")
    endif()
    set(out "${GEN_DIR}/${pkg}/${kind}/${name}${suffix}")
    if(EXISTS "${out}")
      execute_process(COMMAND "${CMAKE_COMMAND}" -E compare_files "${made}" "${out}"
                      RESULT_VARIABLE differs)
      if(differs EQUAL 0)
        continue()
      endif()
    endif()
    get_filename_component(out_dir "${out}" DIRECTORY)
    file(MAKE_DIRECTORY "${out_dir}")
    file(COPY_FILE "${made}" "${out}.part")
    file(RENAME "${out}.part" "${out}")
    math(EXPR landed "${landed} + 1")
  endforeach()
endforeach()
message(STATUS "fastddsgen: ${landed} generated files changed")
