/// @file
/// Fuzz target: MCAP files (mlmap/bag/mcap.h) and the bag on top of them. The input is written to
/// a scratch file (the reader reads files, with pread), then read three ways: every record by
/// scanRecords(), every message through McapReader (summary and indexes, or the linear scan),
/// and the frames of a BagFrameSource with its inputs chosen by autoSelect(). Errors are
/// std::runtime_error; the reader must not crash, hang or allocate more than its limits.

#include "fuzz_support.h"

#include "mlmap/bag/bag_frame_source.h"
#include "mlmap/bag/bag_reader.h"
#include "mlmap/bag/mcap.h"

#include <unistd.h>

#include <cstdio>
#include <stdexcept>
#include <string>

namespace {

/// This process's scratch file.
const std::string& scratchPath() {
  static const std::string path = "/tmp/mlmap_fuzz_mcap_" + std::to_string(::getpid()) + ".mcap";
  return path;
}

void readAllWays(const std::string& path) {
  namespace mcap = mlmap::bag::mcap;
  try {
    std::size_t messages = 0;
    (void)mcap::scanRecords(
        path, [&](const mcap::Record& r) { messages += std::holds_alternative<mcap::Message>(r); });
  } catch (const std::runtime_error&) {
  }
  try {
    const mcap::McapReader reader(path);
    for (std::size_t i = 0; i < reader.messages().size(); ++i) {
      const mcap::Message m = reader.read(i);
      mlmap::fuzz::requireThat(m.log_time_ns == reader.messages()[i].log_time_ns,
                               "McapReader: a message's log time differs from its index entry");
    }
  } catch (const std::runtime_error&) {
  }
  try {
    const mlmap::bag::BagFrameSource source(mlmap::bag::openMcapBag(path),
                                            mlmap::bag::BagFrameSourceOptions{});
    for (std::size_t i = 0; i < source.size(); ++i) (void)source.read(i);
  } catch (const std::runtime_error&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::FILE* file = std::fopen(scratchPath().c_str(), "wb");
  mlmap::fuzz::requireThat(file != nullptr, "cannot write the scratch file");
  const bool written = std::fwrite(data, 1, size, file) == size;
  std::fclose(file);
  mlmap::fuzz::requireThat(written, "cannot write the scratch file");
  readAllWays(scratchPath());
  std::remove(scratchPath().c_str());
  return 0;
}
