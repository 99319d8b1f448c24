#include "mlmap/map_io/map_file.h"

#include "mlmap/core/atomic_file.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <system_error>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace mlmap::io {
namespace {

constexpr char kMagic[8] = {'M', 'L', 'M', 'A', 'P', 'M', 'A', 'P'};
constexpr char kTrailer[8] = {'M', 'L', 'M', 'A', 'P', 'E', 'N', 'D'};
constexpr std::size_t kHeaderBytes = 208;
constexpr std::size_t kSubmapHeadBytes = 16;  // 3 x int32 index + uint32 count
constexpr std::size_t kRecordBytes = 6;       // uint32 offset + int16 log-odds

// Little-endian writer.
class Writer {
 public:
  explicit Writer(std::string* out) : out_(out) {}
  void bytes(const char* p, std::size_t n) { out_->append(p, n); }
  template <typename T>
  void integer(T v) {
    using U = std::make_unsigned_t<T>;
    const U u = static_cast<U>(v);
    for (std::size_t i = 0; i < sizeof(T); ++i)
      out_->push_back(static_cast<char>((u >> (8 * i)) & 0xFFu));
  }
  void real(double v) {
    std::uint64_t u = 0;
    std::memcpy(&u, &v, sizeof u);
    integer(u);
  }
  [[nodiscard]] std::size_t size() const { return out_->size(); }
  void crcFrom(std::size_t start) { integer(crc32(out_->data() + start, out_->size() - start)); }

 private:
  std::string* out_;
};

// Little-endian reader over a checked range (the caller checks sizes first).
class Reader {
 public:
  Reader(const std::string& data, std::size_t pos) : data_(data), pos_(pos) {}
  template <typename T>
  T integer() {
    using U = std::make_unsigned_t<T>;
    U u = 0;
    for (std::size_t i = 0; i < sizeof(T); ++i) {
      u = static_cast<U>(u |
                         (static_cast<U>(static_cast<std::uint8_t>(data_[pos_ + i])) << (8 * i)));
    }
    pos_ += sizeof(T);
    return static_cast<T>(u);
  }
  double real() {
    const std::uint64_t u = integer<std::uint64_t>();
    double v = 0.0;
    std::memcpy(&v, &u, sizeof v);
    return v;
  }
  [[nodiscard]] std::size_t pos() const { return pos_; }

 private:
  const std::string& data_;
  std::size_t pos_;
};

void writeFingerprintFields(Writer& w, const LocalMapConfig& local_map, const LogOddsConfig& lo) {
  w.real(local_map.resolution_m);
  for (int a = 0; a < 3; ++a) w.integer<std::int32_t>(local_map.size_cells[a]);
  for (double v : {lo.hit, lo.miss, lo.clamp_min, lo.clamp_max, lo.occupied_threshold}) w.real(v);
}

[[noreturn]] void refuse(const std::string& source, const std::string& what) {
  throw std::runtime_error(source + ": " + what);
}

std::string errnoText(const std::string& step, int err) {
  return step + ": " +
         std::generic_category().message(err);  // not strerror: clang-tidy concurrency-mt-unsafe
}

}  // namespace

std::uint32_t crc32(const char* data, std::size_t n) {
  static const std::array<std::uint32_t, 256> table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1u) != 0 ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  std::uint32_t c = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < n; ++i) {
    c = table[(c ^ static_cast<std::uint8_t>(data[i])) & 0xFFu] ^ (c >> 8);
  }
  return c ^ 0xFFFFFFFFu;
}

std::uint64_t mapConfigFingerprint(const LocalMapConfig& local_map, const LogOddsConfig& log_odds) {
  std::string bytes;
  Writer w(&bytes);
  writeFingerprintFields(w, local_map, log_odds);
  std::uint64_t h = 1469598103934665603ull;  // FNV-1a 64
  for (char c : bytes) {
    h ^= static_cast<std::uint8_t>(c);
    h *= 1099511628211ull;
  }
  return h;
}

