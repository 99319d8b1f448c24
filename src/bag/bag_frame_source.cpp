#include "mlmap/bag/bag_frame_source.h"

#include "mlmap/bag/ros_messages.h"
#include "mlmap/core/pose_buffer.h"

#include "std_msgs/msg/Header_.h"

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

namespace mlmap::bag {
namespace {

constexpr double kSameStamp_s = 1e-6;  // as PoseBuffer and CloudSequence

bool isDepthEncoding(const std::string& encoding) {
  return encoding == "16UC1" || encoding == "32FC1" || encoding == "mono16";
}

/// "NAME (N messages)" of topics, comma-separated.
std::string listTopics(const BagReader& bag, const std::vector<std::size_t>& topics) {
  std::string text;
  for (const std::size_t t : topics) {
    if (!text.empty()) text += ", ";
    text += bag.topics()[t].name;
  }
  return text;
}

std::vector<std::size_t> topicsOfType(const BagReader& bag, const std::string& type) {
  std::vector<std::size_t> found;
  for (std::size_t t = 0; t < bag.topics().size(); ++t) {
    if (bag.topics()[t].type == type && bag.topics()[t].message_count > 0) found.push_back(t);
  }
  return found;
}

[[noreturn]] void refuse(const BagReader& bag, const std::string& what) {
  throw std::runtime_error(bag.path() + ": " + what + ". The bag's topics:\n" +
                           bag.describeTopics());
}

/// The topic `name`, which must exist with one of `types`.
void requireTopic(const BagReader& bag, const std::string& option, const std::string& name,
                  const std::vector<std::string>& types) {
  const std::size_t t = bag.findTopic(name);
  if (t == bag.topics().size()) refuse(bag, option + " '" + name + "' is not in the bag");
  if (std::find(types.begin(), types.end(), bag.topics()[t].type) == types.end()) {
    std::string want;
    for (const std::string& type : types) want += (want.empty() ? "" : " or ") + type;
    refuse(bag, option + " '" + name + "' is a " + bag.topics()[t].type + ", not a " + want);
  }
  if (bag.topics()[t].serialization_format != "cdr") {
    refuse(bag, option + " '" + name + "' is serialised as '" +
                    bag.topics()[t].serialization_format + "', not cdr");
  }
}

/// The first message of topic `t`, or entries().size().
std::size_t firstMessageOf(const BagReader& bag, std::size_t t) {
  const std::vector<MessageEntry>& entries = bag.entries();
  for (std::size_t i = 0; i < entries.size(); ++i) {
    if (entries[i].topic == t) return i;
  }
  return entries.size();
}

std::string messageName(const BagReader& bag, std::size_t entry) {
  const MessageEntry& e = bag.entries()[entry];
  return bag.path() + ": " + bag.topics()[e.topic].name + " message at log time " +
         std::to_string(e.log_time_ns) + " ns";
}

/// The std_msgs/Header that opens a PointCloud2 or an Image, through the generated type.
::std_msgs::msg::dds_::Header_ headerOf(const std::vector<std::uint8_t>& bytes,
                                        const std::string& what) {
  namespace cdr = eprosima::fastcdr;
  ::std_msgs::msg::dds_::Header_ header;
  try {
    cdr::FastBuffer buffer(const_cast<char*>(reinterpret_cast<const char*>(bytes.data())),
                           bytes.size());
    cdr::Cdr in(buffer, cdr::Cdr::DEFAULT_ENDIAN, cdr::Cdr::DDS_CDR);
    in.read_encapsulation();
    header.deserialize(in);
  } catch (const std::exception&) {
    throw std::runtime_error(what + ": malformed CDR header (" + std::to_string(bytes.size()) +
                             " bytes)");
  }
  if (header.stamp_().nanosec_() >= 1000000000U)
    throw std::runtime_error(what + ": nanosec >= 1e9");
  return header;
}

}  // namespace

BagInputs autoSelect(const BagReader& bag, const BagInputs& requested,
                     const std::string& world_frame) {
  BagInputs inputs = requested;
  for (const std::string& topic : inputs.cloud_topics)
    requireTopic(bag, "cloud_topics", topic, {kPointCloud2Type});
  if (!inputs.depth_topic.empty())
    requireTopic(bag, "depth_topic", inputs.depth_topic, {kImageType});
  if (!inputs.cloud_topics.empty() && !inputs.depth_topic.empty()) {
    refuse(bag, "name either cloud_topics or depth_topic, not both");
  }
  if (inputs.cloud_topics.empty() && inputs.depth_topic.empty()) {
    const std::vector<std::size_t> clouds = topicsOfType(bag, kPointCloud2Type);
    std::vector<std::size_t> depths;
    for (const std::size_t t : topicsOfType(bag, kImageType)) {
      const std::size_t first = firstMessageOf(bag, t);
      dds::sensor_msgs::Image_ image;
      decodeCdr(bag.read(first).data, messageName(bag, first), &image);
      if (isDepthEncoding(image.encoding_())) depths.push_back(t);
    }
    if (clouds.size() + depths.size() != 1) {
      std::string found = std::to_string(clouds.size()) + " PointCloud2 topics" +
                          (clouds.empty() ? "" : " (" + listTopics(bag, clouds) + ")") + " and " +
                          std::to_string(depths.size()) + " depth Image topics" +
                          (depths.empty() ? "" : " (" + listTopics(bag, depths) + ")");
      refuse(bag, "cannot choose the input frames: " + found +
                      "; name them with the option cloud_topics or depth_topic");
    }
    if (clouds.size() == 1) inputs.cloud_topics.push_back(bag.topics()[clouds[0]].name);
    if (depths.size() == 1) inputs.depth_topic = bag.topics()[depths[0]].name;
  }
  if (!inputs.depth_topic.empty()) {
    if (inputs.camera_info_topic.empty()) {
      const std::string& depth = inputs.depth_topic;
      const std::string sibling = depth.substr(0, depth.rfind('/') + 1) + "camera_info";
      const std::vector<std::size_t> infos = topicsOfType(bag, kCameraInfoType);
      if (bag.findTopic(sibling) != bag.topics().size()) {
        inputs.camera_info_topic = sibling;
      } else if (infos.size() == 1) {
        inputs.camera_info_topic = bag.topics()[infos[0]].name;
      } else {
        refuse(bag, "cannot choose the CameraInfo of " + depth + ": no " + sibling + " and " +
                        std::to_string(infos.size()) +
                        " CameraInfo topics; name it with the option "
                        "camera_info_topic");
      }
    }
    requireTopic(bag, "camera_info_topic", inputs.camera_info_topic, {kCameraInfoType});
  }
  if (!inputs.pose_topic.empty() && inputs.pose_from_tf)
    refuse(bag, "name pose_topic or /tf poses, not both");
  if (!inputs.pose_topic.empty()) {
    requireTopic(bag, "pose_topic", inputs.pose_topic, {kPoseStampedType, kOdometryType});
  } else if (!inputs.pose_from_tf) {
    std::vector<std::size_t> poses = topicsOfType(bag, kPoseStampedType);
    for (const std::size_t t : topicsOfType(bag, kOdometryType)) poses.push_back(t);
    const bool has_tf = bag.findTopic("/tf") != bag.topics().size();
    if (poses.size() == 1) {
      inputs.pose_topic = bag.topics()[poses[0]].name;
    } else if (poses.empty() && has_tf && !world_frame.empty()) {
      inputs.pose_from_tf = true;
    } else if (poses.empty() && has_tf) {
      refuse(bag,
             "the poses can only come from /tf: set the option world_frame (and body_frame "
             "when it is not base_link)");
    } else {
      refuse(bag, "cannot choose the pose topic among " + std::to_string(poses.size()) +
                      " PoseStamped / Odometry topics" +
                      (poses.empty() ? "" : " (" + listTopics(bag, poses) + ")") +
                      "; name it with the option pose_topic, or set world_frame for /tf");
    }
  }
  if (inputs.pose_from_tf) {
    requireTopic(bag, "/tf", "/tf", {kTfMessageType});
    if (world_frame.empty()) refuse(bag, "poses from /tf need the option world_frame");
  }
  return inputs;
}

BagFrameSource::BagFrameSource(std::shared_ptr<const BagReader> bag,
                               const BagFrameSourceOptions& options)
    : bag_(std::move(bag)), options_(options), tf_(options.world_frame, options.body_frame) {
  if (bag_ == nullptr) throw std::invalid_argument("BagFrameSource: no bag");
  if (!(options_.pose_tolerance_s > 0.0) || !std::isfinite(options_.pose_tolerance_s)) {
    throw std::invalid_argument("BagFrameSource: pose_tolerance_s must be positive");
  }
  if (options_.body_frame.empty())
    throw std::invalid_argument("BagFrameSource: body_frame is empty");
  if (options_.T_B_S && !isValidPose(*options_.T_B_S)) {
    throw std::invalid_argument("BagFrameSource: T_B_S is not a rigid transform");
  }
  inputs_ = autoSelect(*bag_, options_.inputs, options_.world_frame);
  warnings_ = bag_->warnings();
  indexFrames();
}

void BagFrameSource::addStaticTransforms(const std::vector<std::uint8_t>& bytes,
                                         const std::string& what) {
  tf2_msgs::TFMessage_ msg;
  decodeCdr(bytes, what, &msg);
  for (const auto& t : msg.transforms_()) {
    Transform T = Transform::Identity();
    if (!transformOf(t, &T)) {
      throw std::runtime_error(what + ": transform " + t.header_().frame_id_() + " -> " +
                               t.child_frame_id_() + " is not a rigid transform");
    }
    tf_.addStatic(t.header_().frame_id_(), t.child_frame_id_(), T);
  }
}

std::size_t BagFrameSource::extrinsicFor(const std::string& frame_id) {
  for (std::size_t k = 0; k < extrinsics_.size(); ++k) {
    if (extrinsics_[k].first == frame_id) return k;
  }
  Transform T_B_S = Transform::Identity();
  if (options_.T_B_S) {
    T_B_S = *options_.T_B_S;
  } else if (const std::optional<Transform> found = tf_.staticFromBody(frame_id)) {
    T_B_S = *found;
  } else {
    throw std::runtime_error(bag_->path() + ": no /tf_static path from the body frame '" +
                             options_.body_frame + "' to the sensor frame '" + frame_id +
                             "'; set the option body_frame, or give T_B_S");
  }
  extrinsics_.emplace_back(frame_id, T_B_S);
  return extrinsics_.size() - 1;
}

void BagFrameSource::addPoses(const std::vector<std::uint8_t>& bytes, const std::string& what,
                              bool odometry, std::vector<StampedTransform>* poses) const {
  StampedTransform pose;
  dds::DecodeStatus status;
  if (odometry) {
    dds::nav_msgs::Odometry_ msg;
    decodeCdr(bytes, what, &msg);
    status = dds::decodePose(msg, &pose.stamp_s, &pose.T);
  } else {
    dds::geometry_msgs::PoseStamped_ msg;
    decodeCdr(bytes, what, &msg);
    status = dds::decodePose(msg, &pose.stamp_s, &pose.T);
  }
  if (!status.ok())
    throw std::runtime_error(what + ": " + dds::toString(status.error) + ": " + status.detail);
  poses->push_back(pose);
}

void BagFrameSource::addTf(const std::vector<std::uint8_t>& bytes, const std::string& what) {
  tf2_msgs::TFMessage_ msg;
  decodeCdr(bytes, what, &msg);
  for (const auto& t : msg.transforms_()) {
    const std::string& parent = t.header_().frame_id_();
    const std::string& child = t.child_frame_id_();
    Transform T = Transform::Identity();
    if (!transformOf(t, &T) || t.header_().stamp_().nanosec_() >= 1000000000U) {
      throw std::runtime_error(what + ": transform " + parent + " -> " + child + " is not valid");
    }
    tf_.addDynamic(parent, child, dds::toSeconds(t.header_().stamp_()), T);
  }
}

BagFrameSource::Scan BagFrameSource::scanBag() {
  // One pass in log-time order, so that each chunk of the bag is decompressed once.
  const std::size_t none = bag_->topics().size();
  const std::size_t static_topic = bag_->findTopic("/tf_static");
  const bool has_static =
      static_topic != none && bag_->topics()[static_topic].type == kTfMessageType;
  const std::size_t pose_topic = bag_->findTopic(inputs_.pose_from_tf ? "/tf" : inputs_.pose_topic);
  const bool odometry = bag_->topics()[pose_topic].type == kOdometryType;
  const std::size_t info_topic =
      inputs_.depth_topic.empty() ? none : bag_->findTopic(inputs_.camera_info_topic);
  std::vector<std::size_t> input_topics;
  for (const std::string& t : inputs_.cloud_topics) input_topics.push_back(bag_->findTopic(t));
  if (!inputs_.depth_topic.empty()) input_topics.push_back(bag_->findTopic(inputs_.depth_topic));
  Scan scan;
  for (std::size_t i = 0; i < bag_->entries().size(); ++i) {
    const std::size_t topic = bag_->entries()[i].topic;
    const bool input =
        std::find(input_topics.begin(), input_topics.end(), topic) != input_topics.end();
    if (!input && topic != pose_topic && topic != info_topic &&
        !(has_static && topic == static_topic)) {
      continue;
    }
    const std::string what = messageName(*bag_, i);
    const std::vector<std::uint8_t> bytes = bag_->read(i).data;
    if (has_static && topic == static_topic) addStaticTransforms(bytes, what);
    if (topic == pose_topic && inputs_.pose_from_tf) addTf(bytes, what);
    if (topic == pose_topic && !inputs_.pose_from_tf) addPoses(bytes, what, odometry, &scan.poses);
    if (topic == info_topic)
      scan.infos.emplace_back(dds::toSeconds(headerOf(bytes, what).stamp_()), i);
    if (input) {
      const auto header = headerOf(bytes, what);
      auto id = std::find(scan.frame_ids.begin(), scan.frame_ids.end(), header.frame_id_());
      if (id == scan.frame_ids.end()) id = scan.frame_ids.insert(id, header.frame_id_());
      scan.inputs.push_back({i, dds::toSeconds(header.stamp_()),
                             static_cast<std::size_t>(id - scan.frame_ids.begin())});
    }
  }
  if (inputs_.pose_from_tf) {
    try {
      scan.poses = tf_.poses();
    } catch (const std::runtime_error& e) {
      throw std::runtime_error(bag_->path() + ": " + e.what());
    }
  }
  std::stable_sort(
      scan.poses.begin(), scan.poses.end(),
      [](const StampedTransform& a, const StampedTransform& b) { return a.stamp_s < b.stamp_s; });
  std::sort(scan.infos.begin(), scan.infos.end());
  return scan;
}

void BagFrameSource::indexFrames() {
  const Scan scan = scanBag();
  const std::vector<StampedTransform>& poses = scan.poses;
  pose_count_ = poses.size();
  if (poses.empty()) {
    throw std::runtime_error(bag_->path() + ": no pose in " +
                             (inputs_.pose_from_tf
                                  ? "/tf " + options_.world_frame + " -> " + options_.body_frame
                                  : inputs_.pose_topic));
  }
  if (!inputs_.depth_topic.empty() && scan.infos.empty()) {
    throw std::runtime_error(bag_->path() + ": " + inputs_.camera_info_topic + " has no message");
  }
  PoseBufferConfig config;
  config.tolerance_s = options_.pose_tolerance_s;
  config.horizon_s = 1e12;  // keep the whole trajectory
  config.max_future_s = 1e12;
  PoseBuffer buffer(config);
  for (const StampedTransform& p : poses) buffer.add(p.stamp_s, p.T);  // equal stamps: first kept

  double first_s = 0.0;
  double last_s = 0.0;
  for (std::size_t k = 0; k < scan.inputs.size(); ++k) {
    const Scan::Input& input = scan.inputs[k];
    FrameRef frame;
    frame.entry = input.entry;
    frame.stamp_s = input.stamp_s;
    first_s = k == 0 ? frame.stamp_s : std::min(first_s, frame.stamp_s);
    last_s = k == 0 ? frame.stamp_s : std::max(last_s, frame.stamp_s);
    const auto same =
        std::lower_bound(poses.begin(), poses.end(), frame.stamp_s - kSameStamp_s,
                         [](const StampedTransform& p, double t) { return p.stamp_s < t; });
    if (same != poses.end() && std::abs(same->stamp_s - frame.stamp_s) <= kSameStamp_s) {
      frame.T_W_B = same->T;
    } else if (buffer.lookup(frame.stamp_s, &frame.T_W_B) != PoseBuffer::LookupResult::kFound) {
      ++unpaired_;
      continue;
    }
    frame.extrinsic = extrinsicFor(scan.frame_ids[input.frame_id]);
    if (!scan.infos.empty()) {
      // The CameraInfo nearest in stamp (they rarely change; usually the same stamp).
      const auto& infos = scan.infos;
      auto it = std::lower_bound(infos.begin(), infos.end(),
                                 std::make_pair(frame.stamp_s, std::size_t{0}));
      if (it == infos.end() || (it != infos.begin() &&
                                frame.stamp_s - std::prev(it)->first < it->first - frame.stamp_s)) {
        it = std::prev(it);
      }
      frame.info_entry = it->second;
    }
    frames_.push_back(frame);
  }
  std::stable_sort(frames_.begin(), frames_.end(),
                   [](const FrameRef& a, const FrameRef& b) { return a.stamp_s < b.stamp_s; });
  if (frames_.empty()) {
    std::ostringstream m;
    m << std::fixed << std::setprecision(6) << bag_->path() << ": no input frame has a pose within "
      << options_.pose_tolerance_s << " s of its stamp (" << scan.inputs.size() << " frames";
    if (!scan.inputs.empty()) m << " " << first_s << ".." << last_s << " s";
    m << ", " << poses.size() << " poses " << poses.front().stamp_s << ".." << poses.back().stamp_s
      << " s)";
    throw std::runtime_error(m.str());
  }
  if (unpaired_ > 0) {
    warnings_.push_back(bag_->path() + ": " + std::to_string(unpaired_) + " of " +
                        std::to_string(scan.inputs.size()) + " input frames have no pose within " +
                        std::to_string(options_.pose_tolerance_s) + " s: skipped");
  }
}

datasets::SourceFrame BagFrameSource::read(std::size_t i, datasets::SourceFrameInfo* info) const {
  if (i >= frames_.size()) {
    throw std::out_of_range(bag_->path() + ": frame " + std::to_string(i) + " of " +
                            std::to_string(frames_.size()));
  }
  const FrameRef& ref = frames_[i];
  const std::string what = messageName(*bag_, ref.entry);
  const BagMessage message = bag_->read(ref.entry);
  const Transform& T_B_S = extrinsics_[ref.extrinsic].second;
  if (info != nullptr) {
    std::ostringstream name;
    name << bag_->topics()[message.topic].name << "@" << std::fixed << std::setprecision(6)
         << ref.stamp_s;
    info->name = name.str();
  }
  if (inputs_.depth_topic.empty()) {
    dds::CloudSample sample;
    decodeCdr(message.data, what, &sample);
    if (!sample.status.ok()) {
      throw std::runtime_error(what + ": " + dds::toString(sample.status.error) + ": " +
                               sample.status.detail);
    }
    PointCloudFrame frame;
    frame.stamp_s = ref.stamp_s;
    frame.T_W_B = ref.T_W_B;
    frame.T_B_S = T_B_S;
    frame.points_S.reserve(sample.points_S.size());
    for (const Eigen::Vector3f& p : sample.points_S) {
      if (p.allFinite()) frame.points_S.push_back(p);
    }
    if (info != nullptr) {
      info->points_in_file = sample.points_S.size();
      info->non_finite_dropped = sample.points_S.size() - frame.points_S.size();
    }
    return frame;
  }
  dds::sensor_msgs::Image_ image;
  decodeCdr(message.data, what, &image);
  dds::sensor_msgs::CameraInfo_ camera_info;
  decodeCdr(bag_->read(ref.info_entry).data, messageName(*bag_, ref.info_entry), &camera_info);
  DepthFrame frame;
  const dds::DecodeStatus status = dds::decodeDepthImage(image, camera_info, &frame);
  if (!status.ok())
    throw std::runtime_error(what + ": " + dds::toString(status.error) + ": " + status.detail);
  frame.stamp_s = ref.stamp_s;
  frame.T_W_B = ref.T_W_B;
  frame.T_B_S = T_B_S;
  if (info != nullptr) {
    info->points_in_file = static_cast<std::size_t>(image.width_()) * image.height_();
    info->non_finite_dropped = 0;
  }
  return frame;
}

std::string BagFrameSource::describe() const {
  std::ostringstream text;
  text << frames_.size() << " frames of " << bag_->path() << " from ";
  if (inputs_.depth_topic.empty()) {
    for (std::size_t k = 0; k < inputs_.cloud_topics.size(); ++k)
      text << (k > 0 ? ", " : "") << inputs_.cloud_topics[k];
  } else {
    text << inputs_.depth_topic << " with " << inputs_.camera_info_topic;
  }
  text << ", poses from "
       << (inputs_.pose_from_tf ? "/tf " + options_.world_frame + " -> " + options_.body_frame
                                : inputs_.pose_topic);
  if (unpaired_ > 0) text << " (" << unpaired_ << " frames without a pose skipped)";
  return text.str();
}

}  // namespace mlmap::bag
