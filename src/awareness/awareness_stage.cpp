#include "mlmap/awareness/awareness_stage.h"

#include "direction_bins.h"
#include "mlmap/awareness/point_kernel.h"
#include "mlmap/core/stopwatch.h"
#include "task_threads.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>

// countBits() gets a popcnt clone next to the portable one, picked at load time (GCC ifunc).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && \
    !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
#define MLMAP_POPCNT_CLONES __attribute__((target_clones("popcnt", "default")))
#else
#define MLMAP_POPCNT_CLONES
#endif

namespace mlmap {
namespace {
static_assert(kPointOutsideCutKey + 1 == kPointOutsideHitKey &&
                  kPointOutsideHitKey + 1 == kPointTooCloseKey &&
                  kPointTooCloseKey + 1 == kPointNonFiniteKey,
              "the point loop tells the keys that are no box voxel by key >= kPointOutsideCutKey");
// Matches no key: box keys stay below it (the box holds far fewer than 2^31 voxels).
constexpr std::uint32_t kNoRunKey = kPointOutsideCutKey - 1;
// A bin's shared cone stops where the bin is awareness.bin_width_voxels wide. Thinner bins overlap
// more: a voxel lies in about ((1 + w) / w)^2 cones of width w, so one voxel wide (the default:
// the surfaces OctoMap keeps) makes every free voxel about four times, two voxels wide about
// twice, for 1.09-1.11x over-carving instead of 1.08x (three voxels wide exceed the 1.15x bound).
// The finest level has AwarenessConfig::binsPerFaceSide() bins per cube face side (at most
// 6 x 256^2 bins, of which a frame holds only those its ends fall in).
constexpr std::size_t kProbeAhead = 16;  // ends between a table slot's prefetch and its probe
constexpr std::size_t kRunsAhead = 4;    // runs between a table slot's prefetch and its probe
// Longest that collect() waits for carve() to finish the awareness maps left to it before it
// leaves its own frame's there too.
constexpr int kMapWaitMs = 100;

std::uint32_t hashKey(std::uint32_t key) {
  key ^= key >> 16;
  key *= 0x7feb352du;
  key ^= key >> 15;
  key *= 0x846ca68bu;
  key ^= key >> 16;
  return key;
}

// A key's entry in the recent ends: a multiplicative hash (three instructions; the table's
// hashKey() runs only when the recent ends miss, about one run in nine on depth images).
constexpr int kRecentEndsBits = 10;  // AwarenessStage::kRecentEnds == 1 << 10 (asserted there)
inline std::uint32_t recentIndex(std::uint32_t key) {
  return (key * 0x9e3779b1u) >> (32 - kRecentEndsBits);
}

// VoxelBitset::count() with the popcnt instruction where the CPU has it: the portable build
// calls libgcc's __popcountdi2 for every word (2 M instructions per frame at 0.1 m).
// Counts the set bits of the rows with box x in [x_begin, x_end) within `rows`, and writes the
// bitset's rowsInUse() words of those x (every word: rows outside `rows` hold no bit).
// Rows of `per_row` words (a constant for the common widths, so the row loop unrolls).
template <std::size_t kPerRow>
MLMAP_POPCNT_CLONES std::size_t countBitsOf(VoxelBitset& bits, int x_begin, int x_end,
                                            const VoxelBitset::Rows& rows, std::size_t per_row) {
  if constexpr (kPerRow != 0) per_row = kPerRow;
  std::size_t n = 0;
  for (int x = std::max(x_begin, 0); x < std::min(x_end, bits.dims().x()); ++x) {
    std::uint64_t* in_use = bits.rowsInUse(x);
    std::fill(in_use, in_use + bits.rowsInUseWordsPerX(), std::uint64_t{0});
    if (x < rows.x_begin || x >= rows.x_end) continue;
    const std::uint64_t* w = bits.data() + bits.rowWord(x, rows.y_begin);
    for (int y = rows.y_begin; y < rows.y_end; ++y, w += per_row) {
      std::uint64_t any = 0;
      for (std::size_t i = 0; i < per_row; ++i) {
        n += static_cast<std::size_t>(__builtin_popcountll(w[i]));
        any |= w[i];
      }
      in_use[y >> 6] |= static_cast<std::uint64_t>(any != 0) << (y & 63);
    }
  }
  return n;
}

std::size_t countBits(VoxelBitset& bits, int x_begin, int x_end, const VoxelBitset::Rows& rows) {
  const std::size_t per_row = bits.wordsPerRow();
  switch (per_row) {
    case 1:
      return countBitsOf<1>(bits, x_begin, x_end, rows, per_row);
    case 2:
      return countBitsOf<2>(bits, x_begin, x_end, rows, per_row);
    case 4:
      return countBitsOf<4>(bits, x_begin, x_end, rows, per_row);
    default:
      return countBitsOf<0>(bits, x_begin, x_end, rows, per_row);
  }
}

// The rows that the cones can mark: each cone's part s in [s_min, 1] lies between its sections
// at s_min and 1 (linear in s), and a voxel to spare on each side (the carving is exact within
// that hull).
template <typename Cones>
VoxelBitset::Rows conesRows(const Eigen::Vector3d& o, const Cones& cones) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  Eigen::Vector2d lo(kInf, kInf);  // x, y
  Eigen::Vector2d hi(-kInf, -kInf);
  for (const auto& cone : cones) {
    const double s0 = std::max(cone.s_min, 0.0);
    const double min_x = cone.box.min.x();
    const double max_x = cone.box.max.x();
    const double min_y = cone.box.min.y();
    const double max_y = cone.box.max.y();
    lo.x() = std::min({lo.x(), min_x, o.x() + s0 * (min_x - o.x())});
    hi.x() = std::max({hi.x(), max_x, o.x() + s0 * (max_x - o.x())});
    lo.y() = std::min({lo.y(), min_y, o.y() + s0 * (min_y - o.y())});
    hi.y() = std::max({hi.y(), max_y, o.y() + s0 * (max_y - o.y())});
  }
  if (!(lo.x() <= hi.x()) || !(lo.y() <= hi.y())) return {};  // no cone
  // Clamped before the conversion (a cone may reach far outside the box).
  const auto row = [](double v) {
    return static_cast<int>(std::clamp(std::floor(v), -2.0e9, 2.0e9));
  };
  return {row(lo.x()) - 1, row(hi.x()) + 2, row(lo.y()) - 1, row(hi.y()) + 2};
}

// Borders 0 = b_0 <= b_1 <= ... <= b_threads = dim_x of box x ranges that split the carving of
// `cones` evenly. A cone's work is taken as its length in voxels (about its slabs) plus 10 for its
// set-up, spread evenly over the x its part s in [s_min, 1] spans (what carveRange() tests); on
// the 30 m LiDAR scans the slower of two ranges then takes 5 % less than with the cones' centres
// split in half. `work` is scratch space.
template <typename Cones>
std::vector<int> xRangesOfEqualWork(const Eigen::Vector3d& o, const Cones& cones, int dim_x,
                                    int threads, std::vector<double>* work) {
  constexpr double kSetUp = 10.0;
  work->assign(static_cast<std::size_t>(dim_x) + 1, 0.0);  // per x, as differences
  double total = 0.0;
  const double last_x = dim_x - 1.0;
  for (const auto& cone : cones) {
    const double s0 = std::max(cone.s_min, 0.0);
    const double near_lo = o.x() + s0 * (cone.box.min.x() - o.x());
    const double near_hi = o.x() + s0 * (cone.box.max.x() - o.x());
    const double lo = std::min({near_lo, near_hi, static_cast<double>(cone.box.min.x())});
    const double hi = std::max({near_lo, near_hi, static_cast<double>(cone.box.max.x())});
    const int x0 = floorToInt(std::clamp(lo, 0.0, last_x));
    const int x1 = std::max(x0, floorToInt(std::clamp(hi, 0.0, last_x)));
    const Eigen::Vector3d centre = 0.5 * (cone.box.min + cone.box.max).template cast<double>();
    const double w = kSetUp + std::max(1.0 - s0, 0.0) * (centre - o).norm();
    const double per_x = w / (x1 - x0 + 1);
    (*work)[static_cast<std::size_t>(x0)] += per_x;
    (*work)[static_cast<std::size_t>(x1) + 1] -= per_x;
    total += w;
  }
  std::vector<int> borders(static_cast<std::size_t>(threads) + 1, dim_x);
  borders.front() = 0;
  double density = 0.0;
  double done = 0.0;
  int next = 1;  // the next border to place
  for (int x = 0; x < dim_x && next < threads; ++x) {
    density += (*work)[static_cast<std::size_t>(x)];
    done += density;
    while (next < threads && done >= total * next / threads)
      borders[static_cast<std::size_t>(next++)] = x + 1;
  }
  return borders;
}

// Depth pixels with data, in metres, as points on their rays (backProject()'s arithmetic).
inline float depthMetres(float metres) { return metres; }
template <typename Raw>
void convertPixels(const Raw* __restrict raw, const float* __restrict rx, float ray_y,
                   std::size_t count, float* __restrict xs, float* __restrict ys,
                   float* __restrict zs) {
  for (std::size_t k = 0; k < count; ++k) {
    const float z = depthMetres(raw[k]);
    xs[k] = rx[k] * z;
    ys[k] = ray_y * z;
    zs[k] = z;
  }
}

// The pixels with data among `count`, converted as convertPixels() converts them and packed in
// pixel order, without a branch on the data: every pixel is converted and written at the next
// free place, which advances only past a pixel with data. For the pixels of sensors whose valid
// pixels alternate with invalid ones one or two at a time (a RealSense's sparse pattern), where
// a branch per run of pixels mispredicts about every other pixel. Writes stay below `count`.
template <typename Raw, typename Valid>
std::size_t packPixels(const Raw* __restrict raw, const float* __restrict rx, float ray_y,
                       std::size_t count, Valid valid, float* __restrict xs, float* __restrict ys,
                       float* __restrict zs) {
  std::size_t n = 0;
  for (std::size_t k = 0; k < count; ++k) {
    const float z = depthMetres(raw[k]);
    xs[n] = rx[k] * z;
    ys[n] = ray_y * z;
    zs[n] = z;
    n += valid(raw[k]) ? 1 : 0;
  }
  return n;
}

double distanceToBox(const Eigen::Vector3d& o, const VoxelSpaceBox& b) {
  const Eigen::Vector3d d =
      (b.min.cast<double>() - o).cwiseMax(o - b.max.cast<double>()).cwiseMax(0.0);
  return d.norm();
}
}  // namespace

