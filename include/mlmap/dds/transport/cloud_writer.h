#pragma once
/// @file
/// The sensor publisher's cloud writer: PointCloud2 samples offered with Fast DDS data-sharing
/// to mlmap's own same-host readers (participant.h: dataSharingDomainId()).

#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>

#include <cstdint>
#include <string>

namespace mlmap::dds {

/// A writer of PointCloud2 samples of up to `max_bytes` serialised (encapsulation included: the
/// generated type's getSerializedSizeProvider()) on `dds_topic`, which offers data-sharing: a
/// same-host reader that accepts it (mlmap_node unless dds.data_sharing is false) reads each
/// cloud in this writer's shared-memory history, with none of the transports' copies; any other
/// reader gets it through the transports. Registers its own PointCloud2 type (bounded by
/// max_bytes), so the participant must hold no other PointCloud2 type. `qos` as for any writer;
/// its history's depth + 1 slots of max_bytes are allocated in shared memory up front, and a
/// larger sample fails to write. Throws std::runtime_error when Fast DDS refuses an entity.
eprosima::fastdds::dds::DataWriter* createDataSharingCloudWriter(
    eprosima::fastdds::dds::Publisher* publisher, const std::string& dds_topic,
    eprosima::fastdds::dds::DataWriterQos qos, std::uint32_t max_bytes);

}  // namespace mlmap::dds
