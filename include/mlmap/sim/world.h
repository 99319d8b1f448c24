#pragma once
/// @file
/// Analytic synthetic world for the simulator: axis-aligned boxes, vertical cylinders, spheres and
/// boxes moving at constant velocity during a time window. All solids are closed sets (their
/// surface belongs to them). Coordinates are in the world frame W (z up), metres and seconds.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace mlmap::sim {

/// Static axis-aligned box spanning [min_W, max_W] per axis.
struct Box {
  Eigen::Vector3d min_W = Eigen::Vector3d::Zero();  ///< lower corner in W [m]
  Eigen::Vector3d max_W = Eigen::Vector3d::Zero();  ///< upper corner in W [m]
};

/// Static vertical (z-aligned) solid cylinder with flat caps.
struct Cylinder {
  Eigen::Vector2d center_xy_W = Eigen::Vector2d::Zero();  ///< axis position (x, y) in W [m]
  double radius_m = 0.0;                                  ///< radius [m], > 0
  double z_min_m = 0.0;                                   ///< bottom cap height in W [m]
  double z_max_m = 0.0;                                   ///< top cap height in W [m], >= z_min_m
};

/// Static solid sphere.
struct Sphere {
  Eigen::Vector3d center_W = Eigen::Vector3d::Zero();  ///< centre in W [m]
  double radius_m = 0.0;                               ///< radius [m], > 0
};

/// Axis-aligned box moving at constant velocity. It exists only for t in [t_start_s, t_end_s]
/// (closed), with centre start_center_W + velocity_mps * (t - t_start_s). A walking person is a
/// 0.5 x 0.5 x 1.8 m MovingBox. Moving boxes are ignored by the static queries (isOccupied,
/// intersectsBox, distance, bounds).
struct MovingBox {
  Eigen::Vector3d size_m = Eigen::Vector3d::Zero();          ///< full extent per axis [m], > 0
  Eigen::Vector3d start_center_W = Eigen::Vector3d::Zero();  ///< centre at t_start_s in W [m]
  Eigen::Vector3d velocity_mps = Eigen::Vector3d::Zero();    ///< velocity in W [m/s]
  double t_start_s = 0.0;                                    ///< first time it exists [s]
  double t_end_s = 0.0;                                      ///< last time it exists [s]

  /// True when the box exists at `time_s` (t_start_s <= time_s <= t_end_s).
  [[nodiscard]] bool isActiveAt(double time_s) const {
    return time_s >= t_start_s && time_s <= t_end_s;
  }
  /// Centre in W at `time_s` (extrapolated linearly; meaningful only when active).
  [[nodiscard]] Eigen::Vector3d centerAt(double time_s) const {
    return start_center_W + velocity_mps * (time_s - t_start_s);
  }
};

class World;

/// The primitives that rays from one origin, with directions inside a convex pyramid and
/// lengths up to a range, may hit at one time. Built by World::gatherCandidates and used by the
/// matching World::raycast overload, so that a camera culls the scene once per image tile instead
/// of once per pixel. Reuse one object to avoid allocations.
class RayCandidates {
 public:
  /// Number of candidate primitives (static and moving).
  [[nodiscard]] std::size_t size() const { return static_entries_.size() + moving_.size(); }

 private:
  friend class World;
  Eigen::Vector3d origin_W_ = Eigen::Vector3d::Zero();
  double time_s_ = 0.0;
  std::vector<std::uint32_t> static_entries_;  ///< indices into World::entries_
  std::vector<std::uint32_t> moving_;          ///< indices of moving boxes active at time_s_
};

/// A set of analytic solids with ray casting and ground-truth occupancy queries.
///
/// Queries are exception-free and allocation-free; they are safe to call concurrently on a const
/// World. Adding primitives is not thread-safe. Ray casts use a uniform grid over the static
/// solids that each add* call rebuilds (cost linear in the grid size, at most ~1M cells), so
/// build worlds once, then query.
class World {
 public:
  /// Adds a static box. Returns false (and adds nothing) unless all values are finite and
  /// min_W <= max_W on every axis.
  bool addBox(const Box& box);
  /// Adds a static vertical cylinder. Returns false (and adds nothing) unless all values are
  /// finite, radius_m > 0 and z_min_m <= z_max_m.
  bool addCylinder(const Cylinder& cylinder);
  /// Adds a static sphere. Returns false (and adds nothing) unless all values are finite and
  /// radius_m > 0.
  bool addSphere(const Sphere& sphere);
  /// Adds a moving box. Returns false (and adds nothing) unless all values are finite,
  /// size_m > 0 on every axis and t_start_s <= t_end_s.
  bool addMovingBox(const MovingBox& moving_box);

  /// Static boxes in insertion order.
  [[nodiscard]] const std::vector<Box>& boxes() const { return boxes_; }
  /// Static cylinders in insertion order.
  [[nodiscard]] const std::vector<Cylinder>& cylinders() const { return cylinders_; }
  /// Static spheres in insertion order.
  [[nodiscard]] const std::vector<Sphere>& spheres() const { return spheres_; }
  /// Moving boxes in insertion order.
  [[nodiscard]] const std::vector<MovingBox>& movingBoxes() const { return moving_boxes_; }

