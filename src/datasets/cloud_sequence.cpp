#include "mlmap/datasets/cloud_sequence.h"

#include "mlmap/core/pose_buffer.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <stdexcept>

namespace mlmap::datasets {
namespace {

namespace fs = std::filesystem;

constexpr double kSameStamp_s = 1e-6;  // as PoseBuffer: stamps this close are the same

std::string stem(const std::string& file_name) {
  const std::size_t dot = file_name.rfind('.');
  return dot == std::string::npos ? file_name : file_name.substr(0, dot);
}

bool allDigits(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) {
    return std::isdigit(static_cast<unsigned char>(c));
  });
}

}  // namespace

const char* toString(CloudPairing pairing) {
  return pairing == CloudPairing::kByTime ? "by time (file names are stamps)" : "by order";
}

std::optional<double> stampFromFileName(const std::string& file_name) {
  const std::string s = stem(file_name);
  const std::size_t dot = s.find('.');
  if (dot == std::string::npos) {
    // Epoch stamps as integers, told apart by their length (since 2001 and for centuries):
    // 19-20 digits are nanoseconds, 16-17 microseconds. Split so that the seconds keep their
    // precision in a double.
    std::size_t fraction_digits = 0;
    if (allDigits(s) && s.size() >= 19 && s.size() <= 20) fraction_digits = 9;
    if (allDigits(s) && s.size() >= 16 && s.size() <= 17) fraction_digits = 6;
    if (fraction_digits == 0) return std::nullopt;
    const std::string sec = s.substr(0, s.size() - fraction_digits);
    const std::string fraction = s.substr(s.size() - fraction_digits);
    return std::strtod(sec.c_str(), nullptr) +
           std::strtod(fraction.c_str(), nullptr) * (fraction_digits == 9 ? 1e-9 : 1e-6);
  }
  if (!allDigits(s.substr(0, dot)) || !allDigits(s.substr(dot + 1))) return std::nullopt;
  return std::strtod(s.c_str(), nullptr);
}

bool naturalLess(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const bool da = std::isdigit(static_cast<unsigned char>(a[i])) != 0;
    const bool db = std::isdigit(static_cast<unsigned char>(b[j])) != 0;
    if (da && db) {
      std::size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      // Compare the numbers without leading zeros: longer is larger, then digit by digit.
      std::size_t ia = i, jb = j;
      while (ia + 1 < ie && a[ia] == '0') ++ia;
      while (jb + 1 < je && b[jb] == '0') ++jb;
      if (ie - ia != je - jb) return ie - ia < je - jb;
      const int c = a.compare(ia, ie - ia, b, jb, je - jb);
      if (c != 0) return c < 0;
      if (ie - i != je - j) return ie - i < je - j;  // "007" after "7": stable, total order
      i = ie;
      j = je;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i;
      ++j;
    }
  }
  return i == a.size() && j < b.size();  // a ran out first (equal when both did)
}

