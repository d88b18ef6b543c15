#include "core/geometry/rot2.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/geometry/eigen_types.h"
#include "tests/testing/numerical_derivative.h"

namespace slamd::core {
namespace {

using testing::MaxAbsDiff;
using testing::NumericalJacobian;

TEST(WrapAngleTest, MapsIntoHalfOpenInterval) {
  EXPECT_DOUBLE_EQ(WrapAngle(0.3), 0.3);
  EXPECT_DOUBLE_EQ(WrapAngle(kPi), kPi);
  EXPECT_DOUBLE_EQ(WrapAngle(-kPi), kPi);
  EXPECT_DOUBLE_EQ(WrapAngle(3.0 * kPi), kPi);
  EXPECT_NEAR(WrapAngle(2.0 * kPi + 0.1), 0.1, 1e-15);
  EXPECT_NEAR(WrapAngle(-2.0 * kPi - 0.1), -0.1, 1e-15);
  EXPECT_NEAR(WrapAngle(100.0), 100.0 - 32.0 * kPi, 1e-12);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-50.0, 50.0);
  for (int i = 0; i < 1000; ++i) {
    const double a = u(rng);
    const double w = WrapAngle(a);
    EXPECT_GT(w, -kPi);
    EXPECT_LE(w, kPi);
    EXPECT_NEAR(std::sin(w), std::sin(a), 1e-12);
    EXPECT_NEAR(std::cos(w), std::cos(a), 1e-12);
  }
}

TEST(Rot2Test, AngleRoundTripAndRange) {
  EXPECT_DOUBLE_EQ(Rot2().theta(), 0.0);
  EXPECT_NEAR(Rot2::FromAngle(0.7).theta(), 0.7, 1e-15);
  EXPECT_NEAR(Rot2::FromAngle(0.7 + 2.0 * kPi).theta(), 0.7, 1e-14);
  // (-1, -0) is the angle -pi, reported as +pi.
  EXPECT_EQ(Rot2::FromCosSin(-1.0, -0.0).theta(), kPi);
  EXPECT_NEAR(Rot2::FromAngle(-kPi).theta(), kPi, 1e-15);
}

TEST(Rot2Test, FromCosSinNormalises) {
  const Rot2 r = Rot2::FromCosSin(3.0, 4.0);
  EXPECT_DOUBLE_EQ(r.c(), 0.6);
  EXPECT_DOUBLE_EQ(r.s(), 0.8);
  EXPECT_TRUE(Rot2::FromCosSin(0.0, 0.0).Equals(Rot2()));
}

// A rotation's own (cos, sin), unit length only to rounding, reads back bit for bit (what the
// snapshot and journal codecs rely on); normalising would change last bits of some.
TEST(Rot2Test, FromCosSinKeepsAUnitRotationExactly) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-kPi, kPi);
  int off_unit = 0;
  for (int i = 0; i < 1000; ++i) {
    const Rot2 r = Rot2::FromAngle(u(rng)) * Rot2::FromAngle(u(rng));
    off_unit += std::hypot(r.c(), r.s()) != 1.0;
    const Rot2 back = Rot2::FromCosSin(r.c(), r.s());
    EXPECT_EQ(back.c(), r.c());
    EXPECT_EQ(back.s(), r.s());
  }
  EXPECT_GT(off_unit, 0);  // the case the rule is for occurs
}

TEST(Rot2Test, GroupOperationsMatchAngles) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-kPi, kPi);
  for (int i = 0; i < 200; ++i) {
    const double a = u(rng), b = u(rng);
    const Rot2 ra = Rot2::FromAngle(a), rb = Rot2::FromAngle(b);
    EXPECT_NEAR((ra * rb).theta(), WrapAngle(a + b), 1e-12);
    EXPECT_TRUE(ra.Compose(rb).Equals(Rot2::FromAngle(a + b), 1e-12));
    EXPECT_TRUE(ra.Between(rb).Equals(Rot2::FromAngle(b - a), 1e-12));
    EXPECT_TRUE(ra.Inverse().Equals(Rot2::FromAngle(-a), 1e-12));
    EXPECT_LT(MaxAbsDiff(ra.matrix() * rb.matrix(), (ra * rb).matrix()), 1e-14);
  }
}

TEST(Rot2Test, LongCompositionChainsStayUnit) {
  const Rot2 step = Rot2::FromAngle(0.1234567);
  Rot2 r;
  for (int i = 0; i < 1000000; ++i) r = r * step;
  EXPECT_NEAR(r.c() * r.c() + r.s() * r.s(), 1.0, 1e-14);
  EXPECT_NEAR(r.theta(), WrapAngle(1000000 * 0.1234567), 1e-7);
}

TEST(Rot2Test, RotateUnrotateValuesAndJacobians) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-kPi, kPi);
  std::uniform_real_distribution<double> up(-5.0, 5.0);
  for (int i = 0; i < 200; ++i) {
    const Rot2 r = Rot2::FromAngle(u(rng));
    const Point2 p(up(rng), up(rng));
    Vector2 Hr;
    Matrix2 Hp;
    const Point2 q = r.Rotate(p, &Hr, &Hp);
    EXPECT_LT(MaxAbsDiff(q, r.matrix() * p), 1e-14);
    const auto f_rot = [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
      return (r * Rot2::FromAngle(d[0])).Rotate(p);
    };
    const auto f_p = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return r.Rotate(x); };
    EXPECT_LT(MaxAbsDiff(Hr, NumericalJacobian(f_rot, Eigen::VectorXd::Zero(1))), 1e-8);
    EXPECT_LT(MaxAbsDiff(Hp, NumericalJacobian(f_p, p)), 1e-8);

    const Point2 s = r.Unrotate(p, &Hr, &Hp);
    EXPECT_LT(MaxAbsDiff(s, r.matrix().transpose() * p), 1e-14);
    const auto g_rot = [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
      return (r * Rot2::FromAngle(d[0])).Unrotate(p);
    };
    const auto g_p = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return r.Unrotate(x); };
    EXPECT_LT(MaxAbsDiff(Hr, NumericalJacobian(g_rot, Eigen::VectorXd::Zero(1))), 1e-8);
    EXPECT_LT(MaxAbsDiff(Hp, NumericalJacobian(g_p, p)), 1e-8);
  }
}

TEST(Rot2Test, NullJacobiansAreOptional) {
  const Rot2 r = Rot2::FromAngle(0.3);
  const Point2 p(1.0, 2.0);
  Vector2 Hr;
  EXPECT_LT(MaxAbsDiff(r.Rotate(p, &Hr, nullptr), r.Rotate(p)), 0.0 + 1e-300);
  Matrix2 Hp;
  EXPECT_LT(MaxAbsDiff(r.Unrotate(p, nullptr, &Hp), r.Unrotate(p)), 1e-300);
}

}  // namespace
}  // namespace slamd::core
