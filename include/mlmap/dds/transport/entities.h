#pragma once
/// @file
/// Small helpers every mlmap DDS program uses: registering a generated type, creating a topic's
/// reader or writer (with the ROS 2 type hash in its USER_DATA, as rmw does), a listener that
/// takes samples and hands them over, and a set of readers with their listeners (TakeReaders).

#include "mlmap/dds/wire/cdr_check.h"
#include "mlmap/dds/wire/type_hash.h"

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/DataWriterListener.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include <exception>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace mlmap::dds {

namespace detail {
/// Set on the calling thread when a CheckedType failed to deserialise a payload.
inline bool& deserializeFailed() {
  thread_local bool failed = false;
  return failed;
}
/// Why the calling thread's last failed CheckedType::deserialize failed (set with
/// deserializeFailed; stale otherwise), e.g. "tf2_msgs::msg::dds_::TFMessage_ `transforms`:
/// sequence declares 16777216 elements of >= 72 bytes, 1000 bytes remain".
inline std::string& deserializeError() {
  thread_local std::string error;
  return error;
}
}  // namespace detail

/// A generated type whose deserialize() never throws and never allocates for bytes the payload
/// does not hold. The payload is first checked against the type's CDR layout from idl/
/// (checkCdrPayload, cdr_check.h): Fast CDR 1.0 would size every sequence from its declared
/// count, gigabytes for a small sample that declares millions of elements. Fast CDR also throws
/// on some malformed payloads (a bool byte other than 0/1) past the generated code, and Fast DDS
/// 2.9 then leaves the sample in the reader's history, so every later take() would throw on it
/// again. Here the sample is taken like any other, and the failure is flagged on the taking
/// thread with its reason (TakeListener drops and reports it): Fast DDS ignores deserialize()'s
/// return value.
template <typename PubSubType>
class CheckedType : public PubSubType {
 public:
  /// @throws std::runtime_error when idl/ has no struct of the type's name (its samples could not
  /// be checked).
  CheckedType() : layout_(cdrLayoutOf(this->getName())) {
    if (layout_ == nullptr) {
      throw std::runtime_error(std::string("DDS type ") + this->getName() +
                               " has no CDR layout in idl/");
    }
  }

  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t* payload, void* data) override {
    const CdrCheck check = checkCdrPayload(*layout_, payload->data, payload->length);
    if (!check.ok) {
      detail::deserializeFailed() = true;
      detail::deserializeError() = check.error;
      return false;
    }
    bool ok = false;
    try {
      ok = PubSubType::deserialize(payload, data);
      if (!ok)
        detail::deserializeError() = std::string(layout_->dds_type) + ": refused by Fast CDR";
    } catch (const std::exception& e) {
      detail::deserializeError() = std::string(layout_->dds_type) + ": " + e.what();
    }
    if (!ok) detail::deserializeFailed() = true;
    return ok;
  }

 private:
  const CdrStructLayout* layout_;  ///< the type's layout, from idl/
};

/// Registers the generated type `PubSubType` (as a CheckedType) with the participant, once, and
/// returns its DDS type name, e.g. "sensor_msgs::msg::dds_::PointCloud2_". Throws
/// std::runtime_error on failure, and when the name is registered with another implementation
/// (e.g. the generated PointCloud2 type and CloudSamplePubSubType in one participant: samples
/// would reach the wrong one).
template <typename PubSubType>
std::string registerType(eprosima::fastdds::dds::DomainParticipant* participant) {
  eprosima::fastdds::dds::TypeSupport type(new CheckedType<PubSubType>());
  std::string name = type.get_type_name();
  const eprosima::fastdds::dds::TypeSupport found = participant->find_type(name);
  if (!found.empty()) {
    if (dynamic_cast<const CheckedType<PubSubType>*>(found.get()) == nullptr) {
      throw std::runtime_error("DDS type " + name + " is registered with another implementation");
    }
    return name;
  }
  if (type.register_type(participant) != eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK) {
    throw std::runtime_error("cannot register DDS type " + name);
  }
  return name;
}

