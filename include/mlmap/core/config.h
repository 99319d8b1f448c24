#pragma once
/// @file
/// Typed configuration of the mapping engine. Every default is the paper's configuration
/// (performance run of Section VI-F and Table 1/2); `validate()` explains every bad value.
/// The YAML loader (mlmap/config/config_yaml.h) fills these structs; the core never parses files.
///
/// Every struct lists its keys once, in `visit(self, visitor)`: name, field, unit and meaning of
/// each key (the default is the field's initialiser). Reading and writing YAML, the commented
/// default file config/mlmap.yaml and the key reference in docs/configuration.md all walk that
/// list (mlmap/config/config_keys.h). A visitor has
///   `void key(const char* name, T& field, const char* unit, const char* doc)` and
///   `void section(const char* name, S& sub, const char* doc)` (S: another config struct);
/// `self` is the struct or a const one, and T / S are then const too (mlmap/core/key_list.h).

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "mlmap/core/key_list.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace mlmap {

/// Cylindrical awareness grid around the body (paper IV-A). Axes are parallel to the world
/// frame; the origin is the body position. Default: 100 x 180 x 25 cells (rho x phi x z).
/// Keys: visit().
struct AwarenessConfig {
  /// Its top-level section in the YAML file (MapConfig::visit()).
  static constexpr const char* kSection = "awareness";
  double rho_cell_m = 0.1;        ///< key rho_cell_m
  int rho_cells = 100;            ///< key rho_cells
  int phi_cells = 180;            ///< key phi_cells
  double z_cell_m = 0.2;          ///< key z_cell_m
  int z_cells = 25;               ///< key z_cells
  int z_cells_below = 13;         ///< key z_cells_below
  double min_range_m = 0.1;       ///< key min_range_m
  double max_range_m = 10.0;      ///< key max_range_m
  int sample_count = 0;           ///< key sample_count (the paper's SAMPLE_CNT)
  std::uint32_t sample_seed = 1;  ///< key sample_seed
  int num_threads = 1;            ///< key num_threads
  double bin_width_voxels = 1.0;  ///< key bin_width_voxels

  /// The keys of the `awareness` section (see the file comment).
  template <class Self, class V>
  static void visit(Self& c, V& v) {
    v.key("rho_cell_m", c.rho_cell_m, "m", "radial cell size");
    v.key("rho_cells", c.rho_cells, "", "radial cells: radius = rho_cells x rho_cell_m (10 m)");
    v.key("phi_cells", c.phi_cells, "", "azimuth sectors over 360 deg (2 deg each)");
    v.key("z_cell_m", c.z_cell_m, "m", "vertical cell size");
    v.key("z_cells", c.z_cells, "", "vertical cells (5 m)");
    v.key("z_cells_below", c.z_cells_below, "",
          "how many of them lie below the body (2.6 m below, 2.4 m above)");
    v.key("min_range_m", c.min_range_m, "m", "points closer to the sensor are dropped and counted");
    v.key("max_range_m", c.max_range_m, "m",
          "farther points clear their ray up to here and are no hit; <= the radius");
    v.key("sample_count", c.sample_count, "",
          "0: every valid point counts; N: N random points per frame (paper: 500)");
    v.key("sample_seed", c.sample_seed, "", "seed of that random choice");
    v.key("num_threads", c.num_threads, "",
          "threads carving a frame's free space, the caller's included (the same map with any)");
    v.key("bin_width_voxels", c.bin_width_voxels, "",
          "rays share a cone until their direction bin is this wide, in [1, 2]: 1 carves "
          "closer to the rays (full surfaces, as OctoMap's), 2 costs less carving");
  }

  /// The most direction bins per cube-map face side of the carving's finest level.
  static constexpr int kMaxBinsPerFaceSide = 256;
  /// Direction bins per cube-map face side of the carving's finest level (AwarenessStage): the
  /// power of two whose bins are about bin_width_voxels wide at the range, at most
  /// kMaxBinsPerFaceSide; coarser levels halve it down to 1.
  [[nodiscard]] int binsPerFaceSide(double resolution_m) const;

  /// Upper bound of num_threads.
  static constexpr int kMaxThreads = 64;

  [[nodiscard]] double radius_m() const { return rho_cells * rho_cell_m; }
  [[nodiscard]] double phi_cell_rad() const;
  void validate(std::vector<std::string>* errors) const;
};

