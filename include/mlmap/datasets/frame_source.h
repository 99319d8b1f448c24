#pragma once
/// @file
/// One interface for every source of frames: RGB-D frame directories, point-cloud sequences with
/// a trajectory, and the simulator (a ROS 2 bag reader is the next one). The replay, the demo,
/// the sensor publisher and the simulated flights of the evaluation read their frames through
/// it, so a new source works in all of them at once.

#include "mlmap/core/types.h"
#include "mlmap/datasets/cloud_sequence.h"
#include "mlmap/datasets/frame_directory.h"
#include "mlmap/datasets/world_yaml.h"
#include "mlmap/sim/depth_camera.h"

#include <cstddef>
#include <memory>
#include <string>
#include <variant>

namespace mlmap::datasets {

/// A frame as the engine takes it (MapEngine::submit() has an overload for each).
using SourceFrame = std::variant<DepthFrame, PointCloudFrame>;

/// The stamp of a frame [s].
[[nodiscard]] double stampOf(const SourceFrame& frame);
/// T_W_B of a frame.
[[nodiscard]] const Transform& bodyPoseOf(const SourceFrame& frame);

/// What a source says of a frame besides the frame itself.
struct SourceFrameInfo {
  std::string name;                    ///< "frame-000015", "1305031102.175304.pcd", "sim-12"
  std::size_t points_in_file = 0;      ///< points (a depth image: pixels) the input held
  std::size_t non_finite_dropped = 0;  ///< of them, not finite: dropped by the reader
};

/// Frames of a recording or a simulation, by index, in stamp order.
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  /// How many frames the source yields.
  [[nodiscard]] virtual std::size_t size() const = 0;
  /// Frame `i`; `info`, when given, gets its name and point counts. Throws std::out_of_range
  /// when `i >= size()` and std::runtime_error naming the input when it cannot be read.
  [[nodiscard]] virtual SourceFrame read(std::size_t i, SourceFrameInfo* info = nullptr) const = 0;
  /// What the source is, for logs: "RGB-D frames of DIR".
  [[nodiscard]] virtual std::string describe() const = 0;
};

/// An RGB-D frame directory (FrameDirectory): depth frames, the camera as the body.
class FrameDirectorySource : public FrameSource {
 public:
  /// Opens `dir` (FrameDirectory's checks and errors).
  explicit FrameDirectorySource(const std::string& dir) : frames_(dir) {}
  [[nodiscard]] std::size_t size() const override { return frames_.size(); }
  [[nodiscard]] SourceFrame read(std::size_t i, SourceFrameInfo* info = nullptr) const override;
  [[nodiscard]] std::string describe() const override;
  /// The directory reader itself (intrinsics, frame numbers).
  [[nodiscard]] const FrameDirectory& frames() const { return frames_; }

 private:
  FrameDirectory frames_;
};

/// Point clouds paired with a trajectory (CloudSequence): point-cloud frames.
class CloudSequenceSource : public FrameSource {
 public:
  /// Opens the clouds of `dir` and the trajectory `poses` (CloudSequence's checks and errors).
  CloudSequenceSource(const std::string& dir, const std::string& poses,
                      const CloudSequenceOptions& options)
      : clouds_(dir, poses, options), dir_(dir) {}
  [[nodiscard]] std::size_t size() const override { return clouds_.size(); }
  [[nodiscard]] SourceFrame read(std::size_t i, SourceFrameInfo* info = nullptr) const override;
  [[nodiscard]] std::string describe() const override;
  /// The sequence itself (pairing rule, clouds without a pose, pose count).
  [[nodiscard]] const CloudSequence& sequence() const { return clouds_; }

 private:
  CloudSequence clouds_;
  std::string dir_;
};

/// When the simulator's frames are taken.
struct SimulatedTiming {
  double rate_hz = 0.0;       ///< frames per second; 0: the scenario's frame rate
  double speed = 1.0;         ///< flight seconds per second of frame time (> 1: a faster flight)
  double start_time_s = 0.0;  ///< the first frame is the first at or after this time [s]
};

/// The simulator: depth frames of `scenario`'s camera, mounted on the body at T_B_S, rendered
/// along its trajectory. Frame i of the whole trajectory shows flight time speed x i / rate_hz;
/// there are floor(duration x rate_hz) + 1 of them, those before start_time_s left out.
/// Rendering is deterministic: the same frame twice is the same image.
class SimulatedFlightSource : public FrameSource {
 public:
  SimulatedFlightSource(Scenario scenario, const Transform& T_B_S,
                        const SimulatedTiming& timing = {});
  [[nodiscard]] std::size_t size() const override { return count_; }
  [[nodiscard]] SourceFrame read(std::size_t i, SourceFrameInfo* info = nullptr) const override;
  [[nodiscard]] std::string describe() const override;
  /// The scenario flown (its world is the ground truth).
  [[nodiscard]] const Scenario& scenario() const { return scenario_; }
  /// Flight time of frame `i` [s] (its stamp).
  [[nodiscard]] double frameTime(std::size_t i) const;

  /// Frames the whole trajectory yields at the scenario's frame rate.
  [[nodiscard]] static int frameCount(const Scenario& scenario);

 private:
  Scenario scenario_;
  sim::DepthCamera camera_;
  Transform T_B_S_;
  double rate_hz_ = 0.0;
  double speed_ = 1.0;
  std::size_t first_ = 0;  ///< index of frame 0 on the whole trajectory
  std::size_t count_ = 0;
};

}  // namespace mlmap::datasets