  /// Casts the ray origin_W + t * unit_dir_W and returns the nearest t in (0, t_max] where it
  /// meets the surface of a static solid or of a moving box active at `time_s`. A ray starting
  /// inside (or on the surface of) a solid reports where it leaves that solid unless another
  /// surface is nearer. Grazing contacts (tangent rays, rays along a face) count as hits.
  /// `unit_dir_W` should be unit length so that t is in metres. On a miss `*t_hit` is untouched.
  [[nodiscard]] bool raycast(const Eigen::Vector3d& origin_W, const Eigen::Vector3d& unit_dir_W,
                             double t_max, double time_s, double* t_hit) const;

  /// Collects into `candidates` every primitive (static, or moving and active at `time_s`) that a
  /// ray from `origin_W` of length <= t_max with direction in the convex pyramid spanned by the
  /// four `corner_dirs_W` (in cyclic order) could meet. Culling is conservative.
  void gatherCandidates(const Eigen::Vector3d& origin_W, const Eigen::Vector3d (&corner_dirs_W)[4],
                        double t_max, double time_s, RayCandidates* candidates) const;

  /// Same result as raycast(origin_W, unit_dir_W, t_max, time_s, t_hit) with the origin and
  /// time of `candidates`, provided `unit_dir_W` lies in their pyramid and `t_max` within their
  /// range; tests only the candidates.
  [[nodiscard]] bool raycast(const RayCandidates& candidates, const Eigen::Vector3d& unit_dir_W,
                             double t_max, double* t_hit) const;

  /// True when `p_W` lies inside or on a static solid.
  [[nodiscard]] bool isOccupied(const Eigen::Vector3d& p_W) const;

  /// True when `p_W` lies inside or on a static solid or a moving box active at `time_s`.
  [[nodiscard]] bool isOccupiedAt(const Eigen::Vector3d& p_W, double time_s) const;

  /// True when some static solid comes within `tolerance_m` (Euclidean) of the closed box
  /// [min_W, max_W]. Ground truth for "is this voxel occupied". Moving boxes are ignored.
  [[nodiscard]] bool intersectsBox(const Eigen::Vector3d& min_W, const Eigen::Vector3d& max_W,
                                   double tolerance_m = 1e-6) const;

  /// Euclidean distance from `p_W` to the nearest static solid (0 inside one, +infinity when the
  /// world has no static solid).
  [[nodiscard]] double distance(const Eigen::Vector3d& p_W) const;

  /// Bounding box of all static solids (empty when there are none).
  [[nodiscard]] Eigen::AlignedBox3d bounds() const;

  /// The paper-like simulation room: 30 m x 20 m (x in [0, 30], y in [0, 20]), floor slab with
  /// its top at z = 0, 0.2 m thick 4 m high perimeter walls inside that footprint, no ceiling,
  /// two interior walls with doorway gaps (x = 10 with gaps y in (3, 6) and (14, 17); y = 10 with
  /// gap x in (23.5, 26.5)), 7 cylinders (one 0.05 m pole), 6 boxes (one floating shelf),
  /// 4 spheres, all >= 1 m from Trajectory::defaultRoomFlight(). One MovingBox person
  /// (0.5 x 0.5 x 1.8 m, standing on the floor) walks +y along x = 17 from y = 1 to y = 9 at
  /// 1 m/s during t in [7, 15] s; it crosses the flight path (y = 4.5) at t = 10.5 s when the
  /// drone, flying +x, is at x = 14.5, i.e. ~2.25 m in front of the camera.
  [[nodiscard]] static World defaultRoom();

 private:
  /// Kind of a static primitive referenced by an acceleration entry.
  enum class Kind : std::uint8_t { kBox, kCylinder, kSphere };
  /// Precomputed bounding box of one static primitive.
  struct Entry {
    Eigen::Vector3d min_W;
    Eigen::Vector3d max_W;
    Kind kind;
    std::uint32_t index;
  };

  /// Rebuilds the uniform acceleration grid after a static primitive was added.
  void rebuildGrid();
  /// Intersects static entry `index` with `ray`, lowering `*best` (and setting `*hit`) when it is
  /// met in (0, *best]. RayT is the ray type private to world.cpp.
  template <typename RayT>
  void hitEntry(const RayT& ray, std::uint32_t index, double* best, bool* hit) const;
  /// Same for moving box `index` at `time_s`.
  template <typename RayT>
  void hitMoving(const RayT& ray, std::uint32_t index, double time_s, double* best,
                 bool* hit) const;

  std::vector<Box> boxes_;
  std::vector<Cylinder> cylinders_;
  std::vector<Sphere> spheres_;
  std::vector<MovingBox> moving_boxes_;
  std::vector<Entry> entries_;  ///< one per static primitive, in insertion order

  // Uniform grid over the static bounds: cell (i, j, k) lists the entries whose bounding box
  // touches it, in cell_items_[cell_offsets_[c] .. cell_offsets_[c + 1]).
  Eigen::Vector3d grid_min_W_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d grid_max_W_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d cell_size_m_ = Eigen::Vector3d::Ones();
  Eigen::Vector3i grid_dims_ = Eigen::Vector3i::Zero();
  std::vector<std::uint32_t> cell_offsets_;
  std::vector<std::uint32_t> cell_items_;
};

}  // namespace mlmap::sim
