#pragma once
/// @file
/// The awareness map (paper IV-A, V-B): a cylindrical (rho, phi, z) grid whose origin follows the
/// body position and whose axes stay parallel to the world frame. It holds what the vehicle sees
/// right now: cells hit in this frame, obstacles carried over from earlier frames (Eq. 10), free
/// cells swept by this frame's rays, unknown elsewhere.
///
/// Ray casting is a 2D walk in the rho-z plane of one phi sector: every ray from the origin to a
/// point stays in that point's sector. The walk clears the whole cone from the origin to the hit
/// cell (so every cell any ray into that cell crosses is cleared: no gap before the hit, all
/// sectors including phi 0, rho 0 and the z borders).

#include "mlmap/core/config.h"
#include "mlmap/core/types.h"

#include <cstdint>
#include <vector>

namespace mlmap {

/// Index of an awareness cell.
struct AwarenessCell {
  int rho = 0;
  int phi = 0;
  int z = 0;
};

/// Cylindrical grid around the body. Not thread-safe; owned by the awareness stage.
class AwarenessMap {
 public:
  explicit AwarenessMap(const AwarenessConfig& config);

  /// Starts a frame with the body at `body_W`: moves the previous frame's occupied cells by the
  /// pose change (Eq. 10; the frame is world-aligned, so a cell keeps its world position and is
  /// re-indexed around the new origin), drops those that left the grid, resets everything else
  /// to unknown.
  void beginFrame(const Eigen::Vector3d& body_W);

  /// Marks the cell holding a measured world point as occupied for this frame.
  /// Returns false when the point lies outside the grid.
  bool markHit(const Eigen::Vector3d& p_W);

  /// Casts one ray from the origin to `end_W`: clears the cone from the origin to the end cell.
  /// With `end_is_free` (a ray cut at the maximum range) the end cell is cleared too; otherwise the
  /// end is a hit and is marked as markHit() does. Cells hit in this frame are never cleared. A
  /// segment leaving the grid is cut at the grid border, and its border cell is cleared.
  void castRay(const Eigen::Vector3d& end_W, bool end_is_free);

  /// Casts the rays to every cell hit in this frame (call after all markHit()).
  void castRaysToHits();
  // Rays take effect in endFrame(), one sweep per sector over all the frame's cones, so every
  // hit of the frame is protected whatever the call order.

  /// Cell holding a world point; false outside the grid.
  [[nodiscard]] bool cellOf(const Eigen::Vector3d& p_W, AwarenessCell* cell) const;
  /// State of a cell (must be inside the grid).
  [[nodiscard]] Occupancy state(const AwarenessCell& cell) const;
  /// State at a world point (unknown outside the grid).
  [[nodiscard]] Occupancy stateAt(const Eigen::Vector3d& p_W) const;
  /// World position of a cell centre.
  [[nodiscard]] Eigen::Vector3d cellCenter(const AwarenessCell& cell) const;
  /// One measured world point per occupied cell (hits of this frame and carried obstacles).
  [[nodiscard]] const std::vector<Eigen::Vector3d>& occupiedPoints() const {
    return occupied_points_;
  }
  /// Call after the hits and rays: clears the rays' cones (a hit of the frame is never cleared),
  /// then gathers occupiedPoints() for output and for the next frame's transfer.
  void endFrame();

  [[nodiscard]] const AwarenessConfig& config() const { return config_; }
  [[nodiscard]] const Eigen::Vector3d& origin_W() const { return origin_W_; }
  /// Counts of cells by state (for tests and status).
  [[nodiscard]] std::size_t count(Occupancy wanted) const;
  /// Bytes held.
  [[nodiscard]] std::size_t memoryBytes() const;

 private:
  // Cell flags.
  static constexpr std::uint8_t kFreeBit = 1;
  static constexpr std::uint8_t kOccupiedBit = 2;
  static constexpr std::uint8_t kHitBit = 4;     // hit in this frame: cannot be cleared
  static constexpr std::uint8_t kWalkedBit = 8;  // cone to this cell already cast this frame

  [[nodiscard]] std::size_t linear(int rho, int phi, int z) const {
    return (static_cast<std::size_t>(phi) * static_cast<std::size_t>(config_.rho_cells) +
            static_cast<std::size_t>(rho)) *
               static_cast<std::size_t>(config_.z_cells) +
           static_cast<std::size_t>(z);
  }
  /// floor(atan2(dy, dx) in [0, 2 pi) / sector width): the sector of a direction, by its side of
  /// the sector boundaries (atan2 only within rounding of a boundary). `rho` = |(dx, dy)|.
  [[nodiscard]] int phiIndex(double dx, double dy, double rho) const;
  void walkCone(const AwarenessCell& end);
  void clearRange(int phi, int rho, double z_lo, double z_hi);
  void insertSlopes(double lo, double hi);
  /// Orders cones_ by phi, and within a phi by rho descending (as sweepCones() reads them).
  void sortCones();
  void sweepCones();

  AwarenessConfig config_;
  double phi_cell_rad_;
  std::vector<double> boundary_cos_;  // direction of sector boundary i (i = 0 .. phi_cells)
  std::vector<double> boundary_sin_;
  Eigen::Vector3d origin_W_ = Eigen::Vector3d::Zero();
  std::vector<std::uint8_t> cells_;
  struct Carried {
    std::size_t cell;
    Eigen::Vector3d p_W;
  };
  std::vector<Carried> carried_;  // obstacles of earlier frames, re-indexed
  std::vector<Carried> hits_;     // hit cells of this frame
  std::vector<AwarenessCell> hit_cells_;
  /// A 2D cone of this frame, cleared by sweepCones(): slopes z / rho to the end cell's corners,
  /// and the z range it covers in its own end column.
  struct Cone {
    int phi = 0;
    int rho = 0;
    double slope_lo = 0.0;
    double slope_hi = 0.0;
    double end_lo = 0.0;
    double end_hi = 0.0;
  };
  std::vector<Cone> cones_;
  std::vector<Cone> sort_scratch_;                 // sortCones()' first pass
  std::vector<std::size_t> sort_counts_;           // sortCones()' bucket starts
  std::vector<std::pair<double, double>> merged_;  // disjoint slope intervals, sorted
  std::vector<std::pair<double, double>> merge_scratch_;
  std::vector<Eigen::Vector3d> occupied_points_;
};

}  // namespace mlmap
