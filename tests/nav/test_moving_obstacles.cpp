// The moving-obstacle tracker: grouping against a reference over all pairs, a person's velocity
// measured from the frames that saw them, where they will be predicted (also unseen), standing
// and wide groups left out, and obstacles dropped once unseen for long.
#include "mlmap/nav/moving_obstacles.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

namespace mlmap::nav {
namespace {

/// The points a frame sees of a 0.5 x 0.5 m person centred at c_W: a face of 3 x 3 points.
std::vector<Eigen::Vector3d> personPoints(const Eigen::Vector2d& c_W) {
  std::vector<Eigen::Vector3d> out;
  for (int i = -1; i <= 1; ++i) {
    for (int k = 0; k < 3; ++k) out.emplace_back(c_W.x() - 0.25, c_W.y() + 0.2 * i, 0.8 + 0.2 * k);
  }
  return out;
}

TEST(MovingObstacles, GroupsPointsLinkedByChainsAsAReferenceOverAllPairsDoes) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 4.0);
  for (int round = 0; round < 20; ++round) {
    std::vector<Eigen::Vector3d> points(60);
    for (Eigen::Vector3d& p : points) p = {u(rng), u(rng), 1.0};
    const double link = 0.45;
    // Reference: label propagation over all pairs until nothing changes.
    std::vector<std::size_t> label(points.size());
    std::iota(label.begin(), label.end(), 0);
    for (bool changed = true; changed;) {
      changed = false;
      for (std::size_t i = 0; i < points.size(); ++i) {
        for (std::size_t j = 0; j < points.size(); ++j) {
          if ((points[i].head<2>() - points[j].head<2>()).norm() < link && label[j] < label[i]) {
            label[i] = label[j];
            changed = true;
          }
        }
      }
    }
    const std::vector<std::vector<std::size_t>> groups = groupPoints(points, link);
    std::vector<int> seen(points.size(), 0);
    for (const std::vector<std::size_t>& g : groups) {
      for (const std::size_t i : g) {
        ++seen[i];
        EXPECT_EQ(label[i], label[g.front()]);  // one reference group
      }
      // and all of it
      EXPECT_EQ(static_cast<std::size_t>(std::count(label.begin(), label.end(), label[g.front()])),
                g.size());
    }
    for (const int s : seen) EXPECT_EQ(s, 1);
  }
}

TEST(MovingObstacles, MeasuresAWalkingPersonAndPredictsThemUnseen) {
  MovingObstacleConfig config;
  MovingObstacleTracker tracker(config);
  const Eigen::Vector2d v(0.0, 1.0);
  // Seen for 1 s, 10 frames, walking +y at 1 m/s from (3, -2).
  for (int k = 0; k <= 10; ++k) {
    const double t = 0.1 * k;
    tracker.update(personPoints(Eigen::Vector2d(3.0, -2.0) + v * t), std::vector<bool>(9, true), t);
  }
  ASSERT_EQ(tracker.obstacles().size(), 1u);
  const MovingObstacle& o = tracker.obstacles().front();
  EXPECT_NEAR(o.velocity_W.x(), 0.0, 1e-9);
  EXPECT_NEAR(o.velocity_W.y(), 1.0, 1e-9);
  EXPECT_TRUE(o.moving(config));
  // Then unseen (frames without them) for 1 s: still followed, where they walked to.
  for (int k = 11; k <= 20; ++k) tracker.update({}, {}, 0.1 * k);
  ASSERT_EQ(tracker.obstacles().size(), 1u);
  EXPECT_NEAR(tracker.obstacles().front().centerAt(2.0).y(), 0.0, 1e-9);
  // The predicted points cover where they will be over the horizon, not behind them.
  const std::vector<Eigen::Vector3d> ahead = tracker.predictedPoints(2.0);
  double min_y = 1e9;
  double max_y = -1e9;
  for (const Eigen::Vector3d& p : ahead) {
    min_y = std::min(min_y, p.y());
    max_y = std::max(max_y, p.y());
  }
  EXPECT_NEAR(min_y, -0.2, 1e-9);
  EXPECT_NEAR(max_y, 0.2 + config.horizon_s, 1e-9);
  // A vehicle beside their way, 0.8 m from it, is met within 1 s; a look 0 s ahead misses it.
  Eigen::Vector3d nearest;
  const Eigen::Vector3d vehicle(3.0 - 0.25 - 0.8, 1.0, 1.0);
  EXPECT_EQ(tracker.nearestMoving(vehicle, 2.0, 1.0, 0.0, &nearest), nullptr);
  ASSERT_NE(tracker.nearestMoving(vehicle, 2.0, 1.0, 1.0, &nearest), nullptr);
  EXPECT_NEAR((nearest - vehicle).norm(), 0.8, 1e-9);
  // Unseen for longer than keep_s: dropped.
  tracker.update({}, {}, 1.0 + config.keep_s + 0.1);
  EXPECT_TRUE(tracker.obstacles().empty());
}