/// The participant's topic `dds_topic` of type `PubSubType`, created on first use.
template <typename PubSubType>
eprosima::fastdds::dds::Topic* findOrCreateTopic(
    eprosima::fastdds::dds::DomainParticipant* participant, const std::string& dds_topic) {
  const std::string type = registerType<PubSubType>(participant);
  if (eprosima::fastdds::dds::TopicDescription* d =
          participant->lookup_topicdescription(dds_topic)) {
    if (d->get_type_name() != type) {
      throw std::runtime_error("topic " + dds_topic + " already exists with type " +
                               d->get_type_name());
    }
    return static_cast<eprosima::fastdds::dds::Topic*>(d);
  }
  eprosima::fastdds::dds::Topic* topic =
      participant->create_topic(dds_topic, type, eprosima::fastdds::dds::TOPIC_QOS_DEFAULT);
  if (topic == nullptr) throw std::runtime_error("cannot create topic " + dds_topic);
  return topic;
}

/// `qos` with the USER_DATA rmw_fastrtps_cpp gives a ROS 2 endpoint of `dds_type_name`:
/// "typehash=RIHS01_<64 hex>;" (rosEndpointUserData), so `ros2 topic info -v` shows the type hash
/// and ROS tools do not warn. USER_DATA the caller set already is kept. The one place every writer
/// and reader mlmap creates gets it from (createWriter, createReader, the data-sharing cloud
/// writer). `Qos` is DataWriterQos or DataReaderQos.
template <typename Qos>
Qos withRosTypeHash(Qos qos, const std::string& dds_type_name) {
  if (qos.user_data().data_vec().empty()) {
    qos.user_data().data_vec(rosEndpointUserData(dds_type_name));
  }
  return qos;
}

/// A writer of `PubSubType` on `dds_topic`, with `listener` (which must outlive the writer) if
/// given, with the type's ROS 2 type hash in its USER_DATA (withRosTypeHash). Throws
/// std::runtime_error on failure.
template <typename PubSubType>
eprosima::fastdds::dds::DataWriter* createWriter(
    eprosima::fastdds::dds::Publisher* publisher, const std::string& dds_topic,
    const eprosima::fastdds::dds::DataWriterQos& qos,
    eprosima::fastdds::dds::DataWriterListener* listener = nullptr) {
  auto* participant =
      const_cast<eprosima::fastdds::dds::DomainParticipant*>(publisher->get_participant());
  eprosima::fastdds::dds::Topic* topic = findOrCreateTopic<PubSubType>(participant, dds_topic);
  eprosima::fastdds::dds::DataWriter* writer =
      publisher->create_datawriter(topic, withRosTypeHash(qos, topic->get_type_name()), listener);
  if (writer == nullptr) throw std::runtime_error("cannot create a writer on " + dds_topic);
  return writer;
}

/// Takes every sample of a reader and hands it to `sink` (on Fast DDS's listener thread: keep
/// `sink` short). A payload that fails to deserialise (the reader's type must come from
/// registerType(), see CheckedType) is reported to `on_error` and dropped. `on_matched`, if
/// given, hears the number of publishers the reader matches each time it changes.
template <typename Msg>
class TakeListener : public eprosima::fastdds::dds::DataReaderListener {
 public:
  TakeListener(std::function<void(Msg&&)> sink, std::function<void(const std::string&)> on_error,
               std::function<void(int)> on_matched = {})
      : sink_([s = std::move(sink)](Msg&& m, const eprosima::fastdds::dds::SampleInfo&) {
          s(std::move(m));
        }),
        on_error_(std::move(on_error)),
        on_matched_(std::move(on_matched)) {}
  /// As above, `sink` also getting the sample's SampleInfo (e.g. the publishing writer's GUID,
  /// `publication_handle`).
  TakeListener(std::function<void(Msg&&, const eprosima::fastdds::dds::SampleInfo&)> sink,
               std::function<void(const std::string&)> on_error,
               std::function<void(int)> on_matched = {})
      : sink_(std::move(sink)),
        on_error_(std::move(on_error)),
        on_matched_(std::move(on_matched)) {}
  void on_subscription_matched(
      eprosima::fastdds::dds::DataReader*,
      const eprosima::fastdds::dds::SubscriptionMatchedStatus& status) override {
    if (on_matched_) on_matched_(status.current_count);
  }
  void on_data_available(eprosima::fastdds::dds::DataReader* reader) override {
    for (;;) {
      Msg msg;
      eprosima::fastdds::dds::SampleInfo info;
      detail::deserializeFailed() = false;
      const bool taken = reader->take_next_sample(&msg, &info) ==
                         eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK;
      // cppcheck-suppress knownConditionTrueFalse ; set by CheckedType::deserialize inside take
      if (detail::deserializeFailed()) {  // taken or not, the sample has left the history
        on_error_("cannot deserialise a sample on " + reader->get_topicdescription()->get_name() +
                  " (malformed CDR: " + detail::deserializeError() + ")");
        continue;
      }
      if (!taken) return;
      if (info.valid_data) sink_(std::move(msg), info);
    }
  }

