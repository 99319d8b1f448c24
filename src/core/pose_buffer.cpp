#include "mlmap/core/pose_buffer.h"

#include "mlmap/core/config.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace mlmap {
namespace {
constexpr double kSameStamp_s = 1e-6;
constexpr double kDegPerRad = 57.29577951308232;

void requirePositive(const char* key, double value, std::vector<std::string>* errors) {
  if (!(std::isfinite(value) && value > 0.0)) {
    std::ostringstream out;
    out << key << ": must be a positive number of seconds (got " << value << ")";
    errors->push_back(out.str());
  }
}
}  // namespace

void PoseBufferConfig::validate(std::vector<std::string>* errors) const {
  requirePositive("tolerance_s", tolerance_s, errors);
  requirePositive("horizon_s", horizon_s, errors);
  requirePositive("max_future_s", max_future_s, errors);
  requirePositive("max_speed_mps", max_speed_mps, errors);
  requirePositive("max_rotation_rate_dps", max_rotation_rate_dps, errors);
  if (std::isfinite(tolerance_s) && std::isfinite(horizon_s) && horizon_s < 2.0 * tolerance_s) {
    std::ostringstream out;
    out << "horizon_s: must be at least twice tolerance_s (got " << horizon_s << " < 2 x "
        << tolerance_s << ")";
    errors->push_back(out.str());
  }
}

PoseBuffer::PoseBuffer(const PoseBufferConfig& config) : config_(config) {
  std::vector<std::string> errors;
  config_.validate(&errors);
  throwIfInvalid(errors, "pose buffer configuration");
}

PoseBuffer::AddResult PoseBuffer::add(double stamp_s, const Transform& T_W_B) {
  if (!std::isfinite(stamp_s) || !isValidPose(T_W_B, 1e-3)) {
    ++counters_.rejected_invalid;
    return AddResult::kInvalid;
  }
  if (!poses_.empty()) {
    const double newest = poses_.back().stamp_s;
    if (stamp_s <= newest) {
      ++counters_.rejected_out_of_order;
      return AddResult::kOutOfOrder;
    }
    if (stamp_s > newest + config_.max_future_s) {
      if (has_held_ && stamp_s > held_.stamp_s && stamp_s <= held_.stamp_s + config_.max_future_s) {
        // Two poses agree: the stream resumed after a pause. Nothing spans the pause.
        poses_.clear();
        poses_.push_back(held_);
        ++counters_.poses_added;
        ++counters_.restarts;
      } else {
        ++counters_.rejected_future;
        held_ = {stamp_s, T_W_B};
        has_held_ = true;
        return AddResult::kFuture;
      }
    }
  }
  has_held_ = false;  // not confirmed by this pose: it was a bogus stamp
  poses_.push_back({stamp_s, T_W_B});
  ++counters_.poses_added;
  const double oldest_kept = stamp_s - config_.horizon_s;
  while (poses_.size() > 2 && poses_[1].stamp_s <= oldest_kept) poses_.pop_front();
  return AddResult::kAdded;
}

PoseBuffer::LookupResult PoseBuffer::lookup(double stamp_s, Transform* T_W_B) const {
  if (poses_.empty() || !std::isfinite(stamp_s)) {
    return poses_.empty() && std::isfinite(stamp_s) ? LookupResult::kPending
                                                    : LookupResult::kNoPose;
  }
  const Stamped& newest = poses_.back();
  if (std::abs(stamp_s - newest.stamp_s) <= kSameStamp_s) {
    *T_W_B = newest.T_W_B;
    return LookupResult::kFound;
  }
  if (stamp_s > newest.stamp_s) return LookupResult::kPending;
  // First pose newer than the stamp.
  const auto after = std::upper_bound(poses_.begin(), poses_.end(), stamp_s,
                                      [](double t, const Stamped& p) { return t < p.stamp_s; });
  if (after == poses_.begin()) {
    // Older than every pose: only an exact match counts.
    if (std::abs(after->stamp_s - stamp_s) <= kSameStamp_s) {
      *T_W_B = after->T_W_B;
      return LookupResult::kFound;
    }
    return LookupResult::kNoPose;
  }
  const Stamped& a = *(after - 1);
  const Stamped& b = *after;
  const double nearest = std::min(stamp_s - a.stamp_s, b.stamp_s - stamp_s);
  if (nearest > config_.tolerance_s) return LookupResult::kNoPose;
  for (const Stamped* p : {&a, &b}) {
    if (std::abs(p->stamp_s - stamp_s) <= kSameStamp_s) {
      *T_W_B = p->T_W_B;
      return LookupResult::kFound;
    }
  }
  const double span_s = b.stamp_s - a.stamp_s;
  const double distance_m = (b.T_W_B.translation() - a.T_W_B.translation()).norm();
  const double angle_deg =
      Eigen::AngleAxisd(a.T_W_B.linear().transpose() * b.T_W_B.linear()).angle() * kDegPerRad;
  if (distance_m > config_.max_speed_mps * span_s ||
      angle_deg > config_.max_rotation_rate_dps * span_s) {
    return LookupResult::kAcrossJump;
  }
  *T_W_B = interpolatePose(a.T_W_B, a.stamp_s, b.T_W_B, b.stamp_s, stamp_s);
  return LookupResult::kFound;
}

double PoseBuffer::oldestStamp() const { return poses_.empty() ? 0.0 : poses_.front().stamp_s; }

bool PoseBuffer::newestStamp(double* stamp_s) const {
  if (poses_.empty()) return false;
  *stamp_s = poses_.back().stamp_s;
  return true;
}

Transform interpolatePose(const Transform& a, double ta, const Transform& b, double tb, double t) {
  const double span = tb - ta;
  const double s = span > 0.0 ? std::clamp((t - ta) / span, 0.0, 1.0) : 0.0;
  const Eigen::Quaterniond qa(a.linear());
  const Eigen::Quaterniond qb(b.linear());
  Transform out = Transform::Identity();
  out.linear() = qa.slerp(s, qb).normalized().toRotationMatrix();
  out.translation() = (1.0 - s) * a.translation() + s * b.translation();
  return out;
}

}  // namespace mlmap
