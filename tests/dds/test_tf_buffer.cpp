// TfBuffer against a slow reference: a breadth-first search over every edge, both ways, that
// composes the transforms along the one path between two frames; and its dynamic edges against
// interpolation written out by hand.
#include "mlmap/dds/node/tf_buffer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <deque>
#include <map>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace mlmap::dds {
namespace {

/// The reference: edges by child (the last one set wins, as in tf2), searched breadth-first.
class ReferenceTree {
 public:
  void set(const std::string& parent, const std::string& child, const Transform& T_parent_child) {
    edges_[child] = {parent, T_parent_child};
    named_.insert(parent);
    named_.insert(child);
  }
  /// T_target_source along the path between them, or nothing when there is none.
  std::optional<Transform> lookup(const std::string& target, const std::string& source) const {
    // Neighbours with T_neighbour_frame, both ways along each edge.
    std::multimap<std::string, std::pair<std::string, Transform>> next;
    for (const auto& [child, edge] : edges_) {
      next.insert({child, {edge.first, edge.second}});
      next.insert({edge.first, {child, edge.second.inverse()}});
    }
    std::map<std::string, Transform> T_frame_source = {{source, Transform::Identity()}};
    std::deque<std::string> open = {source};
    while (!open.empty()) {
      const std::string frame = open.front();
      open.pop_front();
      if (frame == target) return T_frame_source.at(frame);
      const auto [begin, end] = next.equal_range(frame);
      for (auto it = begin; it != end; ++it) {
        const auto& [neighbour, T_neighbour_frame] = it->second;
        if (T_frame_source.count(neighbour) != 0) continue;
        T_frame_source[neighbour] = T_neighbour_frame * T_frame_source.at(frame);
        open.push_back(neighbour);
      }
    }
    return std::nullopt;
  }
  /// A frame some transform named, even if a later edge re-parented it away (tf2 forgets no
  /// frame).
  [[nodiscard]] bool knows(const std::string& frame) const { return named_.count(frame) != 0; }

