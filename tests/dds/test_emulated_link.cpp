// The in-process radio link of the fleet's fault test (emulated_link.h) against what it must do:
// deliver in order, never before the delay and the rate allow, lose the configured share at
// random, drop what finds the queue full, and deliver nothing once closed.
#include "emulated_link.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <thread>
#include <vector>

namespace mlmap::dds::test_support {
namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

TEST(DelayLine, DeliversInOrderNoEarlierThanTheDelayAndTheRateAllow) {
  LinkShape shape;
  shape.delay_s = 0.05;
  shape.rate_bit_s = 10e6;  // a 12,500-byte datagram takes 10 ms on the line
  shape.loss_fraction = 0.0;
  shape.queue_limit_bytes = 1 << 20;
  DelayLine line(shape);
  std::mutex mutex;
  std::vector<std::pair<int, double>> delivered;  // (index, seconds after the first push)
  const Clock::time_point t0 = Clock::now();
  constexpr int kCount = 20;
  for (int i = 0; i < kCount; ++i) {
    ASSERT_TRUE(line.push(12500, [&, i] {
      std::lock_guard<std::mutex> lock(mutex);
      delivered.emplace_back(i, secondsSince(t0));
    }));
  }
  for (int k = 0; k < 500 && line.stats().delivered < kCount; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  line.close();  // joins the worker: `delivered` is this thread's alone from here
  ASSERT_EQ(delivered.size(), static_cast<std::size_t>(kCount));
  for (int i = 0; i < kCount; ++i) {
    EXPECT_EQ(delivered[i].first, i);
    // Lower bounds only: the link never hands on early; when it is late depends on the machine.
    EXPECT_GE(delivered[i].second, shape.delay_s + 0.010 * (i + 1) - 1e-6) << "datagram " << i;
  }
  const LinkDirectionStats s = line.stats();
  EXPECT_EQ(s.bytes_delivered, 12500u * kCount);
  EXPECT_GE(s.min_delay_s, shape.delay_s + 0.010);
  EXPECT_GE(s.max_delay_s, shape.delay_s + 0.010 * kCount);
}

TEST(DelayLine, LosesTheConfiguredShareAtRandomAndWhatFindsTheQueueFull) {
  LinkShape shape;
  shape.delay_s = 30.0;  // nothing leaves during the test
  shape.rate_bit_s = 1e12;
  shape.loss_fraction = 0.05;
  shape.queue_limit_bytes = 100000;
  DelayLine line(shape);
  std::atomic<int> delivered{0};
  for (int i = 0; i < 4000; ++i) {
    ASSERT_TRUE(line.push(10, [&] { ++delivered; }));
  }
  LinkDirectionStats s = line.stats();
  EXPECT_EQ(s.lost_queue_full, 0u);
  EXPECT_GT(s.lost_at_random, 4000 * 0.05 * 0.7);
  EXPECT_LT(s.lost_at_random, 4000 * 0.05 * 1.3);
  // 40,000 bytes wait at most; a 100 kB queue takes the next 60,000 and refuses the rest.
  const std::uint64_t random_before = s.lost_at_random;
  for (int i = 0; i < 100; ++i) ASSERT_TRUE(line.push(1000, [&] { ++delivered; }));
  s = line.stats();
  const std::uint64_t taken = 100 - (s.lost_at_random - random_before) - s.lost_queue_full;
  const std::uint64_t waiting_before = 4000 - random_before;
  EXPECT_LE(waiting_before * 10 + taken * 1000, shape.queue_limit_bytes);
  EXPECT_GT(s.lost_queue_full, 0u);
  // Closed: what waited is dropped, never delivered, and the caller delivers what comes after.
  line.close();
  EXPECT_FALSE(line.push(10, [&] { ++delivered; }));
  EXPECT_EQ(delivered.load(), 0);
  EXPECT_EQ(line.stats().delivered, 0u);
}

}  // namespace
}  // namespace mlmap::dds::test_support
