#include "mlmap/planning/planning_layers.h"

#include "mlmap/core/stopwatch.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <utility>

namespace mlmap {
namespace {

using Clock = SteadyClock;

}  // namespace

PlanningLayers::PlanningLayers(const MapConfig& config, bool own_thread,
                               std::function<void(std::uint64_t, double)> esdf_published)
    : config_(config),
      own_thread_(own_thread && config.esdf.enabled),
      snapshot_(std::make_shared<const MapSnapshot>(nullptr, nullptr, nullptr, 0, 0.0,
                                                    Transform::Identity())),
      esdf_(config.esdf),
      esdf_published_(std::move(esdf_published)) {
  if (own_thread_) thread_ = std::thread([this] { planningLoop(); });
}

PlanningLayers::~PlanningLayers() {
  {
    std::lock_guard<std::mutex> lock(job_mutex_);
    stopping_ = true;
  }
  job_cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

// A buffer of the pool that no published snapshot holds any more, or a new one. Only the owner
// thread of the pool calls this; a use count of 1 (the pool's own) cannot grow behind its back
// because readers only reach buffers through snapshots.
template <typename T, typename... Args>
std::shared_ptr<T> PlanningLayers::reuse(std::vector<std::shared_ptr<T>>* pool,
                                         const Args&... args) {
  for (const std::shared_ptr<T>& p : *pool) {
    if (p.use_count() == 1) return p;
  }
  pool->push_back(std::make_shared<T>(args...));
  return pool->back();
}

std::shared_ptr<const MapSnapshot> PlanningLayers::snapshot() const {
  std::lock_guard<std::mutex> lock(snapshot_mutex_);
  return snapshot_;
}

void PlanningLayers::publish(std::shared_ptr<const LocalWindow> window,
                             std::shared_ptr<const ProjectedGrid> grid, PublishedEsdf esdf,
                             bool keep_esdf, std::uint64_t frame, double stamp_s,
                             const Transform& T_W_B) {
  std::shared_ptr<const MapSnapshot> old;
  std::lock_guard<std::mutex> lock(snapshot_mutex_);
  // Read and replace under one lock, so that a field the planning thread published meanwhile
  // is carried over rather than lost.
  std::uint64_t esdf_frame = frame;
  if (keep_esdf) {
    esdf = {snapshot_->esdfPtr(), snapshot_->esdfGridPtr()};
    esdf_frame = snapshot_->esdfFrame();
  }
  old = std::exchange(snapshot_, std::make_shared<const MapSnapshot>(
                                     std::move(window), std::move(grid), std::move(esdf.map), frame,
                                     stamp_s, T_W_B, esdf_frame, std::move(esdf.query_grid)));
}

void PlanningLayers::update(const LocalMap& local, const GlobalMap& global, std::uint64_t frame,
                            double stamp_s, const Transform& T_W_B) {
  const Clock::time_point start = Clock::now();
  const std::shared_ptr<LocalWindow> window = reuse(&window_pool_);
  local.updateWindowCopy(window.get());  // pooled: only the submaps changed since it was filled
  const double copy_ms = msSince(start);
  const Eigen::Vector3d body_W = T_W_B.translation();
  const double grid_ms =
      config_.projected_grid.enabled ? updateGrid(local, global, *window, body_W) : -1.0;
  const EsdfDecision decision = decideEsdf(local, *window, body_W, stamp_s);

  PublishedEsdf esdf;
  double esdf_ms = -1.0;
  EsdfJob job{window, body_W, frame, local.changeClock(), {}};
  if (decision.due) {
    constexpr int kN = LocalMapConfig::kSubmapsPerAxis;
    const SubmapIndex first = local.submapOf(window->min_index);
    job.submap_stamps.reserve(static_cast<std::size_t>(kN) * kN * kN);
    for (int sx = 0; sx < kN; ++sx)
      for (int sy = 0; sy < kN; ++sy)
        for (int sz = 0; sz < kN; ++sz) {
          job.submap_stamps.push_back(local.submapStateChangedAt(first + SubmapIndex(sx, sy, sz)));
        }
  }
  const bool compute_here = decision.due && !own_thread_;
  if (compute_here) {
    const Clock::time_point esdf_start = Clock::now();
    esdf = computeEsdf(job);
    esdf_ms = msSince(esdf_start);
  }
  const Clock::time_point publish_start = Clock::now();
  publish(window, grid_, std::move(esdf), /*keep_esdf=*/!compute_here, frame, stamp_s, T_W_B);
  const double snapshot_ms = copy_ms + msSince(publish_start);
  bool superseded = false;
  if (decision.due && own_thread_) {
    {
      std::lock_guard<std::mutex> lock(job_mutex_);
      superseded = has_job_;
      job_ = job;
      has_job_ = true;
    }
    job_cv_.notify_all();
  }
  recordUpdate(snapshot_ms, grid_ms, esdf_ms, frame, decision, superseded);
}

// 2D grid: rebuilt whole when the window or the band's layers moved, or when the global map it
// includes changed (submaps retired or restored, which moves the window, or a loaded map);
// otherwise only the columns of the band's submaps whose values changed since the last grid are
// projected again.
double PlanningLayers::updateGrid(const LocalMap& local, const GlobalMap& global,
                                  const LocalWindow& window, const Eigen::Vector3d& body_W) {
  const ProjectedGridConfig& gc = config_.projected_grid;
  const Clock::time_point grid_start = Clock::now();
  double grid_ms = -1.0;
  const double offset = gc.relative_band ? body_W.z() : 0.0;
  int band_k0 = 0;
  int band_k1 = 0;
  bandLayers(gc.band_min_m + offset, gc.band_max_m + offset, window.resolution_m, &band_k0,
             &band_k1);
  const int window_z0 = window.min_index.z();
  const int window_z1 = window_z0 + window.size.z();
  // With the global map included, a band reaching beyond the window adds retired voxels above
  // or below the window's columns: those columns then do not depend on the window alone.
  const bool columns_from_window =
      !gc.include_global || (band_k0 >= window_z0 && band_k1 <= window_z1);
  const bool global_changed = gc.include_global && global.modifications() != grid_global_;
  const bool rebuild = grid_ == nullptr || window.min_index != grid_window_min_ ||
                       band_k0 != grid_band_k0_ || band_k1 != grid_band_k1_ ||
                       !columns_from_window || global_changed;
  if (rebuild) {
    const std::shared_ptr<ProjectedGrid> grid = reuse(&grid_pool_);
    projectToGrid(window, &global, gc, body_W.z(), grid.get());
    grid_ = grid;
    grid_window_min_ = window.min_index;
    grid_band_k0_ = band_k0;
    grid_band_k1_ = band_k1;
    grid_global_ = global.modifications();
    grid_ms = msSince(grid_start);
    ++grid_rebuilds_;
  } else if (window.size.prod() > 0 && patchGridColumns(local, window, band_k0, band_k1)) {
    grid_ms = msSince(grid_start);
  }
  grid_clock_ = local.changeClock();
  return grid_ms;
}

bool PlanningLayers::patchGridColumns(const LocalMap& local, const LocalWindow& window, int band_k0,
                                      int band_k1) {
  // Submap columns (x, y) with a changed submap in the band's layers.
  constexpr int kN = LocalMapConfig::kSubmapsPerAxis;
  const Eigen::Vector3i cells = local.config().submap_cells();
  const SubmapIndex first = local.submapOf(window.min_index);
  const int window_z0 = window.min_index.z();
  std::array<std::array<bool, kN>, kN> dirty{};  // [x][y]
  bool any = false;
  for (int sz = 0; sz < kN; ++sz) {
    const int z_lo = window_z0 + sz * cells.z();
    if (z_lo + cells.z() <= band_k0 || z_lo >= band_k1) continue;
    for (int sx = 0; sx < kN; ++sx) {
      for (int sy = 0; sy < kN; ++sy) {
        if (local.submapChangedAt(first + SubmapIndex(sx, sy, sz)) > grid_clock_) {
          dirty[static_cast<std::size_t>(sx)][static_cast<std::size_t>(sy)] = true;
          any = true;
        }
      }
    }
  }
  if (!any) return false;
  const std::shared_ptr<ProjectedGrid> grid = reuse(&grid_pool_);
  *grid = *grid_;  // the published grid stays as it is; the copy is patched
  for (int sx = 0; sx < kN; ++sx) {
    for (int sy = 0; sy < kN; ++sy) {
      if (!dirty[static_cast<std::size_t>(sx)][static_cast<std::size_t>(sy)]) continue;
      const Eigen::Vector2i begin(sx * cells.x(), sy * cells.y());
      reprojectWindowColumns(window, config_.projected_grid, begin, begin + cells.head<2>(),
                             grid.get());
    }
  }
  grid_ = grid;
  return true;
}

// ESDF: due when something changed and the rate allows.
PlanningLayers::EsdfDecision PlanningLayers::decideEsdf(const LocalMap& local,
                                                        const LocalWindow& window,
                                                        const Eigen::Vector3d& body_W,
                                                        double stamp_s) {
  EsdfDecision d;
  if (!config_.esdf.enabled || window.size.prod() <= 0) return d;
  Eigen::Vector3i size;
  const VoxelIndex box_min = esdfBoxMin(window, body_W, &size);
  // Unchanged: the box is where it was and no voxel state inside it changed (submaps of the box
  // with a later state stamp than the last ESDF's).
  d.unchanged = box_min == esdf_box_min_ && size == esdf_box_size_;
  if (d.unchanged) {
    const SubmapIndex m0 = local.submapOf(box_min);
    const SubmapIndex m1 = local.submapOf(box_min + size - VoxelIndex::Ones());
    for (int x = m0.x(); x <= m1.x() && d.unchanged; ++x)
      for (int y = m0.y(); y <= m1.y() && d.unchanged; ++y)
        for (int z = m0.z(); z <= m1.z() && d.unchanged; ++z) {
          d.unchanged = local.submapStateChangedAt(SubmapIndex(x, y, z)) <= esdf_clock_;
        }
  }
  d.rate_limited = !d.unchanged && config_.esdf.max_rate_hz > 0.0 &&
                   stamp_s - esdf_stamp_s_ < 1.0 / config_.esdf.max_rate_hz;
  if (!d.unchanged && !d.rate_limited) {
    d.due = true;
    esdf_clock_ = local.changeClock();
    esdf_box_min_ = box_min;
    esdf_box_size_ = size;
    esdf_stamp_s_ = stamp_s;
  }
  return d;
}

void PlanningLayers::recordUpdate(double snapshot_ms, double grid_ms, double esdf_ms,
                                  std::uint64_t frame, const EsdfDecision& decision,
                                  bool superseded) {
  std::size_t bytes = 0;
  for (const auto& w : window_pool_) bytes += w->log_odds.capacity() * sizeof(LogOddsQ);
  for (const auto& g : grid_pool_) bytes += g->cells.capacity();
  std::lock_guard<std::mutex> lock(stats_mutex_);
  stats_.snapshot_bytes = bytes;
  ++stats_.snapshots;
  stats_.last_snapshot_ms = snapshot_ms;
  stats_.max_snapshot_ms = std::max(stats_.max_snapshot_ms, snapshot_ms);
  stats_.grid_rebuilds = grid_rebuilds_;
  if (grid_ms >= 0.0) {
    ++stats_.grid_updates;
    stats_.last_grid_ms = grid_ms;
    stats_.max_grid_ms = std::max(stats_.max_grid_ms, grid_ms);
  }
  if (esdf_ms >= 0.0) {
    ++stats_.esdf_updates;
    stats_.last_esdf_ms = esdf_ms;
    stats_.max_esdf_ms = std::max(stats_.max_esdf_ms, esdf_ms);
    stats_.esdf_frame = frame;
  }
  stats_.esdf_unchanged += decision.unchanged ? 1 : 0;
  stats_.esdf_rate_limited += decision.rate_limited ? 1 : 0;
  stats_.esdf_superseded += superseded ? 1 : 0;
}

VoxelIndex PlanningLayers::esdfBoxMin(const LocalWindow& window, const Eigen::Vector3d& body_W,
                                      Eigen::Vector3i* size) const {
  const double res = window.resolution_m;
  VoxelIndex box_min = window.min_index;
  *size = window.size;
  const VoxelIndex body = voxelIndexOf(body_W, res);
  for (int a = 0; a < 3; ++a) {
    const double edge_m = config_.esdf.box_size_m[a];
    if (!(edge_m > 0.0)) continue;  // 0: the whole window along this axis
    const int cells =
        std::min(window.size[a], std::max(1, static_cast<int>(std::lround(edge_m / res))));
    (*size)[a] = cells;
    box_min[a] = std::clamp(body[a] - cells / 2, window.min_index[a],
                            window.min_index[a] + window.size[a] - cells);
  }
  return box_min;
}

bool PlanningLayers::fillEsdfBox(const EsdfJob& job) {
  const LocalWindow& window = *job.window;
  Eigen::Vector3i size;
  const VoxelIndex box_min = esdfBoxMin(window, job.body_W, &size);
  const Eigen::Vector3i cells = window.size / LocalMapConfig::kSubmapsPerAxis;
  constexpr int kN = LocalMapConfig::kSubmapsPerAxis;
  constexpr std::size_t kSubmaps = static_cast<std::size_t>(kN) * kN * kN;
  const bool in_place = esdf_box_filled_ && box_min == esdf_box_.min_index &&
                        size == esdf_box_.size && window.min_index == esdf_box_window_ &&
                        window.resolution_m == esdf_box_.resolution_m &&
                        job.submap_stamps.size() == kSubmaps && window.size == cells * kN;
  if (!in_place) esdf_box_.reset(box_min, size, window.resolution_m);
  esdf_refilled_.clear();
  const LogOddsModel& model = window.model;
  // Fills the box voxels of window-relative [lo, hi) (clipped to the box).
  const auto fill = [&](const VoxelIndex& lo_window, const VoxelIndex& hi_window) {
    const VoxelIndex lo = (window.min_index + lo_window).cwiseMax(box_min);
    const VoxelIndex hi = (window.min_index + hi_window).cwiseMin(box_min + size);
    if ((hi.array() <= lo.array()).any()) return;
    for (int x = lo.x(); x < hi.x(); ++x) {
      for (int y = lo.y(); y < hi.y(); ++y) {
        const VoxelIndex r = VoxelIndex(x, y, lo.z()) - window.min_index;
        const LogOddsQ* column =
            window.log_odds.data() +
            (static_cast<std::size_t>(r.x()) * static_cast<std::size_t>(window.size.y()) +
             static_cast<std::size_t>(r.y())) *
                static_cast<std::size_t>(window.size.z()) +
            static_cast<std::size_t>(r.z());
        Occupancy* out = &esdf_box_.at(VoxelIndex(x, y, lo.z()));
        for (int z = 0; z < hi.z() - lo.z(); ++z) out[z] = model.state(column[z]);
      }
    }
  };
  if (!in_place) {
    fill(VoxelIndex::Zero(), window.size);
  } else {
    std::size_t i = 0;
    for (int sx = 0; sx < kN; ++sx)
      for (int sy = 0; sy < kN; ++sy)
        for (int sz = 0; sz < kN; ++sz, ++i) {
          if (job.submap_stamps[i] <= esdf_box_clock_) continue;
          const VoxelIndex lo = VoxelIndex(sx, sy, sz).cwiseProduct(cells);
          fill(lo, lo + cells);
          const VoxelIndex lo_box = window.min_index + lo - box_min;  // clipped by the ESDF
          esdf_refilled_.push_back({lo_box, lo_box + cells});
        }
  }
  esdf_box_filled_ = true;
  esdf_box_window_ = window.min_index;
  esdf_box_clock_ = job.clock;
  return in_place;
}

PlanningLayers::PublishedEsdf PlanningLayers::computeEsdf(const EsdfJob& job) {
  // Refilled in place, the box changed only in the refilled submaps: the ESDF compares it with
  // its kept box there alone.
  const bool ok =
      fillEsdfBox(job) ? esdf_.update(esdf_box_, esdf_refilled_) : esdf_.update(esdf_box_);
  PublishedEsdf published = ok ? publishEsdfCopy() : PublishedEsdf{};
  std::size_t bytes = esdf_box_.states.capacity() * sizeof(Occupancy) + esdf_.memoryBytes();
  for (const EsdfCopy& c : esdf_copies_) {
    bytes += c.map->memoryBytes() + c.pending.capacity() * sizeof(std::uint32_t) +
             (c.query_grid ? c.query_grid->memoryBytes() : 0);
  }
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.esdf_bytes = bytes;
    stats_.esdf_full += ok && esdf_.lastUpdate().full ? 1 : 0;
  }
  return published;
}

PlanningLayers::PublishedEsdf PlanningLayers::publishEsdfCopy() {
  // Past this many changed cells a copy is refreshed whole (a contiguous copy is then cheaper).
  const std::size_t whole_above = esdf_.distances().size() / 8;
  const EsdfMap::UpdateStats& u = esdf_.lastUpdate();
  const std::vector<std::uint32_t>& changed = esdf_.changedCells();
  const bool whole = u.full || u.shifted || changed.size() > whole_above;
  for (EsdfCopy& c : esdf_copies_) {
    if (c.stale) continue;
    if (whole || c.pending.size() + changed.size() > whole_above) {
      c.stale = true;
      c.pending.clear();
    } else {
      c.pending.insert(c.pending.end(), changed.begin(), changed.end());
    }
  }
  EsdfCopy* copy = nullptr;
  for (EsdfCopy& c : esdf_copies_) {
    std::lock_guard<std::mutex> lock(c.lease->mutex);
    if (!c.lease->held) {  // no snapshot holds it
      c.lease->held = true;
      copy = &c;
      break;
    }
  }
  if (copy == nullptr) {
    EsdfCopy fresh;
    fresh.map = std::make_shared<EsdfMap>(config_.esdf);
    esdf_copies_.push_back(std::move(fresh));
    copy = &esdf_copies_.back();
    copy->lease->held = true;  // not yet shared with any other thread
  }
  const bool whole_copy = copy->stale || !copy->map->copyCells(esdf_, copy->pending);
  if (whole_copy) copy->map->copyFrom(esdf_);
  if (config_.esdf.query_grid) {
    if (!copy->query_grid) copy->query_grid = std::make_shared<EsdfQueryGrid>();
    if (whole_copy || !copy->query_grid->syncCells(*copy->map, copy->pending)) {
      copy->query_grid->build(*copy->map);
    }
  }
  copy->pending.clear();
  copy->stale = false;
  // What snapshots hold: the copy, and a release that hands it back to the pool.
  struct Holder {
    Holder(std::shared_ptr<EsdfMap> m, std::shared_ptr<EsdfQueryGrid> g,
           std::shared_ptr<EsdfLease> l)
        : map(std::move(m)), query_grid(std::move(g)), lease(std::move(l)) {}
    Holder(const Holder&) = delete;
    Holder& operator=(const Holder&) = delete;
    ~Holder() {
      std::lock_guard<std::mutex> lock(lease->mutex);
      lease->held = false;
    }
    std::shared_ptr<EsdfMap> map;
    std::shared_ptr<EsdfQueryGrid> query_grid;
    std::shared_ptr<EsdfLease> lease;
  };
  const auto holder = std::make_shared<const Holder>(copy->map, copy->query_grid, copy->lease);
  PublishedEsdf published;
  published.map = std::shared_ptr<const EsdfMap>(holder, holder->map.get());
  if (holder->query_grid) {
    published.query_grid = std::shared_ptr<const EsdfQueryGrid>(holder, holder->query_grid.get());
  }
  return published;
}

void PlanningLayers::planningLoop() {
  for (;;) {
    EsdfJob job;
    {
      std::unique_lock<std::mutex> lock(job_mutex_);
      job_cv_.wait(lock, [&] { return stopping_ || has_job_; });
      if (stopping_) return;
      job = std::move(job_);
      job_ = EsdfJob{};
      has_job_ = false;
      busy_ = true;
    }
    const Clock::time_point start = Clock::now();
    PublishedEsdf esdf = computeEsdf(job);
    const double ms = msSince(start);
    std::uint64_t published_frame = 0;
    double published_stamp_s = 0.0;
    {
      // The newest window and grid with the new field.
      std::shared_ptr<const MapSnapshot> old;
      std::lock_guard<std::mutex> lock(snapshot_mutex_);
      const MapSnapshot& s = *snapshot_;
      published_frame = s.frame();
      published_stamp_s = s.stamp_s();
      old = std::exchange(
          snapshot_, std::make_shared<const MapSnapshot>(
                         s.windowPtr(), s.gridPtr(), std::move(esdf.map), s.frame(), s.stamp_s(),
                         s.T_W_B(), job.frame, std::move(esdf.query_grid)));
    }
    if (esdf_published_) esdf_published_(published_frame, published_stamp_s);
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.esdf_updates;
      stats_.last_esdf_ms = ms;
      stats_.max_esdf_ms = std::max(stats_.max_esdf_ms, ms);
      stats_.esdf_frame = job.frame;
    }
    {
      std::lock_guard<std::mutex> lock(job_mutex_);
      busy_ = false;
    }
    job_cv_.notify_all();
  }
}

void PlanningLayers::flush() {
  if (!own_thread_) return;
  std::unique_lock<std::mutex> lock(job_mutex_);
  job_cv_.wait(lock, [&] { return stopping_ || (!has_job_ && !busy_); });
}

PlanningStats PlanningLayers::stats() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  return stats_;
}

std::size_t PlanningLayers::memoryBytes() const {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  return stats_.snapshot_bytes + stats_.esdf_bytes;
}

}  // namespace mlmap
