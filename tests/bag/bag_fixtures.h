#pragma once
/// @file
/// The test bags written by tests/bag/fixtures (make_bags.mjs with @mcap/core and
/// @foxglove/rosmsg2-serialization, make_db3.py with Python's sqlite3) into the build tree by
/// the ctest fixture mlmap_bag_fixtures, and what they hold (expected.json).

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace mlmap::bag::testing {

/// The folder of the generated bags.
inline std::string fixture(const std::string& name) {
  return (std::filesystem::path(MLMAP_BAG_FIXTURES_DIR) / name).string();
}

/// expected.json: what the generator wrote.
inline const nlohmann::json& expected() {
  static const nlohmann::json json = [] {
    std::ifstream in(fixture("expected.json"));
    if (!in) throw std::runtime_error("no " + fixture("expected.json") + ": run the fixture first");
    return nlohmann::json::parse(in);
  }();
  return json;
}

/// A copy of `bytes` of `name` (or the whole file) at `path`, for the bad-bag tests.
inline std::vector<std::uint8_t> readAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Writes `bytes` to `path`.
inline void writeAll(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

}  // namespace mlmap::bag::testing
