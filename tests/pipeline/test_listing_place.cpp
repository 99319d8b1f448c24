// The threaded engine's choice of how far its first half takes the cone listing.
#include "../../src/pipeline/listing_place.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <random>

namespace mlmap {
namespace {

using Step = AwarenessStage::ConeListingStep;

// The longer half with the listing taken to `step` by the awareness thread.
double longerHalf(const HalvesMs& ms, Step step) {
  const double moved = step == Step::kNothing       ? 0.0
                       : step == Step::kBinsEntered ? ms.bins_ms
                                                    : ms.bins_ms + ms.cones_ms;
  return std::max(ms.awareness_ms + moved, ms.local_ms + ms.bins_ms + ms.cones_ms - moved);
}

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
// longer half): nothing moves; a carving half much the longer (a LiDAR scan's): all of it.
TEST(ListingPlace, MovesTheStepsThatShortenTheLongerHalf) {
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
  // Nothing moves towards the awareness thread before the halves have settled; back, it does.
  EXPECT_EQ(placeConeListing(Step::kNothing, carving, false), Step::kNothing);
  EXPECT_EQ(placeConeListing(Step::kBinsEntered, tabletop, false), Step::kNothing);
}

// Against a slow reference of the rule, on random halves: a step moves only where it shortens
// the longer half by more than half the step, one step at a time, never further without
// `settled`; and within the band no step shortens by that much, so the place stays.
TEST(ListingPlace, MovesAStepOnlyWhereThatShortensTheLongerHalfByHalfTheStep) {
  std::mt19937 rng(44);
  std::uniform_real_distribution<double> half(0.0, 10.0);
  std::uniform_real_distribution<double> part(0.0, 3.0);
  const std::array<Step, 3> steps{Step::kNothing, Step::kBinsEntered, Step::kConesListed};
  int moved_up = 0;
  int moved_down = 0;
  int stayed = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const HalvesMs ms = halves(half(rng), half(rng), part(rng), part(rng));
    const std::array<double, 3> step_ms{0.0, ms.bins_ms, ms.cones_ms};
    for (int k = 0; k < 3; ++k) {
      const bool settled = trial % 4 != 0;
      const Step next = placeConeListing(steps[k], ms, settled);
      const int n = static_cast<int>(next);
      ASSERT_LE(std::abs(n - k), 1);
      const bool up_pays =
          k < 2 && longerHalf(ms, steps[k + 1]) < longerHalf(ms, steps[k]) - 0.5 * step_ms[k + 1];
      const bool down_pays =
          k > 0 && longerHalf(ms, steps[k - 1]) < longerHalf(ms, steps[k]) - 0.5 * step_ms[k];
      if (n == k + 1) {
        EXPECT_TRUE(settled && up_pays);
        ++moved_up;
      } else if (n == k - 1) {
        EXPECT_TRUE(down_pays && !(settled && up_pays));
        ++moved_down;
      } else {
        EXPECT_FALSE(settled && up_pays);
        EXPECT_FALSE(down_pays);
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
