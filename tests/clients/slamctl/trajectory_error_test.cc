// AlignRigid / AbsoluteTrajectoryError against known rigid transforms, and ReadGroundTruth on both
// kinds of ground-truth file.
#include "clients/slamctl/trajectory_error.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/geometry/pose2.h"
#include "core/geometry/pose3.h"
#include "tests/testing/datasets.h"

namespace slamd::clients {
namespace {

using core::MakeKey;

Eigen::MatrixXd RandomPoints(int d, int n, std::mt19937_64* rng) {
  std::normal_distribution<double> normal(0.0, 10.0);
  Eigen::MatrixXd P(d, n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < d; ++i) P(i, j) = normal(*rng);
  return P;
}

TEST(AlignRigidTest, RecoversAKnownTransformIn2dAnd3dUnderNoise) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 0.01);
  for (int d : {2, 3}) {
    const Eigen::MatrixXd truth = RandomPoints(d, 200, &rng);
    Eigen::MatrixXd R;
    Eigen::VectorXd t(d);
    if (d == 2) {
      R = core::Rot2::FromAngle(2.5).matrix();  // more than π/2: no small-angle luck
      t << 4.0, -7.0;
    } else {
      R = core::Rot3::Exp(core::Vector3(0.3, -1.9, 0.7)).matrix();
      t << 4.0, -7.0, 1.5;
    }
    // estimate = R·truth + t + noise, so the alignment estimate -> truth is (Rᵀ, −Rᵀt).
    Eigen::MatrixXd estimate = (R * truth).colwise() + t;
    for (int j = 0; j < estimate.cols(); ++j)
      for (int i = 0; i < d; ++i) estimate(i, j) += noise(rng);
    const core::Result<RigidAlignment> a = AlignRigid(estimate, truth);
    ASSERT_TRUE(a.ok()) << a.status().ToString();
    EXPECT_TRUE(a->R.isApprox(R.transpose(), 1e-3)) << a->R;
    EXPECT_NEAR(a->R.determinant(), 1.0, 1e-12);
    EXPECT_TRUE(a->t.isApprox(-R.transpose() * t, 1e-3)) << a->t.transpose();
  }
}

TEST(AlignRigidTest, NeverReturnsAReflection) {
  // A mirrored copy: the best orthogonal map is a reflection; the answer must be a rotation.
  std::mt19937_64 rng(3);
  const Eigen::MatrixXd truth = RandomPoints(3, 50, &rng);
  Eigen::MatrixXd mirrored = truth;
  mirrored.row(2) *= -1.0;
  const core::Result<RigidAlignment> a = AlignRigid(mirrored, truth);
  ASSERT_TRUE(a.ok());
  EXPECT_NEAR(a->R.determinant(), 1.0, 1e-12);
  EXPECT_TRUE((a->R.transpose() * a->R).isIdentity(1e-12));
}

TEST(AlignRigidTest, RejectsBadShapes) {
  EXPECT_FALSE(AlignRigid(Eigen::MatrixXd(4, 3), Eigen::MatrixXd(4, 3)).ok());
  EXPECT_FALSE(AlignRigid(Eigen::MatrixXd::Zero(2, 3), Eigen::MatrixXd::Zero(2, 4)).ok());
  EXPECT_FALSE(AlignRigid(Eigen::MatrixXd(2, 0), Eigen::MatrixXd(2, 0)).ok());
  Eigen::MatrixXd nan = Eigen::MatrixXd::Zero(2, 2);
  nan(0, 0) = std::nan("");
  EXPECT_FALSE(AlignRigid(nan, Eigen::MatrixXd::Zero(2, 2)).ok());
}

