#include "mlmap/sim/world.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace mlmap::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
/// Acceleration grid size: cells per static primitive, clamped to [min, max] cells.
constexpr double kGridCellsPerPrimitive = 32.0;
constexpr double kGridMinCells = 512.0;
constexpr double kGridMaxCells = 1048576.0;
/// Direction components smaller than this are treated as exactly parallel to an axis plane.
constexpr double kParallelEps = 1e-15;

bool allFinite(const Eigen::Vector3d& v) { return v.allFinite(); }

/// A ray with precomputed reciprocal direction for slab tests. Direction components below
/// kParallelEps are set to +0 so that their reciprocal is +inf: a slab test then yields +-inf
/// (outside / inside the slab) or NaN (exactly on a slab plane), and NaN is ignored by the
/// max/min updates below, which is the closed-set answer.
struct Ray {
  Eigen::Vector3d origin;
  Eigen::Vector3d dir;
  Eigen::Vector3d inv_dir;
  int negative[3];  ///< 1 when the direction component is negative (slab planes swap)

  Ray(const Eigen::Vector3d& o, const Eigen::Vector3d& d) : origin(o), dir(d) {
    for (int i = 0; i < 3; ++i) {
      if (std::abs(dir[i]) < kParallelEps) dir[i] = 0.0;  // also turns -0 into +0
      inv_dir[i] = 1.0 / dir[i];
      negative[i] = inv_dir[i] < 0.0 ? 1 : 0;
    }
  }
};

/// max/min that keep `current` when `candidate` is NaN.
inline double raiseTo(double current, double candidate) {
  return candidate > current ? candidate : current;
}
inline double lowerTo(double current, double candidate) {
  return candidate < current ? candidate : current;
}

/// Parameter interval of the ray inside the slab lo <= x_axis <= hi.
inline void clipSlab(const Ray& ray, int axis, double lo, double hi, double* tn, double* tf) {
  const double o = ray.origin[axis];
  const double inv = ray.inv_dir[axis];
  const double enter = ((ray.negative[axis] != 0 ? hi : lo) - o) * inv;
  const double leave = ((ray.negative[axis] != 0 ? lo : hi) - o) * inv;
  *tn = raiseTo(*tn, enter);
  *tf = lowerTo(*tf, leave);
}

/// Parameter interval [t_near, t_far] where the ray is inside the closed box [lo, hi].
inline bool slabInterval(const Ray& ray, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                         double* t_near, double* t_far) {
  double tn = -kInf;
  double tf = kInf;
  clipSlab(ray, 0, lo.x(), hi.x(), &tn, &tf);
  clipSlab(ray, 1, lo.y(), hi.y(), &tn, &tf);
  clipSlab(ray, 2, lo.z(), hi.z(), &tn, &tf);
  if (tn > tf) return false;
  *t_near = tn;
  *t_far = tf;
  return true;
}

/// Roots of a t^2 + 2 b t + c = 0 (a > 0), i.e. the interval where the quadratic is <= 0.
inline bool quadraticInterval(double a, double b, double c, double* t0, double* t1) {
  const double disc = b * b - a * c;
  if (disc < 0.0) return false;
  const double sq = std::sqrt(disc);
  const double q = (b >= 0.0) ? -(b + sq) : (sq - b);  // numerically stable form
  if (q == 0.0) {
    *t0 = 0.0;
    *t1 = 0.0;
    return true;
  }
  double r0 = q / a;
  double r1 = c / q;
  if (r0 > r1) std::swap(r0, r1);
  *t0 = r0;
  *t1 = r1;
  return true;
}

/// Parameter interval where the ray is inside a closed sphere.
inline bool sphereInterval(const Ray& ray, const Sphere& s, double* t_near, double* t_far) {
  const Eigen::Vector3d oc = ray.origin - s.center_W;
  const double a = ray.dir.squaredNorm();
  if (a <= 0.0) return false;
  return quadraticInterval(a, oc.dot(ray.dir), oc.squaredNorm() - s.radius_m * s.radius_m, t_near,
                           t_far);
}

