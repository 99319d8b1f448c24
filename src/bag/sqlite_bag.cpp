#include "mlmap/bag/bag_reader.h"

#include <sqlite3.h>

#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>
#include <stdexcept>

namespace mlmap::bag {
namespace {

/// A prepared statement, finalised on destruction.
class Statement {
 public:
  Statement(sqlite3* db, const std::string& path, const char* sql) {
    if (sqlite3_prepare_v2(db, sql, -1, &statement_, nullptr) != SQLITE_OK) {
      const std::string error = sqlite3_errmsg(db);
      sqlite3_finalize(statement_);
      throw std::runtime_error(path + ": not a rosbag2 sqlite3 bag (" + error + ")");
    }
  }
  ~Statement() { sqlite3_finalize(statement_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  [[nodiscard]] sqlite3_stmt* get() const { return statement_; }

 private:
  sqlite3_stmt* statement_ = nullptr;
};

std::string text(sqlite3_stmt* statement, int column) {
  const unsigned char* value = sqlite3_column_text(statement, column);
  return value == nullptr ? "" : reinterpret_cast<const char*>(value);
}

/// A rosbag2 sqlite3 file: topics from `topics`, messages from `messages` by timestamp.
class SqliteBag : public BagReader {
 public:
  explicit SqliteBag(const std::string& path) : path_(path) {
    if (sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READONLY | SQLITE_OPEN_FULLMUTEX,
                        nullptr) != SQLITE_OK) {
      const std::string error = db_ != nullptr ? sqlite3_errmsg(db_) : "out of memory";
      sqlite3_close(db_);
      throw std::runtime_error(path + ": cannot open as sqlite3: " + error);
    }
    try {
      requireTables();
      std::error_code ec;
      const std::uintmax_t file_bytes = std::filesystem::file_size(path, ec);
      // Every row of a real table is stored in the file, in a few bytes at least.
      max_rows_ = ec ? 0 : file_bytes / kMinRowBytes;
      readTopics();
      readEntries();
      read_statement_ =
          std::make_unique<Statement>(db_, path_, "SELECT data FROM messages WHERE id = ?");
    } catch (...) {
      sqlite3_close(db_);
      throw;
    }
  }
  ~SqliteBag() override {
    read_statement_.reset();
    sqlite3_close(db_);
  }
  SqliteBag(const SqliteBag&) = delete;
  SqliteBag& operator=(const SqliteBag&) = delete;

  [[nodiscard]] const std::vector<TopicInfo>& topics() const override { return topics_; }
  [[nodiscard]] const std::vector<MessageEntry>& entries() const override { return entries_; }
  [[nodiscard]] const std::vector<std::string>& warnings() const override { return warnings_; }
  [[nodiscard]] const std::string& path() const override { return path_; }

  [[nodiscard]] BagMessage read(std::size_t i) const override {
    if (i >= entries_.size()) {
      throw std::out_of_range(path_ + ": message " + std::to_string(i) + " of " +
                              std::to_string(entries_.size()));
    }
    std::lock_guard<std::mutex> lock(mutex_);
    sqlite3_stmt* statement = read_statement_->get();
    sqlite3_reset(statement);
    sqlite3_bind_int64(statement, 1, row_ids_[i]);
    if (sqlite3_step(statement) != SQLITE_ROW) {
      throw std::runtime_error(path_ + ": message row " + std::to_string(row_ids_[i]) +
                               " cannot be read: " + sqlite3_errmsg(db_));
    }
    BagMessage message;
    message.topic = entries_[i].topic;
    message.log_time_ns = entries_[i].log_time_ns;
    const auto* data = static_cast<const std::uint8_t*>(sqlite3_column_blob(statement, 0));
    const int size = sqlite3_column_bytes(statement, 0);
    if (data != nullptr && size > 0) message.data.assign(data, data + size);
    return message;
  }

 private:
  /// Throws unless `topics` and `messages` are tables: a view can compute rows without end (a
  /// recursive one never finishes, a join can make 10^8 rows of a small file).
  void requireTables() {
    for (const char* name : {"topics", "messages"}) {
      Statement statement(db_, path_, "SELECT type FROM sqlite_master WHERE name = ?");
      sqlite3_bind_text(statement.get(), 1, name, -1, SQLITE_STATIC);
      const std::string type =
          sqlite3_step(statement.get()) == SQLITE_ROW ? text(statement.get(), 0) : "";
      if (type != "table") {
        throw std::runtime_error(path_ + ": not a rosbag2 sqlite3 bag: '" + name + "' is " +
                                 (type.empty() ? std::string("missing") : "a " + type) +
                                 ", not a table");
      }
    }
  }

  /// Throws when a table yields more rows than the file can hold.
  void countRow(std::size_t rows, const char* table) const {
    if (rows > max_rows_) {
      throw std::runtime_error(path_ + ": " + table +
                               " has more rows than a file of its size can " + "hold (" +
                               std::to_string(max_rows_) + ")");
    }
  }

  void readTopics() {
    Statement statement(db_, path_, "SELECT id, name, type, serialization_format FROM topics");
    int step = SQLITE_ROW;
    while ((step = sqlite3_step(statement.get())) == SQLITE_ROW) {
      countRow(topics_.size() + 1, "topics");
      topic_of_id_[sqlite3_column_int64(statement.get(), 0)] = topics_.size();
      topics_.push_back(
          {text(statement.get(), 1), text(statement.get(), 2), text(statement.get(), 3), 0});
    }
    if (step != SQLITE_DONE) throw std::runtime_error(path_ + ": topics: " + sqlite3_errmsg(db_));
  }

  void readEntries() {
    Statement statement(db_, path_,
                        "SELECT id, topic_id, timestamp FROM messages ORDER BY timestamp, id");
    int step = SQLITE_ROW;
    while ((step = sqlite3_step(statement.get())) == SQLITE_ROW) {
      countRow(entries_.size() + 1, "messages");
      const sqlite3_int64 topic_id = sqlite3_column_int64(statement.get(), 1);
      const sqlite3_int64 stamp = sqlite3_column_int64(statement.get(), 2);
      const auto topic = topic_of_id_.find(topic_id);
      if (topic == topic_of_id_.end()) {
        throw std::runtime_error(path_ + ": message row " +
                                 std::to_string(sqlite3_column_int64(statement.get(), 0)) +
                                 " has topic_id " + std::to_string(topic_id) + ", not in topics");
      }
      if (stamp < 0) {
        throw std::runtime_error(path_ + ": message row " +
                                 std::to_string(sqlite3_column_int64(statement.get(), 0)) +
                                 " has a negative timestamp");
      }
      row_ids_.push_back(sqlite3_column_int64(statement.get(), 0));
      entries_.push_back({static_cast<std::uint64_t>(stamp), topic->second});
      ++topics_[topic->second].message_count;
    }
    if (step != SQLITE_DONE) throw std::runtime_error(path_ + ": messages: " + sqlite3_errmsg(db_));
  }

  /// The least bytes a row of a table takes in the file (a record header and a few integers).
  static constexpr std::uintmax_t kMinRowBytes = 4;

  std::string path_;
  sqlite3* db_ = nullptr;
  std::uintmax_t max_rows_ = 0;  ///< rows a file of this size can hold
  std::vector<TopicInfo> topics_;
  std::map<sqlite3_int64, std::size_t> topic_of_id_;
  std::vector<MessageEntry> entries_;
  std::vector<sqlite3_int64> row_ids_;
  std::vector<std::string> warnings_;
  std::unique_ptr<Statement> read_statement_;
  mutable std::mutex mutex_;
};

}  // namespace

std::unique_ptr<BagReader> openSqliteBag(const std::string& path) {
  return std::make_unique<SqliteBag>(path);
}

}  // namespace mlmap::bag
