/// @file
/// Fuzz target: a pose sample as raw CDR bytes, deserialised as mlmap_node does (cdr_payload.h),
/// then decodePose(). The first byte picks the type (even: geometry_msgs/PoseStamped, odd:
/// nav_msgs/Odometry), the rest is the sample. Checks what decodePose() documents: on success a
/// finite stamp and a rigid, finite T_W_B; on error the outputs untouched.

#include "cdr_payload.h"
#include "fuzz_support.h"

#include "mlmap/dds/wire/ros_conversions.h"

#include "geometry_msgs/msg/PoseStamped_PubSubTypes.h"
#include "nav_msgs/msg/Odometry_PubSubTypes.h"

#include <cmath>

namespace {

using mlmap::fuzz::requireThat;

template <typename PubSubType, typename Msg>
void decodeOne(const std::uint8_t* data, std::size_t size) {
  Msg msg;
  if (!mlmap::fuzz::deserializeAsNodeDoes<PubSubType>(data, size, &msg)) return;
  double stamp_s = -7.0;
  mlmap::Transform T_W_B = mlmap::Transform::Identity();
  T_W_B.translation() = Eigen::Vector3d(1.0, 2.0, 3.0);  // a marker
  const mlmap::dds::DecodeStatus status = mlmap::dds::decodePose(msg, &stamp_s, &T_W_B);
  if (!status.ok()) {
    requireThat(stamp_s == -7.0 && T_W_B.translation() == Eigen::Vector3d(1.0, 2.0, 3.0),
                "decodePose: outputs changed on an error");
    return;
  }
  requireThat(std::isfinite(stamp_s) && T_W_B.matrix().allFinite(), "decodePose: not finite");
  const Eigen::Matrix3d R = T_W_B.linear();
  requireThat((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-9 &&
                  R.determinant() > 0.0,
              "decodePose: the rotation is not a rotation");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  if (data[0] % 2 == 0) {
    decodeOne<mlmap::dds::geometry_msgs::PoseStamped_PubSubType,
              mlmap::dds::geometry_msgs::PoseStamped_>(data + 1, size - 1);
  } else {
    decodeOne<mlmap::dds::nav_msgs::Odometry_PubSubType, mlmap::dds::nav_msgs::Odometry_>(data + 1,
                                                                                          size - 1);
  }
  return 0;
}