/// Parameter interval where the ray is inside a closed vertical cylinder: the interval of the
/// infinite cylinder (quadratic in x, y) clipped by the z slab [z_min, z_max] (the caps).
inline bool cylinderInterval(const Ray& ray, const Cylinder& c, double* t_near, double* t_far) {
  const double ox = ray.origin.x() - c.center_xy_W.x();
  const double oy = ray.origin.y() - c.center_xy_W.y();
  const double dx = ray.dir.x();
  const double dy = ray.dir.y();
  const double a = dx * dx + dy * dy;
  const double cc = ox * ox + oy * oy - c.radius_m * c.radius_m;
  double tn = -kInf;
  double tf = kInf;
  if (a < kParallelEps * kParallelEps) {
    if (cc > 0.0) return false;  // vertical ray outside the disc
  } else if (!quadraticInterval(a, ox * dx + oy * dy, cc, &tn, &tf)) {
    return false;
  }
  clipSlab(ray, 2, c.z_min_m, c.z_max_m, &tn, &tf);
  if (tn > tf) return false;
  *t_near = tn;
  *t_far = tf;
  return true;
}

/// First surface crossing in (0, best] of a solid occupying [t_near, t_far] along the ray.
inline bool firstCrossing(double t_near, double t_far, double best, double* t) {
  const double candidate = t_near > 0.0 ? t_near : t_far;
  if (!(candidate > 0.0) || candidate > best) return false;
  *t = candidate;
  return true;
}

inline bool insideBox(const Eigen::Vector3d& p, const Eigen::Vector3d& lo,
                      const Eigen::Vector3d& hi) {
  return p.x() >= lo.x() && p.x() <= hi.x() && p.y() >= lo.y() && p.y() <= hi.y() &&
         p.z() >= lo.z() && p.z() <= hi.z();
}

/// Gap between intervals [a0, a1] and [b0, b1] (0 when they overlap).
inline double intervalGap(double a0, double a1, double b0, double b1) {
  return std::max({0.0, b0 - a1, a0 - b1});
}

/// Euclidean distance from point p to the closed box [lo, hi] (0 inside).
inline double pointBoxDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& lo,
                               const Eigen::Vector3d& hi) {
  return (lo - p).cwiseMax(p - hi).cwiseMax(0.0).norm();
}

}  // namespace

bool World::addBox(const Box& box) {
  if (!allFinite(box.min_W) || !allFinite(box.max_W) ||
      (box.min_W.array() > box.max_W.array()).any()) {
    return false;
  }
  boxes_.push_back(box);
  entries_.push_back(
      {box.min_W, box.max_W, Kind::kBox, static_cast<std::uint32_t>(boxes_.size() - 1)});
  rebuildGrid();
  return true;
}

bool World::addCylinder(const Cylinder& cylinder) {
  const bool finite = cylinder.center_xy_W.allFinite() && std::isfinite(cylinder.radius_m) &&
                      std::isfinite(cylinder.z_min_m) && std::isfinite(cylinder.z_max_m);
  if (!finite || !(cylinder.radius_m > 0.0) || cylinder.z_min_m > cylinder.z_max_m) return false;
  cylinders_.push_back(cylinder);
  const Eigen::Vector3d lo(cylinder.center_xy_W.x() - cylinder.radius_m,
                           cylinder.center_xy_W.y() - cylinder.radius_m, cylinder.z_min_m);
  const Eigen::Vector3d hi(cylinder.center_xy_W.x() + cylinder.radius_m,
                           cylinder.center_xy_W.y() + cylinder.radius_m, cylinder.z_max_m);
  entries_.push_back({lo, hi, Kind::kCylinder, static_cast<std::uint32_t>(cylinders_.size() - 1)});
  rebuildGrid();
  return true;
}

