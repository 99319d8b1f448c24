#include "mlmap/core/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <system_error>

namespace mlmap {
namespace {

std::string errnoText(const std::string& step, int err) {
  return step + ": " +
         std::generic_category().message(err);  // not strerror: clang-tidy concurrency-mt-unsafe
}

}  // namespace

void writeFileAtomically(const std::string& path, const std::string& bytes) {
  const std::filesystem::path target(path);
  const std::filesystem::path dir =
      target.has_parent_path() ? target.parent_path() : std::filesystem::path(".");
  std::string temp = path + ".tmp-XXXXXX";
  auto fail = [&path](const std::string& reason) {
    throw std::runtime_error("cannot write '" + path + "': " + reason);
  };
  const int fd = ::mkstemp(temp.data());
  if (fd < 0) fail(errnoText("cannot create a temporary file in '" + dir.string() + "'", errno));
  auto abandon = [&](const std::string& reason) {
    ::close(fd);
    ::unlink(temp.c_str());
    fail(reason);
  };
  if (::fchmod(fd, 0644) != 0) abandon(errnoText("chmod", errno));
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t k = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (k < 0) {
      if (errno == EINTR) continue;
      abandon(errnoText("write failed after " + std::to_string(done) + " of " +
                            std::to_string(bytes.size()) + " bytes",
                        errno));
    }
    done += static_cast<std::size_t>(k);
  }
  if (::fsync(fd) != 0) abandon(errnoText("flush to disk", errno));
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(temp.c_str());
    fail(errnoText("close", err));
  }
  if (::rename(temp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(temp.c_str());
    fail(errnoText("rename of the temporary file", err));
  }
  // Make the rename itself durable.
  const int dir_fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (dir_fd >= 0) {
    ::fsync(dir_fd);
    ::close(dir_fd);
  }
  (void)removeLeftoverTemporaries(path);
}

std::size_t removeLeftoverTemporaries(const std::string& path) {
  const std::filesystem::path target(path);
  const std::filesystem::path dir =
      target.has_parent_path() ? target.parent_path() : std::filesystem::path(".");
  const std::string prefix = target.filename().string() + ".tmp-";
  constexpr std::size_t kSuffixChars = 6;  // mkstemp's XXXXXX
  std::size_t removed = 0;
  std::error_code ec;
  for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::filesystem::directory_entry& entry = *it;
    std::error_code entry_ec;
    const std::string name = entry.path().filename().string();
    if (name.size() != prefix.size() + kSuffixChars ||
        name.compare(0, prefix.size(), prefix) != 0 ||
        !std::all_of(name.begin() + static_cast<std::ptrdiff_t>(prefix.size()), name.end(),
                     [](char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0; }) ||
        !entry.is_regular_file(entry_ec)) {
      continue;
    }
    if (std::filesystem::remove(entry.path(), entry_ec)) ++removed;
  }
  return removed;
}

}  // namespace mlmap
