#include "map_persistence.h"

#include "mlmap/core/stopwatch.h"
#include "mlmap/map_io/map_export.h"
#include "mlmap/map_io/map_file.h"

#include <chrono>
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <stdexcept>
#include <string>

namespace mlmap::dds::node {

MapPersistence::MapPersistence(const MapFileOptions& options, const MapConfig& map,
                               MapEngine& engine, CounterSink& counters, NodeLog& log)
    : options_(options), map_(map), engine_(engine), counters_(counters), log_(log) {}

MapPersistence::~MapPersistence() { stopPeriodicSaves(); }

bool MapPersistence::load() {
  const bool loaded = loadIfAsked();
  checkSavePath(loaded);
  return loaded;
}

bool MapPersistence::loadIfAsked() {
  if (options_.load_path.empty()) return false;
  if (options_.load_missing_ok && !std::filesystem::exists(options_.load_path)) {
    log_.always(LogLevel::kInfo, "no map at '" + options_.load_path + "' yet: starting empty");
    return false;
  }
  const auto start = SteadyClock::now();
  MapState state;
  try {
    state = io::loadMapFile(options_.load_path);
  } catch (const std::bad_alloc&) {
    throw std::runtime_error(options_.load_path + ": out of memory while loading the map");
  }
  io::checkMapMatchesConfig(state, map_, options_.load_path);
  engine_.restoreState(state);
  std::ostringstream m;
  m << std::fixed << std::setprecision(1) << "loaded map '" << options_.load_path << "' in "
    << msSince(start) << " ms: " << io::occupiedVoxels(state).size() << " occupied voxels ("
    << state.globalVoxelCount() << " in the global map), " << state.frames_mapped
    << " frames mapped before";
  if (state.has_last_stamp)
    m << ", last stamp " << std::setprecision(3) << state.last_stamp_s << " s";
  log_.always(LogLevel::kInfo, m.str());
  return true;
}

void MapPersistence::checkSavePath(bool loaded) {
  const std::string& path = options_.save_path;
  if (path.empty()) return;
  const std::size_t leftovers = removeLeftoverTemporaries(path);
  if (leftovers > 0) {
    log_.always(LogLevel::kWarning, "removed " + std::to_string(leftovers) +
                                        " temporary file(s) of an interrupted save of '" + path +
                                        "'");
  }
  std::error_code ec;
  if (options_.overwrite || !std::filesystem::exists(path, ec)) return;
  if (loaded && std::filesystem::equivalent(path, options_.load_path, ec)) return;
  throw std::runtime_error(
      "map_file.save_path '" + path +
      "' already exists and is not the map this node loaded: its first save would replace it. "
      "Set map_file.load_path to it to go on mapping it, choose another save_path, or set "
      "map_file.overwrite: true");
}

MapPersistence::SaveOutcome MapPersistence::save(const char* why) {
  const std::string& path = options_.save_path;
  std::lock_guard<std::mutex> one_at_a_time(save_mutex_);
  SaveOutcome outcome;
  try {
    if (path.empty()) {
      throw std::runtime_error("no map file is configured (map_file.save_path is empty)");
    }
    const auto start = SteadyClock::now();
    const MapState state = engine_.exportState();
    io::saveMapFile(state, path);
    counters_.mapSaved(true);
    std::ostringstream m;
    m << std::fixed << std::setprecision(1) << why << ": saved the map to '" << path << "' in "
      << msSince(start) << " ms (" << state.frames_mapped << " frames mapped, "
      << state.globalVoxelCount() << " global voxels)";
    outcome = {true, m.str()};
    log_.always(LogLevel::kInfo, outcome.message);
  } catch (const std::exception& e) {
    counters_.mapSaved(false);
    outcome = {false, std::string(why) +
                          ": map not saved (the previous file, if any, is unchanged): " + e.what()};
    log_.always(LogLevel::kError, outcome.message);
  }
  return outcome;
}

void MapPersistence::startPeriodicSaves() {
  if (options_.save_period_s > 0.0) thread_ = std::thread([this] { saveLoop(); });
}

void MapPersistence::stopPeriodicSaves() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void MapPersistence::saveLoop() {
  const auto period = std::chrono::duration<double>(options_.save_period_s);
  std::unique_lock<std::mutex> lock(mutex_);
  while (!cv_.wait_for(lock, period, [this] { return stop_; })) {
    lock.unlock();
    save("periodic save");
    lock.lock();
  }
}

}  // namespace mlmap::dds::node
