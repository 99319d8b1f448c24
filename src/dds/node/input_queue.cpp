#include "input_queue.h"

namespace mlmap::dds::node {

bool isFrame(const Input& input) {
  return std::holds_alternative<CloudSample>(input) ||
         std::holds_alternative<sensor_msgs::Image_>(input);
}

InputQueue::PushResult InputQueue::push(Input&& input) {
  bool dropped = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (closed_) return PushResult::kRefused;
    if (isFrame(input)) {
      if (frames_ >= kMaxFrames) {
        for (auto it = inputs_.begin(); it != inputs_.end(); ++it) {
          if (isFrame(*it)) {
            inputs_.erase(it);
            --frames_;
            dropped = true;
            break;
          }
        }
      }
      ++frames_;
    } else if (inputs_.size() - frames_ >= kMaxOther) {
      return PushResult::kRefused;
    }
    inputs_.push_back(std::move(input));
  }
  cv_.notify_one();
  return dropped ? PushResult::kQueuedOldestFrameDropped : PushResult::kQueued;
}

std::optional<Input> InputQueue::pop(std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait_for(lock, timeout, [this] { return closed_ || !inputs_.empty(); });
  if (inputs_.empty()) return std::nullopt;
  Input input = std::move(inputs_.front());
  inputs_.pop_front();
  if (isFrame(input)) --frames_;
  return input;
}

void InputQueue::close() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = true;
  }
  cv_.notify_all();
}

bool InputQueue::finished() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return closed_ && inputs_.empty();
}

}  // namespace mlmap::dds::node
