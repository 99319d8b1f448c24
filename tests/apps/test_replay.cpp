// mlmap_replay end to end: recorded data written by the test, replayed by the program, and the
// occupied voxels compared with the same data mapped directly through MapEngine.

#include "mlmap/eval/run_outputs.h"
#include "mlmap/map_io/map_export.h"
#include "mlmap/map_io/map_file.h"
#include "mlmap/map_io/voxel_text.h"
#include "mlmap/datasets/world_yaml.h"
#include "mlmap/pipeline/map_engine.h"
#include "mlmap/sim/depth_camera.h"

#include "../support/cloud_file_writers.h"
#include "../support/small_flight.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <thread>

#if !defined(MLMAP_REPLAY_BIN) || !defined(MLMAP_DEMO_BIN) || !defined(MLMAP_SHARED_DATA_DIR) || \
    !defined(MLMAP_SOURCE_DIR)
#error \
    "MLMAP_REPLAY_BIN, MLMAP_DEMO_BIN, MLMAP_SHARED_DATA_DIR and MLMAP_SOURCE_DIR must be defined"
#endif

namespace mlmap {
namespace {

namespace fs = std::filesystem;
using mlmap::testing::fmt;

std::string readText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Runs a command, its output going to `log`; returns its exit status.
int run(const std::string& command, const std::string& log) {
  const int rc = std::system((command + " > '" + log + "' 2>&1").c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

/// The integer value of `"key": N` in a JSON text (first occurrence), or -1.
long jsonInt(const std::string& json, const std::string& key) {
  const std::size_t at = json.find("\"" + key + "\": ");
  if (at == std::string::npos) return -1;
  return std::strtol(json.c_str() + at + key.size() + 4, nullptr, 10);
}

/// The number of `"key": X` in a JSON text (first occurrence), or NaN.
double jsonDouble(const std::string& json, const std::string& key) {
  const std::size_t at = json.find("\"" + key + "\": ");
  if (at == std::string::npos) return std::numeric_limits<double>::quiet_NaN();
  return std::strtod(json.c_str() + at + key.size() + 4, nullptr);
}

/// "x y z qx qy qz qw" of `T`, and the pose the same seven numbers make (what a reader builds).
std::string xyzQuat(const Transform& T, Transform* as_read) {
  const Eigen::Quaterniond q(T.linear());
  const Eigen::Vector3d t = T.translation();
  EXPECT_TRUE(makePose(t, q, as_read));  // %.17g round-trips every double exactly
  return fmt(t.x()) + " " + fmt(t.y()) + " " + fmt(t.z()) + " " + fmt(q.x()) + " " + fmt(q.y()) +
         " " + fmt(q.z()) + " " + fmt(q.w());
}

TEST(Replay, SimulatedCloudsWithTumPosesMapLikeTheEngineDirectly) {
  const std::string dir = ::testing::TempDir() + "/mlmap_replay_clouds";
  fs::remove_all(dir);
  fs::create_directories(dir + "/clouds");
  // A 10-frame stretch of the demo's flight, from a 160 x 120 camera, as organised clouds in
  // the camera frame (NaN where the camera saw nothing); the poses are the body's, the camera's
  // mounting is the extrinsic.
  datasets::Scenario scenario = datasets::defaultScenario();
  scenario.camera.intrinsics = test::quarterCamera();
  const sim::DepthCamera camera(scenario.camera);
  MapConfig config;
  eval::setResolution(&config, 0.1);
  config.awareness.max_range_m = 8.0;
  Transform T_B_S_read;
  const std::string extrinsic = xyzQuat(config.sensor.T_B_S(), &T_B_S_read);
  MapEngine reference(config);
  std::ofstream tum(dir + "/poses.tum");
  tum << "# timestamp tx ty tz qx qy qz qw\n";
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::size_t nan_points = 0;
  for (int i = 0; i < 10; ++i) {
    const double t = 20.0 + 0.1 * i;
    DepthFrame depth;
    const Transform T_W_B = scenario.trajectory.poseAt(t);
    camera.render(scenario.world, T_W_B * T_B_S_read, t, &depth);
    char stamp[32];
    std::snprintf(stamp, sizeof(stamp), "%.6f", 1000.0 + t);  // a file name that is a stamp
    PointCloudFrame frame;
    frame.stamp_s = std::strtod(stamp, nullptr);
    tum << stamp << " " << xyzQuat(T_W_B, &frame.T_W_B) << "\n";
    frame.T_B_S = T_B_S_read;
    std::vector<Eigen::Vector3d> organised;
    const PinholeIntrinsics& K = depth.intrinsics;
    for (int v = 0; v < K.height; ++v) {
      for (int u = 0; u < K.width; ++u) {
        const float z = depth.depth_m[static_cast<std::size_t>(v * K.width + u)];
        Eigen::Vector3f p(nan, nan, nan);
        if (z > 0.0f) {
          p = Eigen::Vector3f(static_cast<float>((u - K.cx) / K.fx) * z,
                              static_cast<float>((v - K.cy) / K.fy) * z, z);
          frame.points_S.push_back(p);
        } else {
          ++nan_points;
        }
        organised.push_back(p.cast<double>());
      }
    }
    mlmap::testing::PcdOptions o;
    o.height = static_cast<std::uint32_t>(K.height);
    o.data = i % 3 == 0   ? mlmap::testing::PcdData::kAscii
             : i % 3 == 1 ? mlmap::testing::PcdData::kBinary
                          : mlmap::testing::PcdData::kBinaryCompressed;
    if (i == 9) {
      mlmap::testing::writeFile(
          dir + "/clouds/" + stamp + ".ply",
          mlmap::testing::makePly(organised, mlmap::testing::PlyFormat::kBinaryBigEndian, false));
    } else {
      mlmap::testing::writeFile(dir + "/clouds/" + stamp + ".pcd",
                                mlmap::testing::makePcd(organised, o));
    }
    ASSERT_EQ(reference.submit(std::move(frame)), FrameStatus::kAccepted);
  }
  tum.close();
  ASSERT_GT(nan_points, 0u);

  const std::string out = dir + "/out";
  const std::string command =
      std::string(MLMAP_REPLAY_BIN) + " --clouds '" + dir + "/clouds' --poses '" + dir +
      "/poses.tum' --extrinsic '" + extrinsic + "' --resolution 0.1 --max-range 8 --out '" + out +
      "' --voxels-out '" + dir + "/voxels.txt' --stats-out '" + dir + "/stats.json'";
  ASSERT_EQ(run(command, dir + "/replay.log"), 0) << readText(dir + "/replay.log");

  const std::vector<VoxelIndex> replayed = io::readVoxelText(dir + "/voxels.txt");
  const std::vector<VoxelIndex> direct = io::sortedUnique(reference.occupiedVoxels());
  EXPECT_GT(direct.size(), 500u);
  EXPECT_EQ(replayed, direct);  // same voxels, sorted, one per line
  const std::string stats = readText(dir + "/stats.json");
  EXPECT_EQ(jsonInt(stats, "frames_mapped"), 10);
  EXPECT_EQ(jsonInt(stats, "non_finite_dropped_by_reader"), static_cast<long>(nan_points));
  EXPECT_EQ(jsonInt(stats, "occupied_voxels"), static_cast<long>(direct.size()));
  EXPECT_NE(stats.find("\"pairing\": \"by time"), std::string::npos);
  EXPECT_NE(stats.find("\"local_global_ms\": "), std::string::npos);
  EXPECT_GT(jsonInt(stats, "peak_rss"), 0);
  // The phases: start-up, the frames, the outputs; each took time, none more than the test's run.
  ASSERT_NE(stats.find("\"phases_s\": {"), std::string::npos) << stats;
  for (const char* phase : {"startup", "mapping", "outputs"}) {
    const double seconds = jsonDouble(stats.substr(stats.find("\"phases_s\": {")), phase);
    EXPECT_GT(seconds, 0.0) << phase;
    EXPECT_LT(seconds, 300.0) << phase;
  }
  ASSERT_NE(stats.find("\"phases_cpu_s\": {"), std::string::npos) << stats;
  const std::string cpu = stats.substr(stats.find("\"phases_cpu_s\": {"));
  for (const char* phase : {"before_main", "startup", "mapping", "outputs"}) {
    EXPECT_GE(jsonDouble(cpu, phase), 0.0) << phase;  // CPU time may round to 0 on a short phase
    EXPECT_LT(jsonDouble(cpu, phase), 300.0) << phase;
  }
  EXPECT_GT(jsonDouble(cpu, "before_main") + jsonDouble(cpu, "mapping"), 0.0);
  for (const char* f : {"map_top.png", "map_side.png", "report.json"}) {
    EXPECT_TRUE(fs::exists(out + "/" + f)) << f;
  }
}

TEST(Replay, VoxelIndicesAreFloorOfCoordinateOverResolution) {
  // Two walls at x = +2.05 and x = -2.05 seen from the origin, one PLY cloud paired by order:
  // every occupied voxel must be ix = floor(2.05 / 0.1) = 20 or floor(-2.05 / 0.1) = -21.
  const std::string dir = ::testing::TempDir() + "/mlmap_replay_grid";
  fs::remove_all(dir);
  fs::create_directories(dir + "/clouds");
  std::vector<Eigen::Vector3d> points;
  for (int j = -10; j <= 10; ++j) {
    for (int k = -5; k <= 5; ++k) {
      points.emplace_back(2.05, 0.1 * j + 0.05, 0.1 * k + 0.05);
      points.emplace_back(-2.05, 0.1 * j + 0.05, 0.1 * k + 0.05);
    }
  }
  mlmap::testing::writeFile(
      dir + "/clouds/scan_a.ply",
      mlmap::testing::makePly(points, mlmap::testing::PlyFormat::kAscii, true));
  mlmap::testing::writeFile(dir + "/poses.csv", "t,x,y,z,qx,qy,qz,qw\n1,0,0,0,0,0,0,1\n");
  const std::string command = std::string(MLMAP_REPLAY_BIN) + " --clouds '" + dir +
                              "/clouds' --poses '" + dir + "/poses.csv' --resolution 0.1 --out '" +
                              dir + "/out'";
  ASSERT_EQ(run(command, dir + "/replay.log"), 0) << readText(dir + "/replay.log");
  const std::vector<VoxelIndex> voxels = io::readVoxelText(dir + "/out/occupied_voxels.txt");
  ASSERT_GT(voxels.size(), 100u);
  std::size_t negative = 0;
  for (const VoxelIndex& v : voxels) {
    EXPECT_TRUE(v.x() == 20 || v.x() == -21) << v.transpose();
    EXPECT_TRUE(v.y() >= -10 && v.y() <= 10) << v.transpose();
    negative += v.x() < 0 ? 1 : 0;
  }
  EXPECT_GT(negative, 50u);
  EXPECT_EQ(
      readText(dir + "/out/occupied_voxels.txt").rfind("# mlmap occupied voxels: ix iy iz", 0), 0u);
}

/// One scan of `points` (sensor frame) taken at the origin, in `dir`: clouds/scan_a.ply and
/// poses.csv; and fixed.yaml, a configuration whose window is fixed at 19 x 19 x 7 m (0.1 m
/// voxels) with a 20 m range.
void writeOneScanWithAFixedWindow(const std::string& dir,
                                  const std::vector<Eigen::Vector3d>& points) {
  mlmap::testing::writeFile(
      dir + "/clouds/scan_a.ply",
      mlmap::testing::makePly(points, mlmap::testing::PlyFormat::kAscii, true));
  mlmap::testing::writeFile(dir + "/poses.csv", "t,x,y,z,qx,qy,qz,qw\n1,0,0,0,0,0,0,1\n");
  mlmap::testing::writeFile(dir + "/fixed.yaml",
                            "local_map: {resolution_m: 0.1, size_cells: [190, 190, 70]}\n"
                            "awareness: {max_range_m: 20, rho_cells: 200}\n");
}

TEST(Replay, HitsOutsideTheLocalWindowAreCountedAndSaid) {
  // A wall 2 m away and one 15 m away beside it, in range (20 m) but beyond the 19 m window's
  // reach (7.6 to 11.4 m: 2 to 3 submaps) when the configuration fixes the window: the far wall's
  // hits go to the global map (its free space is not mapped), and the summary, the log and
  // stats.json say how many. With --max-range the replay sizes the window itself, and both walls
  // are mapped in the window, even with the body at the far edge of its submap.
  const std::string dir = ::testing::TempDir() + "/mlmap_replay_outside";
  fs::remove_all(dir);
  fs::create_directories(dir + "/clouds");
  std::vector<Eigen::Vector3d> points;
  for (int j = -10; j <= 10; ++j) {
    for (int k = -5; k <= 5; ++k) {
      points.emplace_back(2.05, 0.1 * j + 0.05, 0.1 * k + 0.05);
      points.emplace_back(15.05, 0.1 * j + 5.05, 0.1 * k + 0.05);  // not behind the first
    }
  }
  writeOneScanWithAFixedWindow(dir, points);
  const std::string source = std::string(MLMAP_REPLAY_BIN) + " --clouds '" + dir +
                             "/clouds' --poses '" + dir + "/poses.csv'";
  const std::string command = source + " --config '" + dir + "/fixed.yaml' --out '" + dir + "/out'";
  ASSERT_EQ(run(command, dir + "/replay.log"), 0) << readText(dir + "/replay.log");
  const std::string stats = readText(dir + "/out/stats.json");
  EXPECT_EQ(jsonInt(stats, "hits_beyond_local_map"), 21 * 11);    // every point of the far wall
  EXPECT_EQ(jsonInt(stats, "hits_above_or_below_local_map"), 0);  // beyond it horizontally
  EXPECT_EQ(jsonInt(stats, "hits_outside_window"), 0);
  EXPECT_EQ(jsonInt(stats, "hit_voxels"), 21 * 11);          // the near wall's
  EXPECT_EQ(jsonInt(stats, "hits_to_global_map"), 21 * 11);  // the far wall's, one per voxel
  EXPECT_EQ(jsonInt(stats, "hits_lost"), 0);
  std::size_t near_wall = 0;
  std::size_t far_wall = 0;
  for (const VoxelIndex& v : io::readVoxelText(dir + "/out/occupied_voxels.txt")) {
    EXPECT_TRUE(v.x() == 20 || v.x() == 150) << v.transpose();
    (v.x() == 20 ? near_wall : far_wall) += 1;
  }
  EXPECT_EQ(near_wall, 21u * 11u);
  EXPECT_EQ(far_wall, 21u * 11u);  // in the global map
  const std::string log = readText(dir + "/replay.log");
  EXPECT_NE(log.find("beyond the window    231 points beyond the local map's reach, 0 hit voxels "
                     "outside its window: 231 hit updates to the global map, 0 hits lost"),
            std::string::npos)
      << log;
  EXPECT_NE(log.find("their free space was not mapped"), std::string::npos) << log;
  EXPECT_NE(log.find("local window 190 x 190 x 70 voxels (19.0 x 19.0 x 7.0 m): a hit within 7.6 "
                     "m horizontally of the body"),
            std::string::npos)
      << log;  // the window used, as fixed.yaml gives it
  EXPECT_EQ(jsonInt(readText(dir + "/out/report.json"), "hits_beyond_local_map"), 21 * 11);

  // --max-range 20: the window grows to hold the range, and every hit is mapped, with the body
  // 6.6 m along x: at the far edge of its submap in a window of 2 x 20 / 0.6 = 335 voxels (6.7 m
  // submaps), which reached only 13.5 m ahead.
  mlmap::testing::writeFile(dir + "/edge.csv", "t,x,y,z,qx,qy,qz,qw\n1,6.6,0,0,0,0,0,1\n");
  ASSERT_EQ(run(std::string(MLMAP_REPLAY_BIN) + " --clouds '" + dir + "/clouds' --poses '" + dir +
                    "/edge.csv' --resolution 0.1 --max-range 20 --out '" + dir + "/sized'",
                dir + "/sized.log"),
            0)
      << readText(dir + "/sized.log");
  const std::string sized = readText(dir + "/sized/stats.json");
  EXPECT_EQ(jsonInt(sized, "hits_beyond_local_map"), 0);
  EXPECT_EQ(jsonInt(sized, "hits_outside_window"), 0);
  EXPECT_EQ(jsonInt(sized, "hit_voxels"), 2 * 21 * 11);
  std::size_t far = 0;
  for (const VoxelIndex& v : io::readVoxelText(dir + "/sized/occupied_voxels.txt")) {
    far += v.x() == 216 ? 1 : 0;
  }
  EXPECT_EQ(far, 21u * 11u) << "the far wall, 15 m away";
  EXPECT_NE(readText(dir + "/sized.log").find("the local window grows from 190 x 190 to 500 x 500"),
            std::string::npos)
      << readText(dir + "/sized.log");
  EXPECT_NE(readText(dir + "/sized.log")
                .find("local window 500 x 500 x 70 voxels (50.0 x 50.0 x 7.0 m): a hit within "
                      "20.0 m horizontally of the body"),
            std::string::npos)
      << readText(dir + "/sized.log");  // the window used, as the growth said
}

// A LiDAR's upper beams: hits within the window's horizontal reach but above it are counted
// apart, and the log says that a taller window, not a wider one, maps them.
TEST(Replay, HitsAboveTheWindowAreToldApartFromThoseBeyondIt) {
  const std::string dir = ::testing::TempDir() + "/mlmap_replay_above";
  fs::remove_all(dir);
  fs::create_directories(dir + "/clouds");
  std::vector<Eigen::Vector3d> points;
  for (int j = -10; j <= 10; ++j) {
    for (int k = 0; k <= 10; ++k) points.emplace_back(3.05, 0.1 * j + 0.05, 5.05 + 0.1 * k);
  }
  // 70 voxels (7 m) tall: the scratch box reaches 3 submaps (4.2 m) above the sensor.
  writeOneScanWithAFixedWindow(dir, points);
  ASSERT_EQ(run(std::string(MLMAP_REPLAY_BIN) + " --clouds '" + dir + "/clouds' --poses '" + dir +
                    "/poses.csv' --config '" + dir + "/fixed.yaml' --out '" + dir + "/out'",
                dir + "/replay.log"),
            0)
      << readText(dir + "/replay.log");
  const std::string stats = readText(dir + "/out/stats.json");
  EXPECT_EQ(jsonInt(stats, "hits_beyond_local_map"), 21 * 11);
  EXPECT_EQ(jsonInt(stats, "hits_above_or_below_local_map"), 21 * 11);
  EXPECT_NE(readText(dir + "/replay.log")
                .find("0 lay beyond its horizontal reach (a wider local_map.size_cells x, y, or "
                      "--max-range, maps them whole) and 231 above or below it"),
            std::string::npos)
      << readText(dir + "/replay.log");
}

TEST(Replay, BadInputIsRefusedWithAMessage) {
  const std::string dir = ::testing::TempDir() + "/mlmap_replay_bad";
  fs::remove_all(dir);
  fs::create_directories(dir + "/clouds");
  mlmap::testing::writeFile(dir + "/clouds/a.pcd", "VERSION 0.7\nFIELDS x y\n");
  mlmap::testing::writeFile(dir + "/poses.txt", "0 0 0 0 0 0 0 1\n");
  const std::string bin = MLMAP_REPLAY_BIN;
  const std::string base = bin + " --out '" + dir + "/out' --clouds '" + dir +
                           "/clouds' --poses '" + dir + "/poses.txt'";
  EXPECT_NE(run(base, dir + "/a.log"), 0);
  EXPECT_NE(
      readText(dir + "/a.log").find(dir + "/clouds/a.pcd: PCD header ends before its DATA line"),
      std::string::npos)
      << readText(dir + "/a.log");
  EXPECT_NE(run(base + " --extrinsic '0 0 0 0 0 0'", dir + "/b.log"), 0);
  EXPECT_NE(readText(dir + "/b.log").find("expected 7 numbers"), std::string::npos)
      << readText(dir + "/b.log");
  EXPECT_NE(run(bin + " --clouds '" + dir + "/clouds'", dir + "/c.log"), 0);  // --poses missing
  EXPECT_NE(readText(dir + "/c.log").find("--poses"), std::string::npos)
      << readText(dir + "/c.log");
  EXPECT_EQ(run(bin + " --help", dir + "/help.log"), 0);
  const std::string help = readText(dir + "/help.log");
  for (const char* option : {"--frames", "--clouds", "--poses", "--extrinsic", "--resolution",
                             "--max-range", "--config", "--out", "--voxels-out", "--stats-out"}) {
    EXPECT_NE(help.find(option), std::string::npos) << option;
  }
}

// No output of a run may replace one of its inputs, under any spelling of the path or inside an
// input folder, for any output option; the input stays as it was and nothing is written.
TEST(Replay, NoOutputReplacesAnInput) {
  const std::string dir = ::testing::TempDir() + "/mlmap_replay_outputs";
  fs::remove_all(dir);
  fs::create_directories(dir + "/clouds");
  const std::string bag = "not a bag, but an input all the same\n";
  mlmap::testing::writeFile(dir + "/run.mcap", bag);
  mlmap::testing::writeFile(dir + "/clouds/a.pcd", "VERSION 0.7\n");
  mlmap::testing::writeFile(dir + "/clouds/a.pgm", "P5\n");
  mlmap::testing::writeFile(dir + "/poses.txt", "0 0 0 0 0 0 0 1\n");
  mlmap::testing::writeFile(dir + "/mlmap.yaml", "local_map: {resolution_m: 0.2}\n");
  const std::string bin = MLMAP_REPLAY_BIN;
  const std::string out = " --out '" + dir + "/out'";
  struct Case {
    std::string args;
    std::string option;  ///< named in the message
  };
  const std::vector<Case> cases = {
      {" --bag '" + dir + "/run.mcap' --save-map '" + dir + "/run.mcap'", "--save-map"},
      {" --bag '" + dir + "/run.mcap' --save-map '" + dir + "/clouds/../run.mcap' --overwrite",
       "--save-map"},
      {" --bag '" + dir + "/run.mcap' --voxels-out '" + dir + "/./run.mcap'", "--voxels-out"},
      {" --bag '" + dir + "/run.mcap' --stats-out '" + dir + "/run.mcap'", "--stats-out"},
      {" --config '" + dir + "/mlmap.yaml' --stats-out '" + dir + "/mlmap.yaml'", "--stats-out"},
      {" --clouds '" + dir + "/clouds' --poses '" + dir + "/poses.txt' --voxels-out '" + dir +
           "/clouds/a.pcd'",
       "--voxels-out"},
      {" --clouds '" + dir + "/clouds' --poses '" + dir + "/poses.txt' --grid-out '" + dir +
           "/clouds/a'",
       "--grid-out"},  // clouds/a.pgm exists below

  };
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const std::string log = dir + "/case" + std::to_string(i) + ".log";
    const int rc = run(bin + out + cases[i].args, log);
    EXPECT_EQ(rc, 1) << cases[i].args << "\n" << readText(log);
    const std::string said = readText(log);
    EXPECT_NE(said.find(cases[i].option + ": '"), std::string::npos) << said;
    EXPECT_TRUE(said.find("is an input of this run") != std::string::npos ||
                said.find("is inside the input folder") != std::string::npos)
        << said;
    EXPECT_FALSE(fs::exists(dir + "/out")) << "case " << i << " wrote its output folder";
  }
  EXPECT_EQ(readText(dir + "/run.mcap"), bag) << "the bag was replaced";
  EXPECT_EQ(readText(dir + "/mlmap.yaml"), "local_map: {resolution_m: 0.2}\n");
  EXPECT_EQ(readText(dir + "/clouds/a.pcd"), "VERSION 0.7\n");
}

TEST(Replay, SimulatorIsTheDefaultSource) {
  const std::string dir = ::testing::TempDir() + "/mlmap_replay_sim";
  fs::remove_all(dir);
  // A --save-map folder that does not exist is refused before the run, not after it.
  EXPECT_NE(run(std::string(MLMAP_REPLAY_BIN) + " --max-frames 5 --out '" + dir + "' --save-map '" +
                    dir + "/no/such/folder/map.mlmap'",
                dir + ".log"),
            0);
  EXPECT_NE(readText(dir + ".log").find("does not exist"), std::string::npos)
      << readText(dir + ".log");
  EXPECT_FALSE(fs::exists(dir + "/stats.json"));
  ASSERT_EQ(run(std::string(MLMAP_REPLAY_BIN) + " --max-frames 5 --out '" + dir + "' --save-map '" +
                    dir + "/map.mlmap'",
                dir + ".log"),
            0)
      << readText(dir + ".log");
  // The saved map holds exactly the voxels of the text list.
  std::vector<VoxelIndex> saved;
  for (const io::OccupiedVoxel& v : io::occupiedVoxels(io::loadMapFile(dir + "/map.mlmap")))
    saved.push_back(v.index);
  std::vector<VoxelIndex> listed = io::readVoxelText(dir + "/occupied_voxels.txt");
  const auto less = [](const VoxelIndex& a, const VoxelIndex& b) {
    return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
  };
  std::sort(saved.begin(), saved.end(), less);
  std::sort(listed.begin(), listed.end(), less);
  EXPECT_GT(saved.size(), 100u);
  EXPECT_EQ(saved, listed);
  const std::string stats = readText(dir + "/stats.json");
  EXPECT_EQ(jsonInt(stats, "frames_mapped"), 5);
  EXPECT_NE(stats.find("\"kind\": \"simulator\""), std::string::npos);
  EXPECT_TRUE(fs::exists(dir + "/accuracy_top.png"));
  EXPECT_EQ(io::readVoxelText(dir + "/occupied_voxels.txt").size(),
            static_cast<std::size_t>(jsonInt(readText(dir + "/report.json"), "occupied_voxels")));
}

TEST(Replay, ReaderThreadGivesTheSameMapAsReadingInTurn) {
  const std::string frames = std::string(MLMAP_SHARED_DATA_DIR) + "/realsense_tabletop";
  const std::string dir = ::testing::TempDir() + "/mlmap_replay_reader";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string base = std::string(MLMAP_REPLAY_BIN) + " --frames '" + frames +
                           "' --resolution 0.02 --max-frames 20 --reader-threads ";
  ASSERT_EQ(run(base + "0 --out '" + dir + "/in_turn'", dir + "/in_turn.log"), 0)
      << readText(dir + "/in_turn.log");
  ASSERT_EQ(run(base + "1 --out '" + dir + "/ahead'", dir + "/ahead.log"), 0)
      << readText(dir + "/ahead.log");
  const std::string in_turn = readText(dir + "/in_turn/occupied_voxels.txt");
  EXPECT_GT(io::readVoxelText(dir + "/in_turn/occupied_voxels.txt").size(), 1000u);
  EXPECT_EQ(readText(dir + "/ahead/occupied_voxels.txt"), in_turn);
  // The frames in the same order, each with its own read time.
  const std::string stats = readText(dir + "/ahead/stats.json");
  EXPECT_EQ(jsonInt(stats, "frames_mapped"), 20);
  std::size_t at = 0;
  for (const char* name : {"frame-000015", "frame-000017", "frame-000019", "frame-000021"}) {
    const std::size_t found = stats.find(std::string("\"name\": \"") + name + "\"", at);
    ASSERT_NE(found, std::string::npos) << name;
    at = found;
  }
  EXPECT_NE(stats.find("\"read_wait_ms\": "), std::string::npos);
  // The default replay runs no planning layer: no output needs one.
  EXPECT_EQ(jsonInt(stats, "esdf_updates"), 0);
  EXPECT_NE(readText(dir + "/ahead.log").find("planning layers       off"), std::string::npos)
      << readText(dir + "/ahead.log");
}

TEST(Replay, AwarenessThreadsGiveTheSameMapAsOne) {
  const std::string dir = ::testing::TempDir() + "/mlmap_replay_awareness_threads";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string base = std::string(MLMAP_REPLAY_BIN) + " --max-frames 8 --awareness-threads ";
  ASSERT_EQ(run(base + "1 --out '" + dir + "/one'", dir + "/one.log"), 0)
      << readText(dir + "/one.log");
  ASSERT_EQ(run(base + "3 --out '" + dir + "/three'", dir + "/three.log"), 0)
      << readText(dir + "/three.log");
  const std::string one = readText(dir + "/one/occupied_voxels.txt");
  EXPECT_GT(io::readVoxelText(dir + "/one/occupied_voxels.txt").size(), 1000u);
  EXPECT_EQ(readText(dir + "/three/occupied_voxels.txt"), one);
  EXPECT_EQ(jsonInt(readText(dir + "/one/stats.json"), "awareness_threads"), 1);
  EXPECT_EQ(jsonInt(readText(dir + "/three/stats.json"), "awareness_threads"), 3);
  EXPECT_NE(run(base + "0 --out '" + dir + "/none'", dir + "/none.log"), 0);
  // Without the option or --config: two threads where the machine has two cores.
  ASSERT_EQ(run(std::string(MLMAP_REPLAY_BIN) + " --max-frames 8 --out '" + dir + "/auto'",
                dir + "/auto.log"),
            0)
      << readText(dir + "/auto.log");
  EXPECT_EQ(jsonInt(readText(dir + "/auto/stats.json"), "awareness_threads"),
            std::thread::hardware_concurrency() >= 2 ? 2 : 1);
  EXPECT_EQ(readText(dir + "/auto/occupied_voxels.txt"), one);
}

TEST(Replay, UnreadableCloudAfterGoodOnesIsNamedWithOrWithoutTheReaderThread) {
  const std::string dir = ::testing::TempDir() + "/mlmap_replay_bad_middle";
  fs::remove_all(dir);
  fs::create_directories(dir + "/clouds");
  std::vector<Eigen::Vector3d> wall;
  for (int j = -10; j <= 10; ++j) wall.emplace_back(2.05, 0.1 * j, 0.0);
  std::string poses;
  for (int i = 0; i < 8; ++i) {
    const std::string name = dir + "/clouds/scan_" + std::to_string(i);
    if (i == 5) {
      mlmap::testing::writeFile(name + ".pcd", "VERSION 0.7\nFIELDS x y\n");
    } else {
      mlmap::testing::writeFile(
          name + ".ply", mlmap::testing::makePly(wall, mlmap::testing::PlyFormat::kAscii, true));
    }
    poses += std::to_string(i + 1) + " 0 0 0 0 0 0 1\n";
  }
  mlmap::testing::writeFile(dir + "/poses.txt", poses);
  for (const char* threads : {"0", "1"}) {
    const std::string log = dir + "/threads_" + threads + ".log";
    EXPECT_EQ(run(std::string(MLMAP_REPLAY_BIN) + " --clouds '" + dir + "/clouds' --poses '" + dir +
                      "/poses.txt' --reader-threads " + threads + " --out '" + dir + "/out'",
                  log),
              1);
    EXPECT_NE(readText(log).find(dir + "/clouds/scan_5.pcd: PCD header ends before its DATA line"),
              std::string::npos)
        << readText(log);
  }
}

TEST(Replay, TheMapIsWrittenFirstAndAFailedPictureLeavesNoPartialFile) {
  const std::string dir = ::testing::TempDir() + "/mlmap_replay_picture_fails";
  fs::remove_all(dir);
  // map_top.png cannot be replaced (a folder holds its name): the picture fails after the map.
  fs::create_directories(dir + "/out/map_top.png");
  const std::string command = std::string(MLMAP_REPLAY_BIN) + " --max-frames 5 --out '" + dir +
                              "/out' --save-map '" + dir + "/map.mlmap' --voxels-out '" + dir +
                              "/voxels.txt' --grid-out '" + dir + "/grid'";
  EXPECT_EQ(run(command, dir + "/replay.log"), 1);
  const std::string log = readText(dir + "/replay.log");
  EXPECT_NE(log.find("cannot write '" + dir + "/out/map_top.png'"), std::string::npos) << log;
  // The map, its voxel list and the grid were written before, whole.
  std::vector<VoxelIndex> saved;
  for (const io::OccupiedVoxel& v : io::occupiedVoxels(io::loadMapFile(dir + "/map.mlmap")))
    saved.push_back(v.index);
  EXPECT_GT(saved.size(), 100u);
  EXPECT_EQ(io::sortedUnique(saved), io::readVoxelText(dir + "/voxels.txt"));
  EXPECT_NE(readText(dir + "/grid.yaml").find("image: grid.pgm"), std::string::npos);
  EXPECT_TRUE(fs::is_regular_file(dir + "/grid.pgm"));
  // No temporary file is left behind, and nothing after the failed picture was written.
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    EXPECT_EQ(entry.path().filename().string().find(".tmp-"), std::string::npos) << entry.path();
  }
  EXPECT_FALSE(fs::exists(dir + "/out/stats.json"));
}

TEST(Replay, RealsenseFramesGiveTheDemosMap) {
  const std::string frames = std::string(MLMAP_SHARED_DATA_DIR) + "/realsense_tabletop";
  const std::string dir = ::testing::TempDir() + "/mlmap_replay_frames";
  fs::remove_all(dir);
  fs::create_directories(dir);
  // The DDS replay configuration as it is (the offline programs skip its dds and map_file
  // sections): the demo's frame settings with the ESDF box cut to 2 x 2 x 1 m, which makes
  // planning ten times cheaper and changes no voxel.
  const std::string config = std::string(MLMAP_SOURCE_DIR) + "/config/mlmap_node_replay.yaml";
  const std::string options = " --frames '" + frames + "' --config '" + config + "' --out '" + dir;
  ASSERT_EQ(run(std::string(MLMAP_REPLAY_BIN) + options + "/replay'", dir + "/replay.log"), 0)
      << readText(dir + "/replay.log");
  ASSERT_EQ(run(std::string(MLMAP_DEMO_BIN) + options + "/demo'", dir + "/demo.log"), 0)
      << readText(dir + "/demo.log");
  // mlmap_demo maps the frames with the same settings (eval::runConfig) in the same order: the
  // same map (4,813 voxels, as mlmap_dds_end_to_end_replay receives over DDS). Voxel-for-voxel
  // agreement with the engine run directly is checked on clouds above.
  const std::vector<VoxelIndex> replayed = io::readVoxelText(dir + "/replay/occupied_voxels.txt");
  const long demo = jsonInt(readText(dir + "/demo/report.json"), "occupied_voxels");
  EXPECT_GT(demo, 1000);
  EXPECT_EQ(static_cast<long>(replayed.size()), demo);
  EXPECT_EQ(jsonInt(readText(dir + "/replay/report.json"), "occupied_voxels"), demo);
  EXPECT_EQ(jsonInt(readText(dir + "/replay/stats.json"), "frames_mapped"), 50);
}

}  // namespace
}  // namespace mlmap
