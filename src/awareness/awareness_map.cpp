#include "mlmap/awareness/awareness_map.h"

#include <algorithm>
#include <cmath>

namespace mlmap {
namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 6.28318530717958647692;
// A direction at least this far from a sector boundary (as a fraction of its length: radians)
// is in the sector the boundary test says, whatever the rounding of atan2, the division and the
// boundary directions (each about 1e-16).
constexpr double kBoundaryMargin = 1e-12;
// Boundary slack so that a cone merely touching a cell edge does not clear it.
constexpr double kEdgeEpsilon = 1e-9;
}  // namespace

AwarenessMap::AwarenessMap(const AwarenessConfig& config)
    : config_(config),
      phi_cell_rad_(config.phi_cell_rad()),
      cells_(static_cast<std::size_t>(config.rho_cells) *
                 static_cast<std::size_t>(config.phi_cells) *
                 static_cast<std::size_t>(config.z_cells),
             0) {
  for (int i = 0; i <= config.phi_cells; ++i) {
    const double theta = i * phi_cell_rad_;
    boundary_cos_.push_back(std::cos(theta));
    boundary_sin_.push_back(std::sin(theta));
  }
}

int AwarenessMap::phiIndex(double dx, double dy, double rho) const {
  if (rho > 0.0) {
    // An estimate within 2e-4 rad (atan on [0, 1] by a cubic in a^2, then the octant; sectors are
    // at least 1.5e-3 rad wide)...
    const double ax = std::abs(dx);
    const double ay = std::abs(dy);
    const double a = std::min(ax, ay) / std::max(ax, ay);
    const double s = a * a;
    double phi = ((-0.0464964749 * s + 0.15931422) * s - 0.327622764) * s * a + a;
    if (ay > ax) phi = 0.5 * kPi - phi;
    if (dx < 0.0) phi = kPi - phi;
    if (dy < 0.0) phi = kTwoPi - phi;
    int i = std::min(static_cast<int>(phi / phi_cell_rad_), config_.phi_cells - 1);
    // ...then the sector by the side of its two boundaries the direction lies on (one step to a
    // neighbour when the estimate was next to a boundary). Sectors span at most 90 degrees.
    const double margin = kBoundaryMargin * rho;
    for (int step = 0; step < 2; ++step) {
      const std::size_t k = static_cast<std::size_t>(i);
      const double past_lo = boundary_cos_[k] * dy - boundary_sin_[k] * dx;
      const double past_hi = boundary_cos_[k + 1] * dy - boundary_sin_[k + 1] * dx;
      if (past_lo > margin && past_hi < -margin) return i;
      if (std::abs(past_lo) <= margin || std::abs(past_hi) <= margin) break;  // on a boundary
      i = past_lo < 0.0 ? (i == 0 ? config_.phi_cells - 1 : i - 1)
                        : (i + 1 == config_.phi_cells ? 0 : i + 1);
    }
  }
  // On a boundary (or at the axis): atan2 decides, as it always did.
  double phi = std::atan2(dy, dx);
  if (phi < 0.0) phi += kTwoPi;
  int phi_index = static_cast<int>(phi / phi_cell_rad_);
  if (phi_index >= config_.phi_cells) phi_index -= config_.phi_cells;  // phi == 2 pi - eps rounding
  return phi_index;
}

bool AwarenessMap::cellOf(const Eigen::Vector3d& p_W, AwarenessCell* cell) const {
  const Eigen::Vector3d d = p_W - origin_W_;
  const double rho = std::sqrt(d.x() * d.x() + d.y() * d.y());
  const double rho_index = std::floor(rho / config_.rho_cell_m);
  const double z_index = std::floor(d.z() / config_.z_cell_m) + config_.z_cells_below;
  if (!(rho_index < config_.rho_cells) || !(z_index >= 0.0) || !(z_index < config_.z_cells)) {
    return false;
  }
  cell->rho = static_cast<int>(rho_index);
  cell->phi = phiIndex(d.x(), d.y(), rho);
  cell->z = static_cast<int>(z_index);
  return true;
}

Occupancy AwarenessMap::state(const AwarenessCell& cell) const {
  const std::uint8_t v = cells_[linear(cell.rho, cell.phi, cell.z)];
  if (v & kOccupiedBit) return Occupancy::kOccupied;
  if (v & kFreeBit) return Occupancy::kFree;
  return Occupancy::kUnknown;
}

Occupancy AwarenessMap::stateAt(const Eigen::Vector3d& p_W) const {
  AwarenessCell cell;
  return cellOf(p_W, &cell) ? state(cell) : Occupancy::kUnknown;
}

Eigen::Vector3d AwarenessMap::cellCenter(const AwarenessCell& cell) const {
  const double rho = (cell.rho + 0.5) * config_.rho_cell_m;
  const double phi = (cell.phi + 0.5) * phi_cell_rad_;
  const double z = (cell.z - config_.z_cells_below + 0.5) * config_.z_cell_m;
  return origin_W_ + Eigen::Vector3d(rho * std::cos(phi), rho * std::sin(phi), z);
}