bool World::addSphere(const Sphere& sphere) {
  if (!allFinite(sphere.center_W) || !std::isfinite(sphere.radius_m) || !(sphere.radius_m > 0.0)) {
    return false;
  }
  spheres_.push_back(sphere);
  const Eigen::Vector3d r = Eigen::Vector3d::Constant(sphere.radius_m);
  entries_.push_back({sphere.center_W - r, sphere.center_W + r, Kind::kSphere,
                      static_cast<std::uint32_t>(spheres_.size() - 1)});
  rebuildGrid();
  return true;
}

bool World::addMovingBox(const MovingBox& moving_box) {
  const bool finite = allFinite(moving_box.size_m) && allFinite(moving_box.start_center_W) &&
                      allFinite(moving_box.velocity_mps) && std::isfinite(moving_box.t_start_s) &&
                      std::isfinite(moving_box.t_end_s);
  if (!finite || !(moving_box.size_m.array() > 0.0).all() ||
      moving_box.t_start_s > moving_box.t_end_s) {
    return false;
  }
  moving_boxes_.push_back(moving_box);
  return true;
}

void World::rebuildGrid() {
  cell_offsets_.clear();
  cell_items_.clear();
  grid_dims_.setZero();
  if (entries_.empty()) return;
  Eigen::AlignedBox3d bounds;
  for (const Entry& e : entries_) {
    bounds.extend(e.min_W);
    bounds.extend(e.max_W);
  }
  // Pad so that no axis is degenerate and surfaces on the bounds are strictly inside.
  const double pad = 1e-3 + 1e-6 * bounds.sizes().maxCoeff();
  grid_min_W_ = bounds.min() - Eigen::Vector3d::Constant(pad);
  grid_max_W_ = bounds.max() + Eigen::Vector3d::Constant(pad);
  const Eigen::Vector3d extent = grid_max_W_ - grid_min_W_;
  const double target_cells = std::clamp(
      kGridCellsPerPrimitive * static_cast<double>(entries_.size()), kGridMinCells, kGridMaxCells);
  double edge = std::cbrt(extent.prod() / target_cells);
  for (;;) {
    for (int i = 0; i < 3; ++i) {
      grid_dims_[i] = static_cast<int>(std::clamp(std::ceil(extent[i] / edge), 1.0, 1e6));
    }
    if (grid_dims_.cast<double>().prod() <= kGridMaxCells) break;
    edge *= 1.25;
  }
  cell_size_m_ = extent.cwiseQuotient(grid_dims_.cast<double>());

  // Cell index range of a (slightly expanded) box, clamped to the grid.
  auto cellRange = [this](const Entry& e, Eigen::Vector3i* lo, Eigen::Vector3i* hi) {
    const double eps = 1e-9 * (1.0 + cell_size_m_.maxCoeff());
    for (int i = 0; i < 3; ++i) {
      const double a = std::floor((e.min_W[i] - eps - grid_min_W_[i]) / cell_size_m_[i]);
      const double b = std::floor((e.max_W[i] + eps - grid_min_W_[i]) / cell_size_m_[i]);
      (*lo)[i] = static_cast<int>(std::clamp(a, 0.0, grid_dims_[i] - 1.0));
      (*hi)[i] = static_cast<int>(std::clamp(b, 0.0, grid_dims_[i] - 1.0));
    }
  };
  const std::size_t num_cells = static_cast<std::size_t>(grid_dims_.x()) *
                                static_cast<std::size_t>(grid_dims_.y()) *
                                static_cast<std::size_t>(grid_dims_.z());
  auto cellId = [this](int x, int y, int z) {
    return (static_cast<std::size_t>(z) * static_cast<std::size_t>(grid_dims_.y()) +
            static_cast<std::size_t>(y)) *
               static_cast<std::size_t>(grid_dims_.x()) +
           static_cast<std::size_t>(x);
  };
  // Two passes (count, fill) into a compressed cell -> entries table.
  std::vector<std::uint32_t> counts(num_cells + 1, 0);
  Eigen::Vector3i lo;
  Eigen::Vector3i hi;
  for (const Entry& e : entries_) {
    cellRange(e, &lo, &hi);
    for (int z = lo.z(); z <= hi.z(); ++z)
      for (int y = lo.y(); y <= hi.y(); ++y)
        for (int x = lo.x(); x <= hi.x(); ++x) ++counts[cellId(x, y, z) + 1];
  }
  for (std::size_t c = 0; c < num_cells; ++c) counts[c + 1] += counts[c];
  cell_offsets_ = counts;
  cell_items_.assign(cell_offsets_.back(), 0);
  for (std::uint32_t index = 0; index < entries_.size(); ++index) {
    cellRange(entries_[index], &lo, &hi);
    for (int z = lo.z(); z <= hi.z(); ++z)
      for (int y = lo.y(); y <= hi.y(); ++y)
        for (int x = lo.x(); x <= hi.x(); ++x) cell_items_[counts[cellId(x, y, z)]++] = index;
  }
}

