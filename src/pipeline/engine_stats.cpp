#include "mlmap/pipeline/engine_stats.h"

#include <algorithm>
#include <cmath>

namespace mlmap {

double sortedQuantile(const std::vector<double>& sorted, double q) {
  const auto i = static_cast<std::size_t>(std::lround(q * static_cast<double>(sorted.size() - 1)));
  return sorted[std::min(i, sorted.size() - 1)];
}

TimingSummary summarizeTimings(std::vector<double> values_ms) {
  TimingSummary s;
  s.samples = values_ms.size();
  if (values_ms.empty()) return s;
  std::sort(values_ms.begin(), values_ms.end());
  s.median_ms = sortedQuantile(values_ms, 0.5);
  s.p99_ms = sortedQuantile(values_ms, 0.99);
  s.max_ms = values_ms.back();
  double sum = 0.0;
  for (double v : values_ms) sum += v;
  s.mean_ms = sum / static_cast<double>(values_ms.size());
  return s;
}

void TimingWindow::add(double ms) {
  if (values_ms_.size() < kCapacity) {
    values_ms_.push_back(ms);
  } else {
    values_ms_[next_] = ms;
  }
  next_ = (next_ + 1) % kCapacity;
}

EngineStats EngineStatsRecorder::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  EngineStats s = record_.stats;
  s.awareness = record_.awareness_ms.summary();
  s.local_global = record_.local_ms.summary();
  s.total = record_.total_ms.summary();
  return s;
}

}  // namespace mlmap
