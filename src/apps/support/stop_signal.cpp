#include "mlmap/apps/stop_signal.h"

#include <atomic>
#include <csignal>
#include <mutex>

namespace mlmap::apps {
namespace {

std::atomic<bool> g_stop{false};  // lock-free on every target mlmap builds for
static_assert(std::atomic<bool>::is_always_lock_free, "the signal handler needs a lock-free flag");

extern "C" void onStopSignal(int) { g_stop.store(true); }

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

}  // namespace mlmap::apps
