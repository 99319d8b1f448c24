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
/// tolerance from both poses around it (a gap in the pose stream), is kNoPose. Nor is a frame
/// interpolated across a jump of the pose stream (a relocalisation, an odometry reset): when the
/// two poses around it are farther apart than the vehicle can fly in their time difference, it
/// is kAcrossJump, and only a frame at the stamp of one of them gets that pose.

#include "mlmap/core/types.h"

#include <cstdint>
#include <deque>
#include <vector>

namespace mlmap {

/// Settings of a PoseBuffer.
struct PoseBufferConfig {
  double tolerance_s = 0.05;  ///< a frame needs a pose at most this far from its stamp
  double horizon_s = 2.0;     ///< poses older than the newest minus this are dropped
  /// A pose this far ahead of the newest one is held, not added: a single bogus stamp. When
  /// the next pose confirms it (newer, and at most this far after it), the stream has resumed
  /// after a pause: the buffer restarts from the two.
  double max_future_s = 1.0;
  /// Two consecutive poses that imply a faster motion than this are a jump, not a flight: no
  /// frame between them is interpolated. Far above what a multirotor flies [m/s].
  double max_speed_mps = 50.0;
  /// The same for the rotation between them [deg/s].
  double max_rotation_rate_dps = 1800.0;
  /// Every problem as "key: what is wrong (got X)".
  void validate(std::vector<std::string>* errors) const;
};

/// Counters of a PoseBuffer.
struct PoseBufferCounters {
  std::uint64_t poses_added = 0;
  std::uint64_t rejected_invalid = 0;       ///< non-finite stamp or T_W_B not a valid pose
  std::uint64_t rejected_out_of_order = 0;  ///< stamp not newer than the newest pose
  std::uint64_t rejected_future = 0;        ///< stamp more than max_future_s after the newest pose
  std::uint64_t restarts = 0;  ///< a kFuture pose confirmed by the next one: the buffer restarted
};

/// Stamped poses, newest last. Not thread-safe (one owner).
class PoseBuffer {
 public:
  /// Why add() refused a pose.
  enum class AddResult {
    kAdded,       ///< in the buffer (after a held pose: both, the buffer restarted from them)
    kInvalid,     ///< non-finite stamp or not a valid pose
    kOutOfOrder,  ///< not newer than the newest pose
    kFuture,      ///< far ahead of the newest pose: not added, held until the next pose
                  ///< (see PoseBufferConfig::max_future_s)
  };
  /// What lookup() found.
  enum class LookupResult {
    kFound,       ///< the pose is in T_W_B
    kPending,     ///< newer than every pose: it may still come
    kNoPose,      ///< older than the buffer, or in a gap of the pose stream
    kAcrossJump,  ///< between two poses of a jump (see PoseBufferConfig::max_speed_mps)
  };

  /// Throws std::invalid_argument listing every problem when `config` is not valid.
  explicit PoseBuffer(const PoseBufferConfig& config);

  /// Adds a pose. Poses must come in stamp order; the others are refused and counted. A kFuture
  /// pose is counted as rejected and held: if the next pose confirms it, both are added and the
  /// older poses dropped (counted in restarts).
  AddResult add(double stamp_s, const Transform& T_W_B);
  /// The pose at `stamp_s` (see the file comment). T_W_B is written only when kFound.
  LookupResult lookup(double stamp_s, Transform* T_W_B) const;

  /// Stamp of the oldest pose kept (0 when the buffer is empty).
  [[nodiscard]] double oldestStamp() const;
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
  bool has_held_ = false;
  Stamped held_{0.0, Transform::Identity()};
  PoseBufferCounters counters_;
};

/// Pose between a (at ta) and b (at tb) at time t in [ta, tb]: linear translation, slerp rotation.
Transform interpolatePose(const Transform& a, double ta, const Transform& b, double tb, double t);

}  // namespace mlmap
