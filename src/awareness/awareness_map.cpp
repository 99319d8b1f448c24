#include "mlmap/awareness/awareness_map.h"

#include <algorithm>
#include <cmath>

namespace mlmap {
namespace {
constexpr double kTwoPi = 6.28318530717958647692;
// Boundary slack so that a cone merely touching a cell edge does not clear it.
constexpr double kEdgeEpsilon = 1e-9;
}  // namespace

AwarenessMap::AwarenessMap(const AwarenessConfig& config)
    : config_(config),
      phi_cell_rad_(config.phi_cell_rad()),
      cells_(static_cast<std::size_t>(config.rho_cells) * static_cast<std::size_t>(config.phi_cells) *
                 static_cast<std::size_t>(config.z_cells),
             0) {}

bool AwarenessMap::cellOf(const Eigen::Vector3d& p_W, AwarenessCell* cell) const {
  const Eigen::Vector3d d = p_W - origin_W_;
  const double rho = std::hypot(d.x(), d.y());
  const double rho_index = std::floor(rho / config_.rho_cell_m);
  const double z_index = std::floor(d.z() / config_.z_cell_m) + config_.z_cells_below;
  if (!(rho_index < config_.rho_cells) || !(z_index >= 0.0) || !(z_index < config_.z_cells)) {
    return false;
  }
  double phi = std::atan2(d.y(), d.x());
  if (phi < 0.0) phi += kTwoPi;
  int phi_index = static_cast<int>(phi / phi_cell_rad_);
  if (phi_index >= config_.phi_cells) phi_index -= config_.phi_cells;  // phi == 2 pi - eps rounding
  cell->rho = static_cast<int>(rho_index);
  cell->phi = phi_index;
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
  const double rho = std::hypot(d.x(), d.y());
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
  // [r0, r1] x [z0, z1] fill the cone conv(origin, cell). Column k < end.rho spans
  // rho in [ra, rb]; there the cone's z lies between the lowest and highest slopes to the
  // cell's corners. In the end column the cone is the cell plus the part reached from the origin.
  const double dr = config_.rho_cell_m;
  const double dz = config_.z_cell_m;
  const double inv_dz = 1.0 / dz;
  const int below = config_.z_cells_below;
  const double r0 = end.rho * dr;
  const double r1 = r0 + dr;
  const double z0 = (end.z - below) * dz;
  const double z1 = z0 + dz;
  const std::size_t sector_base = static_cast<std::size_t>(end.phi) *
                                  static_cast<std::size_t>(config_.rho_cells) *
                                  static_cast<std::size_t>(config_.z_cells);
  auto clear_range = [&](int rho, double z_lo, double z_hi) {
    int k0 = floorToInt((z_lo + kEdgeEpsilon) * inv_dz) + below;
    int k1 = ceilToInt((z_hi - kEdgeEpsilon) * inv_dz) - 1 + below;
    k0 = std::max(k0, 0);
    k1 = std::min(k1, config_.z_cells - 1);
    std::uint8_t* column = cells_.data() + sector_base +
                           static_cast<std::size_t>(rho) * static_cast<std::size_t>(config_.z_cells);
    for (int k = k0; k <= k1; ++k) {
      std::uint8_t& v = column[k];
      if (v & kHitBit) continue;
      v = static_cast<std::uint8_t>((v & kWalkedBit) | kFreeBit);  // clears carried obstacles
    }
  };
  if (end.rho > 0) {
    const double m_lo = std::min(z0 / r0, z0 / r1);
    const double m_hi = std::max(z1 / r0, z1 / r1);
    for (int k = 0; k < end.rho; ++k) {
      const double ra = k * dr;
      const double rb = ra + dr;
      clear_range(k, std::min(ra * m_lo, rb * m_lo), std::max(ra * m_hi, rb * m_hi));
    }
  }
  // End column: lambda in [r0 / r1, 1] scales the cell towards the origin.
  const double lambda_min = r0 / r1;
  clear_range(end.rho, std::min(z0, z0 * lambda_min), std::max(z1, z1 * lambda_min));
  // The end cell was skipped if hit this frame, and cleared otherwise (a ray cut at the range).
}

void AwarenessMap::endFrame() {
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
         occupied_points_.capacity() * sizeof(Eigen::Vector3d);
}

}  // namespace mlmap