template <typename RayT>
void World::hitEntry(const RayT& ray, std::uint32_t index, double* best, bool* hit) const {
  const Entry& entry = entries_[index];
  double t_near = 0.0;
  double t_far = 0.0;
  // Culling by the primitive's bounding box (exact for boxes).
  if (!slabInterval(ray, entry.min_W, entry.max_W, &t_near, &t_far)) return;
  if (!(t_far > 0.0) || t_near > *best) return;
  switch (entry.kind) {
    case Kind::kBox:
      break;
    case Kind::kCylinder:
      if (!cylinderInterval(ray, cylinders_[entry.index], &t_near, &t_far)) return;
      break;
    case Kind::kSphere:
      if (!sphereInterval(ray, spheres_[entry.index], &t_near, &t_far)) return;
      break;
  }
  if (firstCrossing(t_near, t_far, *best, best)) *hit = true;
}

template <typename RayT>
void World::hitMoving(const RayT& ray, std::uint32_t index, double time_s, double* best,
                      bool* hit) const {
  const MovingBox& moving = moving_boxes_[index];
  const Eigen::Vector3d center = moving.centerAt(time_s);
  const Eigen::Vector3d half = 0.5 * moving.size_m;
  double t_near = 0.0;
  double t_far = 0.0;
  if (!slabInterval(ray, center - half, center + half, &t_near, &t_far)) return;
  if (firstCrossing(t_near, t_far, *best, best)) *hit = true;
}

void World::gatherCandidates(const Eigen::Vector3d& origin_W,
                             const Eigen::Vector3d (&corner_dirs_W)[4], double t_max, double time_s,
                             RayCandidates* candidates) const {
  if (candidates == nullptr) return;
  candidates->origin_W_ = origin_W;
  candidates->time_s_ = time_s;
  candidates->static_entries_.clear();
  candidates->moving_.clear();
  // Side planes through the origin with normals pointing into the pyramid.
  const Eigen::Vector3d axis =
      corner_dirs_W[0] + corner_dirs_W[1] + corner_dirs_W[2] + corner_dirs_W[3];
  Eigen::Vector3d normals[4];
  for (int i = 0; i < 4; ++i) {
    normals[i] = corner_dirs_W[i].cross(corner_dirs_W[(i + 1) % 4]);
    if (normals[i].dot(axis) < 0.0) normals[i] = -normals[i];
  }
  // Conservative test of a box against the pyramid and the range sphere.
  auto mayBeHit = [&](const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
    const Eigen::Vector3d center = 0.5 * (lo + hi) - origin_W;
    const Eigen::Vector3d half = 0.5 * (hi - lo);
    const double slack = 1e-9 * (1.0 + center.norm() + half.norm());
    if (pointBoxDistance(origin_W, lo, hi) > t_max + slack) return false;
    for (const Eigen::Vector3d& n : normals) {
      const double reach = n.dot(center) + n.cwiseAbs().dot(half);
      if (reach < -slack * n.norm()) return false;
    }
    return true;
  };
  for (std::uint32_t i = 0; i < entries_.size(); ++i) {
    if (mayBeHit(entries_[i].min_W, entries_[i].max_W)) candidates->static_entries_.push_back(i);
  }
  for (std::uint32_t i = 0; i < moving_boxes_.size(); ++i) {
    const MovingBox& m = moving_boxes_[i];
    if (!m.isActiveAt(time_s)) continue;
    const Eigen::Vector3d center = m.centerAt(time_s);
    if (mayBeHit(center - 0.5 * m.size_m, center + 0.5 * m.size_m)) {
      candidates->moving_.push_back(i);
    }
  }
}

