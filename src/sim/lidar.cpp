#include "mlmap/sim/lidar.h"

#include "noise.h"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace mlmap::sim {
namespace {

constexpr double kPi = 3.141592653589793238462643383279502884;
constexpr double kDegToRad = kPi / 180.0;

template <typename T>
void require(bool ok, const char* key, const char* what, T got, std::vector<std::string>* errors) {
  if (ok) return;
  std::ostringstream message;
  message << "lidar." << key << ": " << what << " (got " << got << ")";
  errors->push_back(message.str());
}

}  // namespace

void LidarModel::validate(std::vector<std::string>* errors) const {
  require(beams >= 1 && beams <= 4096, "beams", "must be in 1..4096", beams, errors);
  require(azimuth_steps >= 1 && azimuth_steps <= 65536, "azimuth_steps", "must be in 1..65536",
          azimuth_steps, errors);
  require(std::isfinite(vertical_min_deg) && vertical_min_deg > -90.0, "vertical_min_deg",
          "must be finite and > -90", vertical_min_deg, errors);
  require(std::isfinite(vertical_max_deg) && vertical_max_deg < 90.0 &&
              vertical_max_deg >= vertical_min_deg,
          "vertical_max_deg", "must be finite, < 90 and >= vertical_min_deg", vertical_max_deg,
          errors);
  require(std::isfinite(min_range_m) && min_range_m >= 0.0, "min_range_m",
          "must be finite and >= 0", min_range_m, errors);
  require(std::isfinite(max_range_m) && max_range_m > min_range_m, "max_range_m",
          "must be finite and > min_range_m", max_range_m, errors);
  require(std::isfinite(noise_sigma_m) && noise_sigma_m >= 0.0, "noise_sigma_m",
          "must be finite and >= 0", noise_sigma_m, errors);
}

Lidar::Lidar(const LidarModel& model) : model_(model) {
  std::vector<std::string> errors;
  model_.validate(&errors);
  if (!errors.empty()) {
    std::string message = "invalid LiDAR model:";
    for (const std::string& e : errors) message += "\n  " + e;
    throw std::invalid_argument(message);
  }
  directions_S_.reserve(model_.rayCount());
  for (int b = 0; b < model_.beams; ++b) {
    for (int a = 0; a < model_.azimuth_steps; ++a) directions_S_.push_back(rayDirection_S(b, a));
  }
}

Eigen::Vector3d Lidar::rayDirection_S(int beam, int azimuth_step) const {
  const double elevation_deg =
      model_.beams == 1
          ? 0.5 * (model_.vertical_min_deg + model_.vertical_max_deg)
          : model_.vertical_min_deg +
                beam * (model_.vertical_max_deg - model_.vertical_min_deg) / (model_.beams - 1);
  const double elevation = elevation_deg * kDegToRad;
  const double azimuth = azimuth_step * (2.0 * kPi / model_.azimuth_steps);
  return {std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
          std::sin(elevation)};
}

void Lidar::render(const World& world, const Transform& T_W_S, double time_s,
                   PointCloudFrame* frame) const {
  if (frame == nullptr) return;
  frame->stamp_s = time_s;
  frame->points_S.clear();
  frame->points_S.reserve(directions_S_.size());
  const Eigen::Matrix3d R_W_S = T_W_S.linear();
  const Eigen::Vector3d origin_W = T_W_S.translation();
  const bool noisy = model_.noise_sigma_m > 0.0;
  const std::uint64_t frame_key = detail::frameKey(model_.seed, time_s);
  for (std::size_t i = 0; i < directions_S_.size(); ++i) {
    const Eigen::Vector3d& dir_S = directions_S_[i];
    double range = 0.0;
    if (!world.raycast(origin_W, R_W_S * dir_S, model_.max_range_m, time_s, &range)) continue;
    if (range < model_.min_range_m) continue;
    if (noisy) {
      range += model_.noise_sigma_m * detail::standardNormal(frame_key, i);
      if (range < model_.min_range_m) continue;
    }
    frame->points_S.push_back((dir_S * range).cast<float>());
  }
}

}  // namespace mlmap::sim
