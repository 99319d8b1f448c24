/// @file
/// Fuzz target: a mlmap_msgs/Submap sample as raw CDR bytes, deserialised as mlmap_fleet and
/// mlmap_node (dds.fleet.subscribe) do (cdr_payload.h), then decodeSubmapMessage(). Checks what
/// it documents: on success as many voxels as voxel_count says, offsets ascending inside the
/// submap, a submap of at most kMaxSubmapVoxels; and that no size in the sample makes it
/// allocate beyond its own limits (a decompression bomb is refused, not inflated).

#include "cdr_payload.h"
#include "fuzz_support.h"

#include "mlmap/dds/fleet/submap_messages.h"

#include "mlmap_msgs/msg/Submap_PubSubTypes.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using mlmap::fuzz::requireThat;
  ::mlmap_msgs::msg::dds_::Submap_ msg;
  if (!mlmap::fuzz::deserializeAsNodeDoes<::mlmap_msgs::msg::dds_::Submap_PubSubType>(data, size,
                                                                                      &msg)) {
    return 0;
  }
  mlmap::dds::DecodedSubmap decoded;
  if (!mlmap::dds::decodeSubmapMessage(msg, &decoded).empty()) return 0;
  const std::uint64_t voxels = static_cast<std::uint64_t>(decoded.geometry.cells.x()) *
                               static_cast<std::uint64_t>(decoded.geometry.cells.y()) *
                               static_cast<std::uint64_t>(decoded.geometry.cells.z());
  requireThat(voxels > 0 && voxels <= mlmap::dds::kMaxSubmapVoxels, "decodeSubmapMessage: size");
  requireThat(decoded.records.size() == msg.voxel_count_(), "decodeSubmapMessage: voxel count");
  for (std::size_t i = 0; i < decoded.records.size(); ++i) {
    requireThat(decoded.records[i].offset < voxels,
                "decodeSubmapMessage: offset beyond the submap");
    requireThat(i == 0 || decoded.records[i - 1].offset < decoded.records[i].offset,
                "decodeSubmapMessage: offsets not ascending");
  }
  return 0;
}
