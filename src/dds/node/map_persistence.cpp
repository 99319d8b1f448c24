#include "map_persistence.h"

#include "mlmap/core/stopwatch.h"
#include "mlmap/map_io/map_export.h"
#include "mlmap/map_io/map_file.h"

#include <chrono>
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <string>

namespace mlmap::dds::node {

MapPersistence::MapPersistence(const MapFileOptions& options, const MapConfig& map,
                               MapEngine& engine, CounterSink& counters, NodeLog& log)
    : options_(options), map_(map), engine_(engine), counters_(counters), log_(log) {}

MapPersistence::~MapPersistence() { stopPeriodicSaves(); }

bool MapPersistence::load() {
  if (options_.load_path.empty()) return false;
  if (options_.load_missing_ok && !std::filesystem::exists(options_.load_path)) {
    log_.always(LogLevel::kInfo, "no map at '" + options_.load_path + "' yet: starting empty");
    return false;
  }
  const auto start = SteadyClock::now();
  const MapState state = io::loadMapFile(options_.load_path);
  io::checkMapMatchesConfig(state, map_, options_.load_path);
  engine_.restoreState(state);
  std::ostringstream m;
  m << std::fixed << std::setprecision(1) << "loaded map '" << options_.load_path << "' in "
    << msSince(start) << " ms: " << io::occupiedVoxels(state).size() << " occupied voxels ("
    << state.globalVoxelCount() << " in the global map), " << state.frames_mapped
    << " frames mapped before";
  log_.always(LogLevel::kInfo, m.str());
  return true;
}

void MapPersistence::save(const char* why) {
  const std::string& path = options_.save_path;
  try {
    const auto start = SteadyClock::now();
    const MapState state = engine_.exportState();
    io::saveMapFile(state, path);
    counters_.mapSaved(true);
    std::ostringstream m;
    m << std::fixed << std::setprecision(1) << why << ": saved the map to '" << path << "' in "
      << msSince(start) << " ms (" << state.frames_mapped << " frames mapped, "
      << state.globalVoxelCount() << " global voxels)";
    log_.always(LogLevel::kInfo, m.str());
  } catch (const std::exception& e) {
    counters_.mapSaved(false);
    log_.always(LogLevel::kError, std::string(why) +
                                      ": map not saved (the previous file, if any, is "
                                      "unchanged): " +
                                      e.what());
  }
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