TEST(AbsoluteTrajectoryErrorTest, ARigidCopyHasZeroErrorAndAPerturbedPoseShows) {
  core::Values truth, moved;
  const core::Pose2 offset(10.0, -3.0, 2.0);
  for (int i = 0; i < 30; ++i) {
    const core::Pose2 p(std::cos(0.3 * i) * i, std::sin(0.2 * i) * 5.0, 0.1 * i);
    ASSERT_TRUE(truth.Insert(MakeKey('x', i), p).ok());
    ASSERT_TRUE(moved.Insert(MakeKey('x', i), offset * p).ok());
  }
  ASSERT_TRUE(truth.Insert(MakeKey('l', 0), core::Point2(1.0, 1.0)).ok());  // ignored
  ASSERT_TRUE(moved.Insert(MakeKey('x', 99), core::Pose2()).ok());          // not in the truth
  core::Result<TrajectoryError> ate = AbsoluteTrajectoryError(moved, truth);
  ASSERT_TRUE(ate.ok()) << ate.status().ToString();
  EXPECT_EQ(ate->poses, 30u);
  EXPECT_NEAR(ate->rmse, 0.0, 1e-9);
  EXPECT_NEAR(ate->max, 0.0, 1e-9);

  // One position off by 0.6 m (before the rigid offset): the alignment barely moves, so the
  // error is ~0.6 at that pose, and the RMSE is about 0.6/√30.
  const core::Pose2 p5 = truth.At<core::Pose2>(MakeKey('x', 5));
  ASSERT_TRUE(moved.Update(MakeKey('x', 5), offset * core::Pose2(p5.rotation(), p5.translation() +
                                                                  core::Point2(0.6, 0.0))).ok());
  ate = AbsoluteTrajectoryError(moved, truth);
  ASSERT_TRUE(ate.ok());
  EXPECT_NEAR(ate->max, 0.6, 0.05);
  EXPECT_NEAR(ate->rmse, 0.6 / std::sqrt(30.0), 0.01);
  EXPECT_LE(ate->max, 0.6);  // the best alignment can only lower the worst error here
}

TEST(AbsoluteTrajectoryErrorTest, Pose3RigidCopyHasZeroError) {
  core::Values truth, moved;
  const core::Pose3 offset(core::Rot3::Exp(core::Vector3(0.5, 0.2, -1.0)), core::Point3(1, 2, 3));
  for (int i = 0; i < 10; ++i) {
    const core::Pose3 p(core::Rot3::Exp(core::Vector3(0.1 * i, 0.0, 0.2)), core::Point3(i, i * i * 0.1, std::sin(i)));
    ASSERT_TRUE(truth.Insert(MakeKey('x', i), p).ok());
    ASSERT_TRUE(moved.Insert(MakeKey('x', i), offset * p).ok());
  }
  const core::Result<TrajectoryError> ate = AbsoluteTrajectoryError(moved, truth);
  ASSERT_TRUE(ate.ok());
  EXPECT_NEAR(ate->rmse, 0.0, 1e-9);
  EXPECT_TRUE(ate->alignment.R.isApprox(offset.rotation().matrix().transpose(), 1e-9));
}

TEST(AbsoluteTrajectoryErrorTest, ErrorsWhenNothingIsSharedOrDimensionsMix) {
  core::Values a, b;
  ASSERT_TRUE(a.Insert(MakeKey('x', 0), core::Pose2()).ok());
  ASSERT_TRUE(b.Insert(MakeKey('x', 1), core::Pose2()).ok());
  EXPECT_FALSE(AbsoluteTrajectoryError(a, b).ok());
  ASSERT_TRUE(b.Insert(MakeKey('x', 0), core::Pose3()).ok());
  EXPECT_FALSE(AbsoluteTrajectoryError(a, b).ok());
}

TEST(ReadGroundTruthTest, VerticesOrComposedNoiseFreeMeasurements) {
  // g2o with vertices: the vertices (an edge that disagrees with them does not matter).
  const std::string g2o = testing::WriteTempFile(
      "truth.g2o",
      "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 1.5707963267948966\nVERTEX_SE2 2 1 2 0\n"
      "EDGE_SE2 0 1 5 5 0 1 0 0 1 0 1\nEDGE_SE2 1 2 5 5 0 1 0 0 1 0 1\n");
  core::Result<core::Values> v = ReadGroundTruth(g2o);
  ASSERT_TRUE(v.ok()) << v.status().ToString();
  ASSERT_EQ(v->size(), 3u);
  EXPECT_NEAR(v->At<core::Pose2>(MakeKey('x', 2)).y(), 2.0, 1e-12);
  // iSAM measurements without vertices: composed from pose 0 at the identity.
  const std::string isam = testing::WriteTempFile(
      "truth.txt", "EDGE2 0 1 1 0 1.5707963267948966 50 0 0 50 0 100\nEDGE2 1 2 2 0 0 50 0 0 50 0 100\n"
                   "EDGE2 0 2 1 2 1.5707963267948966 50 0 0 50 0 100\n");
  v = ReadGroundTruth(isam);
  ASSERT_TRUE(v.ok()) << v.status().ToString();
  const core::Pose2 x2 = v->At<core::Pose2>(MakeKey('x', 2));
  EXPECT_NEAR(x2.x(), 1.0, 1e-12);
  EXPECT_NEAR(x2.y(), 2.0, 1e-12);
  EXPECT_FALSE(ReadGroundTruth("/nonexistent/truth.g2o").ok());
}

}  // namespace
}  // namespace slamd::clients
