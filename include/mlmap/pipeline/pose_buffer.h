#pragma once
/// @file
/// Pairs sensor frames with vehicle poses by time stamp: a short buffer of stamped T_W_B,
/// interpolated (linear translation, slerp rotation) between the two poses around a frame's stamp.
///
/// A frame is never mapped with a pose that was not measured close to its stamp, nor extrapolated:
/// lookup() finds a pose only when a buffered pose has (within 1 us) the frame's stamp, or when
/// the frame lies between two buffered poses and the nearer of them is at most `tolerance_s`
/// away. A frame newer than every pose is kPending (its pose may still arrive: the caller retries
/// when one does and gives up after a while); one older than the buffer, or farther than the
/// tolerance from both poses around it (a gap in the pose stream), is kNoPose.

#include "mlmap/core/types.h"

#include <cstdint>
#include <deque>
#include <vector>

namespace mlmap {

/// Settings of a PoseBuffer.
struct PoseBufferConfig {
  double tolerance_s = 0.05;   ///< a frame needs a pose at most this far from its stamp
  double horizon_s = 2.0;      ///< poses older than the newest minus this are dropped
  double max_future_s = 1.0;   ///< a pose this far ahead of the newest one is rejected as bogus
  /// Every problem as "key: what is wrong (got X)".
  void validate(std::vector<std::string>* errors) const;
};

/// Counters of a PoseBuffer.
struct PoseBufferCounters {
  std::uint64_t poses_added = 0;
  std::uint64_t rejected_invalid = 0;       ///< non-finite stamp or T_W_B not a valid pose
  std::uint64_t rejected_out_of_order = 0;  ///< stamp not newer than the newest pose
  std::uint64_t rejected_future = 0;        ///< stamp more than max_future_s after the newest pose
};

/// Stamped poses, newest last. Not thread-safe (one owner).
class PoseBuffer {
 public:
  /// Why add() refused a pose.
  enum class AddResult { kAdded, kInvalid, kOutOfOrder, kFuture };
  /// What lookup() found.
  enum class LookupResult { kFound, kPending, kNoPose };

  /// Throws std::invalid_argument listing every problem when `config` is not valid.
  explicit PoseBuffer(const PoseBufferConfig& config);

  /// Adds a pose. Poses must come in stamp order; the others are refused and counted.
  AddResult add(double stamp_s, const Transform& T_W_B);
  /// The pose at `stamp_s` (see the file comment). T_W_B is written only when kFound.
  LookupResult lookup(double stamp_s, Transform* T_W_B) const;

  /// Stamp of the newest pose; false when the buffer is empty.
  bool newestStamp(double* stamp_s) const;
  [[nodiscard]] std::size_t size() const { return poses_.size(); }
  [[nodiscard]] const PoseBufferCounters& counters() const { return counters_; }
  [[nodiscard]] const PoseBufferConfig& config() const { return config_; }

 private:
  struct Stamped {
    double stamp_s;
    Transform T_W_B;
  };
  PoseBufferConfig config_;
  std::deque<Stamped> poses_;
  PoseBufferCounters counters_;
};

/// Pose between a (at ta) and b (at tb) at time t in [ta, tb]: linear translation, slerp rotation.
Transform interpolatePose(const Transform& a, double ta, const Transform& b, double tb, double t);

}  // namespace mlmap
