#pragma once
/// @file
/// Helpers shared by the fuzz targets (tests/fuzz/fuzz_*.cpp, docs/fuzzing.md).
///
/// A fuzz target may fail only by a sanitizer report or a crash. The code under test must answer
/// bad input with its documented error: each target catches exactly the documented exception
/// types, so any other exception escapes and aborts (libFuzzer reports it as a crash). Properties
/// the code documents (output sizes, round trips) are checked with requireThat(), which aborts.

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace mlmap::fuzz {

/// Aborts with `what` when `condition` is false: a documented property does not hold.
inline void requireThat(bool condition, const char* what) {
  if (!condition) {
    std::fprintf(stderr, "fuzz target: property violated: %s\n", what);
    std::abort();
  }
}

/// The input as a string (text parsers take std::string).
inline std::string asString(const std::uint8_t* data, std::size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

}  // namespace mlmap::fuzz
