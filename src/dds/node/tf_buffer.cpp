#include "mlmap/dds/node/tf_buffer.h"

#include <algorithm>
#include <utility>
#include <vector>

namespace mlmap::dds {
namespace {

/// The transform a fraction `s` of the way from `a` to `b` (linear translation, slerp).
Transform interpolate(const Transform& a, const Transform& b, double s) {
  const Eigen::Quaterniond qa(a.linear());
  const Eigen::Quaterniond qb(b.linear());
  Transform T = Transform::Identity();
  T.linear() = qa.slerp(s, qb).normalized().toRotationMatrix();
  T.translation() = (1.0 - s) * a.translation() + s * b.translation();
  return T;
}

}  // namespace

TfBuffer::Edge& TfBuffer::edgeOf(const std::string& parent, const std::string& child) {
  Edge& edge = edges_[child];
  if (edge.parent != parent) {  // a new parent: the old edge's history means nothing now
    edge.parent = parent;
    edge.samples.clear();
  }
  parents_.insert(parent);
  return edge;
}

void TfBuffer::setStatic(const std::string& parent, const std::string& child,
                         const Transform& T_parent_child) {
  Edge& edge = edgeOf(parent, child);
  edge.is_static = true;
  edge.T_static = T_parent_child;
  edge.samples.clear();
}

void TfBuffer::setDynamic(const std::string& parent, const std::string& child, double stamp_s,
                          const Transform& T_parent_child) {
  Edge& edge = edgeOf(parent, child);
  edge.is_static = false;
  auto& samples = edge.samples;
  const auto later = std::upper_bound(samples.begin(), samples.end(), stamp_s,
                                      [](double t, const Sample& s) { return t < s.stamp_s; });
  if (later != samples.begin() && std::prev(later)->stamp_s == stamp_s) {
    std::prev(later)->T_parent_child = T_parent_child;
  } else {
    samples.insert(later, Sample{stamp_s, T_parent_child});
  }
  const double oldest_kept_s = samples.back().stamp_s - horizon_s_;
  while (samples.size() > 1 &&
         (samples.front().stamp_s < oldest_kept_s || samples.size() > kMaxSamplesPerEdge)) {
    samples.pop_front();
  }
}

TfBuffer::Lookup TfBuffer::edgeAt(const Edge& edge, double stamp_s,
                                  Transform* T_parent_child) const {
  if (edge.is_static) {
    *T_parent_child = edge.T_static;
    return Lookup::kFound;
  }
  const auto& samples = edge.samples;
  if (samples.empty()) return Lookup::kNotYet;
  if (stamp_s <= samples.front().stamp_s) {
    if (samples.front().stamp_s - stamp_s > tolerance_s_) return Lookup::kTooOld;
    *T_parent_child = samples.front().T_parent_child;
    return Lookup::kFound;
  }
  if (stamp_s >= samples.back().stamp_s) {
    if (stamp_s - samples.back().stamp_s > tolerance_s_) return Lookup::kNotYet;
    *T_parent_child = samples.back().T_parent_child;
    return Lookup::kFound;
  }
  const auto after = std::upper_bound(samples.begin(), samples.end(), stamp_s,
                                      [](double t, const Sample& s) { return t < s.stamp_s; });
  const Sample& a = *std::prev(after);
  const Sample& b = *after;
  *T_parent_child = interpolate(a.T_parent_child, b.T_parent_child,
                                (stamp_s - a.stamp_s) / (b.stamp_s - a.stamp_s));
  return Lookup::kFound;
}

TfBuffer::Lookup TfBuffer::lookup(const std::string& target, const std::string& source,
                                  double stamp_s, Transform* T_target_source) const {
  if (!knows(target) || !knows(source)) return Lookup::kUnknownFrame;
  // The source's ancestors, each with T_ancestor_source.
  std::vector<std::pair<std::string, Transform>> up_from_source = {{source, Transform::Identity()}};
  Lookup worst = Lookup::kFound;  // why a chain that exists cannot be used at this stamp
  for (std::size_t depth = 0; depth < kMaxDepth; ++depth) {
    const auto found = edges_.find(up_from_source.back().first);
    if (found == edges_.end()) break;
    Transform T_parent_child;
    const Lookup at = edgeAt(found->second, stamp_s, &T_parent_child);
    if (at != Lookup::kFound) {
      worst = at;
      break;
    }
    up_from_source.emplace_back(found->second.parent,
                                T_parent_child * up_from_source.back().second);
  }
  // Up from the target to the first frame on that list.
  std::string frame = target;
  Transform T_frame_target = Transform::Identity();
  for (std::size_t depth = 0; depth <= kMaxDepth; ++depth) {
    for (const auto& [ancestor, T_ancestor_source] : up_from_source) {
      if (ancestor == frame) {
        *T_target_source = T_frame_target.inverse() * T_ancestor_source;
        return Lookup::kFound;
      }
    }
    const auto found = edges_.find(frame);
    if (found == edges_.end()) break;
    Transform T_parent_child;
    const Lookup at = edgeAt(found->second, stamp_s, &T_parent_child);
    if (at != Lookup::kFound) {
      worst = at;
      break;
    }
    frame = found->second.parent;
    T_frame_target = T_parent_child * T_frame_target;
  }
  return worst == Lookup::kFound ? Lookup::kNotConnected : worst;
}

bool TfBuffer::knows(const std::string& frame) const {
  return edges_.count(frame) != 0 || parents_.count(frame) != 0;
}

std::string TfBuffer::parentOf(const std::string& child) const {
  const auto found = edges_.find(child);
  return found == edges_.end() ? std::string() : found->second.parent;
}

const char* toString(TfBuffer::Lookup lookup) {
  switch (lookup) {
    case TfBuffer::Lookup::kFound:
      return "found";
    case TfBuffer::Lookup::kUnknownFrame:
      return "frame unknown";
    case TfBuffer::Lookup::kNotConnected:
      return "frames not connected";
    case TfBuffer::Lookup::kNotYet:
      return "no transform yet at that stamp";
    case TfBuffer::Lookup::kTooOld:
      return "stamp older than the transforms kept";
  }
  return "?";
}

}  // namespace mlmap::dds
