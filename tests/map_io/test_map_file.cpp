// mlmap's map file: round trips, continuing after a load, every corruption refused, safe saves;
// and the PLY / PCD / PGM + YAML exports read back with parsers written here.

#include "../support/small_flight.h"
#include "../support/small_map_state.h"
#include "../support/temp_dir.h"
#include "mlmap/map_io/map_export.h"
#include "mlmap/map_io/map_file.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <fcntl.h>
#include <linux/fs.h>
#include <sys/ioctl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <tuple>
#include <vector>

namespace mlmap {
namespace {

namespace fs = std::filesystem;

using test::flyCheap;
MapConfig smallConfig() { return test::smallWindowConfig(); }

/// A scratch folder of this file's tests.
struct TempDir : test::TempDir {
  TempDir() : test::TempDir("mlmap_map_file_test") {}
};

std::string readAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

MapState smallState() { return test::smallMapState(); }

void expectSameState(const MapState& a, const MapState& b) {
  MapConfig b_config;
  b_config.local_map = b.local_map;
  b_config.log_odds = b.log_odds;
  EXPECT_TRUE(mapConfigDifferences(a, b_config).empty());
  EXPECT_EQ(a.window.min_index, b.window.min_index);
  EXPECT_EQ(a.window.size, b.window.size);
  EXPECT_TRUE(a.window.log_odds == b.window.log_odds);
  ASSERT_EQ(a.global_submaps.size(), b.global_submaps.size());
  for (std::size_t i = 0; i < a.global_submaps.size(); ++i) {
    EXPECT_EQ(a.global_submaps[i].first, b.global_submaps[i].first);
    ASSERT_EQ(a.global_submaps[i].second.size(), b.global_submaps[i].second.size());
    for (std::size_t k = 0; k < a.global_submaps[i].second.size(); ++k) {
      EXPECT_EQ(a.global_submaps[i].second[k].offset, b.global_submaps[i].second[k].offset);
      EXPECT_EQ(a.global_submaps[i].second[k].log_odds, b.global_submaps[i].second[k].log_odds);
    }
  }
  EXPECT_EQ(a.has_last_stamp, b.has_last_stamp);
  EXPECT_EQ(a.last_stamp_s, b.last_stamp_s);
  EXPECT_TRUE(a.T_W_B.isApprox(b.T_W_B, 1e-15));
  EXPECT_EQ(a.frames_mapped, b.frames_mapped);
}

std::string refusal(const std::string& bytes) {
  try {
    (void)io::decodeMapFile(bytes, "test.mlmap");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(MapFile, SavedFlightLoadsBackIdenticalVoxelByVoxel) {
  MapEngine engine(smallConfig());
  flyCheap(engine, 0, 30);
  const MapState saved = engine.exportState();
  ASSERT_GT(saved.global_submaps.size(), 0u) << "the flight should have slid the window";
  TempDir dir;
  const std::string path = dir.file("flight.mlmap");
  io::saveMapFile(saved, path);
  const MapState loaded = io::loadMapFile(path);
  expectSameState(saved, loaded);

  MapEngine restored(smallConfig());
  restored.restoreState(loaded);
  // Every voxel of the window and of the global map has the same state and log-odds.
  const LocalMap& a = engine.localMap();
  const LocalMap& b = restored.localMap();
  ASSERT_EQ(a.minIndex(), b.minIndex());
  std::size_t known = 0;
  for (int x = a.minIndex().x(); x < a.maxIndex().x(); ++x) {
    for (int y = a.minIndex().y(); y < a.maxIndex().y(); ++y) {
      for (int z = a.minIndex().z(); z < a.maxIndex().z(); ++z) {
        const VoxelIndex g(x, y, z);
        ASSERT_EQ(a.state(g), b.state(g));
        double la = 0.0;
        double lb = 0.0;
        ASSERT_EQ(a.logOdds(g, &la), b.logOdds(g, &lb));
        EXPECT_EQ(la, lb);
        known += a.state(g) != Occupancy::kUnknown ? 1 : 0;
      }
    }
  }
  EXPECT_GT(known, 1000u);
  std::map<std::tuple<int, int, int>, double> global_a;
  std::map<std::tuple<int, int, int>, double> global_b;
  engine.globalMap().forEachVoxel([&](const VoxelIndex& g, double l) {
    global_a[{g.x(), g.y(), g.z()}] = l;
  });
  restored.globalMap().forEachVoxel([&](const VoxelIndex& g, double l) {
    global_b[{g.x(), g.y(), g.z()}] = l;
  });
  EXPECT_GT(global_a.size(), 100u);
  EXPECT_TRUE(global_a == global_b);
  // And the same file again.
  EXPECT_EQ(io::encodeMapFile(restored.exportState()), readAll(path));
  // The snapshot planners read shows the loaded window.
  EXPECT_EQ(restored.snapshot()->windowMin_W(), engine.snapshot()->windowMin_W());
  EXPECT_EQ(restored.snapshot()->grid().cells, engine.snapshot()->grid().cells);
}

TEST(MapFile, MappingAfterALoadGivesTheSameMapAsNeverStopping) {
  MapEngine straight(smallConfig());
  flyCheap(straight, 0, 40);

  MapEngine first_half(smallConfig());
  flyCheap(first_half, 0, 20);
  const std::string bytes = io::encodeMapFile(first_half.exportState());
  MapEngine second_half(smallConfig());
  second_half.restoreState(io::decodeMapFile(bytes, "first_half"));
  flyCheap(second_half, 20, 20);

  // The same bytes: every voxel, every global record, the window position, last stamp and pose.
  EXPECT_EQ(io::encodeMapFile(second_half.exportState()),
            io::encodeMapFile(straight.exportState()));
  EXPECT_GT(straight.globalMap().voxelCount(), 100u);
}

// A map saved on one time base (wall-clock time) and a sensor on another (sim time, a clock
// reset at boot): every frame used to be refused as out of order, without a word. The first
// frame after a load that is older than the map restarts the stamp order, counted; frames older
// than it are refused as before.
TEST(MapFile, AFirstFrameOlderThanTheLoadedMapRestartsTheStampOrder) {
  MapEngine first_half(smallConfig());
  flyCheap(first_half, 0, 20);
  const MapState saved = io::decodeMapFile(io::encodeMapFile(first_half.exportState()), "saved");
  ASSERT_TRUE(saved.has_last_stamp);
  ASSERT_GT(saved.last_stamp_s, 0.6);

  MapEngine reloaded(smallConfig());
  reloaded.restoreState(saved);
  PointCloudFrame frame;
  frame.points_S = {Eigen::Vector3f(0, 0, 1)};
  frame.stamp_s = 0.5;
  EXPECT_EQ(reloaded.submit(frame), FrameStatus::kAccepted);
  EXPECT_EQ(reloaded.stats().stamp_order_restarts, 1u);
  frame.stamp_s = 0.4;
  EXPECT_EQ(reloaded.submit(frame), FrameStatus::kOutOfOrder);
  frame.stamp_s = 0.6;
  EXPECT_EQ(reloaded.submit(frame), FrameStatus::kAccepted);
  EXPECT_EQ(reloaded.stats().stamp_order_restarts, 1u);

  // On the same time base nothing restarts.
  MapEngine resumed(smallConfig());
  resumed.restoreState(saved);
  frame.stamp_s = saved.last_stamp_s + 0.1;
  EXPECT_EQ(resumed.submit(frame), FrameStatus::kAccepted);
  frame.stamp_s = saved.last_stamp_s;
  EXPECT_EQ(resumed.submit(frame), FrameStatus::kOutOfOrder);
  EXPECT_EQ(resumed.stats().stamp_order_restarts, 0u);
}

TEST(MapFile, EveryTruncationIsRefusedAsTruncated) {
  const std::string bytes = io::encodeMapFile(smallState());
  ASSERT_GT(bytes.size(), 2000u);
  expectSameState(io::decodeMapFile(bytes, "x"), smallState());
  EXPECT_NE(refusal("").find("not an mlmap map file"), std::string::npos);
  for (std::size_t cut = 1; cut < bytes.size(); ++cut) {
    const std::string message = refusal(bytes.substr(0, cut));
    ASSERT_NE(message.find("test.mlmap: truncated"), std::string::npos)
        << "cut at " << cut << ": " << message;
  }
}

TEST(MapFile, EveryFlippedBitIsRefused) {
  const std::string bytes = io::encodeMapFile(smallState());
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    for (int bit = 0; bit < 8; ++bit) {
      std::string corrupt = bytes;
      corrupt[i] = static_cast<char>(corrupt[i] ^ (1 << bit));
      const std::string message = refusal(corrupt);
      ASSERT_FALSE(message.empty()) << "bit " << bit << " of byte " << i << " went unnoticed";
      ASSERT_EQ(message.rfind("test.mlmap: ", 0), 0u) << message;
    }
  }
}

TEST(MapFile, WrongMagicVersionOrTrailingDataIsRefusedWithItsReason) {
  const std::string bytes = io::encodeMapFile(smallState());
  std::string png = bytes;
  png.replace(0, 8, "\x89PNG\r\n\x1a\n");
  EXPECT_NE(refusal(png).find("not an mlmap map file"), std::string::npos);
  // Version 2 (its header checksum no longer matches, but the version is checked first, so a
  // newer file is reported as newer, not as corrupted).
  std::string v2 = bytes;
  v2[8] = 2;
  EXPECT_NE(refusal(v2).find("map file format version 2, this build reads version 1"),
            std::string::npos)
      << refusal(v2);
  EXPECT_NE(refusal(bytes + "x").find("1 bytes after the end of the map"), std::string::npos);
  std::string header = bytes;
  header[40] = static_cast<char>(header[40] ^ 1);  // a window size byte
  EXPECT_NE(refusal(header).find("header checksum mismatch"), std::string::npos);
  std::string local = bytes;
  local[300] = static_cast<char>(local[300] ^ 1);
  EXPECT_NE(refusal(local).find("local map checksum mismatch"), std::string::npos);
  std::string global = bytes;
  global[bytes.size() - 20] = static_cast<char>(global[bytes.size() - 20] ^ 1);
  EXPECT_NE(refusal(global).find("global map checksum mismatch"), std::string::npos);
}

TEST(MapFile, AMapOfAnotherConfigurationIsRefusedNamingTheFields) {
  MapEngine engine(smallConfig());
  flyCheap(engine, 0, 5);
  const MapState state = engine.exportState();
  MapConfig other = smallConfig();
  EXPECT_NO_THROW(io::checkMapMatchesConfig(state, other, "a.mlmap"));
  other.local_map.resolution_m = 0.1;
  other.log_odds.hit = 0.6;
  try {
    io::checkMapMatchesConfig(state, other, "a.mlmap");
    FAIL() << "accepted a map of another resolution";
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("a.mlmap: made with a different configuration"), std::string::npos) << m;
    EXPECT_NE(m.find("local_map.resolution_m is 0.2 in the map, 0.1 in the configuration"),
              std::string::npos)
        << m;
    EXPECT_NE(m.find("log_odds.hit is 0.85 in the map, 0.6 in the configuration"),
              std::string::npos)
        << m;
  }
  EXPECT_NE(io::mapConfigFingerprint(state.local_map, state.log_odds),
            io::mapConfigFingerprint(other.local_map, other.log_odds));
  // The engine itself refuses it too, and keeps its map.
  MapEngine wrong(other);
  EXPECT_THROW(wrong.restoreState(state), std::invalid_argument);
  EXPECT_FALSE(wrong.localMap().placed());
}

TEST(MapFile, TheEngineRefusesInconsistentStatesAndKeepsItsMap) {
  MapConfig c;
  c.local_map = smallState().local_map;
  MapEngine engine(c);
  engine.restoreState(smallState());
  const std::string before = io::encodeMapFile(engine.exportState());
  auto refused = [&](const MapState& s, const std::string& expected) {
    try {
      engine.restoreState(s);
      ADD_FAILURE() << "accepted: " << expected;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
    EXPECT_EQ(io::encodeMapFile(engine.exportState()), before);
    // The same state in a file with valid checksums: the loader refuses it too, before any
    // program (mlmap_map_tool's exports, say) could index with it.
    try {
      (void)io::decodeMapFile(io::encodeMapFile(s), "bad.mlmap");
      ADD_FAILURE() << "the file was accepted: " << expected;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("bad.mlmap: inconsistent map: "), std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  MapState s = smallState();
  s.global_submaps[0].second[1].offset = 1000;  // a 2 x 2 x 2 submap has 8 voxels
  refused(s, "is not an occupied voxel of the submap");
  s = smallState();
  s.global_submaps[0].second[1].log_odds = -5;  // free: the global map holds occupied voxels only
  refused(s, "is not an occupied voxel of the submap");
  s = smallState();
  s.window.log_odds[3] = 9000;
  refused(s, "outside the clamping bounds");
  s = smallState();
  s.window.min_index.x() += 1;
  refused(s, "not on the submap grid");
  s = smallState();
  s.global_submaps.push_back(s.global_submaps[0]);
  refused(s, "a global submap is listed twice");
  s = smallState();
  s.global_submaps[1].first = SubmapIndex(-1, 2, 4);  // the window's submaps: (-2..2, 1..5, 3..7)
  refused(s, "lies inside the local window");
  s = smallState();
  s.global_submaps[1].first =
      SubmapIndex(GlobalMap::kSubmapIndexLimit, 0, 0);  // would alias -limit
  refused(s, "is out of range");
  s = smallState();
  s.global_submaps[0].first = SubmapIndex(-GlobalMap::kSubmapIndexLimit - 1, 0, 0);
  refused(s, "is out of range");
  s = smallState();
  s.window.min_index.x() = 2147483646;  // min_index + size would overflow int
  refused(s, "is beyond");
  // The stamp and pose pass the checks a live frame's do: a body 1e300 m up used to hang the 2D
  // grid's band computation of every program that loaded the map.
  s = smallState();
  s.T_W_B.translation().z() = 1e300;
  refused(s, "last body pose is not a valid pose within 1e+06 m");
  s = smallState();
  s.T_W_B.translation().x() = -2e6;
  refused(s, "last body pose");
  s = smallState();
  s.has_last_stamp = true;
  s.last_stamp_s = std::nan("");
  refused(s, "last stamp is not finite");
}

// Only a regular file within the size limit is read, and only past a header that checks out:
// /dev/zero as a map allocated until std::bad_alloc; a directory gave a libstdc++ message
// without the path.
TEST(MapFile, OnlyARegularFileWithAValidHeaderIsReadWhole) {
  TempDir dir;
  auto loadError = [](const std::string& path) {
    try {
      (void)io::loadMapFile(path);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(loadError("/dev/zero").find("/dev/zero: is not a regular file"), std::string::npos);
  EXPECT_NE(loadError(dir.path.string()).find(dir.path.string() + ": is a directory"),
            std::string::npos);
  EXPECT_NE(loadError(dir.file("missing.mlmap")).find("missing.mlmap: cannot open"),
            std::string::npos);
  // A header announcing more than the file holds is refused from the header alone.
  const std::string path = dir.file("short.mlmap");
  const std::string bytes = io::encodeMapFile(smallState());
  {
    std::ofstream out(path, std::ios::binary);
    out << bytes.substr(0, bytes.size() / 2);
  }
  EXPECT_NE(loadError(path).find("truncated"), std::string::npos) << loadError(path);
  {
    std::ofstream out(path, std::ios::binary);
    out << "not a map at all, just text";
  }
  EXPECT_NE(loadError(path).find("not an mlmap map file"), std::string::npos) << loadError(path);
}

// A save killed before its rename leaves "<name>.tmp-XXXXXX"; the next save removes it, and
// nothing else.
TEST(MapFile, TheNextSaveRemovesTemporaryFilesOfAnInterruptedOne) {
  TempDir dir;
  const std::string path = dir.file("map.mlmap");
  for (const char* name : {"map.mlmap.tmp-a1B2c3", "map.mlmap.tmp-ZZZZZZ"}) {
    std::ofstream(dir.file(name)) << "half a map";
  }
  for (const char* name : {"map.mlmap.tmp-toolong1", "other.mlmap.tmp-a1B2c3", "map.mlmap.tmp-"}) {
    std::ofstream(dir.file(name)) << "not ours";
  }
  io::saveMapFile(smallState(), path);
  std::vector<std::string> left;
  for (const auto& entry : fs::directory_iterator(dir.path))
    left.push_back(entry.path().filename());
  std::sort(left.begin(), left.end());
  EXPECT_EQ(left, (std::vector<std::string>{"map.mlmap", "map.mlmap.tmp-", "map.mlmap.tmp-toolong1",
                                            "other.mlmap.tmp-a1B2c3"}));
  EXPECT_EQ(removeLeftoverTemporaries(path), 0u);
}

TEST(MapFile, AFailedSaveLeavesThePreviousFileAndNoTemporaryFile) {
  TempDir dir;
  const std::string path = dir.file("map.mlmap");
  const MapState first = smallState();
  io::saveMapFile(first, path);
  MapEngine engine(smallConfig());
  flyCheap(engine, 0, 10);
  const MapState bigger = engine.exportState();
  // A full disk, simulated with a file size limit (works as root too).
  struct rlimit old_limit {};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old_limit), 0);
  const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
  struct rlimit small = old_limit;
  small.rlim_cur = 4096;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  std::string message;
  try {
    io::saveMapFile(bigger, path);
  } catch (const std::runtime_error& e) {
    message = e.what();
  }
  ::setrlimit(RLIMIT_FSIZE, &old_limit);
  std::signal(SIGXFSZ, old_handler);
  EXPECT_NE(message.find("cannot write '" + path + "': write failed after"), std::string::npos)
      << message;
  expectSameState(io::loadMapFile(path), first);
  for (const auto& entry : fs::directory_iterator(dir.path)) {
    EXPECT_EQ(entry.path().filename(), "map.mlmap") << "left behind: " << entry.path();
  }
  // A folder that does not exist.
  EXPECT_THROW(io::saveMapFile(first, dir.file("missing/map.mlmap")), std::runtime_error);
}

TEST(MapFile, SavingIntoAReadOnlyFolderFailsCleanly) {
  TempDir dir;
  const fs::path ro = dir.path / "ro";
  fs::create_directories(ro);
  const std::string path = (ro / "map.mlmap").string();
  io::saveMapFile(smallState(), path);
  // Not writable: permissions for a normal user; for root (who ignores them) the immutable flag.
  bool immutable = false;
  int fd = -1;
  if (::geteuid() == 0) {
    fd = ::open(ro.c_str(), O_RDONLY | O_DIRECTORY);
    int flags = 0;
    if (fd < 0 || ::ioctl(fd, FS_IOC_GETFLAGS, &flags) != 0) GTEST_SKIP() << "no inode flags here";
    flags |= FS_IMMUTABLE_FL;
    if (::ioctl(fd, FS_IOC_SETFLAGS, &flags) != 0) {
      ::close(fd);
      GTEST_SKIP() << "running as root on a file system without the immutable flag";
    }
    immutable = true;
  } else {
    fs::permissions(ro, fs::perms::owner_read | fs::perms::owner_exec);
  }
  MapState changed = smallState();
  changed.frames_mapped = 43;
  std::string message;
  try {
    io::saveMapFile(changed, path);
  } catch (const std::runtime_error& e) {
    message = e.what();
  }
  if (immutable) {
    int flags = 0;
    ::ioctl(fd, FS_IOC_GETFLAGS, &flags);
    flags &= ~FS_IMMUTABLE_FL;
    ::ioctl(fd, FS_IOC_SETFLAGS, &flags);
    ::close(fd);
  } else {
    fs::permissions(ro, fs::perms::owner_all);
  }
  EXPECT_NE(message.find("cannot write '" + path + "': cannot create a temporary file"),
            std::string::npos)
      << message;
  expectSameState(io::loadMapFile(path), smallState());
}

// ---- Exports ---------------------------------------------------------------------------------

// Splits "header\n...end_header\n" (PLY) or up to the DATA line (PCD) from the payload.
std::vector<std::string> headerLines(const std::string& bytes, const std::string& last,
                                     std::size_t* payload) {
  std::vector<std::string> lines;
  std::size_t pos = 0;
  for (;;) {
    const std::size_t end = bytes.find('\n', pos);
    if (end == std::string::npos) return {};
    lines.push_back(bytes.substr(pos, end - pos));
    pos = end + 1;
    if (lines.back() == last) break;
  }
  *payload = pos;
  return lines;
}

float floatAt(const std::string& bytes, std::size_t pos) {
  std::uint32_t u = 0;
  for (int i = 0; i < 4; ++i)
    u |= static_cast<std::uint32_t>(static_cast<std::uint8_t>(bytes[pos + i])) << (8 * i);
  float f = 0.0f;
  std::memcpy(&f, &u, sizeof f);
  return f;
}

// The engine's occupied voxels with their log-odds, straight from its layers.
std::map<std::tuple<int, int, int>, double> engineOccupied(const MapEngine& engine) {
  std::map<std::tuple<int, int, int>, double> out;
  engine.globalMap().forEachVoxel([&](const VoxelIndex& g, double l) {
    out[{g.x(), g.y(), g.z()}] = l;
  });
  engine.localMap().forEachOccupied([&](const VoxelIndex& g, double l) {
    out[{g.x(), g.y(), g.z()}] = l;
  });
  return out;
}

std::tuple<int, int, int> voxelOf(float x, float y, float z, double res) {
  const VoxelIndex g = voxelIndexOf(Eigen::Vector3d(x, y, z), res);
  return {g.x(), g.y(), g.z()};
}

TEST(MapExport, PlyAndPcdHoldEveryOccupiedVoxelCentreAndItsProbability) {
  MapEngine engine(smallConfig());
  flyCheap(engine, 0, 30);
  const double res = 0.2;
  const auto expected = engineOccupied(engine);
  ASSERT_GT(expected.size(), 500u);
  const std::vector<io::OccupiedVoxel> voxels = io::occupiedVoxels(engine.exportState());
  TempDir dir;
  io::writePly(voxels, res, dir.file("map.ply"));
  io::writePcd(voxels, res, dir.file("map.pcd"));

  const std::string ply = readAll(dir.file("map.ply"));
  std::size_t payload = 0;
  std::vector<std::string> h = headerLines(ply, "end_header", &payload);
  ASSERT_GE(h.size(), 10u);
  EXPECT_EQ(h[0], "ply");
  EXPECT_EQ(h[1], "format binary_little_endian 1.0");
  const std::vector<std::string> properties(h.end() - 6, h.end() - 1);
  EXPECT_EQ(properties,
            (std::vector<std::string>{"property float x", "property float y", "property float z",
                                      "property float log_odds", "property float probability"}));
  EXPECT_EQ(h[h.size() - 7], "element vertex " + std::to_string(expected.size()));
  ASSERT_EQ(ply.size() - payload, expected.size() * 20);
  std::map<std::tuple<int, int, int>, double> seen;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const std::size_t p = payload + i * 20;
    const float x = floatAt(ply, p);
    const float y = floatAt(ply, p + 4);
    const float z = floatAt(ply, p + 8);
    const auto key = voxelOf(x, y, z, res);
    const Eigen::Vector3d centre =
        voxelCenter(VoxelIndex(std::get<0>(key), std::get<1>(key), std::get<2>(key)), res);
    EXPECT_FLOAT_EQ(x, static_cast<float>(centre.x()));
    EXPECT_FLOAT_EQ(z, static_cast<float>(centre.z()));
    seen[key] = floatAt(ply, p + 12);
    const auto it = expected.find(key);
    ASSERT_NE(it, expected.end());
    EXPECT_NEAR(floatAt(ply, p + 12), it->second, 1e-6);
    EXPECT_NEAR(floatAt(ply, p + 16), 1.0 / (1.0 + std::exp(-it->second)), 1e-6);
  }
  EXPECT_EQ(seen.size(), expected.size());

  const std::string pcd = readAll(dir.file("map.pcd"));
  h = headerLines(pcd, "DATA binary", &payload);
  ASSERT_FALSE(h.empty());
  auto has = [&h](const std::string& line) {
    return std::find(h.begin(), h.end(), line) != h.end();
  };
  EXPECT_TRUE(has("VERSION 0.7"));
  EXPECT_TRUE(has("FIELDS x y z intensity"));
  EXPECT_TRUE(has("SIZE 4 4 4 4"));
  EXPECT_TRUE(has("TYPE F F F F"));
  EXPECT_TRUE(has("COUNT 1 1 1 1"));
  EXPECT_TRUE(has("WIDTH " + std::to_string(expected.size())));
  EXPECT_TRUE(has("HEIGHT 1"));
  EXPECT_TRUE(has("POINTS " + std::to_string(expected.size())));
  ASSERT_EQ(pcd.size() - payload, expected.size() * 16);
  seen.clear();
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const std::size_t p = payload + i * 16;
    const auto key = voxelOf(floatAt(pcd, p), floatAt(pcd, p + 4), floatAt(pcd, p + 8), res);
    const auto it = expected.find(key);
    ASSERT_NE(it, expected.end());
    EXPECT_NEAR(floatAt(pcd, p + 12), 1.0 / (1.0 + std::exp(-it->second)), 1e-6);
    seen[key] = 1.0;
  }
  EXPECT_EQ(seen.size(), expected.size());
}

// Reads a binary PGM (P5, comments allowed), returns width, height and the pixels.
std::vector<std::uint8_t> readPgm(const std::string& bytes, int* width, int* height) {
  std::istringstream in(bytes);
  std::string magic;
  in >> magic;
  EXPECT_EQ(magic, "P5");
  std::vector<int> numbers;
  while (numbers.size() < 3) {
    in >> std::ws;
    if (in.peek() == '#') {
      std::string comment;
      std::getline(in, comment);
      continue;
    }
    int v = 0;
    in >> v;
    numbers.push_back(v);
  }
  in.get();  // the single whitespace after maxval
  EXPECT_EQ(numbers[2], 255);
  *width = numbers[0];
  *height = numbers[1];
  const std::size_t start = static_cast<std::size_t>(in.tellg());
  EXPECT_EQ(bytes.size() - start,
            static_cast<std::size_t>(*width) * static_cast<std::size_t>(*height));
  return std::vector<std::uint8_t>(bytes.begin() + static_cast<std::ptrdiff_t>(start), bytes.end());
}

TEST(MapExport, PgmAndYamlMatchTheGridCellByCellAsMapServerReadsThem) {
  MapEngine engine(smallConfig());
  flyCheap(engine, 0, 30);
  const MapState state = engine.exportState();
  // The export's grid of the local window is the engine's own snapshot grid.
  const ProjectedGrid grid = io::projectMap(state, smallConfig().projected_grid);
  const ProjectedGrid& snap = engine.snapshot()->grid();
  EXPECT_EQ(grid.cells, snap.cells);
  EXPECT_EQ(grid.origin_W, snap.origin_W);
  ProjectedGridConfig probability = smallConfig().projected_grid;
  probability.probability_values = true;
  probability.include_global = true;
  TempDir dir;
  for (const ProjectedGrid& g : {grid, io::projectMap(state, probability)}) {
    io::writeGridMap(g, dir.file("map"));
    int w = 0;
    int h = 0;
    const std::vector<std::uint8_t> pixels = readPgm(readAll(dir.file("map.pgm")), &w, &h);
    ASSERT_EQ(w, g.width);
    ASSERT_EQ(h, g.height);
    std::size_t counts[3] = {0, 0, 0};
    for (int row = 0; row < h; ++row) {
      for (int x = 0; x < w; ++x) {
        const int v = g.at(x, h - 1 - row);  // the image's first row is the grid's last (top = +y)
        const std::uint8_t expected = v < 0 ? 205 : v <= 25 ? 254 : v >= 65 ? 0 : 205;
        ASSERT_EQ(pixels[static_cast<std::size_t>(row * w + x)], expected) << x << ", " << row;
        counts[expected == 0 ? 0 : expected == 254 ? 1 : 2]++;
      }
    }
    EXPECT_GT(counts[0], 10u);
    EXPECT_GT(counts[1], 100u);
    EXPECT_GT(counts[2], 10u);
    const YAML::Node yaml = YAML::LoadFile(dir.file("map.yaml"));
    EXPECT_EQ(yaml.size(), 7u);
    EXPECT_EQ(yaml["image"].as<std::string>(), "map.pgm");
    EXPECT_EQ(yaml["mode"].as<std::string>(), "trinary");
    EXPECT_EQ(yaml["resolution"].as<double>(), g.resolution_m);
    ASSERT_EQ(yaml["origin"].size(), 3u);
    EXPECT_NEAR(yaml["origin"][0].as<double>(), g.origin_W.x(), 1e-9);
    EXPECT_NEAR(yaml["origin"][1].as<double>(), g.origin_W.y(), 1e-9);
    EXPECT_EQ(yaml["origin"][2].as<double>(), 0.0);
    EXPECT_EQ(yaml["negate"].as<int>(), 0);
    // Load the image back as map_server does (trinary, negate 0): occ = (255 - p) / 255,
    // occupied above occupied_thresh, free below free_thresh, unknown otherwise. Every cell must
    // come back as the grid's own three-state reading.
    const double occupied_thresh = yaml["occupied_thresh"].as<double>();
    const double free_thresh = yaml["free_thresh"].as<double>();
    for (int row = 0; row < h; ++row) {
      for (int x = 0; x < w; ++x) {
        const int v = g.at(x, h - 1 - row);
        const int expected = v < 0 ? -1 : v <= 25 ? 0 : v >= 65 ? 100 : -1;
        const double occ = (255.0 - pixels[static_cast<std::size_t>(row * w + x)]) / 255.0;
        const int loaded = occ > occupied_thresh ? 100 : occ < free_thresh ? 0 : -1;
        ASSERT_EQ(loaded, expected) << "cell " << x << ", " << row << " (grid value " << v << ")";
      }
    }
  }
}

TEST(MapExport, AGridOverFarApartSubmapsIsRefusedBeforeItIsAllocated) {
  MapState s = smallState();
  ProjectedGridConfig all_heights;
  all_heights.relative_band = false;
  all_heights.band_min_m = -1e3;
  all_heights.band_max_m = 1e3;
  all_heights.include_global = true;
  EXPECT_GT(io::projectMap(s, all_heights).cells.size(), 0u);
  // 2-voxel submaps 10,000 apart on x and y: 20,000 x 20,000 cells, over the 2^28 limit.
  s.global_submaps.push_back({SubmapIndex(10000, 10000, 0), {{0, 850}}});
  try {
    (void)io::projectMap(s, all_heights);
    ADD_FAILURE() << "a 4e8-cell grid was made";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("lie far apart"), std::string::npos) << e.what();
  }
  all_heights.include_global = false;  // the local window alone is fine
  EXPECT_GT(io::projectMap(s, all_heights).cells.size(), 0u);
}

}  // namespace
}  // namespace mlmap
