#include "listing_place.h"

#include <array>
#include <cstddef>

namespace mlmap {

AwarenessStage::ConeListingStep placeConeListing(AwarenessStage::ConeListingStep now,
                                                 const HalvesMs& ms, bool settled) {
  using Step = AwarenessStage::ConeListingStep;
  // The listing's milliseconds on the awareness thread, per step; the rest is the other's.
  const std::array<double, 3> in_awareness{0.0, ms.bins_ms, ms.bins_ms + ms.cones_ms};
  const double listing_ms = in_awareness[2];
  const auto k = static_cast<std::size_t>(now);
  // Forth while the awareness thread's half stays the shorter with the next step.
  if (settled && k < 2 &&
      ms.awareness_ms + in_awareness[k + 1] < ms.local_ms + listing_ms - in_awareness[k + 1]) {
    return static_cast<Step>(k + 1);
  }
  // Back where its half is the longer even without its last step.
  if (k > 0 && ms.awareness_ms + in_awareness[k - 1] > ms.local_ms + listing_ms - in_awareness[k]) {
    return static_cast<Step>(k - 1);
  }
  return now;
}

}  // namespace mlmap
