#include "frame_pairer.h"

#include "mlmap/core/stopwatch.h"
#include "mlmap/dds/node/node_config.h"

#include <sstream>
#include <string>

namespace mlmap::dds::node {
namespace {

double stampOf(const std::variant<PointCloudFrame, DepthFrame>& frame) {
  return std::visit([](const auto& f) { return f.stamp_s; }, frame);
}

}  // namespace

FramePairer::FramePairer(const DdsConfig& dds, const Transform& T_B_S, const TfListener* tf,
                         MapEngine& engine, CounterSink& counters, NodeLog& log)
    : dds_(dds),
      frames_(resolveFrames(dds)),
      extrinsic_(resolveExtrinsicSource(dds)),
      T_B_S_(T_B_S),
      tf_(tf),
      engine_(engine),
      counters_(counters),
      log_(log),
      poses_(poseBufferConfig(dds)) {}

void FramePairer::handle(Input& input) {
  std::visit([this](auto& msg) { handle(msg); }, input);
}

void FramePairer::malformed(const char* what, const DecodeStatus& status) {
  counters_.add(&NodeCounters::inputs_malformed);
  log_.limited(LogLevel::kWarning, kReasonMalformed,
               std::string("rejected a malformed ") + what + ": " + toString(status.error) +
                   (status.detail.empty() ? "" : " (" + status.detail + ")"));
}

void FramePairer::handle(CloudSample& msg) {
  counters_.add(&NodeCounters::clouds_received);
  if (msg.header_().stamp_().nanosec_() >= 1000000000u) {
    return malformed("PointCloud2", DecodeStatus{DecodeError::kBadStamp, "nanosec >= 1e9"});
  }
  if (!msg.status.ok()) return malformed("PointCloud2", msg.status);  // decoded when taken
  PointCloudFrame frame;
  frame.stamp_s = toSeconds(msg.header_().stamp_());
  if (!extrinsicFor(msg.header_().frame_id_(), frame.stamp_s, &frame.T_B_S)) return;
  frame.points_S = std::move(msg.points_S);
  place(Frame(std::move(frame)));
}

void FramePairer::handle(sensor_msgs::Image_& msg) {
  counters_.add(&NodeCounters::images_received);
  if (!have_camera_info_) {
    counters_.add(&NodeCounters::images_without_info);
    log_.limited(LogLevel::kWarning, kReasonNoInfo,
                 "depth image before any valid CameraInfo: dropped");
    return;
  }
  if (msg.header_().stamp_().nanosec_() >= 1000000000u) {
    return malformed("depth Image", DecodeStatus{DecodeError::kBadStamp, "nanosec >= 1e9"});
  }
  DepthFrame frame;
  const DecodeStatus status = decodeDepthImage(msg, camera_info_, &frame);
  if (!status.ok()) return malformed("depth Image", status);
  frame.stamp_s = toSeconds(msg.header_().stamp_());
  if (!extrinsicFor(msg.header_().frame_id_(), frame.stamp_s, &frame.T_B_S)) return;
  place(Frame(std::move(frame)));
}

bool FramePairer::extrinsicFor(const std::string& frame_id, double stamp_s, Transform* T_B_S) {
  if (extrinsic_ == ExtrinsicSource::kConfig) {
    *T_B_S = T_B_S_;
    if (frame_id != frames_.sensor) {
      counters_.add(&NodeCounters::frames_unexpected_frame_id);
      log_.limited(LogLevel::kWarning, kReasonFrameId,
                   "a frame in '" + frame_id + "', not the sensor frame '" + frames_.sensor +
                       "': mapped with the configured extrinsic (sensor.*); set dds.sensor_frame, "
                       "or dds.sensor_extrinsic tf_static");
    }
    return true;
  }
  const TfBuffer::Lookup found = tf_ == nullptr
                                     ? TfBuffer::Lookup::kUnknownFrame
                                     : tf_->lookup(frames_.body, frame_id, stamp_s, T_B_S);
  if (found == TfBuffer::Lookup::kFound) return true;
  counters_.add(&NodeCounters::frames_unresolved_frame_id);
  log_.limited(LogLevel::kWarning, kReasonFrameId,
               "dropped a frame in '" + frame_id + "': no transform from the body frame '" +
                   frames_.body + "' on /tf_static (" + toString(found) + ")");
  return false;
}

void FramePairer::checkChildFrame(const nav_msgs::Odometry_& msg) {
  if (msg.child_frame_id_() == frames_.body) return;
  counters_.add(&NodeCounters::odometry_child_frame_mismatch);
  log_.limited(LogLevel::kWarning, kReasonChildFrame,
               "an Odometry with child_frame_id '" + msg.child_frame_id_() +
                   "', not the body frame '" + frames_.body +
                   "': its pose is used as the body's; set dds.body_frame (and dds.frame_prefix)");
}

void FramePairer::handle(sensor_msgs::CameraInfo_& msg) {
  // Checked with each image it is used for (decodeDepthImage()): a bad one rejects those.
  camera_info_ = std::move(msg);
  have_camera_info_ = true;
}

/// PoseStamped or Odometry.
template <typename PoseMsg>
void FramePairer::handle(PoseMsg& msg) {
  double stamp_s = 0.0;
  Transform T_W_B;
  counters_.add(&NodeCounters::poses_received);
  const DecodeStatus status = decodePose(msg, &stamp_s, &T_W_B);
  if (!status.ok()) return malformed("pose", status);
  checkChildFrame(msg);
  addPose(stamp_s, T_W_B);
}

void FramePairer::addPose(double stamp_s, const Transform& T_W_B) {
  const std::uint64_t restarts = poses_.counters().restarts;
  const PoseBuffer::AddResult result = poses_.add(stamp_s, T_W_B);
  if (result != PoseBuffer::AddResult::kAdded) {
    counters_.add(&NodeCounters::poses_rejected);
    const char* why = result == PoseBuffer::AddResult::kOutOfOrder ? "not newer than the last pose"
                      : result == PoseBuffer::AddResult::kFuture
                          ? "far ahead of the last pose (used if the next pose confirms it)"
                          : "not a valid pose";
    std::ostringstream m;
    m << "rejected a pose stamped " << std::fixed << stamp_s << ": " << why;
    log_.limited(LogLevel::kWarning, kReasonPose, m.str());
    return;
  }
  if (poses_.counters().restarts > restarts) {
    std::ostringstream m;
    m << "the pose stream resumed after a pause: pairing restarts from the poses stamped "
      << std::fixed << poses_.oldestStamp() << " and " << stamp_s;
    log_.always(LogLevel::kWarning, m.str());
  }
  releaseWaiting();  // frames waiting for this pose, in stamp order
}

void FramePairer::releaseWaiting() {
  while (!waiting_.empty() &&
         tryPlace(waiting_.front().frame) != PoseBuffer::LookupResult::kPending) {
    waiting_.pop_front();
  }
}

PoseBuffer::LookupResult FramePairer::tryPlace(Frame& frame) {
  Transform T_W_B;
  const double stamp_s = stampOf(frame);
  const PoseBuffer::LookupResult found = poses_.lookup(stamp_s, &T_W_B);
  if (found == PoseBuffer::LookupResult::kFound) {
    std::visit([&](auto& f) { f.T_W_B = T_W_B; }, frame);
    const FrameStatus status =
        std::visit([&](auto& f) { return engine_.submit(std::move(f)); }, frame);
    counters_.add(status == FrameStatus::kAccepted ? &NodeCounters::frames_submitted
                                                   : &NodeCounters::frames_engine_rejected);
  } else if (found == PoseBuffer::LookupResult::kNoPose) {
    noPose(stamp_s);
  } else if (found == PoseBuffer::LookupResult::kAcrossJump) {
    counters_.add(&NodeCounters::frames_across_pose_jump);
    std::ostringstream m;
    m << "dropped a frame stamped " << std::fixed << stamp_s
      << ": the pose stream jumps around it (faster than " << poses_.config().max_speed_mps
      << " m/s or " << poses_.config().max_rotation_rate_dps << " deg/s), not interpolated";
    log_.limited(LogLevel::kWarning, kReasonJump, m.str());
  }
  return found;
}

void FramePairer::noPose(double stamp_s) {
  counters_.add(&NodeCounters::frames_without_pose);
  std::ostringstream m;
  m << "dropped a frame stamped " << std::fixed << stamp_s << ": no pose within "
    << dds_.pose_tolerance_s << " s of it";
  log_.limited(LogLevel::kWarning, kReasonNoPose, m.str());
}

void FramePairer::place(Frame&& frame) {
  double newest = 0.0;
  const double stamp_s = stampOf(frame);
  if (poses_.newestStamp(&newest) && stamp_s > newest + dds_.max_future_s) {
    counters_.add(&NodeCounters::frames_future);
    std::ostringstream m;
    m << "dropped a frame stamped " << std::fixed << stamp_s << ": " << stamp_s - newest
      << " s after the newest pose";
    log_.limited(LogLevel::kWarning, kReasonFuture, m.str());
    return;
  }
  if (waiting_.empty() && tryPlace(frame) != PoseBuffer::LookupResult::kPending) return;
  if (!waiting_.empty() && stamp_s <= stampOf(waiting_.back().frame)) {
    // Waiting frames stay in stamp order; the engine would refuse this one anyway.
    counters_.add(&NodeCounters::frames_engine_rejected);
    return;
  }
  if (waiting_.size() >= kMaxPending) {
    noPose(stampOf(waiting_.front().frame));
    waiting_.pop_front();
  }
  waiting_.push_back({std::move(frame), std::chrono::steady_clock::now()});
  releaseWaiting();  // a pose may already cover it (frames queued behind an earlier waiting one)
}

void FramePairer::expireWaiting() {
  while (!waiting_.empty() &&
         secondsBetween(waiting_.front().since, SteadyClock::now()) > kPoseWait_s) {
    noPose(stampOf(waiting_.front().frame));
    waiting_.pop_front();
  }
}

void FramePairer::dropWaiting() {
  if (!waiting_.empty()) counters_.add(&NodeCounters::frames_without_pose, waiting_.size());
  waiting_.clear();
}

}  // namespace mlmap::dds::node