PointCounters& PointCounters::operator+=(const PointCounters& o) {
  points_in += o.points_in;
  rejected_non_finite += o.rejected_non_finite;
  rejected_too_close += o.rejected_too_close;
  beyond_max_range += o.beyond_max_range;
  hits_beyond_local_map += o.hits_beyond_local_map;
  hits_above_or_below_local_map += o.hits_above_or_below_local_map;
  sampled_out += o.sampled_out;
  hit_voxels += o.hit_voxels;
  free_voxels += o.free_voxels;
  return *this;
}

AwarenessStage::AwarenessStage(const MapConfig& config)
    : config_(config),
      map_(config.awareness),
      parts_(static_cast<std::size_t>(std::max(1, config.awareness.num_threads))),
      rng_(config.awareness.sample_seed) {
  if (config.awareness.num_threads > 1) {
    threads_ = std::make_unique<TaskThreads>(config.awareness.num_threads);
  }
  map_bytes_.store(map_.memoryBytes(), std::memory_order_relaxed);
  bins_per_face_side_ = config.awareness.binsPerFaceSide(config.local_map.resolution_m);
}

AwarenessStage::~AwarenessStage() = default;

std::uint32_t AwarenessStage::findOrAddEnd(PointPart* part, std::uint32_t full_key) const {
  std::vector<Slot>& table = part->table;
  std::vector<End>& ends = part->ends;
  const std::uint32_t stamp = part->stamp;
  if (2 * (ends.size() + 1) > table.size()) {
    // Grow and re-insert this frame's ends.
    std::vector<Slot> bigger(table.size() * 2);
    const std::uint32_t mask = static_cast<std::uint32_t>(bigger.size() - 1);
    for (std::uint32_t e = 0; e < ends.size(); ++e) {
      const Eigen::Vector3i& v = ends[e].voxel;  // only ends inside the box are in ends here
      const std::uint32_t k =
          static_cast<std::uint32_t>(
              (static_cast<std::size_t>(v.x()) * box_dims_.y() + v.y()) * box_dims_.z() + v.z()) |
          (ends[e].cut ? kPointCutFlag : 0u);
      std::uint32_t h = hashKey(k) & mask;
      while (bigger[h].stamp == stamp) h = (h + 1) & mask;
      bigger[h] = {stamp, k, e};
    }
    table.swap(bigger);
  }
  const std::uint32_t mask = static_cast<std::uint32_t>(table.size() - 1);
  std::uint32_t h = hashKey(full_key) & mask;
  for (;;) {
    Slot& slot = table[h];
    if (slot.stamp != stamp) {
      slot = {stamp, full_key, static_cast<std::uint32_t>(ends.size())};
      // Decoded here, once per end voxel rather than once per run of points (three divisions).
      const std::uint32_t voxel = full_key & ~kPointCutFlag;
      const std::uint32_t dim_y = static_cast<std::uint32_t>(box_dims_.y());
      const std::uint32_t dim_z = static_cast<std::uint32_t>(box_dims_.z());
      End e;
      e.voxel = Eigen::Vector3i(static_cast<int>(voxel / (dim_y * dim_z)),
                                static_cast<int>((voxel / dim_z) % dim_y),
                                static_cast<int>(voxel % dim_z));
      e.cut = (full_key & kPointCutFlag) != 0;
      e.points.min = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
      e.points.max = Eigen::Vector3f::Constant(std::numeric_limits<float>::lowest());
      ends.push_back(e);
      return slot.end;
    }
    if (slot.key == full_key) return slot.end;
    h = (h + 1) & mask;
  }
}

