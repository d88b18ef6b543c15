// BAL problems (core/io/sfm_io.h): the reprojection cost of every development file, computed with
// BAL's own camera model straight from the file's numbers, equals the cost of the Reconstruction
// under slamd's convention; the conversion on a hand-made camera; numbers spread over lines;
// WriteBal → ReadBal round trips; malformed files and unwritable reconstructions.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/io/sfm_io.h"
#include "tests/testing/datasets.h"
#include "tests/testing/sfm_reconstructions.h"

namespace slamd::core {
namespace {

using slamd::testing::BundlerReprojectionCost;
using slamd::testing::ExpectSameReconstruction;
using slamd::testing::SharedDatasetPath;
using slamd::testing::WriteTempFile;
using ::testing::HasSubstr;

// A BAL file as its numbers, read with nothing of slamd's.
struct BalNumbers {
  int num_cameras = 0, num_points = 0, num_observations = 0;
  std::vector<int> camera, point;
  std::vector<Eigen::Vector2d> observed;
  std::vector<Eigen::Matrix<double, 9, 1>> cameras;
  std::vector<Eigen::Vector3d> points;
};

BalNumbers ReadBalNumbers(const std::string& path) {
  std::ifstream in(path);
  BalNumbers b;
  in >> b.num_cameras >> b.num_points >> b.num_observations;
  for (int k = 0; k < b.num_observations; ++k) {
    int i, j;
    double x, y;
    in >> i >> j >> x >> y;
    b.camera.push_back(i);
    b.point.push_back(j);
    b.observed.emplace_back(x, y);
  }
  b.cameras.resize(b.num_cameras);
  for (auto& c : b.cameras) {
    for (int k = 0; k < 9; ++k) in >> c[k];
  }
  b.points.resize(b.num_points);
  for (auto& p : b.points) in >> p.x() >> p.y() >> p.z();
  EXPECT_FALSE(in.fail()) << path;
  return b;
}

// ½ Σ |pixel - observed|² with BAL's camera: P = R(w)·X + t, p = -P / P.z,
// pixel = f·(1 + k1|p|² + k2|p|⁴)·p, R(w) by Eigen's angle-axis (not slamd's Rot3::Exp).
double BalFormulaCost(const BalNumbers& b) {
  double cost = 0.0;
  for (int k = 0; k < b.num_observations; ++k) {
    const Eigen::Matrix<double, 9, 1>& c = b.cameras[b.camera[k]];
    const Eigen::Vector3d w = c.head<3>();
    const double angle = w.norm();
    const Eigen::Matrix3d R = angle == 0.0 ? Eigen::Matrix3d::Identity()
                                           : Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
    const Eigen::Vector3d P = R * b.points[b.point[k]] + c.segment<3>(3);
    const Eigen::Vector2d p = -P.head<2>() / P.z();
    const double r2 = p.squaredNorm();
    const Eigen::Vector2d pixel = c[6] * (1.0 + c[7] * r2 + c[8] * r2 * r2) * p;
    cost += 0.5 * (pixel - b.observed[k]).squaredNorm();
  }
  return cost;
}

Reconstruction MustReadBal(const std::string& path) {
  Result<Reconstruction> r = ReadBal(path);
  EXPECT_TRUE(r.ok()) << r.status().ToString();
  return r.ok() ? std::move(r).value() : Reconstruction{};
}

class BalFileTest : public ::testing::TestWithParam<const char*> {};

TEST_P(BalFileTest, CostEqualsTheBalFormulaOnTheFilesNumbers) {
  const std::string path = SharedDatasetPath(std::string("bal/") + GetParam());
  SLAMD_SKIP_IF_NO_SHARED_DATASET(path);
  const BalNumbers numbers = ReadBalNumbers(path);
  const Reconstruction r = MustReadBal(path);
  ASSERT_EQ(r.images.size(), static_cast<std::size_t>(numbers.num_cameras));
  ASSERT_EQ(r.intrinsics.size(), static_cast<std::size_t>(numbers.num_cameras));
  ASSERT_EQ(r.points.size(), static_cast<std::size_t>(numbers.num_points));
  ASSERT_EQ(r.observations.size(), static_cast<std::size_t>(numbers.num_observations));
  EXPECT_TRUE(r.Validate().ok());
  const double expected = BalFormulaCost(numbers);
  EXPECT_NEAR(BundlerReprojectionCost(r), expected, 1e-9 * expected + 1e-12);
}

INSTANTIATE_TEST_SUITE_P(DevelopmentFiles, BalFileTest,
                         ::testing::Values("problem-49-7776-pre.txt", "problem-21-11315-pre.txt",
                                           "dubrovnik-3-7-pre.txt", "dubrovnik-1-1-pre.txt",
                                           "5pointExample1.txt", "18pointExample1.txt"));

TEST(BalTest, Ladybug49InitialCostIsNearCeres) {
  const std::string path = SharedDatasetPath("bal/problem-49-7776-pre.txt");
  SLAMD_SKIP_IF_NO_SHARED_DATASET(path);
  // Ceres' bundle_adjuster reports an initial cost of 8.509117e+05 on this file. slamd's is
  // 850912.46, as is the BAL formula's (BalFileTest): 9e-7 relative above Ceres' figure, a
  // difference not explained here (bundle_adjuster normalises the problem before it reports).
  EXPECT_NEAR(BundlerReprojectionCost(MustReadBal(path)), 8.509117e5, 1e-6 * 8.509117e5);
}

TEST(BalTest, SyntheticFilesHaveZeroCost) {
  for (const char* name : {"bal/5pointExample1.txt", "bal/18pointExample1.txt"}) {
    const std::string path = SharedDatasetPath(name);
    SLAMD_SKIP_IF_NO_SHARED_DATASET(path);
    EXPECT_LT(BundlerReprojectionCost(MustReadBal(path)), 1e-20) << name;
  }
}

// One camera at the BAL origin looking down BAL's -z (rotation 0, translation t): slamd's camera
// is BAL's rotated by π about x, R_cw = diag(1, -1, -1), t_cw = (t1, -t2, -t3).
TEST(BalTest, ConvertsToSlamdsCameraConvention) {
  const std::string path = WriteTempFile("one_camera.bal",
                                         "1 2 2\n"
                                         "0 0 10.5 -20.25\n"
                                         "0 1 1 2\n"
                                         "0 0 0  1 2 3  500 0.1 0.01\n"
                                         "1 2 3\n"
                                         "4 5 6\n");
  const Reconstruction r = MustReadBal(path);
  ASSERT_EQ(r.images.size(), 1u);
  const Pose3 T_cw = r.images[0].pose.Inverse();
  EXPECT_TRUE(T_cw.rotation().Equals(Rot3(Eigen::Vector3d(1, -1, -1).asDiagonal()), 1e-15));
  EXPECT_EQ(T_cw.translation(), Point3(1, -2, -3));
  EXPECT_EQ(r.images[0].intrinsics, 0);
  EXPECT_EQ(r.images[0].id, 0u);
  EXPECT_EQ(r.images[0].name, "");
  ASSERT_EQ(r.intrinsics.size(), 1u);
  EXPECT_EQ(std::get<Cal3Bundler>(r.intrinsics[0].calibration).vector(),
            Eigen::Vector3d(500, 0.1, 0.01));
  EXPECT_EQ(r.intrinsics[0].principal_point, Eigen::Vector2d::Zero());
  EXPECT_EQ(r.intrinsics[0].model, "");
  ASSERT_EQ(r.observations.size(), 2u);
  EXPECT_EQ(r.observations[0].uv, Eigen::Vector2d(10.5, 20.25));  // y flipped
  EXPECT_EQ(r.observations[1].point, 1);
  ASSERT_EQ(r.points.size(), 2u);
  EXPECT_EQ(r.points[1].position, Point3(4, 5, 6));
  EXPECT_EQ(r.points[1].id, 1u);
}

TEST(BalTest, NumbersMaySpreadOverLinesInAnyWay) {
  const std::string one_line =
      WriteTempFile("one_line.bal",
                    "2 1 2 0 0 1.5 2.5 1 0 -3 4 0.1 0.2 0.3 1 2 3 400 0 0 -0.1 0 0.2 0 0 1 600 "
                    "1e-3 0 1 2 30\n");
  const std::string per_line = WriteTempFile(
      "per_line.bal",
      "2 1 2\n\n0 0 1.5 2.5\n1 0 -3 4\n\n0.1\n0.2\n0.3\n1\n2\n3\n400\n0\n0\n\n-0.1\n0\n"
      "0.2\n0\n0\n1\n600\n1e-3\n0\n\n1\n2\n30\n");
  ExpectSameReconstruction(MustReadBal(one_line), MustReadBal(per_line), 0.0, 0.0);
}

TEST(BalTest, WriteReadRoundTrip) {
  for (const char* name : {"bal/dubrovnik-3-7-pre.txt", "bal/problem-49-7776-pre.txt"}) {
    const std::string path = SharedDatasetPath(name);
    SLAMD_SKIP_IF_NO_SHARED_DATASET(path);
    const Reconstruction r = MustReadBal(path);
    const std::string out = WriteTempFile("round_trip.bal", "");
    ASSERT_TRUE(WriteBal(r, out).ok()) << name;
    // Poses go through the Rodrigues vector and back (translations of up to ~100 here).
    ExpectSameReconstruction(r, MustReadBal(out), 1e-12, 0.0);
  }
}

struct BadBal {
  const char* text;
  const char* message;  // after "FILE:"
};

TEST(BalTest, MalformedFilesNameTheLine) {
  const BadBal cases[] = {
      {"", "1: expected num_cameras (an integer in [0, 2147483647)), got the end of the file"},
      {"-1 0 0\n", "1: expected num_cameras (an integer in [0, 2147483647)), got '-1'"},
      {"1 1 1\n\n0 0 1.0 abc\n", "3: expected y of observation 0 (a finite number), got 'abc'"},
      {"1 1 2\n0 0 1 2\n3 0 1 2\n",
       "3: expected the camera of observation 1 (an integer in [0, 1)), got '3'"},
      {"1 1 1\n0 0 1 2\n0\nnan\n", "4: expected w2 of camera 0 (a finite number), got 'nan'"},
      {"1 1 1\n0 0 1 2\n0 0 0 0 0 0 1 0 0\n1e999 0 0\n",
       "4: expected X of point 0 (a finite number), got '1e999'"},
      {"1 2 1\n0 1 1 2\n0 0 0 0 0 0 1 0 0\n1 2 3\n",
       "4: expected X of point 1 (a finite number), got the end of the file"},
      {"1 1 1\n0 0 1 2\n0 0 0 0 0 0 1 0 0\n1 2 3\n\n7\n",
       "6: expected the end of the file after the last point, got '7'"},
  };
  for (const BadBal& c : cases) {
    const std::string path = WriteTempFile("bad.bal", c.text);
    const Result<Reconstruction> r = ReadBal(path);
    ASSERT_FALSE(r.ok()) << c.text;
    EXPECT_EQ(r.status().code(), StatusCode::kDataLoss) << c.text;
    EXPECT_EQ(r.status().message(), path + ":" + c.message) << c.text;
  }
}

TEST(BalTest, MissingFileIsNotFound) {
  EXPECT_EQ(ReadBal(::testing::TempDir() + "slamd_no_such.bal").status().code(),
            StatusCode::kNotFound);
}

// One image with its own Cal3Bundler, one point, one observation: what BAL can hold.
Reconstruction BalWritable() {
  Reconstruction r;
  r.intrinsics.resize(1);
  r.intrinsics[0].calibration = Cal3Bundler(500, 0, 0);
  r.images.resize(1);
  r.images[0].pose = Pose3(Rot3(), Point3(0, 0, -5));
  r.points.resize(1);
  r.observations.resize(1);
  return r;
}

TEST(BalTest, WriteRefusesWhatBalCannotHold) {
  const std::string path = ::testing::TempDir() + "slamd_never_written.bal";
  std::filesystem::remove(path);
  const auto expect_refused = [&](const Reconstruction& r, const std::string& message) {
    const Status s = WriteBal(r, path);
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument) << message;
    EXPECT_THAT(s.message(), HasSubstr(message));
    EXPECT_FALSE(std::filesystem::exists(path)) << message;
  };
  ASSERT_TRUE(BalWritable().Validate().ok());

