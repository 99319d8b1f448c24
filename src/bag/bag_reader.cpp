#include "mlmap/bag/bag_reader.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace mlmap::bag {
namespace {

namespace fs = std::filesystem;

/// The files of a bag folder merged in log-time order; topics with the same name and type are one.
class FolderBag : public BagReader {
 public:
  FolderBag(std::string path, std::vector<std::unique_ptr<BagReader>> files)
      : path_(std::move(path)), files_(std::move(files)) {
    struct Source {
      MessageEntry entry;
      std::size_t file;
      std::size_t index;
    };
    std::vector<Source> all;
    for (std::size_t f = 0; f < files_.size(); ++f) {
      std::vector<std::size_t> topic_map;
      for (const TopicInfo& topic : files_[f]->topics()) {
        std::size_t k = 0;
        while (k < topics_.size() &&
               (topics_[k].name != topic.name || topics_[k].type != topic.type))
          ++k;
        if (k == topics_.size())
          topics_.push_back({topic.name, topic.type, topic.serialization_format, 0});
        topics_[k].message_count += topic.message_count;
        topic_map.push_back(k);
      }
      const std::vector<MessageEntry>& entries = files_[f]->entries();
      for (std::size_t i = 0; i < entries.size(); ++i) {
        all.push_back({{entries[i].log_time_ns, topic_map[entries[i].topic]}, f, i});
      }
      for (const std::string& w : files_[f]->warnings()) warnings_.push_back(w);
    }
    std::stable_sort(all.begin(), all.end(), [](const Source& a, const Source& b) {
      return a.entry.log_time_ns < b.entry.log_time_ns;
    });
    entries_.reserve(all.size());
    where_.reserve(all.size());
    for (const Source& s : all) {
      entries_.push_back(s.entry);
      where_.emplace_back(s.file, s.index);
    }
  }
  [[nodiscard]] const std::vector<TopicInfo>& topics() const override { return topics_; }
  [[nodiscard]] const std::vector<MessageEntry>& entries() const override { return entries_; }
  [[nodiscard]] const std::vector<std::string>& warnings() const override { return warnings_; }
  [[nodiscard]] const std::string& path() const override { return path_; }
  [[nodiscard]] BagMessage read(std::size_t i) const override {
    if (i >= entries_.size()) {
      throw std::out_of_range(path_ + ": message " + std::to_string(i) + " of " +
                              std::to_string(entries_.size()));
    }
    BagMessage message = files_[where_[i].first]->read(where_[i].second);
    message.topic = entries_[i].topic;
    return message;
  }

 private:
  std::string path_;
  std::vector<std::unique_ptr<BagReader>> files_;
  std::vector<TopicInfo> topics_;
  std::vector<MessageEntry> entries_;
  std::vector<std::pair<std::size_t, std::size_t>> where_;  ///< file, index in the file
  std::vector<std::string> warnings_;
};

/// Throws unless `path` is a regular file: opening a FIFO blocks until something writes to it,
/// and a device never ends.
void requireRegularFile(const std::string& path) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec) throw std::runtime_error(path + ": cannot open: " + ec.message());
  if (!fs::is_regular_file(status)) {
    throw std::runtime_error(path + ": not a regular file (a device, pipe or socket), not a bag");
  }
}

/// A bag file by its first bytes: MCAP or sqlite3.
std::unique_ptr<BagReader> openFile(const std::string& path) {
  requireRegularFile(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open");
  char head[16] = {};
  in.read(head, sizeof(head));
  if (in.gcount() >= 8 && std::memcmp(head, "\x89MCAP0\r\n", 8) == 0) return openMcapBag(path);
  if (in.gcount() == 16 && std::memcmp(head, "SQLite format 3\0", 16) == 0)
    return openSqliteBag(path);
  throw std::runtime_error(path + ": neither MCAP nor sqlite3 (unknown first bytes)");
}

std::unique_ptr<BagReader> openFolder(const std::string& dir) {
  const fs::path metadata_path = fs::path(dir) / "metadata.yaml";
  if (!fs::exists(metadata_path)) {
    throw std::runtime_error(dir + ": a folder without metadata.yaml is not a ROS 2 bag");
  }
  YAML::Node info;
  try {
    info = YAML::LoadFile(metadata_path.string())["rosbag2_bagfile_information"];
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(metadata_path.string() + ": " + e.what());
  }
  if (!info || !info.IsMap()) {
    throw std::runtime_error(metadata_path.string() + ": no rosbag2_bagfile_information");
  }
  const std::string storage =
      info["storage_identifier"] ? info["storage_identifier"].as<std::string>("") : "";
  if (storage != "mcap" && storage != "sqlite3") {
    throw std::runtime_error(metadata_path.string() + ": storage_identifier '" + storage +
                             "' (known: mcap, sqlite3)");
  }
  const std::string compression =
      info["compression_format"] ? info["compression_format"].as<std::string>("") : "";
  if (!compression.empty()) {
    throw std::runtime_error(metadata_path.string() + ": compression_format '" + compression +
                             "' (whole-file compression) is not read; decompress the files first");
  }
  const YAML::Node paths = info["relative_file_paths"];
  if (!paths || !paths.IsSequence() || paths.size() == 0) {
    throw std::runtime_error(metadata_path.string() + ": relative_file_paths lists no file");
  }
  std::vector<std::unique_ptr<BagReader>> files;
  for (const YAML::Node& p : paths) {
    const std::string relative = p.as<std::string>("");
    if (relative.empty() || fs::path(relative).is_absolute() ||
        relative.find("..") != std::string::npos) {
      throw std::runtime_error(metadata_path.string() + ": relative file path '" + relative +
                               "' is not a file name inside the folder");
    }
    const std::string file = (fs::path(dir) / relative).string();
    requireRegularFile(file);
    files.push_back(storage == "mcap" ? openMcapBag(file) : openSqliteBag(file));
  }
  return std::make_unique<FolderBag>(dir, std::move(files));
}

}  // namespace

std::size_t BagReader::findTopic(const std::string& name) const {
  const std::vector<TopicInfo>& all = topics();
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (all[i].name == name) return i;
  }
  return all.size();
}

std::string BagReader::describeTopics() const {
  std::ostringstream text;
  for (const TopicInfo& topic : topics()) {
    text << "  " << topic.name << " (" << (topic.type.empty() ? "no type" : topic.type) << ", "
         << topic.message_count << " messages)\n";
  }
  return text.str();
}

std::unique_ptr<BagReader> openBag(const std::string& path) {
  if (fs::is_directory(path)) return openFolder(path);
  if (!fs::exists(path)) throw std::runtime_error(path + ": no such bag file or folder");
  return openFile(path);
}

}  // namespace mlmap::bag
