#pragma once
/// @file
/// How far the threaded engine's first half takes a frame's cone listing (private to the
/// pipeline): the choice that balances the two halves.

#include "mlmap/awareness/awareness_stage.h"

namespace mlmap {

/// Milliseconds per frame of the threaded engine's halves and of the cone listing's steps.
struct HalvesMs {
  double awareness_ms = 0.0;  ///< the awareness thread's, without the listing
  double local_ms = 0.0;      ///< the local-global thread's, without the listing
  double bins_ms = 0.0;       ///< the listing's first step (the bin entry), on either thread
  double cones_ms = 0.0;      ///< its second step (the cones), on either thread
};

/// How far the awareness thread takes the cone listing from now on (the rest is the
/// local-global thread's), from `now`: a step further while the awareness thread's half stays
/// the shorter one with it, and only when `settled`; a step back where that half is the longer
/// one even without its last step. Between the two the place stays, so that it does not follow
/// the halves' noise (each is the shortest of a few frames, and they swap now and then where
/// they are about even): each move finds the other half's listing scratch out of its cache.
AwarenessStage::ConeListingStep placeConeListing(AwarenessStage::ConeListingStep now,
                                                 const HalvesMs& ms, bool settled);

}  // namespace mlmap