std::size_t AwarenessStage::Source::fill(std::size_t first, std::size_t len, float* xs, float* ys,
                                         float* zs) const {
  if (depth == nullptr) {
    for (std::size_t i = 0; i < len; ++i) {
      const Eigen::Vector3f& p = points[indices != nullptr ? indices[first + i] : first + i];
      xs[i] = p.x();
      ys[i] = p.y();
      zs[i] = p.z();
    }
    return len;
  }
  // Depth pixels, row segment by row segment. Pixels without data are left out (a quarter of a
  // simulated frame: the point loop need not classify them). Millimetre images are packed by
  // packDepthPixelsMm() (eight pixels at a time on AVX2). Float images go 32 pixels at a time:
  // their pixels with data counted without a branch (the compiler vectorises the count), none
  // skipped, all converted in a loop the compiler vectorises, and a mix packed by packPixels();
  // the same points in the same order either way.
  const std::size_t width = static_cast<std::size_t>(depth->intrinsics.width);
  std::size_t done = 0;
  std::size_t n = 0;
  auto copyValid = [&](const auto* raw, std::size_t seg, auto valid, const float* rx, float ray_y) {
    constexpr std::size_t kStep = 32;
    std::size_t i = 0;
    for (; i + kStep <= seg; i += kStep) {
      int with_data = 0;
      for (std::size_t k = 0; k < kStep; ++k) with_data += valid(raw[i + k]) ? 1 : 0;
      if (with_data == 0) continue;
      if (with_data == static_cast<int>(kStep)) {
        convertPixels(raw + i, rx + i, ray_y, kStep, xs + n, ys + n, zs + n);
        n += kStep;
      } else {
        n += packPixels(raw + i, rx + i, ray_y, kStep, valid, xs + n, ys + n, zs + n);
      }
    }
    n += packPixels(raw + i, rx + i, ray_y, seg - i, valid, xs + n, ys + n, zs + n);
  };
  while (done < len) {
    const std::size_t pixel = first + done;
    const std::size_t u0 = pixel % width;
    const std::size_t seg = std::min(len - done, width - u0);
    const std::size_t v = pixel / width;  // image row
    const float ray_y = (static_cast<float>(v) - cy) * inv_fy;
    const float* rx = ray_x->data() + u0;
    if (depth->encoding == DepthEncoding::kUint16Millimetres) {
      n +=
          packDepthPixelsMm(depth->depth_mm.data() + pixel, rx, ray_y, seg, xs + n, ys + n, zs + n);
    } else {
      // 0 < r <= FLT_MAX (no NaN, no infinity), in one comparison of the bits.
      copyValid(
          depth->depth_m.data() + pixel, seg,
          [](float r) {
            std::uint32_t bits = 0;
            std::memcpy(&bits, &r, sizeof bits);
            return bits - 1u < 0x7F7FFFFFu;
          },
          rx, ray_y);
    }
    done += seg;
  }
  return n;
}

void AwarenessStage::process(const PointCloudFrame& frame, MeasurementBatch* batch,
                             PointCounters* counters) {
  processCloud(frame, batch, counters, /*split=*/false);
}

bool AwarenessStage::process(const DepthFrame& frame, MeasurementBatch* batch,
                             PointCounters* counters) {
  return processDepth(frame, batch, counters, /*split=*/false);
}

void AwarenessStage::collect(const PointCloudFrame& frame, MeasurementBatch* batch,
                             PointCounters* counters) {
  processCloud(frame, batch, counters, /*split=*/true);
}

bool AwarenessStage::collect(const DepthFrame& frame, MeasurementBatch* batch,
                             PointCounters* counters) {
  return processDepth(frame, batch, counters, /*split=*/true);
}

double AwarenessStage::carve(MeasurementBatch* batch, PointCounters* counters,
                             const std::function<void(const AwarenessMap&)>& on_map) {
  std::unique_ptr<CollectedFrame> frame;
  {
    std::lock_guard<std::mutex> lock(collected_mutex_);
    if (collected_.empty()) throw std::logic_error("AwarenessStage::carve() without a collect()");
    frame = std::move(collected_.front());
    collected_.pop_front();
  }
  batch->free.reset(frame->box_origin, frame->dims);
  // The frame's cone listing as far as collect() took it: into carve_listing_, whose memory
  // goes back with the frame for a later collect() to fill.
  if (frame->listed != ConeListingStep::kNothing) std::swap(carve_listing_, frame->listing);
  // The awareness map, where collect() left it here: beside the rest of the listing on a kept
  // thread, as in process(), when the other half does not hold them.
  double map_ms = 0.0;
  if (frame->map_in_carve) {
    map_ms = mapAndListCones(frame->body_W, frame->origin_vox, frame->ends, frame->listed);
  } else {
    advanceListing(frame->origin_vox, frame->ends, frame->listed, ConeListingStep::kConesListed,
                   &carve_listing_, &carve_listing_ms_);
  }
  // With kept threads, the carving is split over them as in process(): a kept thread that the
  // other half's point loop does not hold (it waits for a core meanwhile, or finds the carving's
  // ranges claimed) helps here; otherwise this thread carves every range itself.
  carveCones(frame->origin_vox, batch);
  counters->free_voxels += batch->free_count;
  if (frame->map_in_carve && on_map) on_map(map_);
  std::lock_guard<std::mutex> lock(collected_mutex_);
  if (frame->map_in_carve && --maps_in_carve_ == 0) maps_carved_.notify_all();  // collect() may
  spare_.push_back(std::move(frame));
  return map_ms;
}

void AwarenessStage::processCloud(const PointCloudFrame& frame, MeasurementBatch* batch,
                                  PointCounters* counters, bool split) {
  const AwarenessConfig& ac = config_.awareness;
  Source source;
  source.points = frame.points_S.data();
  source.count = frame.points_S.size();
  PointCounters c;
  c.points_in = source.count;
  if (ac.sample_count > 0 && source.count > static_cast<std::size_t>(ac.sample_count)) {
    const std::size_t n = source.count;
    sample_indices_.resize(n);
    std::iota(sample_indices_.begin(), sample_indices_.end(), 0u);
    source.count = static_cast<std::size_t>(ac.sample_count);
    for (std::size_t i = 0; i < source.count; ++i) {
      std::uniform_int_distribution<std::size_t> pick(i, n - 1);
      std::swap(sample_indices_[i], sample_indices_[pick(rng_)]);
    }
    c.sampled_out = n - source.count;
    source.indices = sample_indices_.data();
  }
  processSource(source, frame.stamp_s, frame.T_W_B, frame.T_B_S, batch, &c, split);
  *counters += c;
}

