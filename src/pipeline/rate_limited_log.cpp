#include "mlmap/pipeline/rate_limited_log.h"

#include <algorithm>
#include <chrono>

namespace mlmap {

RateLimitedLog::RateLimitedLog(LogSink sink, std::size_t reasons, double interval_s)
    : sink_(std::move(sink)), interval_s_(interval_s), limits_(std::max<std::size_t>(reasons, 1)) {}

void RateLimitedLog::log(LogLevel level, int reason, const std::string& message) {
  if (!sink_) return;
  std::uint64_t suppressed = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    Limit& limit = limits_[static_cast<std::size_t>(reason) % limits_.size()];
    const double now_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
    if (now_s - limit.last_s < interval_s_) {
      ++limit.suppressed;
      return;
    }
    limit.last_s = now_s;
    suppressed = limit.suppressed;
    limit.suppressed = 0;
  }
  if (suppressed > 0) {
    sink_(level, message + " (" + std::to_string(suppressed) + " similar since the last report)");
  } else {
    sink_(level, message);
  }
}

}  // namespace mlmap