/// Log-odds sensor model (paper Eq. 7-9, Table 1). Natural logarithm throughout:
/// logit(p) = ln(p / (1 - p)). Defaults: high-precision sensor of Table 1 (hit 0.85 = P 0.7,
/// miss -0.4 = P 0.4), clamping as OctoMap ([-2, 3.5] = P 0.12..0.97), occupied above 0 (P 0.5).
/// Keys: visit().
struct LogOddsConfig {
  /// Its top-level section in the YAML file (MapConfig::visit()).
  static constexpr const char* kSection = "log_odds";
  double hit = 0.85;                ///< key hit
  double miss = -0.4;               ///< key miss
  double clamp_min = -2.0;          ///< key clamp_min
  double clamp_max = 3.5;           ///< key clamp_max
  double occupied_threshold = 0.0;  ///< key occupied_threshold

  /// The keys of the `log_odds` section (see the file comment).
  template <class Self, class V>
  static void visit(Self& c, V& v) {
    v.key("hit", c.hit, "",
          "added on an occupied measurement (P 0.70: high-precision sensor; depth camera: 0.6)");
    v.key("miss", c.miss, "", "added on a free measurement (P 0.40)");
    v.key("clamp_min", c.clamp_min, "", "saturation (Eq. 9), P 0.12");
    v.key("clamp_max", c.clamp_max, "", "saturation, P 0.97: 9 misses turn a saturated voxel free");
    v.key("occupied_threshold", c.occupied_threshold, "",
          "occupied when log-odds > this (P 0.5); observed and <= this: free");
  }

  void validate(std::vector<std::string>* errors) const;
};

/// Sliding local map (paper IV-B, IV-C): a dense grid cut into 5 x 5 x 5 submaps.
/// Default: paper Table 2, 0.2 m voxels, 95 x 95 x 35 cells = 19 x 19 x 7 m.
/// Keys: visit().
struct LocalMapConfig {
  /// Its top-level section in the YAML file (MapConfig::visit()).
  static constexpr const char* kSection = "local_map";
  double resolution_m = 0.2;               ///< key resolution_m
  Eigen::Vector3i size_cells{95, 95, 35};  ///< key size_cells (multiples of kSubmapsPerAxis)

  /// The keys of the `local_map` section (see the file comment).
  template <class Self, class V>
  static void visit(Self& c, V& v) {
    v.key("resolution_m", c.resolution_m, "m", "voxel edge");
    v.key("size_cells", c.size_cells, "",
          "voxels in x, y, z (19 x 19 x 7 m); each a multiple of 5 (5 x 5 x 5 submaps)");
  }

  static constexpr int kSubmapsPerAxis = 5;
  [[nodiscard]] Eigen::Vector3i submap_cells() const { return size_cells / kSubmapsPerAxis; }
  /// How far from the body [m] the window holds every hit horizontally, wherever the body is in
  /// the centre submap it is re-centred on: the 2 submaps beyond it on the narrower axis (the
  /// body may sit at the centre submap's edge).
  [[nodiscard]] double horizontalReach_m() const {
    return 0.4 * std::min(size_cells.x(), size_cells.y()) * resolution_m;
  }
  /// The voxels per horizontal axis (a multiple of 5) whose reach holds `range_m`: 2.5 x the
  /// range across.
  [[nodiscard]] int horizontalCellsForRange(double range_m) const {
    return static_cast<int>(std::ceil(range_m / (2.0 * resolution_m) - 1e-9)) * kSubmapsPerAxis;
  }
  void validate(std::vector<std::string>* errors) const;
};

/// Where the sensor sits on the body: T_B_S. Default: a forward-looking camera in optical
/// convention (z forward, x right, y down) on a FLU body, 0.1 m ahead of the body origin.
/// Keys: visit().
struct SensorConfig {
  /// Its top-level section in the YAML file (MapConfig::visit()).
  static constexpr const char* kSection = "sensor";
  Eigen::Vector3d translation_B_m{0.1, 0.0, 0.0};       ///< key translation_B_m
  Eigen::Vector3d rotation_rpy_deg{-90.0, 0.0, -90.0};  ///< key rotation_rpy_deg

  /// The keys of the `sensor` section (see the file comment).
  template <class Self, class V>
  static void visit(Self& c, V& v) {
    v.key("translation_B_m", c.translation_B_m, "m", "sensor origin in the body frame (FLU)");
    v.key("rotation_rpy_deg", c.rotation_rpy_deg, "deg",
          "roll, pitch, yaw of the sensor frame in the body frame (Z-Y-X); this one:\n"
          "the optical frame (z forward, x right, y down) of a forward camera");
  }

  void validate(std::vector<std::string>* errors) const;
  /// T_B_S built from the translation and roll-pitch-yaw.
  [[nodiscard]] Eigen::Isometry3d T_B_S() const;
};

