/// @file
/// TfTree, the /tf and /tf_static chains of a bag: poses against a slow reference that composes
/// every edge at every stamp, and every walk bounded (cycles, chains too long, no world frame).

#include "mlmap/bag/tf_tree.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

namespace mlmap::bag {
namespace {

Transform shifted(double x, double y, double yaw_rad) {
  Transform T = Transform::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, 0.1 * x);
  return T;
}

/// The message of the std::runtime_error that `tree.poses()` throws ("" when none).
std::string posesError(TfTree& tree) {
  try {
    (void)tree.poses();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

// A chain map -s-> a -d-> b -s-> c -s-> d -d-> base_link: the poses at the lowest dynamic edge's
// stamps, each edge composed one by one at each stamp (the slow way), agree with the tree's, whose
// consecutive static edges are multiplied once.
TEST(TfTree, PosesEqualEveryEdgeComposedAtEveryStamp) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  TfTree tree("map", "base_link");
  const Transform T_map_a = shifted(u(rng), u(rng), u(rng));
  const Transform T_b_c = shifted(u(rng), u(rng), u(rng));
  const Transform T_c_d = shifted(u(rng), u(rng), u(rng));
  tree.addStatic("map", "a", T_map_a);
  tree.addStatic("b", "c", T_b_c);
  tree.addStatic("c", "d", T_c_d);
  std::vector<StampedTransform> a_b, d_base;
  for (int i = 0; i < 5; ++i) a_b.push_back({1.0 * i, shifted(u(rng), u(rng), u(rng))});
  for (int i = 0; i < 40; ++i) d_base.push_back({0.1 * i + 0.05, shifted(u(rng), u(rng), u(rng))});
  // Interleaved, out of order, as a bag may hold them.
  for (int i = 39; i >= 0; --i) {
    tree.addDynamic("d", "base_link", d_base[i].stamp_s, d_base[i].T);
    if (i % 8 == 0) tree.addDynamic("a", "b", a_b[i / 8].stamp_s, a_b[i / 8].T);
  }
  const std::vector<StampedTransform> poses = tree.poses();
  ASSERT_EQ(poses.size(), d_base.size());
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const double t = d_base[k].stamp_s;
    ASSERT_DOUBLE_EQ(poses[k].stamp_s, t);
    const Transform expected = T_map_a * TfTree::at(a_b, t) * T_b_c * T_c_d * TfTree::at(d_base, t);
    EXPECT_LT((poses[k].T.matrix() - expected.matrix()).cwiseAbs().maxCoeff(), 1e-9) << k;
  }
}

// A static edge between the body and its /tf parent (base_link -> base_footprint, as many robots
// have) used to hide every frame above it: no pose at all, or a read of an empty series (a crash)
// when a dynamic edge sat above and below it.
TEST(TfTree, StaticEdgesBetweenDynamicOnesKeepTheSeriesAboveThem) {
  TfTree tree("map", "base_link");
  tree.addStatic("base_footprint", "base_link", shifted(0.0, 0.0, 0.0));
  tree.addDynamic("odom", "base_footprint", 0.0, shifted(1.0, 0.0, 0.0));
  tree.addDynamic("map", "odom", 0.0, shifted(0.0, 1.0, 0.0));
  tree.addDynamic("odom", "base_footprint", 1.0, shifted(2.0, 0.0, 0.0));
  tree.addDynamic("map", "odom", 1.0, shifted(0.0, 3.0, 0.0));
  const std::vector<StampedTransform> poses = tree.poses();
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_TRUE(poses[1].T.translation().isApprox(Eigen::Vector3d(2.0, 3.0, 0.2), 1e-12))
      << poses[1].T.translation().transpose();
  // Static edges that arrive after the dynamic ones (a /tf_static later in the bag) too.
  TfTree late("map", "base_link");
  late.addDynamic("odom", "base_footprint", 0.0, shifted(1.0, 0.0, 0.0));
  late.addDynamic("map", "odom", 0.0, shifted(0.0, 1.0, 0.0));
  late.addStatic("base_footprint", "base_link", shifted(0.0, 0.0, 0.0));
  late.addDynamic("odom", "base_footprint", 1.0, shifted(2.0, 0.0, 0.0));
  EXPECT_EQ(late.poses().size(), 2u);
}

TEST(TfTree, CyclesAndChainsThatNeverReachTheWorldAreRefused) {
  TfTree dynamic_cycle("map", "base_link");
  dynamic_cycle.addDynamic("odom", "base_link", 0.0, Transform::Identity());
  dynamic_cycle.addDynamic("base_link", "odom", 0.0, Transform::Identity());
  EXPECT_NE(posesError(dynamic_cycle).find("base_link <- odom <- base_link"), std::string::npos)
      << posesError(dynamic_cycle);

  TfTree static_cycle("map", "base_link");
  static_cycle.addDynamic("odom", "base_link", 0.0, Transform::Identity());
  static_cycle.addStatic("a", "odom", Transform::Identity());
  static_cycle.addStatic("odom", "a", Transform::Identity());
  EXPECT_NE(posesError(static_cycle).find("a /tf or /tf_static cycle"), std::string::npos);

  TfTree no_world("map", "base_link");
  no_world.addDynamic("odom", "base_link", 0.0, Transform::Identity());
  EXPECT_NE(posesError(no_world).find("no /tf path from 'map'"), std::string::npos);
}

TEST(TfTree, ChainsLongerThanTheBoundAreRefusedAndShorterOnesComposed) {
  for (const std::size_t edges : {kMaxTfChainEdges, kMaxTfChainEdges + 1}) {
    TfTree tree("f0", "base_link");
    tree.addDynamic("f" + std::to_string(edges - 1), "base_link", 0.0, shifted(0.01, 0.0, 0.0));
    for (std::size_t k = edges - 1; k >= 1; --k) {
      tree.addStatic("f" + std::to_string(k - 1), "f" + std::to_string(k), shifted(1.0, 0.0, 0.0));
    }
    if (edges <= kMaxTfChainEdges) {
      const std::vector<StampedTransform> poses = tree.poses();
      ASSERT_EQ(poses.size(), 1u);
      EXPECT_NEAR(poses[0].T.translation().x(), double(edges - 1) + 0.01, 1e-9);
    } else {
      EXPECT_NE(posesError(tree).find("more than 64 transforms"), std::string::npos)
          << posesError(tree);
    }
  }
}

TEST(TfTree, ExtrinsicsThroughStaticEdgesEitherWayWithinTheBound) {
  TfTree tree("map", "base_link");
  const Transform T_base_mount = shifted(0.2, 0.0, 0.5);
  const Transform T_mount_cam = shifted(0.0, 0.1, -0.2);
  tree.addStatic("base_link", "mount", T_base_mount);
  tree.addStatic("mount", "camera", T_mount_cam);
  tree.addStatic("lidar", "base_link", shifted(0.3, 0.0, 0.0));  // the body as the child
  ASSERT_TRUE(tree.staticFromBody("camera"));
  EXPECT_TRUE(tree.staticFromBody("camera")->isApprox(T_base_mount * T_mount_cam, 1e-12));
  ASSERT_TRUE(tree.staticFromBody("lidar"));
  EXPECT_TRUE(tree.staticFromBody("lidar")->isApprox(shifted(0.3, 0.0, 0.0).inverse(), 1e-12));
  EXPECT_TRUE(tree.staticFromBody("base_link")->isApprox(Transform::Identity()));
  EXPECT_FALSE(tree.staticFromBody("nowhere"));
  // A sensor further than the bound is not reached; a static cycle ends the search.
  TfTree deep("map", "base_link");
  std::string parent = "base_link";
  for (std::size_t k = 0; k <= kMaxTfChainEdges; ++k) {
    deep.addStatic(parent, "s" + std::to_string(k), Transform::Identity());
    parent = "s" + std::to_string(k);
  }
  EXPECT_TRUE(deep.staticFromBody("s" + std::to_string(kMaxTfChainEdges - 1)));
  EXPECT_FALSE(deep.staticFromBody("s" + std::to_string(kMaxTfChainEdges)));
  deep.addStatic("s" + std::to_string(kMaxTfChainEdges), "base_link", Transform::Identity());
  EXPECT_FALSE(deep.staticFromBody("nowhere")) << "the search ends in a cycle";
  EXPECT_TRUE(deep.staticFromBody("s" + std::to_string(kMaxTfChainEdges)))
      << "one edge away the other way round";
}

}  // namespace
}  // namespace mlmap::bag
