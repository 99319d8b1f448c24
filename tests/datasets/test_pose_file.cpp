#include "mlmap/datasets/cloud_sequence.h"
#include "mlmap/datasets/pose_file.h"

#include "../support/expect_throw.h"
#include "../support/cloud_file_writers.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <stdexcept>

namespace mlmap::datasets {
namespace {

void expectError(const std::function<void()>& fn, const std::vector<std::string>& parts) {
  mlmap::testing::expectThrowWith<std::exception>(fn, parts);
}

/// 90 degrees about z.
const Eigen::Quaterniond kYaw90(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));

TEST(TumPoses, ParsesPosesSkippingCommentsAndBlankLines) {
  const std::string text =
      "# ground truth trajectory\n# timestamp tx ty tz qx qy qz qw\n\n"
      "1305031102.1758 1.0 2.0 3.0 0 0 0.7071067811865476 0.7071067811865476\n"
      "1305031102.2 1.5 2.0 3.0 0 0 0 1\r\n";
  const std::vector<StampedPose> poses = parseTumPoses(text, "gt.txt");
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_DOUBLE_EQ(poses[0].stamp_s, 1305031102.1758);
  EXPECT_EQ(poses[0].line, 4);
  EXPECT_TRUE(poses[0].T_W_P.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_TRUE(poses[0].T_W_P.linear().isApprox(kYaw90.toRotationMatrix(), 1e-12));
  EXPECT_TRUE(poses[1].T_W_P.linear().isIdentity(1e-15));
}

TEST(TumPoses, BadLinesAreRefusedWithTheirNumber) {
  const std::string ok = "0 0 0 0 0 0 0 1\n";
  expectError([&] { (void)parseTumPoses(ok + "1 0 0 0 0 0 0.5 0.5\n", "q.txt"); },
              {"q.txt: line 2", "quaternion", "norm 0.707"});
  expectError([&] { (void)parseTumPoses(ok + "1 nan 0 0 0 0 0 1\n", "n.txt"); },
              {"n.txt: line 2", "tx is not finite"});
  expectError([&] { (void)parseTumPoses(ok + "# c\n0 0 0 0 0 0 0 1\n", "s.txt"); },
              {"s.txt: line 3", "not after the previous one", "line 1"});
  expectError([&] { (void)parseTumPoses(ok + "2 0 0 0 0 0 1\n", "c.txt"); },
              {"c.txt: line 2", "expected 8 values", "got 7"});
  expectError([&] { (void)parseTumPoses(ok + "2 0 0 x 0 0 0 1\n", "x.txt"); },
              {"x.txt: line 2", "tz 'x' is not a number"});
  expectError([&] { (void)parseTumPoses("# nothing\n", "e.txt"); }, {"e.txt", "no poses"});
}

TEST(CsvPoses, AcceptsTheDocumentedHeaders) {
  const std::vector<StampedPose> a = parseCsvPoses(
      "t,x,y,z,qx,qy,qz,qw\n0.5,1,2,3,0,0,0.7071067811865476,0.7071067811865476\n", "a.csv");
  ASSERT_EQ(a.size(), 1u);
  EXPECT_DOUBLE_EQ(a[0].stamp_s, 0.5);
  EXPECT_TRUE(a[0].T_W_P.linear().isApprox(kYaw90.toRotationMatrix(), 1e-12));
  // Other order, other names, units, spaces, a '#' on the header and extra columns.
  const std::vector<StampedPose> b = parseCsvPoses(
      "# timestamp [ns], qw, qx, qy, qz, frame, position_x [m], position_y [m], position_z [m], "
      "vx\n"
      "1500000000, 0.7071067811865476, 0, 0, 0.7071067811865476, base, 1, 2, 3, 9\n"
      "2500000000, 1, 0, 0, 0, base, 4, 5, 6, 9\n",
      "b.csv");
  ASSERT_EQ(b.size(), 2u);
  EXPECT_DOUBLE_EQ(b[0].stamp_s, 1.5);
  EXPECT_DOUBLE_EQ(b[1].stamp_s, 2.5);
  EXPECT_TRUE(b[0].T_W_P.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_TRUE(b[0].T_W_P.linear().isApprox(kYaw90.toRotationMatrix(), 1e-12));
  const std::vector<StampedPose> c =
      parseCsvPoses("time_ms,tx,ty,tz,q_x,q_y,q_z,q_w\n250,1,2,3,0,0,0,1\n", "c.csv");
  EXPECT_DOUBLE_EQ(c[0].stamp_s, 0.25);
  const std::vector<StampedPose> d = parseCsvPoses(
      "stamp,pos_x,pos_y,pos_z,orientation_x,orientation_y,orientation_z,orientation_w\n1,1,2,3,0,"
      "0,0,1\n",
      "d.csv");
  EXPECT_TRUE(d[0].T_W_P.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
}

TEST(CsvPoses, BadHeadersAndLinesAreRefusedWithTheirNumber) {
  expectError([&] { (void)parseCsvPoses("t,x,y,z,qx,qy,qz\n", "a.csv"); },
              {"a.csv: line 1", "no qw column"});
  expectError([&] { (void)parseCsvPoses("t,x,y,z,qx,qy,qz,qw,x\n", "b.csv"); },
              {"b.csv: line 1", "'x'", "earlier column"});
  const std::string h = "t,x,y,z,qx,qy,qz,qw\n0,0,0,0,0,0,0,1\n";
  expectError([&] { (void)parseCsvPoses(h + "1,0,0,0,0,0,0,2\n", "c.csv"); },
              {"c.csv: line 3", "norm 2"});
  expectError([&] { (void)parseCsvPoses(h + "1,0,NaN,0,0,0,0,1\n", "d.csv"); },
              {"d.csv: line 3", "not finite"});
  expectError([&] { (void)parseCsvPoses(h + "0,0,0,0,0,0,0,1\n", "e.csv"); },
              {"e.csv: line 3", "not after"});
  expectError([&] { (void)parseCsvPoses(h + "1,0,0,0,0,0,1\n", "f.csv"); },
              {"f.csv: line 3", "expected 8"});
  expectError([&] { (void)parseCsvPoses("\n\n", "g.csv"); }, {"g.csv", "no CSV header"});
  expectError([&] { (void)parseCsvPoses("t,x,y,z,qx,qy,qz,qw\n", "h.csv"); },
              {"h.csv", "no poses"});
}

TEST(PoseFile, FormatIsDetectedByNameOrComma) {
  EXPECT_EQ(detectPoseFileFormat("a.CSV", "0 0 0 0 0 0 0 1\n"), PoseFileFormat::kCsv);
  EXPECT_EQ(detectPoseFileFormat("a.txt", "\nt,x,y,z,qx,qy,qz,qw\n"), PoseFileFormat::kCsv);
  EXPECT_EQ(detectPoseFileFormat("a.txt", "# t tx ty tz qx qy qz qw\n0 0 0 0 0 0 0 1\n"),
            PoseFileFormat::kTum);
}

TEST(PoseFile, ExtrinsicParses) {
  const Transform T = parseTransformXyzQuat("0.1, 0 0.2 0 0 0.7071067811865476 0.7071067811865476");
  EXPECT_TRUE(T.translation().isApprox(Eigen::Vector3d(0.1, 0, 0.2)));
  EXPECT_TRUE(T.linear().isApprox(kYaw90.toRotationMatrix(), 1e-12));
  expectError([] { (void)parseTransformXyzQuat("0 0 0 0 0 0"); }, {"expected 7 numbers", "got 6"});
  expectError([] { (void)parseTransformXyzQuat("0 0 0 0 0 0 3"); }, {"norm 3"});
  expectError([] { (void)parseTransformXyzQuat("0 0 0 0 0 0 one"); }, {"'one'"});
}

// ---- Pairing ------------------------------------------------------------------------------------

std::vector<StampedPose> posesAt(const std::vector<double>& stamps) {
  std::vector<StampedPose> poses;
  for (double t : stamps) {
    StampedPose p;
    p.stamp_s = t;
    p.T_W_P.translation() = Eigen::Vector3d(t, 0, 0);  // x = t: interpolation is easy to check
    poses.push_back(p);
  }
  return poses;
}

TEST(CloudPairing, FileNamesThatAreStampsArePairedByTimeWithInterpolation) {
  EXPECT_DOUBLE_EQ(*stampFromFileName("1305031102.175304.pcd"), 1305031102.175304);
  EXPECT_NEAR(*stampFromFileName("1305031102175304000.ply"), 1305031102.175304, 1e-6);  // ns
  EXPECT_NEAR(*stampFromFileName("1305031102175304.pcd"), 1305031102.175304, 1e-6);     // us
  EXPECT_FALSE(stampFromFileName("130503110217530.pcd").has_value());  // 15 digits: no unit fits
  EXPECT_FALSE(stampFromFileName("000015.pcd").has_value());
  EXPECT_FALSE(stampFromFileName("scan_1.5.pcd").has_value());
  EXPECT_FALSE(stampFromFileName("1.5e3.pcd").has_value());

  const std::vector<StampedPose> poses = posesAt({10.0, 10.1, 10.2, 10.5, 10.6});
  CloudPairing how;
  std::vector<std::string> unpaired;
  // 10.03: between 10.0 and 10.1, nearer 0.03 s away -> interpolated (x = 10.03).
  // 10.1: exact. 10.35: nearer pose 0.15 s away -> none. 9.9, 10.7: outside -> none.
  const std::vector<PairedCloud> paired =
      pairCloudsWithPoses({"10.350000.pcd", "10.100000.pcd", "9.900000.pcd", "10.030000.pcd",
                           "10.700000.ply", "10.580000.pcd"},
                          poses, 0.05, &how, &unpaired);
  EXPECT_EQ(how, CloudPairing::kByTime);
  ASSERT_EQ(paired.size(), 3u);
  EXPECT_EQ(paired[0].file_name, "10.030000.pcd");
  EXPECT_NEAR(paired[0].T_W_P.translation().x(), 10.03, 1e-9);
  EXPECT_EQ(paired[1].file_name, "10.100000.pcd");
  EXPECT_NEAR(paired[1].T_W_P.translation().x(), 10.1, 1e-12);
  EXPECT_EQ(paired[2].file_name, "10.580000.pcd");
  EXPECT_NEAR(paired[2].T_W_P.translation().x(), 10.58, 1e-9);
  EXPECT_EQ(unpaired, (std::vector<std::string>{"9.900000.pcd", "10.350000.pcd", "10.700000.ply"}));

  expectError(
      [&] {
        (void)pairCloudsWithPoses({"1.5.pcd", "1.50.pcd"}, poses, 0.05, &how, nullptr);
      },
      {"same time stamp"});
  expectError([&] { (void)pairCloudsWithPoses({"1.5.pcd"}, poses, 0.05, &how, nullptr); },
              {"no cloud has a pose within 0.05"});
}

TEST(CloudPairing, OtherNamesArePairedByOrderAndNeedEqualCounts) {
  const std::vector<StampedPose> poses = posesAt({1, 2, 3});
  CloudPairing how;
  const std::vector<PairedCloud> paired =
      pairCloudsWithPoses({"scan_10.pcd", "scan_2.ply", "scan_9.pcd"}, poses, 0.05, &how, nullptr);
  EXPECT_EQ(how, CloudPairing::kByOrder);
  ASSERT_EQ(paired.size(), 3u);
  EXPECT_EQ(paired[0].file_name, "scan_2.ply");
  EXPECT_EQ(paired[1].file_name, "scan_9.pcd");
  EXPECT_EQ(paired[2].file_name, "scan_10.pcd");
  EXPECT_DOUBLE_EQ(paired[2].stamp_s, 3.0);
  EXPECT_DOUBLE_EQ(paired[2].T_W_P.translation().x(), 3.0);
  // One stamp-like name among others: by order.
  EXPECT_NO_THROW(
      (void)pairCloudsWithPoses({"1.5.pcd", "a.pcd", "b.pcd"}, poses, 0.05, &how, nullptr));
  EXPECT_EQ(how, CloudPairing::kByOrder);
  expectError(
      [&] {
        (void)pairCloudsWithPoses({"a.pcd", "b.pcd"}, poses, 0.05, &how, nullptr);
      },
      {"2 clouds but 3 poses", "by order"});
  EXPECT_TRUE(naturalLess("000009.pcd", "000010.pcd"));
  EXPECT_TRUE(naturalLess("a2", "a10"));
  EXPECT_FALSE(naturalLess("a10", "a2"));
  EXPECT_TRUE(naturalLess("a", "b"));
  EXPECT_FALSE(naturalLess("a1", "a1"));
}

TEST(CloudSequence, AppliesTheExtrinsicAndTheViewpoint) {
  const std::string dir = ::testing::TempDir() + "/mlmap_cloud_sequence";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir + "/clouds");
  mlmap::testing::PcdOptions o;
  o.viewpoint = "0 0 1 0.7071067811865476 0 0 0.7071067811865476";  // sensor 1 m up, yawed 90 deg
  mlmap::testing::writeFile(dir + "/clouds/0.pcd",
                            mlmap::testing::makePcd({{2, 0, 0}, {0, 3, 1}}, o));
  mlmap::testing::writeFile(dir + "/poses.txt",
                            "5 10 0 0 0 0 0.7071067811865476 0.7071067811865476\n");
  CloudSequenceOptions options;
  options.T_P_C = parseTransformXyzQuat("0.5 0 0 0 0 0 1");
  const CloudSequence seq(dir + "/clouds", dir + "/poses.txt", options);
  ASSERT_EQ(seq.size(), 1u);
  EXPECT_EQ(seq.pairing(), CloudPairing::kByOrder);
  PointCloudFile file;
  const PointCloudFrame frame = seq.read(0, &file);
  EXPECT_EQ(file.encoding, "pcd ascii");
  EXPECT_DOUBLE_EQ(frame.stamp_s, 5.0);
  // The world points are T_W_P * T_P_C * p_C whatever the split, and the sensor (ray origin)
  // is at the viewpoint: T_W_P * T_P_C * (0, 0, 1).
  const Transform T_W_S = frame.T_W_B * frame.T_B_S;
  const Transform T_W_C = frame.T_W_B * options.T_P_C;
  ASSERT_EQ(frame.points_S.size(), 2u);
  EXPECT_TRUE(
      (T_W_S * frame.points_S[0].cast<double>()).isApprox(T_W_C * Eigen::Vector3d(2, 0, 0), 1e-6));
  EXPECT_TRUE(
      (T_W_S * frame.points_S[1].cast<double>()).isApprox(T_W_C * Eigen::Vector3d(0, 3, 1), 1e-6));
  EXPECT_TRUE(T_W_S.translation().isApprox(T_W_C * Eigen::Vector3d(0, 0, 1), 1e-12));

  expectError([&] { CloudSequence(dir + "/none", dir + "/poses.txt"); },
              {dir + "/none", "not a directory"});
  std::filesystem::create_directories(dir + "/empty");
  expectError([&] { CloudSequence(dir + "/empty", dir + "/poses.txt"); },
              {dir + "/empty", "no point-cloud files"});
}

}  // namespace
}  // namespace mlmap::datasets
