#pragma once
/// @file
/// A small tf2-style buffer: a tree of frames in which each child has one parent, static edges
/// (from /tf_static) and dynamic edges with a short history (from /tf), and lookups that compose
/// the chain between two frames through their common ancestor. No middleware: the node's TF
/// listener fills it from DDS.

#include "mlmap/core/types.h"

#include <cstddef>
#include <deque>
#include <string>
#include <unordered_map>
#include <unordered_set>

namespace mlmap::dds {

/// Frames and the transforms between them. Setting an edge for a child replaces its earlier
/// parent (tf2 keeps one parent per child; the last writer wins). Not thread-safe.
class TfBuffer {
 public:
  /// How a lookup went.
  enum class Lookup {
    kFound,         ///< the transform is set
    kUnknownFrame,  ///< a frame appears in no transform received
    kNotConnected,  ///< both frames are known, but no chain joins them (two trees, or a cycle)
    kNotYet,        ///< a dynamic edge on the chain has no sample yet as new as the stamp
    kTooOld,        ///< a dynamic edge on the chain has no sample as old as the stamp any more
  };

  /// A longest chain walked (deeper is a cycle, or a tree no robot has).
  static constexpr std::size_t kMaxDepth = 64;
  /// The most samples kept per dynamic edge (a flood of one edge cannot grow the buffer).
  static constexpr std::size_t kMaxSamplesPerEdge = 4096;

  /// `horizon_s`: how far behind an edge's newest sample its history reaches [s].
  /// `tolerance_s`: how far beyond its first or last sample a stamp may be and still use that
  /// sample [s] (a stamp between two samples is interpolated).
  TfBuffer(double horizon_s, double tolerance_s)
      : horizon_s_(horizon_s), tolerance_s_(tolerance_s) {}

  /// Sets the static edge parent -> child: T_parent_child, valid at every time.
  void setStatic(const std::string& parent, const std::string& child,
                 const Transform& T_parent_child);
  /// Adds a sample of the dynamic edge parent -> child at `stamp_s` (in any order; a sample at
  /// the stamp of an earlier one replaces it). Samples older than the edge's newest minus the
  /// horizon are dropped.
  void setDynamic(const std::string& parent, const std::string& child, double stamp_s,
                  const Transform& T_parent_child);

  /// T_target_source (maps points in `source` into `target`) at `stamp_s`: static edges as they
  /// are, dynamic ones interpolated between their samples around the stamp (linear translation,
  /// slerp). On anything but kFound `T_target_source` is left untouched.
  Lookup lookup(const std::string& target, const std::string& source, double stamp_s,
                Transform* T_target_source) const;

  /// A frame appears in some transform (as a parent or a child).
  [[nodiscard]] bool knows(const std::string& frame) const;
  /// The parent of `child` ("" when it has none).
  [[nodiscard]] std::string parentOf(const std::string& child) const;

 private:
  struct Sample {
    double stamp_s;
    Transform T_parent_child;
  };
  struct Edge {
    std::string parent;
    bool is_static = true;
    Transform T_static = Transform::Identity();
    std::deque<Sample> samples;  ///< dynamic edges, by stamp
  };

  /// T_parent_child of `edge` at `stamp_s`.
  Lookup edgeAt(const Edge& edge, double stamp_s, Transform* T_parent_child) const;
  Edge& edgeOf(const std::string& parent, const std::string& child);

  double horizon_s_;
  double tolerance_s_;
  std::unordered_map<std::string, Edge> edges_;  ///< by child frame
  std::unordered_set<std::string> parents_;      ///< every frame that was a parent
};

/// Its name, e.g. "frame unknown".
const char* toString(TfBuffer::Lookup lookup);

}  // namespace mlmap::dds