/// How the two stages run (paper V-A, Figure 5).
/// Keys: visit().
struct PipelineConfig {
  /// Its top-level section in the YAML file (MapConfig::visit()).
  static constexpr const char* kSection = "pipeline";
  bool threaded = false;            ///< key threaded
  int input_queue_capacity = 2;     ///< key input_queue_capacity (drops the OLDEST when full)
  int batch_queue_capacity = 2;     ///< key batch_queue_capacity (back-pressure when full)
  bool reject_out_of_order = true;  ///< key reject_out_of_order
  bool planning_layers = true;      ///< key planning_layers

  /// The keys of the `pipeline` section (see the file comment).
  template <class Self, class V>
  static void visit(Self& c, V& v) {
    v.key("threaded", c.threaded, "",
          "false: synchronous and deterministic (tests, benchmarks, replay);\n"
          "true: awareness and local-global stages on their own threads");
    v.key("input_queue_capacity", c.input_queue_capacity, "",
          "frames waiting for the awareness thread; when full the oldest is dropped\n"
          "(counted): the freshest data matters most to a flying vehicle");
    v.key("batch_queue_capacity", c.batch_queue_capacity, "",
          "measurement batches waiting; when full the awareness thread waits (nothing lost)");
    v.key("reject_out_of_order", c.reject_out_of_order, "",
          "frames not newer than the last accepted one are rejected (counted)");
    v.key("planning_layers", c.planning_layers, "",
          "true: after every mapped frame, a snapshot of the local window with the 2D grid\n"
          "and the ESDF (as projected_grid and esdf enable them) is published for planners;\n"
          "false: none is made, whatever those say (a program that only writes the map)");
  }

  void validate(std::vector<std::string>* errors) const;
};

/// The projected 2D grid for ground-plane planners (paper Fig. 6, nav_msgs/OccupancyGrid values).
/// Keys: visit().
struct ProjectedGridConfig {
  /// Its top-level section in the YAML file (MapConfig::visit()).
  static constexpr const char* kSection = "projected_grid";
  bool enabled = true;              ///< key enabled
  bool relative_band = true;        ///< key relative_band
  double band_min_m = -0.3;         ///< key band_min_m
  double band_max_m = 0.3;          ///< key band_max_m
  bool probability_values = false;  ///< key probability_values
  bool include_global = false;      ///< key include_global

  /// The keys of the `projected_grid` section (see the file comment).
  template <class Self, class V>
  static void visit(Self& c, V& v) {
    v.key("enabled", c.enabled, "", "compute the grid");
    v.key("relative_band", c.relative_band, "",
          "true: band relative to the body height; false: absolute heights in the world");
    v.key("band_min_m", c.band_min_m, "m",
          "voxels whose centre lies in [band_min_m, band_max_m] are projected");
    v.key("band_max_m", c.band_max_m, "m", "upper end of that height band");
    v.key("probability_values", c.probability_values, "",
          "false: -1 unknown, 0 free, 100 occupied; true: the band's highest probability x 100");
    v.key("include_global", c.include_global, "",
          "also project the global map's occupied voxels (the grid grows with it)");
  }

  void validate(std::vector<std::string>* errors) const;
};

/// How unknown (never observed) voxels count for planners (distance field, collision checks).
enum class UnknownAs : std::uint8_t {
  kOccupied,  ///< unknown is an obstacle (safe default: a planner keeps away from it)
  kFree,      ///< unknown is free space (optimistic planning)
};

/// Human-readable name of an unknown-voxel policy ("occupied", "free").
const char* toString(UnknownAs policy);
/// Parses "occupied" or "free" (toString()'s names). False, `policy` untouched, otherwise.
bool parseUnknownAs(const std::string& text, UnknownAs* policy);
/// Every accepted name of an unknown-voxel policy, for messages: "occupied or free".
const char* unknownAsChoices();

/// The local ESDF for planners (mlmap/planning/esdf.h).
/// Keys: visit().
struct EsdfConfig {
  /// Its top-level section in the YAML file (MapConfig::visit()).
  static constexpr const char* kSection = "esdf";
  bool enabled = true;                                   ///< key enabled
  double max_distance_m = 2.0;                           ///< key max_distance_m
  UnknownAs unknown_as = UnknownAs::kOccupied;           ///< key unknown_as
  int num_threads = 1;                                   ///< key num_threads
  double max_rate_hz = 10.0;                             ///< key max_rate_hz
  Eigen::Vector3d box_size_m = Eigen::Vector3d::Zero();  ///< key box_size_m
  bool query_grid = false;                               ///< key query_grid

