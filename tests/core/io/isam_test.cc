// The iSAM text format: square-root information (Ω = RᵀR) or covariance noise, LANDMARK, and
// EDGE3's Euler-angle noise converted to slamd's SE(3) chart.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "core/factors/between_factor.h"
#include "core/factors/relative_point_factor.h"
#include "core/io/dataset.h"
#include "tests/testing/datasets.h"

namespace slamd::core {
namespace {

using slamd::testing::WriteTempFile;

Dataset MustReadIsam(const std::string& text, const ReadOptions& options = {}) {
  Result<Dataset> d = ReadDataset(WriteTempFile("isam.txt", text), options);
  EXPECT_TRUE(d.ok()) << d.status().ToString();
  return d.ok() ? std::move(d).value() : Dataset{};
}

TEST(Isam, SqrtInformationIsSquared) {
  const Dataset d = MustReadIsam(
      "ODOMETRY 0 1 1 0 0.1 1 2 3 4 5 6\n"
      "LANDMARK 1 0 2 -1 2 1 3\n");
  Eigen::Matrix3d R;
  R << 1, 2, 3, 0, 4, 5, 0, 0, 6;
  const Eigen::Matrix3d omega = R.transpose() * R;  // [1 2 3; 2 20 26; 3 26 70]
  EXPECT_NEAR(omega(1, 2), 26, 0);
  EXPECT_TRUE(d.graph[0]->noise_model().Information().isApprox(omega, 1e-14));
  Eigen::Matrix2d Rl;
  Rl << 2, 1, 0, 3;
  EXPECT_TRUE(d.graph[1]->noise_model().Information().isApprox(Rl.transpose() * Rl, 1e-14));
  // The landmark: id namespace of its own, initialised from its observation.
  EXPECT_EQ(d.landmarks, (KeyVector{MakeKey('l', 0)}));
  const auto& obs = dynamic_cast<const RelativePointFactor<Pose2, Point2>&>(*d.graph[1]);
  EXPECT_EQ(ToKeyVector(obs.keys()), (KeyVector{MakeKey('x', 1), MakeKey('l', 0)}));
  const Pose2 x1(1, 0, 0.1);
  EXPECT_TRUE(
      d.initial.At<Point2>(MakeKey('l', 0)).isApprox(x1.TransformFrom(Point2(2, -1)), 1e-15));
}

TEST(Isam, CovarianceOption) {
  ReadOptions options;
  options.isam_noise = ReadOptions::IsamNoise::kCovariance;
  const Dataset d = MustReadIsam(
      "ODOMETRY 0 1 1 0 0.1 4 1 0 9 0 16\n"
      "LANDMARK 1 0 2 -1 0.5 0.1 0.25\n",
      options);
  Eigen::Matrix3d cov;
  cov << 4, 1, 0, 1, 9, 0, 0, 0, 16;
  EXPECT_TRUE(d.graph[0]->noise_model().Information().isApprox(cov.inverse(), 1e-14));
  Eigen::Matrix2d cov_l;
  cov_l << 0.5, 0.1, 0.1, 0.25;
  EXPECT_TRUE(d.graph[1]->noise_model().Information().isApprox(cov_l.inverse(), 1e-14));
}

// iSAM's EDGE3 error: the difference of (x, y, z, yaw, pitch, roll) vectors.
Vector6 IsamVector(const Pose3& p) {
  const Vector3 rpy = p.rotation().RollPitchYaw();
  Vector6 v;
  v << p.translation(), rpy(2), rpy(1), rpy(0);
  return v;
}

TEST(Isam, Edge3NoiseMatchesIsamErrorToFirstOrder) {
  // Upper triangle s11..s66 in file order; distinct values, diagonally dominant.
  const double s[21] = {10, 0.1, 0.2, 0.3, 0.4, 0.5,  //
                        11, 0.6, 0.7, 0.8, 0.9,       //
                        12, 1.0, 1.1, 1.2,            //
                        13, 1.3, 1.4,                 //
                        14, 1.5,                      //
                        15};
  std::string text = "EDGE3 0 1 1 2 3 0.3 -0.4 1.2";
  for (const double v : s) {
    text += ' ';
    text += std::to_string(v);
  }
  const Dataset d = MustReadIsam(text + "\n");
  ASSERT_TRUE(d.is_3d);
  const auto& f = dynamic_cast<const BetweenFactor<Pose3>&>(*d.graph[0]);
  const Pose3& m = f.measured();
  const Eigen::Matrix3d R_expected = (Eigen::AngleAxisd(1.2, Eigen::Vector3d::UnitZ()) *
                                      Eigen::AngleAxisd(-0.4, Eigen::Vector3d::UnitY()) *
                                      Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()))
                                         .toRotationMatrix();
  EXPECT_TRUE(m.rotation().matrix().isApprox(R_expected, 1e-15));
  EXPECT_TRUE(m.translation().isApprox(Point3(1, 2, 3), 0.0));
  EXPECT_TRUE(d.initial.At<Pose3>(MakeKey('x', 1)).Equals(m, 1e-15));

