#pragma once
/// @file
/// Synthetic 360-degree spinning LiDAR that ray casts a sim::World into a point cloud.

#include "mlmap/core/types.h"
#include "mlmap/sim/world.h"

#include <cstdint>
#include <string>
#include <vector>

namespace mlmap::sim {

/// Parameters of a simulated multi-beam LiDAR. Defaults: 128 beams x 640 azimuth steps
/// (81,920 rays per scan, an Ouster OS1-128-like sensor at 640 columns), 45 deg vertical field
/// of view, 30 m range, no noise.
///
/// The sensor frame S is x forward, y left, z up (the usual LiDAR convention). Beam b has the
/// elevation vertical_min_deg + b * (vertical_max_deg - vertical_min_deg) / (beams - 1) (the
/// middle one when beams = 1); azimuth step a has the azimuth a * 360 / azimuth_steps deg,
/// counter-clockwise from +x.
struct LidarModel {
  int beams = 128;                  ///< rows (elevations), >= 1
  int azimuth_steps = 640;          ///< columns over 360 deg, >= 1
  double vertical_min_deg = -22.5;  ///< elevation of the lowest beam [deg], > -90
  double vertical_max_deg = 22.5;   ///< elevation of the highest beam [deg], < 90, >= min
  double min_range_m = 0.3;         ///< closer returns are dropped [m], >= 0
  double max_range_m = 30.0;        ///< nothing hit within this range gives no point [m], > min
  double noise_sigma_m = 0.0;       ///< Gaussian range noise sigma [m]; 0 = off
  std::uint32_t seed = 1;           ///< noise seed; noise is a pure function of (seed, time, ray)

  /// Rays per scan (beams x azimuth_steps).
  [[nodiscard]] std::size_t rayCount() const {
    return static_cast<std::size_t>(beams) * static_cast<std::size_t>(azimuth_steps);
  }
  /// Appends every problem as "lidar.key: what is wrong (got X)"; appends nothing when valid.
  void validate(std::vector<std::string>* errors) const;
};

/// Renders instantaneous 360-degree scans (no motion distortion: every ray of a scan leaves
/// from the same pose at the same time).
class Lidar {
 public:
  /// Throws std::invalid_argument listing every problem when `model` is not valid.
  explicit Lidar(const LidarModel& model = {});

  /// The LiDAR model.
  [[nodiscard]] const LidarModel& model() const { return model_; }

  /// Unit direction of ray (beam, azimuth step) in S; see LidarModel for the angles.
  [[nodiscard]] Eigen::Vector3d rayDirection_S(int beam, int azimuth_step) const;

  /// Renders `world` at `time_s` from the sensor pose `T_W_S` into `frame`: sets stamp_s =
  /// time_s and points_S (one point per ray that hits a solid at a range in
  /// [min_range_m, max_range_m], beam-major order; rays with no return give no point); leaves
  /// T_W_B and T_B_S untouched. With noise, the measured range is the true one plus
  /// N(0, noise_sigma_m^2) and a point whose noisy range falls below min_range_m is dropped.
  /// Deterministic: rendering the same time twice gives the same cloud. Does nothing when
  /// `frame` is null. Never throws.
  void render(const World& world, const Transform& T_W_S, double time_s,
              PointCloudFrame* frame) const;

 private:
  LidarModel model_;
  std::vector<Eigen::Vector3d> directions_S_;  ///< per ray, beam-major
};

}  // namespace mlmap::sim