bool World::raycast(const RayCandidates& candidates, const Eigen::Vector3d& unit_dir_W,
                    double t_max, double* t_hit) const {
  if (!(t_max > 0.0) || !candidates.origin_W_.allFinite() || !unit_dir_W.allFinite()) {
    return false;
  }
  const Ray ray(candidates.origin_W_, unit_dir_W);
  double best = t_max;
  bool hit = false;
  for (const std::uint32_t index : candidates.static_entries_) hitEntry(ray, index, &best, &hit);
  for (const std::uint32_t index : candidates.moving_) {
    hitMoving(ray, index, candidates.time_s_, &best, &hit);
  }
  if (hit && t_hit != nullptr) *t_hit = best;
  return hit;
}

bool World::raycast(const Eigen::Vector3d& origin_W, const Eigen::Vector3d& unit_dir_W,
                    double t_max, double time_s, double* t_hit) const {
  if (!(t_max > 0.0) || !origin_W.allFinite() || !unit_dir_W.allFinite()) return false;
  const Ray ray(origin_W, unit_dir_W);
  double best = t_max;
  bool hit = false;
  // Walk the grid cells along the ray (Amanatides-Woo) until the nearest hit so far lies before
  // the exit of the current cell.
  double t_enter = 0.0;
  double t_leave = 0.0;
  if (!cell_offsets_.empty() && slabInterval(ray, grid_min_W_, grid_max_W_, &t_enter, &t_leave) &&
      t_leave > 0.0 && t_enter <= best) {
    t_enter = std::max(t_enter, 0.0);
    const Eigen::Vector3d entry_point = ray.origin + t_enter * ray.dir;
    int cell[3];
    int step[3];
    double t_next[3];
    for (int i = 0; i < 3; ++i) {
      const double f = std::floor((entry_point[i] - grid_min_W_[i]) / cell_size_m_[i]);
      cell[i] = static_cast<int>(std::clamp(f, 0.0, grid_dims_[i] - 1.0));
      step[i] = ray.dir[i] > 0.0 ? 1 : (ray.dir[i] < 0.0 ? -1 : 0);
      t_next[i] = step[i] == 0
                      ? kInf
                      : (grid_min_W_[i] + (cell[i] + (step[i] > 0 ? 1 : 0)) * cell_size_m_[i] -
                         ray.origin[i]) *
                            ray.inv_dir[i];
    }
    const std::size_t stride_y = static_cast<std::size_t>(grid_dims_.x());
    const std::size_t stride_z = stride_y * static_cast<std::size_t>(grid_dims_.y());
    for (;;) {
      const std::size_t c = static_cast<std::size_t>(cell[2]) * stride_z +
                            static_cast<std::size_t>(cell[1]) * stride_y +
                            static_cast<std::size_t>(cell[0]);
      for (std::uint32_t k = cell_offsets_[c]; k < cell_offsets_[c + 1]; ++k) {
        hitEntry(ray, cell_items_[k], &best, &hit);
      }
      const int axis = (t_next[0] < t_next[1]) ? (t_next[0] < t_next[2] ? 0 : 2)
                                               : (t_next[1] < t_next[2] ? 1 : 2);
      const double t_exit = t_next[axis];
      if (best <= t_exit || t_exit > t_leave) break;
      cell[axis] += step[axis];
      if (cell[axis] < 0 || cell[axis] >= grid_dims_[axis]) break;
      t_next[axis] =
          (grid_min_W_[axis] + (cell[axis] + (step[axis] > 0 ? 1 : 0)) * cell_size_m_[axis] -
           ray.origin[axis]) *
          ray.inv_dir[axis];
    }
  }
  for (std::uint32_t i = 0; i < moving_boxes_.size(); ++i) {
    if (moving_boxes_[i].isActiveAt(time_s)) hitMoving(ray, i, time_s, &best, &hit);
  }
  if (hit && t_hit != nullptr) *t_hit = best;
  return hit;
}

