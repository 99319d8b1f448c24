#include "mlmap/datasets/frame_prefetcher.h"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <string>

namespace mlmap::datasets {
namespace {

/// Frames whose stamp is their index; reading frame `bad` throws.
class CountingSource : public FrameSource {
 public:
  CountingSource(std::size_t size, std::size_t bad) : size_(size), bad_(bad) {}
  [[nodiscard]] std::size_t size() const override { return size_; }
  [[nodiscard]] SourceFrame read(std::size_t i, SourceFrameInfo* info) const override {
    ++reads_;
    if (i == bad_) throw std::runtime_error("frame-" + std::to_string(i) + ".pcd: unreadable");
    PointCloudFrame f;
    f.stamp_s = static_cast<double>(i);
    f.points_S.assign(i + 1, Eigen::Vector3f::Zero());
    if (info != nullptr) info->name = "frame-" + std::to_string(i);
    return f;
  }
  [[nodiscard]] std::string describe() const override { return "counting source"; }
  [[nodiscard]] std::size_t reads() const { return reads_; }

 private:
  std::size_t size_;
  std::size_t bad_;
  mutable std::atomic<std::size_t> reads_{0};
};

TEST(FramePrefetcher, HandsOverEveryFrameInOrderWithOrWithoutItsThread) {
  const CountingSource source(50, 1000);
  for (const std::size_t capacity : {std::size_t{0}, std::size_t{1}, std::size_t{4}}) {
    FramePrefetcher reader(source, 40, capacity);
    PrefetchedFrame f;
    std::size_t n = 0;
    while (reader.next(&f)) {
      EXPECT_EQ(stampOf(f.frame), static_cast<double>(n)) << "capacity " << capacity;
      EXPECT_EQ(f.info.name, "frame-" + std::to_string(n));
      EXPECT_EQ(std::get<PointCloudFrame>(f.frame).points_S.size(), n + 1);
      EXPECT_GE(f.read_ms, 0.0);
      ++n;
    }
    EXPECT_EQ(n, 40u) << "capacity " << capacity;
    EXPECT_FALSE(reader.next(&f));
  }
}

TEST(FramePrefetcher, AnUnreadableFrameThrowsAfterTheFramesBeforeIt) {
  const CountingSource source(50, 30);
  for (const std::size_t capacity : {std::size_t{0}, std::size_t{3}}) {
    FramePrefetcher reader(source, 50, capacity);
    PrefetchedFrame f;
    std::size_t n = 0;
    try {
      while (reader.next(&f)) ++n;
      ADD_FAILURE() << "frame 30 should have thrown (capacity " << capacity << ")";
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()), "frame-30.pcd: unreadable");
    }
    EXPECT_EQ(n, 30u) << "capacity " << capacity;
  }
}

TEST(FramePrefetcher, ReadsAtMostItsCapacityAheadAndStopsWhenDestroyed) {
  const CountingSource source(1000, 1000);
  {
    FramePrefetcher reader(source, 1000, 2);
    PrefetchedFrame f;
    ASSERT_TRUE(reader.next(&f));
    // Whatever the timing: one frame handed over, at most 2 waiting and 1 being read.
  }  // the destructor stops the reader without reading the rest
  EXPECT_LE(source.reads(), 4u);
}

}  // namespace
}  // namespace mlmap::datasets