void AwarenessMap::beginFrame(const Eigen::Vector3d& body_W) {
  origin_W_ = body_W;
  std::fill(cells_.begin(), cells_.end(), std::uint8_t{0});
  hits_.clear();
  hit_cells_.clear();
  // Eq. 10: the previous occupied cells, moved by the pose change. The grid is world-aligned, so
  // the change is a translation and a carried obstacle keeps its world point.
  std::size_t kept = 0;
  for (const Eigen::Vector3d& p_W : occupied_points_) {
    AwarenessCell cell;
    if (!cellOf(p_W, &cell)) continue;
    const std::size_t i = linear(cell.rho, cell.phi, cell.z);
    if (cells_[i] & kOccupiedBit) continue;
    cells_[i] = kOccupiedBit;
    if (kept < carried_.size()) {
      carried_[kept] = {i, p_W};
    } else {
      carried_.push_back({i, p_W});
    }
    ++kept;
  }
  carried_.resize(kept);
}

bool AwarenessMap::markHit(const Eigen::Vector3d& p_W) {
  AwarenessCell cell;
  if (!cellOf(p_W, &cell)) return false;
  const std::size_t i = linear(cell.rho, cell.phi, cell.z);
  if (!(cells_[i] & kHitBit)) {
    cells_[i] = kOccupiedBit | kHitBit;
    hits_.push_back({i, p_W});
    hit_cells_.push_back(cell);
  }
  return true;
}

void AwarenessMap::castRaysToHits() {
  for (const AwarenessCell& cell : hit_cells_) {
    std::uint8_t& v = cells_[linear(cell.rho, cell.phi, cell.z)];
    if (v & kWalkedBit) continue;
    v |= kWalkedBit;
    walkCone(cell);
  }
}

void AwarenessMap::castRay(const Eigen::Vector3d& end_W, bool end_is_free) {
  Eigen::Vector3d end = end_W;
  const Eigen::Vector3d d = end_W - origin_W_;
  // Cut a segment that leaves through the top, bottom or side at the border of the grid.
  double scale = 1.0;
  const double z_top = (config_.z_cells - config_.z_cells_below) * config_.z_cell_m;
  const double z_bottom = -config_.z_cells_below * config_.z_cell_m;
  if (d.z() >= z_top) scale = std::min(scale, z_top / d.z());
  if (d.z() < z_bottom) scale = std::min(scale, z_bottom / d.z());
  const double rho = std::sqrt(d.x() * d.x() + d.y() * d.y());
  if (rho >= config_.radius_m()) scale = std::min(scale, config_.radius_m() / rho);
  if (!end_is_free && scale >= 1.0) markHit(end_W);
  if (scale < 1.0) {
    // Stay a hair inside so the border cell is the end cell (cleared, not hit).
    scale *= 1.0 - 1e-9;
    end = origin_W_ + d * scale;
  }
  AwarenessCell cell;
  if (!cellOf(end, &cell)) return;
  // One cone per end cell and frame: the cone to a cell holds every ray into it.
  std::uint8_t& v = cells_[linear(cell.rho, cell.phi, cell.z)];
  if (v & kWalkedBit) return;
  v |= kWalkedBit;
  walkCone(cell);
}

void AwarenessMap::walkCone(const AwarenessCell& end) {
  // In the rho-z plane of the sector, the rays from the origin (0, 0) into the end cell
  // [r0, r1] x [z0, z1] fill the cone conv(origin, cell). In a column k < end.rho the cone's z
  // lies between the lowest and the highest slope to the cell's corners; in the end column it is
  // the cell plus the part reached from the origin (the cell scaled by r0 / r1 .. 1).
  const double dr = config_.rho_cell_m;
  const double dz = config_.z_cell_m;
  const double r0 = end.rho * dr;
  const double r1 = r0 + dr;
  const double z0 = (end.z - config_.z_cells_below) * dz;
  const double z1 = z0 + dz;
  Cone cone;
  cone.phi = end.phi;
  cone.rho = end.rho;
  const double lambda_min = r0 / r1;
  cone.end_lo = std::min(z0, z0 * lambda_min);
  cone.end_hi = std::max(z1, z1 * lambda_min);
  cone.slope_lo = end.rho > 0 ? std::min(z0 / r0, z0 / r1) : 0.0;
  cone.slope_hi = end.rho > 0 ? std::max(z1 / r0, z1 / r1) : 0.0;
  cones_.push_back(cone);
}

void AwarenessMap::clearRange(int phi, int rho, double z_lo, double z_hi) {
  const double inv_dz = 1.0 / config_.z_cell_m;
  const int below = config_.z_cells_below;
  const int k0 = std::max(floorToInt((z_lo + kEdgeEpsilon) * inv_dz) + below, 0);
  const int k1 =
      std::min(ceilToInt((z_hi - kEdgeEpsilon) * inv_dz) - 1 + below, config_.z_cells - 1);
  std::uint8_t* column = cells_.data() + linear(rho, phi, 0);
  for (int k = k0; k <= k1; ++k) {
    std::uint8_t& v = column[k];
    if (v & kHitBit) continue;
    v = static_cast<std::uint8_t>((v & kWalkedBit) | kFreeBit);  // clears carried obstacles
  }
}

