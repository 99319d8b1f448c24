/// @file
/// Fuzz target: CDR samples whose sequence counts drive allocation, taken as the node takes them
/// (cdr_payload.h: CheckedType, which checks the payload against the type's layout from idl/
/// before Fast CDR reads it). The first byte picks the type (even: tf2_msgs/TFMessage, the /tf and
/// /tf_static readers and the bag's /tf; odd: rcl_interfaces SetParameters request, the parameter
/// service), the rest is the sample. Checks what mlmap/dds/wire/cdr_check.h documents: every
/// layout's walk of the bytes stays inside them, and a sample taken holds no more elements than its
/// bytes back (each element takes at least its type's minimum bytes on the wire), so no count makes
/// the reader allocate beyond the sample's size.

#include "cdr_payload.h"
#include "fuzz_support.h"

#include "mlmap/dds/wire/cdr_check.h"

#include "rcl_interfaces/srv/SetParameters_PubSubTypes.h"
#include "tf2_msgs/msg/TFMessage_PubSubTypes.h"

namespace {

using mlmap::fuzz::requireThat;

/// Least bytes one value of the DDS type `dds_type` takes on the wire.
std::size_t minBytes(const char* dds_type) {
  const mlmap::dds::CdrStructLayout* layout = mlmap::dds::cdrLayoutOf(dds_type);
  requireThat(layout != nullptr, "no layout for a type of idl/");
  return layout->min_bytes;
}

void takeTf(const std::uint8_t* data, std::size_t size) {
  ::tf2_msgs::msg::dds_::TFMessage_ msg;
  if (!mlmap::fuzz::deserializeAsNodeDoes<::tf2_msgs::msg::dds_::TFMessage_PubSubType>(data, size,
                                                                                       &msg)) {
    return;
  }
  static const std::size_t transform_bytes =
      minBytes("geometry_msgs::msg::dds_::TransformStamped_");
  requireThat(4 + msg.transforms_().size() * transform_bytes <= size,
              "TFMessage: more transforms than bytes");
}

void takeSetParameters(const std::uint8_t* data, std::size_t size) {
  namespace rcl = ::rcl_interfaces::srv::dds_;
  rcl::SetParameters_Request_ msg;
  if (!mlmap::fuzz::deserializeAsNodeDoes<rcl::SetParameters_Request_PubSubType>(data, size, &msg))
    return;
  static const std::size_t parameter_bytes = minBytes("rcl_interfaces::msg::dds_::Parameter_");
  requireThat(4 + msg.parameters_().size() * parameter_bytes <= size,
              "SetParameters: more parameters than bytes");
  std::size_t elements = 0;
  for (const auto& p : msg.parameters_()) {
    const auto& v = p.value_();
    elements += v.byte_array_value_().size() + v.bool_array_value_().size() +
                8 * (v.integer_array_value_().size() + v.double_array_value_().size()) +
                4 * v.string_array_value_().size();
  }
  requireThat(elements <= size, "SetParameters: array values beyond the bytes");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  // Every layout walks the same bytes without reading past them.
  std::size_t count = 0;
  const mlmap::dds::CdrStructLayout* const* layouts = mlmap::dds::cdrLayouts(&count);
  for (std::size_t i = 0; i < count; ++i) {
    const mlmap::dds::CdrCheck check = mlmap::dds::checkCdrPayload(*layouts[i], data + 1, size - 1);
    requireThat(check.ok ? check.consumed_bytes <= size - 1 : !check.error.empty(),
                "checkCdrPayload");
  }
  if (data[0] % 2 == 0) {
    takeTf(data + 1, size - 1);
  } else {
    takeSetParameters(data + 1, size - 1);
  }
  return 0;
}