 private:
  std::map<std::string, std::pair<std::string, Transform>> edges_;
  std::set<std::string> named_;
};

Transform randomTransform(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Quaterniond q(u(rng), u(rng), u(rng), u(rng));
  if (q.norm() < 1e-3) q = Eigen::Quaterniond::Identity();
  Transform T = Transform::Identity();
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(u(rng), u(rng), u(rng)) * 3.0;
  return T;
}

/// The largest difference between two transforms' matrices.
double difference(const Transform& a, const Transform& b) {
  return (a.matrix() - b.matrix()).cwiseAbs().maxCoeff();
}

std::string frameName(int i) { return "frame_" + std::to_string(i); }

// Forests of static edges (several roots, so some pairs are not connected), some children
// re-parented on the way, every pair of frames looked up both ways.
TEST(TfBuffer, StaticChainsEqualTheBreadthFirstReferenceOnRandomForests) {
  std::mt19937 rng(30);
  for (int forest = 0; forest < 40; ++forest) {
    TfBuffer buffer(10.0, 0.05);
    ReferenceTree reference;
    const int frames = 2 + forest % 14;
    std::uniform_real_distribution<double> u(0.0, 1.0);
    // Parents always have lower numbers, so no set of edges ever closes a cycle.
    for (int pass = 0; pass < 2; ++pass) {
      for (int child = 1; child < frames; ++child) {
        if (pass == 1 && u(rng) < 0.7) continue;  // the second pass re-parents a few
        if (u(rng) < 0.15) continue;              // a root, or an edge left as it was
        const int parent = std::uniform_int_distribution<int>(0, child - 1)(rng);
        const Transform T = randomTransform(rng);
        buffer.setStatic(frameName(parent), frameName(child), T);
        reference.set(frameName(parent), frameName(child), T);
      }
    }
    for (int a = 0; a <= frames; ++a) {  // `frames` itself is a frame no edge names
      for (int b = 0; b <= frames; ++b) {
        SCOPED_TRACE("forest " + std::to_string(forest) + ": " + frameName(a) + " <- " +
                     frameName(b));
        Transform T_a_b = Transform::Identity();
        const TfBuffer::Lookup found = buffer.lookup(frameName(a), frameName(b), 0.0, &T_a_b);
        if (!reference.knows(frameName(a)) || !reference.knows(frameName(b))) {
          EXPECT_EQ(found, TfBuffer::Lookup::kUnknownFrame);
          continue;
        }
        const std::optional<Transform> expected = reference.lookup(frameName(a), frameName(b));
        if (!expected) {
          EXPECT_EQ(found, TfBuffer::Lookup::kNotConnected);
          continue;
        }
        ASSERT_EQ(found, TfBuffer::Lookup::kFound);
        EXPECT_LT(difference(T_a_b, *expected), 1e-9);
      }
    }
  }
}

TEST(TfBuffer, AFrameLookedUpInItselfIsTheIdentityAndAParentCycleIsNotConnected) {
  TfBuffer buffer(10.0, 0.05);
  std::mt19937 rng(1);
  buffer.setStatic("a", "b", randomTransform(rng));
  Transform T = randomTransform(rng);
  ASSERT_EQ(buffer.lookup("b", "b", 0.0, &T), TfBuffer::Lookup::kFound);
  EXPECT_LT(difference(T, Transform::Identity()), 1e-12);
  // b -> c -> b: a cycle never ends a walk; frames outside it are not joined to it.
  buffer.setStatic("b", "c", randomTransform(rng));
  buffer.setStatic("c", "b", randomTransform(rng));
  buffer.setStatic("x", "y", randomTransform(rng));
  EXPECT_EQ(buffer.lookup("y", "b", 0.0, &T), TfBuffer::Lookup::kNotConnected);
  EXPECT_EQ(buffer.parentOf("b"), "c") << "the last edge set for a child wins";
}

// odom -> base_link moving, base_link -> camera static: a lookup between samples interpolates
// (linear translation, slerp) and composes with the static edge; outside the samples it is
// refused beyond the tolerance, and old samples leave after the horizon.
TEST(TfBuffer, DynamicEdgesInterpolateBetweenSamplesAndRefuseStampsOutsideThem) {
  constexpr double kTolerance_s = 0.05;
  constexpr double kHorizon_s = 2.0;
  TfBuffer buffer(kHorizon_s, kTolerance_s);
  auto T_O_B = [](double t_s) {  // yaw t rad, x = t m
    Transform T = Transform::Identity();
    T.linear() = Eigen::AngleAxisd(t_s, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(t_s, 2.0 * t_s, 0.5);
    return T;
  };
  Transform T_B_C = Transform::Identity();
  T_B_C.translation() = Eigen::Vector3d(0.1, 0.0, 0.2);
  T_B_C.linear() = Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  buffer.setStatic("base_link", "camera", T_B_C);
  Transform T;
  EXPECT_EQ(buffer.lookup("odom", "camera", 1.0, &T), TfBuffer::Lookup::kUnknownFrame);
  for (const double t_s : {1.0, 1.2, 1.1}) buffer.setDynamic("odom", "base_link", t_s, T_O_B(t_s));

  // Yaw about one axis interpolates to the yaw in between; the translation is linear anyway.
  for (const double t_s : {1.0, 1.03, 1.1, 1.15, 1.2}) {
    ASSERT_EQ(buffer.lookup("odom", "camera", t_s, &T), TfBuffer::Lookup::kFound) << t_s;
    EXPECT_LT(difference(T, T_O_B(t_s) * T_B_C), 1e-9) << t_s;
    ASSERT_EQ(buffer.lookup("camera", "odom", t_s, &T), TfBuffer::Lookup::kFound) << t_s;
    EXPECT_LT(difference(T, (T_O_B(t_s) * T_B_C).inverse()), 1e-9) << t_s;
  }
  // Within the tolerance of the ends: the end sample itself.
  ASSERT_EQ(buffer.lookup("odom", "base_link", 1.2 + 0.5 * kTolerance_s, &T),
            TfBuffer::Lookup::kFound);
  EXPECT_LT(difference(T, T_O_B(1.2)), 1e-12);
  ASSERT_EQ(buffer.lookup("odom", "base_link", 1.0 - 0.5 * kTolerance_s, &T),
            TfBuffer::Lookup::kFound);
  EXPECT_LT(difference(T, T_O_B(1.0)), 1e-12);
  EXPECT_EQ(buffer.lookup("odom", "camera", 1.3, &T), TfBuffer::Lookup::kNotYet);
  EXPECT_EQ(buffer.lookup("odom", "camera", 0.9, &T), TfBuffer::Lookup::kTooOld);
  // The static part alone does not need the dynamic edge at any stamp.
  EXPECT_EQ(buffer.lookup("base_link", "camera", 99.0, &T), TfBuffer::Lookup::kFound);

  // A sample at an existing stamp replaces it; the horizon drops what is older than it.
  buffer.setDynamic("odom", "base_link", 1.1, T_O_B(5.0));
  ASSERT_EQ(buffer.lookup("odom", "base_link", 1.1, &T), TfBuffer::Lookup::kFound);
  EXPECT_LT(difference(T, T_O_B(5.0)), 1e-12);
  buffer.setDynamic("odom", "base_link", 1.0 + kHorizon_s + 0.15, T_O_B(3.15));
  EXPECT_EQ(buffer.lookup("odom", "base_link", 1.0, &T), TfBuffer::Lookup::kTooOld);
  EXPECT_EQ(buffer.lookup("odom", "base_link", 1.2, &T), TfBuffer::Lookup::kFound);
}

}  // namespace
}  // namespace mlmap::dds
