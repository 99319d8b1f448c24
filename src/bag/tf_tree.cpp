#include "mlmap/bag/tf_tree.h"

#include "mlmap/core/pose_buffer.h"

#include <algorithm>
#include <deque>
#include <iterator>
#include <stdexcept>
#include <utility>

namespace mlmap::bag {
namespace {

Transform inverse(const Transform& T) {
  Transform inv = Transform::Identity();
  inv.linear() = T.linear().transpose();
  inv.translation() = -(inv.linear() * T.translation());
  return inv;
}

}  // namespace

TfTree::TfTree(std::string world_frame, std::string body_frame)
    : world_frame_(std::move(world_frame)), body_frame_(std::move(body_frame)) {}

void TfTree::addStatic(const std::string& parent, const std::string& child,
                       const Transform& T_parent_child) {
  const auto known = static_edges_.find(child);
  const bool new_parent = known == static_edges_.end() || known->second.parent != parent;
  if (new_parent && known != static_edges_.end())
    static_children_[known->second.parent].erase(child);
  static_edges_[child] = {parent, child, T_parent_child};
  static_children_[parent].insert(child);
  if (new_parent) updateAncestors();
}

void TfTree::addDynamic(const std::string& parent, const std::string& child, double stamp_s,
                        const Transform& T_parent_child) {
  const StampedTransform sample{stamp_s, T_parent_child};
  const auto known = parent_of_.find(child);
  if (known == parent_of_.end() || known->second != parent) {
    parent_of_[child] = parent;
    updateAncestors();
  }
  latest_[child] = sample;
  if (ancestors_.count(child) != 0) series_[child].push_back(sample);
}

const std::string* TfTree::parentOf(const std::string& frame) const {
  if (const auto up = parent_of_.find(frame); up != parent_of_.end()) return &up->second;
  if (const auto up = static_edges_.find(frame); up != static_edges_.end()) {
    return &up->second.parent;
  }
  return nullptr;
}

void TfTree::updateAncestors() {
  // Up through /tf and /tf_static edges alike (a static edge may sit between two dynamic ones,
  // e.g. base_link -> base_footprint): a cycle ends the walk (poses() refuses it), and so does
  // kMaxTfChainEdges.
  ancestors_.clear();
  std::string frame = body_frame_;
  for (const std::string* up = parentOf(frame);
       up != nullptr && ancestors_.size() <= kMaxTfChainEdges && ancestors_.insert(frame).second;
       up = parentOf(frame)) {
    frame = *up;
  }
  for (const std::string& a : ancestors_) {
    const auto latest = latest_.find(a);
    if (series_[a].empty() && latest != latest_.end()) series_[a].push_back(latest->second);
  }
}

std::vector<StampedTransform> TfTree::poses() {
  // The chain world -> ... -> body, body end first; consecutive static edges are multiplied
  // into one, so that composing costs (poses x dynamic edges), whatever the number of static
  // ones.
  struct Edge {
    const std::vector<StampedTransform>* series = nullptr;  ///< dynamic; null: static
    Transform T_parent_child = Transform::Identity();
  };
  std::vector<Edge> chain;
  std::string frame = body_frame_;
  std::string walked = frame;
  std::set<std::string> visited = {frame};
  for (std::size_t edges = 0; frame != world_frame_; ++edges) {
    Edge edge;
    std::string parent;
    if (const auto up = parent_of_.find(frame); up != parent_of_.end()) {
      parent = up->second;
      std::vector<StampedTransform>& series = series_[frame];
      if (series.empty()) series.push_back(latest_.at(frame));  // every /tf child has a latest
      std::stable_sort(series.begin(), series.end(),
                       [](const StampedTransform& a, const StampedTransform& b) {
                         return a.stamp_s < b.stamp_s;
                       });
      edge.series = &series;
    } else if (const auto fixed = static_edges_.find(frame); fixed != static_edges_.end()) {
      parent = fixed->second.parent;
      edge.T_parent_child = fixed->second.T_parent_child;
    }
    if (parent.empty()) {
      throw std::runtime_error("no /tf path from '" + world_frame_ + "' to the body frame '" +
                               body_frame_ + "' (found " + walked +
                               " with no parent); set world_frame or body_frame");
    }
    walked += " <- " + parent;
    if (!visited.insert(parent).second) {
      throw std::runtime_error("the transforms from the body frame '" + body_frame_ +
                               "' loop back to '" + parent + "' (" + walked +
                               ") before reaching '" + world_frame_ +
                               "': a /tf or /tf_static cycle; no pose is taken from it");
    }
    if (edges + 1 > kMaxTfChainEdges) {
      throw std::runtime_error("more than " + std::to_string(kMaxTfChainEdges) +
                               " transforms between '" + world_frame_ + "' and the body frame '" +
                               body_frame_ + "' (" + walked + ")");
    }
    if (edge.series == nullptr && !chain.empty() && chain.back().series == nullptr) {
      chain.back().T_parent_child = edge.T_parent_child * chain.back().T_parent_child;
    } else {
      chain.push_back(edge);
    }
    frame = parent;
  }
  // The poses at the stamps of the lowest dynamic edge, the others interpolated there (their
  // nearest transform held outside their range, as a slow map -> odom is).
  const auto lowest =
      std::find_if(chain.begin(), chain.end(), [](const Edge& e) { return e.series != nullptr; });
  if (lowest == chain.end() || lowest->series->empty()) return {};
  std::vector<StampedTransform> poses;
  poses.reserve(lowest->series->size());
  for (const StampedTransform& sample : *lowest->series) {
    StampedTransform pose;
    pose.stamp_s = sample.stamp_s;
    for (auto edge = chain.rbegin(); edge != chain.rend(); ++edge) {
      pose.T = pose.T *
               (edge->series == nullptr ? edge->T_parent_child : at(*edge->series, sample.stamp_s));
    }
    poses.push_back(pose);
  }
  return poses;
}

std::optional<Transform> TfTree::staticFromBody(const std::string& sensor_frame) const {
  if (sensor_frame == body_frame_) return Transform::Identity();
  // Breadth-first through /tf_static, both ways along each edge, from the body frame; each
  // frame is entered once, and no deeper than kMaxTfChainEdges: the cost is the edges of the
  // frames reached, whatever the number of others.
  struct Visit {
    std::string frame;
    Transform T_B_F;
    std::size_t depth = 0;
  };
  std::deque<Visit> queue = {{body_frame_, Transform::Identity(), 0}};
  std::set<std::string> seen = {body_frame_};
  while (!queue.empty()) {
    const Visit here = queue.front();
    queue.pop_front();
    if (here.depth >= kMaxTfChainEdges) continue;
    std::vector<std::pair<std::string, Transform>> neighbours;  // frame, T_B_N
    if (const auto down = static_children_.find(here.frame); down != static_children_.end()) {
      for (const std::string& child : down->second) {
        neighbours.emplace_back(child, here.T_B_F * static_edges_.at(child).T_parent_child);
      }
    }
    if (const auto up = static_edges_.find(here.frame); up != static_edges_.end()) {
      neighbours.emplace_back(up->second.parent, here.T_B_F * inverse(up->second.T_parent_child));
    }
    for (auto& [next, T_B_N] : neighbours) {
      if (!seen.insert(next).second) continue;
      if (next == sensor_frame) return T_B_N;
      queue.push_back({next, T_B_N, here.depth + 1});
    }
  }
  return std::nullopt;
}

Transform TfTree::at(const std::vector<StampedTransform>& series, double stamp_s) {
  const auto after =
      std::lower_bound(series.begin(), series.end(), stamp_s,
                       [](const StampedTransform& p, double t) { return p.stamp_s < t; });
  if (after == series.begin()) return series.front().T;
  if (after == series.end()) return series.back().T;
  const StampedTransform& before = *std::prev(after);
  return interpolatePose(before.T, before.stamp_s, after->T, after->stamp_s, stamp_s);
}

}  // namespace mlmap::bag
