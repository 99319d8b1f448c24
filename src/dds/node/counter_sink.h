#pragma once
/// @file
/// The node's counters (NodeCounters), written by every thread of the node.

#include "mlmap/dds/node/node_counters.h"

#include <cstdint>
#include <mutex>

namespace mlmap::dds::node {

/// NodeCounters behind a mutex. Thread-safe.
class CounterSink {
 public:
  /// Adds `n` to one counter.
  void add(std::uint64_t NodeCounters::*field, std::uint64_t n = 1) {
    std::lock_guard<std::mutex> lock(mutex_);
    counters_.*field += n;
  }
  /// Moves publishers_matched by `change` (negative when publishers left).
  void addPublishersMatched(std::int64_t change) {
    std::lock_guard<std::mutex> lock(mutex_);
    counters_.publishers_matched = static_cast<std::uint64_t>(
        static_cast<std::int64_t>(counters_.publishers_matched) + change);
  }
  /// Counts a map save that succeeded (`ok`) or failed.
  void mapSaved(bool ok) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++(ok ? counters_.map_saves : counters_.map_saves_failed);
    counters_.last_map_save_failed = !ok;
  }
  /// A consistent copy of every counter.
  [[nodiscard]] NodeCounters snapshot() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return counters_;
  }

 private:
  mutable std::mutex mutex_;
  NodeCounters counters_;
};

}  // namespace mlmap::dds::node
