# Target helpers of every mlmap CMakeLists.txt: warnings, sanitizers, libraries, programs.
# With ASan, three UBSan checks are left out: object-size (ASan's redzones catch the same
# out-of-bounds accesses, exactly), null (ASan reports a null dereference as a SEGV with its
# stack) and alignment (not covered by ASan, but every reinterpret_cast in src/ is to bytes and
# wire data are read through memcpy and Fast CDR; x86-64 and ARM64 load misaligned scalars).
# Together they kept Eigen's one-line accessors out of line: the depth-camera simulator ran 6x
# slower (8 frames: 2.75 s, 0.44 s without them, 0.14 s under ASan alone) and the test suite
# with it.
set(MLMAP_SANITIZE_EXCLUDE "")
if(MLMAP_SANITIZE MATCHES "undefined" AND MLMAP_SANITIZE MATCHES "address")
  set(MLMAP_SANITIZE_EXCLUDE -fno-sanitize=object-size,alignment,null)
endif()

# Standard, warnings and sanitizers for every mlmap target.
function(mlmap_target_defaults target)
  target_compile_features(${target} PUBLIC cxx_std_17)
  set_target_properties(${target} PROPERTIES CXX_EXTENSIONS OFF POSITION_INDEPENDENT_CODE ON)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wconversion
                                           -Wno-sign-conversion $<$<BOOL:${MLMAP_WERROR}>:-Werror>
                                           -fno-math-errno -fno-trapping-math)  # lets hot loops vectorise
  if(MLMAP_SANITIZE)
    target_compile_options(${target} PUBLIC -fsanitize=${MLMAP_SANITIZE} -fno-omit-frame-pointer
                                            ${MLMAP_SANITIZE_EXCLUDE})
    target_link_options(${target} PUBLIC -fsanitize=${MLMAP_SANITIZE})
  endif()
endfunction()

function(mlmap_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_library(${name} ${ARG_SOURCES})
  add_library(mlmap::${name} ALIAS ${name})
  target_include_directories(${name} PUBLIC $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include>
                                            $<INSTALL_INTERFACE:include>)
  target_link_libraries(${name} PUBLIC ${ARG_DEPS})
  mlmap_target_defaults(${name})
endfunction()

# Coverage feedback for libFuzzer (MLMAP_FUZZ): instruments `sources` of `target` (the parsers of
# outside data; the rest keeps its speed) and links its consumers with the coverage callbacks.
# Call it in the folder that adds `target` (source properties belong to their folder).
function(mlmap_fuzz_instrument target)
  cmake_parse_arguments(ARG "" "" "SOURCES" ${ARGN})
  if(MLMAP_FUZZ)
    set_property(SOURCE ${ARG_SOURCES} APPEND PROPERTY COMPILE_OPTIONS -fsanitize=fuzzer-no-link)
    target_link_options(${target} INTERFACE -fsanitize=fuzzer-no-link)
  endif()
endfunction()

# A program of src/apps or tests/benchmarks linking `DEPS`.
function(mlmap_program name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS})
  mlmap_target_defaults(${name})
endfunction()
