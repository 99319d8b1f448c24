// The ROS 2 type hashes computed at build time from idl/ (tools/idl_type_hashes.py) against
// ROS 2 Jazzy's own, and the USER_DATA that carries them.

#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/wire/type_hash.h"

#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>

#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

namespace mlmap::dds {
namespace {

// Jazzy's hashes of the message types in idl/, read from the share/<pkg>/msg/<Name>.json files of
// a ROS 2 Jazzy source build (../shared/reference/ros2-type-hashes.md).
const std::vector<std::pair<std::string, std::string>> kJazzyHashes = {
    {"builtin_interfaces::msg::dds_::Time_",
     "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197"},
    {"std_msgs::msg::dds_::Header_",
     "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01"},
    {"geometry_msgs::msg::dds_::Point_",
     "RIHS01_6963084842a9b04494d6b2941d11444708d892da2f4b09843b9c43f42a7f6881"},
    {"geometry_msgs::msg::dds_::Quaternion_",
     "RIHS01_8a765f66778c8ff7c8ab94afcc590a2ed5325a1d9a076ffff38fbce36f458684"},
    {"geometry_msgs::msg::dds_::Vector3_",
     "RIHS01_cc12fe83e4c02719f1ce8070bfd14aecd40f75a96696a67a2a1f37f7dbb0765d"},
    {"geometry_msgs::msg::dds_::Pose_",
     "RIHS01_d501954e9476cea2996984e812054b68026ae0bfae789d9a10b23daf35cc90fa"},
    {"geometry_msgs::msg::dds_::PoseStamped_",
     "RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8"},
    {"geometry_msgs::msg::dds_::PoseWithCovariance_",
     "RIHS01_9a7c0fd234b7f45c6098745ecccd773ca1085670e64107135397aee31c02e1bb"},
    {"geometry_msgs::msg::dds_::Twist_",
     "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a"},
    {"geometry_msgs::msg::dds_::TwistWithCovariance_",
     "RIHS01_49f574f033f095d8b6cd1beaca5ca7925e296e84af1716d16c89d38b059c8c18"},
    {"geometry_msgs::msg::dds_::Transform_",
     "RIHS01_beb83fbe698636351461f6f35d1abb20010c43d55374d81bd041f1ba2581fddc"},
    {"geometry_msgs::msg::dds_::TransformStamped_",
     "RIHS01_0a241f87d04668d94099cbb5ba11691d5ad32c2f29682e4eb5653424bd275206"},
    {"nav_msgs::msg::dds_::Odometry_",
     "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0"},
    {"nav_msgs::msg::dds_::MapMetaData_",
     "RIHS01_2772d4b2000ef2b35dbaeb80fd3946c1369f817fb4f75677d916d27c17d763c8"},
    {"nav_msgs::msg::dds_::OccupancyGrid_",
     "RIHS01_8d348150c12913a31ee0ec170fbf25089e4745d17035792a1ba94d6f0bc0cfc7"},
    {"sensor_msgs::msg::dds_::PointField_",
     "RIHS01_5c6a4750728c2bcfbbf7037225b20b02d4429634732146b742dee1726637ef01"},
    {"sensor_msgs::msg::dds_::PointCloud2_",
     "RIHS01_9198cabf7da3796ae6fe19c4cb3bdd3525492988c70522628af5daa124bae2b5"},
    {"sensor_msgs::msg::dds_::Image_",
     "RIHS01_d31d41a9a4c4bc8eae9be757b0beed306564f7526c88ea6a4588fb9582527d47"},
    {"sensor_msgs::msg::dds_::CameraInfo_",
     "RIHS01_b3dfd68ff46c9d56c80fd3bd4ed22c7a4ddce8c8348f2f59c299e73118e7e275"},
    {"sensor_msgs::msg::dds_::RegionOfInterest_",
     "RIHS01_ad16bcba5f9131dcdba6fbded19f726f5440e3c513b4fb586dd3027eeed8abb1"},
    {"tf2_msgs::msg::dds_::TFMessage_",
     "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"},
    {"rcl_interfaces::msg::dds_::Log_",
     "RIHS01_e28ce254ca8abc06abf92773b74602cdbf116ed34fbaf294fb9f81da9f318eac"},
    {"rmw_dds_common::msg::dds_::Gid_",
     "RIHS01_ab6f21cfbb0a6dbb837161e1110c2051a2850ed9f9c53944d7115d9bcebedf71"},
    {"rmw_dds_common::msg::dds_::NodeEntitiesInfo_",
     "RIHS01_8ffef65ee2d088c63b1e8fcd31e800ba9fc8dbe0ee15ca60d1676de5218087a7"},
    {"rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_",
     "RIHS01_91a0593bacdcc50ea9bdcf849a938b128412cc1ea821245c663bcd26f83c295e"},
};

// Jazzy's hashes of services (the service type itself, derived by rosidl from its request and
// response) and of the request and response types their endpoints carry, same source.
const std::vector<std::pair<std::string, std::string>> kJazzyServiceHashes = {
    {"rcl_interfaces::srv::dds_::GetParameters_",
     "RIHS01_bf9803d5c74cf989a5de3e0c2e99444599a627c7ff75f97b8c05b01003675cbc"},
    {"rcl_interfaces::srv::dds_::ListParameters_",
     "RIHS01_3e6062bfbb27bfb8730d4cef2558221f51a11646d78e7bb30a1e83afac3aad9d"},
    {"std_srvs::srv::dds_::Trigger_",
     "RIHS01_eeff2cd6fa5ad9d27cdf4dec64818317839b62f212a91e6b5304b634b2062c5f"},
    {"std_srvs::srv::dds_::Empty_",
     "RIHS01_5888399dedec5ccc85ea6451949fd2c9f97bfdf963f9a588821639fcd31b5d19"},
    {"std_srvs::srv::dds_::Trigger_Request_",
     "RIHS01_d010825374ce8918e72bfd826c82603e60f45419e932ea976f807b74a863a199"},
    {"std_srvs::srv::dds_::Trigger_Response_",
     "RIHS01_2d946c21e2fc3f1e9ca6986a8191d85fcc70097a8bb7771a053564bc47009cdf"},
    {"rcl_interfaces::srv::dds_::GetParameters_Request_",
     "RIHS01_135a9e1c3d7cebef792f6687d7ddf99949b21a0bd9a320d863a9110a3f5cf4d6"},
    {"rcl_interfaces::srv::dds_::GetParameters_Response_",
     "RIHS01_9fa773b46e39cc5d02db6224d8fd520bb9caeeffc2b27c96c1e59431baba9f2a"},
    {"rcl_interfaces::srv::dds_::ListParameters_Request_",
     "RIHS01_a1b0b5d6b967a5b8ac5bc8563c3ea678f349e312a6a4967227c5a96bc5ce38df"},
    {"rcl_interfaces::srv::dds_::ListParameters_Response_",
     "RIHS01_31b937b82de3612426be79f231e386259f97e8dc843e3f2845288b4bfa296bdd"},
    {"rcl_interfaces::srv::dds_::DescribeParameters_Request_",
     "RIHS01_05dd1c2bc87dec2627105c8070d6f9725c781a4f2ab852975bf105462b82b644"},
    {"rcl_interfaces::srv::dds_::DescribeParameters_Response_",
     "RIHS01_ad6747319613c6131589e062e095b469a46cc764f7d0f12a001a49e6cd893995"},
};

TEST(TypeHashes, EqualJazzysForEveryStandardType) {
  for (const auto& [type, hash] : kJazzyHashes) {
    EXPECT_EQ(rosTypeHash(type), hash) << type;
  }
}

// nav_msgs/Path (the reference planner's plan over DDS) is not in that file: its hash is the one
// published ROS 2 type tables carry for Jazzy (e.g. the typings rosbags generates), and it is
// built from Header and PoseStamped, whose hashes the test above checks against Jazzy's own.
TEST(TypeHashes, PathEqualsThePublishedOne) {
  EXPECT_EQ(rosTypeHash("nav_msgs::msg::dds_::Path_"),
            "RIHS01_1957a5bb3cee5da65c4e52e52b65a93df227efce4c20f8458b36e73066ca334b");
}

TEST(TypeHashes, EqualJazzysForServicesAndTheirRequestsAndResponses) {
  for (const auto& [type, hash] : kJazzyServiceHashes) {
    EXPECT_EQ(rosTypeHash(type), hash) << type;
  }
}

TEST(TypeHashes, MlmapsOwnTypesHaveOne) {
  for (const char* type :
       {"mlmap_msgs::msg::dds_::Status_", "mlmap_msgs::msg::dds_::VoxelBlock_"}) {
    const std::string hash = rosTypeHash(type);
    EXPECT_EQ(hash.size(), 7u + 64u) << type;
    EXPECT_EQ(hash.rfind("RIHS01_", 0), 0u) << type;
  }
  EXPECT_NE(rosTypeHash("mlmap_msgs::msg::dds_::Status_"),
            rosTypeHash("mlmap_msgs::msg::dds_::VoxelBlock_"));
}

TEST(TypeHashes, UnknownTypeHasNone) {
  EXPECT_EQ(rosTypeHash("std_msgs::msg::dds_::String_"), "");
  EXPECT_EQ(rosTypeHash("std_msgs/msg/Header"), "");  // the ROS name is not the DDS name
  EXPECT_TRUE(rosEndpointUserData("std_msgs::msg::dds_::String_").empty());
}

TEST(TypeHashes, UserDataAsRmwWritesIt) {
  const std::vector<std::uint8_t> data = rosEndpointUserData("std_msgs::msg::dds_::Header_");
  EXPECT_EQ(std::string(data.begin(), data.end()),
            "typehash=RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01;");
}

TEST(TypeHashes, EndpointQosGetsTheHashUnlessUserDataIsSet) {
  namespace fdds = eprosima::fastdds::dds;
  const std::string type = "nav_msgs::msg::dds_::OccupancyGrid_";
  const fdds::DataWriterQos writer = withRosTypeHash(fdds::DataWriterQos(), type);
  const fdds::DataReaderQos reader = withRosTypeHash(fdds::DataReaderQos(), type);
  const std::string text =
      "typehash=RIHS01_8d348150c12913a31ee0ec170fbf25089e4745d17035792a1ba94d6f0bc0cfc7;";
  const std::vector<std::uint8_t> expected(text.begin(), text.end());
  EXPECT_EQ(writer.user_data().data_vec(), expected);
  EXPECT_EQ(reader.user_data().data_vec(), expected);

  fdds::DataWriterQos own;
  own.user_data().data_vec({'x', ';'});
  EXPECT_EQ(withRosTypeHash(own, type).user_data().data_vec(),
            (std::vector<std::uint8_t>{'x', ';'}));
}

}  // namespace
}  // namespace mlmap::dds