bool World::isOccupied(const Eigen::Vector3d& p_W) const {
  for (const Box& box : boxes_) {
    if (insideBox(p_W, box.min_W, box.max_W)) return true;
  }
  for (const Cylinder& c : cylinders_) {
    if (p_W.z() < c.z_min_m || p_W.z() > c.z_max_m) continue;
    if ((p_W.head<2>() - c.center_xy_W).squaredNorm() <= c.radius_m * c.radius_m) return true;
  }
  for (const Sphere& s : spheres_) {
    if ((p_W - s.center_W).squaredNorm() <= s.radius_m * s.radius_m) return true;
  }
  return false;
}

bool World::isOccupiedAt(const Eigen::Vector3d& p_W, double time_s) const {
  if (isOccupied(p_W)) return true;
  for (const MovingBox& moving : moving_boxes_) {
    if (!moving.isActiveAt(time_s)) continue;
    const Eigen::Vector3d center = moving.centerAt(time_s);
    const Eigen::Vector3d half = 0.5 * moving.size_m;
    if (insideBox(p_W, center - half, center + half)) return true;
  }
  return false;
}

bool World::intersectsBox(const Eigen::Vector3d& min_W, const Eigen::Vector3d& max_W,
                          double tolerance_m) const {
  const double tol = std::max(0.0, tolerance_m);
  const double tol_sq = tol * tol;
  for (const Box& box : boxes_) {
    const Eigen::Vector3d gap = (box.min_W - max_W).cwiseMax(min_W - box.max_W).cwiseMax(0.0);
    if (gap.squaredNorm() <= tol_sq) return true;
  }
  for (const Cylinder& c : cylinders_) {
    // Both solids are products (disc x interval, rectangle x interval), so the distance between
    // them is the hypotenuse of the xy distance and the z gap.
    const double gap_z = intervalGap(c.z_min_m, c.z_max_m, min_W.z(), max_W.z());
    const Eigen::Vector2d lo = min_W.head<2>();
    const Eigen::Vector2d hi = max_W.head<2>();
    const double d_center = (lo - c.center_xy_W).cwiseMax(c.center_xy_W - hi).cwiseMax(0.0).norm();
    const double gap_xy = std::max(0.0, d_center - c.radius_m);
    if (gap_xy * gap_xy + gap_z * gap_z <= tol_sq) return true;
  }
  for (const Sphere& s : spheres_) {
    if (pointBoxDistance(s.center_W, min_W, max_W) <= s.radius_m + tol) return true;
  }
  return false;
}

double World::distance(const Eigen::Vector3d& p_W) const {
  double best = kInf;
  for (const Box& box : boxes_) best = std::min(best, pointBoxDistance(p_W, box.min_W, box.max_W));
  for (const Cylinder& c : cylinders_) {
    const double radial = std::max(0.0, (p_W.head<2>() - c.center_xy_W).norm() - c.radius_m);
    const double vertical = intervalGap(c.z_min_m, c.z_max_m, p_W.z(), p_W.z());
    best = std::min(best, std::hypot(radial, vertical));
  }
  for (const Sphere& s : spheres_) {
    best = std::min(best, std::max(0.0, (p_W - s.center_W).norm() - s.radius_m));
  }
  return best;
}

Eigen::AlignedBox3d World::bounds() const {
  Eigen::AlignedBox3d box;  // default constructed = empty
  for (const Entry& entry : entries_) {
    box.extend(entry.min_W);
    box.extend(entry.max_W);
  }
  return box;
}