std::string encodeMapFile(const MapState& state) {
  const std::size_t voxels = static_cast<std::size_t>(state.window.size.prod());
  if (state.window.log_odds.size() != voxels) {
    throw std::invalid_argument("map state: window holds " +
                                std::to_string(state.window.log_odds.size()) + " values for " +
                                std::to_string(voxels) + " voxels");
  }
  const std::size_t global_voxels = state.globalVoxelCount();
  // The window as runs: (unknown count, known count, the known values), so that never-observed
  // space costs 8 bytes per run instead of 2 per voxel.
  std::string runs;
  Writer rw(&runs);
  const std::vector<LogOddsQ>& values = state.window.log_odds;
  for (std::size_t i = 0; i < voxels;) {
    std::size_t unknown = 0;
    while (i + unknown < voxels && values[i + unknown] == kUnknownLogOdds) ++unknown;
    std::size_t known = 0;
    while (i + unknown + known < voxels && values[i + unknown + known] != kUnknownLogOdds) ++known;
    rw.integer<std::uint32_t>(static_cast<std::uint32_t>(unknown));
    rw.integer<std::uint32_t>(static_cast<std::uint32_t>(known));
    for (std::size_t k = 0; k < known; ++k) rw.integer<std::int16_t>(values[i + unknown + k]);
    i += unknown + known;
  }
  const std::size_t local_bytes = runs.size() + 4;
  const std::size_t global_bytes =
      state.global_submaps.size() * kSubmapHeadBytes + global_voxels * kRecordBytes + 4;
  const std::size_t total = kHeaderBytes + local_bytes + global_bytes + sizeof kTrailer;

  std::string out;
  out.reserve(total);
  Writer w(&out);
  w.bytes(kMagic, sizeof kMagic);
  w.integer<std::uint32_t>(kMapFileVersion);
  w.integer<std::uint32_t>(kHeaderBytes);
  w.integer<std::uint64_t>(total);
  w.integer<std::uint64_t>(mapConfigFingerprint(state.local_map, state.log_odds));
  writeFingerprintFields(w, state.local_map, state.log_odds);
  w.integer<std::uint8_t>(state.has_last_stamp ? 1 : 0);
  w.integer<std::uint8_t>(voxels > 0 ? 1 : 0);
  w.integer<std::uint16_t>(0);  // reserved
  w.real(state.last_stamp_s);
  const Eigen::Vector3d t = state.T_W_B.translation();
  const Eigen::Quaterniond q(state.T_W_B.rotation());
  for (double v : {t.x(), t.y(), t.z(), q.w(), q.x(), q.y(), q.z()}) w.real(v);
  w.integer<std::uint64_t>(state.frames_mapped);
  for (int a = 0; a < 3; ++a) w.integer<std::int32_t>(state.window.min_index[a]);
  w.integer<std::uint64_t>(local_bytes);
  w.integer<std::uint64_t>(state.global_submaps.size());
  w.integer<std::uint64_t>(global_voxels);
  w.crcFrom(0);

  const std::size_t local_start = w.size();
  w.bytes(runs.data(), runs.size());
  w.crcFrom(local_start);

  const std::size_t global_start = w.size();
  for (const auto& [m, records] : state.global_submaps) {
    for (int a = 0; a < 3; ++a) w.integer<std::int32_t>(m[a]);
    w.integer<std::uint32_t>(static_cast<std::uint32_t>(records.size()));
    for (const VoxelRecord& r : records) {
      w.integer<std::uint32_t>(r.offset);
      w.integer<std::int16_t>(r.log_odds);
    }
  }
  w.crcFrom(global_start);
  w.bytes(kTrailer, sizeof kTrailer);
  return out;
}

