#include "core/geometry/camera.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "tests/testing/camera_examples.h"
#include "tests/testing/numerical_derivative.h"

namespace slamd::core {
namespace {

using testing::MaxRelDiff;
using testing::NumericalJacobian;
using testing::NumericalJacobianRight;
using testing::RandomCalibration;
using testing::RandomCameraPose;
using testing::RandomPointAhead;

// Central differences with h = 1e-6 on pixels of a few hundred: ~1e-9 relative error.
constexpr double kCameraTol = 1e-6;

// ∂f/∂c for f a function of a calibration's parameter vector (the calibration moves by addition).
template <typename Cal, typename F>
Eigen::MatrixXd NumericalCalibrationJacobian(F&& f, const Cal& K) {
  return NumericalJacobian(
      [&](const Eigen::VectorXd& c) -> Eigen::VectorXd { return f(Cal(typename Cal::Vector(c))); },
      K.vector());
}

template <typename Cal>
class CameraModelTest : public ::testing::Test {};
using CalibrationModels = ::testing::Types<Cal3_S2, Cal3DS2, Cal3Bundler>;
TYPED_TEST_SUITE(CameraModelTest, CalibrationModels);

TYPED_TEST(CameraModelTest, UncalibrateJacobiansMatchNumerical) {
  using Cal = TypeParam;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  for (int trial = 0; trial < 20; ++trial) {
    const Cal K = RandomCalibration<Cal>(rng);
    const Vector2 p(u(rng), u(rng));
    Matrix2 H_p;
    CalibrationJacobian<Cal> H_cal;
    const Vector2 uv = Uncalibrate(K, p, &H_p, &H_cal);
    EXPECT_TRUE(uv.isApprox(Uncalibrate(K, p), 1e-15)) << "Jacobians change the pixel";
    EXPECT_LT(MaxRelDiff(H_p, NumericalJacobian(
                                  [&](const Eigen::VectorXd& q) -> Eigen::VectorXd {
                                    return Uncalibrate(K, Vector2(q));
                                  },
                                  p)),
              kCameraTol);
    EXPECT_LT(MaxRelDiff(H_cal, NumericalCalibrationJacobian(
                                    [&](const Cal& c) { return Uncalibrate(c, p); }, K)),
              kCameraTol);
  }
}

TYPED_TEST(CameraModelTest, ProjectJacobiansMatchNumerical) {
  using Cal = TypeParam;
  std::mt19937 rng(11);
  for (int trial = 0; trial < 20; ++trial) {
    const Cal K = RandomCalibration<Cal>(rng);
    const Pose3 pose = RandomCameraPose(rng);
    const Point3 p_w = pose.TransformFrom(RandomPointAhead(rng));
    Matrix26 H_pose;
    Matrix23 H_point;
    CalibrationJacobian<Cal> H_cal;
    const Projection proj = Project(pose, K, p_w, &H_pose, &H_point, &H_cal);
    ASSERT_TRUE(proj.in_front());
    EXPECT_TRUE(proj.uv.isApprox(Project(pose, K, p_w).uv, 1e-15));
    // Pose: right perturbation, pose.Retract(ξ) = pose·Exp(ξ) with ξ = (v, ω).
    EXPECT_LT(MaxRelDiff(H_pose, NumericalJacobianRight(
                                     [&](const Pose3& x) { return Project(x, K, p_w).uv; }, pose)),
              kCameraTol);
    EXPECT_LT(MaxRelDiff(H_point, NumericalJacobian(
                                      [&](const Eigen::VectorXd& q) -> Eigen::VectorXd {
                                        return Project(pose, K, Point3(q)).uv;
                                      },
                                      p_w)),
              kCameraTol);
    EXPECT_LT(MaxRelDiff(H_cal, NumericalCalibrationJacobian(
                                    [&](const Cal& c) { return Project(pose, c, p_w).uv; }, K)),
              kCameraTol);
  }
}

TYPED_TEST(CameraModelTest, ProjectCameraFrameIsProjectAtTheIdentity) {
  using Cal = TypeParam;
  std::mt19937 rng(13);
  const Cal K = RandomCalibration<Cal>(rng);
  const Point3 p_c = RandomPointAhead(rng);
  Matrix23 H_a, H_b;
  CalibrationJacobian<Cal> C_a, C_b;
  const Projection a = ProjectCameraFrame(K, p_c, &H_a, &C_a);
  const Projection b = Project(Pose3(), K, p_c, nullptr, &H_b, &C_b);
  EXPECT_TRUE(a.uv.isApprox(b.uv, 1e-15));
  EXPECT_EQ(a.depth, p_c.z());
  EXPECT_TRUE(H_a.isApprox(H_b, 1e-15));
  EXPECT_TRUE(C_a.isApprox(C_b, 1e-15));
}

TYPED_TEST(CameraModelTest, CalibrateInvertsUncalibrate) {
  using Cal = TypeParam;
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  for (int trial = 0; trial < 50; ++trial) {
    const Cal K = RandomCalibration<Cal>(rng);
    const Vector2 p(u(rng), u(rng));
    const Vector2 uv = Uncalibrate(K, p);
    EXPECT_LT((Calibrate(K, uv) - p).norm(), 1e-11) << "p = " << p.transpose();
    EXPECT_LT((Uncalibrate(K, Calibrate(K, uv)) - uv).norm(), 1e-8);
  }
}

TYPED_TEST(CameraModelTest, PointBehindIsReportedWithAFinitePixelAndJacobians) {
  using Cal = TypeParam;
  std::mt19937 rng(19);
  const Cal K = RandomCalibration<Cal>(rng);
  const Pose3 pose = RandomCameraPose(rng);
  const Point3 p_c(0.4, -0.2, -2.0);
  Matrix26 H_pose;
  Matrix23 H_point;
  const Projection proj = Project(pose, K, pose.TransformFrom(p_c), &H_pose, &H_point);
  EXPECT_FALSE(proj.in_front());
  EXPECT_NEAR(proj.depth, -2.0, 1e-12);
  EXPECT_TRUE(proj.uv.allFinite());
  EXPECT_TRUE(H_pose.allFinite());
  EXPECT_TRUE(H_point.allFinite());
  EXPECT_GT(H_pose.norm(), 1.0);
  EXPECT_GT(H_point.norm(), 1.0);
  EXPECT_TRUE(Project(pose, K, pose.TransformFrom(Point3(0.4, -0.2, 2.0))).in_front());
}

TEST(CameraTest, ProjectToNormalizedJacobianMatchesNumerical) {
  std::mt19937 rng(23);
  for (int trial = 0; trial < 20; ++trial) {
    const Point3 p_c = RandomPointAhead(rng);
    Matrix23 H;
    const Vector2 p = ProjectToNormalized(p_c, &H);
    EXPECT_TRUE(p.isApprox(Vector2(p_c.x() / p_c.z(), p_c.y() / p_c.z()), 1e-15));
    EXPECT_LT(MaxRelDiff(H, NumericalJacobian(
                                [](const Eigen::VectorXd& q) -> Eigen::VectorXd {
                                  return ProjectToNormalized(Point3(q));
                                },
                                p_c)),
              kCameraTol);
  }
}

// The pixels below are worked by hand from the formulas in camera.h, for the camera-frame point
// (0.4, -0.2, 2): normalised (x, y) = (0.2, -0.1), r² = 0.05, xy = -0.02.
TEST(CameraTest, Cal3_S2PixelByHand) {
  // u = 500·0.2 + 2·(-0.1) + 320 = 419.8, v = 490·(-0.1) + 240 = 191.
  const Cal3_S2 K(500.0, 490.0, 2.0, 320.0, 240.0);
  const Projection p = ProjectCameraFrame(K, Point3(0.4, -0.2, 2.0));
  EXPECT_NEAR(p.uv.x(), 419.8, 1e-12);
  EXPECT_NEAR(p.uv.y(), 191.0, 1e-12);
  EXPECT_EQ(p.depth, 2.0);
}

TEST(CameraTest, Cal3DS2PixelByHand) {
  // g = 1 - 0.2·0.05 + 0.05·0.0025 = 0.990125
  // x' = 0.990125·0.2 + 2·0.001·(-0.02) - 0.002·(0.05 + 2·0.04) = 0.198025 - 0.00004 - 0.00026
  //    = 0.197725
  // y' = 0.990125·(-0.1) + 0.001·(0.05 + 2·0.01) + 2·(-0.002)·(-0.02)
  //    = -0.0990125 + 0.00007 + 0.00008 = -0.0988625
  // u = 500·0.197725 + 2·(-0.0988625) + 320 = 418.664775, v = 490·(-0.0988625) + 240 = 191.557375
  const Cal3DS2 K(Cal3_S2(500.0, 490.0, 2.0, 320.0, 240.0), -0.2, 0.05, 1e-3, -2e-3);
  const Projection p = ProjectCameraFrame(K, Point3(0.4, -0.2, 2.0));
  EXPECT_NEAR(p.uv.x(), 418.664775, 1e-10);
  EXPECT_NEAR(p.uv.y(), 191.557375, 1e-10);
}

TEST(CameraTest, Cal3BundlerPixelByHand) {
  // g = 0.990125 (as above); (u, v) = 500·g·(0.2, -0.1) = (99.0125, -49.50625).
  const Cal3Bundler K(500.0, -0.2, 0.05);
  const Projection p = ProjectCameraFrame(K, Point3(0.4, -0.2, 2.0));
  EXPECT_NEAR(p.uv.x(), 99.0125, 1e-10);
  EXPECT_NEAR(p.uv.y(), -49.50625, 1e-10);
}

TEST(CameraTest, DepthIsTheCameraFrameZ) {
  std::mt19937 rng(29);
  const Pose3 pose = RandomCameraPose(rng);
  const Point3 p_w(1.0, 2.0, 3.0);
  EXPECT_NEAR(Project(pose, Cal3_S2(500, 500, 0, 320, 240), p_w).depth, pose.TransformTo(p_w).z(),
              1e-12);
}

TEST(CameraTest, StereoPixelByHand) {
  // uL = 500·0.2 + 320 = 420, v = 500·(-0.1) + 240 = 190, uR = 420 - 500·0.12 / 2 = 390.
  const Cal3_S2Stereo K(Cal3_S2(500.0, 500.0, 0.0, 320.0, 240.0), 0.12);
  const StereoProjection s = ProjectStereo(Pose3(), K, Point3(0.4, -0.2, 2.0));
  EXPECT_NEAR(s.uuv[0], 420.0, 1e-12);
  EXPECT_NEAR(s.uuv[1], 390.0, 1e-12);
  EXPECT_NEAR(s.uuv[2], 190.0, 1e-12);
  EXPECT_TRUE(s.in_front());
}

TEST(CameraTest, StereoJacobiansMatchNumerical) {
  std::mt19937 rng(31);
  for (int trial = 0; trial < 20; ++trial) {
    const Cal3_S2Stereo K(RandomCalibration<Cal3_S2>(rng), 0.1 + 0.1 * (trial % 3));
    const Pose3 pose = RandomCameraPose(rng);
    const Point3 p_c = RandomPointAhead(rng);
    const Point3 p_w = pose.TransformFrom(p_c);
    Matrix36 H_pose;
    Matrix3 H_point;
    const StereoProjection s = ProjectStereo(pose, K, p_w, &H_pose, &H_point);
    // uR = uL - fx·b/z, and (uL, v) is the left camera's monocular pixel.
    EXPECT_NEAR(s.uuv[1], s.uuv[0] - K.K().fx() * K.baseline() / p_c.z(), 1e-9);
    EXPECT_TRUE(Vector2(s.uuv[0], s.uuv[2]).isApprox(Project(pose, K.K(), p_w).uv, 1e-14));
    EXPECT_NEAR(s.depth, p_c.z(), 1e-12);
    EXPECT_LT(
        MaxRelDiff(H_pose, NumericalJacobianRight(
                               [&](const Pose3& x) { return ProjectStereo(x, K, p_w).uuv; }, pose)),
        kCameraTol);
    EXPECT_LT(MaxRelDiff(H_point, NumericalJacobian(
                                      [&](const Eigen::VectorXd& q) -> Eigen::VectorXd {
                                        return ProjectStereo(pose, K, Point3(q)).uuv;
                                      },
                                      p_w)),
              kCameraTol);
    // Back-projection recovers the camera-frame point.
    EXPECT_LT((BackprojectStereo(K, s.uuv) - p_c).norm(), 1e-9 * p_c.norm());
  }
}

TEST(CameraTest, StereoPointBehindIsReported) {
  const Cal3_S2Stereo K(Cal3_S2(500.0, 500.0, 0.0, 320.0, 240.0), 0.12);
  Matrix36 H_pose;
  const StereoProjection s = ProjectStereo(Pose3(), K, Point3(0.4, -0.2, -2.0), &H_pose);
  EXPECT_FALSE(s.in_front());
  EXPECT_TRUE(s.uuv.allFinite());
  EXPECT_GT(H_pose.norm(), 1.0);
  EXPECT_GT(s.uuv[1], s.uuv[0]);  // negative disparity
}

}  // namespace
}  // namespace slamd::core