bool AwarenessStage::processDepth(const DepthFrame& frame, MeasurementBatch* batch,
                                  PointCounters* counters, bool split) {
  const PinholeIntrinsics& K = frame.intrinsics;
  const std::size_t n = static_cast<std::size_t>(std::max(K.width, 0)) *
                        static_cast<std::size_t>(std::max(K.height, 0));
  const bool is_mm = frame.encoding == DepthEncoding::kUint16Millimetres;
  if (n == 0 || (is_mm ? frame.depth_mm.size() : frame.depth_m.size()) != n || !(K.fx > 0.0) ||
      !(K.fy > 0.0)) {
    return false;
  }
  if (config_.awareness.sample_count > 0) {
    // Sub-sampling draws from the valid points only: go through a cloud.
    PointCloudFrame cloud;
    cloud.stamp_s = frame.stamp_s;
    cloud.T_W_B = frame.T_W_B;
    cloud.T_B_S = frame.T_B_S;
    cloud.points_S.swap(depth_points_);
    std::size_t skipped = 0;
    backProject(frame, &cloud.points_S, &skipped);
    processCloud(cloud, batch, counters, split);
    counters->points_in += skipped;
    counters->rejected_non_finite += skipped;  // pixels without a measurement
    depth_points_.swap(cloud.points_S);
    return true;
  }
  // Every pixel straight into the point kernel, no intermediate cloud. Same arithmetic as
  // backProject(): x = ((u - cx) / fx) z, y = ((v - cy) / fy) z in float.
  const float inv_fx = static_cast<float>(1.0 / K.fx);
  ray_x_.resize(static_cast<std::size_t>(K.width));
  for (int u = 0; u < K.width; ++u) {
    ray_x_[static_cast<std::size_t>(u)] =
        (static_cast<float>(u) - static_cast<float>(K.cx)) * inv_fx;
  }
  Source source;
  source.depth = &frame;
  source.count = n;
  source.ray_x = &ray_x_;
  source.inv_fy = static_cast<float>(1.0 / K.fy);
  source.cy = static_cast<float>(K.cy);
  PointCounters c;
  c.points_in = n;
  processSource(source, frame.stamp_s, frame.T_W_B, frame.T_B_S, batch, &c, split);
  *counters += c;
  return true;
}

void AwarenessStage::processSource(const Source& source, double stamp_s, const Transform& T_W_B,
                                   const Transform& T_B_S, MeasurementBatch* batch,
                                   PointCounters* counters, bool split) {
  const FrameGeometry g = beginFrame(stamp_s, T_W_B, T_B_S, batch);
  // The free set is cleared by the half that carves it: split, that is carve()'s thread, whose
  // cache the cleared rows are then in.
  if (!split) batch->free.reset(g.box_origin, g.dims);
  collectEnds(source, g, counters);
  for (const End& e : outside_) {
    if (!e.cut) batch->far_hits.push_back(voxelIndexOf(e.p_W, config_.local_map.resolution_m));
  }
  // Occupied list (unique voxels).
  for (const End& e : ends_) {
    if (!e.cut) batch->hits.push_back({e.voxel + g.box_origin, e.p_W});
  }
  // From here on ends_ holds every end, those beyond the box last (the hits are listed already).
  ends_.insert(ends_.end(), outside_.begin(), outside_.end());
  counters->hit_voxels = batch->hits.size();
  if (split) {
    // The awareness map here, once the earlier frames' maps that wait for carve() are done (a
    // bounded wait: carve() may never come, e.g. the engine stopping), or in carve().
    bool map_in_carve = map_in_carve_;
    {
      std::unique_lock<std::mutex> lock(collected_mutex_);
      if (!map_in_carve) {
        map_in_carve = !maps_carved_.wait_for(lock, std::chrono::milliseconds(kMapWaitMs),
                                              [&] { return maps_in_carve_ == 0; });
      }
      if (map_in_carve) ++maps_in_carve_;
    }
    collect_map_ms_ = -1.0;
    if (!map_in_carve) collect_map_ms_ = updateAwarenessMap(T_W_B.translation(), ends_);
    // The cone listing here as far as placeConeListing() asks, into this half's own listing
    // (carve() may be listing an earlier frame's cones into its own).
    const ConeListingStep listed = listing_in_collect_;
    advanceListing(g.origin_vox, ends_, ConeListingStep::kNothing, listed, &collect_listing_,
                   &collect_listing_ms_);
    // The second half waits for carve() (maybe on another thread) with the frame's ends; ends_
    // takes a spare one's memory.
    std::lock_guard<std::mutex> lock(collected_mutex_);
    std::unique_ptr<CollectedFrame> frame;
    if (spare_.empty()) {
      frame = std::make_unique<CollectedFrame>();
    } else {
      frame = std::move(spare_.back());
      spare_.pop_back();
    }
    frame->ends.swap(ends_);
    frame->body_W = T_W_B.translation();
    frame->map_in_carve = map_in_carve;
    frame->listed = listed;
    if (listed != ConeListingStep::kNothing) std::swap(frame->listing, collect_listing_);
    frame->origin_vox = g.origin_vox;
    frame->box_origin = g.box_origin;
    frame->dims = g.dims;
    collected_.push_back(std::move(frame));
    return;
  }
  mapAndListCones(T_W_B.translation(), g.origin_vox, ends_, ConeListingStep::kNothing);
  carveCones(g.origin_vox, batch);
  counters->free_voxels = batch->free_count;
}

AwarenessStage::FrameGeometry AwarenessStage::beginFrame(double stamp_s, const Transform& T_W_B,
                                                         const Transform& T_B_S,
                                                         MeasurementBatch* batch) {
  const double res = config_.local_map.resolution_m;
  FrameGeometry g;
  g.T_W_S = T_W_B * T_B_S;
  const Transform& T_W_S = g.T_W_S;
  const Eigen::Vector3d o_W = T_W_S.translation();
  const Eigen::Vector3d body_W = T_W_B.translation();

  // Scratch box around the sensor: everything within range that the local map can hold. After
  // re-centring the body lies in the centre submap, so the map reaches at most 3 submaps away.
  const VoxelIndex sensor_voxel = voxelIndexOf(o_W, res);
  const int range_voxels = static_cast<int>(std::ceil(config_.awareness.max_range_m / res)) + 1;
  const int offset_voxels = static_cast<int>(std::ceil((o_W - body_W).norm() / res)) + 1;
  const Eigen::Vector3i submap = config_.local_map.submap_cells();
  Eigen::Vector3i half;
  for (int a = 0; a < 3; ++a) half[a] = std::min(range_voxels, 3 * submap[a] + offset_voxels);
  g.box_origin = sensor_voxel - half;
  g.dims = 2 * half + Eigen::Vector3i::Ones();
  g.origin_vox = o_W * (1.0 / res) - g.box_origin.cast<double>();  // as collectEnds() scales
  box_dims_ = g.dims;
  batch->hits.clear();
  batch->far_hits.clear();
  batch->stamp_s = stamp_s;
  batch->T_W_B = T_W_B;
  batch->sensor_origin_W = o_W;
  batch->resolution_m = res;
  ends_.clear();
  outside_.clear();
  return g;
}