namespace {

/// What the header says beyond the MapState fields it fills.
struct MapFileLayout {
  std::uint64_t total = 0;  ///< file size
  bool placed = false;      ///< the local window has a place (and voxels)
  VoxelIndex min_index = VoxelIndex::Zero();
  std::uint64_t local_bytes = 0;  ///< local section, its checksum included
  std::uint64_t submaps = 0;
  std::uint64_t global_voxels = 0;
  // Where the sections lie (checkSections()).
  std::size_t local_start = 0;
  std::size_t local_data = 0;  ///< local section without its checksum
  std::size_t global_start = 0;
  std::size_t window_voxels = 0;
};

/// Magic, version, header size and checksum, and the size the header announces against the
/// file's, `file_bytes`; `bytes` holds the file from its start, at least its header when the file
/// has one. Leaves `r` after the announced size.
std::uint64_t checkEnvelope(const std::string& bytes, std::uint64_t file_bytes,
                            const std::string& source, Reader* r) {
  const std::uint64_t n = file_bytes;
  const std::size_t magic_checked = std::min(bytes.size(), sizeof kMagic);
  if (n < 16 || std::memcmp(bytes.data(), kMagic, magic_checked) != 0) {
    if (n > 0 && std::memcmp(bytes.data(), kMagic, magic_checked) == 0) {
      refuse(source, "truncated: " + std::to_string(n) + " bytes, not even a complete header");
    }
    refuse(source, "not an mlmap map file (it does not start with \"MLMAPMAP\"; " +
                       std::to_string(n) + " bytes)");
  }
  const auto version = r->integer<std::uint32_t>();
  if (version != kMapFileVersion) {
    refuse(source, "map file format version " + std::to_string(version) +
                       ", this build reads version " + std::to_string(kMapFileVersion));
  }
  const auto header_bytes = r->integer<std::uint32_t>();
  // cppcheck-suppress knownConditionTrueFalse ; refuse() throws, cppcheck misses it
  if (header_bytes != kHeaderBytes) {
    refuse(source, "corrupted header: header size " + std::to_string(header_bytes) +
                       ", version 1 headers have " + std::to_string(kHeaderBytes));
  }
  if (n < kHeaderBytes) {
    refuse(source, "truncated: " + std::to_string(n) + " bytes, the header alone has " +
                       std::to_string(kHeaderBytes));
  }
  const std::uint32_t header_crc = crc32(bytes.data(), kHeaderBytes - 4);
  if (Reader(bytes, kHeaderBytes - 4).integer<std::uint32_t>() != header_crc) {
    refuse(source, "header checksum mismatch: the file is corrupted");
  }
  const auto total = r->integer<std::uint64_t>();
  if (n < total) {
    refuse(source, "truncated: " + std::to_string(n) + " bytes of the " + std::to_string(total) +
                       " its header announces");
  }
  if (n > total) {
    refuse(source, std::to_string(n - total) + " bytes after the end of the map (" +
                       std::to_string(total) + " bytes announced)");
  }
  return total;
}

/// The configuration fields, checked against their fingerprint and validated.
void readConfiguration(const std::string& source, Reader* r, MapState* state) {
  const auto fingerprint = r->integer<std::uint64_t>();
  state->local_map.resolution_m = r->real();
  for (int a = 0; a < 3; ++a) state->local_map.size_cells[a] = r->integer<std::int32_t>();
  LogOddsConfig& lo = state->log_odds;
  for (double* v : {&lo.hit, &lo.miss, &lo.clamp_min, &lo.clamp_max, &lo.occupied_threshold}) {
    *v = r->real();
  }
  if (fingerprint != mapConfigFingerprint(state->local_map, lo)) {
    refuse(source, "corrupted header: the configuration fingerprint does not match its fields");
  }
  std::vector<std::string> config_errors;
  state->local_map.validate(&config_errors);
  lo.validate(&config_errors);
  if (!config_errors.empty())
    refuse(source, "invalid configuration in the header: " + config_errors[0]);
}

/// The rest of the header: stamp, pose, frame count, the window's place and the section sizes.
void readHeaderFields(const std::string& source, Reader* r, MapState* state,
                      MapFileLayout* layout) {
  state->has_last_stamp = r->integer<std::uint8_t>() != 0;
  layout->placed = r->integer<std::uint8_t>() != 0;
  (void)r->integer<std::uint16_t>();
  state->last_stamp_s = r->real();
  double pose[7];
  for (double& v : pose) v = r->real();
  const Eigen::Quaterniond q(pose[3], pose[4], pose[5], pose[6]);
  if (!makePose(Eigen::Vector3d(pose[0], pose[1], pose[2]), q, &state->T_W_B)) {
    refuse(source, "invalid body pose in the header");
  }
  state->frames_mapped = r->integer<std::uint64_t>();
  for (int a = 0; a < 3; ++a) layout->min_index[a] = r->integer<std::int32_t>();
  layout->local_bytes = r->integer<std::uint64_t>();
  layout->submaps = r->integer<std::uint64_t>();
  layout->global_voxels = r->integer<std::uint64_t>();
}

/// The section sizes against the window and the file size (before anything is allocated), the
/// sections' checksums and the end marker.
void checkSections(const std::string& bytes, const std::string& source, const MapState& state,
                   MapFileLayout* l) {
  l->window_voxels = l->placed ? static_cast<std::size_t>(state.local_map.size_cells.prod()) : 0;
  if (l->local_bytes < 4 || l->local_bytes > l->total || (l->placed && l->local_bytes < 12) ||
      l->local_bytes > l->window_voxels * (sizeof(LogOddsQ) + 8) + 4) {
    refuse(source, "local section of " + std::to_string(l->local_bytes) +
                       " bytes for a window of " + std::to_string(l->window_voxels) + " voxels");
  }
  const std::uint64_t rest = l->total - kHeaderBytes - l->local_bytes - sizeof kTrailer;
  if (l->total < kHeaderBytes + l->local_bytes + sizeof kTrailer ||
      l->submaps > rest / kSubmapHeadBytes || l->global_voxels > rest / kRecordBytes ||
      rest != l->submaps * kSubmapHeadBytes + l->global_voxels * kRecordBytes + 4) {
    refuse(source, "section sizes in the header do not add up to the file size");
  }
  l->local_start = kHeaderBytes;
  l->local_data = static_cast<std::size_t>(l->local_bytes) - 4;
  if (Reader(bytes, l->local_start + l->local_data).integer<std::uint32_t>() !=
      crc32(bytes.data() + l->local_start, l->local_data)) {
    refuse(source, "local map checksum mismatch: the file is corrupted");
  }
  l->global_start = l->local_start + static_cast<std::size_t>(l->local_bytes);
  const std::size_t global_data = static_cast<std::size_t>(rest) - 4;
  if (Reader(bytes, l->global_start + global_data).integer<std::uint32_t>() !=
      crc32(bytes.data() + l->global_start, global_data)) {
    refuse(source, "global map checksum mismatch: the file is corrupted");
  }
  if (std::memcmp(bytes.data() + bytes.size() - sizeof kTrailer, kTrailer, sizeof kTrailer) != 0) {
    refuse(source, "missing end marker \"MLMAPEND\": the file is corrupted");
  }
}

/// The local window from its runs of unknown and known voxels; they must cover it exactly.
void readLocalWindow(const std::string& bytes, const std::string& source, const MapFileLayout& l,
                     MapState* state) {
  state->window.resolution_m = state->local_map.resolution_m;
  state->window.model = LogOddsModel(state->log_odds);
  if (!l.placed) return;
  state->window.min_index = l.min_index;
  state->window.size = state->local_map.size_cells;
  state->window.log_odds.assign(l.window_voxels, kUnknownLogOdds);
  const std::size_t end = l.local_start + l.local_data;
  Reader lr(bytes, l.local_start);
  std::size_t filled = 0;
  while (lr.pos() + 8 <= end && filled < l.window_voxels) {
    const auto unknown = lr.integer<std::uint32_t>();
    const auto known = lr.integer<std::uint32_t>();
    if (unknown > l.window_voxels - filled || known > l.window_voxels - filled - unknown ||
        lr.pos() + known * sizeof(LogOddsQ) > end) {
      break;
    }
    filled += unknown;
    for (std::uint32_t k = 0; k < known; ++k)
      state->window.log_odds[filled++] = lr.integer<std::int16_t>();
  }
  if (filled != l.window_voxels || lr.pos() != end) {
    refuse(source, "local map: its runs do not cover the " + std::to_string(l.window_voxels) +
                       "-voxel window exactly");
  }
}

/// The global map's submaps; their voxels must add up to what the header announces.
void readGlobalSubmaps(const std::string& bytes, const std::string& source, const MapFileLayout& l,
                       MapState* state) {
  Reader gr(bytes, l.global_start);
  std::uint64_t voxels_read = 0;
  state->global_submaps.resize(static_cast<std::size_t>(l.submaps));
  for (auto& [m, records] : state->global_submaps) {
    for (int a = 0; a < 3; ++a) m[a] = gr.integer<std::int32_t>();
    const auto count = gr.integer<std::uint32_t>();
    if (count > l.global_voxels - voxels_read) {
      refuse(source, "global map: more voxels in the submaps than the header announces");
    }
    voxels_read += count;
    records.resize(count);
    for (VoxelRecord& rec : records) {
      rec.offset = gr.integer<std::uint32_t>();
      rec.log_odds = gr.integer<std::int16_t>();
    }
  }
  if (voxels_read != l.global_voxels) {
    refuse(source, "global map: " + std::to_string(voxels_read) +
                       " voxels in the submaps, the header announces " +
                       std::to_string(l.global_voxels));
  }
}

}  // namespace

