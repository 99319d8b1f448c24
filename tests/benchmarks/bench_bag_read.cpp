/// @file
/// Reading speed of a ROS 2 bag through BagFrameSource: open (index, poses, pairing), then every
/// frame read and decoded, as the replay would. Prints the times and the rates in MB/s of the
/// file and of the decoded messages.
///
///   build/mlmap_bench_bag_read BAG [--world-frame F] [--body-frame B] [--cloud-topic T]

#include "mlmap/bag/bag_frame_source.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace {

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::uint64_t bytesOnDisk(const std::string& path) {
  namespace fs = std::filesystem;
  if (!fs::is_directory(path)) return fs::file_size(path);
  std::uint64_t total = 0;
  for (const auto& entry : fs::directory_iterator(path)) {
    if (entry.is_regular_file()) total += entry.file_size();
  }
  return total;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s BAG [--world-frame F] [--body-frame B] [--cloud-topic T]\n",
                 argv[0]);
    return 2;
  }
  const std::string path = argv[1];
  mlmap::bag::BagFrameSourceOptions options;
  for (int k = 2; k + 1 < argc; k += 2) {
    const std::string flag = argv[k];
    if (flag == "--world-frame") {
      options.world_frame = argv[k + 1];
    } else if (flag == "--body-frame") {
      options.body_frame = argv[k + 1];
    } else if (flag == "--cloud-topic") {
      options.inputs.cloud_topics.push_back(argv[k + 1]);
    } else {
      std::fprintf(stderr, "unknown option %s\n", flag.c_str());
      return 2;
    }
  }
  try {
    const auto start = std::chrono::steady_clock::now();
    const mlmap::bag::BagFrameSource source(mlmap::bag::openBag(path), options);
    const double open_s = secondsSince(start);
    std::uint64_t message_bytes = 0;
    std::uint64_t points = 0;
    const auto read_start = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < source.size(); ++i) {
      mlmap::datasets::SourceFrameInfo info;
      const mlmap::datasets::SourceFrame frame = source.read(i, &info);
      points += info.points_in_file;
      message_bytes += std::visit(
          [](const auto& f) -> std::uint64_t {
            using F = std::decay_t<decltype(f)>;
            if constexpr (std::is_same_v<F, mlmap::PointCloudFrame>)
              return f.points_S.size() * 12;
            else
              return f.depth_mm.size() * 2 + f.depth_m.size() * 4;
          },
          frame);
    }
    const double read_s = secondsSince(read_start);
    const double file_mb = static_cast<double>(bytesOnDisk(path)) / 1e6;
    std::printf("%s\n", source.describe().c_str());
    std::printf(
        "file %.1f MB; open (index, poses, pairing) %.3f s; read + decode %zu frames "
        "(%llu points) %.3f s\n",
        file_mb, open_s, source.size(), static_cast<unsigned long long>(points), read_s);
    std::printf("file rate (open + read): %.1f MB/s; decoded x,y,z: %.1f MB/s; %.1f frames/s\n",
                file_mb / (open_s + read_s), static_cast<double>(message_bytes) / 1e6 / read_s,
                static_cast<double>(source.size()) / read_s);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
