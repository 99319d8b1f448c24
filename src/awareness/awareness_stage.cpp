#include "mlmap/awareness/awareness_stage.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace mlmap {
namespace {
constexpr std::uint32_t kCutFlag = 0x80000000u;
// Direction bins at most this many voxels wide at the maximum range (over-carving bound).
constexpr double kBinWidthVoxels = 1.0;
constexpr int kMaxBinsPerFaceSide = 256;

std::uint32_t hashKey(std::uint32_t key) {
  key ^= key >> 16;
  key *= 0x7feb352du;
  key ^= key >> 15;
  key *= 0x846ca68bu;
  key ^= key >> 16;
  return key;
}

double distanceToBox(const Eigen::Vector3d& o, const VoxelSpaceBox& b) {
  const Eigen::Vector3d d = (b.min.cast<double>() - o).cwiseMax(o - b.max.cast<double>()).cwiseMax(0.0);
  return d.norm();
}
}  // namespace

PointCounters& PointCounters::operator+=(const PointCounters& o) {
  points_in += o.points_in;
  rejected_non_finite += o.rejected_non_finite;
  rejected_too_close += o.rejected_too_close;
  beyond_max_range += o.beyond_max_range;
  sampled_out += o.sampled_out;
  hit_voxels += o.hit_voxels;
  free_voxels += o.free_voxels;
  return *this;
}

AwarenessStage::AwarenessStage(const MapConfig& config)
    : config_(config), map_(config.awareness), table_(1u << 15), rng_(config.awareness.sample_seed) {
  const double range_voxels = config.awareness.max_range_m / config.local_map.resolution_m;
  // Cube-map face coordinates span [-1, 1]; a bin of width 2 / n subtends at most ~2 / n rad.
  bins_per_face_side_ = std::clamp(static_cast<int>(std::ceil(2.0 * range_voxels / kBinWidthVoxels)),
                                   8, kMaxBinsPerFaceSide);
  bins_.resize(6u * static_cast<std::size_t>(bins_per_face_side_) *
               static_cast<std::size_t>(bins_per_face_side_));
}

std::uint32_t AwarenessStage::directionBin(const Eigen::Vector3d& d) const {
  const Eigen::Vector3d m = d.cwiseAbs();
  int axis = 0;
  if (m.y() > m[axis]) axis = 1;
  if (m.z() > m[axis]) axis = 2;
  const double inv = 1.0 / std::max(m[axis], 1e-12);
  const double u = d[(axis + 1) % 3] * inv;  // in [-1, 1]
  const double v = d[(axis + 2) % 3] * inv;
  const int n = bins_per_face_side_;
  const int iu = std::min(static_cast<int>((u + 1.0) * 0.5 * n), n - 1);
  const int iv = std::min(static_cast<int>((v + 1.0) * 0.5 * n), n - 1);
  const int face = axis * 2 + (d[axis] < 0.0 ? 1 : 0);
  return static_cast<std::uint32_t>((face * n + iu) * n + iv);
}

std::uint32_t AwarenessStage::findOrAddEnd(std::uint32_t key, bool cut, const Eigen::Vector3i& voxel) {
  const std::uint32_t full_key = key | (cut ? kCutFlag : 0u);
  if (2 * (ends_.size() + 1) > table_.size()) {
    // Grow and re-insert this frame's ends.
    std::vector<Slot> bigger(table_.size() * 2);
    const std::uint32_t mask = static_cast<std::uint32_t>(bigger.size() - 1);
    for (std::uint32_t e = 0; e < ends_.size(); ++e) {
      const Eigen::Vector3i& v = ends_[e].voxel;  // only ends inside the box are in ends_ here
      const std::uint32_t k =
          static_cast<std::uint32_t>((static_cast<std::size_t>(v.x()) * hit_bits_.dims().y() + v.y()) *
                                         hit_bits_.dims().z() + v.z()) |
          (ends_[e].cut ? kCutFlag : 0u);
      std::uint32_t h = hashKey(k) & mask;
      while (bigger[h].stamp == stamp_) h = (h + 1) & mask;
      bigger[h] = {stamp_, k, e};
    }
    table_.swap(bigger);
  }
  const std::uint32_t mask = static_cast<std::uint32_t>(table_.size() - 1);
  std::uint32_t h = hashKey(full_key) & mask;
  for (;;) {
    Slot& slot = table_[h];
    if (slot.stamp != stamp_) {
      slot = {stamp_, full_key, static_cast<std::uint32_t>(ends_.size())};
      End e;
      e.voxel = voxel;
      e.cut = cut;
      e.points.min = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
      e.points.max = Eigen::Vector3f::Constant(std::numeric_limits<float>::lowest());
      ends_.push_back(e);
      return slot.end;
    }
    if (slot.key == full_key) return slot.end;
    h = (h + 1) & mask;
  }
}

