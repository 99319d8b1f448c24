#pragma once
/// @file
/// ROS 2 type hashes (REP-2011, "RIHS01_" + SHA-256 of the type description) of the types in
/// idl/, computed at build time by tools/idl_type_hashes.py, and the USER_DATA that carries them
/// on an endpoint as rmw does since Iron.

#include <cstdint>
#include <string>
#include <vector>

namespace mlmap::dds {

/// The ROS 2 type hash of a DDS type name of idl/ (e.g. "std_msgs::msg::dds_::Header_" ->
/// "RIHS01_f49f..."), or "" when idl/ defines no such type.
std::string rosTypeHash(const std::string& dds_type_name);

/// The USER_DATA rmw_fastrtps_cpp gives an endpoint of `dds_type_name`:
/// "typehash=RIHS01_<64 hex>;" as bytes; empty when idl/ defines no such type (rmw then sends
/// none either, and ROS tools show the hash as unknown).
std::vector<std::uint8_t> rosEndpointUserData(const std::string& dds_type_name);

}  // namespace mlmap::dds
