#include "mlmap/dds/nav/plan_messages.h"

#include <Eigen/Geometry>

#include <cmath>
#include <limits>
#include <stdexcept>

namespace mlmap::dds {
namespace {

DecodeStatus fail(DecodeError error, std::string detail) { return {error, std::move(detail)}; }

bool finitePositive(double v) { return std::isfinite(v) && v > 0.0; }

}  // namespace

DecodeStatus decodeOccupancyGrid(const nav_msgs::OccupancyGrid_& msg, ProjectedGrid* grid) {
  if (msg.header_().stamp_().nanosec_() >= 1000000000u) {
    return fail(DecodeError::kBadStamp, "nanosec >= 1e9");
  }
  const nav_msgs::MapMetaData_& info = msg.info_();
  // float32 on the wire: 0.2 arrives as 0.20000000298. Rounded to the micrometre it is the
  // node's double again, so that cells fall on the same lattice as the node's.
  const double resolution_m = std::round(static_cast<double>(info.resolution_()) * 1e6) / 1e6;
  if (!finitePositive(resolution_m)) return fail(DecodeError::kBadLayout, "resolution");
  const auto& position = info.origin_().position_();
  const auto& q = info.origin_().orientation_();
  if (!std::isfinite(position.x_()) || !std::isfinite(position.y_()) ||
      !std::isfinite(position.z_())) {
    return fail(DecodeError::kBadLayout, "origin not finite");
  }
  if (!(std::abs(q.x_()) < 1e-6 && std::abs(q.y_()) < 1e-6 && std::abs(q.z_()) < 1e-6 &&
        std::abs(q.w_() - 1.0) < 1e-6)) {
    return fail(DecodeError::kBadLayout, "origin rotated (only grids aligned with the world)");
  }
  const std::uint64_t cells = std::uint64_t{info.width_()} * info.height_();
  if (info.width_() > static_cast<std::uint32_t>(std::numeric_limits<int>::max()) ||
      info.height_() > static_cast<std::uint32_t>(std::numeric_limits<int>::max()) ||
      msg.data_().size() != cells) {
    return fail(DecodeError::kBadLayout, std::to_string(msg.data_().size()) + " cells for " +
                                             std::to_string(info.width_()) + " x " +
                                             std::to_string(info.height_()));
  }
  for (const std::int8_t v : msg.data_()) {
    if (v < -1 || v > 100) return fail(DecodeError::kBadLayout, "cell value " + std::to_string(v));
  }
  grid->origin_W = Eigen::Vector2d(position.x_(), position.y_());
  grid->resolution_m = resolution_m;
  grid->width = static_cast<int>(info.width_());
  grid->height = static_cast<int>(info.height_());
  grid->band_min_z_m = 0.0;
  grid->band_max_z_m = 0.0;
  grid->cells.assign(msg.data_().begin(), msg.data_().end());
  return {};
}

DecodeStatus decodeEsdfBlock(const mlmap_msgs::VoxelBlock_& msg, OccupancyBox* box,
                             double* max_distance_m) {
  if (msg.header_().stamp_().nanosec_() >= 1000000000u) {
    return fail(DecodeError::kBadStamp, "nanosec >= 1e9");
  }
  if (msg.layer_() != "esdf" || msg.version_() != 1) {
    return fail(DecodeError::kUnsupportedType,
                "layer \"" + msg.layer_() + "\" version " + std::to_string(msg.version_()));
  }
  const double resolution_m = msg.resolution_();
  if (!finitePositive(resolution_m)) return fail(DecodeError::kBadLayout, "resolution");
  if (!finitePositive(msg.max_value_())) return fail(DecodeError::kBadLayout, "max_value");
  const std::uint32_t sx = msg.size_x_();
  const std::uint32_t sy = msg.size_y_();
  const std::uint32_t sz = msg.size_z_();
  const auto axis_max = static_cast<std::uint32_t>(EsdfMap::kMaxCellsPerAxis);
  if (sx > axis_max || sy > axis_max || sz > axis_max) {
    return fail(DecodeError::kBadLayout, "a size above " + std::to_string(axis_max));
  }
  const std::uint64_t cells = std::uint64_t{sx} * sy * sz;
  if (cells > static_cast<std::uint64_t>(EsdfMap::kMaxCells) || msg.values_().size() != cells) {
    return fail(DecodeError::kBadLayout, std::to_string(msg.values_().size()) + " values for " +
                                             std::to_string(sx) + " x " + std::to_string(sy) +
                                             " x " + std::to_string(sz));
  }
  const Eigen::Vector3d origin(msg.origin_().x_(), msg.origin_().y_(), msg.origin_().z_());
  const Eigen::Vector3d in_voxels = origin / resolution_m;
  if (!in_voxels.allFinite() || in_voxels.cwiseAbs().maxCoeff() > kMaxAbsWindowVoxelIndex) {
    return fail(DecodeError::kBadLayout, "origin not finite or too far");
  }
  const Eigen::Vector3d rounded = in_voxels.array().round();
  if ((in_voxels - rounded).cwiseAbs().maxCoeff() > 1e-3) {
    return fail(DecodeError::kBadLayout, "origin off the voxel grid");
  }
  box->reset(rounded.cast<int>(),
             Eigen::Vector3i(static_cast<int>(sx), static_cast<int>(sy), static_cast<int>(sz)),
             resolution_m);
  const std::vector<float>& values = msg.values_();
  for (std::size_t i = 0; i < values.size(); ++i) {  // the same order: x-major, z fastest
    const float d = values[i];
    box->states[i] = std::isnan(d) ? Occupancy::kUnknown
                     : d < 0.0f    ? Occupancy::kOccupied
                                   : Occupancy::kFree;
  }
  if (max_distance_m != nullptr) *max_distance_m = msg.max_value_();
  return {};
}

std::shared_ptr<LocalWindow> windowFromBox(const OccupancyBox& box) {
  auto window = std::make_shared<LocalWindow>();
  window->min_index = box.min_index;
  window->size = box.size;
  window->resolution_m = box.resolution_m;
  window->log_odds.resize(box.states.size());
  const LogOddsModel& model = window->model;
  for (std::size_t i = 0; i < box.states.size(); ++i) {
    switch (box.states[i]) {
      case Occupancy::kOccupied:
        window->log_odds[i] = model.clampMax();
        break;
      case Occupancy::kFree:
        window->log_odds[i] = model.clampMin();
        break;
      case Occupancy::kUnknown:
        window->log_odds[i] = kUnknownLogOdds;
        break;
    }
  }
  return window;
}

std::shared_ptr<const MapSnapshot> plannerSnapshot(const OccupancyBox& box,
                                                   const ProjectedGrid& grid,
                                                   const EsdfConfig& esdf, std::uint64_t frame,
                                                   double stamp_s) {
  std::shared_ptr<EsdfMap> field;
  if (!box.states.empty()) {
    field = std::make_shared<EsdfMap>(esdf);
    if (!field->compute(box)) field.reset();
  }
  return std::make_shared<const MapSnapshot>(
      windowFromBox(box), std::make_shared<const ProjectedGrid>(grid), std::move(field), frame,
      stamp_s, Transform::Identity(), frame);
}

nav_msgs::Path_ toPath(const std::vector<Eigen::Vector3d>& points_W, double stamp_s,
                       const std::string& frame_id) {
  nav_msgs::Path_ path;
  path.header_().stamp_(toRosTime(stamp_s));
  path.header_().frame_id_(frame_id);
  double yaw_rad = 0.0;
  for (std::size_t i = 0; i < points_W.size(); ++i) {
    if (i + 1 < points_W.size()) {
      const Eigen::Vector3d d = points_W[i + 1] - points_W[i];
      if (d.head<2>().norm() > 1e-9) yaw_rad = std::atan2(d.y(), d.x());
    }
    Transform T_W_P = Transform::Identity();
    T_W_P.translation() = points_W[i];
    T_W_P.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    path.poses_().push_back(toPoseStamped(T_W_P, stamp_s, frame_id));
  }
  return path;
}

geometry_msgs::PoseStamped_ toSetpointPose(const nav::Setpoint& setpoint,
                                           double position_gain_per_s, double stamp_s,
                                           const std::string& frame_id) {
  if (!finitePositive(position_gain_per_s)) {
    throw std::invalid_argument("toSetpointPose: the position gain must be finite and positive");
  }
  Transform T_W_S = Transform::Identity();
  T_W_S.translation() = setpoint.position_W + setpoint.velocity_W / position_gain_per_s;
  T_W_S.linear() = Eigen::AngleAxisd(setpoint.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return toPoseStamped(T_W_S, stamp_s, frame_id);
}

DecodeStatus decodeSetpointPose(const geometry_msgs::PoseStamped_& msg, double* stamp_s,
                                Eigen::Vector3d* position_W, double* yaw_rad) {
  double stamp = 0.0;
  Transform T_W_S = Transform::Identity();
  DecodeStatus status = decodePose(msg, &stamp, &T_W_S);
  if (!status.ok()) return status;
  const Eigen::Vector3d x_W = T_W_S.linear().col(0);
  *stamp_s = stamp;
  *position_W = T_W_S.translation();
  *yaw_rad = std::atan2(x_W.y(), x_W.x());
  return status;
}

}  // namespace mlmap::dds
