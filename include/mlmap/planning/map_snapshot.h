#pragma once
/// @file
/// What a planner holds: an immutable snapshot of the planning layers, published by the engine
/// after each mapped frame (MapEngine::snapshot()).
///
/// Why snapshots: a planner's reads never block the mapper and never see a half-updated map.
/// The engine copies the local window (2 bytes per voxel, one contiguous copy per column) and
/// swaps a shared pointer under a mutex held for a pointer copy; readers take the pointer and
/// then read lock-free for as long as they keep it, e.g. one whole planning cycle, which also
/// gives every query of the cycle the same map. The ESDF and the 2D grid are built once per
/// update and shared between snapshots until they change.
///
/// Frames and units: every point is in the world frame W, in metres.

#include "mlmap/local/local_map.h"
#include "mlmap/planning/esdf.h"
#include "mlmap/planning/esdf_query_grid.h"
#include "mlmap/planning/projected_grid.h"

#include <cstdint>
#include <memory>

namespace mlmap {

/// An immutable view of the map for planners. All methods are const and thread-safe.
class MapSnapshot {
 public:
  MapSnapshot(std::shared_ptr<const LocalWindow> window, std::shared_ptr<const ProjectedGrid> grid,
              std::shared_ptr<const EsdfMap> esdf, std::uint64_t frame, double stamp_s,
              const Transform& T_W_B, std::uint64_t esdf_frame = 0,
              std::shared_ptr<const EsdfQueryGrid> esdf_grid = nullptr);

  /// Occupancy of the voxel holding p_W; unknown outside the local window.
  [[nodiscard]] Occupancy state(const Eigen::Vector3d& p_W) const;
  /// Occupancy probability of the voxel holding p_W; false (unknown or outside) leaves it alone.
  [[nodiscard]] bool probability(const Eigen::Vector3d& p_W, double* probability) const;

  /// Signed distance and gradient (see EsdfMap::query()); invalid when no ESDF was computed yet,
  /// outside its box, or in unknown space.
  [[nodiscard]] EsdfMap::Query distance(const Eigen::Vector3d& p_W) const;

  /// True when no voxel whose interior the segment a-b passes through is occupied, nor unknown
  /// when `unknown` is UnknownAs::kOccupied. Space outside the window counts as unknown.
  [[nodiscard]] bool isSegmentFree(const Eigen::Vector3d& a_W, const Eigen::Vector3d& b_W,
                                   UnknownAs unknown = UnknownAs::kOccupied) const;
  /// The same for every voxel overlapping the axis-aligned box [min_W, max_W] (interiors).
  [[nodiscard]] bool isBoxFree(const Eigen::Vector3d& min_W, const Eigen::Vector3d& max_W,
                               UnknownAs unknown = UnknownAs::kOccupied) const;

  /// The projected 2D grid (may be empty when disabled).
  [[nodiscard]] const ProjectedGrid& grid() const { return *grid_; }
  /// The ESDF, or nullptr when it is disabled or not computed yet.
  [[nodiscard]] const EsdfMap* esdf() const { return esdf_.get(); }
  /// The query copy of esdf() (EsdfQueryGrid, built from the same field), or nullptr when
  /// esdf.query_grid is off or there is no ESDF.
  [[nodiscard]] const EsdfQueryGrid* esdfGrid() const { return esdf_grid_.get(); }
  /// The local window the occupancy queries read.
  [[nodiscard]] const LocalWindow& window() const { return *window_; }
  /// Lower and upper corners of the local window in W [m] (both zero before the first frame).
  [[nodiscard]] Eigen::Vector3d windowMin_W() const;
  [[nodiscard]] Eigen::Vector3d windowMax_W() const;
  /// Number of frames mapped when the snapshot was taken, their last stamp and body pose.
  [[nodiscard]] std::uint64_t frame() const { return frame_; }
  [[nodiscard]] double stamp_s() const { return stamp_s_; }
  [[nodiscard]] const Transform& T_W_B() const { return T_W_B_; }
  /// Frame whose window the ESDF was computed from (it may lag frame() by the ESDF's rate or,
  /// with the planning thread, by its computation time).
  [[nodiscard]] std::uint64_t esdfFrame() const { return esdf_frame_; }

  /// Shared parts, for the engine to build the next snapshot from.
  [[nodiscard]] const std::shared_ptr<const LocalWindow>& windowPtr() const { return window_; }
  [[nodiscard]] const std::shared_ptr<const ProjectedGrid>& gridPtr() const { return grid_; }
  [[nodiscard]] const std::shared_ptr<const EsdfMap>& esdfPtr() const { return esdf_; }
  [[nodiscard]] const std::shared_ptr<const EsdfQueryGrid>& esdfGridPtr() const {
    return esdf_grid_;
  }

 private:
  [[nodiscard]] bool voxelBlocks(const VoxelIndex& g, UnknownAs unknown) const;

  std::shared_ptr<const LocalWindow> window_;
  std::shared_ptr<const ProjectedGrid> grid_;
  std::shared_ptr<const EsdfMap> esdf_;
  std::uint64_t frame_ = 0;
  double stamp_s_ = 0.0;
  Transform T_W_B_ = Transform::Identity();
  std::uint64_t esdf_frame_ = 0;
  std::shared_ptr<const EsdfQueryGrid> esdf_grid_;
};

}  // namespace mlmap
