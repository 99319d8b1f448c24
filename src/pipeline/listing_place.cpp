#include "listing_place.h"

#include <algorithm>
#include <array>
#include <cstddef>

namespace mlmap {

AwarenessStage::ConeListingStep placeConeListing(AwarenessStage::ConeListingStep now,
                                                 const HalvesMs& ms, bool settled) {
  using Step = AwarenessStage::ConeListingStep;
  // The listing's milliseconds on the awareness thread, per step.
  const std::array<double, 3> in_awareness{0.0, ms.bins_ms, ms.bins_ms + ms.cones_ms};
  auto longer = [&](std::size_t step) {
    return std::max(ms.awareness_ms + in_awareness[step],
                    ms.local_ms + in_awareness[2] - in_awareness[step]);
  };
  const auto k = static_cast<std::size_t>(now);
  if (settled && k < 2 &&
      longer(k + 1) < longer(k) - 0.5 * (in_awareness[k + 1] - in_awareness[k])) {
    return static_cast<Step>(k + 1);
  }
  if (k > 0 && longer(k - 1) < longer(k) - 0.5 * (in_awareness[k] - in_awareness[k - 1])) {
    return static_cast<Step>(k - 1);
  }
  return now;
}

}  // namespace mlmap
