#pragma once
/// @file
/// mlmap's own map file: the full state of a map (MapState: global layer, local window with every
/// voxel's log-odds, last stamp and pose), so that mapping goes on exactly where it stopped.
///
/// Layout (version 1, little endian; see docs/map-files.md):
///
/// | bytes | content |
/// |---|---|
/// | 208 | header: magic `MLMAPMAP`, format version, header size, file size, config fingerprint,
/// the fingerprinted fields (resolution, window size, log-odds model), last stamp and body pose,
/// frames mapped, window position, section sizes, CRC-32 of the header | | 8 per run + 2 per
/// observed voxel + 4 | local window in box order (x-major, z fastest) as runs: uint32 count of
/// unknown voxels, uint32 count of observed voxels, their int16 log-odds in units of 0.001; CRC-32
/// | | 16 per submap + 6 per voxel + 4 | global map: per submap its index (3 x int32), voxel count,
/// then (uint32 offset, int16 log-odds) per voxel; CRC-32 | | 8 | trailer `MLMAPEND` |
///
/// A file is refused, with a message naming it and what is wrong, when it is not an mlmap map
/// (magic), has another format version, is shorter or longer than its header says, fails a
/// checksum, holds inconsistent data, or (checkMapMatchesConfig) was made with a configuration
/// whose fingerprinted fields differ.

#include "mlmap/core/atomic_file.h"
#include "mlmap/core/config.h"
#include "mlmap/local/map_state.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace mlmap::io {

/// The format version this build writes and reads.
inline constexpr std::uint32_t kMapFileVersion = 1;

/// FNV-1a 64 hash of the fields that give the stored data its meaning: voxel size, window size
/// (and so the submap size) and the log-odds model (hit, miss, clamping bounds, threshold).
[[nodiscard]] std::uint64_t mapConfigFingerprint(const LocalMapConfig& local_map,
                                                 const LogOddsConfig& log_odds);

/// CRC-32 (IEEE 802.3, the one of zlib and PNG) of `n` bytes: the checksum of the header and of
/// each section of a map file.
[[nodiscard]] std::uint32_t crc32(const char* data, std::size_t n);

/// The file's bytes for `state`. The same state always gives the same bytes.
[[nodiscard]] std::string encodeMapFile(const MapState& state);
/// Parses a map file's bytes. Throws std::runtime_error "<source_name>: <what is wrong>".
[[nodiscard]] MapState decodeMapFile(const std::string& bytes, const std::string& source_name);

/// Writes `state` to `path` safely: into a temporary file in the same folder, flushed to disk,
/// then renamed over `path`. When anything fails (folder missing or read-only, disk full) the
/// temporary file is removed, `path` keeps its previous content, and std::runtime_error names
/// the path and the reason.
void saveMapFile(const MapState& state, const std::string& path);
/// Largest map file loadMapFile() reads [bytes] (8 GiB: some 800 million occupied voxels).
inline constexpr std::uintmax_t kMaxMapFileBytes = std::uintmax_t{8} << 30;

/// Reads and decodes a map file. Only a regular file within kMaxMapFileBytes is read, and only
/// past a header that checks out and announces the file's exact size. Throws std::runtime_error
/// naming the path (missing, a directory or device, too large, corrupted, truncated).
[[nodiscard]] MapState loadMapFile(const std::string& path);

/// Throws std::runtime_error "<source_name>: made with a different configuration: ..." listing
/// every fingerprinted field whose value differs between the map and `config`.
void checkMapMatchesConfig(const MapState& state, const MapConfig& config,
                           const std::string& source_name);

/// True when `path` is an existing file that starts like an mlmap map file ("MLMAPMAP").
[[nodiscard]] bool isMapFile(const std::string& path);

/// Why a program must not write `output`, or "" when it may: `output` exists and is one of
/// `inputs` (the same file under any spelling of its path) or lies inside an input that is a
/// folder, or it is an existing mlmap map file while `overwrite_maps` is false (the message then
/// names `overwrite_flag`, the option that allows it). A path that does not exist yet never
/// conflicts. Every program checks its outputs with it before writing anything.
[[nodiscard]] std::string outputConflict(const std::string& output,
                                         const std::vector<std::string>& inputs,
                                         bool overwrite_maps, const std::string& overwrite_flag);

}  // namespace mlmap::io
