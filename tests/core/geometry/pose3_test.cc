#include "core/geometry/pose3.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <new>
#include <random>
#include <vector>

#include "tests/testing/numerical_derivative.h"

// Counts heap allocations so the test can check that geometry calls never allocate.
namespace {
std::atomic<long> g_allocations{0};
}  // namespace

void* operator new(std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace slamd::core {
namespace {

using testing::MaxRelDiff;
using testing::NumericalJacobian;
using testing::NumericalJacobianRight;
using testing::NumericalJacobianVector;

constexpr double kPose3Tol = 1e-7;

Eigen::Matrix4d Hat(const Vector6& xi) {
  Eigen::Matrix4d X = Eigen::Matrix4d::Zero();
  X.topLeftCorner<3, 3>() = Skew(xi.tail<3>());
  X.topRightCorner<3, 1>() = xi.head<3>();
  return X;
}

// Independent reference for the SE(3) exponential: a truncated power series of the 4x4 hat
// matrix, scaled and squared (accurate to ~1e-15 for the magnitudes used here).
Eigen::Matrix4d ExpBySeries(const Vector6& xi) {
  const Eigen::Matrix4d A = Hat(xi) / 1024.0;
  Eigen::Matrix4d term = Eigen::Matrix4d::Identity(), sum = Eigen::Matrix4d::Identity();
  for (int k = 1; k < 20; ++k) {
    term = term * A / k;
    sum += term;
  }
  for (int i = 0; i < 10; ++i) sum = sum * sum;
  return sum;
}

class Pose3Test : public ::testing::Test {
 protected:
  Vector3 RandomUnit() { return Vector3(n_(rng_), n_(rng_), n_(rng_)).normalized(); }
  Vector3 RandomVec(double scale) { return scale * Vector3(n_(rng_), n_(rng_), n_(rng_)); }
  Pose3 RandomPose() { return Pose3(Rot3::Exp(RandomUnit() * (kPi * u01_(rng_))), RandomVec(5.0)); }
  // Tangent vectors with random translation and rotations at delicate angles.
  std::vector<Vector6> TestTangents() {
    std::vector<Vector6> out;
    auto add = [&](const Vector3& w) {
      Vector6 xi;
      xi << RandomVec(3.0), w;
      out.push_back(xi);
    };
    for (int i = 0; i < 100; ++i) add(RandomUnit() * (kPi * u01_(rng_)));
    for (double t :
         {0.0, 1e-12, 1e-9, 1e-5, 1e-3, 9.999e-3, 1.0001e-2, 0.5, 2.0, kPi - 1e-3, kPi - 1e-6}) {
      for (int k = 0; k < 5; ++k) add(RandomUnit() * t);
    }
    for (int a = 0; a < 3; ++a) add(Vector3::Unit(a) * (kPi - 1e-6));
    return out;
  }

  std::mt19937 rng_{777};
  std::normal_distribution<double> n_{0.0, 1.0};
  std::uniform_real_distribution<double> u01_{0.0, 1.0};
};

TEST_F(Pose3Test, GroupOperationsMatchMatrices) {
  for (int i = 0; i < 100; ++i) {
    const Pose3 a = RandomPose(), b = RandomPose();
    const Point3 p = RandomVec(5.0);
    EXPECT_LT(MaxRelDiff(a.Compose(b).matrix(), a.matrix() * b.matrix()), 1e-13);
    EXPECT_LT(MaxRelDiff((a * b).matrix(), a.matrix() * b.matrix()), 1e-13);
    EXPECT_LT(MaxRelDiff(a.Between(b).matrix(), a.matrix().inverse() * b.matrix()), 1e-13);
    EXPECT_LT(MaxRelDiff(a.Inverse().matrix(), a.matrix().inverse()), 1e-13);
    const Eigen::Vector4d ph = p.homogeneous();
    EXPECT_LT(MaxRelDiff(a.TransformFrom(p), (a.matrix() * ph).head<3>()), 1e-13);
    EXPECT_LT(MaxRelDiff(a.TransformTo(p), (a.matrix().inverse() * ph).head<3>()), 1e-13);
  }
}

TEST_F(Pose3Test, ComposeBetweenInverseJacobians) {
  for (int i = 0; i < 100; ++i) {
    const Pose3 a = RandomPose(), b = RandomPose();
    Matrix6 H1, H2;
    a.Compose(b, &H1, &H2);
    EXPECT_LT(
        MaxRelDiff(H1, NumericalJacobianRight([&](const Pose3& x) { return x.Compose(b); }, a)),
        kPose3Tol);
    EXPECT_LT(
        MaxRelDiff(H2, NumericalJacobianRight([&](const Pose3& x) { return a.Compose(x); }, b)),
        kPose3Tol);
    a.Between(b, &H1, &H2);
    EXPECT_LT(
        MaxRelDiff(H1, NumericalJacobianRight([&](const Pose3& x) { return x.Between(b); }, a)),
        kPose3Tol);
    EXPECT_LT(
        MaxRelDiff(H2, NumericalJacobianRight([&](const Pose3& x) { return a.Between(x); }, b)),
        kPose3Tol);
    Matrix6 H;
    a.Inverse(&H);
    EXPECT_LT(MaxRelDiff(H, NumericalJacobianRight([](const Pose3& x) { return x.Inverse(); }, a)),
              kPose3Tol);
  }
}

TEST_F(Pose3Test, TransformJacobians) {
  for (int i = 0; i < 100; ++i) {
    const Pose3 a = RandomPose();
    const Point3 p = RandomVec(5.0);
    Matrix36 Hx;
    Matrix3 Hp;
    a.TransformFrom(p, &Hx, &Hp);
    EXPECT_LT(MaxRelDiff(Hx, NumericalJacobianRight(
                                 [&](const Pose3& x) { return x.TransformFrom(p); }, a)),
              kPose3Tol);
    EXPECT_LT(MaxRelDiff(Hp, NumericalJacobian(
                                 [&](const Eigen::VectorXd& q) -> Eigen::VectorXd {
                                   return a.TransformFrom(q);
                                 },
                                 p)),
              kPose3Tol);
    a.TransformTo(p, &Hx, &Hp);
    EXPECT_LT(
        MaxRelDiff(Hx, NumericalJacobianRight([&](const Pose3& x) { return x.TransformTo(p); }, a)),
        kPose3Tol);
    EXPECT_LT(MaxRelDiff(Hp, NumericalJacobian([&](const Eigen::VectorXd& q)
                                                   -> Eigen::VectorXd { return a.TransformTo(q); },
                                               p)),
              kPose3Tol);
  }
}

TEST_F(Pose3Test, ExpMatchesMatrixExponential) {
  for (const Vector6& xi : TestTangents()) {
    EXPECT_LT(MaxRelDiff(Pose3::Exp(xi).matrix(), ExpBySeries(xi)), 1e-12) << xi.transpose();
  }
  // Pure translation.
  Vector6 xi;
  xi << 1.0, 2.0, 3.0, 0.0, 0.0, 0.0;
  EXPECT_TRUE(Pose3::Exp(xi).Equals(Pose3(Rot3(), Point3(1.0, 2.0, 3.0)), 1e-15));
}

TEST_F(Pose3Test, ExpLogJacobiansAndRoundTrips) {
  for (const Vector6& xi : TestTangents()) {
    SCOPED_TRACE(xi.transpose());
    Matrix6 H;
    const Pose3 X = Pose3::Exp(xi, &H);
    EXPECT_LT(MaxRelDiff(H, NumericalJacobianVector(
                                [](const Eigen::VectorXd& v) { return Pose3::Exp(v); }, xi)),
              kPose3Tol);
    const double margin = kPi - xi.tail<3>().norm();
    const double h = std::min(1e-6, margin / 10.0);
    Matrix6 Hl;
    const Vector6 back = Pose3::Log(X, &Hl);
    EXPECT_LT(
        MaxRelDiff(Hl, NumericalJacobianRight([](const Pose3& x) { return Pose3::Log(x); }, X, h)),
        h < 1e-6 ? 1e-5 : kPose3Tol);
    EXPECT_LT(MaxRelDiff(back, xi), 1e-10);
    EXPECT_LT(MaxRelDiff(Hl * H, Matrix6::Identity()), 1e-9);
    EXPECT_TRUE(Pose3::Exp(back).Equals(X, 1e-13));
  }
}

TEST_F(Pose3Test, LogAtExactlyPi) {
  const Pose3 X(Rot3(Matrix3(Eigen::Vector3d(-1, 1, -1).asDiagonal())), Point3(1.0, -2.0, 0.5));
  const Vector6 xi = Pose3::Log(X);
  EXPECT_NEAR(xi.tail<3>().norm(), kPi, 1e-15);
  EXPECT_TRUE(Pose3::Exp(xi).Equals(X, 1e-14));
}

TEST_F(Pose3Test, RetractLocalCoordinatesAreInverse) {
  for (int i = 0; i < 100; ++i) {
    const Pose3 a = RandomPose(), b = RandomPose();
    EXPECT_TRUE(a.Retract(a.LocalCoordinates(b)).Equals(b, 1e-12));
    Vector6 d;
    d << RandomVec(2.0), RandomUnit() * ((kPi - 1e-3) * u01_(rng_));
    EXPECT_LT(MaxRelDiff(a.LocalCoordinates(a.Retract(d)), d), 1e-10);
  }
}

TEST_F(Pose3Test, AdjointMapProperty) {
  for (int i = 0; i < 100; ++i) {
    const Pose3 X = RandomPose();
    Vector6 xi;
    xi << RandomVec(2.0), RandomVec(0.5);
    const Pose3 lhs = Pose3::Exp(X.AdjointMap() * xi);
    const Pose3 rhs = X * Pose3::Exp(xi) * X.Inverse();
    EXPECT_TRUE(lhs.Equals(rhs, 1e-12));
    // Ad(X) Ad(X^-1) = I.
    EXPECT_LT(MaxRelDiff(X.AdjointMap() * X.Inverse().AdjointMap(), Matrix6::Identity()), 1e-13);
  }
}

TEST_F(Pose3Test, TangentOrderIsTranslationFirst) {
  Vector6 xi;
  xi << 1.0, 0.0, 0.0, 0.0, 0.0, 0.0;
  EXPECT_TRUE(Pose3::Exp(xi).rotation().Equals(Rot3()));
  EXPECT_NEAR(Pose3::Exp(xi).translation().x(), 1.0, 1e-15);
}

TEST_F(Pose3Test, HotPathsDoNotAllocate) {
  const Pose3 a = RandomPose(), b = RandomPose();
  const Point3 p = RandomVec(1.0);
  Matrix6 H1, H2, H3;
  Matrix36 Hx;
  Matrix3 Hp, R1, R2;
  const long before = g_allocations.load();
  double sink = 0.0;
  for (int i = 0; i < 100; ++i) {
    const Pose3 d = a.Between(b, &H1, &H2);
    const Vector6 xi = Pose3::Log(d, &H3);
    const Pose3 e = Pose3::Exp(xi, &H3).Compose(a, &H1, &H2).Inverse(&H3);
    sink += e.TransformFrom(p, &Hx, &Hp).sum() + e.TransformTo(p, &Hx, &Hp).sum();
    const Rot3 r = a.rotation().Between(b.rotation(), &R1, &R2);
    sink += Rot3::Log(r, &R1).sum() + Rot3::Exp(xi.tail<3>(), &R2).matrix().sum();
  }
  EXPECT_EQ(g_allocations.load() - before, 0);
  EXPECT_TRUE(std::isfinite(sink));
}

}  // namespace
}  // namespace slamd::core
