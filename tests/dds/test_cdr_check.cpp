// CDR payloads checked against idl/'s layouts before Fast CDR deserialises them
// (mlmap/dds/wire/cdr_check.h, CheckedType in mlmap/dds/transport/entities.h): the walker agrees
// with Fast CDR's generated code on random messages of every IDL type, refuses truncated payloads
// and counts the payload cannot hold at every nesting level, and a sample declaring millions of
// elements is refused before anything is allocated (issue 43, item 10). This binary counts every
// allocation (../support/allocation_counter.cpp replaces operator new).

#include <fastdds/rtps/common/SerializedPayload.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "../support/allocation_counter.h"
#include "mlmap/dds/wire/cdr_check.h"
#include "mlmap/dds/wire/cloud_sample.h"
#include "mlmap/dds/transport/entities.h"
#include "mlmap_idl_types.h"  // every struct's generated Fast DDS type, generated from idl/

namespace mlmap::dds {
namespace {

using test_support::AllocationScope;
using Bytes = std::vector<std::uint8_t>;

/// Where a payload written by RandomCdr holds a sequence count.
struct CountSite {
  std::size_t offset = 0;               ///< byte offset of the uint32 count in the payload
  std::uint64_t min_element_bytes = 0;  ///< least bytes one element takes
  std::uint32_t bound = 0;              ///< the sequence's bound (0: unbounded)
  std::string member;                   ///< its member name
};

/// The least bytes one value of `m` takes on the wire.
std::uint64_t minValueBytes(const CdrMemberLayout& m) {
  switch (m.kind) {
    case CdrValueKind::kNumber:
      return m.number_bytes;
    case CdrValueKind::kString:
      return 4;
    case CdrValueKind::kStruct:
      return m.type->min_bytes;
  }
  return 1;
}

/// Writes a random valid payload of a layout, independently of Fast CDR: numbers aligned to
/// their size after the 4-byte header, nothing aligned for an empty sequence, strings with their
/// NUL, sequences within their bound. One-byte numbers are 0 or 1 (valid bools), wider ones never
/// NaN (so a copy keeps their bytes).
class RandomCdr {
 public:
  RandomCdr(std::mt19937_64* rng, bool big_endian)
      : rng_(rng),
        big_(big_endian),
        bytes_{0x00, big_endian ? std::uint8_t{0x00} : std::uint8_t{0x01}, 0x00, 0x00} {}

  void writeStruct(const CdrStructLayout& layout, int depth) {
    for (std::size_t i = 0; i < layout.member_count; ++i) writeMember(layout.members[i], depth);
  }

  [[nodiscard]] const Bytes& bytes() const { return bytes_; }
  [[nodiscard]] const std::vector<CountSite>& sites() const { return sites_; }

 private:
  std::uint32_t below(std::uint32_t n) {
    return n == 0 ? 0 : static_cast<std::uint32_t>((*rng_)() % n);
  }

  void align(std::size_t n) {
    while ((bytes_.size() - 4) % n != 0) bytes_.push_back(0);
  }

  void u32(std::uint32_t v) {
    align(4);
    for (int i = 0; i < 4; ++i) {
      const int shift = 8 * (big_ ? 3 - i : i);
      bytes_.push_back(static_cast<std::uint8_t>((v >> shift) & 0xFFU));
    }
  }

  void numbers(std::uint8_t size, std::uint64_t count) {
    if (count == 0) return;
    align(size);
    for (std::uint64_t i = 0; i < count * size; ++i) {
      bytes_.push_back(static_cast<std::uint8_t>(size == 1 ? below(2) : below(0x40)));
    }
  }

  void string(std::uint32_t bound) {
    const std::uint32_t most = bound > 0 ? std::min<std::uint32_t>(bound, 12) : 12;
    const std::uint32_t length = below(most + 1);
    u32(length + 1);
    for (std::uint32_t i = 0; i < length; ++i)
      bytes_.push_back(static_cast<std::uint8_t>('a' + below(26)));
    bytes_.push_back(0);
  }

  void values(const CdrMemberLayout& m, std::uint64_t count, int depth) {
    switch (m.kind) {
      case CdrValueKind::kNumber:
        numbers(m.number_bytes, count);
        return;
      case CdrValueKind::kString:
        for (std::uint64_t i = 0; i < count; ++i) string(m.string_bound);
        return;
      case CdrValueKind::kStruct:
        for (std::uint64_t i = 0; i < count; ++i) writeStruct(*m.type, depth + 1);
        return;
    }
  }