  // iSAM's sqrt-info in its (x, y, z, yaw, pitch, roll) order, as its Loader arranges the
  // numbers: the rotation rows reversed (s66 s56 s46 / s55 s45 / s44).
  Matrix6 S;
  S << 10, 0.1, 0.2, 0.3, 0.4, 0.5,  //
      0, 11, 0.6, 0.7, 0.8, 0.9,     //
      0, 0, 12, 1.0, 1.1, 1.2,       //
      0, 0, 0, 15, 1.5, 1.4,         //
      0, 0, 0, 0, 14, 1.3,           //
      0, 0, 0, 0, 0, 13;
  // Reference: central differences of iSAM's error at ξ = 0 for p = m·Exp(ξ).
  Matrix6 J;
  const double h = 1e-6;
  for (int k = 0; k < 6; ++k) {
    const Vector6 dk = h * Vector6::Unit(k);
    J.col(k) =
        (IsamVector(m.Compose(Pose3::Exp(dk))) - IsamVector(m.Compose(Pose3::Exp(-dk)))) / (2 * h);
  }
  const Matrix6 expected = J.transpose() * S.transpose() * S * J;
  const Eigen::MatrixXd info = f.noise_model().Information();
  EXPECT_LE((info - expected).cwiseAbs().maxCoeff(), 1e-6 * expected.cwiseAbs().maxCoeff())
      << info << "\n\n"
      << expected;
}

TEST(Isam, Edge3WithoutNoiseUsesUnitSqrtInformation) {
  const Dataset d = MustReadIsam("EDGE3 0 1 1 0 0 0 0 0\nEDGE3 2 1 1 0 0 0 0 0.5\n");
  // At zero angles J = I, so Ω = I.
  EXPECT_TRUE(d.graph[0]->noise_model().Information().isApprox(Matrix6::Identity(), 1e-14));
  // Reversed edge 2 -> 1: x2 = x1 ∘ z.
  const Pose3 z(Rot3::FromRollPitchYaw(0, 0, 0.5), Point3(1, 0, 0));
  EXPECT_TRUE(
      d.initial.At<Pose3>(MakeKey('x', 1)).Equals(d.initial.At<Pose3>(MakeKey('x', 2)) * z, 1e-15));
  EXPECT_EQ(d.num_pose_edges, 2u);
}

TEST(Isam, Edge3CovarianceIsRejected) {
  ReadOptions options;
  options.isam_noise = ReadOptions::IsamNoise::kCovariance;
  const Status s =
      ReadDataset(WriteTempFile("e3.txt", "EDGE3 0 1 1 0 0 0 0 0\n"), options).status();
  EXPECT_EQ(s.code(), StatusCode::kDataLoss);
  EXPECT_THAT(s.message(), ::testing::HasSubstr("square-root information"));
}

// WriteIsam → ReadDataset: the same measurements and noise (sqrt-information written as is).
TEST(Isam, WriteIsamRoundTrip) {
  Dataset d;
  Eigen::Matrix3d info;
  info << 20, 2, 1, 2, 30, 3, 1, 3, 400;
  Eigen::Matrix2d info_l;
  info_l << 5, 1, 1, 7;
  d.graph.Emplace<BetweenFactor<Pose2>>(MakeKey('x', 0), MakeKey('x', 1), Pose2(1, 0.1, 0.2),
                                        NoiseModel::FromInformation(info).value());
  d.graph.Emplace<RelativePointFactor<Pose2, Point2>>(MakeKey('x', 1), MakeKey('l', 4),
                                                      Point2(2.5, -1.0 / 3),
                                                      NoiseModel::FromInformation(info_l).value());
  d.graph.Emplace<BetweenFactor<Pose2>>(MakeKey('x', 1), MakeKey('x', 2), Pose2(0.3, -0.7, -3.1),
                                        NoiseModel::Isotropic(3, 0.1).value());
  d.graph.Emplace<BetweenFactor<Pose2>>(MakeKey('x', 0), MakeKey('x', 2), Pose2(1.2, -0.5, 3.0),
                                        NoiseModel::Isotropic(3, 0.1).value());
  const std::string path = WriteTempFile("written.txt", "");
  ASSERT_TRUE(WriteIsam(d, path).ok());
  Result<Dataset> read = ReadDataset(path);
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  const Dataset& back = read.value();
  EXPECT_EQ(back.format, DatasetFormat::kIsam);
  ASSERT_EQ(back.graph.size(), d.graph.size());
  EXPECT_EQ(back.num_pose_edges, 3u);
  EXPECT_EQ(back.num_landmark_observations, 1u);
  EXPECT_EQ(back.num_loop_like, 1u);
  for (std::size_t i = 0; i < d.graph.size(); ++i) {
    EXPECT_EQ(ToKeyVector(back.graph[i]->keys()), ToKeyVector(d.graph[i]->keys())) << i;
    EXPECT_TRUE(back.graph[i]->noise_model().Information().isApprox(
        d.graph[i]->noise_model().Information(), 1e-12))
        << i;
    // Same measurement: the errors at the read-back initial guess agree.
    EXPECT_LT((back.graph[i]->Error(back.initial) - d.graph[i]->Error(back.initial)).norm(), 1e-12)
        << i;
  }
  EXPECT_TRUE(back.initial.At<Pose2>(MakeKey('x', 1)).Equals(Pose2(1, 0.1, 0.2), 1e-15));
}

TEST(Isam, WriteIsamRejectsWhatItCannotWrite) {
  Dataset d;
  d.graph.Emplace<BetweenFactor<Pose3>>(MakeKey('x', 0), MakeKey('x', 1), Pose3(),
                                        NoiseModel::Isotropic(6, 1).value());
  const std::string path = ::testing::TempDir() + "slamd_isam_never_written.txt";
  Status s = WriteIsam(d, path);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), ::testing::HasSubstr("BetweenPose3"));
  EXPECT_FALSE(std::ifstream(path).good());  // nothing written
  Dataset robot;
  robot.graph.Emplace<BetweenFactor<Pose2>>(MakeKey('x', 0, 'a'), MakeKey('x', 1, 'a'), Pose2(),
                                            NoiseModel::Isotropic(3, 1).value());
  s = WriteIsam(robot, path);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), ::testing::HasSubstr("robot id"));
  EXPECT_EQ(WriteIsam(Dataset{}, "/nonexistent/dir/out.txt").code(), StatusCode::kIoError);
}

}  // namespace
}  // namespace slamd::core