MapState decodeMapFile(const std::string& bytes, const std::string& source) {
  Reader r(bytes, sizeof kMagic);
  MapFileLayout layout;
  layout.total = checkEnvelope(bytes, bytes.size(), source, &r);
  MapState state;
  readConfiguration(source, &r, &state);
  readHeaderFields(source, &r, &state, &layout);
  checkSections(bytes, source, state, &layout);
  readLocalWindow(bytes, source, layout, &state);
  readGlobalSubmaps(bytes, source, layout, &state);
  // Checksums prove the bytes are what was written, not that what was written is a map.
  const std::vector<std::string> problems = mapStateProblems(state);
  if (!problems.empty()) refuse(source, "inconsistent map: " + problems.front());
  return state;
}

void checkMapMatchesConfig(const MapState& state, const MapConfig& config,
                           const std::string& source) {
  const std::vector<std::string> differences = mapConfigDifferences(state, config);
  if (differences.empty()) return;
  std::ostringstream m;
  m << source << ": made with a different configuration (fingerprint " << std::hex
    << mapConfigFingerprint(state.local_map, state.log_odds) << ", the configuration's "
    << mapConfigFingerprint(config.local_map, config.log_odds) << std::dec << "):";
  for (const std::string& d : differences) m << "\n  " << d;
  throw std::runtime_error(m.str());
}

