#pragma once
/// @file
/// The requests a service thread has yet to handle: one FIFO per client, the clients served in
/// turn, bounded in total and per client, so that a client that floods a service is refused
/// beyond its share and an honest client waits for at most one request of each other client.

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
  /// At most `max_total` jobs in all, at most `max_per_client` of one client (both >= 1).
  FairRequestQueue(std::size_t max_total, std::size_t max_per_client)
      : max_total_(max_total), max_per_client_(max_per_client) {}

  /// Adds `job` at the end of `client`'s FIFO. False, and nothing added, when the queue holds
  /// max_total jobs or the client max_per_client.
  bool push(const Client& client, Job job) {
    if (size_ >= max_total_) return false;
    std::deque<Job>& fifo = fifos_[client];
    if (fifo.size() >= max_per_client_) return false;
    fifo.push_back(std::move(job));
    ++size_;
    return true;
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