  void writeMember(const CdrMemberLayout& m, int depth) {
    switch (m.container) {
      case CdrContainer::kSingle:
        values(m, 1, depth);
        return;
      case CdrContainer::kArray:
        values(m, m.count, depth);
        return;
      case CdrContainer::kSequence: {
        std::uint32_t most = m.kind == CdrValueKind::kNumber ? 40 : (depth < 2 ? 4 : 1);
        if (m.count > 0) most = std::min(most, m.count);
        const std::uint32_t count = below(most + 1);
        align(4);
        sites_.push_back({bytes_.size(), minValueBytes(m), m.count, m.name});
        u32(count);
        values(m, count, depth);
        return;
      }
    }
  }

  std::mt19937_64* rng_;
  bool big_;
  Bytes bytes_;
  std::vector<CountSite> sites_;
};

eprosima::fastrtps::rtps::SerializedPayload_t payloadOf(const Bytes& bytes) {
  eprosima::fastrtps::rtps::SerializedPayload_t payload(static_cast<std::uint32_t>(bytes.size()));
  if (!bytes.empty()) std::memcpy(payload.data, bytes.data(), bytes.size());
  payload.length = static_cast<std::uint32_t>(bytes.size());
  return payload;
}

/// Fast CDR's generated code reading `bytes`: false when it refuses them (returns false or throws).
template <typename PubSubType>
bool fastCdrReads(const Bytes& bytes, typename PubSubType::type* msg) {
  PubSubType type;
  auto payload = payloadOf(bytes);
  try {
    return type.deserialize(&payload, msg);
  } catch (const std::exception&) {
    return false;
  }
}

/// Fast CDR's generated code writing `msg`.
template <typename PubSubType>
Bytes fastCdrWrites(typename PubSubType::type* msg) {
  PubSubType type;
  eprosima::fastrtps::rtps::SerializedPayload_t payload(type.getSerializedSizeProvider(msg)());
  EXPECT_TRUE(type.serialize(msg, &payload));
  return Bytes(payload.data, payload.data + payload.length);
}

const CdrStructLayout& layoutOf(const char* dds_type) {
  const CdrStructLayout* layout = cdrLayoutOf(dds_type);
  if (layout == nullptr) throw std::runtime_error(std::string("no layout for ") + dds_type);
  return *layout;
}

/// Calls `f.template operator()<PubSubType>()` for every struct of idl/.
template <typename F, std::size_t... I>
void forEachTypeImpl(F&& f, std::index_sequence<I...>) {
  (f(static_cast<std::tuple_element_t<I, generated::IdlPubSubTypes>*>(nullptr)), ...);
}
template <typename F>
void forEachIdlType(F&& f) {
  forEachTypeImpl(std::forward<F>(f),
                  std::make_index_sequence<std::tuple_size_v<generated::IdlPubSubTypes>>());
}

TEST(CdrCheck, EveryIdlStructHasALayoutUnderItsGeneratedTypesName) {
  std::size_t count = 0;
  const CdrStructLayout* const* layouts = cdrLayouts(&count);
  ASSERT_EQ(count, std::tuple_size_v<generated::IdlPubSubTypes>);
  std::size_t i = 0;
  forEachIdlType([&](auto* tag) {
    using PubSubType = std::remove_pointer_t<decltype(tag)>;
    PubSubType type;
    EXPECT_STREQ(layouts[i]->dds_type, type.getName());
    EXPECT_EQ(cdrLayoutOf(type.getName()), layouts[i]);
    ++i;
  });
  EXPECT_EQ(cdrLayoutOf("tf2_msgs::msg::dds_::NoSuchType_"), nullptr);
  // The figure the issue's refusal quotes: TransformStamped takes at least 72 bytes.
  EXPECT_EQ(layoutOf("geometry_msgs::msg::dds_::TransformStamped_").min_bytes, 72U);
}

TEST(CdrCheck, AgreesWithFastCdrOnRandomMessagesOfEveryType) {
  std::mt19937_64 rng(43);
  forEachIdlType([&](auto* tag) {
    using PubSubType = std::remove_pointer_t<decltype(tag)>;
    const CdrStructLayout& layout = layoutOf(PubSubType().getName());
    SCOPED_TRACE(layout.dds_type);
    // What Fast CDR writes for the default message is accepted, every byte used.
    typename PubSubType::type empty;
    const Bytes written = fastCdrWrites<PubSubType>(&empty);
    const CdrCheck empty_check = checkCdrPayload(layout, written.data(), written.size());
    EXPECT_TRUE(empty_check.ok) << empty_check.error;
    EXPECT_EQ(empty_check.consumed_bytes, written.size());
    for (int trial = 0; trial < 40; ++trial) {
      const bool big_endian = trial % 4 == 3;
      RandomCdr random(&rng, big_endian);
      random.writeStruct(layout, 0);
      const Bytes& bytes = random.bytes();
      const CdrCheck check = checkCdrPayload(layout, bytes.data(), bytes.size());
      ASSERT_TRUE(check.ok) << check.error;
      ASSERT_EQ(check.consumed_bytes, bytes.size());
      // Fast CDR reads the same bytes and writes them back identically (little endian: the
      // same bytes; big endian: as many bytes, which the walker takes all of).
      typename PubSubType::type msg;
      ASSERT_TRUE(fastCdrReads<PubSubType>(bytes, &msg)) << "trial " << trial;
      const Bytes again = fastCdrWrites<PubSubType>(&msg);
      if (!big_endian) {
        ASSERT_EQ(again, bytes) << "trial " << trial;
      } else {
        ASSERT_EQ(again.size(), bytes.size());
        EXPECT_EQ(checkCdrPayload(layout, again.data(), again.size()).consumed_bytes, again.size());
      }
      // Bytes after the value (a writer's padding) are allowed, as Fast CDR allows them.
      Bytes padded = bytes;
      padded.insert(padded.end(), 3, 0);
      EXPECT_EQ(checkCdrPayload(layout, padded.data(), padded.size()).consumed_bytes, bytes.size());
    }
  });
}

TEST(CdrCheck, RefusesEveryTruncationAsFastCdrDoes) {
  std::mt19937_64 rng(44);
  forEachIdlType([&](auto* tag) {
    using PubSubType = std::remove_pointer_t<decltype(tag)>;
    const CdrStructLayout& layout = layoutOf(PubSubType().getName());
    SCOPED_TRACE(layout.dds_type);
    CheckedType<PubSubType> checked;
    for (int trial = 0; trial < 3; ++trial) {
      RandomCdr random(&rng, trial == 2);
      random.writeStruct(layout, 0);
      const Bytes& bytes = random.bytes();
      for (std::size_t size = 0; size < bytes.size(); ++size) {
        const Bytes cut(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(size));
        EXPECT_FALSE(checkCdrPayload(layout, cut.data(), cut.size()).ok) << size << " bytes";
        typename PubSubType::type msg;
        EXPECT_FALSE(fastCdrReads<PubSubType>(cut, &msg)) << "Fast CDR took " << size << " bytes";
        auto payload = payloadOf(cut);
        EXPECT_FALSE(checked.deserialize(&payload, &msg));
      }
    }
  });
}

TEST(CdrCheck, RefusesCountsThePayloadCannotHoldAtEveryNestingLevelBeforeAllocating) {
  std::mt19937_64 rng(45);
  std::size_t sites_tried = 0;
  forEachIdlType([&](auto* tag) {
    using PubSubType = std::remove_pointer_t<decltype(tag)>;
    const CdrStructLayout& layout = layoutOf(PubSubType().getName());
    SCOPED_TRACE(layout.dds_type);
    CheckedType<PubSubType> checked;
    for (int trial = 0; trial < 4; ++trial) {
      RandomCdr random(&rng, trial == 3);
      random.writeStruct(layout, 0);
      for (const CountSite& site : random.sites()) {
        SCOPED_TRACE("sequence " + site.member + " at byte " + std::to_string(site.offset));
        ++sites_tried;
        // The largest count: refused by the walker whatever the element.
        Bytes hostile = random.bytes();
        std::memset(hostile.data() + site.offset, 0xFF, 4);
        const CdrCheck check = checkCdrPayload(layout, hostile.data(), hostile.size());
        EXPECT_FALSE(check.ok);
        EXPECT_NE(check.error.find("`"), std::string::npos) << check.error;
        EXPECT_NE(check.error.find("declares 4294967295 elements"), std::string::npos)
            << check.error;
        // The count Fast CDR's own check lets through (one byte per element), in a payload of
        // 256 KB: Fast CDR would allocate count x sizeof(element), many times the payload.
        // Checked first, nothing beyond the payload's size is allocated.
        hostile = random.bytes();
        hostile.resize(hostile.size() + 256 * 1024, 0);
        const std::size_t after_count = hostile.size() - site.offset - 4;
        const auto count = static_cast<std::uint32_t>(after_count);
        const bool big = hostile[1] == 0;
        for (int i = 0; i < 4; ++i) {
          hostile[site.offset + static_cast<std::size_t>(i)] =
              static_cast<std::uint8_t>((count >> (8 * (big ? 3 - i : i))) & 0xFFU);
        }
        auto payload = payloadOf(hostile);
        typename PubSubType::type msg;
        bool taken = false;
        std::size_t peak_bytes = 0;
        {
          AllocationScope scope(2 * hostile.size());
          taken = checked.deserialize(&payload, &msg);
          peak_bytes = scope.peakBytes();
          EXPECT_FALSE(scope.capHit()) << "refused an allocation of " << scope.largestRefusedBytes()
                                       << " bytes for a payload of " << hostile.size();
        }
        EXPECT_LE(peak_bytes, 2 * hostile.size());
        if (site.min_element_bytes > 1 || site.bound > 0) {
          EXPECT_FALSE(taken);
          EXPECT_NE(
              detail::deserializeError().find("declares " + std::to_string(count) + " elements"),
              std::string::npos)
              << detail::deserializeError();
        }
      }
    }
  });
  EXPECT_GT(sites_tried, 200U);
}

/// A tf2_msgs/TFMessage payload that declares `count` transforms and holds `body_bytes` zero
/// bytes after the count: the issue's sample is 16,777,216 transforms in 16 MB.
Bytes hostileTf(std::uint32_t count, std::size_t body_bytes) {
  Bytes bytes{0x00, 0x01, 0x00, 0x00};
  for (int i = 0; i < 4; ++i)
    bytes.push_back(static_cast<std::uint8_t>((count >> (8 * i)) & 0xFFU));
  bytes.resize(bytes.size() + body_bytes, 0);
  return bytes;
}

TEST(CdrCheck, IssueTfSampleDeclaringMillionsOfTransformsIsRefusedBeforeAllocation) {
  // Issue 43 item 10: 16 MB claiming 16.7 M transforms cost a 2.15 GB peak before the refusal.
  const Bytes bytes = hostileTf(16777216U, 16U * 1024 * 1024);
  CheckedType<::tf2_msgs::msg::dds_::TFMessage_PubSubType> type;  // what the node's /tf readers use
  auto payload = payloadOf(bytes);
  ::tf2_msgs::msg::dds_::TFMessage_ msg;
  detail::deserializeFailed() = false;
  bool taken = true;
  std::size_t peak_bytes = 0;
  {
    // Capped at 64 MB, so the old code fails here without taking its 2 GB.
    AllocationScope scope(64U * 1024 * 1024);
    taken = type.deserialize(&payload, &msg);
    peak_bytes = scope.peakBytes();
    EXPECT_FALSE(scope.capHit()) << "refused an allocation of " << scope.largestRefusedBytes()
                                 << " bytes";
  }
  EXPECT_FALSE(taken);
  EXPECT_TRUE(detail::deserializeFailed());
  EXPECT_EQ(
      detail::deserializeError(),
      "tf2_msgs::msg::dds_::TFMessage_ `transforms`: sequence declares 16777216 elements of >= 72 "
      "bytes, 16777216 bytes remain");
  EXPECT_LT(peak_bytes, 4096U);  // the error message, no more
  std::printf(
      "16 MB /tf sample declaring 16777216 transforms: refused, peak allocation %zu bytes\n",
      peak_bytes);
  // A count the bytes could hold at 72 bytes per transform is walked, and refused where the bytes
  // run out (zeroed transforms take 76 or 80 bytes with their padding).
  const Bytes short_tf = hostileTf(1000U, 1000U * 72U);
  const CdrCheck check = checkCdrPayload(layoutOf("tf2_msgs::msg::dds_::TFMessage_"),
                                         short_tf.data(), short_tf.size());
  EXPECT_FALSE(check.ok);
  EXPECT_NE(check.error.find("`transforms[9"), std::string::npos) << check.error;
  EXPECT_NE(check.error.find("truncated at byte"), std::string::npos) << check.error;
}

TEST(CdrCheck, CloudSampleFieldsCountIsCheckedToo) {
  // The node's own PointCloud2 decoder (CloudSamplePubSubType) reads `fields` with Fast CDR.
  Bytes bytes{0x00, 0x01, 0x00, 0x00};
  const auto put32 = [&](std::uint32_t v) {
    while ((bytes.size() - 4) % 4 != 0) bytes.push_back(0);
    for (int i = 0; i < 4; ++i) bytes.push_back(static_cast<std::uint8_t>((v >> (8 * i)) & 0xFFU));
  };
  put32(0);  // stamp.sec
  put32(0);  // stamp.nanosec
  put32(1);  // frame_id: "" with its NUL
  bytes.push_back(0);
  put32(1);  // height
  put32(1);  // width
  const std::size_t body_bytes = 4U * 1024 * 1024;
  put32(static_cast<std::uint32_t>(body_bytes));  // fields: as many as there are bytes
  bytes.resize(bytes.size() + body_bytes, 0);
  CheckedType<CloudSamplePubSubType> type;
  auto payload = payloadOf(bytes);
  CloudSample sample;
  bool taken = true;
  {
    AllocationScope scope(2 * bytes.size());
    taken = type.deserialize(&payload, &sample);
    EXPECT_FALSE(scope.capHit()) << "refused an allocation of " << scope.largestRefusedBytes()
                                 << " bytes";
    EXPECT_LT(scope.peakBytes(), 4096U);
  }
  EXPECT_FALSE(taken);
  EXPECT_NE(detail::deserializeError().find(
                "`fields`: sequence declares 4194304 elements of >= 13 bytes"),
            std::string::npos)
      << detail::deserializeError();
}

TEST(CdrCheck, NamesTheFailingMemberAndRefusesBoundsAndEncapsulations) {
  const CdrStructLayout& tf = layoutOf("tf2_msgs::msg::dds_::TFMessage_");
  std::mt19937_64 rng(46);
  // Two transforms, the second's frame_id claiming more bytes than remain.
  ::tf2_msgs::msg::dds_::TFMessage_ msg;
  msg.transforms_().resize(2);
  msg.transforms_()[1].header_().frame_id_("odom");
  Bytes bytes = fastCdrWrites<::tf2_msgs::msg::dds_::TFMessage_PubSubType>(&msg);
  ASSERT_TRUE(checkCdrPayload(tf, bytes.data(), bytes.size()).ok);
  const Bytes odom{5,   0,   0,   0, 'o',
                   'd', 'o', 'm', 0};  // "odom": its length with the NUL, its bytes
  const auto at = std::search(bytes.begin(), bytes.end(), odom.begin(), odom.end());
  ASSERT_NE(at, bytes.end());
  *at = 0xF0;
  CdrCheck check = checkCdrPayload(tf, bytes.data(), bytes.size());
  EXPECT_FALSE(check.ok);
  EXPECT_NE(check.error.find("`transforms[1].header.frame_id`: string of 240 bytes"),
            std::string::npos)
      << check.error;

  // A bounded sequence (ParameterDescriptor's floating_point_range, at most 1) and a bounded
  // string (NodeEntitiesInfo's node_name, at most 256 characters) past their bound.
  ::rcl_interfaces::msg::dds_::ParameterDescriptor_ descriptor;
  descriptor.floating_point_range_().resize(2);
  Bytes over =
      fastCdrWrites<::rcl_interfaces::msg::dds_::ParameterDescriptor_PubSubType>(&descriptor);
  check = checkCdrPayload(layoutOf("rcl_interfaces::msg::dds_::ParameterDescriptor_"), over.data(),
                          over.size());
  EXPECT_FALSE(check.ok);
  EXPECT_NE(
      check.error.find("`floating_point_range`: sequence declares 2 elements, its bound is 1"),
      std::string::npos)
      << check.error;
  // "" (its length, its NUL, padding), then a length of 258.
  Bytes name{0x00, 0x01, 0x00, 0x00, 1, 0, 0, 0, 0, 0, 0, 0, 0x02, 0x01, 0x00, 0x00};
  name.resize(name.size() + 258 + 8, 'a');
  check = checkCdrPayload(layoutOf("rmw_dds_common::msg::dds_::NodeEntitiesInfo_"), name.data(),
                          name.size());
  EXPECT_FALSE(check.ok);
  EXPECT_NE(check.error.find("`node_name`: string of 258 bytes, its bound is 256 characters"),
            std::string::npos)
      << check.error;

  // Encapsulations: too short, a non-zero first byte, an unknown kind are refused; PL_CDR is read
  // as plain CDR, as Fast CDR's generated code reads it.
  const CdrStructLayout& time = layoutOf("builtin_interfaces::msg::dds_::Time_");
  Bytes stamp{0x00, 0x01, 0x00, 0x00, 1, 0, 0, 0, 2, 0, 0, 0};
  EXPECT_TRUE(checkCdrPayload(time, stamp.data(), stamp.size()).ok);
  EXPECT_FALSE(checkCdrPayload(time, stamp.data(), 3).ok);
  EXPECT_EQ(checkCdrPayload(time, stamp.data(), 3).error,
            "payload of 3 bytes has no encapsulation header");
  stamp[0] = 1;
  EXPECT_FALSE(checkCdrPayload(time, stamp.data(), stamp.size()).ok);
  stamp[0] = 0;
  stamp[1] = 4;
  EXPECT_FALSE(checkCdrPayload(time, stamp.data(), stamp.size()).ok);
  stamp[1] = 3;
  EXPECT_TRUE(checkCdrPayload(time, stamp.data(), stamp.size()).ok);
  (void)rng;
}

/// A generated type under a name idl/ does not have.
class UnknownType : public ::builtin_interfaces::msg::dds_::Time_PubSubType {
 public:
  UnknownType() { setName("mlmap_msgs::msg::dds_::NotInIdl_"); }
};

TEST(CdrCheck, CheckedTypeRefusesATypeWithoutLayout) {
  EXPECT_THROW(CheckedType<UnknownType>(), std::runtime_error);
}

TEST(CdrCheck, CostOnLargeValidMessages) {
  // 100,000 transforms (about 10 MB): the walker visits every element; a 4.9 MB cloud: its data
  // are skipped in O(1).
  ::tf2_msgs::msg::dds_::TFMessage_ tf;
  tf.transforms_().resize(100000);
  for (std::size_t i = 0; i < tf.transforms_().size(); ++i) {
    tf.transforms_()[i].header_().frame_id_("map");
    tf.transforms_()[i].child_frame_id_("robot_" + std::to_string(i));
  }
  const Bytes bytes = fastCdrWrites<::tf2_msgs::msg::dds_::TFMessage_PubSubType>(&tf);
  const CdrStructLayout& layout = layoutOf("tf2_msgs::msg::dds_::TFMessage_");
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  const CdrCheck check = checkCdrPayload(layout, bytes.data(), bytes.size());
  const auto t1 = Clock::now();
  ::tf2_msgs::msg::dds_::TFMessage_ back;
  ASSERT_TRUE(fastCdrReads<::tf2_msgs::msg::dds_::TFMessage_PubSubType>(bytes, &back));
  const auto t2 = Clock::now();
  ASSERT_TRUE(check.ok) << check.error;
  EXPECT_EQ(check.consumed_bytes, bytes.size());
  const double mb = static_cast<double>(bytes.size()) / 1e6;
  const double walk_ms = std::chrono::duration<double, std::milli>(t1 - t0).count();
  const double read_ms = std::chrono::duration<double, std::milli>(t2 - t1).count();
  std::printf(
      "TFMessage of %.1f MB (100000 transforms): walker %.2f ms (%.2f ms/MB), Fast CDR %.2f ms\n",
      mb, walk_ms, walk_ms / mb, read_ms);

  ::sensor_msgs::msg::dds_::PointCloud2_ cloud;
  cloud.data_().resize(640U * 480U * 16U);
  const Bytes cloud_bytes = fastCdrWrites<::sensor_msgs::msg::dds_::PointCloud2_PubSubType>(&cloud);
  const auto t3 = Clock::now();
  const CdrCheck cloud_check = checkCdrPayload(layoutOf("sensor_msgs::msg::dds_::PointCloud2_"),
                                               cloud_bytes.data(), cloud_bytes.size());
  const auto t4 = Clock::now();
  ASSERT_TRUE(cloud_check.ok) << cloud_check.error;
  EXPECT_EQ(cloud_check.consumed_bytes, cloud_bytes.size());
  std::printf("PointCloud2 of %.1f MB: walker %.4f ms\n",
              static_cast<double>(cloud_bytes.size()) / 1e6,
              std::chrono::duration<double, std::milli>(t4 - t3).count());
}

}  // namespace
}  // namespace mlmap::dds
