#include "mlmap/dds/wire/type_hash.h"

#include "mlmap_type_hashes.h"  // generated from idl/ at build time

#include <string_view>

namespace mlmap::dds {

std::string rosTypeHash(const std::string& dds_type_name) {
  for (const generated::TypeHashEntry& entry : generated::kTypeHashes) {
    if (std::string_view(entry.dds_type) == dds_type_name) return entry.hash;
  }
  return {};
}

std::vector<std::uint8_t> rosEndpointUserData(const std::string& dds_type_name) {
  const std::string hash = rosTypeHash(dds_type_name);
  if (hash.empty()) return {};
  const std::string text = "typehash=" + hash + ";";
  return {text.begin(), text.end()};
}

}  // namespace mlmap::dds
