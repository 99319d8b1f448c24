/// @file
/// The driver of the fuzz targets when they are not built with libFuzzer (gcc, or MLMAP_FUZZ=OFF):
/// runs LLVMFuzzerTestOneInput once on every file given, and on every file of every directory
/// given (sorted by name), so the seed corpus and the regression inputs are a regression suite in
/// every build. Exits non-zero when a path cannot be read; a failing input aborts, as under
/// libFuzzer.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

namespace fs = std::filesystem;

bool readFile(const fs::path& path, std::string* bytes) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  bytes->assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  return !in.bad();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: " << argv[0] << " FILE_OR_DIR...\n"
              << "Runs the fuzz target once on each file (directories: every file in them).\n";
    return 2;
  }
  std::vector<fs::path> files;
  for (int i = 1; i < argc; ++i) {
    const fs::path arg = argv[i];
    std::error_code error;
    if (fs::is_directory(arg, error)) {
      std::vector<fs::path> in_dir;
      for (const fs::directory_entry& entry : fs::directory_iterator(arg, error)) {
        if (entry.is_regular_file(error)) in_dir.push_back(entry.path());
      }
      if (error) {
        std::cerr << arg.string() << ": cannot list the directory: " << error.message() << "\n";
        return 1;
      }
      std::sort(in_dir.begin(), in_dir.end());
      files.insert(files.end(), in_dir.begin(), in_dir.end());
    } else if (fs::is_regular_file(arg, error)) {
      files.push_back(arg);
    } else {
      std::cerr << arg.string() << ": no such file or directory\n";
      return 1;
    }
  }
  std::string bytes;
  for (const fs::path& file : files) {
    if (!readFile(file, &bytes)) {
      std::cerr << file.string() << ": cannot read\n";
      return 1;
    }
    // Run the input from a heap buffer of its exact size (never null, as under libFuzzer), so
    // that a read past its end is a sanitizer report.
    const std::unique_ptr<std::uint8_t[]> input(new std::uint8_t[bytes.size()]);
    std::copy(bytes.begin(), bytes.end(), input.get());
    std::cerr << "running " << file.string() << " (" << bytes.size() << " bytes)\n";
    LLVMFuzzerTestOneInput(input.get(), bytes.size());
  }
  std::cerr << "ran " << files.size() << " inputs\n";
  return 0;
}