void AwarenessStage::process(const PointCloudFrame& frame, MeasurementBatch* batch,
                             PointCounters* counters) {
  const AwarenessConfig& ac = config_.awareness;
  const double res = config_.local_map.resolution_m;
  const Transform T_W_S = frame.T_W_B * frame.T_B_S;
  const Eigen::Vector3d o_W = T_W_S.translation();
  const Eigen::Vector3d body_W = frame.T_W_B.translation();

  // Scratch box around the sensor: everything within range that the local map can hold. After
  // re-centring the body lies in the centre submap, so the map reaches at most 3 submaps away.
  const VoxelIndex sensor_voxel = voxelIndexOf(o_W, res);
  const int range_voxels = static_cast<int>(std::ceil(ac.max_range_m / res)) + 1;
  const int offset_voxels = static_cast<int>(std::ceil((o_W - body_W).norm() / res)) + 1;
  const Eigen::Vector3i submap = config_.local_map.submap_cells();
  Eigen::Vector3i half;
  for (int a = 0; a < 3; ++a) half[a] = std::min(range_voxels, 3 * submap[a] + offset_voxels);
  const VoxelIndex box_origin = sensor_voxel - half;
  const Eigen::Vector3i dims = 2 * half + Eigen::Vector3i::Ones();
  hit_bits_.reset(box_origin, dims);
  batch->free.reset(box_origin, dims);
  batch->hits.clear();
  batch->stamp_s = frame.stamp_s;
  batch->T_W_B = frame.T_W_B;
  batch->sensor_origin_W = o_W;
  batch->resolution_m = res;
  ends_.clear();
  if (++stamp_ == 0) {  // wrapped: forget every slot
    std::fill(table_.begin(), table_.end(), Slot{});
    stamp_ = 1;
  }

  PointCounters c;
  const std::size_t n = frame.points_S.size();
  c.points_in = n;
  const bool sample = ac.sample_count > 0 && n > static_cast<std::size_t>(ac.sample_count);
  std::size_t count = n;
  if (sample) {
    sample_indices_.resize(n);
    std::iota(sample_indices_.begin(), sample_indices_.end(), 0u);
    count = static_cast<std::size_t>(ac.sample_count);
    for (std::size_t i = 0; i < count; ++i) {
      std::uniform_int_distribution<std::size_t> pick(i, n - 1);
      std::swap(sample_indices_[i], sample_indices_[pick(rng_)]);
    }
    c.sampled_out = n - count;
  }

  // Point voxel: floor((o + R p) / res), in double so that a point on a voxel face goes to the
  // same side as voxelIndexOf() puts it; box-relative coordinates give the point's box.
  const double inv_res = 1.0 / res;
  const Eigen::Vector3d origin_vox = o_W * inv_res - box_origin.cast<double>();
  const Eigen::Matrix3d R_W_S = T_W_S.linear();
  const double min_range2 = ac.min_range_m * ac.min_range_m;
  const double max_range = ac.max_range_m;
  const double max_range2 = max_range * max_range;
  const std::uint32_t dim_y = static_cast<std::uint32_t>(dims.y());
  const std::uint32_t dim_z = static_cast<std::uint32_t>(dims.z());
  const double box_offset[3] = {static_cast<double>(box_origin.x()),
                                static_cast<double>(box_origin.y()),
                                static_cast<double>(box_origin.z())};
  std::uint32_t last_key = 0xFFFFFFFFu;
  std::uint32_t last_end = 0;
  outside_.clear();
  for (std::size_t idx = 0; idx < count; ++idx) {
    const Eigen::Vector3f& p_S = frame.points_S[sample ? sample_indices_[idx] : idx];
    if (!std::isfinite(p_S.x()) || !std::isfinite(p_S.y()) || !std::isfinite(p_S.z())) {
      ++c.rejected_non_finite;
      continue;
    }
    const Eigen::Vector3d q_S = p_S.cast<double>();
    const double r2 = q_S.squaredNorm();
    if (r2 <= min_range2) {
      ++c.rejected_too_close;
      continue;
    }
    const bool cut = r2 > max_range2;
    Eigen::Vector3d p_W = o_W + R_W_S * q_S;
    if (cut) {
      p_W = o_W + R_W_S * (q_S * (max_range / std::sqrt(r2)));
      ++c.beyond_max_range;
    }
    // Poses are within 1e6 m and points within max_range_m, so w fits an int.
    double v[3] = {0.0, 0.0, 0.0};
    int iv[3] = {0, 0, 0};
    bool inside = true;
    for (int a = 0; a < 3; ++a) {
      const double w = p_W[a] * inv_res;
      iv[a] = floorToInt(w) - box_origin[a];
      v[a] = w - box_offset[a];
      inside = inside && iv[a] >= 0 && iv[a] < dims[a];
    }
    const Eigen::Vector3f vf(static_cast<float>(v[0]), static_cast<float>(v[1]),
                             static_cast<float>(v[2]));
    if (!inside) {
      // Beyond what the local map can hold; the awareness map and the carving still use it.
      End e;
      e.voxel = Eigen::Vector3i::Constant(-1);
      e.points = {vf, vf};
      e.p_W = p_W;
      e.cut = cut;
      outside_.push_back(e);
      continue;
    }
    const std::uint32_t key =
        ((static_cast<std::uint32_t>(iv[0]) * dim_y + static_cast<std::uint32_t>(iv[1])) * dim_z +
         static_cast<std::uint32_t>(iv[2])) |
        (cut ? kCutFlag : 0u);
    if (key != last_key) {
      last_end = findOrAddEnd(key & ~kCutFlag, cut, Eigen::Vector3i(iv[0], iv[1], iv[2]));
      last_key = key;
      End& e = ends_[last_end];
      if (e.points.min.x() > e.points.max.x()) {  // new: remember its first point
        e.p_W = p_W;
        if (!cut) hit_bits_.testAndSet(iv[0], iv[1], iv[2]);
      }
    }
    End& e = ends_[last_end];
    e.points.min = e.points.min.cwiseMin(vf);
    e.points.max = e.points.max.cwiseMax(vf);
  }

  // Occupied list (unique voxels).
  for (const End& e : ends_) {
    if (!e.cut) batch->hits.push_back({e.voxel + box_origin, e.p_W});
  }

  // Awareness map: carried obstacles, hits, then the 2D rho-z ray walks.
  map_.beginFrame(body_W);
  for (const auto* list : {&ends_, &outside_}) {
    for (const End& e : *list) {
      if (!e.cut) map_.markHit(e.p_W);
    }
  }
  map_.castRaysToHits();
  for (const auto* list : {&ends_, &outside_}) {
    for (const End& e : *list) {
      if (e.cut) map_.castRay(e.p_W, /*end_is_free=*/true);
    }
  }
  map_.endFrame();

  std::size_t freed = 0;
  carve(origin_vox, batch, &freed);
  batch->free_count = freed;
  c.hit_voxels = batch->hits.size();
  c.free_voxels = freed;
  *counters += c;
}

