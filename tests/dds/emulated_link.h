// A radio link inside the process, for tests: a Fast DDS chaining transport over UDPv4 that
// delays, paces and drops what a participant sends and receives, as `tc netem` with a rate would
// on its interface (this VM's kernel has no netem, see tests/fleet/fleet_netns.sh).
#pragma once

#include "mlmap/dds/transport/participant.h"

#include <fastdds/rtps/transport/ChainingTransport.h>
#include <fastdds/rtps/transport/ChainingTransportDescriptor.h>

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <random>
#include <thread>

namespace mlmap::dds::test_support {

/// One direction of the link, as netem with a rate and a drop-tail queue shapes it.
struct LinkShape {
  double delay_s = 0.1;         ///< every datagram is delivered this long after it was sent
  double rate_bit_s = 10e6;     ///< datagrams leave one after another at this rate
  double loss_fraction = 0.05;  ///< this share of the datagrams is lost at random
  std::size_t queue_limit_bytes = 500000;  ///< a datagram that finds this much waiting is lost
  std::uint32_t seed = 1;                  ///< of the random losses
};

/// What one direction of the link did.
struct LinkDirectionStats {
  std::uint64_t delivered = 0;        ///< datagrams handed on
  std::uint64_t lost_at_random = 0;   ///< dropped by loss_fraction
  std::uint64_t lost_queue_full = 0;  ///< dropped because the queue held queue_limit_bytes
  std::uint64_t lost_link_down = 0;   ///< sent while the link was down (setDown)
  std::uint64_t bytes_delivered = 0;
  double min_delay_s = 0.0;  ///< shortest time from sending to delivery (0 before any)
  double max_delay_s = 0.0;  ///< longest, queueing behind the rate included
};

/// One direction: a FIFO of datagrams, each delivered by a worker thread no earlier than
/// delay_s after it was pushed and no earlier than the previous one's end at rate_bit_s.
/// Thread-safe.
class DelayLine {
 public:
  explicit DelayLine(const LinkShape& shape);
  ~DelayLine();
  DelayLine(const DelayLine&) = delete;
  DelayLine& operator=(const DelayLine&) = delete;

  /// Takes a datagram of `bytes` whose delivery is `deliver`; false once close() ran (then the
  /// caller delivers it itself). A datagram lost on the way is taken and never delivered.
  bool push(std::size_t bytes, std::function<void()> deliver);
  /// Cuts the line (every datagram pushed is lost) or restores it; what waits still arrives.
  void setDown(bool down);
  /// Drops what waits and stops the worker; a delivery under way finishes first.
  void close();
  LinkDirectionStats stats() const;

 private:
  using Clock = std::chrono::steady_clock;
  struct Datagram {
    std::size_t bytes;
    Clock::time_point sent;
    Clock::time_point due;
    std::function<void()> deliver;
  };
  void run();

  const LinkShape shape_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Datagram> queue_;
  std::size_t queued_bytes_ = 0;
  Clock::time_point line_free_;  ///< when the last datagram taken has left at the rate
  std::mt19937 random_;
  LinkDirectionStats stats_;
  bool down_ = false;
  bool closed_ = false;
  std::thread worker_;
};

/// Both directions of a participant's link. Close it before the participant is deleted: queued
/// datagrams refer to the participant's send and receive resources.
class EmulatedLink {
 public:
  /// `out`: what the participant sends; `in`: what it receives.
  EmulatedLink(const LinkShape& out, const LinkShape& in) : out_(out), in_(in) {}
  DelayLine& out() { return out_; }
  DelayLine& in() { return in_; }
  /// Cuts both directions (as a radio out of range) or restores them.
  void setDown(bool down) {
    out_.setDown(down);
    in_.setDown(down);
  }
  void close() {
    out_.close();
    in_.close();
  }

 private:
  DelayLine out_;
  DelayLine in_;
};

/// Chaining transport descriptor: `low_level` (UDPv4) through `link`.
struct EmulatedLinkTransportDescriptor
    : public eprosima::fastdds::rtps::ChainingTransportDescriptor {
  EmulatedLinkTransportDescriptor(
      std::shared_ptr<eprosima::fastdds::rtps::TransportDescriptorInterface> low_level,
      std::shared_ptr<EmulatedLink> link_in)
      : ChainingTransportDescriptor(std::move(low_level)), link(std::move(link_in)) {}
  eprosima::fastdds::rtps::TransportInterface* create_transport() const override;

  std::shared_ptr<EmulatedLink> link;
};

/// A participant as createParticipant(localhostConfig(domain_id)) makes it, whose UDPv4
/// transports go through `link`. Close the link before this participant is deleted (declare an
/// EmulatedLinkCloser after it).
ParticipantPtr participantOverLink(int domain_id, const std::shared_ptr<EmulatedLink>& link);

/// Closes a link when it goes out of scope: declared after the participant, it runs first.
class EmulatedLinkCloser {
 public:
  explicit EmulatedLinkCloser(std::shared_ptr<EmulatedLink> link) : link_(std::move(link)) {}
  ~EmulatedLinkCloser() { link_->close(); }
  EmulatedLinkCloser(const EmulatedLinkCloser&) = delete;
  EmulatedLinkCloser& operator=(const EmulatedLinkCloser&) = delete;

 private:
  std::shared_ptr<EmulatedLink> link_;
};

}  // namespace mlmap::dds::test_support
