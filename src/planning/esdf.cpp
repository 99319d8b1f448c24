// EsdfMap, the full compute(): the geometry and constants of a box, and the three passes over
// the whole box (pass 1 along x with esdf_kernel::sweepBlock(), passes 2 and 3 along y and z
// with the envelope code or the windowed 16-bit kernels). The incremental update() is in
// esdf_update.cpp.

#include "mlmap/planning/esdf.h"

#include "esdf_line_kernels.h"
#include "mlmap/planning/esdf_window_kernel.h"

#include <cstring>
#include <stdexcept>
#include <system_error>
#include <thread>

namespace mlmap {
namespace {

using esdf_kernel::StridedLine;
using esdf_kernel::sweepBlock;
using esdf_kernel::transformLine;

/// Largest metres lookup table (entries); larger caps use sqrt directly.
constexpr std::size_t kMaxLookupEntries = std::size_t{1} << 16;
/// Largest accepted |index| of the box corners (keeps grid coordinates far from int overflow).
constexpr std::int64_t kMaxAbsIndex = std::int64_t{1} << 30;

const EsdfConfig& validated(const EsdfConfig& config) {
  std::vector<std::string> errors;
  config.validate(&errors);
  throwIfInvalid(errors, "ESDF configuration");
  return config;
}

/// Runs work(thread, begin, end) over [0, count) cut into `threads` contiguous ranges; the
/// caller's thread takes range 0. Deterministic: a range's result does not depend on the others.
template <typename Work>
void parallelFor(int count, int threads, const Work& work) {
  threads = std::max(1, std::min(threads, count));
  const auto begin = [&](int t) {
    return static_cast<int>(static_cast<std::int64_t>(count) * t / threads);
  };
  std::vector<std::thread> pool;
  pool.reserve(static_cast<std::size_t>(threads - 1));
  for (int t = 1; t < threads; ++t) {
    const int b = begin(t);
    const int e = begin(t + 1);
    try {
      pool.emplace_back([&work, t, b, e] { work(t, b, e); });
    } catch (const std::system_error&) {
      work(t, b, e);  // no thread available: do that range here (it owns scratch t alone)
    }
  }
  work(0, 0, begin(1));
  for (std::thread& thread : pool) thread.join();
}

}  // namespace

bool EsdfMap::wellFormed(const OccupancyBox& box) {
  for (int a = 0; a < 3; ++a) {
    if (box.size[a] < 1 || box.size[a] > kMaxCellsPerAxis) return false;
    const std::int64_t lo = box.min_index[a];
    if (lo < -kMaxAbsIndex || lo + box.size[a] > kMaxAbsIndex) return false;
  }
  const std::int64_t cells = std::int64_t{box.size.x()} * box.size.y() * box.size.z();
  return cells <= kMaxCells && box.states.size() == static_cast<std::size_t>(cells) &&
         std::isfinite(box.resolution_m) && box.resolution_m > 0.0;
}

EsdfMap::EsdfMap(const EsdfConfig& config) : config_(validated(config)) {}

void EsdfMap::clear() {
  field_.clear();  // capacities are kept
  kept_ = false;
  changed_cells_.clear();
}

void EsdfMap::prepare(const OccupancyBox& box) {
  field_.reset(box.min_index, box.size, box.resolution_m);
  setClamp();
  sizeBuffers();
}

void EsdfMap::setClamp() {
  const Eigen::Vector3i& size = field_.size();
  const int nx = size.x();
  const int ny = size.y();
  const int nz = size.z();
  // Squared voxel distances above cap_sq_ are beyond max_distance_m (cap_sq_ > (max / res)^2),
  // or beyond anything the box holds; the work buffers store them as inf_.
  const double max_cells = config_.max_distance_m / field_.resolution_m();
  const double box_sq = static_cast<double>(nx - 1) * (nx - 1) +
                        static_cast<double>(ny - 1) * (ny - 1) +
                        static_cast<double>(nz - 1) * (nz - 1);
  cap_sq_ = static_cast<std::int32_t>(std::min(std::floor(max_cells * max_cells), box_sq) + 1.0);
  inf_ = cap_sq_ + 1;
  const std::int64_t longest_line = std::max(ny, nz);
  narrow_keys_ = (cap_sq_ + longest_line * longest_line) * longest_line < (std::int64_t{1} << 29);
  cap_d_ = static_cast<std::int32_t>(std::sqrt(static_cast<double>(cap_sq_)));
  while (std::int64_t{cap_d_ + 1} * (cap_d_ + 1) <= cap_sq_) ++cap_d_;
  while (std::int64_t{cap_d_} * cap_d_ > cap_sq_) --cap_d_;
  window_kernel_ = !envelope_only_ && esdf_kernel::windowFits(cap_sq_, cap_d_);
  if (2 * static_cast<std::size_t>(inf_) + 1 <= kMaxLookupEntries) {
    metres_table_.resize(2 * static_cast<std::size_t>(inf_) + 1);
    for (std::size_t i = 0; i < metres_table_.size(); ++i) {
      metres_table_[i] = slowMetres(static_cast<std::int32_t>(i) - inf_);
    }
  } else {
    metres_table_.clear();
  }
}

void EsdfMap::sizeBuffers() {
  const Eigen::Vector3i& size = field_.size();
  const int nx = size.x();
  const int ny = size.y();
  const int nz = size.z();
  const int threads = std::max(1, config_.num_threads);
  const std::size_t cells = field_.values_m().size();
  // Pass 1's results in 8 bits (+-(cap_d_ + 1) beyond the cap) and pass 2's in 16 where the
  // windowed passes apply (they fit), in 32 otherwise; the other buffers stay empty.
  if (window_kernel_) {
    pass1_.clear();
    pass2_.clear();
    pass1_narrow_.resize(cells);
    pass2_narrow_.resize(cells);
  } else {
    pass1_narrow_.clear();
    pass2_narrow_.clear();
    pass1_.resize(cells);
    pass2_.resize(cells);
  }
  tracker_.reset(size);
  if (scratch_.size() < static_cast<std::size_t>(threads)) {
    scratch_.resize(static_cast<std::size_t>(threads));
  }
  const std::size_t longest = static_cast<std::size_t>(std::max(ny, nz)) + 1;
  const std::size_t row_block =
      static_cast<std::size_t>(std::min(kRowBlock, ny)) * static_cast<std::size_t>(nz);
  for (Scratch& s : scratch_) {
    if (s.near_free.size() < row_block) {
      s.near_free.resize(row_block);
      s.near_obstacle.resize(row_block);
    }
    if (window_kernel_) {
      const std::size_t narrow_block =
          static_cast<std::size_t>(std::min(kNarrowRowBlock, ny)) * static_cast<std::size_t>(nz);
      if (s.sweep.size() < narrow_block * static_cast<std::size_t>(nx)) {
        s.sweep.resize(narrow_block * static_cast<std::size_t>(nx));
      }
    }
    if (s.runs.size() >= longest) continue;
    for (std::vector<std::int32_t>* v :
         {&s.runs, &s.out_sites, &s.in_sites, &s.out_keys32, &s.in_keys32, &s.line}) {
      v->resize(longest);
    }
    s.out_keys64.resize(longest);
    s.in_keys64.resize(longest);
  }
}

bool EsdfMap::compute(const OccupancyBox& box) {
  if (!wellFormed(box)) {
    clear();
    return false;
  }
  try {
    prepare(box);
  } catch (...) {
    clear();
    throw;
  }
  const int threads = std::max(1, config_.num_threads);
  const auto* states = reinterpret_cast<const std::uint8_t*>(box.states.data());
  std::memcpy(tracker_.keptStates(), states, box.states.size());
  const Eigen::Vector3i& size = field_.size();
  parallelFor(size.y(), threads, [this, states](int t, int b, int e) {
    sweepRows(states, b, e, &scratch_[static_cast<std::size_t>(t)]);
  });
  parallelFor(size.x(), threads, [this, states](int t, int b, int e) {
    transformSlabs(states, b, e, &scratch_[static_cast<std::size_t>(t)]);
  });
  kept_ = true;
  last_update_ = UpdateStats{};
  last_update_.changed_states = box.states.size();
  last_update_.rows_swept = static_cast<std::size_t>(size.y());
  last_update_.y_lines = static_cast<std::size_t>(size.x()) * static_cast<std::size_t>(size.z());
  last_update_.z_lines = static_cast<std::size_t>(size.x()) * static_cast<std::size_t>(size.y());
  last_update_.changed_cells = box.states.size();
  changed_cells_.clear();
  return true;
}

void EsdfMap::sweepRows(const std::uint8_t* states, int y_begin, int y_end, Scratch* scratch) {
  const Eigen::Vector3i& size = field_.size();
  const int nz = size.z();
  const std::size_t slab = static_cast<std::size_t>(size.y()) * static_cast<std::size_t>(nz);
  const std::int32_t unknown_is_obstacle = unknownIsObstacle();
  if (window_kernel_) {
    // kNarrowRowBlock rows at a time through the scratch buffer, out in 8 bits.
    for (int y0 = y_begin; y0 < y_end; y0 += kNarrowRowBlock) {
      const std::size_t row = static_cast<std::size_t>(y0) * nz;
      const int n = std::min(kNarrowRowBlock, y_end - y0) * nz;
      sweepBlock(states + row, slab, scratch->sweep.data(), static_cast<std::size_t>(n), size.x(),
                 n, scratch->near_free.data(), scratch->near_obstacle.data(), unknown_is_obstacle,
                 cap_d_, pass1Inf(), pass1_narrow_.data() + row, slab);
    }
    return;
  }
  // kRowBlock rows (y) at a time: each x step then reads one contiguous run of the arrays.
  for (int y0 = y_begin; y0 < y_end; y0 += kRowBlock) {
    const std::size_t row = static_cast<std::size_t>(y0) * nz;
    const int n = std::min(kRowBlock, y_end - y0) * nz;
    sweepBlock(states + row, slab, pass1_.data() + row, slab, size.x(), n,
               scratch->near_free.data(), scratch->near_obstacle.data(), unknown_is_obstacle,
               cap_d_, inf_);
  }
}

void EsdfMap::transformYLine(int x, int z, int begin, int end, std::int32_t* line,
                             Scratch* scratch) const {
  const int ny = end - begin;
  const int nz = field_.size().z();
  const std::int32_t* in =
      pass1_.data() + (static_cast<std::size_t>(x) * field_.size().y() + begin) * nz + z;
  for (int y = 0; y < ny; ++y) line[y] = in[static_cast<std::ptrdiff_t>(y) * nz];
  if (narrow_keys_) {
    transformLine<std::int32_t, std::int32_t*, true>(
        line, ny, cap_sq_, cap_d_,
        {scratch->runs.data(), scratch->out_sites.data(), scratch->out_keys32.data(),
         scratch->in_sites.data(), scratch->in_keys32.data()});
  } else {
    transformLine<std::int64_t, std::int32_t*, true>(
        line, ny, cap_sq_, cap_d_,
        {scratch->runs.data(), scratch->out_sites.data(), scratch->out_keys64.data(),
         scratch->in_sites.data(), scratch->in_keys64.data()});
  }
}

void EsdfMap::transformZLine(int x, int y, int begin, int end, std::int32_t* line,
                             Scratch* scratch) const {
  const int nz = end - begin;
  const Eigen::Vector3i& size = field_.size();
  std::memcpy(line, pass2_.data() + (static_cast<std::size_t>(x) * size.y() + y) * size.z() + begin,
              static_cast<std::size_t>(nz) * sizeof(std::int32_t));
  if (size.z() == 1) return;  // (as compute(): no z pass)
  if (narrow_keys_) {
    transformLine<std::int32_t, std::int32_t*, false>(
        line, nz, cap_sq_, cap_d_,
        {scratch->runs.data(), scratch->out_sites.data(), scratch->out_keys32.data(),
         scratch->in_sites.data(), scratch->in_keys32.data()});
  } else {
    transformLine<std::int64_t, std::int32_t*, false>(
        line, nz, cap_sq_, cap_d_,
        {scratch->runs.data(), scratch->out_sites.data(), scratch->out_keys64.data(),
         scratch->in_sites.data(), scratch->in_keys64.data()});
  }
}

void EsdfMap::transformSlabs(const std::uint8_t* states, int x_begin, int x_end, Scratch* scratch) {
  const int ny = field_.size().y();
  const int nz = field_.size().z();
  const std::size_t slab = static_cast<std::size_t>(ny) * static_cast<std::size_t>(nz);
  const float* table = metres_table_.empty() ? nullptr : metres_table_.data() + inf_;
  for (int x = x_begin; x < x_end; ++x) {
    if (!window_kernel_) {
      transformSlabEnvelope(x, table, scratch);
      field_.writeUnknownBits(states, x);
      continue;
    }
    // Both passes on 16-bit copies of the slab (see esdf_window_kernel.h); the metres table is
    // there (windowFits() keeps 2 inf_ + 1 below its limit).
    const std::size_t first = static_cast<std::size_t>(x) * slab;
    float* field = field_.mutableValues_m().data() + first;
    esdf_kernel::WindowBuffers* buffers = &scratch->window;
    esdf_kernel::transformSlabY(pass1_narrow_.data() + first, ny, nz, cap_sq_, cap_d_,
                                pass2_narrow_.data() + first, buffers);
    esdf_kernel::transformSlabZ(ny, nz, cap_sq_, cap_d_, buffers);
    const std::int16_t* values = buffers->signed_sq.data();  // z-major
    const auto lanes = static_cast<std::size_t>(esdf_kernel::paddedLanes(ny));
    for (int y = 0; y < ny; ++y) {
      float* out = field + static_cast<std::size_t>(y) * nz;
      for (int z = 0; z < nz; ++z) out[z] = table[values[static_cast<std::size_t>(z) * lanes + y]];
    }
    field_.writeUnknownBits(states, x);
  }
}

void EsdfMap::transformSlabEnvelope(int x, const float* table, Scratch* scratch) {
  const int ny = field_.size().y();
  const int nz = field_.size().z();
  const std::size_t slab = static_cast<std::size_t>(ny) * static_cast<std::size_t>(nz);
  const std::size_t first = static_cast<std::size_t>(x) * slab;
  float* field = field_.mutableValues_m().data() + first;
  std::int32_t* line = scratch->line.data();
  // Pass 2 in place on a copy of pass 1's slab (the slab stays in cache).
  std::int32_t* a = pass2_.data() + first;
  std::memcpy(a, pass1_.data() + first, slab * sizeof(std::int32_t));
  for (int z = 0; z < nz; ++z) {
    const StridedLine y_line{a + z, nz};
    if (narrow_keys_) {
      transformLine<std::int32_t, StridedLine, true>(
          y_line, ny, cap_sq_, cap_d_,
          {scratch->runs.data(), scratch->out_sites.data(), scratch->out_keys32.data(),
           scratch->in_sites.data(), scratch->in_keys32.data()});
    } else {
      transformLine<std::int64_t, StridedLine, true>(
          y_line, ny, cap_sq_, cap_d_,
          {scratch->runs.data(), scratch->out_sites.data(), scratch->out_keys64.data(),
           scratch->in_sites.data(), scratch->in_keys64.data()});
    }
  }
  // Pass 3 line by line, into the field in metres.
  for (int y = 0; y < ny; ++y) {
    transformZLine(x, y, 0, nz, line, scratch);
    float* out = field + static_cast<std::size_t>(y) * nz;
    if (table != nullptr) {
      for (int z = 0; z < nz; ++z) out[z] = table[line[z]];
    } else {
      for (int z = 0; z < nz; ++z) out[z] = slowMetres(line[z]);
    }
  }
}

void EsdfMap::copyFrom(const EsdfMap& source) {
  config_ = source.config_;
  field_ = source.field_;
  cap_sq_ = source.cap_sq_;
  inf_ = source.inf_;
  cap_d_ = source.cap_d_;
  narrow_keys_ = source.narrow_keys_;
  kept_ = false;
  last_update_ = source.last_update_;
  changed_cells_.clear();
}

bool EsdfMap::copyCells(const EsdfMap& source, const std::vector<std::uint32_t>& offsets) {
  return field_.copyCells(source.field_, offsets);
}

float EsdfMap::slowMetres(std::int32_t value) const {
  const float max_m = static_cast<float>(config_.max_distance_m);
  const std::int32_t magnitude = value < 0 ? -value : value;
  const float m = magnitude >= inf_
                      ? max_m
                      : std::min(static_cast<float>(std::sqrt(static_cast<double>(magnitude)) *
                                                    field_.resolution_m()),
                                 max_m);
  return value < 0 ? -m : m;
}

float EsdfMap::distanceAt(const VoxelIndex& world_index) const {
  return field_.distanceAt(world_index);
}

std::size_t EsdfMap::memoryBytes() const {
  std::size_t bytes =
      field_.memoryBytes() + tracker_.memoryBytes() +
      (pass1_.capacity() + pass2_.capacity() + row_buffer_.capacity()) * sizeof(std::int32_t) +
      pass2_narrow_.capacity() * sizeof(std::int16_t) +
      pass1_narrow_.capacity() * sizeof(std::int8_t) +
      changed_cells_.capacity() * sizeof(std::uint32_t) + metres_table_.capacity() * sizeof(float) +
      scratch_.capacity() * sizeof(Scratch);
  for (const Scratch& s : scratch_) {
    bytes +=
        (s.runs.capacity() + s.out_sites.capacity() + s.in_sites.capacity() +
         s.out_keys32.capacity() + s.in_keys32.capacity() + s.near_free.capacity() +
         s.near_obstacle.capacity() + s.line.capacity() + s.sweep.capacity()) *
            sizeof(std::int32_t) +
        (s.out_keys64.capacity() + s.in_keys64.capacity()) * sizeof(std::int64_t) +
        s.gathered.capacity() * sizeof(std::int16_t) + s.narrow_rows.capacity() +
        (s.window.magnitude.capacity() + s.window.best.capacity() + s.window.near_free.capacity() +
         s.window.near_obstacle.capacity() + s.window.lines.capacity() +
         s.window.transposed.capacity() + s.window.signed_sq.capacity()) *
            sizeof(std::int16_t);
  }
  return bytes;
}

}  // namespace mlmap
