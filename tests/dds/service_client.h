#pragma once
// A ROS 2 service client that does what rmw_fastrtps_cpp's does (Jazzy), for the service tests
// and the service benchmark.

#include "mlmap/dds/transport/entities.h"
#include "mlmap/dds/node/ros_services.h"

#include "dds_test_support.h"

#include <fastrtps/rtps/common/WriteParams.h>
#include <fastdds/dds/domain/DomainParticipant.hpp>

#include <chrono>
#include <optional>

namespace mlmap::dds::test_support {

/// What rmw_fastrtps_cpp's client does (Jazzy, rmw_request.cpp / rmw_response.cpp): writes the
/// request with its reply reader's GUID as the related sample identity, takes every reply and keeps
/// the ones whose related sample identity names its reader (or its writer) and whose sequence
/// number is the request's.
template <class ReqPubSub, class RespPubSub>
class RmwFastrtpsStyleClient {
 public:
  using Request = typename ReqPubSub::type;
  using Response = typename RespPubSub::type;

  /// A client of the service on `topics`. Its reply reader keeps the last `reply_depth` replies
  /// not yet taken (rmw's services default: 10). Every client's reader receives the replies to
  /// every client: one that takes late while another calls fast can lose its own reply from a
  /// 10-deep history (a property of rmw_fastrtps_cpp's framing, whose clients have the same
  /// depth), so tests of concurrent clients give a deeper one.
  RmwFastrtpsStyleClient(eprosima::fastdds::dds::DomainParticipant* participant,
                         const ServiceTopics& topics, int reply_depth = 10) {
    publisher_ = participant->create_publisher(eprosima::fastdds::dds::PUBLISHER_QOS_DEFAULT);
    subscriber_ = participant->create_subscriber(eprosima::fastdds::dds::SUBSCRIBER_QOS_DEFAULT);
    writer_ = createWriter<ReqPubSub>(publisher_, topics.request, serviceWriterQos());
    eprosima::fastdds::dds::DataReaderQos reader_qos = serviceReaderQos();
    reader_qos.history().depth = reply_depth;
    reader_ = createReader<RespPubSub>(subscriber_, topics.reply, reader_qos, nullptr);
  }

  /// True once both endpoints matched the server (what rclcpp's service_is_ready checks).
  bool ready() const { return writerMatched(writer_) && readerMatched(reader_); }

  /// Calls the service; nothing when no reply came within `timeout`.
  std::optional<Response> call(const Request& request, std::chrono::milliseconds timeout =
                                                           std::chrono::milliseconds(10000)) {
    eprosima::fastrtps::rtps::WriteParams params;
    params.related_sample_identity().writer_guid() = reader_->guid();
    if (!writer_->write(const_cast<Request*>(&request), params)) return std::nullopt;
    const eprosima::fastrtps::rtps::SequenceNumber_t sequence =
        params.sample_identity().sequence_number();
    const eprosima::fastrtps::rtps::GUID_t reply_reader = reader_->guid();
    const eprosima::fastrtps::rtps::GUID_t request_writer = writer_->guid();
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      Response response;
      eprosima::fastdds::dds::SampleInfo info;
      if (reader_->take_next_sample(&response, &info) !=
          eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK) {
        reader_->wait_for_unread_message(eprosima::fastrtps::Duration_t(0, 20000000));
        continue;
      }
      if (!info.valid_data) continue;
      const eprosima::fastrtps::rtps::GUID_t& to = info.related_sample_identity.writer_guid();
      if (to != reply_reader && to != request_writer) {
        ++foreign_replies_;  // another client's reply on the shared topic
        continue;
      }
      if (info.related_sample_identity.sequence_number() != sequence) continue;
      return response;
    }
    return std::nullopt;
  }

  /// The first call after ready(): repeated (1 s per attempt) until answered. The client's writer
  /// can match the node's reader before that reader has matched the writer, and a VOLATILE reader
  /// drops what it receives before; rmw_fastrtps_cpp's clients have the same race, so a test calls
  /// its first request this way and every later one once.
  std::optional<Response> callUntilAnswered(const Request& request) {
    for (int attempt = 0; attempt < 10; ++attempt) {
      if (auto response = call(request, std::chrono::milliseconds(1000))) return response;
    }
    return std::nullopt;
  }

  /// The request writer, for tests that write requests of their own making.
  eprosima::fastdds::dds::DataWriter* writer() const { return writer_; }

  /// Replies to other clients that this one took and dropped.
  int foreignReplies() const { return foreign_replies_; }

 private:
  eprosima::fastdds::dds::Publisher* publisher_ = nullptr;
  eprosima::fastdds::dds::Subscriber* subscriber_ = nullptr;
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
  eprosima::fastdds::dds::DataReader* reader_ = nullptr;
  int foreign_replies_ = 0;
};

}  // namespace mlmap::dds::test_support