std::vector<PairedCloud> pairCloudsWithPoses(std::vector<std::string> file_names,
                                             const std::vector<StampedPose>& poses,
                                             double pose_tolerance_s, CloudPairing* pairing,
                                             std::vector<std::string>* unpaired) {
  if (file_names.empty()) throw std::runtime_error("no point-cloud files (.pcd, .ply)");
  if (poses.empty()) throw std::runtime_error("no poses");
  std::vector<std::optional<double>> stamps;
  bool by_time = true;
  for (const std::string& name : file_names) {
    stamps.push_back(stampFromFileName(name));
    by_time = by_time && stamps.back().has_value();
  }
  std::vector<PairedCloud> out;
  if (!by_time) {
    *pairing = CloudPairing::kByOrder;
    if (file_names.size() != poses.size()) {
      throw std::runtime_error(std::to_string(file_names.size()) + " clouds but " +
                               std::to_string(poses.size()) +
                               " poses: pairing by order (file names are not time stamps) needs "
                               "one pose per cloud; name the clouds by their time stamp "
                               "(e.g. 1305031102.175304.pcd) to pair them by time");
    }
    std::sort(file_names.begin(), file_names.end(), naturalLess);
    for (std::size_t i = 0; i < file_names.size(); ++i) {
      out.push_back({file_names[i], poses[i].stamp_s, poses[i].T_W_P});
    }
    return out;
  }
  *pairing = CloudPairing::kByTime;
  std::vector<std::size_t> order(file_names.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return *stamps[a] < *stamps[b]; });
  PoseBufferConfig config;
  config.tolerance_s = pose_tolerance_s;
  config.horizon_s = 1e12;  // keep the whole trajectory
  config.max_future_s = 1e12;
  PoseBuffer buffer(config);
  for (const StampedPose& p : poses) buffer.add(p.stamp_s, p.T_W_P);  // checked by the reader
  for (std::size_t k = 0; k < order.size(); ++k) {
    const std::size_t i = order[k];
    if (k > 0 && *stamps[i] <= *stamps[order[k - 1]]) {
      throw std::runtime_error("clouds '" + file_names[order[k - 1]] + "' and '" + file_names[i] +
                               "' have the same time stamp");
    }
    // A pose with the cloud's stamp is used as read (PoseBuffer would pass it through slerp).
    const auto same =
        std::lower_bound(poses.begin(), poses.end(), *stamps[i] - kSameStamp_s,
                         [](const StampedPose& p, double t) { return p.stamp_s < t; });
    Transform T = Transform::Identity();
    if (same != poses.end() && std::abs(same->stamp_s - *stamps[i]) <= kSameStamp_s) {
      out.push_back({file_names[i], *stamps[i], same->T_W_P});
    } else if (buffer.lookup(*stamps[i], &T) == PoseBuffer::LookupResult::kFound) {
      out.push_back({file_names[i], *stamps[i], T});
    } else if (unpaired != nullptr) {
      unpaired->push_back(file_names[i]);
    }
  }
  if (out.empty()) {
    std::ostringstream m;
    m << std::fixed << std::setprecision(6) << "no cloud has a pose within " << pose_tolerance_s
      << " s of its stamp (clouds " << *stamps[order.front()] << ".." << *stamps[order.back()]
      << " s, poses " << poses.front().stamp_s << ".." << poses.back().stamp_s << " s)";
    throw std::runtime_error(m.str());
  }
  return out;
}

CloudSequence::CloudSequence(const std::string& clouds_dir, const std::string& poses_path,
                             const CloudSequenceOptions& options)
    : dir_(clouds_dir), options_(options) {
  if (!(std::isfinite(options.pose_tolerance_s) && options.pose_tolerance_s > 0.0)) {
    throw std::invalid_argument("pose_tolerance_s must be > 0");
  }
  if (!isValidPose(options.T_P_C, 1e-6))
    throw std::invalid_argument("the extrinsic is not a rigid transform");
  std::error_code ec;
  if (!fs::is_directory(clouds_dir, ec)) throw std::runtime_error(clouds_dir + ": not a directory");
  std::vector<std::string> names;
  for (const fs::directory_entry& e : fs::directory_iterator(clouds_dir)) {
    const std::string name = e.path().filename().string();
    if (e.is_regular_file() && isPointCloudFileName(name)) names.push_back(name);
  }
  const std::vector<StampedPose> poses = readPoseFile(poses_path);
  pose_count_ = poses.size();
  try {
    clouds_ = pairCloudsWithPoses(names, poses, options.pose_tolerance_s, &pairing_, &unpaired_);
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(clouds_dir + " with " + poses_path + ": " + e.what());
  }
}

PointCloudFrame CloudSequence::read(std::size_t i, PointCloudFile* file) const {
  if (i >= clouds_.size()) throw std::out_of_range("CloudSequence::read: index out of range");
  const PairedCloud& c = clouds_[i];
  PointCloudFile cloud = readPointCloudFile((fs::path(dir_) / c.file_name).string());
  PointCloudFrame frame;
  frame.stamp_s = c.stamp_s;
  frame.T_W_B = c.T_W_P;
  frame.T_B_S = options_.T_P_C * cloud.T_C_V;
  if (cloud.T_C_V.matrix() == Eigen::Matrix4d::Identity()) {
    frame.points_S = std::move(cloud.points_C);
  } else {
    const Eigen::Isometry3f T_V_C = cloud.T_C_V.inverse().cast<float>();
    frame.points_S.reserve(cloud.points_C.size());
    for (const Eigen::Vector3f& p : cloud.points_C) frame.points_S.push_back(T_V_C * p);
    cloud.points_C.clear();
  }
  if (file != nullptr) *file = std::move(cloud);
  return frame;
}

}  // namespace mlmap::datasets
