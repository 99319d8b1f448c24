#include "mlmap/apps/stop_signal.h"

#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <mutex>
#include <thread>

namespace mlmap::apps {
namespace {

// Lock-free on every target mlmap builds for: the signal handler reads and writes them.
std::atomic<bool> g_stop{false};
std::atomic<bool> g_exit_at_once{false};
std::atomic<int> g_signal{0};  ///< the last stop signal received
static_assert(std::atomic<bool>::is_always_lock_free, "the signal handler needs lock-free flags");
static_assert(std::atomic<int>::is_always_lock_free, "the signal handler needs lock-free flags");

/// Ends the process as `signo`'s default action does; only async-signal-safe calls.
[[noreturn]] void exitBySignal(int signo) {
  static const char kMessage[] =
      "stop signal during start-up: exiting at once (nothing to save yet)\n";
  (void)!::write(STDERR_FILENO, kMessage, sizeof kMessage - 1);
  // The default action, with the signal unblocked (it is blocked while its handler runs), ends
  // the process as killed by it.
  std::signal(signo, SIG_DFL);
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, signo);
  ::pthread_sigmask(SIG_UNBLOCK, &set, nullptr);
  std::raise(signo);
  // cppcheck-suppress unreachableCode ; raise() returns if the signal stays blocked elsewhere
  ::_exit(128 + signo);
}

extern "C" void onStopSignal(int signo) {
  g_signal.store(signo);
  g_stop.store(true);
  if (g_exit_at_once.load()) exitBySignal(signo);
}

}  // namespace

void installStopHandler() {
  static std::once_flag installed;
  std::call_once(installed, [] {
    std::signal(SIGINT, onStopSignal);
    std::signal(SIGTERM, onStopSignal);
  });
}

bool stopRequested() { return g_stop.load(); }

void requestStop() { g_stop.store(true); }

ExitAtOnceOnStop::ExitAtOnceOnStop() {
  g_exit_at_once.store(true);
  const int signo = g_signal.load();
  if (signo != 0) exitBySignal(signo);  // it came before this phase began
}

ExitAtOnceOnStop::~ExitAtOnceOnStop() { g_exit_at_once.store(false); }

void runUntilStopped(double duration_s, double report_every_s,
                     const std::function<void()>& report) {
  using Clock = std::chrono::steady_clock;
  const auto seconds = [](Clock::time_point from, Clock::time_point to) {
    return std::chrono::duration<double>(to - from).count();
  };
  const auto start = Clock::now();
  auto last_report = start;
  while (!stopRequested()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const auto now = Clock::now();
    if (duration_s > 0 && seconds(start, now) >= duration_s) break;
    if (report_every_s > 0 && seconds(last_report, now) >= report_every_s) {
      last_report = now;
      report();
    }
  }
}

}  // namespace mlmap::apps
