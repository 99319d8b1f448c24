#pragma once
/// @file
/// The transforms of a bag's /tf and /tf_static, and the chains a replay takes from them: the
/// body poses T_W_B through world_frame -> ... -> body_frame (map -> odom -> base_link), and a
/// sensor's extrinsic T_B_S through /tf_static. Nothing in a bag is trusted: every walk detects
/// cycles and stops at kMaxTfChainEdges, a pose chain must reach the world frame, and composing
/// costs (poses x dynamic edges of the chain), however many static edges it has.

#include "mlmap/core/types.h"

#include <cstddef>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace mlmap::bag {

/// The most transforms between the world frame and the body frame, or the body frame and a
/// sensor frame (a robot's tree is a few deep).
inline constexpr std::size_t kMaxTfChainEdges = 64;

/// A transform at a time.
struct StampedTransform {
  double stamp_s = 0.0;
  Transform T = Transform::Identity();
};

/// /tf and /tf_static edges between a world frame and a body frame.
class TfTree {
 public:
  /// A tree whose poses are T_W_B, W = `world_frame`, B = `body_frame`.
  TfTree(std::string world_frame, std::string body_frame);

  /// A /tf_static edge parent -> child; a child's latest one replaces the earlier (as tf2 keeps
  /// one parent per child), so a bag that republishes its static transforms adds nothing.
  void addStatic(const std::string& parent, const std::string& child,
                 const Transform& T_parent_child);

  /// A /tf edge parent -> child at `stamp_s`. A child takes its latest parent. Only the series of
  /// the body frame's ancestors (through /tf and /tf_static edges) are kept whole; of other
  /// frames the latest transform, which seeds the series of a frame found to be an ancestor
  /// later.
  void addDynamic(const std::string& parent, const std::string& child, double stamp_s,
                  const Transform& T_parent_child);

  /// T_W_B at the stamps of the lowest /tf edge of the chain world -> ... -> body, the other
  /// dynamic edges interpolated there (their nearest transform held outside their range), static
  /// edges composed once. Empty when the chain has no /tf edge with a transform.
  /// @throws std::runtime_error saying why when the body has no path to the world frame, the
  ///         path loops (a /tf or /tf_static cycle), or it is longer than kMaxTfChainEdges.
  [[nodiscard]] std::vector<StampedTransform> poses();

  /// T_B_S of `sensor_frame`, through /tf_static edges taken either way, breadth first from the
  /// body frame (identity for the body frame itself); nothing when no static path joins them
  /// within kMaxTfChainEdges edges.
  [[nodiscard]] std::optional<Transform> staticFromBody(const std::string& sensor_frame) const;

  /// A transform of `series` (sorted by stamp) at `stamp_s`: interpolated, or the nearest
  /// outside its range.
  static Transform at(const std::vector<StampedTransform>& series, double stamp_s);

 private:
  struct StaticEdge {
    std::string parent;
    std::string child;
    Transform T_parent_child = Transform::Identity();
  };
  /// The /tf parent of `frame`, else its /tf_static parent; null when it has none.
  [[nodiscard]] const std::string* parentOf(const std::string& frame) const;
  /// Recomputes ancestors_ (bounded walk up from the body) and seeds their series.
  void updateAncestors();

  std::string world_frame_;
  std::string body_frame_;
  std::map<std::string, StaticEdge> static_edges_;  ///< /tf_static: child -> its edge
  std::map<std::string, std::set<std::string>>
      static_children_;                             ///< /tf_static: parent -> children
  std::map<std::string, std::string> parent_of_;    ///< /tf: child -> parent, every frame seen
  std::set<std::string> ancestors_;                 ///< the body and the /tf frames above it
  std::map<std::string, StampedTransform> latest_;  ///< child -> its latest /tf transform
  std::map<std::string, std::vector<StampedTransform>> series_;  ///< child -> its transforms
};

}  // namespace mlmap::bag