void AwarenessStage::collectEnds(const Source& source, const FrameGeometry& g,
                                 PointCounters* counters) {
  // Parts of whole blocks, at least two blocks each.
  const std::size_t blocks = (source.count + kPointBlock - 1) / kPointBlock;
  const std::size_t threads = threads_ != nullptr ? parts_.size() : 1;
  const std::size_t parts = std::max<std::size_t>(1, std::min(threads, blocks / 2));
  const std::size_t per_part = (blocks + parts - 1) / parts * kPointBlock;
  auto collect = [&](int t) {
    const std::size_t first = static_cast<std::size_t>(t) * per_part;
    collectPart(source, g, std::min(first, source.count), std::min(first + per_part, source.count),
                &parts_[static_cast<std::size_t>(t)]);
  };
  if (parts > 1) {
    threads_->run(static_cast<int>(parts), collect);
  } else {
    collect(0);
  }
  // The later parts into the first, in order: an end met first in part t comes after those of
  // the parts before, as one pass over the points would list it; its first point is the first
  // part's that has it, and its box the hull of the parts' boxes (min and max: exact).
  PointPart& merged = parts_[0];
  const auto keyOf = [&](const End& e) {  // as the point loop keys a box voxel
    return static_cast<std::uint32_t>(
               (static_cast<std::size_t>(e.voxel.x()) * box_dims_.y() + e.voxel.y()) *
                   box_dims_.z() +
               e.voxel.z()) |
           (e.cut ? kPointCutFlag : 0u);
  };
  const auto mergeInto = [](End* into, const End& e) {
    into->points.min = into->points.min.cwiseMin(e.points.min);
    into->points.max = into->points.max.cwiseMax(e.points.max);
  };
  for (std::size_t t = 1; t < parts; ++t) {
    PointPart& part = parts_[t];
    const std::vector<End>& ends = part.ends;
    if (t + 1 < parts) {
      for (const End& e : ends) {
        const std::size_t before = merged.ends.size();
        End& into = merged.ends[findOrAddEnd(&merged, keyOf(e))];
        if (merged.ends.size() > before) {
          into = e;
        } else {
          mergeInto(&into, e);
        }
      }
    } else {
      // The last part: no later part looks its ends up, so the table only answers (its slots
      // fetched a few ends ahead: a LiDAR's ends are nearly all new, all over the table).
      const std::vector<Slot>& table = merged.table;
      const std::uint32_t mask = static_cast<std::uint32_t>(table.size() - 1);
      for (std::size_t i = 0; i < ends.size(); ++i) {
        if (i + kProbeAhead < ends.size())
          __builtin_prefetch(&table[hashKey(keyOf(ends[i + kProbeAhead])) & mask]);
        const End& e = ends[i];
        const std::uint32_t key = keyOf(e);
        std::uint32_t h = hashKey(key) & mask;
        while (table[h].stamp == merged.stamp && table[h].key != key) h = (h + 1) & mask;
        if (table[h].stamp == merged.stamp) {
          mergeInto(&merged.ends[table[h].end], e);
        } else {
          merged.ends.push_back(e);
        }
      }
    }
    merged.outside.insert(merged.outside.end(), part.outside.begin(), part.outside.end());
    merged.counters += part.counters;
  }
  *counters += merged.counters;
  ends_.swap(merged.ends);
  outside_.swap(merged.outside);
}

