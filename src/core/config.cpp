#include "mlmap/core/config.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace mlmap {
namespace {

constexpr double kPi = 3.14159265358979323846;

template <typename T>
void require(bool ok, const std::string& key, const std::string& what, const T& value,
             std::vector<std::string>* errors) {
  if (ok) return;
  std::ostringstream message;
  message << key << ": " << what << " (got " << value << ")";
  errors->push_back(message.str());
}

bool finitePositive(double v) { return std::isfinite(v) && v > 0.0; }

/// "section.key" of `field`, a member of section struct `section`, from its key list.
template <class Section, class T>
std::string sectionKey(const Section& section, const T& field) {
  return std::string(Section::kSection) + "." + keyPath(section, field);
}

}  // namespace

double AwarenessConfig::phi_cell_rad() const { return 2.0 * kPi / phi_cells; }

int AwarenessConfig::binsPerFaceSide(double resolution_m) const {
  // Cube-map face coordinates span [-1, 1]; a bin of width 2 / n subtends at most ~2 / n rad,
  // so it is about a voxel wide at n / 2 voxels away.
  const double range_voxels = max_range_m / resolution_m;
  int n = 2;
  while (n < kMaxBinsPerFaceSide && n < 2.0 * range_voxels / bin_width_voxels) n *= 2;
  return n;
}

void AwarenessConfig::validate(std::vector<std::string>* errors) const {
  require(finitePositive(rho_cell_m) && rho_cell_m <= 10.0, sectionKey(*this, rho_cell_m),
          "must be in (0, 10] m", rho_cell_m, errors);
  require(rho_cells >= 1 && rho_cells <= 4096, sectionKey(*this, rho_cells), "must be in [1, 4096]",
          rho_cells, errors);
  require(phi_cells >= 4 && phi_cells <= 4096, sectionKey(*this, phi_cells), "must be in [4, 4096]",
          phi_cells, errors);
  require(finitePositive(z_cell_m) && z_cell_m <= 10.0, sectionKey(*this, z_cell_m),
          "must be in (0, 10] m", z_cell_m, errors);
  require(z_cells >= 1 && z_cells <= 4096, sectionKey(*this, z_cells), "must be in [1, 4096]",
          z_cells, errors);
  require(z_cells_below >= 0 && z_cells_below <= z_cells, sectionKey(*this, z_cells_below),
          "must be in [0, z_cells]", z_cells_below, errors);
  require(std::isfinite(min_range_m) && min_range_m >= 0.0, sectionKey(*this, min_range_m),
          "must be >= 0 m", min_range_m, errors);
  require(finitePositive(max_range_m) && max_range_m > min_range_m, sectionKey(*this, max_range_m),
          "must be > min_range_m", max_range_m, errors);
  require(sample_count >= 0, sectionKey(*this, sample_count), "must be >= 0 (0 = all points)",
          sample_count, errors);
  require(num_threads >= 1 && num_threads <= kMaxThreads, sectionKey(*this, num_threads),
          "must be in [1, 64]", num_threads, errors);
  require(std::isfinite(bin_width_voxels) && bin_width_voxels >= 1.0 && bin_width_voxels <= 2.0,
          sectionKey(*this, bin_width_voxels), "must be in [1, 2] voxels", bin_width_voxels,
          errors);
}

void LogOddsConfig::validate(std::vector<std::string>* errors) const {
  require(std::isfinite(hit) && hit > 0.0 && hit <= 10.0, sectionKey(*this, hit),
          "must be in (0, 10]", hit, errors);
  require(std::isfinite(miss) && miss < 0.0 && miss >= -10.0, sectionKey(*this, miss),
          "must be in [-10, 0)", miss, errors);
  require(std::isfinite(clamp_min) && clamp_min < 0.0 && clamp_min >= -30.0,
          sectionKey(*this, clamp_min), "must be in [-30, 0)", clamp_min, errors);
  require(std::isfinite(clamp_max) && clamp_max > 0.0 && clamp_max <= 30.0,
          sectionKey(*this, clamp_max), "must be in (0, 30]", clamp_max, errors);
  require(std::isfinite(occupied_threshold) && occupied_threshold >= clamp_min &&
              occupied_threshold < clamp_max,
          sectionKey(*this, occupied_threshold), "must be in [clamp_min, clamp_max)",
          occupied_threshold, errors);
}

void LocalMapConfig::validate(std::vector<std::string>* errors) const {
  require(finitePositive(resolution_m) && resolution_m >= 0.01 && resolution_m <= 5.0,
          sectionKey(*this, resolution_m), "must be in [0.01, 5] m", resolution_m, errors);
  static const char* kAxis[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    const int n = size_cells[a];
    require(n >= kSubmapsPerAxis && n % kSubmapsPerAxis == 0 && n <= 2000,
            sectionKey(*this, size_cells) + "." + kAxis[a],
            "must be a multiple of 5 (5 submaps per axis) in [5, 2000]", n, errors);
  }
  const double cells = static_cast<double>(size_cells.x()) * size_cells.y() * size_cells.z();
  require(cells <= 2.0e8, sectionKey(*this, size_cells),
          "more than 2e8 voxels in the active area (each takes 2 bytes in the window and up to "
          "21 more in the planners' snapshots and ESDF: 4.7 GB at the limit)",
          cells, errors);
}

