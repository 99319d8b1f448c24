#pragma once
/// @file
/// The requests a service thread has yet to handle: one FIFO per client, the clients served in
/// turn, bounded in total and per client, so that a client that floods a service is refused
/// beyond its share, an honest client waits for at most one request of each other client, and
/// when floods fill the whole queue a client with fewer requests waiting still gets in.

#include <algorithm>
#include <cstddef>
#include <deque>
#include <iterator>
#include <map>
#include <optional>
#include <utility>

namespace mlmap::dds {

/// Per-client FIFOs served round-robin (ordered by `Client`'s operator<). Not thread-safe: the
/// owner's mutex guards it.
template <class Client, class Job>
class FairRequestQueue {
 public:
  /// What push() did.
  enum class Pushed {
    kQueued,         ///< added
    kQueuedInPlace,  ///< added in place of the busiest client's newest job, which is dropped
    kRefused,        ///< not added: the client holds its share, or no client holds more
  };

  /// At most `max_total` jobs in all, at most `max_per_client` of one client (both >= 1).
  FairRequestQueue(std::size_t max_total, std::size_t max_per_client)
      : max_total_(max_total), max_per_client_(max_per_client) {}

  /// Adds `job` at the end of `client`'s FIFO, unless the client holds max_per_client jobs.
  /// When the queue holds max_total, the busiest client's newest job makes room, if that client
  /// holds at least two more than `client` (so that places move towards an even share and never
  /// back and forth); else nothing is added.
  Pushed push(const Client& client, Job job) {
    const std::size_t mine = size(client);
    if (mine >= max_per_client_) return Pushed::kRefused;
    Pushed pushed = Pushed::kQueued;
    if (size_ >= max_total_) {
      const auto busiest = std::max_element(
          fifos_.begin(), fifos_.end(),
          [](const auto& a, const auto& b) { return a.second.size() < b.second.size(); });
      if (busiest == fifos_.end() || busiest->second.size() < mine + 2) return Pushed::kRefused;
      busiest->second.pop_back();  // at least 2 held: never empty after
      --size_;
      pushed = Pushed::kQueuedInPlace;
    }
    fifos_[client].push_back(std::move(job));
    ++size_;
    return pushed;
  }

  /// The oldest job of the next client after the one served last (in key order, wrapping),
  /// removed from the queue; nothing when the queue is empty.
  std::optional<Job> pop() {
    if (size_ == 0) return std::nullopt;
    auto next = served_last_ ? fifos_.upper_bound(*served_last_) : fifos_.begin();
    if (next == fifos_.end()) next = fifos_.begin();
    served_last_ = next->first;
    std::optional<Job> job(std::move(next->second.front()));
    next->second.pop_front();
    if (next->second.empty()) fifos_.erase(next);
    --size_;
    return job;
  }

  /// Jobs queued, in all.
  [[nodiscard]] std::size_t size() const { return size_; }
  /// Jobs queued for `client`.
  [[nodiscard]] std::size_t size(const Client& client) const {
    const auto it = fifos_.find(client);
    return it == fifos_.end() ? 0 : it->second.size();
  }
  [[nodiscard]] bool empty() const { return size_ == 0; }

  /// Drops every job.
  void clear() {
    fifos_.clear();
    size_ = 0;
  }

 private:
  std::size_t max_total_;
  std::size_t max_per_client_;
  std::map<Client, std::deque<Job>> fifos_;  // only non-empty FIFOs
  std::optional<Client> served_last_;
  std::size_t size_ = 0;
};

}  // namespace mlmap::dds
