#include "core/geometry/rot3.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <vector>

#include "tests/testing/numerical_derivative.h"

namespace slamd::core {
namespace {

using testing::MaxRelDiff;
using testing::NumericalJacobian;
using testing::NumericalJacobianRight;
using testing::NumericalJacobianVector;

constexpr double kRot3Tol = 1e-7;

// Independent reference for Exp: Eigen's angle-axis conversion.
Matrix3 AngleAxisMatrix(const Vector3& w) {
  const double t = w.norm();
  if (t == 0.0) return Matrix3::Identity();
  return Eigen::AngleAxisd(t, w / t).toRotationMatrix();
}

class Rot3Test : public ::testing::Test {
 protected:
  Vector3 RandomUnit() {
    Vector3 v(n_(rng_), n_(rng_), n_(rng_));
    return v.normalized();
  }
  // Rotation vector with angle uniform in [0, max_angle).
  Vector3 RandomRotVec(double max_angle = kPi) { return RandomUnit() * (u01_(rng_) * max_angle); }
  Rot3 RandomRot() { return Rot3::Exp(RandomRotVec()); }
  Point3 RandomPoint() { return Point3(5.0 * n_(rng_), 5.0 * n_(rng_), 5.0 * n_(rng_)); }

  // Random axes at the delicate angles (0 series, pi branch) plus random rotation vectors.
  std::vector<Vector3> TestRotVecs() {
    std::vector<Vector3> out;
    for (int i = 0; i < 100; ++i) out.push_back(RandomRotVec());
    for (double t :
         {0.0, 1e-12, 1e-9, 1e-5, 1e-3, 9.999e-3, 1.0001e-2, 0.5, 2.0, kPi - 1e-3, kPi - 1e-6}) {
      for (int k = 0; k < 5; ++k) out.push_back(RandomUnit() * t);
    }
    // Axis-aligned near pi (largest-diagonal branches of the quaternion extraction).
    for (int a = 0; a < 3; ++a) out.push_back(Vector3::Unit(a) * (kPi - 1e-6));
    return out;
  }