void SensorConfig::validate(std::vector<std::string>* errors) const {
  require(translation_B_m.allFinite() && translation_B_m.norm() <= 10.0,
          sectionKey(*this, translation_B_m), "must be finite and within 10 m of the body",
          translation_B_m.transpose(), errors);
  require(rotation_rpy_deg.allFinite(), sectionKey(*this, rotation_rpy_deg), "must be finite",
          rotation_rpy_deg.transpose(), errors);
}

Eigen::Isometry3d SensorConfig::T_B_S() const {
  const Eigen::Vector3d rad = rotation_rpy_deg * (kPi / 180.0);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(rad.z(), Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(rad.y(), Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(rad.x(), Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = translation_B_m;
  return T;
}

void PipelineConfig::validate(std::vector<std::string>* errors) const {
  require(input_queue_capacity >= 1 && input_queue_capacity <= 1000,
          sectionKey(*this, input_queue_capacity), "must be in [1, 1000]", input_queue_capacity,
          errors);
  require(batch_queue_capacity >= 1 && batch_queue_capacity <= 1000,
          sectionKey(*this, batch_queue_capacity), "must be in [1, 1000]", batch_queue_capacity,
          errors);
}

void ProjectedGridConfig::validate(std::vector<std::string>* errors) const {
  require(std::isfinite(band_min_m) && std::abs(band_min_m) <= 1000.0,
          sectionKey(*this, band_min_m), "must be a finite height within 1000 m", band_min_m,
          errors);
  require(std::isfinite(band_max_m) && std::abs(band_max_m) <= 1000.0,
          sectionKey(*this, band_max_m), "must be a finite height within 1000 m", band_max_m,
          errors);
  require(!(band_max_m < band_min_m), sectionKey(*this, band_max_m), "must not be below band_min_m",
          band_max_m, errors);
}

void throwIfInvalid(const std::vector<std::string>& errors, const std::string& what) {
  if (errors.empty()) return;
  std::ostringstream out;
  out << "invalid " << what << ":";
  for (const std::string& e : errors) out << "\n  " << e;
  throw std::invalid_argument(out.str());
}

const char* toString(UnknownAs policy) {
  switch (policy) {
    case UnknownAs::kOccupied:
      return "occupied";
    case UnknownAs::kFree:
      return "free";
  }
  return "invalid";
}

bool parseUnknownAs(const std::string& text, UnknownAs* policy) {
  for (const UnknownAs candidate : {UnknownAs::kOccupied, UnknownAs::kFree}) {
    if (text == toString(candidate)) {
      *policy = candidate;
      return true;
    }
  }
  return false;
}

const char* unknownAsChoices() { return "occupied or free"; }

void EsdfConfig::validate(std::vector<std::string>* errors) const {
  require(std::isfinite(max_distance_m) && max_distance_m > 0.0 && max_distance_m <= 1000.0,
          sectionKey(*this, max_distance_m), "must be finite, > 0 and <= 1000 m", max_distance_m,
          errors);
  require(unknown_as == UnknownAs::kOccupied || unknown_as == UnknownAs::kFree,
          sectionKey(*this, unknown_as), std::string("must be ") + unknownAsChoices(),
          static_cast<int>(unknown_as), errors);
  require(num_threads >= 1 && num_threads <= kMaxThreads, sectionKey(*this, num_threads),
          "must be in [1, 64]", num_threads, errors);
  require(std::isfinite(max_rate_hz) && max_rate_hz >= 0.0, sectionKey(*this, max_rate_hz),
          "must be finite and >= 0 (0: no limit)", max_rate_hz, errors);
  for (int a = 0; a < 3; ++a) {
    require(std::isfinite(box_size_m[a]) && box_size_m[a] >= 0.0 && box_size_m[a] <= 10000.0,
            sectionKey(*this, box_size_m),
            "must be finite, >= 0 and <= 10000 m per axis (0: whole local map)", box_size_m[a],
            errors);
  }
}

std::vector<std::string> MapConfig::validate() const {
  std::vector<std::string> errors;
  awareness.validate(&errors);
  log_odds.validate(&errors);
  local_map.validate(&errors);
  sensor.validate(&errors);
  pipeline.validate(&errors);
  projected_grid.validate(&errors);
  esdf.validate(&errors);
  if (errors.empty()) {
    // The awareness stage keeps one bit per voxel of a box around the sensor that reaches the
    // maximum range or the local map's farthest extent, whichever is nearer (and keys its voxels
    // with 31 bits).
    const double res = local_map.resolution_m;
    const double range_voxels = std::ceil(awareness.max_range_m / res) + 1.0;
    const double offset_voxels = std::ceil(sensor.translation_B_m.norm() / res) + 1.0;
    double box_voxels = 1.0;
    for (int a = 0; a < 3; ++a) {
      const int submap_cells = local_map.size_cells[a] / LocalMapConfig::kSubmapsPerAxis;  // exact
      const double submap = submap_cells;
      box_voxels *= 2.0 * std::min(range_voxels, 3.0 * submap + offset_voxels) + 1.0;
    }
    constexpr double kMaxScratchVoxels = 268435456.0;  // 2^28: a 32 MB bitset
    if (box_voxels > kMaxScratchVoxels) {
      std::ostringstream message;
      message << keyPath(*this, awareness.max_range_m) << " / "
              << keyPath(*this, local_map.resolution_m)
              << ": the free-space scratch box around the sensor would hold " << box_voxels
              << " voxels (limit 2^28); lower max_range_m, the resolution or the "
                 "local map size";
      errors.push_back(message.str());
    }
  }
  if (errors.empty() && awareness.max_range_m > awareness.radius_m() + 1e-9) {
    std::ostringstream message;
    message << keyPath(*this, awareness.max_range_m)
            << ": must not exceed the awareness radius rho_cells * rho_cell_m = "
            << awareness.radius_m() << " m (got " << awareness.max_range_m << ")";
    errors.push_back(message.str());
  }
  return errors;
}

namespace {

/// The free-space scratch box of the awareness stage [voxels] (MapConfig::validate()).
double scratchBoxVoxels(const MapConfig& c) {
  const double res = c.local_map.resolution_m;
  const double range_voxels = std::ceil(c.awareness.max_range_m / res) + 1.0;
  const double offset_voxels = std::ceil(c.sensor.translation_B_m.norm() / res) + 1.0;
  double box_voxels = 1.0;
  for (int a = 0; a < 3; ++a) {
    const int submap = c.local_map.size_cells[a] / LocalMapConfig::kSubmapsPerAxis;  // exact
    box_voxels *= 2.0 * std::min(range_voxels, 3.0 * submap + offset_voxels) + 1.0;
  }
  return box_voxels;
}

std::string megabytes(std::size_t bytes) {
  std::ostringstream m;
  m.precision(bytes >= 1000000000 ? 2 : 3);
  if (bytes >= 1000000000) {
    m << static_cast<double>(bytes) / 1e9 << " GB";
  } else {
    m << static_cast<double>(bytes) / 1e6 << " MB";
  }
  return m.str();
}

}  // namespace

MemoryEstimate estimateMemory(const MapConfig& c) {
  // Bytes per voxel, read off the engine's accounting (docs/performance.md, "Memory").
  constexpr double kLocalPerVoxel = 2.05;      // int16 log-odds plus per-submap bookkeeping
  constexpr double kSnapshotPerVoxel = 4.0;    // two int16 window copies
  constexpr double kEsdfPerBoxVoxel = 20.6;    // field, passes 1-2 (8 + 16 bits with the
                                               // windowed passes), kept states; 2 copies
  constexpr double kAwarenessCellBytes = 9.0;  // per cylindrical cell: state, bins, scratch
  MemoryEstimate e;
  const Eigen::Vector3i& n = c.local_map.size_cells;
  const double window = static_cast<double>(n.x()) * n.y() * n.z();
  e.local_bytes = static_cast<std::size_t>(window * kLocalPerVoxel);
  e.snapshot_bytes = static_cast<std::size_t>(window * kSnapshotPerVoxel);
  if (c.esdf.enabled) {
    double box = 1.0;
    for (int a = 0; a < 3; ++a) {
      const double edge_m = c.esdf.box_size_m[a];
      const double cells_on_axis = std::max(1.0, std::round(edge_m / c.local_map.resolution_m));
      box *= edge_m > 0.0 ? std::min<double>(n[a], cells_on_axis) : n[a];
    }
    e.esdf_bytes = static_cast<std::size_t>(box * kEsdfPerBoxVoxel);
  }
  const double cells =
      static_cast<double>(c.awareness.rho_cells) * c.awareness.phi_cells * c.awareness.z_cells;
  // The frame's ends, direction bins and cones grow with what it sees, not with the settings.
  e.awareness_bytes =
      static_cast<std::size_t>(cells * kAwarenessCellBytes + scratchBoxVoxels(c) / 8.0);
  return e;
}

std::string describeMemory(const MemoryEstimate& e) {
  return megabytes(e.total()) + " (local map " + megabytes(e.local_bytes) + ", snapshots " +
         megabytes(e.snapshot_bytes) + ", ESDF " + megabytes(e.esdf_bytes) + ", awareness " +
         megabytes(e.awareness_bytes) + ")";
}

}  // namespace mlmap