 private:
  std::function<void(Msg&&, const eprosima::fastdds::dds::SampleInfo&)> sink_;
  std::function<void(const std::string&)> on_error_;
  std::function<void(int)> on_matched_;
};

/// A reader of `PubSubType` on `dds_topic` whose samples go to `listener` (which must outlive
/// the reader), with the type's ROS 2 type hash in its USER_DATA (withRosTypeHash). Throws
/// std::runtime_error on failure.
template <typename PubSubType>
eprosima::fastdds::dds::DataReader* createReader(
    eprosima::fastdds::dds::Subscriber* subscriber, const std::string& dds_topic,
    const eprosima::fastdds::dds::DataReaderQos& qos,
    eprosima::fastdds::dds::DataReaderListener* listener) {
  auto* participant =
      const_cast<eprosima::fastdds::dds::DomainParticipant*>(subscriber->get_participant());
  eprosima::fastdds::dds::Topic* topic = findOrCreateTopic<PubSubType>(participant, dds_topic);
  eprosima::fastdds::dds::DataReader* reader =
      subscriber->create_datareader(topic, withRosTypeHash(qos, topic->get_type_name()), listener);
  if (reader == nullptr) throw std::runtime_error("cannot create a reader on " + dds_topic);
  return reader;
}

/// Readers that each hand their samples to a TakeListener, created together with their listener,
/// which the set keeps alive: delete the readers (or their participant) before the set. The one
/// way a program subscribes to a topic of `PubSubType` (its generated `type` is the message).
class TakeReaders {
 public:
  /// Readers on `subscriber`; a payload that fails to deserialise on any of them is reported to
  /// `on_error` (on Fast DDS's listener thread) and dropped.
  TakeReaders(eprosima::fastdds::dds::Subscriber* subscriber,
              std::function<void(const std::string&)> on_error)
      : subscriber_(subscriber), on_error_(std::move(on_error)) {}

  /// A reader of `PubSubType` on `dds_topic` whose samples go to `sink` (on Fast DDS's listener
  /// thread: keep it short); `on_matched`, if given, hears its number of matched publishers each
  /// time it changes. Throws std::runtime_error on failure.
  template <typename PubSubType>
  eprosima::fastdds::dds::DataReader* add(const std::string& dds_topic,
                                          const eprosima::fastdds::dds::DataReaderQos& qos,
                                          std::function<void(typename PubSubType::type&&)> sink,
                                          std::function<void(int)> on_matched = {}) {
    auto listener = std::make_unique<TakeListener<typename PubSubType::type>>(
        std::move(sink), on_error_, std::move(on_matched));
    eprosima::fastdds::dds::DataReader* reader =
        createReader<PubSubType>(subscriber_, dds_topic, qos, listener.get());
    listeners_.push_back(std::move(listener));
    return reader;
  }

  /// As add(), `sink` also getting each sample's SampleInfo.
  template <typename PubSubType>
  eprosima::fastdds::dds::DataReader* addWithInfo(
      const std::string& dds_topic, const eprosima::fastdds::dds::DataReaderQos& qos,
      std::function<void(typename PubSubType::type&&, const eprosima::fastdds::dds::SampleInfo&)>
          sink,
      std::function<void(int)> on_matched = {}) {
    auto listener = std::make_unique<TakeListener<typename PubSubType::type>>(
        std::move(sink), on_error_, std::move(on_matched));
    eprosima::fastdds::dds::DataReader* reader =
        createReader<PubSubType>(subscriber_, dds_topic, qos, listener.get());
    listeners_.push_back(std::move(listener));
    return reader;
  }

  /// The number of readers added.
  [[nodiscard]] std::size_t size() const { return listeners_.size(); }

 private:
  eprosima::fastdds::dds::Subscriber* subscriber_;
  std::function<void(const std::string&)> on_error_;
  std::vector<std::unique_ptr<eprosima::fastdds::dds::DataReaderListener>> listeners_;
};

}  // namespace mlmap::dds
