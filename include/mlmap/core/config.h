#pragma once
/// @file
/// Typed configuration of the mapping engine. Every default is the paper's configuration
/// (performance run of Section VI-F and Table 1/2); `validate()` explains every bad value.
/// The YAML loader (mlmap/config/config_yaml.h) fills these structs; the core never parses files.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <string>
#include <vector>

namespace mlmap {

/// Cylindrical awareness grid around the body (paper IV-A). Axes are parallel to the world
/// frame; the origin is the body position. Default: 100 x 180 x 25 cells (rho x phi x z).
struct AwarenessConfig {
  double rho_cell_m = 0.1;  ///< radial cell size
  int rho_cells = 100;      ///< radial cell count (radius = rho_cells * rho_cell_m)
  int phi_cells = 180;      ///< azimuth sectors over 360 deg (2 deg each by default)
  double z_cell_m = 0.2;    ///< vertical cell size
  int z_cells = 25;         ///< vertical cell count
  int z_cells_below = 13;   ///< how many of the z cells lie below the body
  double min_range_m = 0.1;   ///< points closer to the sensor are dropped (counted)
  double max_range_m = 10.0;  ///< farther points clear their ray up to here and are no hit
  /// 0 = every valid point counts (default). N > 0 keeps N random points per frame
  /// (the paper's 500-point mode, SAMPLE_CNT).
  int sample_count = 0;
  std::uint32_t sample_seed = 1;  ///< seed of the sub-sampling generator

  [[nodiscard]] double radius_m() const { return rho_cells * rho_cell_m; }
  [[nodiscard]] double phi_cell_rad() const;
  void validate(std::vector<std::string>* errors) const;
};

/// Log-odds sensor model (paper Eq. 7-9, Table 1). Natural logarithm throughout:
/// logit(p) = ln(p / (1 - p)). Defaults: high-precision sensor of Table 1 (hit 0.85 = P 0.7,
/// miss -0.4 = P 0.4), clamping as OctoMap ([-2, 3.5] = P 0.12..0.97), occupied above 0 (P 0.5).
struct LogOddsConfig {
  double hit = 0.85;
  double miss = -0.4;
  double clamp_min = -2.0;
  double clamp_max = 3.5;
  double occupied_threshold = 0.0;  ///< occupied when log-odds > threshold, free when <=

  void validate(std::vector<std::string>* errors) const;
};

/// Sliding local map (paper IV-B, IV-C): a dense grid cut into 5 x 5 x 5 submaps.
/// Default: paper Table 2, 0.2 m voxels, 95 x 95 x 35 cells = 19 x 19 x 7 m.
struct LocalMapConfig {
  double resolution_m = 0.2;
  Eigen::Vector3i size_cells{95, 95, 35};  ///< each must be a multiple of 5 (kSubmapsPerAxis)

  static constexpr int kSubmapsPerAxis = 5;
  [[nodiscard]] Eigen::Vector3i submap_cells() const { return size_cells / kSubmapsPerAxis; }
  void validate(std::vector<std::string>* errors) const;
};

/// Where the sensor sits on the body: T_B_S. Default: a forward-looking camera in optical
/// convention (z forward, x right, y down) on a FLU body, 0.1 m ahead of the body origin.
struct SensorConfig {
  Eigen::Vector3d translation_B_m{0.1, 0.0, 0.0};
  /// Rotation of the sensor frame in the body frame as roll, pitch, yaw (deg, applied Z-Y-X).
  /// The default (-90, 0, -90) is the optical frame of a forward camera.
  Eigen::Vector3d rotation_rpy_deg{-90.0, 0.0, -90.0};

  void validate(std::vector<std::string>* errors) const;
  /// T_B_S built from the translation and roll-pitch-yaw.
  [[nodiscard]] Eigen::Isometry3d T_B_S() const;
};

/// How the two stages run (paper V-A, Figure 5).
struct PipelineConfig {
  /// false: synchronous, deterministic, single thread (tests, benchmarks, offline replay).
  /// true: awareness and local-global stages on their own threads.
  bool threaded = false;
  /// Frames waiting for the awareness thread. When full, the OLDEST waiting frame is dropped
  /// (the freshest data matters most to a flying vehicle) and `frames_dropped` counts it.
  int input_queue_capacity = 2;
  /// Measurement batches waiting for the local-global thread. When full the awareness thread
  /// waits (measurements are never dropped once computed); back-pressure reaches the input queue.
  int batch_queue_capacity = 2;
  /// Frames whose stamp is not newer than the previous accepted frame are rejected.
  bool reject_out_of_order = true;

  void validate(std::vector<std::string>* errors) const;
};

/// The projected 2D grid for ground-plane planners (paper Fig. 6, nav_msgs/OccupancyGrid values).
struct ProjectedGridConfig {
  bool enabled = true;
  /// true: the band is relative to the body height; false: absolute heights in W.
  bool relative_band = true;
  double band_min_m = -0.3;  ///< lower end of the height band [m]
  double band_max_m = 0.3;   ///< upper end of the height band [m]
  /// false: -1 unknown, 0 free, 100 occupied. true: known cells hold the band's highest
  /// occupancy probability scaled to 0..100.
  bool probability_values = false;
  /// Also project the global map's occupied voxels (the grid grows to the global extent).
  bool include_global = false;

  void validate(std::vector<std::string>* errors) const;
};

/// How unknown (never observed) voxels count for planners (distance field, collision checks).
enum class UnknownAs : std::uint8_t {
  kOccupied,  ///< unknown is an obstacle (safe default: a planner keeps away from it)
  kFree,      ///< unknown is free space (optimistic planning)
};

/// Human-readable name of an unknown-voxel policy ("occupied", "free").
const char* toString(UnknownAs policy);

/// The local ESDF for planners (mlmap/planning/esdf.h).
struct EsdfConfig {
  bool enabled = true;
  /// Distances are clamped to [-max_distance_m, +max_distance_m]; larger values cost more time.
  double max_distance_m = 2.0;
  /// How unknown voxels count (obstacle by default).
  UnknownAs unknown_as = UnknownAs::kOccupied;
  /// Threads used by one computation, the caller's included (1 = the caller's thread only).
  int num_threads = 1;
  /// Recomputed at most this often (by frame stamps) and only when a voxel state changed in the
  /// window or the box moved; 0 = at every change.
  double max_rate_hz = 10.0;
  /// Box centred on the body [m]; 0 along an axis = the whole local map along it (default).
  Eigen::Vector3d box_size_m = Eigen::Vector3d::Zero();

  static constexpr int kMaxThreads = 64;
  /// Appends every problem as "esdf.key: what is wrong (got X)"; appends nothing when valid.
  void validate(std::vector<std::string>* errors) const;
};

/// Throws std::invalid_argument "invalid <what>:" followed by one error per line, when `errors`
/// is not empty (the form every config check in mlmap reports in).
void throwIfInvalid(const std::vector<std::string>& errors, const std::string& what);

/// Everything the engine needs.
struct MapConfig {
  AwarenessConfig awareness;
  LogOddsConfig log_odds;
  LocalMapConfig local_map;
  SensorConfig sensor;
  PipelineConfig pipeline;
  ProjectedGridConfig projected_grid;
  EsdfConfig esdf;

  /// All problems found, each as "section.key: what is wrong (got X)". Empty = valid.
  [[nodiscard]] std::vector<std::string> validate() const;
};

}  // namespace mlmap
