#pragma once
/// @file
/// Rate-limited log lines: bad input can arrive at sensor rate, its log must not.

#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

namespace mlmap {

/// Severity of a log message.
enum class LogLevel { kInfo, kWarning, kError };
/// Receives log lines (default: none). Called from the thread that saw the problem.
using LogSink = std::function<void(LogLevel, const std::string&)>;

/// Passes at most one line per reason and interval to a sink; the next line that passes says how
/// many were suppressed since. Thread-safe.
class RateLimitedLog {
 public:
  /// `reasons`: number of distinct reasons (reason ids are taken modulo it).
  explicit RateLimitedLog(LogSink sink, std::size_t reasons, double interval_s = 1.0);
  /// Logs `message` unless a line with the same reason passed less than the interval ago.
  void log(LogLevel level, int reason, const std::string& message);

 private:
  struct Limit {
    double last_s = -1e300;
    std::uint64_t suppressed = 0;
  };
  LogSink sink_;
  double interval_s_;
  std::mutex mutex_;
  std::vector<Limit> limits_;
};

}  // namespace mlmap
