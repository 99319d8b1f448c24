// The README's C++ example, compiled and run: it maps a cloud and queries the ESDF. The README's
// ```cpp block must equal the lines between the markers below, so the example on the front page
// is code that builds and does what it says.
#include "mlmap/pipeline/map_engine.h"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace {

/// A wall 2 m ahead of the sensor (x), 2 m wide and 1.6 m tall, a point every 2 cm.
std::vector<Eigen::Vector3f> wallAhead() {
  std::vector<Eigen::Vector3f> points;
  for (float y = -1.0f; y <= 1.0f; y += 0.02f) {
    for (float z = -0.8f; z <= 0.8f; z += 0.02f) points.emplace_back(2.0f, y, z);
  }
  return points;
}

struct Result {
  mlmap::EsdfMap::Query near_wall;
  mlmap::Occupancy wall = mlmap::Occupancy::kUnknown;
};

Result readmeExample(const std::vector<Eigen::Vector3f>& cloud, const mlmap::Transform& T_W_B) {
  // The README aligns the comments in one column.
  // clang-format off
  // README:begin
  mlmap::MapConfig config;                    // defaults: 0.1 m voxels, 10 m range
  mlmap::MapEngine engine(config);
  mlmap::PointCloudFrame frame;
  frame.stamp_s = 0.0;
  frame.points_S = cloud;                     // std::vector<Eigen::Vector3f>, sensor frame S
  frame.T_W_B = T_W_B;                        // body pose in the world W (here S = B)
  engine.submit(frame);
  engine.flush();                             // with pipeline.threaded: wait for the map
  const auto snapshot = engine.snapshot();    // what planners read, from any thread
  const auto q = snapshot->distance({1.5, 0.0, 0.0});  // q.distance_m, q.gradient, q.valid
  // README:end
  // clang-format on
  return {q, snapshot->state({2.05, 0.0, 0.0})};
}

TEST(ReadmeExample, MapsACloudAndTheEsdfSeesTheWall) {
  const Result r = readmeExample(wallAhead(), mlmap::Transform::Identity());
  EXPECT_EQ(r.wall, mlmap::Occupancy::kOccupied);
  ASSERT_TRUE(r.near_wall.valid);
  // The wall's voxels span x = 2.0 .. 2.1 m: half a metre away, to within a voxel's edge.
  EXPECT_GE(r.near_wall.distance_m, 0.45);
  EXPECT_LE(r.near_wall.distance_m, 0.65);
  EXPECT_LT(r.near_wall.gradient.x(), -0.9);  // away from the wall: towards -x
}

TEST(ReadmeExample, TheReadmeShowsExactlyThisCode) {
  auto read = [](const std::string& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  };
  const std::string self =
      read(std::string(MLMAP_SOURCE_DIR) + "/tests/pipeline/test_readme_example.cpp");
  const std::string readme = read(std::string(MLMAP_SOURCE_DIR) + "/README.md");
  ASSERT_FALSE(self.empty());
  ASSERT_FALSE(readme.empty());
  // The marked lines, without their two-space indentation.
  const std::size_t begin = self.find('\n', self.find("// README:begin")) + 1;
  const std::size_t end = self.rfind('\n', self.find("// README:end")) + 1;
  std::istringstream lines(self.substr(begin, end - begin));
  std::string code, line;
  while (std::getline(lines, line)) code += (line.size() >= 2 ? line.substr(2) : line) + "\n";
  const std::size_t block = readme.find("```cpp\n");
  ASSERT_NE(block, std::string::npos) << "README.md has no ```cpp block";
  const std::size_t block_end = readme.find("```", block + 7);
  EXPECT_EQ(readme.substr(block + 7, block_end - block - 7), code);
}

}  // namespace
