#include "mlmap/datasets/frame_source.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace mlmap::datasets {
namespace {

void checkIndex(std::size_t i, std::size_t size, const char* what) {
  if (i >= size) {
    throw std::out_of_range(std::string(what) + ": frame " + std::to_string(i) + " of " +
                            std::to_string(size));
  }
}

}  // namespace

double stampOf(const SourceFrame& frame) {
  return std::visit([](const auto& f) { return f.stamp_s; }, frame);
}

const Transform& bodyPoseOf(const SourceFrame& frame) {
  return std::visit([](const auto& f) -> const Transform& { return f.T_W_B; }, frame);
}

SourceFrame FrameDirectorySource::read(std::size_t i, SourceFrameInfo* info) const {
  DepthFrame frame = frames_.read(i);
  if (info != nullptr) {
    info->name = frames_.frameName(i);
    info->points_in_file = frame.depth_mm.size() + frame.depth_m.size();
    info->non_finite_dropped = 0;
  }
  return frame;
}

std::string FrameDirectorySource::describe() const {
  return std::to_string(frames_.size()) + " RGB-D frames of " + frames_.directory();
}

SourceFrame CloudSequenceSource::read(std::size_t i, SourceFrameInfo* info) const {
  PointCloudFile file;
  PointCloudFrame frame = clouds_.read(i, &file);
  if (info != nullptr) {
    info->name = clouds_.clouds()[i].file_name;
    info->points_in_file = file.points_in_file;
    info->non_finite_dropped = file.non_finite_dropped;
  }
  return frame;
}

std::string CloudSequenceSource::describe() const {
  return std::to_string(clouds_.size()) + " clouds of " + dir_ + " paired " +
         toString(clouds_.pairing()) + " with " + std::to_string(clouds_.poseCount()) + " poses";
}

SimulatedFlightSource::SimulatedFlightSource(Scenario scenario, const Transform& T_B_S,
                                             const SimulatedTiming& timing)
    : scenario_(std::move(scenario)),
      camera_(scenario_.camera),
      T_B_S_(T_B_S),
      rate_hz_(timing.rate_hz == 0.0 ? scenario_.frame_rate_hz : timing.rate_hz),
      speed_(timing.speed) {
  if (!(rate_hz_ > 0.0) || !std::isfinite(rate_hz_) || !(speed_ > 0.0) || !std::isfinite(speed_)) {
    throw std::invalid_argument("simulated flight: the frame rate and the speed must be positive");
  }
  const double frames = std::floor(scenario_.trajectory.duration_s() * rate_hz_) + 1.0;
  if (!(frames < 1e9)) throw std::invalid_argument("simulated flight: more than 1e9 frames");
  const auto total = static_cast<std::size_t>(frames);
  const double first = std::ceil(timing.start_time_s * rate_hz_);  // may be huge or negative
  first_ = !(first > 0.0) ? 0 : first >= frames ? total : static_cast<std::size_t>(first);
  count_ = total - first_;
}

int SimulatedFlightSource::frameCount(const Scenario& scenario) {
  return static_cast<int>(std::floor(scenario.trajectory.duration_s() * scenario.frame_rate_hz)) +
         1;
}

double SimulatedFlightSource::frameTime(std::size_t i) const {
  return speed_ * static_cast<double>(first_ + i) / rate_hz_;
}

SourceFrame SimulatedFlightSource::read(std::size_t i, SourceFrameInfo* info) const {
  checkIndex(i, count_, "simulated flight");
  const double t = frameTime(i);
  DepthFrame frame;
  frame.T_W_B = scenario_.trajectory.poseAt(t);
  frame.T_B_S = T_B_S_;
  camera_.render(scenario_.world, frame.T_W_B * T_B_S_, t, &frame);
  frame.stamp_s = t;
  if (info != nullptr) {
    info->name = "sim-" + std::to_string(first_ + i);
    info->points_in_file = static_cast<std::size_t>(scenario_.camera.intrinsics.width) *
                           static_cast<std::size_t>(scenario_.camera.intrinsics.height);
    info->non_finite_dropped = 0;
  }
  return frame;
}

std::string SimulatedFlightSource::describe() const {
  std::ostringstream text;
  text << count_ << " simulated depth frames at " << rate_hz_ << " Hz";
  if (speed_ != 1.0) text << ", flown " << speed_ << "x as fast";
  return text.str();
}

}  // namespace mlmap::datasets
