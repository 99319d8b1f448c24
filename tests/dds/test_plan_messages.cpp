// The planner peer's inputs rebuilt from the node's messages (plan_messages.h) against what the
// node built them from: the grid and the box's occupancy exactly, the ESDF bit for bit, and the
// reference planner's route and local plan on the rebuilt snapshot equal to those on the
// engine's own. Malformed messages are rejected with a reason. No DDS traffic.

#include "mlmap/dds/nav/plan_messages.h"
#include "mlmap/nav/nav_flight.h"
#include "mlmap/pipeline/map_engine.h"
#include "mlmap/sim/depth_camera.h"
#include "mlmap/sim/vehicle.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace mlmap::dds {
namespace {

/// A box of random states (a quarter unknown, a fifth occupied), seeded.
OccupancyBox randomBox(std::uint32_t seed) {
  OccupancyBox box;
  box.reset(VoxelIndex(-7, 12, -3), Eigen::Vector3i(23, 17, 9), 0.1);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (Occupancy& s : box.states) {
    const double r = u(rng);
    s = r < 0.25 ? Occupancy::kUnknown : r < 0.45 ? Occupancy::kOccupied : Occupancy::kFree;
  }
  return box;
}

EsdfConfig navEsdf(double max_distance_m) {
  EsdfConfig c;
  c.max_distance_m = max_distance_m;
  c.unknown_as = UnknownAs::kFree;
  return c;
}

TEST(PlanMessages, EsdfBlockGivesTheBoxAndTheFieldBack) {
  const OccupancyBox box = randomBox(5);
  EsdfMap node_field(navEsdf(1.0));
  ASSERT_TRUE(node_field.compute(box));
  const mlmap_msgs::VoxelBlock_ msg = toVoxelBlock(node_field, 12.5, "map");

  OccupancyBox decoded;
  double max_distance_m = 0.0;
  const DecodeStatus s = decodeEsdfBlock(msg, &decoded, &max_distance_m);
  ASSERT_TRUE(s.ok()) << s.detail;
  EXPECT_EQ(decoded.min_index, box.min_index);
  EXPECT_EQ(decoded.size, box.size);
  EXPECT_DOUBLE_EQ(decoded.resolution_m, box.resolution_m);
  EXPECT_EQ(decoded.states, box.states);
  EXPECT_DOUBLE_EQ(max_distance_m, 1.0);

  const auto snap = plannerSnapshot(decoded, ProjectedGrid{}, navEsdf(max_distance_m), 3, 12.5);
  ASSERT_NE(snap->esdf(), nullptr);
  EXPECT_EQ(snap->frame(), 3u);
  EXPECT_DOUBLE_EQ(snap->stamp_s(), 12.5);
  EXPECT_EQ(snap->esdf()->distances(), node_field.distances());
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> ux(-0.7, 1.6), uy(1.2, 2.9), uz(-0.3, 0.6);
  for (int i = 0; i < 2000; ++i) {
    const double x = ux(rng);
    const double y = uy(rng);
    const Eigen::Vector3d p(x, y, uz(rng));
    const EsdfMap::Query a = node_field.query(p);
    const EsdfMap::Query b = snap->distance(p);
    ASSERT_EQ(a.valid, b.valid) << p.transpose();
    if (a.valid) {
      ASSERT_EQ(a.distance_m, b.distance_m) << p.transpose();
    }
    const VoxelIndex g = voxelIndexOf(p, 0.1);
    ASSERT_EQ(snap->state(p), box.contains(g) ? box.at(g) : Occupancy::kUnknown) << p.transpose();
  }
}

TEST(PlanMessages, MalformedEsdfBlocksAreRejected) {
  EsdfMap field(navEsdf(1.0));
  ASSERT_TRUE(field.compute(randomBox(7)));
  const mlmap_msgs::VoxelBlock_ good = toVoxelBlock(field, 1.0, "map");
  OccupancyBox out = randomBox(8);
  const OccupancyBox before = out;
  auto expect_rejected = [&](const mlmap_msgs::VoxelBlock_& m, DecodeError error) {
    const DecodeStatus s = decodeEsdfBlock(m, &out);
    EXPECT_EQ(s.error, error) << s.detail;
    EXPECT_FALSE(s.detail.empty());
    EXPECT_EQ(out.states, before.states);
  };
  mlmap_msgs::VoxelBlock_ m = good;
  m.values_().pop_back();
  expect_rejected(m, DecodeError::kBadLayout);
  m = good;
  m.size_z_(m.size_z_() + 1);
  expect_rejected(m, DecodeError::kBadLayout);
  m = good;
  m.size_x_(1u << 20);
  expect_rejected(m, DecodeError::kBadLayout);
  m = good;
  m.origin_().x_(m.origin_().x_() + 0.03);
  expect_rejected(m, DecodeError::kBadLayout);
  m = good;
  m.origin_().y_(std::numeric_limits<double>::infinity());
  expect_rejected(m, DecodeError::kBadLayout);
  m = good;
  m.resolution_(0.0);
  expect_rejected(m, DecodeError::kBadLayout);
  m = good;
  m.max_value_(std::numeric_limits<float>::quiet_NaN());
  expect_rejected(m, DecodeError::kBadLayout);
  m = good;
  m.layer_("occupancy");
  expect_rejected(m, DecodeError::kUnsupportedType);
  m = good;
  m.version_(2);
  expect_rejected(m, DecodeError::kUnsupportedType);
  m = good;
  m.header_().stamp_().nanosec_(1000000000u);
  expect_rejected(m, DecodeError::kBadStamp);
}

TEST(PlanMessages, OccupancyGridGivesTheGridBack) {
  ProjectedGrid grid;
  grid.origin_W = Eigen::Vector2d(-3.2, 1.4);
  grid.resolution_m = 0.2;
  grid.width = 7;
  grid.height = 5;
  for (int i = 0; i < 35; ++i) {
    grid.cells.push_back(static_cast<std::int8_t>(i % 3 == 0 ? -1 : i % 3 == 1 ? 0 : 100));
  }
  const nav_msgs::OccupancyGrid_ msg = toOccupancyGrid(grid, 1.5, 4.0, "map");
  ProjectedGrid decoded;
  ASSERT_TRUE(decodeOccupancyGrid(msg, &decoded).ok());
  EXPECT_EQ(decoded.origin_W, grid.origin_W);
  EXPECT_EQ(decoded.resolution_m, grid.resolution_m);  // 0.2, not the float's 0.20000000298
  EXPECT_EQ(decoded.width, grid.width);
  EXPECT_EQ(decoded.height, grid.height);
  EXPECT_EQ(decoded.cells, grid.cells);

  const ProjectedGrid before = decoded;
  auto expect_rejected = [&](const nav_msgs::OccupancyGrid_& m) {
    const DecodeStatus s = decodeOccupancyGrid(m, &decoded);
    EXPECT_FALSE(s.ok());
    EXPECT_EQ(decoded.cells, before.cells);
  };
  nav_msgs::OccupancyGrid_ m = msg;
  m.data_().pop_back();
  expect_rejected(m);
  m = msg;
  m.data_()[3] = 101;
  expect_rejected(m);
  m = msg;
  m.info_().origin_().orientation_().z_(0.7071);
  m.info_().origin_().orientation_().w_(0.7071);
  expect_rejected(m);
  m = msg;
  m.info_().resolution_(-0.2f);
  expect_rejected(m);
  m = msg;
  m.header_().stamp_().nanosec_(2000000000u);
  expect_rejected(m);
}

// The lead a setpoint carries makes a position-only controller (sim::Vehicle with zero velocity
// feed-forward) fly the command the setpoint's velocity asks for.
TEST(PlanMessages, SetpointLeadGivesThePositionControllerTheVelocityCommand) {
  nav::Setpoint sp;
  sp.position_W = Eigen::Vector3d(1.0, 2.0, 1.5);
  sp.velocity_W = Eigen::Vector3d(0.6, -0.3, 0.0);
  sp.yaw_rad = 2.5;
  sim::VehicleLimits limits;
  sim::VehicleState start;
  start.position_W = Eigen::Vector3d(1.1, 1.8, 1.45);
  start.yaw_rad = 0.3;
  sim::Vehicle with_velocity(start, limits);
  sim::Vehicle with_lead(start, limits);
  Eigen::Vector3d target_W;
  double yaw_rad = 0.0;
  double stamp_s = 0.0;
  const geometry_msgs::PoseStamped_ msg =
      toSetpointPose(sp, limits.position_gain_per_s, 7.25, "map");
  ASSERT_TRUE(decodeSetpointPose(msg, &stamp_s, &target_W, &yaw_rad).ok());
  EXPECT_DOUBLE_EQ(stamp_s, 7.25);
  EXPECT_NEAR(yaw_rad, 2.5, 1e-9);
  for (int k = 0; k < 5; ++k) {
    with_velocity.step(sp.position_W, sp.velocity_W, sp.yaw_rad, 0.02);
    with_lead.step(target_W, Eigen::Vector3d::Zero(), yaw_rad, 0.02);
  }
  EXPECT_LT((with_velocity.state().position_W - with_lead.state().position_W).norm(), 1e-9);
  EXPECT_LT((with_velocity.state().velocity_W - with_lead.state().velocity_W).norm(), 1e-9);
  EXPECT_THROW((void)toSetpointPose(sp, 0.0, 0.0, "map"), std::invalid_argument);
}

TEST(PlanMessages, PathHoldsThePointsFacingAlongIt) {
  const std::vector<Eigen::Vector3d> points = {{0, 0, 1}, {1, 0, 1}, {1, 2, 1}};
  const nav_msgs::Path_ path = toPath(points, 3.5, "map");
  EXPECT_EQ(path.header_().frame_id_(), "map");
  EXPECT_DOUBLE_EQ(toSeconds(path.header_().stamp_()), 3.5);
  ASSERT_EQ(path.poses_().size(), 3u);
  const double expected_yaw[3] = {0.0, M_PI / 2, M_PI / 2};
  for (std::size_t i = 0; i < 3; ++i) {
    double stamp_s = 0.0;
    Eigen::Vector3d p;
    double yaw_rad = 0.0;
    ASSERT_TRUE(decodeSetpointPose(path.poses_()[i], &stamp_s, &p, &yaw_rad).ok());
    EXPECT_LT((p - points[i]).norm(), 1e-12);
    EXPECT_NEAR(yaw_rad, expected_yaw[i], 1e-9);
  }
  EXPECT_TRUE(toPath({}, 0.0, "map").poses_().empty());
}

// The reference planner on the snapshot rebuilt from the node's two messages plans what it plans
// on the engine's own snapshot: the same route and the same local plan.
TEST(PlanMessages, NavigatorPlansTheSameOnTheRebuiltSnapshot) {
  const nav::NavWorld world = nav::forestWorld(21, 0.08, {14.0, 8.0});
  MapConfig config = nav::navMapConfig(0.2);
  MapEngine engine(config);
  const nav::NavFlightOptions flight;
  const sim::DepthCamera camera(flight.camera);
  sim::VehicleState state;
  state.position_W = world.start_W;
  state.yaw_rad = world.start_yaw_rad;
  for (int i = 0; i < 3; ++i) {
    DepthFrame frame;
    frame.stamp_s = 0.1 * i;
    camera.render(world.world, state.T_W_B() * config.sensor.T_B_S(), frame.stamp_s, &frame);
    frame.T_W_B = state.T_W_B();
    frame.T_B_S = config.sensor.T_B_S();
    ASSERT_EQ(engine.submit(std::move(frame)), FrameStatus::kAccepted);
  }
  const auto own = engine.snapshot();
  ASSERT_NE(own->esdf(), nullptr);
  OccupancyBox box;
  ProjectedGrid grid;
  double max_distance_m = 0.0;
  ASSERT_TRUE(
      decodeEsdfBlock(toVoxelBlock(*own->esdf(), own->stamp_s(), "map"), &box, &max_distance_m)
          .ok());
  ASSERT_TRUE(
      decodeOccupancyGrid(toOccupancyGrid(own->grid(), 0.0, own->stamp_s(), "map"), &grid).ok());
  const auto rebuilt =
      plannerSnapshot(box, grid, navEsdf(max_distance_m), own->frame(), own->stamp_s());

  nav::Navigator a(flight.planner);
  nav::Navigator b(flight.planner);
  a.setGoal(world.goal_W);
  b.setGoal(world.goal_W);
  EXPECT_NE(a.update(*own, state.position_W, 0.3), nav::PlanReason::kNone);
  EXPECT_NE(b.update(*rebuilt, state.position_W, 0.3), nav::PlanReason::kNone);
  ASSERT_GE(a.route_W().size(), 2u);
  EXPECT_EQ(a.route_W(), b.route_W());
  EXPECT_EQ(a.localPlan().points_W, b.localPlan().points_W);
  EXPECT_EQ(a.localPlan().committed, b.localPlan().committed);
  EXPECT_GT(a.localPlan().committed, 1u);
}

}  // namespace
}  // namespace mlmap::dds