bool isMapFile(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return false;
  std::ifstream in(path, std::ios::binary);
  char magic[sizeof kMagic] = {};
  in.read(magic, sizeof magic);
  return in.gcount() == static_cast<std::streamsize>(sizeof magic) &&
         std::memcmp(magic, kMagic, sizeof magic) == 0;
}

namespace {

/// True when `path` names something inside the directory `folder` (any spelling of either).
bool isInside(const std::filesystem::path& path, const std::filesystem::path& folder) {
  std::error_code ec;
  const std::filesystem::path inner = std::filesystem::weakly_canonical(path, ec);
  if (ec) return false;
  const std::filesystem::path outer = std::filesystem::weakly_canonical(folder, ec);
  if (ec) return false;
  auto o = outer.begin();
  auto i = inner.begin();
  for (; o != outer.end() && !o->empty(); ++o, ++i) {
    if (i == inner.end() || *i != *o) return false;
  }
  return i != inner.end();
}

}  // namespace

std::string outputConflict(const std::string& output, const std::vector<std::string>& inputs,
                           bool overwrite_maps, const std::string& overwrite_flag) {
  std::error_code ec;
  if (!std::filesystem::exists(output, ec)) return "";
  for (const std::string& input : inputs) {
    if (input.empty()) continue;
    if (std::filesystem::equivalent(output, input, ec)) {
      return "'" + output + "' is an input of this run: writing it would destroy what is read";
    }
    if (std::filesystem::is_directory(input, ec) && isInside(output, input)) {
      return "'" + output + "' is inside the input folder '" + input +
             "' of this run: writing it could destroy what is read";
    }
  }
  if (!overwrite_maps && isMapFile(output)) {
    return "'" + output + "' is an existing mlmap map: give another path, or " + overwrite_flag +
           " to replace it";
  }
  return "";
}

void saveMapFile(const MapState& state, const std::string& path) {
  writeFileAtomically(path, encodeMapFile(state));
}

MapState loadMapFile(const std::string& path) {
  // What is read from outside is bounded before it is allocated: a regular file, within the
  // size limit, whose header (checked first) announces exactly the file's size.
  std::error_code ec;
  const std::filesystem::file_status status = std::filesystem::status(path, ec);
  if (ec) refuse(path, "cannot open the map file: " + ec.message());
  if (!std::filesystem::is_regular_file(status)) {
    refuse(path, std::filesystem::is_directory(status)
                     ? "is a directory, not a map file"
                     : "is not a regular file (a device, pipe or socket), not a map file");
  }
  const std::uintmax_t file_bytes = std::filesystem::file_size(path, ec);
  if (ec) refuse(path, "cannot read the map file's size: " + ec.message());
  if (file_bytes > kMaxMapFileBytes) {
    refuse(path, std::to_string(file_bytes) + " bytes: larger than the " +
                     std::to_string(kMaxMapFileBytes >> 30) + " GiB a map file may have");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) refuse(path, errnoText("cannot open the map file", errno));
  auto readInto = [&](std::string* bytes, std::size_t from, std::size_t to) {
    bytes->resize(to);
    in.read(bytes->data() + from, static_cast<std::streamsize>(to - from));
    if (static_cast<std::size_t>(in.gcount()) != to - from) {
      refuse(path, "read error after " +
                       std::to_string(from + static_cast<std::size_t>(in.gcount())) + " of " +
                       std::to_string(file_bytes) + " bytes (did the file change?)");
    }
  };
  std::string bytes;
  readInto(&bytes, 0, static_cast<std::size_t>(std::min<std::uintmax_t>(file_bytes, kHeaderBytes)));
  Reader header(bytes, sizeof kMagic);
  (void)checkEnvelope(bytes, file_bytes, path, &header);
  readInto(&bytes, bytes.size(), static_cast<std::size_t>(file_bytes));
  return decodeMapFile(bytes, path);
}

}  // namespace mlmap::io
