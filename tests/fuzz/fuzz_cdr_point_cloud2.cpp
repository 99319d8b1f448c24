/// @file
/// Fuzz target: a sensor_msgs/PointCloud2 sample as raw CDR bytes, deserialised as mlmap_node
/// does (cdr_payload.h), then decodePointCloud2(). Checks what decodePointCloud2() documents: on
/// success width * height points, each all finite or all NaN, and the same points again after
/// encodePointCloud2() -> decodePointCloud2(); on error no points. The node's own type
/// (CloudSamplePubSubType, decoding in place) must agree with that reference exactly: the same
/// samples refused, the same decode errors, the same points.

#include "cdr_payload.h"
#include "fuzz_support.h"

#include "mlmap/dds/wire/cloud_sample.h"
#include "mlmap/dds/wire/ros_conversions.h"

#include "sensor_msgs/msg/PointCloud2_PubSubTypes.h"

#include <cstring>
#include <vector>

namespace {

using mlmap::fuzz::requireThat;
using PointCloud2 = ::sensor_msgs::msg::dds_::PointCloud2_;
using PointCloud2Type = ::sensor_msgs::msg::dds_::PointCloud2_PubSubType;

bool sameBits(const std::vector<Eigen::Vector3f>& a, const std::vector<Eigen::Vector3f>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      const bool both_nan = std::isnan(a[i][k]) && std::isnan(b[i][k]);
      if (!both_nan && std::memcmp(&a[i][k], &b[i][k], sizeof(float)) != 0) return false;
    }
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  PointCloud2 msg;
  const bool accepted = mlmap::fuzz::deserializeAsNodeDoes<PointCloud2Type>(data, size, &msg);
  mlmap::dds::CloudSample sample;
  sample.points_S = {Eigen::Vector3f::Zero()};  // reused memory
  const bool sample_accepted =
      mlmap::fuzz::deserializeAsNodeDoes<mlmap::dds::CloudSamplePubSubType>(data, size, &sample);
  requireThat(sample_accepted == accepted,
              "CloudSamplePubSubType and the generated type disagree on the CDR");
  if (!accepted) return 0;  // dropped and counted as malformed CDR
  std::vector<Eigen::Vector3f> points_S = {Eigen::Vector3f::Ones()};  // reused memory
  const mlmap::dds::DecodeStatus status = mlmap::dds::decodePointCloud2(msg, &points_S);
  requireThat(sample.status.error == status.error && sample.status.detail == status.detail,
              "CloudSample's decode status differs from decodePointCloud2()'s");
  requireThat(sameBits(sample.points_S, points_S), "CloudSample's points differ");
  requireThat(sample.header_().frame_id_() == msg.header_().frame_id_() &&
                  sample.width_() == msg.width_() && sample.is_dense_() == msg.is_dense_() &&
                  sample.data_().empty(),
              "CloudSample's fields differ from the generated type's");
  if (!status.ok()) {
    requireThat(points_S.empty(), "decodePointCloud2: points left after an error");
    requireThat(!status.detail.empty(), "decodePointCloud2: an error without a detail");
    return 0;
  }
  requireThat(points_S.size() == std::size_t{msg.width_()} * msg.height_(),
              "decodePointCloud2: not width * height points");
  for (const Eigen::Vector3f& p : points_S) {
    requireThat(p.allFinite() || p.array().isNaN().all(),
                "decodePointCloud2: a point neither finite nor all NaN");
  }
  const PointCloud2 again = mlmap::dds::encodePointCloud2(points_S, nullptr, 0.0, "fuzz");
  std::vector<Eigen::Vector3f> decoded_again;
  requireThat(mlmap::dds::decodePointCloud2(again, &decoded_again).ok(),
              "decodePointCloud2 refuses what encodePointCloud2 wrote");
  requireThat(sameBits(points_S, decoded_again), "encode -> decode changed the points");
  return 0;
}
