#pragma once
/// @file
/// A ROS 2 bag as `ros2 bag record` writes it, read without ROS: a bag folder (metadata.yaml with
/// its storage_identifier and relative_file_paths), or one `.mcap` or `.db3` (sqlite3, the
/// rosbag2 schema) file. One interface lists the topics and serves the messages by index in
/// log-time order; only the messages' locations are kept in memory, their bytes are read when
/// asked for.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace mlmap::bag {

/// A topic of a bag.
struct TopicInfo {
  std::string name;                  ///< "/points"
  std::string type;                  ///< "sensor_msgs/msg/PointCloud2"
  std::string serialization_format;  ///< "cdr"
  std::uint64_t message_count = 0;   ///< messages found in the bag (not what metadata.yaml says)
};

/// Where a message is in the log, without its bytes.
struct MessageEntry {
  std::uint64_t log_time_ns = 0;  ///< when the recorder received it [ns since the epoch]
  std::size_t topic = 0;          ///< index into BagReader::topics()
};

/// A message with its bytes.
struct BagMessage {
  std::size_t topic = 0;           ///< index into BagReader::topics()
  std::uint64_t log_time_ns = 0;   ///< [ns since the epoch]
  std::vector<std::uint8_t> data;  ///< serialised as topics()[topic].serialization_format says
};

/// The messages of a bag by index, in log-time order (ties in recording order). read() may be
/// called from several threads.
class BagReader {
 public:
  virtual ~BagReader() = default;
  /// The bag's topics.
  [[nodiscard]] virtual const std::vector<TopicInfo>& topics() const = 0;
  /// Every message's log time and topic, in log-time order.
  [[nodiscard]] virtual const std::vector<MessageEntry>& entries() const = 0;
  /// Message `i` of entries(), with its bytes. @throws std::out_of_range for a bad index and
  /// std::runtime_error naming the file when it cannot be read.
  [[nodiscard]] virtual BagMessage read(std::size_t i) const = 0;
  /// What was wrong but did not stop the reading (a recording cut off, ...).
  [[nodiscard]] virtual const std::vector<std::string>& warnings() const = 0;
  /// The bag's path, for messages.
  [[nodiscard]] virtual const std::string& path() const = 0;

  /// Index into topics() of the topic named `name`, or topics().size() when there is none.
  [[nodiscard]] std::size_t findTopic(const std::string& name) const;
  /// The topics as lines "NAME (TYPE, N messages)", for error messages and logs.
  [[nodiscard]] std::string describeTopics() const;
};

/// Opens a bag: a folder with metadata.yaml (storage `mcap` or `sqlite3`, every file of
/// relative_file_paths merged in log-time order), or one `.mcap` / `.db3` file (by its first
/// bytes, not its name). @throws std::runtime_error naming the path and what is wrong.
[[nodiscard]] std::unique_ptr<BagReader> openBag(const std::string& path);

/// An MCAP file as a bag (see mlmap/bag/mcap.h): topics are its channels, types their schema
/// names. @throws std::runtime_error as McapReader does.
[[nodiscard]] std::unique_ptr<BagReader> openMcapBag(const std::string& path);

/// A sqlite3 file of the rosbag2 schema (tables `topics` and `messages`; schema versions 2 to 4
/// of Foxy to Jazzy all have the columns read) as a bag. @throws std::runtime_error naming the
/// file when it is not sqlite3 or lacks the tables.
[[nodiscard]] std::unique_ptr<BagReader> openSqliteBag(const std::string& path);

}  // namespace mlmap::bag