World World::defaultRoom() {
  World world;
  using V3 = Eigen::Vector3d;
  using V2 = Eigen::Vector2d;
  constexpr double kWallHeight_m = 4.0;
  constexpr double kT = 0.2;  // wall thickness [m]
  // Floor slab, top surface at z = 0.
  world.addBox({V3(0.0, 0.0, -0.2), V3(30.0, 20.0, 0.0)});
  // Perimeter walls (inside the 30 x 20 m footprint), no ceiling.
  world.addBox({V3(0.0, 0.0, 0.0), V3(30.0, kT, kWallHeight_m)});              // south, y = 0
  world.addBox({V3(0.0, 20.0 - kT, 0.0), V3(30.0, 20.0, kWallHeight_m)});      // north, y = 20
  world.addBox({V3(0.0, kT, 0.0), V3(kT, 20.0 - kT, kWallHeight_m)});          // west, x = 0
  world.addBox({V3(30.0 - kT, kT, 0.0), V3(30.0, 20.0 - kT, kWallHeight_m)});  // east, x = 30
  // Interior wall at x = 10 with doorway gaps y in (3, 6) and (14, 17).
  world.addBox({V3(9.9, kT, 0.0), V3(10.1, 3.0, kWallHeight_m)});
  world.addBox({V3(9.9, 6.0, 0.0), V3(10.1, 14.0, kWallHeight_m)});
  world.addBox({V3(9.9, 17.0, 0.0), V3(10.1, 20.0 - kT, kWallHeight_m)});
  // Interior wall at y = 10 from x = 20 to the east wall with a gap x in (23.5, 26.5).
  world.addBox({V3(20.0, 9.9, 0.0), V3(23.5, 10.1, kWallHeight_m)});
  world.addBox({V3(26.5, 9.9, 0.0), V3(30.0 - kT, 10.1, kWallHeight_m)});
  // Furniture boxes.
  world.addBox({V3(6.5, 1.0, 0.0), V3(8.0, 2.5, 1.5)});      // crate on the floor
  world.addBox({V3(12.0, 6.5, 0.0), V3(14.0, 8.5, 1.0)});    // low wide box
  world.addBox({V3(16.0, 12.0, 1.1), V3(19.0, 12.6, 1.2)});  // floating shelf
  world.addBox({V3(27.0, 1.0, 0.0), V3(29.0, 2.5, 2.2)});    // tall cabinet
  world.addBox({V3(6.0, 11.0, 0.0), V3(8.0, 13.0, 0.8)});    // table-like block
  world.addBox({V3(22.0, 17.0, 0.0), V3(24.0, 19.0, 2.0)});  // stack in the north-east
  // Vertical cylinders.
  world.addCylinder({V2(7.0, 8.0), 0.3, 0.0, 3.0});
  world.addCylinder({V2(14.0, 2.0), 0.4, 0.0, 3.0});
  world.addCylinder({V2(15.0, 10.0), 0.5, 0.0, 4.0});
  world.addCylinder({V2(22.0, 7.0), 0.25, 0.0, 2.5});
  world.addCylinder({V2(27.5, 13.0), 0.3, 0.0, 3.0});
  world.addCylinder({V2(12.0, 17.5), 0.05, 0.0, 3.0});  // thin pole
  world.addCylinder({V2(20.0, 13.0), 0.2, 0.5, 2.5});   // floating column
  // Spheres.
  world.addSphere({V3(18.0, 8.0, 1.5), 0.5});   // floating
  world.addSphere({V3(12.0, 12.5, 2.0), 0.6});  // floating
  world.addSphere({V3(27.0, 7.0, 0.4), 0.4});   // resting on the floor
  world.addSphere({V3(3.0, 18.0, 1.2), 0.7});   // floating
  // A person crossing in front of the camera during the first leg of defaultRoomFlight().
  world.addMovingBox({V3(0.5, 0.5, 1.8), V3(17.0, 1.0, 0.9), V3(0.0, 1.0, 0.0), 7.0, 15.0});
  return world;
}

}  // namespace mlmap::sim
