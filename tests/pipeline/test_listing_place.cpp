// The threaded engine's choice of how far its first half takes the cone listing.
#include "../../src/pipeline/listing_place.h"

#include <gtest/gtest.h>

#include <array>
#include <cstdlib>
#include <random>

namespace mlmap {
namespace {

using Step = AwarenessStage::ConeListingStep;

HalvesMs halves(double awareness_ms, double local_ms, double bins_ms, double cones_ms) {
  HalvesMs ms;
  ms.awareness_ms = awareness_ms;
  ms.local_ms = local_ms;
  ms.bins_ms = bins_ms;
  ms.cones_ms = cones_ms;
  return ms;
}

// The streamed flight's halves (as measured): the bin entry to the point loop, not the cones,
// which would make the point loop the longer half; the tabletop frames' (the point loop the
// longer half): nothing moves, and what moved comes back; a carving half much the longer (a
// LiDAR scan with one awareness thread): all of it. Halves about even keep their place.
TEST(ListingPlace, MovesTheStepsThatKeepTheMovingHalfTheShorter) {
  const HalvesMs flight = halves(1.89, 2.16, 0.45, 0.47);
  EXPECT_EQ(placeConeListing(Step::kNothing, flight, true), Step::kBinsEntered);
  EXPECT_EQ(placeConeListing(Step::kBinsEntered, flight, true), Step::kBinsEntered);
  const HalvesMs tabletop = halves(0.61, 0.44, 0.06, 0.03);
  EXPECT_EQ(placeConeListing(Step::kNothing, tabletop, true), Step::kNothing);
  EXPECT_EQ(placeConeListing(Step::kBinsEntered, tabletop, true), Step::kNothing);
  EXPECT_EQ(placeConeListing(Step::kConesListed, tabletop, true), Step::kBinsEntered);
  const HalvesMs carving = halves(3.0, 9.0, 2.0, 1.5);
  EXPECT_EQ(placeConeListing(Step::kNothing, carving, true), Step::kBinsEntered);
  EXPECT_EQ(placeConeListing(Step::kBinsEntered, carving, true), Step::kConesListed);
  EXPECT_EQ(placeConeListing(Step::kConesListed, carving, true), Step::kConesListed);
  // About even: the bin entry neither moves nor comes back.
  const HalvesMs even = halves(1.05, 1.0, 0.2, 0.2);
  EXPECT_EQ(placeConeListing(Step::kNothing, even, true), Step::kNothing);
  EXPECT_EQ(placeConeListing(Step::kBinsEntered, even, true), Step::kBinsEntered);
  // Nothing moves towards the awareness thread before the halves have settled; back, it does.
  EXPECT_EQ(placeConeListing(Step::kNothing, carving, false), Step::kNothing);
  EXPECT_EQ(placeConeListing(Step::kBinsEntered, tabletop, false), Step::kNothing);
}

// Against the rule written out, on random halves: a step forth only while the awareness half
// stays the shorter with it (and only when `settled`), a step back only where that half is the
// longer even without its last step, one step at a time; otherwise the place stays.
TEST(ListingPlace, MovesAStepOnlyWhereTheRuleSays) {
  std::mt19937 rng(44);
  std::uniform_real_distribution<double> half(0.0, 10.0);
  std::uniform_real_distribution<double> part(0.0, 3.0);
  const std::array<Step, 3> steps{Step::kNothing, Step::kBinsEntered, Step::kConesListed};
  int moved_up = 0;
  int moved_down = 0;
  int stayed = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const HalvesMs ms = halves(half(rng), half(rng), part(rng), part(rng));
    // The listing's milliseconds on the awareness thread at each step, and in all.
    const std::array<double, 3> here{0.0, ms.bins_ms, ms.bins_ms + ms.cones_ms};
    const double all = here[2];
    for (int k = 0; k < 3; ++k) {
      const auto uk = static_cast<std::size_t>(k);
      const bool settled = trial % 4 != 0;
      const Step next = placeConeListing(steps[uk], ms, settled);
      const int n = static_cast<int>(next);
      ASSERT_LE(std::abs(n - k), 1);
      const bool forth = k < 2 && ms.awareness_ms + here[uk + 1] < ms.local_ms + all - here[uk + 1];
      const bool back = k > 0 && ms.awareness_ms + here[uk - 1] > ms.local_ms + all - here[uk];
      ASSERT_FALSE(forth && back);  // the two never meet
      if (n == k + 1) {
        EXPECT_TRUE(settled && forth);
        ++moved_up;
      } else if (n == k - 1) {
        EXPECT_TRUE(back);
        ++moved_down;
      } else {
        EXPECT_FALSE(settled && forth);
        EXPECT_FALSE(back);
        ++stayed;
      }
    }
  }
  // Every outcome met.
  EXPECT_GT(moved_up, 1000);
  EXPECT_GT(moved_down, 1000);
  EXPECT_GT(stayed, 1000);
}

}  // namespace
}  // namespace mlmap
