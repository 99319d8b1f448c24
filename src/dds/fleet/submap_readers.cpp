#include "mlmap/dds/fleet/submap_readers.h"

#include "mlmap/dds/fleet/submap_messages.h"

#include "mlmap_msgs/msg/Submap_PubSubTypes.h"

#include <numeric>
#include <stdexcept>
#include <utility>

namespace mlmap::dds {
namespace fdds = eprosima::fastdds::dds;
namespace frtps = eprosima::fastrtps::rtps;
using SubmapType = ::mlmap_msgs::msg::dds_::Submap_PubSubType;

/// Hears every remote writer the participant discovers and passes on the vehicle topics.
class SubmapReaders::Discovery : public fdds::DomainParticipantListener {
 public:
  explicit Discovery(SubmapReaders* owner) : owner_(owner), type_name_(SubmapType().getName()) {}

  void on_publisher_discovery(fdds::DomainParticipant* /*participant*/,
                              frtps::WriterDiscoveryInfo&& info) override {
    if (info.status != frtps::WriterDiscoveryInfo::DISCOVERED_WRITER) return;
    if (info.info.typeName().to_string() != type_name_) return;
    const std::string vehicle =
        vehicleOfSubmapTopic(info.info.topicName().to_string(), owner_->config_.topic);
    if (!vehicle.empty()) owner_->found(vehicle);
  }

 private:
  SubmapReaders* owner_;
  std::string type_name_;
};

SubmapReaders::SubmapReaders(SubmapReadersConfig config, Sink sink,
                             std::function<void(const std::string&)> on_error,
                             std::function<void(int)> on_matched)
    : config_(std::move(config)),
      sink_(std::move(sink)),
      on_matched_(std::move(on_matched)),
      on_error_(std::move(on_error)) {
  for (const std::string& vehicle : config_.vehicles) {
    if (vehicleOfSubmapTopic(vehicleSubmapTopic(vehicle, config_.topic), config_.topic) !=
        vehicle) {
      throw std::invalid_argument("'" + vehicle +
                                  "' is not a vehicle name: a ROS name of letters, digits, '_' and "
                                  "inner '/', at most 256 bytes");
    }
  }
  if (config_.vehicles.empty()) discovery_ = std::make_unique<Discovery>(this);
}

SubmapReaders::~SubmapReaders() { stop(); }

fdds::DomainParticipantListener* SubmapReaders::discoveryListener() { return discovery_.get(); }

void SubmapReaders::start(fdds::Subscriber* subscriber) {
  readers_ = std::make_unique<TakeReaders>(subscriber, on_error_);
  for (const std::string& vehicle : config_.vehicles) addReader(vehicle);
  if (!discovery_) return;
  thread_ = std::thread([this] { createLoop(); });
}

void SubmapReaders::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void SubmapReaders::found(const std::string& vehicle) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_ || vehicle == config_.own_vehicle || known_.count(vehicle) > 0) return;
    if (known_.size() >= config_.max_discovered) {
      ++ignored_;
      return;
    }
    known_.insert(vehicle);
    pending_.push_back(vehicle);
  }
  wake_.notify_all();
}

void SubmapReaders::createLoop() {
  for (;;) {
    std::vector<std::string> batch;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || !pending_.empty(); });
      if (stopping_) return;
      batch.swap(pending_);
    }
    for (const std::string& vehicle : batch) {
      try {
        addReader(vehicle);
      } catch (const std::exception& e) {
        // Not permitted to read it (DDS Security), or out of resources: said, counted.
        {
          std::lock_guard<std::mutex> lock(mutex_);
          ++ignored_;
        }
        on_error_("no reader for vehicle '" + vehicle + "': " + e.what());
      }
    }
  }
}

void SubmapReaders::addReader(const std::string& vehicle) {
  std::size_t index = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    index = matched_.size();
    matched_.push_back(0);
  }
  readers_->addWithInfo<SubmapType>(
      vehicleSubmapTopic(vehicle, config_.topic), submapReaderQos(),
      [this, vehicle](::mlmap_msgs::msg::dds_::Submap_&& msg, const fdds::SampleInfo& info) {
        sink_(vehicle, std::move(msg), info);
      },
      [this, index](int count) { matched(index, count); });
  std::lock_guard<std::mutex> lock(mutex_);
  known_.insert(vehicle);
  read_.push_back(vehicle);
}

void SubmapReaders::matched(std::size_t reader, int count) {
  int total = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    matched_[reader] = count;
    total = std::accumulate(matched_.begin(), matched_.end(), 0);
  }
  if (on_matched_) on_matched_(total);
}

std::vector<std::string> SubmapReaders::vehicles() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return read_;
}

std::uint64_t SubmapReaders::topicsIgnored() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return ignored_;
}

}  // namespace mlmap::dds