  /// The keys of the `esdf` section (see the file comment).
  template <class Self, class V>
  static void visit(Self& c, V& v) {
    v.key("enabled", c.enabled, "", "compute the ESDF");
    v.key("max_distance_m", c.max_distance_m, "m",
          "distances are clamped to +-this; larger costs more time");
    v.key("unknown_as", c.unknown_as, "",
          "occupied (safe: planners keep away from unseen space) or free");
    v.key("num_threads", c.num_threads, "",
          "threads of one computation, the caller's included\n"
          "(on its own planning thread when pipeline.threaded)");
    v.key("max_rate_hz", c.max_rate_hz, "Hz",
          "updated at most this often (frame stamps), only when a voxel state\n"
          "changed in the window or the box moved; 0: at every change");
    v.key("box_size_m", c.box_size_m, "m",
          "box centred on the body; 0 on an axis: the whole local map along it");
    v.key("query_grid", c.query_grid, "",
          "snapshots also carry a 16-bit query copy of the field (esdfGrid(),\n"
          "2 B a voxel per pooled copy, kept up to date cell by cell)");
  }

  static constexpr int kMaxThreads = 64;
  /// Appends every problem as "esdf.key: what is wrong (got X)"; appends nothing when valid.
  void validate(std::vector<std::string>* errors) const;
};

/// Throws std::invalid_argument "invalid <what>:" followed by one error per line, when `errors`
/// is not empty (the form every config check in mlmap reports in).
void throwIfInvalid(const std::vector<std::string>& errors, const std::string& what);

/// Everything the engine needs: the sections of config/mlmap.yaml.
struct MapConfig {
  AwarenessConfig awareness;           ///< section awareness
  LogOddsConfig log_odds;              ///< section log_odds
  LocalMapConfig local_map;            ///< section local_map
  SensorConfig sensor;                 ///< section sensor
  PipelineConfig pipeline;             ///< section pipeline
  ProjectedGridConfig projected_grid;  ///< section projected_grid
  EsdfConfig esdf;                     ///< section esdf

  /// The top-level sections of an engine configuration (see the file comment).
  template <class Self, class V>
  static void visit(Self& c, V& v) {
    v.section(AwarenessConfig::kSection, c.awareness,
              "cylindrical grid around the body, axes parallel to the world (paper IV-A)");
    v.section(LogOddsConfig::kSection, c.log_odds,
              "natural-log odds, ln(p / (1 - p)) (paper Eq. 7-9, Table 1)");
    v.section(LocalMapConfig::kSection, c.local_map,
              "dense sliding window of the active area (paper IV-B, IV-C, Table 2)");
    v.section(SensorConfig::kSection, c.sensor, "where the sensor sits on the body: T_B_S");
    v.section(PipelineConfig::kSection, c.pipeline, "threads (paper V-A, Figure 5)");
    v.section(ProjectedGridConfig::kSection, c.projected_grid,
              "2D grid for ground-plane planners (paper Fig. 6), nav_msgs/OccupancyGrid values");
    v.section(EsdfConfig::kSection, c.esdf,
              "exact signed distance field of the local map, for planners");
  }

  /// All problems found, each as "section.key: what is wrong (got X)". Empty = valid.
  [[nodiscard]] std::vector<std::string> validate() const;
};

/// The memory [bytes] of the layers whose size a configuration fixes, before anything is
/// allocated: the engine's own accounting (EngineStats::memory) once mapping runs, within about
/// 15 % (tests/pipeline compares them). The global map is not in it: it grows with what is seen.
struct MemoryEstimate {
  std::size_t local_bytes = 0;     ///< the local map's window: 2 bytes of log-odds per voxel
  std::size_t snapshot_bytes = 0;  ///< two window copies for planners (one read, one filled)
  std::size_t esdf_bytes = 0;  ///< the ESDF and its published copies (0 when esdf.enabled is off)
  /// The cylindrical grid and the free-space scratch box (a frame's point buffers add about
  /// 12 bytes per point: 3.7 MB for a 640 x 480 depth image).
  std::size_t awareness_bytes = 0;
  [[nodiscard]] std::size_t total() const {
    return local_bytes + snapshot_bytes + esdf_bytes + awareness_bytes;
  }
};

/// The memory `config` will take (see MemoryEstimate); `config` must be valid.
[[nodiscard]] MemoryEstimate estimateMemory(const MapConfig& config);

/// "4.7 GB (local map 400 MB, snapshots 800 MB, ESDF 3.4 GB, awareness 12 MB)".
[[nodiscard]] std::string describeMemory(const MemoryEstimate& estimate);

}  // namespace mlmap
