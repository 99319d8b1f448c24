#include "mlmap/sim/trajectory.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace mlmap::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
/// Consecutive waypoints closer than this are rejected as coincident [m].
constexpr double kMinSegmentLength_m = 1e-9;

/// Wraps an angle to (-pi, pi].
double wrapAngle(double angle_rad) {
  double a = std::remainder(angle_rad, 2.0 * kPi);
  if (a <= -kPi) a += 2.0 * kPi;
  return a;
}

double smoothstep(double x) {
  const double c = std::clamp(x, 0.0, 1.0);
  return c * c * (3.0 - 2.0 * c);
}

}  // namespace

Trajectory::Trajectory(std::vector<Waypoint> waypoints, double speed_mps, double yaw_blend_s)
    : waypoints_(std::move(waypoints)), speed_mps_(speed_mps), yaw_blend_s_(yaw_blend_s) {
  if (waypoints_.empty()) throw std::invalid_argument("trajectory: needs at least one waypoint");
  if (!std::isfinite(speed_mps_) || speed_mps_ <= 0.0) {
    throw std::invalid_argument("trajectory: speed_mps must be finite and > 0, got " +
                                std::to_string(speed_mps_));
  }
  if (!std::isfinite(yaw_blend_s_) || yaw_blend_s_ < 0.0) {
    throw std::invalid_argument("trajectory: yaw blend time must be finite and >= 0, got " +
                                std::to_string(yaw_blend_s_));
  }
  const std::size_t n = waypoints_.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Waypoint& wp = waypoints_[i];
    if (!wp.position_W.allFinite() || (wp.has_yaw && !std::isfinite(wp.yaw_rad))) {
      throw std::invalid_argument("trajectory: waypoints[" + std::to_string(i) +
                                  "] has a non-finite value");
    }
    if (i > 0 && (wp.position_W - waypoints_[i - 1].position_W).norm() < kMinSegmentLength_m) {
      throw std::invalid_argument("trajectory: waypoints[" + std::to_string(i) +
                                  "] coincides with waypoints[" + std::to_string(i - 1) + "]");
    }
  }

  // Segment timing.
  start_times_s_.assign(1, 0.0);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const double len = (waypoints_[k + 1].position_W - waypoints_[k].position_W).norm();
    length_m_ += len;
    start_times_s_.push_back(start_times_s_.back() + len / speed_mps_);
  }
  duration_s_ = start_times_s_.back();

  // Horizontal heading of each segment; vertical segments inherit a neighbour's heading.
  const std::size_t segments = n - 1;
  std::vector<double> heading(segments, 0.0);
  std::vector<bool> defined(segments, false);
  for (std::size_t k = 0; k < segments; ++k) {
    const Eigen::Vector3d d = waypoints_[k + 1].position_W - waypoints_[k].position_W;
    if (d.head<2>().norm() > kMinSegmentLength_m) {
      heading[k] = std::atan2(d.y(), d.x());
      defined[k] = true;
    }
  }
  double fallback = waypoints_.front().has_yaw ? waypoints_.front().yaw_rad : 0.0;
  for (std::size_t k = 0; k < segments; ++k) {  // first defined heading for leading gaps
    if (defined[k]) {
      fallback = heading[k];
      break;
    }
  }
  for (std::size_t k = 0; k < segments; ++k) {
    if (defined[k]) {
      fallback = heading[k];
    } else {
      heading[k] = fallback;
    }
  }

  start_yaw_rad_.resize(segments);
  end_yaw_rad_.resize(segments);
  for (std::size_t k = 0; k < segments; ++k) {
    start_yaw_rad_[k] = waypoints_[k].has_yaw ? waypoints_[k].yaw_rad : heading[k];
    end_yaw_rad_[k] = waypoints_[k + 1].has_yaw ? waypoints_[k + 1].yaw_rad : heading[k];
  }
  blend_half_s_.assign(n, 0.0);
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const double before = start_times_s_[i] - start_times_s_[i - 1];
    const double after = start_times_s_[i + 1] - start_times_s_[i];
    blend_half_s_[i] = std::min({0.5 * yaw_blend_s_, 0.5 * before, 0.5 * after});
  }
}

