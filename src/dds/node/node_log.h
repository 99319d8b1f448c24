#pragma once
/// @file
/// The node's log: rare lines always (map files, discovery), the rest at most once per second
/// and reason (bad input can arrive at sensor rate).

#include "mlmap/pipeline/rate_limited_log.h"

#include <string>

namespace mlmap::dds::node {

/// Why a line is logged; each reason is limited on its own.
enum Reason : int {
  kReasonMalformed,
  kReasonNoPose,
  kReasonFuture,
  kReasonJump,
  kReasonPose,
  kReasonNoInfo,
  kReasonHandover,
  kReasonEngine,
  kReasonDds,
  kReasonQos,
  kReasonMapGrid,
  kReasonFrameId,     ///< a cloud / image frame_id not the sensor frame, or not resolved
  kReasonChildFrame,  ///< an Odometry child_frame_id not the body frame
  kReasonTfMissing,   ///< map_odom: odom -> body missing at a pose's stamp
  kReasonFleet,       ///< dds.fleet.subscribe: another vehicle's submap refused
  kReasonCount
};

/// The node's sink, unlimited and limited. Thread-safe.
class NodeLog {
 public:
  explicit NodeLog(const LogSink& sink) : sink_(sink), limited_(sink, kReasonCount) {}

  /// A line that must not be merged with others (map files, publishers coming and going).
  void always(LogLevel level, const std::string& message) const {
    if (sink_) sink_(level, message);
  }
  /// At most one line per second for `reason` (the next one says how many were suppressed).
  void limited(LogLevel level, Reason reason, const std::string& message) {
    limited_.log(level, reason, message);
  }

 private:
  LogSink sink_;
  RateLimitedLog limited_;
};

}  // namespace mlmap::dds::node