void AwarenessStage::collectPart(const Source& source, const FrameGeometry& g, std::size_t first,
                                 std::size_t end, PointPart* part) const {
  const AwarenessConfig& ac = config_.awareness;
  const double res = config_.local_map.resolution_m;
  const Transform& T_W_S = g.T_W_S;
  const Eigen::Vector3d o_W = T_W_S.translation();
  const VoxelIndex& box_origin = g.box_origin;
  const Eigen::Vector3i& dims = g.dims;
  part->counters = PointCounters{};
  part->ends.clear();
  part->outside.clear();
  // cppcheck-suppress knownConditionTrueFalse ; it does wrap after 2^32 frames
  if (++part->stamp == 0) {  // wrapped: forget every slot
    std::fill(part->table.begin(), part->table.end(), Slot{});
    part->stamp = 1;
  }
  PointCounters& c = part->counters;
  std::vector<End>& ends = part->ends;
  std::vector<Slot>& table = part->table;
  const std::uint32_t stamp = part->stamp;
  static_assert(kRecentEnds == std::size_t{1} << kRecentEndsBits, "recentIndex() sizes");
  RecentEnd* recent = part->recent.data();
  std::fill(part->recent.begin(), part->recent.end(), RecentEnd{kNoRunKey, 0});

  // Points in world voxel units, w = o / res + (R / res) p: the voxel is floor(w). Pass 1 turns
  // every point into a key (box voxel, or why it is not one) and its box coordinates, without
  // branches; pass 2 groups the runs of equal keys into end voxels.
  const double inv_res = 1.0 / res;
  const Eigen::Matrix3d M = T_W_S.linear() * inv_res;
  const double m00 = M(0, 0), m01 = M(0, 1), m02 = M(0, 2);
  const double m10 = M(1, 0), m11 = M(1, 1), m12 = M(1, 2);
  const double m20 = M(2, 0), m21 = M(2, 1), m22 = M(2, 2);
  const double ow_x = o_W.x() * inv_res, ow_y = o_W.y() * inv_res, ow_z = o_W.z() * inv_res;
  const double bx = box_origin.x(), by = box_origin.y(), bz = box_origin.z();
  const double min_range2 = ac.min_range_m * ac.min_range_m;
  const double max_range = ac.max_range_m;
  const double max_range2 = max_range * max_range;
  const std::uint32_t dim_x = static_cast<std::uint32_t>(dims.x());
  const std::uint32_t dim_y = static_cast<std::uint32_t>(dims.y());
  const std::uint32_t dim_z = static_cast<std::uint32_t>(dims.z());
  // Point -> world voxel units (rays beyond the maximum range cut there). Used by both passes so
  // that a recomputed point is bit-identical.
  auto toVoxelUnits = [&](const Eigen::Vector3f& p, double* w) {
    double x = p.x();
    double y = p.y();
    double z = p.z();
    const double r2 = x * x + y * y + z * z;
    const double scale = r2 > max_range2 ? max_range / std::sqrt(r2) : 1.0;
    x *= scale;
    y *= scale;
    z *= scale;
    w[0] = ow_x + m00 * x + m01 * y + m02 * z;
    w[1] = ow_y + m10 * x + m11 * y + m12 * z;
    w[2] = ow_z + m20 * x + m21 * y + m22 * z;
    return r2;
  };
  PointKernel kernel;
  kernel.m = {m00, m01, m02, m10, m11, m12, m20, m21, m22};
  kernel.o = {ow_x, ow_y, ow_z};
  kernel.box_origin = {bx, by, bz};
  kernel.dims = {dim_x, dim_y, dim_z};
  kernel.min_range2 = min_range2;
  kernel.max_range = max_range;
  // Pass 2 takes the block's runs of equal keys (depth images give runs along a row) with their
  // point boxes and merges each into its voxel's entry; the voxel is looked up only when a run's
  // key differs from the last box key (a run after points outside the box can continue it).
  // Both passes go block by block, so a block's keys and coordinates are still in the cache when
  // pass 2 reads them.
  std::uint32_t last_key = kNoRunKey;
  End* last = nullptr;
  std::uint64_t last_cut = 0;  // 1 when the last end's rays are cut at the maximum range
  // The world point of a block's point, from its sensor-frame coordinates in the block.
  float* xs = part->block_xyz.data();
  float* ys = xs + kPointBlock;
  float* zs = ys + kPointBlock;
  auto worldPoint = [&](std::size_t i) {
    double w[3] = {0.0, 0.0, 0.0};
    toVoxelUnits(Eigen::Vector3f(xs[i], ys[i], zs[i]), w);
    return Eigen::Vector3d(w[0] * res, w[1] * res, w[2] * res);
  };
  // Points outside the box, one by one.
  auto addOutside = [&](std::uint32_t key, std::size_t at) {
    const Eigen::Array4f v = Eigen::Array4f::Map(part->box_coords[at].data());
    if (key == kPointNonFiniteKey) {
      ++c.rejected_non_finite;
    } else if (key == kPointTooCloseKey) {
      ++c.rejected_too_close;
    } else {
      // Beyond what the local map can hold; the awareness map and the carving still use it.
      End e;
      e.voxel = Eigen::Vector3i::Constant(-1);
      e.points = {v.head<3>().matrix(), v.head<3>().matrix()};
      e.p_W = worldPoint(at);
      e.cut = key == kPointOutsideCutKey;
      c.beyond_max_range += e.cut ? 1 : 0;
      c.hits_beyond_local_map += e.cut ? 0 : 1;
      // Box-relative voxel coordinates: inside horizontally, so outside in z.
      const bool beside = v[0] >= 0.0f && v[0] < static_cast<float>(box_dims_.x()) &&
                          v[1] >= 0.0f && v[1] < static_cast<float>(box_dims_.y());
      c.hits_above_or_below_local_map += !e.cut && beside ? 1 : 0;
      part->outside.push_back(e);
    }
  };
  const std::uint32_t* keys = part->keys.data();
  PointRuns& runs = part->runs;
  for (std::size_t block = first; block < end; block += kPointBlock) {
    const std::size_t len = std::min(kPointBlock, end - block);
    const std::size_t n = source.fill(block, len, xs, ys, zs);
    c.rejected_non_finite += len - n;  // depth pixels without data
    if (n == 0) continue;
    classifyPoints(kernel, xs, ys, zs, n, part->keys.data(), part->box_coords[0].data());
    groupPointRuns(keys, part->box_coords[0].data(), n, &runs);
    const std::uint32_t* run_first = runs.first.data();
    const float* run_box = runs.box.data();
    for (std::size_t r = 0; r < runs.count; ++r) {
      const std::size_t at = run_first[r];
      const std::uint32_t key = keys[at];
      const std::size_t points = run_first[r + 1] - at;
      if (key >= kPointOutsideCutKey) {
        for (std::size_t i = at; i < at + points; ++i) addOutside(key, i);
        continue;
      }
      if (key != last_key) {
        // A new end voxel or one met before: first the recent ends (L1-resident), then the
        // table. The slot of the run a few ahead is fetched meanwhile when it will be needed
        // (a new voxel's slot is anywhere). The table's size as of now: findOrAddEnd() grows it.
        const std::uint32_t mask = static_cast<std::uint32_t>(table.size() - 1);
        if (r + kRunsAhead < runs.count) {
          const std::uint32_t ahead = keys[run_first[r + kRunsAhead]];
          if (recent[recentIndex(ahead)].key != ahead)
            __builtin_prefetch(&table[hashKey(ahead) & mask]);
        }
        RecentEnd& entry = recent[recentIndex(key)];
        if (entry.key != key) {
          const Slot& slot = table[hashKey(key) & mask];
          entry = {key,
                   slot.stamp == stamp && slot.key == key ? slot.end : findOrAddEnd(part, key)};
        }
        last = &ends[entry.end];
        last_key = key;
        last_cut = key >> 31;  // kPointCutFlag
        if (last->points.min.x() > last->points.max.x()) last->p_W = worldPoint(at);  // first point
      }
      const float* box = run_box + 8 * r;
      last->points.min = last->points.min.cwiseMin(Eigen::Vector3f(box[0], box[1], box[2]));
      last->points.max = last->points.max.cwiseMax(Eigen::Vector3f(box[4], box[5], box[6]));
      c.beyond_max_range += last_cut * points;
    }
  }
}

