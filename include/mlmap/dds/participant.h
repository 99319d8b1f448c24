#pragma once
/// @file
/// Creating a DomainParticipant the way a ROS 2 Jazzy node does, and the QoS presets ROS 2 users
/// expect (sensor data, default, maps / tf_static).

#include "mlmap/dds/dds_config.h"

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>

#include <memory>
#include <string>

namespace mlmap::dds {

/// Deletes a participant and every entity it holds.
struct ParticipantDeleter {
  void operator()(eprosima::fastdds::dds::DomainParticipant* participant) const;
};
using ParticipantPtr = std::unique_ptr<eprosima::fastdds::dds::DomainParticipant, ParticipantDeleter>;

/// Creates the participant named `name` on the resolved domain with the resolved discovery range
/// (see DdsConfig). Loads `profiles_file` first when set; LOCALHOST replaces the transports with
/// SHM + UDPv4 on 127.0.0.1 and unicast discovery to 127.0.0.1; `large_data` sizes the SHM
/// segment and socket buffers for multi-MB samples. Throws std::runtime_error with the reason
/// when Fast DDS refuses.
ParticipantPtr createParticipant(const DdsConfig& config, const std::string& name);

/// ROS 2 "sensor data" QoS: BEST_EFFORT, VOLATILE, KEEP_LAST depth (5).
eprosima::fastdds::dds::DataReaderQos sensorReaderQos(int depth = 5);
/// ROS 2 default QoS for a writer: RELIABLE, VOLATILE, KEEP_LAST depth (10), synchronous publish
/// mode, PREALLOCATED_WITH_REALLOC history memory (as rmw_fastrtps).
eprosima::fastdds::dds::DataWriterQos reliableWriterQos(int depth = 10);
/// Latched ("map") writer: RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1 (late joiners get the last one).
eprosima::fastdds::dds::DataWriterQos latchedWriterQos();
/// Readers matching those writers (RELIABLE; TRANSIENT_LOCAL with `latched`).
eprosima::fastdds::dds::DataReaderQos reliableReaderQos(bool latched = false, int depth = 10);

}  // namespace mlmap::dds
