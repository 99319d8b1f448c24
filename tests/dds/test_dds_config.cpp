#include "mlmap/dds/transport/dds_config.h"

#include "scoped_env.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

namespace mlmap::dds {
namespace {

using test_support::ScopedEnv;

/// Whether one of the problems of `config` is about `key`.
bool hasProblem(const DdsConfig& config, const std::string& key) {
  for (const std::string& e : config.validate()) {
    if (e.rfind(key + ":", 0) == 0) return true;
  }
  return false;
}

TEST(DdsConfig, DefaultsAreValid) {
  const DdsConfig config;
  EXPECT_TRUE(config.validate().empty());
}

TEST(DdsConfig, EveryBadValueIsNamedByItsKey) {
  struct Case {
    const char* key;
    void (*spoil)(DdsConfig*);
  };
  const Case cases[] = {
      {"dds.domain_id", [](DdsConfig* c) { c->domain_id = 233; }},
      {"dds.domain_id", [](DdsConfig* c) { c->domain_id = -2; }},
      {"dds.ns", [](DdsConfig* c) { c->ns = "uav 1"; }},
      {"dds.ns", [](DdsConfig* c) { c->ns = "1uav"; }},
      {"dds.discovery_range", [](DdsConfig* c) { c->discovery_range = "LAN"; }},
      {"dds.participant_profile", [](DdsConfig* c) { c->profiles_file = "x.xml"; }},
      {"dds.world_frame", [](DdsConfig* c) { c->world_frame = ""; }},
      {"dds.body_frame", [](DdsConfig* c) { c->body_frame = "/base_link"; }},
      {"dds.sensor_frame", [](DdsConfig* c) { c->sensor_frame = "camera frame"; }},
      {"dds.topics.cloud", [](DdsConfig* c) { c->topics.cloud = "cloud/"; }},
      {"dds.topics.pose", [](DdsConfig* c) { c->topics.pose = "a//b"; }},
      {"dds.topics.odometry", [](DdsConfig* c) { c->topics.odometry = "odom-1"; }},
      {"dds.topics.depth_image",
       [](DdsConfig* c) {
         c->topics.depth_image = "2depth";
         c->topics.camera_info = "camera_info";
       }},
      {"dds.topics.camera_info", [](DdsConfig* c) { c->topics.camera_info = "info?"; }},
      {"dds.topics.camera_info", [](DdsConfig* c) { c->topics.depth_image = "depth"; }},
      {"dds.topics.awareness", [](DdsConfig* c) { c->topics.awareness = "/"; }},
      {"dds.topics.local_map", [](DdsConfig* c) { c->topics.local_map = "local map"; }},
      {"dds.topics.global_map", [](DdsConfig* c) { c->topics.global_map = "mlmap/3d"; }},
      {"dds.topics.grid", [](DdsConfig* c) { c->topics.grid = "~/grid"; }},
      {"dds.topics.esdf_slice", [](DdsConfig* c) { c->topics.esdf_slice = "esdf.slice"; }},
      {"dds.topics.esdf_block", [](DdsConfig* c) { c->topics.esdf_block = "esdf//block"; }},
      {"dds.topics.status", [](DdsConfig* c) { c->topics.status = "{node}/status"; }},
      {"dds.rates.awareness_hz", [](DdsConfig* c) { c->rates.awareness_hz = -1.0; }},
      {"dds.rates.local_map_hz", [](DdsConfig* c) { c->rates.local_map_hz = std::nan(""); }},
      {"dds.rates.global_map_hz",
       [](DdsConfig* c) { c->rates.global_map_hz = std::numeric_limits<double>::infinity(); }},
      {"dds.rates.grid_hz", [](DdsConfig* c) { c->rates.grid_hz = -0.5; }},
      {"dds.rates.esdf_hz", [](DdsConfig* c) { c->rates.esdf_hz = -2.0; }},
      {"dds.rates.status_hz", [](DdsConfig* c) { c->rates.status_hz = std::nan(""); }},
      {"dds.pose_tolerance_s", [](DdsConfig* c) { c->pose_tolerance_s = 0.0; }},
      {"dds.pose_buffer_s", [](DdsConfig* c) { c->pose_buffer_s = -1.0; }},
      {"dds.max_future_s", [](DdsConfig* c) { c->max_future_s = std::nan(""); }},
      {"dds.esdf_slice_height_m",
       [](DdsConfig* c) { c->esdf_slice_height_m = std::numeric_limits<double>::infinity(); }},
      {"dds.fleet.rate_hz", [](DdsConfig* c) { c->fleet.rate_hz = std::nan(""); }},
      {"dds.fleet.rate_hz",
       [](DdsConfig* c) {
         c->fleet.publish = true;
         c->fleet.vehicle = "uav1";
         c->fleet.rate_hz = 0.0;
       }},
      {"dds.fleet.topic", [](DdsConfig* c) { c->fleet.topic = "mlmap//submaps"; }},
      {"dds.fleet.vehicle", [](DdsConfig* c) { c->fleet.vehicle = "uav 1"; }},
      {"dds.fleet.vehicle", [](DdsConfig* c) { c->fleet.publish = true; }},  // no name, no ns
  };
  for (const Case& test : cases) {
    DdsConfig config;
    test.spoil(&config);
    const std::vector<std::string> problems = config.validate();
    ASSERT_EQ(problems.size(), 1u) << test.key;
    EXPECT_EQ(problems[0].rfind(std::string(test.key) + ":", 0), 0u) << problems[0];
  }
}

TEST(DdsConfig, TheFleetVehicleIsItsNameElseTheNamespace) {
  DdsConfig config;
  config.ns = "/uav3";
  EXPECT_EQ(resolveFleetVehicle(config), "uav3");
  config.fleet.publish = true;
  EXPECT_TRUE(config.validate().empty());
  config.fleet.vehicle = "scout";
  EXPECT_EQ(resolveFleetVehicle(config), "scout");
}

TEST(DdsConfig, AcceptsTheValuesItDocuments) {
  DdsConfig config;
  config.domain_id = 232;
  config.ns = "/fleet/uav_1";
  config.discovery_range = "localhost";
  config.profiles_file = "config/dds/loopback.xml";
  config.participant_profile = "mlmap_loopback";
  config.topics.cloud = "/camera/depth/points";
  config.topics.odometry = "odom";
  config.topics.depth_image = "camera/depth/image_rect_raw";
  config.topics.camera_info = "camera/depth/camera_info";
  config.topics.status = "";         // disabled
  config.rates.global_map_hz = 0.0;  // disabled
  config.esdf_slice_height_m = -0.5;
  EXPECT_TRUE(config.validate().empty());
  config.domain_id = 0;
  EXPECT_TRUE(config.validate().empty());
  config.domain_id = -1;
  EXPECT_TRUE(config.validate().empty());
}

TEST(DdsConfig, SeveralProblemsAreReportedTogether) {
  DdsConfig config;
  config.domain_id = 500;
  config.rates.grid_hz = -1.0;
  config.world_frame = "";
  EXPECT_EQ(config.validate().size(), 3u);
  EXPECT_TRUE(hasProblem(config, "dds.domain_id"));
  EXPECT_TRUE(hasProblem(config, "dds.rates.grid_hz"));
  EXPECT_TRUE(hasProblem(config, "dds.world_frame"));
  EXPECT_NE(config.validate()[0].find("got 500"), std::string::npos);
}

TEST(DdsConfig, DiscoveryRangeParsesCaseInsensitivelyAndPrintsBack) {
  const DiscoveryRange all[] = {DiscoveryRange::kSystemDefault, DiscoveryRange::kLocalhost,
                                DiscoveryRange::kSubnet, DiscoveryRange::kOff};
  for (DiscoveryRange range : all) {
    DiscoveryRange parsed = DiscoveryRange::kOff;
    if (range == DiscoveryRange::kOff) parsed = DiscoveryRange::kLocalhost;
    ASSERT_TRUE(parseDiscoveryRange(toString(range), &parsed)) << toString(range);
    EXPECT_EQ(parsed, range);
  }
  DiscoveryRange parsed = DiscoveryRange::kOff;
  EXPECT_TRUE(parseDiscoveryRange("localHost", &parsed));
  EXPECT_EQ(parsed, DiscoveryRange::kLocalhost);
  EXPECT_TRUE(parseDiscoveryRange("subnet", &parsed));
  EXPECT_EQ(parsed, DiscoveryRange::kSubnet);
  EXPECT_FALSE(parseDiscoveryRange("", &parsed));
  EXPECT_FALSE(parseDiscoveryRange("LOCAL", &parsed));
  EXPECT_FALSE(parseDiscoveryRange("LOCALHOST ", &parsed));
  EXPECT_EQ(parsed, DiscoveryRange::kSubnet);  // untouched on failure
  EXPECT_STREQ(toString(DiscoveryRange::kLocalhost), "LOCALHOST");
}

TEST(DdsTopicName, FollowsRos2Mangling) {
  EXPECT_EQ(ddsTopicName("", "cloud"), "rt/cloud");
  EXPECT_EQ(ddsTopicName("uav1", "cloud"), "rt/uav1/cloud");
  EXPECT_EQ(ddsTopicName("/uav1", "/cloud"), "rt/uav1/cloud");
  EXPECT_EQ(ddsTopicName("/uav1/", "mlmap/grid"), "rt/uav1/mlmap/grid");
  EXPECT_EQ(ddsTopicName("fleet//uav1", "mlmap//awareness/occupied"),
            "rt/fleet/uav1/mlmap/awareness/occupied");
  EXPECT_EQ(ddsTopicName("", "/tf_static"), "rt/tf_static");
  EXPECT_EQ(ddsTopicName("/", "tf"), "rt/tf");
}

TEST(ResolveDomainId, ConfigThenEnvironmentThenZero) {
  DdsConfig config;
  {
    ScopedEnv env("ROS_DOMAIN_ID", std::nullopt);
    EXPECT_EQ(resolveDomainId(config), 0);
  }
  {
    ScopedEnv env("ROS_DOMAIN_ID", "");
    EXPECT_EQ(resolveDomainId(config), 0);  // empty counts as unset (as in ROS 2)
  }
  {
    ScopedEnv env("ROS_DOMAIN_ID", "42");
    EXPECT_EQ(resolveDomainId(config), 42);
    config.domain_id = 7;
    EXPECT_EQ(resolveDomainId(config), 7);  // the config wins
    config.domain_id = 0;
    EXPECT_EQ(resolveDomainId(config), 0);
    config.domain_id = -1;
  }
  {
    ScopedEnv env("ROS_DOMAIN_ID", "232");
    EXPECT_EQ(resolveDomainId(config), 232);
  }
}

TEST(ResolveDomainId, InvalidEnvironmentValueIsAnErrorNamingTheVariable) {
  DdsConfig config;
  for (const char* bad : {"abc", "12x", "-1", "233", "1e3", "99999999999999999999"}) {
    ScopedEnv env("ROS_DOMAIN_ID", std::string(bad));
    try {
      resolveDomainId(config);
      ADD_FAILURE() << "accepted ROS_DOMAIN_ID=" << bad;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("ROS_DOMAIN_ID"), std::string::npos);
      EXPECT_NE(std::string(e.what()).find(bad), std::string::npos);
    }
  }
  // A valid config value does not read the environment at all.
  ScopedEnv env("ROS_DOMAIN_ID", "abc");
  config.domain_id = 3;
  EXPECT_EQ(resolveDomainId(config), 3);
}

TEST(ResolveDiscoveryRange, ConfigThenEnvironmentThenSubnetAsRcl) {
  DdsConfig config;
  {
    ScopedEnv env("ROS_AUTOMATIC_DISCOVERY_RANGE", std::nullopt);
    EXPECT_EQ(resolveDiscoveryRange(config), DiscoveryRange::kSubnet);
    config.discovery_range = "SYSTEM_DEFAULT";
    EXPECT_EQ(resolveDiscoveryRange(config), DiscoveryRange::kSystemDefault);
    config.discovery_range = "";
  }
  {
    ScopedEnv env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST");
    EXPECT_EQ(resolveDiscoveryRange(config), DiscoveryRange::kLocalhost);
    config.discovery_range = "OFF";
    EXPECT_EQ(resolveDiscoveryRange(config), DiscoveryRange::kOff);
    config.discovery_range = "";
  }
  {
    ScopedEnv env("ROS_AUTOMATIC_DISCOVERY_RANGE", "subnet");
    EXPECT_EQ(resolveDiscoveryRange(config), DiscoveryRange::kSubnet);
  }
  {
    ScopedEnv env("ROS_AUTOMATIC_DISCOVERY_RANGE", "EVERYWHERE");
    try {
      resolveDiscoveryRange(config);
      ADD_FAILURE() << "accepted ROS_AUTOMATIC_DISCOVERY_RANGE=EVERYWHERE";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("ROS_AUTOMATIC_DISCOVERY_RANGE"), std::string::npos);
    }
    config.discovery_range = "LAN";
    EXPECT_THROW(resolveDiscoveryRange(config), std::invalid_argument);
  }
}

}  // namespace
}  // namespace mlmap::dds
