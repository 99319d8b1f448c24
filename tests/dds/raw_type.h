#pragma once
// A DDS type that puts caller-given bytes on the wire under any type name: the malformed samples
// a broken or hostile writer could send on a real topic (the type name is all that matching
// checks).

#include <fastdds/dds/topic/TopicDataType.hpp>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace mlmap::dds::test_support {

/// The sample of RawType: the whole serialized payload, encapsulation header included.
using RawBytes = std::vector<std::uint8_t>;

/// Writes RawBytes unchanged; never reads.
class RawType : public eprosima::fastdds::dds::TopicDataType {
 public:
  RawType(const std::string& type_name, std::uint32_t max_bytes) {
    setName(type_name.c_str());
    m_typeSize = max_bytes;
    m_isGetKeyDefined = false;
  }
  bool serialize(void* data, eprosima::fastrtps::rtps::SerializedPayload_t* payload) override {
    const RawBytes& bytes = *static_cast<const RawBytes*>(data);
    if (bytes.size() > payload->max_size) return false;
    std::memcpy(payload->data, bytes.data(), bytes.size());
    payload->length = static_cast<std::uint32_t>(bytes.size());
    payload->encapsulation = bytes.size() > 1 && bytes[1] == 0 ? CDR_BE : CDR_LE;
    return true;
  }
  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t*, void*) override { return false; }
  std::function<std::uint32_t()> getSerializedSizeProvider(void* data) override {
    return
        [data] { return static_cast<std::uint32_t>(static_cast<const RawBytes*>(data)->size()); };
  }
  void* createData() override { return new RawBytes(); }
  void deleteData(void* data) override { delete static_cast<RawBytes*>(data); }
  bool getKey(void*, eprosima::fastrtps::rtps::InstanceHandle_t*, bool) override { return false; }
};

/// Little-endian CDR payload builder (encapsulation CDR_LE, 4-byte header).
class CdrBytes {
 public:
  CdrBytes() : bytes_{0x00, 0x01, 0x00, 0x00} {}
  CdrBytes& u8(std::uint8_t v) { return put(&v, 1, 1); }
  CdrBytes& u32(std::uint32_t v) { return put(&v, 4, 4); }
  CdrBytes& i32(std::int32_t v) { return put(&v, 4, 4); }
  CdrBytes& f64(double v) { return put(&v, 8, 8); }
  CdrBytes& str(const std::string& s) {
    u32(static_cast<std::uint32_t>(s.size() + 1));
    return put(s.c_str(), s.size() + 1, 1);
  }
  [[nodiscard]] const RawBytes& bytes() const { return bytes_; }

 private:
  CdrBytes& put(const void* v, std::size_t n, std::size_t align) {
    while ((bytes_.size() - 4) % align != 0) bytes_.push_back(0);  // CDR aligns after the header
    const auto* p = static_cast<const std::uint8_t*>(v);
    bytes_.insert(bytes_.end(), p, p + n);
    return *this;
  }
  RawBytes bytes_;
};

}  // namespace mlmap::dds::test_support
