#pragma once
// A temporary folder of a test, made empty on construction and removed with the object.

#include <unistd.h>

#include <filesystem>
#include <string>

namespace mlmap::test {

/// `<temp>/<name>_<pid>_<n>`: unique per process and per object, so tests of one binary and
/// binaries running side by side never share one.
struct TempDir {
  std::filesystem::path path;

  explicit TempDir(const std::string& name) {
    static int made = 0;
    path = std::filesystem::temp_directory_path() /
           (name + "_" + std::to_string(::getpid()) + "_" + std::to_string(made++));
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
  }
  ~TempDir() { std::filesystem::remove_all(path); }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  /// The path of `name` inside the folder.
  [[nodiscard]] std::string file(const std::string& name) const { return (path / name).string(); }
};

}  // namespace mlmap::test