std::size_t Trajectory::segmentAt(double t_s) const {
  // start_times_s_ has (segments + 1) entries; find the last start <= t.
  const auto it = std::upper_bound(start_times_s_.begin(), start_times_s_.end(), t_s);
  std::size_t k = (it == start_times_s_.begin())
                      ? 0
                      : static_cast<std::size_t>(it - start_times_s_.begin()) - 1;
  const std::size_t segments = waypoints_.size() - 1;
  return std::min(k, segments - 1);
}

double Trajectory::segmentYaw(std::size_t k, double t_s) const {
  const double t0 = start_times_s_[k];
  const double dt = start_times_s_[k + 1] - t0;
  const double s = std::clamp((t_s - t0) / dt, 0.0, 1.0);
  return start_yaw_rad_[k] + s * wrapAngle(end_yaw_rad_[k] - start_yaw_rad_[k]);
}

Eigen::Vector3d Trajectory::positionAt(double t_s) const {
  if (waypoints_.empty()) return Eigen::Vector3d::Zero();
  if (waypoints_.size() == 1) return waypoints_.front().position_W;
  const double t = std::clamp(t_s, 0.0, duration_s_);
  const std::size_t k = segmentAt(t);
  const double t0 = start_times_s_[k];
  const double s = std::clamp((t - t0) / (start_times_s_[k + 1] - t0), 0.0, 1.0);
  const Eigen::Vector3d& a = waypoints_[k].position_W;
  const Eigen::Vector3d& b = waypoints_[k + 1].position_W;
  return a + s * (b - a);
}

double Trajectory::yawAt(double t_s) const {
  if (waypoints_.empty()) return 0.0;
  if (waypoints_.size() == 1) {
    return waypoints_.front().has_yaw ? wrapAngle(waypoints_.front().yaw_rad) : 0.0;
  }
  const double t = std::clamp(t_s, 0.0, duration_s_);
  const std::size_t k = segmentAt(t);
  const std::size_t segments = waypoints_.size() - 1;
  // Corner blending windows around waypoint k (start of segment k) and k + 1 (its end).
  std::size_t corner = 0;
  bool blend = false;
  if (k >= 1 && t < start_times_s_[k] + blend_half_s_[k]) {
    corner = k;
    blend = true;
  } else if (k + 1 < segments && t > start_times_s_[k + 1] - blend_half_s_[k + 1]) {
    corner = k + 1;
    blend = true;
  }
  if (!blend) return wrapAngle(segmentYaw(k, t));
  const double half = blend_half_s_[corner];
  const double in = segmentYaw(corner - 1, t);
  const double out = segmentYaw(corner, t);
  const double x = (t - (start_times_s_[corner] - half)) / (2.0 * half);
  return wrapAngle(in + smoothstep(x) * wrapAngle(out - in));
}

Transform Trajectory::poseAt(double t_s) const {
  Transform T_W_B = Transform::Identity();
  T_W_B.translation() = positionAt(t_s);
  T_W_B.linear() = Eigen::AngleAxisd(yawAt(t_s), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T_W_B;
}

Trajectory Trajectory::defaultRoomFlight() {
  std::vector<Waypoint> waypoints;
  waypoints.push_back({Eigen::Vector3d(4.0, 4.5, 1.5), 0.0, false});
  waypoints.push_back({Eigen::Vector3d(25.0, 4.5, 1.5), 0.0, false});
  waypoints.push_back({Eigen::Vector3d(25.0, 15.5, 1.8), 0.0, false});
  waypoints.push_back({Eigen::Vector3d(4.0, 15.5, 1.2), 0.0, false});
  waypoints.push_back({Eigen::Vector3d(4.0, 5.5, 1.5), 0.0, false});
  return Trajectory(std::move(waypoints), 1.0);
}

}  // namespace mlmap::sim
