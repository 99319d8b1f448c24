#pragma once
/// @file
/// The node's map file (`map_file:` section): loaded at start, saved at shutdown and
/// periodically.

#include "counter_sink.h"
#include "node_log.h"

#include "mlmap/dds/node/node_config.h"
#include "mlmap/pipeline/map_engine.h"

#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

namespace mlmap::dds::node {

/// Loads and saves `engine`'s layers as map_file.* says; every outcome is logged, saves are
/// counted (map_saves, map_saves_failed).
class MapPersistence {
 public:
  MapPersistence(const MapFileOptions& options, const MapConfig& map, MapEngine& engine,
                 CounterSink& counters, NodeLog& log);
  ~MapPersistence();
  MapPersistence(const MapPersistence&) = delete;
  MapPersistence& operator=(const MapPersistence&) = delete;

  /// Loads load_path into the engine; false when there is nothing to load (none set, or
  /// missing with load_missing_ok). Then removes what interrupted saves left beside save_path.
  /// Throws std::runtime_error naming the file when the map cannot be used (unreadable,
  /// corrupt, too large, or made with another resolution, window or log-odds model), or when
  /// save_path names an existing file that was not loaded and map_file.overwrite is false.
  bool load();
  /// What a save did: whether the file was written, and the line logged about it.
  struct SaveOutcome {
    bool ok = false;      ///< the file was written
    std::string message;  ///< what happened (the path and the size, or why it failed)
  };
  /// Saves to save_path (atomically: the previous file stays when this fails); logs the outcome,
  /// never throws. `why` starts the log line ("shutdown", "periodic save"). Saves from several
  /// threads (periodic, shutdown, the save_map service) run one at a time.
  SaveOutcome save(const char* why);
  /// Saves every save_period_s from a thread of its own (nothing when the period is 0).
  void startPeriodicSaves();
  /// Stops the periodic saves (waits for one under way). Idempotent.
  void stopPeriodicSaves();

 private:
  bool loadIfAsked();
  void checkSavePath(bool loaded);
  void saveLoop();

  const MapFileOptions& options_;
  const MapConfig& map_;
  MapEngine& engine_;
  CounterSink& counters_;
  NodeLog& log_;
  std::thread thread_;
  std::mutex save_mutex_;  ///< one save at a time
  std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false;
};

}  // namespace mlmap::dds::node