double AwarenessStage::updateAwarenessMap(const Eigen::Vector3d& body_W,
                                          const std::vector<End>& ends) {
  const auto start = std::chrono::steady_clock::now();
  map_.beginFrame(body_W);
  for (const End& e : ends) {
    if (!e.cut) map_.markHit(e.p_W);
  }
  map_.castRaysToHits();
  for (const End& e : ends) {
    if (e.cut) map_.castRay(e.p_W, /*end_is_free=*/true);
  }
  map_.endFrame();
  map_bytes_.store(map_.memoryBytes(), std::memory_order_relaxed);
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

double AwarenessStage::mapAndListCones(const Eigen::Vector3d& body_W,
                                       const Eigen::Vector3d& origin_vox,
                                       const std::vector<End>& ends, ConeListingStep from) {
  auto listRest = [&] {
    advanceListing(origin_vox, ends, from, ConeListingStep::kConesListed, &carve_listing_,
                   &carve_listing_ms_);
  };
  if (threads_ == nullptr || from == ConeListingStep::kConesListed) {
    const double map_ms = updateAwarenessMap(body_W, ends);
    listRest();
    return map_ms;
  }
  // The awareness map and the cones share no state (both only read the ends): the map is
  // updated on a kept thread meanwhile, the same map either way.
  double map_ms = 0.0;
  threads_->run(2, [&](int job) {
    if (job == 0) {
      listRest();
    } else {
      map_ms = updateAwarenessMap(body_W, ends);
    }
  });
  return map_ms;
}

void AwarenessStage::advanceListing(const Eigen::Vector3d& o, const std::vector<End>& ends,
                                    ConeListingStep from, ConeListingStep to, ConeListing* listing,
                                    ListingMs* ms) const {
  *ms = ListingMs{};
  if (from < ConeListingStep::kBinsEntered && to >= ConeListingStep::kBinsEntered) {
    const SteadyClock::time_point start = SteadyClock::now();
    enterBins(o, ends, listing);
    ms->bins = msSince(start);
  }
  if (from < ConeListingStep::kConesListed && to >= ConeListingStep::kConesListed) {
    const SteadyClock::time_point start = SteadyClock::now();
    listCones(o, ends, listing);
    ms->cones = msSince(start);
  }
}

void AwarenessStage::enterBins(const Eigen::Vector3d& o, const std::vector<End>& ends,
                               ConeListing* listing) const {
  const int n0 = bins_per_face_side_;
  int lg0 = 0;
  while ((1 << lg0) < n0) ++lg0;
  // Every end's finest bin and its distance, in one pass over the ends; then the ends sorted by
  // bin, so that each level's bins come out in index order, a bin's children next to each other
  // (binKey()), and every level is built by one pass over the level below.
  std::vector<std::uint64_t>* order = &listing->order;
  std::vector<double>& near = listing->end_near;
  order->resize(ends.size());
  near.resize(ends.size());
  listing->end_bin.resize(ends.size());
  for (std::size_t i = 0; i < ends.size(); ++i) {
    const End& e = ends[i];
    const Eigen::Vector3d d = 0.5 * (e.points.min + e.points.max).cast<double>() - o;
    const Eigen::Vector3d m = d.cwiseAbs();
    int axis = 0;
    if (m.y() > m[axis]) axis = 1;
    if (m.z() > m[axis]) axis = 2;
    const double inv = 1.0 / std::max(m[axis], 1e-12);
    const int face = axis * 2 + (d[axis] < 0.0 ? 1 : 0);
    const int iu =
        std::clamp(static_cast<int>((d[(axis + 1) % 3] * inv + 1.0) * 0.5 * n0), 0, n0 - 1);
    const int iv =
        std::clamp(static_cast<int>((d[(axis + 2) % 3] * inv + 1.0) * 0.5 * n0), 0, n0 - 1);
    near[i] = distanceToBox(o, e.points);
    (*order)[i] = (std::uint64_t{binKey(face, iu, iv, lg0)} << 32) | i;
  }
  sortByKey(3 + 2 * lg0, order, &listing->order_scratch);
  // The bins of levels n0, n0 / 2, .., 1 a face side, each with its members' nearest distance.
  // A bin's directions start empty; listing the cones hulls its members' into them.
  Bin empty;
  empty.dir_lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::max());
  empty.dir_hi = Eigen::Vector3d::Constant(std::numeric_limits<double>::lowest());
  buildBinLevels(
      *order, static_cast<std::size_t>(lg0) + 1, empty,
      [&near](std::uint32_t i) { return near[i]; },
      [listing](std::uint32_t i, std::uint32_t place) { listing->end_bin[i] = place; },
      &listing->bins);
}

void AwarenessStage::listCones(const Eigen::Vector3d& o, const std::vector<End>& ends,
                               ConeListing* listing) const {
  std::vector<std::vector<Bin>>& levels = listing->bins;
  std::vector<Cone>& cones = listing->cones;
  const int n0 = bins_per_face_side_;
  const int level_count = static_cast<int>(levels.size());
  // Level L's bins cover the distances up to its reach (where they are still about
  // bin_width_voxels wide); a bin's reach is min(its nearest member, its level's reach).
  std::array<double, 32> level_reach{};
  for (int level = 0; level < level_count; ++level) {
    level_reach[static_cast<std::size_t>(level)] =
        0.5 * config_.awareness.bin_width_voxels * (n0 >> level);
  }
  auto reachOf = [&](int level, const Bin& bin) {
    return std::min(bin.near, level_reach[static_cast<std::size_t>(level)]);
  };
  // Each bin carves the part of its members' rays between its parent's reach and its own: the
  // members' point boxes scaled so that their nearest point lies at the bin's reach. In the ray
  // parameter u of a member (point = o + u (p - o)), the parent covers u <= parent_reach / near
  // and the bin continues from there to reach / near, so the chain leaves no gap. Scaling about
  // o commutes with the hull, so a bin keeps the hull of its members' (p - o) / near (its
  // directions): its box at its reach is o + reach [dir_lo, dir_hi], and a parent's directions
  // are the hull of its children's, with no scaling from level to level.
  //
  // A bin with one child (one member on the finest level) carves no cone of its own: its box is
  // its child's scaled about o, so its cone is the child's continued towards the sensor, and the
  // child's cone starts where the bin's would have (its `start`) instead. Most of a LiDAR scan's
  // bins have one child (95 % of the finest, 70 % of the next), so most chains are one cone,
  // not one per level. A bin's start is its parent's reach, or its parent's start when the
  // parent is a chain link; the coarsest bins start at the sensor.
  std::vector<Bin>& coarsest = levels[static_cast<std::size_t>(level_count) - 1];
  for (Bin& bin : coarsest) bin.start = 0.0;
  for (int level = level_count - 2; level >= 0; --level) {
    const std::vector<Bin>& parents = levels[static_cast<std::size_t>(level) + 1];
    for (Bin& bin : levels[static_cast<std::size_t>(level)]) {
      const Bin& parent = parents[bin.parent];
      bin.start = parent.children > 1 ? reachOf(level + 1, parent) : parent.start;
    }
  }
  // Each member carves the rest of its own cone: listed here, in the same pass over the ends (the
  // bins' cones follow). The nearest member of its bin has nothing left but its point box, which
  // lies in its own voxel, so a hit there needs no carving (it wins anyway). Only the float
  // rounding of the box can put a face of it on the next voxel's boundary, and the walk then
  // marked that voxel, which the ray does not reach.
  //
  // The directions stay finite: a distance above 0 is above 1e-162 (distanceToBox() squares it),
  // and an end's points lie within a voxel, so |p - o| / near < 1 + 2 / near.
  std::vector<Bin>& finest = levels[0];
  cones.clear();
  for (std::size_t i = 0; i < ends.size(); ++i) {
    const End& e = ends[i];
    const double near = listing->end_near[i];
    if (!(near > 0.0)) {
      cones.push_back({e.points, 0.0});
      continue;
    }
    Bin& bin = finest[listing->end_bin[i]];
    const double inv_near = 1.0 / near;
    bin.dir_lo = bin.dir_lo.cwiseMin((e.points.min.cast<double>() - o) * inv_near);
    bin.dir_hi = bin.dir_hi.cwiseMax((e.points.max.cast<double>() - o) * inv_near);
    const double s_min = (bin.children > 1 ? reachOf(0, bin) : bin.start) * inv_near;
    if (s_min >= 1.0 && !e.cut) continue;
    cones.push_back({e.points, s_min});
  }
  // A bin's box at its reach, rounded outwards to float.
  auto boxAt = [&o](const Bin& bin, double reach) {
    return roundOutwards(o + reach * bin.dir_lo, o + reach * bin.dir_hi);
  };
  // A child's directions are complete when its level is hulled into the next (its own children
  // came before), so its cone is listed in the same pass; the coarsest level's after it. Reach
  // never shrinks towards the fine end of a chain, because the nearest member and the level
  // reach both grow.
  for (int level = 1; level < level_count; ++level) {
    std::vector<Bin>& bins = levels[static_cast<std::size_t>(level)];
    for (const Bin& child : levels[static_cast<std::size_t>(level) - 1]) {
      if (child.dir_lo.x() > child.dir_hi.x()) continue;  // no member with a distance
      const double child_reach = reachOf(level - 1, child);
      if (child.children > 1 && child_reach > 0.0 && child_reach > child.start)
        cones.push_back({boxAt(child, child_reach), child.start / child_reach});
      Bin& parent = bins[child.parent];
      if (!(reachOf(level, parent) > 0.0)) continue;
      parent.dir_lo = parent.dir_lo.cwiseMin(child.dir_lo);
      parent.dir_hi = parent.dir_hi.cwiseMax(child.dir_hi);
    }
  }
  for (const Bin& bin : coarsest) {
    const double reach = reachOf(level_count - 1, bin);
    if (bin.children < 2 || !(reach > 0.0) || bin.dir_lo.x() > bin.dir_hi.x()) continue;
    cones.push_back({boxAt(bin, reach), 0.0});  // from the sensor
  }
}