void AwarenessMap::insertSlopes(double lo, double hi) {
  // merged_ stays sorted and disjoint: overlapping intervals fuse into the new one.
  std::vector<std::pair<double, double>>& out = merge_scratch_;
  out.clear();
  bool placed = false;
  for (const auto& iv : merged_) {
    if (iv.second < lo) {
      out.push_back(iv);
    } else if (iv.first > hi) {
      if (!placed) {
        out.emplace_back(lo, hi);
        placed = true;
      }
      out.push_back(iv);
    } else {
      lo = std::min(lo, iv.first);
      hi = std::max(hi, iv.second);
    }
  }
  if (!placed) out.emplace_back(lo, hi);
  merged_.swap(out);
}

void AwarenessMap::sortCones() {
  // Two stable counting sorts (by rho descending, then by phi): the order of a comparison sort by
  // (phi, rho descending) up to the order among equal (phi, rho), which the sweep does not see
  // (it clears each such cone's end range and merges its slopes: a union). A comparison sort took
  // 2 % of a LiDAR scan, mostly mispredicted comparisons.
  const auto by = [&](const std::vector<Cone>& in, std::vector<Cone>& out, int buckets,
                      auto bucketOf) {
    sort_counts_.assign(static_cast<std::size_t>(buckets) + 1, 0);
    for (const Cone& c : in) ++sort_counts_[static_cast<std::size_t>(bucketOf(c)) + 1];
    for (std::size_t b = 1; b < sort_counts_.size(); ++b) sort_counts_[b] += sort_counts_[b - 1];
    out.resize(in.size());
    for (const Cone& c : in) out[sort_counts_[static_cast<std::size_t>(bucketOf(c))]++] = c;
  };
  const int rho_cells = config_.rho_cells;
  by(cones_, sort_scratch_, rho_cells, [&](const Cone& c) { return rho_cells - 1 - c.rho; });
  by(sort_scratch_, cones_, config_.phi_cells, [](const Cone& c) { return c.phi; });
}

void AwarenessMap::sweepCones() {
  // Per sector, the union of the cones in column k is the union of the slope intervals of the
  // cones that reach past k, scaled to the column, plus the end-column ranges of the cones that
  // end in k: sweep the columns from far to near, merging each cone's slopes once the sweep has
  // passed its end column.
  sortCones();
  const double dr = config_.rho_cell_m;
  for (std::size_t first = 0; first < cones_.size();) {
    std::size_t last = first;
    while (last < cones_.size() && cones_[last].phi == cones_[first].phi) ++last;
    const int phi = cones_[first].phi;
    merged_.clear();
    std::size_t next = first;
    for (int k = cones_[first].rho; k >= 0; --k) {
      // Column k: the cones that reach past it (their slopes, scaled to the column)...
      const double ra = k * dr;
      const double rb = ra + dr;
      for (const auto& [m_lo, m_hi] : merged_) {
        clearRange(phi, k, std::min(ra * m_lo, rb * m_lo), std::max(ra * m_hi, rb * m_hi));
      }
      // ...and the cones that end in it (their end-column range); from now on they reach past.
      for (; next < last && cones_[next].rho == k; ++next) {
        const Cone& c = cones_[next];
        clearRange(phi, k, c.end_lo, c.end_hi);
        insertSlopes(c.slope_lo, c.slope_hi);
      }
    }
    first = last;
  }
  cones_.clear();
}

void AwarenessMap::endFrame() {
  sweepCones();
  occupied_points_.clear();
  for (const Carried& h : hits_) occupied_points_.push_back(h.p_W);
  for (const Carried& c : carried_) {
    const std::uint8_t v = cells_[c.cell];
    if ((v & kOccupiedBit) && !(v & kHitBit)) occupied_points_.push_back(c.p_W);
  }
}

std::size_t AwarenessMap::count(Occupancy wanted) const {
  std::size_t n = 0;
  for (std::uint8_t v : cells_) {
    const Occupancy s = (v & kOccupiedBit) ? Occupancy::kOccupied
                        : (v & kFreeBit)   ? Occupancy::kFree
                                           : Occupancy::kUnknown;
    n += (s == wanted) ? 1 : 0;
  }
  return n;
}

std::size_t AwarenessMap::memoryBytes() const {
  return cells_.capacity() + (carried_.capacity() + hits_.capacity()) * sizeof(Carried) +
         hit_cells_.capacity() * sizeof(AwarenessCell) +
         occupied_points_.capacity() * sizeof(Eigen::Vector3d) +
         (cones_.capacity() + sort_scratch_.capacity()) * sizeof(Cone) +
         sort_counts_.capacity() * sizeof(std::size_t) +
         (boundary_cos_.capacity() + boundary_sin_.capacity()) * sizeof(double);
}

}  // namespace mlmap