  Reconstruction pinhole = BalWritable();
  pinhole.intrinsics[0].calibration = Cal3_S2(500, 500, 0, 320, 240);
  expect_refused(pinhole, "intrinsics 0 are not a Cal3Bundler");

  Reconstruction shifted = BalWritable();
  shifted.intrinsics[0].principal_point = Eigen::Vector2d(320, 240);
  expect_refused(shifted, "non-zero principal point");

  Reconstruction shared = BalWritable();
  shared.images.push_back(shared.images[0]);  // both use intrinsics 0
  expect_refused(shared, "1 intrinsics for 2 images");
  shared.intrinsics.push_back(shared.intrinsics[0]);
  expect_refused(shared, "image 1 uses intrinsics 0");

  Reconstruction invalid = BalWritable();
  invalid.observations[0].point = 3;
  expect_refused(invalid, "observation 0");
}

TEST(BalTest, WrittenFileStartsWithTheCounts) {
  const std::string path = WriteTempFile("written.bal", "");
  ASSERT_TRUE(WriteBal(BalWritable(), path).ok());
  std::ifstream in(path);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "1 1 1");
  EXPECT_NEAR(MustReadBal(path).images[0].pose.translation().z(), -5.0, 1e-12);
}

}  // namespace
}  // namespace slamd::core
