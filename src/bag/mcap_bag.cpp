#include "mlmap/bag/bag_reader.h"
#include "mlmap/bag/mcap.h"

#include <map>
#include <stdexcept>

namespace mlmap::bag {
namespace {

/// An MCAP file through BagReader: channels with the same topic and type are one topic.
class McapBag : public BagReader {
 public:
  explicit McapBag(const std::string& path) : mcap_(path) {
    std::map<std::uint16_t, std::size_t> topic_of_channel;
    for (const auto& [id, channel] : mcap_.channels()) {
      TopicInfo info;
      info.name = channel.topic;
      const auto schema = mcap_.schemas().find(channel.schema_id);
      info.type = schema != mcap_.schemas().end() ? schema->second.name : "";
      info.serialization_format = channel.message_encoding;
      std::size_t index = topics_.size();
      for (std::size_t k = 0; k < topics_.size(); ++k) {
        if (topics_[k].name == info.name && topics_[k].type == info.type) index = k;
      }
      if (index == topics_.size()) topics_.push_back(info);
      topic_of_channel[id] = index;
    }
    entries_.reserve(mcap_.messages().size());
    for (const mcap::MessageLocation& m : mcap_.messages()) {
      const auto topic = topic_of_channel.find(m.channel_id);
      if (topic == topic_of_channel.end()) {
        throw std::runtime_error(path + ": a message of channel " + std::to_string(m.channel_id) +
                                 ", which has no Channel record");
      }
      entries_.push_back({m.log_time_ns, topic->second});
      ++topics_[topic->second].message_count;
    }
  }
  [[nodiscard]] const std::vector<TopicInfo>& topics() const override { return topics_; }
  [[nodiscard]] const std::vector<MessageEntry>& entries() const override { return entries_; }
  [[nodiscard]] BagMessage read(std::size_t i) const override {
    mcap::Message message = mcap_.read(i);
    return {entries_[i].topic, message.log_time_ns, std::move(message.data)};
  }
  [[nodiscard]] const std::vector<std::string>& warnings() const override {
    return mcap_.warnings();
  }
  [[nodiscard]] const std::string& path() const override { return mcap_.path(); }

 private:
  mcap::McapReader mcap_;
  std::vector<TopicInfo> topics_;
  std::vector<MessageEntry> entries_;
};

}  // namespace

std::unique_ptr<BagReader> openMcapBag(const std::string& path) {
  return std::make_unique<McapBag>(path);
}

}  // namespace mlmap::bag
