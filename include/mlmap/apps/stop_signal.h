#pragma once
/// @file
/// The programs' stop request: SIGINT and SIGTERM set a flag that the programs' loops poll. A
/// phase that cannot poll and has nothing to save (a node's start-up: loading its map, creating
/// its DDS entities) holds an ExitAtOnceOnStop instead: a signal then ends the process at once,
/// so a supervisor's SIGTERM works in every phase.

#include <functional>

namespace mlmap::apps {

/// Installs the handler of SIGINT and SIGTERM that sets the stop flag (once per process: later
/// calls do nothing).
void installStopHandler();

/// True once SIGINT or SIGTERM arrived (or requestStop() was called).
[[nodiscard]] bool stopRequested();

/// Sets the stop flag, as the signals do.
void requestStop();

/// Waits until a stop is requested or `duration_s` seconds have passed (0: no limit), polling
/// every 50 ms and calling `report` every `report_every_s` seconds (0: never): the main loop of
/// the programs that serve until stopped (mlmap_node, mlmap_fleet).
void runUntilStopped(double duration_s, double report_every_s, const std::function<void()>& report);

/// While an object of this class lives, SIGINT and SIGTERM (with installStopHandler() called)
/// end the process at once, as the signal's default action does (a supervisor sees "terminated
/// by SIGTERM"), after one line on stderr. A signal that arrived before it was made ends the
/// process when it is made. Not nestable.
class ExitAtOnceOnStop {
 public:
  ExitAtOnceOnStop();
  ~ExitAtOnceOnStop();
  ExitAtOnceOnStop(const ExitAtOnceOnStop&) = delete;
  ExitAtOnceOnStop& operator=(const ExitAtOnceOnStop&) = delete;
};

}  // namespace mlmap::apps