  std::mt19937 rng_{2024};
  std::normal_distribution<double> n_{0.0, 1.0};
  std::uniform_real_distribution<double> u01_{0.0, 1.0};
};

TEST_F(Rot3Test, SkewIsCrossProduct) {
  const Vector3 a(1.0, -2.0, 0.5), b(0.3, 0.7, -1.1);
  EXPECT_LT(MaxRelDiff(Skew(a) * b, a.cross(b)), 1e-15);
  EXPECT_LT(MaxRelDiff(Skew(a).transpose(), -Skew(a)), 0.0 + 1e-300);
}

TEST_F(Rot3Test, ExpMatchesAngleAxis) {
  for (const Vector3& w : TestRotVecs()) {
    EXPECT_LT(MaxRelDiff(Rot3::Exp(w).matrix(), AngleAxisMatrix(w)), 1e-14) << w.transpose();
  }
  // Larger than pi is fine too.
  const Vector3 w(4.0, -1.0, 2.0);
  EXPECT_LT(MaxRelDiff(Rot3::Exp(w).matrix(), AngleAxisMatrix(w)), 1e-14);
}

TEST_F(Rot3Test, LogOfExpRoundTripIncludingNearPi) {
  for (const Vector3& w : TestRotVecs()) {
    // Reference rotation built independently, so Log is checked on its own.
    const Rot3 R(AngleAxisMatrix(w));
    EXPECT_LT(MaxRelDiff(Rot3::Log(R), w), 1e-12) << w.transpose();
    EXPECT_TRUE(Rot3::Exp(Rot3::Log(R)).Equals(R, 1e-14));
  }
}

TEST_F(Rot3Test, LogAtExactlyPi) {
  for (const Matrix3& M : {Matrix3(Eigen::Vector3d(1, -1, -1).asDiagonal()),
                           Matrix3(Eigen::Vector3d(-1, 1, -1).asDiagonal()),
                           Matrix3(Eigen::Vector3d(-1, -1, 1).asDiagonal())}) {
    const Rot3 R(M);
    const Vector3 w = Rot3::Log(R);
    EXPECT_NEAR(w.norm(), kPi, 1e-15);
    EXPECT_TRUE(Rot3::Exp(w).Equals(R, 1e-15));
  }
  for (int i = 0; i < 20; ++i) {
    const Vector3 n = RandomUnit();
    const Rot3 R(AngleAxisMatrix(n * kPi));
    const Vector3 w = Rot3::Log(R);
    EXPECT_NEAR(w.norm(), kPi, 1e-12);
    EXPECT_NEAR(std::abs(w.normalized().dot(n)), 1.0, 1e-12);
    EXPECT_TRUE(Rot3::Exp(w).Equals(R, 1e-14));
  }
}

TEST_F(Rot3Test, ExpLogJacobians) {
  for (const Vector3& w : TestRotVecs()) {
    SCOPED_TRACE(w.transpose());
    Matrix3 H;
    const Rot3 R = Rot3::Exp(w, &H);
    EXPECT_LT(MaxRelDiff(H, NumericalJacobianVector(
                                [](const Eigen::VectorXd& v) { return Rot3::Exp(v); }, w)),
              kRot3Tol);
    EXPECT_LT(MaxRelDiff(H, Rot3::RightJacobian(w)), 1e-15);
    // Log: keep the finite-difference step inside the branch when the angle is near pi.
    const double margin = kPi - w.norm();
    const double h = std::min(1e-6, margin / 10.0);
    Matrix3 Hl;
    Rot3::Log(R, &Hl);
    EXPECT_LT(
        MaxRelDiff(Hl, NumericalJacobianRight([](const Rot3& x) { return Rot3::Log(x); }, R, h)),
        h < 1e-6 ? 1e-5 : kRot3Tol);
    EXPECT_LT(MaxRelDiff(Hl * H, Matrix3::Identity()), 1e-10);
    EXPECT_LT(MaxRelDiff(Rot3::RightJacobianInverse(w), Hl), 1e-10);
  }
}

TEST_F(Rot3Test, GroupOperationsAndJacobians) {
  for (int i = 0; i < 100; ++i) {
    const Rot3 a = RandomRot(), b = RandomRot();
    Matrix3 H1, H2;
    const Rot3 c = a.Compose(b, &H1, &H2);
    EXPECT_LT(MaxRelDiff(c.matrix(), a.matrix() * b.matrix()), 1e-14);
    EXPECT_LT(MaxRelDiff((a * b).matrix(), c.matrix()), 1e-15);
    EXPECT_LT(
        MaxRelDiff(H1, NumericalJacobianRight([&](const Rot3& x) { return x.Compose(b); }, a)),
        kRot3Tol);
    EXPECT_LT(
        MaxRelDiff(H2, NumericalJacobianRight([&](const Rot3& x) { return a.Compose(x); }, b)),
        kRot3Tol);
    const Rot3 d = a.Between(b, &H1, &H2);
    EXPECT_LT(MaxRelDiff(d.matrix(), a.matrix().transpose() * b.matrix()), 1e-14);
    EXPECT_LT(
        MaxRelDiff(H1, NumericalJacobianRight([&](const Rot3& x) { return x.Between(b); }, a)),
        kRot3Tol);
    EXPECT_LT(
        MaxRelDiff(H2, NumericalJacobianRight([&](const Rot3& x) { return a.Between(x); }, b)),
        kRot3Tol);
    Matrix3 H;
    const Rot3 ai = a.Inverse(&H);
    EXPECT_TRUE((ai * a).Equals(Rot3(), 1e-14));
    EXPECT_LT(MaxRelDiff(H, NumericalJacobianRight([](const Rot3& x) { return x.Inverse(); }, a)),
              kRot3Tol);
  }
}

TEST_F(Rot3Test, RotateUnrotateJacobians) {
  for (int i = 0; i < 100; ++i) {
    const Rot3 R = RandomRot();
    const Point3 p = RandomPoint();
    Matrix3 Hr, Hp;
    EXPECT_LT(MaxRelDiff(R.Rotate(p, &Hr, &Hp), R.matrix() * p), 1e-14);
    EXPECT_LT(MaxRelDiff(Hr, NumericalJacobianRight([&](const Rot3& x) { return x.Rotate(p); }, R)),
              kRot3Tol);
    EXPECT_LT(
        MaxRelDiff(
            Hp, NumericalJacobian(
                    [&](const Eigen::VectorXd& q) -> Eigen::VectorXd { return R.Rotate(q); }, p)),
        kRot3Tol);
    EXPECT_LT(MaxRelDiff(R.Unrotate(p, &Hr, &Hp), R.matrix().transpose() * p), 1e-14);
    EXPECT_LT(
        MaxRelDiff(Hr, NumericalJacobianRight([&](const Rot3& x) { return x.Unrotate(p); }, R)),
        kRot3Tol);
    EXPECT_LT(
        MaxRelDiff(
            Hp, NumericalJacobian(
                    [&](const Eigen::VectorXd& q) -> Eigen::VectorXd { return R.Unrotate(q); }, p)),
        kRot3Tol);
  }
}

TEST_F(Rot3Test, QuaternionRoundTrip) {
  for (int i = 0; i < 200; ++i) {
    Eigen::Quaterniond q(n_(rng_), n_(rng_), n_(rng_), n_(rng_));
    if (i == 0) q = Eigen::Quaterniond(0.0, 1.0, 0.0, 0.0);  // angle pi
    if (i == 1) q = Eigen::Quaterniond(1.0, 0.0, 0.0, 0.0);  // identity
    const Rot3 R = Rot3::FromQuaternion(q.w() * 3.0, q.x() * 3.0, q.y() * 3.0, q.z() * 3.0);
    const Eigen::Quaterniond qn = q.normalized();
    EXPECT_LT(MaxRelDiff(R.matrix(), qn.toRotationMatrix()), 1e-14);
    const Eigen::Quaterniond back = R.ToQuaternion();
    EXPECT_GE(back.w(), 0.0);
    EXPECT_NEAR(back.norm(), 1.0, 1e-15);
    EXPECT_NEAR(std::abs(back.dot(qn)), 1.0, 1e-14);
  }
}

TEST_F(Rot3Test, RollPitchYawRoundTripAndConvention) {
  std::uniform_real_distribution<double> ua(-kPi, kPi);
  std::uniform_real_distribution<double> up(-1.5, 1.5);
  for (int i = 0; i < 200; ++i) {
    const double r = ua(rng_), p = up(rng_), y = ua(rng_);
    const Rot3 R = Rot3::FromRollPitchYaw(r, p, y);
    const Matrix3 expected =
        (Eigen::AngleAxisd(y, Vector3::UnitZ()) * Eigen::AngleAxisd(p, Vector3::UnitY()) *
         Eigen::AngleAxisd(r, Vector3::UnitX()))
            .toRotationMatrix();
    EXPECT_LT(MaxRelDiff(R.matrix(), expected), 1e-14);
    EXPECT_LT(MaxRelDiff(R.RollPitchYaw(), Vector3(r, p, y)), 1e-12);
  }
}

TEST_F(Rot3Test, RetractLocalCoordinatesAreInverse) {
  for (int i = 0; i < 100; ++i) {
    const Rot3 a = RandomRot(), b = RandomRot();
    EXPECT_TRUE(a.Retract(a.LocalCoordinates(b)).Equals(b, 1e-13));
    const Vector3 w = RandomRotVec(kPi - 1e-3);
    EXPECT_LT(MaxRelDiff(a.LocalCoordinates(a.Retract(w)), w), 1e-11);
    EXPECT_TRUE(a.Retract(w).Equals(a * Rot3::Exp(w), 1e-15));
  }
}

TEST_F(Rot3Test, NormalizedRestoresOrthonormality) {
  Rot3 R = RandomRot();
  const Rot3 step = Rot3::Exp(Vector3(0.01, -0.02, 0.03));
  for (int i = 0; i < 1000; ++i) R = R * step;
  Matrix3 drifted = R.matrix();
  drifted(0, 1) += 1e-6;
  drifted(2, 2) -= 2e-6;
  const Rot3 fixed = Rot3(drifted).Normalized();
  EXPECT_LT(MaxRelDiff(fixed.matrix() * fixed.matrix().transpose(), Matrix3::Identity()), 1e-15);
  EXPECT_NEAR(fixed.matrix().determinant(), 1.0, 1e-15);
  EXPECT_LT(MaxRelDiff(fixed.matrix(), R.matrix()), 3e-6);
}

TEST_F(Rot3Test, AdjointIsTheRotation) {
  // For SO(3), Ad(R) = R: R Exp(w) R^T = Exp(R w).
  for (int i = 0; i < 50; ++i) {
    const Rot3 R = RandomRot();
    const Vector3 w = RandomRotVec();
    EXPECT_TRUE(Rot3::Exp(R.matrix() * w).Equals(R * Rot3::Exp(w) * R.Inverse(), 1e-13));
  }
}

}  // namespace
}  // namespace slamd::core
