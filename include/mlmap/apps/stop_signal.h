#pragma once
/// @file
/// The programs' stop request: SIGINT and SIGTERM set a flag that the programs' loops poll.

namespace mlmap::apps {

/// Installs the handler of SIGINT and SIGTERM that sets the stop flag (once per process: later
/// calls do nothing).
void installStopHandler();

/// True once SIGINT or SIGTERM arrived (or requestStop() was called).
[[nodiscard]] bool stopRequested();

/// Sets the stop flag, as the signals do.
void requestStop();

}  // namespace mlmap::apps