void AwarenessStage::carve(const Eigen::Vector3d& o, MeasurementBatch* batch, std::size_t* freed) {
  // 1. Bin the ends by direction; each bin's shared cone reaches its nearest member.
  touched_bins_.clear();
  ends_.insert(ends_.end(), outside_.begin(), outside_.end());  // hits are listed already
  for (End& e : ends_) {
    const Eigen::Vector3d centre = 0.5 * (e.points.min + e.points.max).cast<double>();
    e.bin = directionBin(centre - o);
    e.near = distanceToBox(o, e.points);
    Bin& bin = bins_[e.bin];
    if (bin.stamp != stamp_) {
      bin.stamp = stamp_;
      bin.near = e.near;
      touched_bins_.push_back(e.bin);
    } else {
      bin.near = std::min(bin.near, e.near);
    }
  }
  // 2. The bin's box: the hull of its members' point boxes scaled towards the sensor so that
  //    their nearest point lies at the bin's distance. conv(o, scaled box) holds every member
  //    ray up to that distance.
  for (std::uint32_t b : touched_bins_) {
    bins_[b].box.min = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
    bins_[b].box.max = Eigen::Vector3f::Constant(std::numeric_limits<float>::lowest());
  }
  const Eigen::Vector3f of = o.cast<float>();
  for (const End& e : ends_) {
    Bin& bin = bins_[e.bin];
    const float lambda = e.near > 0.0 ? static_cast<float>(bin.near / e.near) : 0.0f;
    bin.box.min = bin.box.min.cwiseMin(of + lambda * (e.points.min - of));
    bin.box.max = bin.box.max.cwiseMax(of + lambda * (e.points.max - of));
  }
  for (std::uint32_t b : touched_bins_) {
    if (bins_[b].near > 0.0) *freed += carveCone(o, bins_[b].box, 0.0, hit_bits_, &batch->free);
  }
  // 3. Each member carves the rest of its own cone, beyond the part its bin covered.
  for (const End& e : ends_) {
    const double s_min = e.near > 0.0 ? bins_[e.bin].near / e.near : 0.0;
    *freed += carveCone(o, e.points, s_min, hit_bits_, &batch->free, /*skip_end=*/!e.cut, e.voxel);
  }
}

std::size_t AwarenessStage::memoryBytes() const {
  return map_.memoryBytes() + hit_bits_.memoryBytes() + ends_.capacity() * sizeof(End) +
         table_.capacity() * sizeof(Slot) + bins_.capacity() * sizeof(Bin) +
         touched_bins_.capacity() * sizeof(std::uint32_t) +
         sample_indices_.capacity() * sizeof(std::uint32_t);
}

}  // namespace mlmap