void AwarenessStage::carveRange(const Eigen::Vector3d& o, int x_begin, int x_end,
                                MeasurementBatch* batch, std::size_t* free_count) const {
  VoxelBitset& free = batch->free;
  const bool whole = x_begin <= 0 && x_end >= free.dims().x();
  for (const Cone& cone : carve_listing_.cones) {
    if (whole) {
      carveCone(o, cone.box, cone.s_min, &free);
      continue;
    }
    // The cone's part s in [s_min, 1] lies between its sections at s_min and 1 (linear in s):
    // skip it when that lies outside the range with a voxel to spare (the call is exact).
    const double s0 = std::max(cone.s_min, 0.0);
    const double near_lo = o.x() + s0 * (cone.box.min.x() - o.x());
    const double near_hi = o.x() + s0 * (cone.box.max.x() - o.x());
    const double lo = std::min({near_lo, near_hi, static_cast<double>(cone.box.min.x())});
    const double hi = std::max({near_lo, near_hi, static_cast<double>(cone.box.max.x())});
    if (hi + 1.0 < x_begin || lo - 1.0 >= x_end) continue;
    carveCone(o, cone.box, cone.s_min, x_begin, x_end, &free);
  }
  // A hit wins over a miss.
  for (const HitMeasurement& h : batch->hits) {
    const VoxelIndex r = h.index - free.origin();
    if (r.x() < x_begin || r.x() >= x_end) continue;
    free.data()[free.rowWord(r.x(), r.y()) + static_cast<std::size_t>(r.z() >> 6)] &=
        ~(std::uint64_t{1} << (r.z() & 63));
  }
  *free_count = countBits(free, x_begin, x_end, free.markedRows());
}

void AwarenessStage::carveCones(const Eigen::Vector3d& o, MeasurementBatch* batch) {
  const int threads = threads_ != nullptr ? threads_->size() : 1;
  carve_bytes_.store(carveBytes(), std::memory_order_relaxed);
  const int dim_x = batch->free.dims().x();
  // Only these rows get bits: the count here, the local map's reading and the next frame's
  // clearing look only there (a 360-degree scan in a room marks a small part of its box).
  const std::vector<Cone>& cones = carve_listing_.cones;
  batch->free.setMarkedRows(conesRows(o, cones));
  if (threads == 1 || cones.size() < 2 * static_cast<std::size_t>(threads)) {
    carveRange(o, 0, dim_x, batch, &batch->free_count);
    batch->free.setRowsInUseValid();
    return;
  }
  // Each thread owns a range of box x: it marks only there, so no two write the same word and
  // the union is what one thread marks (cones straddling a border are walked by both sides,
  // each marking its part).
  const std::vector<int> borders = xRangesOfEqualWork(o, cones, dim_x, threads, &range_scratch_);
  std::vector<std::size_t> counts(static_cast<std::size_t>(threads), 0);
  threads_->run(threads, [&](int t) {
    const auto ut = static_cast<std::size_t>(t);
    carveRange(o, borders[ut], borders[ut + 1], batch, &counts[ut]);
  });
  batch->free_count = std::accumulate(counts.begin(), counts.end(), std::size_t{0});
  batch->free.setRowsInUseValid();  // the ranges cover every box x
}

std::size_t AwarenessStage::ConeListing::bytes() const {
  std::size_t n = (order.capacity() + order_scratch.capacity()) * sizeof(std::uint64_t) +
                  end_near.capacity() * sizeof(double) +
                  end_bin.capacity() * sizeof(std::uint32_t) + cones.capacity() * sizeof(Cone);
  for (const std::vector<Bin>& level : bins) n += level.capacity() * sizeof(Bin);
  return n;
}

std::size_t AwarenessStage::carveBytes() const {
  return carve_listing_.bytes() + range_scratch_.capacity() * sizeof(double);
}

std::size_t AwarenessStage::memoryBytes() const {
  std::size_t bins = carve_bytes_.load(std::memory_order_relaxed);
  {
    std::lock_guard<std::mutex> lock(collected_mutex_);
    const auto frameBytes = [](const CollectedFrame& f) {
      return f.ends.capacity() * sizeof(End) + f.listing.bytes();
    };
    for (const std::unique_ptr<CollectedFrame>& f : collected_) bins += frameBytes(*f);
    for (const std::unique_ptr<CollectedFrame>& f : spare_) bins += frameBytes(*f);
  }
  for (const PointPart& p : parts_) {
    bins += sizeof(p.recent) + p.table.capacity() * sizeof(Slot) +
            (p.ends.capacity() + p.outside.capacity()) * sizeof(End) +
            p.keys.capacity() * sizeof(std::uint32_t) +
            p.box_coords.capacity() * sizeof(p.box_coords[0]) +
            p.block_xyz.capacity() * sizeof(float) +
            p.runs.first.capacity() * sizeof(std::uint32_t) + p.runs.box.capacity() * sizeof(float);
  }
  bins += collect_listing_.bytes();
  return bins + map_bytes_.load(std::memory_order_relaxed) + ends_.capacity() * sizeof(End) +
         outside_.capacity() * sizeof(End) + sample_indices_.capacity() * sizeof(std::uint32_t);
}

}  // namespace mlmap
