/// @file
/// Fuzz target: mlmap's map file loader (io::decodeMapFile). Errors are std::runtime_error.
///
/// Checksums and the configuration fingerprint stop almost every mutation at the header, so the
/// input is decoded twice: as it is, and with the file size, fingerprint and the three CRC-32s
/// rewritten to match its content (the layout of include/mlmap/map_io/map_file.h), which lets the
/// fuzzer reach the sections. A map that decodes must encode to bytes that decode to the same map
/// (the body pose to rounding).

#include "fuzz_support.h"

#include "mlmap/map_io/map_export.h"
#include "mlmap/map_io/map_file.h"

#include <cstring>
#include <stdexcept>

namespace {

using mlmap::fuzz::requireThat;

// Offsets in the 208-byte version 1 header.
constexpr std::size_t kHeaderBytes = 208;
constexpr std::size_t kTotalAt = 16;
constexpr std::size_t kFingerprintAt = 24;
constexpr std::size_t kResolutionAt = 32;
constexpr std::size_t kLocalBytesAt = 180;
constexpr std::size_t kHeaderCrcAt = 204;
constexpr std::size_t kTrailerBytes = 8;

template <typename T>
T load(const std::string& b, std::size_t at) {
  T v;
  std::memcpy(&v, b.data() + at, sizeof v);  // little-endian host (x86-64, arm64)
  return v;
}
template <typename T>
void store(std::string* b, std::size_t at, T v) {
  std::memcpy(&(*b)[at], &v, sizeof v);
}

/// The input with its size, fingerprint and checksums made to match (when it has a header).
std::string withMatchingChecks(std::string b) {
  if (b.size() < kHeaderBytes + 4 + 4 + kTrailerBytes) return b;
  store<std::uint64_t>(&b, kTotalAt, b.size());
  mlmap::LocalMapConfig local_map;
  mlmap::LogOddsConfig lo;
  local_map.resolution_m = load<double>(b, kResolutionAt);
  for (int a = 0; a < 3; ++a)
    local_map.size_cells[a] = load<std::int32_t>(b, kResolutionAt + 8 + 4 * a);
  std::size_t at = kResolutionAt + 20;
  for (double* v : {&lo.hit, &lo.miss, &lo.clamp_min, &lo.clamp_max, &lo.occupied_threshold}) {
    *v = load<double>(b, at);
    at += 8;
  }
  store<std::uint64_t>(&b, kFingerprintAt, mlmap::io::mapConfigFingerprint(local_map, lo));
  const auto local_bytes = load<std::uint64_t>(b, kLocalBytesAt);
  const std::size_t room = b.size() - kHeaderBytes - kTrailerBytes - 4;  // global CRC at least
  if (local_bytes >= 4 && local_bytes <= room) {
    const std::size_t local_crc_at = kHeaderBytes + local_bytes - 4;
    store<std::uint32_t>(&b, local_crc_at,
                         mlmap::io::crc32(b.data() + kHeaderBytes, local_bytes - 4));
    const std::size_t global_start = kHeaderBytes + local_bytes;
    const std::size_t global_crc_at = b.size() - kTrailerBytes - 4;
    store<std::uint32_t>(&b, global_crc_at,
                         mlmap::io::crc32(b.data() + global_start, global_crc_at - global_start));
  }
  store<std::uint32_t>(&b, kHeaderCrcAt, mlmap::io::crc32(b.data(), kHeaderCrcAt));
  return b;
}

void decodeOne(const std::string& bytes) {
  mlmap::MapState state;
  try {
    state = mlmap::io::decodeMapFile(bytes, "fuzz.mlmap");
  } catch (const std::runtime_error&) {
    return;  // the documented answer to bad input
  }
  // A file the loader accepts already matches its checks: if the offsets above drifted from
  // src/map_io/map_file.cpp, patching would change it (and the fuzzer would stop passing the
  // header).
  requireThat(withMatchingChecks(bytes) == bytes,
              "withMatchingChecks() is out of date with src/map_io/map_file.cpp");
  const std::string encoded = mlmap::io::encodeMapFile(state);
  mlmap::MapState again = mlmap::io::decodeMapFile(encoded, "encoded.mlmap");
  // The pose is stored as a quaternion and held as a rotation matrix: matrix -> quaternion ->
  // matrix is exact only to rounding (a few ulp), so the pose is compared with a tolerance and
  // everything else bit for bit.
  requireThat(again.T_W_B.isApprox(state.T_W_B, 1e-12), "decode(encode(map)) moved the body pose");
  again.T_W_B = state.T_W_B;
  requireThat(mlmap::io::encodeMapFile(again) == encoded,
              "decode(encode(map)) is not the same map");
  (void)mlmap::io::occupiedVoxels(state);
  try {
    (void)mlmap::io::projectMap(state, mlmap::ProjectedGridConfig{});  // the band around the body
  } catch (const std::runtime_error&) {
    // a grid too large to make (submaps far apart) is refused, by design
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes = mlmap::fuzz::asString(data, size);
  decodeOne(bytes);
  const std::string fixed = withMatchingChecks(bytes);
  if (fixed != bytes) decodeOne(fixed);
  return 0;
}