TEST(MovingObstacles, LeavesOutWhatStandsWhatIsTooWideOrTooSmallAndWhatMostlyDidNotMove) {
  MovingObstacleConfig config;
  MovingObstacleTracker tracker(config);
  std::vector<Eigen::Vector3d> wall;
  for (int i = 0; i < 20; ++i) wall.emplace_back(5.0, -2.0 + 0.2 * i, 1.0);
  for (int k = 0; k <= 10; ++k) {
    const double t = 0.1 * k;
    std::vector<Eigen::Vector3d> frame = personPoints({2.0, 0.0});  // standing
    // A wall's edge seen moving along with the view: one long group.
    for (const Eigen::Vector3d& p : wall) frame.emplace_back(p.x(), p.y() + t, p.z());
    std::vector<bool> moved(frame.size(), true);
    // A tree's trunk, 20 points sliding with the view, only the 8 of its edge where the map knew
    // free: the rest touches them.
    for (int i = 0; i < 20; ++i) {
      frame.emplace_back(2.0 + 0.1 * (i % 5), 4.0 + t, 0.8 + 0.2 * (i / 5));
      moved.push_back(i % 5 < 2);
    }
    // A few points (a mixed cell's) sliding with the view: too few.
    for (int i = 0; i < 4; ++i) {
      frame.emplace_back(-2.0 + 0.1 * i, 2.0 + t, 1.0);
      moved.push_back(true);
    }
    tracker.update(frame, moved, t);
  }
  ASSERT_EQ(tracker.obstacles().size(), 1u);
  EXPECT_FALSE(tracker.obstacles().front().moving(config));
  EXPECT_TRUE(tracker.predictedPoints(1.0).empty());
  Eigen::Vector3d nearest;
  EXPECT_EQ(tracker.nearestMoving({2.0, 0.0, 1.0}, 1.0, 2.0, 1.0, &nearest), nullptr);
}

TEST(MovingObstacles, FollowsTwoPeopleApartWithoutSwappingThem) {
  MovingObstacleTracker tracker;
  for (int k = 0; k <= 10; ++k) {
    const double t = 0.1 * k;
    std::vector<Eigen::Vector3d> frame = personPoints({1.0, -2.0 + t});
    const std::vector<Eigen::Vector3d> other = personPoints({4.0, 2.0 - t});
    frame.insert(frame.end(), other.begin(), other.end());
    tracker.update(frame, std::vector<bool>(frame.size(), true), t);
  }
  ASSERT_EQ(tracker.obstacles().size(), 2u);
  for (const MovingObstacle& o : tracker.obstacles()) {
    const double expected = o.center_W.x() < 2.5 ? 1.0 : -1.0;
    EXPECT_NEAR(o.velocity_W.y(), expected, 1e-9);
    EXPECT_NEAR(o.velocity_W.x(), 0.0, 1e-9);
  }
}

}  // namespace
}  // namespace mlmap::nav
