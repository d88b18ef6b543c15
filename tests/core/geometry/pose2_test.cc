#include "core/geometry/pose2.h"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <cmath>
#include <random>
#include <vector>

#include "tests/testing/numerical_derivative.h"

namespace slamd::core {
namespace {

using testing::NumericalJacobian;
using testing::NumericalJacobianRight;
using testing::NumericalJacobianVector;

// Largest absolute difference, relative to the reference's scale when that exceeds 1.
double RelDiff(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& expected) {
  return testing::MaxRelDiff(actual, expected);
}

constexpr double kPose2Tol = 1e-7;

class Pose2Test : public ::testing::Test {
 protected:
  Pose2 RandomPose() { return Pose2(u10_(rng_), u10_(rng_), upi_(rng_)); }
  Point2 RandomPoint() { return Point2(u10_(rng_), u10_(rng_)); }

  std::mt19937 rng_{12345};
  std::uniform_real_distribution<double> u10_{-10.0, 10.0};
  std::uniform_real_distribution<double> upi_{-kPi, kPi};
};

// Angles where the closed forms are delicate: around 0 (series) and around +-pi.
const std::vector<double> kSpecialAngles = {
    0.0,       1e-12, 1e-9, -1e-9,      1e-5,       -1e-5,       1e-3,       9.999e-3,
    1.0001e-2, 0.5,   -2.0, kPi - 1e-3, kPi - 1e-6, -kPi + 1e-6, -kPi + 1e-3};

TEST_F(Pose2Test, ConstructionAndAccessors) {
  const Pose2 p(1.0, -2.0, 0.5);
  EXPECT_DOUBLE_EQ(p.x(), 1.0);
  EXPECT_DOUBLE_EQ(p.y(), -2.0);
  EXPECT_NEAR(p.theta(), 0.5, 1e-15);
  EXPECT_NEAR(Pose2(0, 0, 3.0 * kPi).theta(), kPi, 1e-12);
  Matrix3 T;
  T << std::cos(0.5), -std::sin(0.5), 1.0, std::sin(0.5), std::cos(0.5), -2.0, 0, 0, 1;
  EXPECT_LT(RelDiff(p.matrix(), T), 1e-15);
  EXPECT_TRUE(Pose2().Equals(Pose2(0, 0, 0)));
  EXPECT_FALSE(p.Equals(Pose2(1.0, -2.0, 0.5 + 1e-6)));
  EXPECT_TRUE(Pose2(0, 0, kPi).Equals(Pose2(0, 0, -kPi)));
}

TEST_F(Pose2Test, GroupOperationsMatchMatrices) {
  for (int i = 0; i < 100; ++i) {
    const Pose2 a = RandomPose(), b = RandomPose();
    const Point2 p = RandomPoint();
    EXPECT_LT(RelDiff(a.Compose(b).matrix(), a.matrix() * b.matrix()), 1e-13);
    EXPECT_LT(RelDiff(a.Between(b).matrix(), a.matrix().inverse() * b.matrix()), 1e-13);
    EXPECT_LT(RelDiff(a.Inverse().matrix(), a.matrix().inverse()), 1e-13);
    const Eigen::Vector3d ph(p.x(), p.y(), 1.0);
    EXPECT_LT(RelDiff(a.TransformFrom(p), (a.matrix() * ph).head<2>()), 1e-13);
    EXPECT_LT(RelDiff(a.TransformTo(p), (a.matrix().inverse() * ph).head<2>()), 1e-13);
  }
}

TEST_F(Pose2Test, ComposeBetweenInverseJacobians) {
  for (int i = 0; i < 100; ++i) {
    const Pose2 a = RandomPose(), b = RandomPose();
    Matrix3 H1, H2;
    a.Compose(b, &H1, &H2);
    EXPECT_LT(RelDiff(H1, NumericalJacobianRight([&](const Pose2& x) { return x.Compose(b); }, a)),
              kPose2Tol);
    EXPECT_LT(RelDiff(H2, NumericalJacobianRight([&](const Pose2& x) { return a.Compose(x); }, b)),
              kPose2Tol);
    a.Between(b, &H1, &H2);
    EXPECT_LT(RelDiff(H1, NumericalJacobianRight([&](const Pose2& x) { return x.Between(b); }, a)),
              kPose2Tol);
    EXPECT_LT(RelDiff(H2, NumericalJacobianRight([&](const Pose2& x) { return a.Between(x); }, b)),
              kPose2Tol);
    Matrix3 H;
    a.Inverse(&H);
    EXPECT_LT(RelDiff(H, NumericalJacobianRight([](const Pose2& x) { return x.Inverse(); }, a)),
              kPose2Tol);
  }
}

TEST_F(Pose2Test, TransformJacobians) {
  for (int i = 0; i < 100; ++i) {
    const Pose2 a = RandomPose();
    const Point2 p = RandomPoint();
    Matrix23 Hx;
    Matrix2 Hp;
    a.TransformFrom(p, &Hx, &Hp);
    EXPECT_LT(
        RelDiff(Hx, NumericalJacobianRight([&](const Pose2& x) { return x.TransformFrom(p); }, a)),
        kPose2Tol);
    EXPECT_LT(RelDiff(Hp, NumericalJacobian([&](const Eigen::VectorXd& q)
                                                -> Eigen::VectorXd { return a.TransformFrom(q); },
                                            p)),
              kPose2Tol);
    a.TransformTo(p, &Hx, &Hp);
    EXPECT_LT(
        RelDiff(Hx, NumericalJacobianRight([&](const Pose2& x) { return x.TransformTo(p); }, a)),
        kPose2Tol);
    EXPECT_LT(RelDiff(Hp, NumericalJacobian([&](const Eigen::VectorXd& q)
                                                -> Eigen::VectorXd { return a.TransformTo(q); },
                                            p)),
              kPose2Tol);
  }
}

TEST_F(Pose2Test, ExpKnownValues) {
  EXPECT_TRUE(Pose2::Exp(Vector3::Zero()).Equals(Pose2()));
  EXPECT_TRUE(Pose2::Exp(Vector3(1.0, 2.0, 0.0)).Equals(Pose2(1.0, 2.0, 0.0)));
  // A quarter circle of radius 1: move forward pi/2 while turning pi/2 -> ends at (1, 1).
  EXPECT_TRUE(Pose2::Exp(Vector3(kPi / 2, 0.0, kPi / 2)).Equals(Pose2(1.0, 1.0, kPi / 2), 1e-12));
  // Half circle of radius 1: ends at (0, 2) facing backwards.
  EXPECT_TRUE(Pose2::Exp(Vector3(kPi, 0.0, kPi)).Equals(Pose2(0.0, 2.0, kPi), 1e-12));
}

TEST_F(Pose2Test, ExpLogJacobiansRandomAndSpecialAngles) {
  std::vector<Vector3> xis;
  for (int i = 0; i < 100; ++i) xis.emplace_back(u10_(rng_), u10_(rng_), upi_(rng_));
  for (double th : kSpecialAngles) xis.emplace_back(u10_(rng_), u10_(rng_), th);
  for (const Vector3& xi : xis) {
    SCOPED_TRACE(xi.transpose());
    Matrix3 H;
    const Pose2 X = Pose2::Exp(xi, &H);
    EXPECT_LT(RelDiff(H, NumericalJacobianVector(
                             [](const Eigen::VectorXd& v) { return Pose2::Exp(v); }, xi)),
              kPose2Tol);
    // Log: keep the finite-difference step well inside the branch when theta is near +-pi.
    const double margin = kPi - std::abs(xi[2]);
    const double h = std::min(1e-6, margin / 10.0);
    Matrix3 Hl;
    const Vector3 back = Pose2::Log(X, &Hl);
    EXPECT_LT(
        RelDiff(Hl, NumericalJacobianRight([](const Pose2& x) { return Pose2::Log(x); }, X, h)),
        h < 1e-6 ? 1e-5 : kPose2Tol);
    // Log(Exp(xi)) == xi and Jr^-1 * Jr == I.
    EXPECT_LT(RelDiff(back, xi), 1e-12);
    EXPECT_LT(RelDiff(Hl * H, Matrix3::Identity()), 1e-12);
  }
}

TEST_F(Pose2Test, ExpOfLogRoundTrip) {
  std::vector<Pose2> poses;
  for (int i = 0; i < 100; ++i) poses.push_back(RandomPose());
  for (double th : kSpecialAngles) poses.emplace_back(u10_(rng_), u10_(rng_), th);
  poses.emplace_back(3.0, -4.0, kPi);  // exactly pi
  for (const Pose2& X : poses) {
    EXPECT_TRUE(Pose2::Exp(Pose2::Log(X)).Equals(X, 1e-12)) << X.x() << " " << X.theta();
  }
  // Pure translation and pure rotation.
  EXPECT_LT(RelDiff(Pose2::Log(Pose2(1.5, -2.0, 0.0)), Vector3(1.5, -2.0, 0.0)), 1e-15);
  EXPECT_LT(RelDiff(Pose2::Log(Pose2(0.0, 0.0, 1.2)), Vector3(0.0, 0.0, 1.2)), 1e-15);
  EXPECT_NEAR(Pose2::Log(Pose2(0.0, 0.0, kPi))[2], kPi, 1e-15);
}

TEST_F(Pose2Test, ChartMatchesGtsamConvention) {
  for (int i = 0; i < 100; ++i) {
    const Pose2 a = RandomPose(), b = RandomPose();
    // GTSAM's Pose2 chart: local = (R_a^T (t_b - t_a), wrap(theta_b - theta_a)).
    const Vector3 local = a.LocalCoordinates(b);
    const Point2 dt = a.rotation().matrix().transpose() * (b.translation() - a.translation());
    EXPECT_LT(RelDiff(local, Vector3(dt.x(), dt.y(), WrapAngle(b.theta() - a.theta()))), 1e-12);
    // Retract is its inverse.
    EXPECT_TRUE(a.Retract(local).Equals(b, 1e-12));
    const Vector3 d(u10_(rng_), u10_(rng_), upi_(rng_));
    EXPECT_LT(RelDiff(a.LocalCoordinates(a.Retract(d)), d), 1e-12);
    EXPECT_TRUE(a.Retract(d).Equals(a * Pose2(d[0], d[1], d[2]), 1e-12));
  }
}

TEST_F(Pose2Test, ChartLocalJacobian) {
  for (int i = 0; i < 100; ++i) {
    Pose2 a = RandomPose();
    if (std::abs(a.theta()) > kPi - 1e-3) continue;  // the chart wraps at +-pi
    Matrix3 H;
    const Vector3 v = Pose2::ChartLocal(a, &H);
    EXPECT_LT(RelDiff(v, Vector3(a.x(), a.y(), a.theta())), 1e-15);
    EXPECT_LT(
        RelDiff(H, NumericalJacobianRight([](const Pose2& x) { return Pose2::ChartLocal(x); }, a)),
        kPose2Tol);
  }
}

TEST_F(Pose2Test, AdjointMapProperty) {
  for (int i = 0; i < 100; ++i) {
    const Pose2 X = RandomPose();
    const Vector3 xi(u10_(rng_), u10_(rng_), 0.9 * upi_(rng_));
    const Pose2 lhs = Pose2::Exp(X.AdjointMap() * xi);
    const Pose2 rhs = X * Pose2::Exp(xi) * X.Inverse();
    EXPECT_TRUE(lhs.Equals(rhs, 1e-10));
  }
}

}  // namespace
}  // namespace slamd::core
