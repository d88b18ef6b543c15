#include "server/messages/wire_values.h"

#include <gtest/gtest.h>

#include <cmath>

namespace slamd::server {
namespace {

TEST(ToValues, Pose2) {
  const std::vector<double> v = ToValues(core::Pose2(1.5, -2.0, 3.5));
  ASSERT_EQ(v.size(), 3u);
  EXPECT_EQ(v[0], 1.5);
  EXPECT_EQ(v[1], -2.0);
  EXPECT_NEAR(v[2], 3.5 - 2 * M_PI, 1e-15);  // in (-pi, pi]
}

TEST(ToValues, Pose3QuaternionHasNonNegativeW) {
  // A rotation of 3 rad about (0, 0, 1): quaternion (cos 1.5, 0, 0, sin 1.5), cos 1.5 > 0.
  const core::Pose3 p(core::Rot3::Exp(core::Vector3(0, 0, 3.0)), core::Point3(1, 2, 3));
  std::vector<double> v = ToValues(p);
  ASSERT_EQ(v.size(), 7u);
  EXPECT_EQ(v[0], 1.0);
  EXPECT_EQ(v[2], 3.0);
  EXPECT_NEAR(v[3], std::cos(1.5), 1e-15);
  EXPECT_NEAR(v[6], std::sin(1.5), 1e-15);
  // 4 rad: (cos 2, 0, 0, sin 2) has w < 0; the canonical form is its negation.
  v = ToValues(core::Pose3(core::Rot3::Exp(core::Vector3(0, 0, 4.0)), core::Point3::Zero()));
  EXPECT_GE(v[3], 0.0);
  EXPECT_NEAR(v[3], -std::cos(2.0), 1e-15);
  EXPECT_NEAR(v[6], -std::sin(2.0), 1e-15);
  // Round trip through the quaternion.
  const core::Rot3 back = core::Rot3::FromQuaternion(v[3], v[4], v[5], v[6]);
  EXPECT_TRUE(back.Equals(core::Rot3::Exp(core::Vector3(0, 0, 4.0)), 1e-14));
}

TEST(ToValues, Points) {
  EXPECT_EQ(ToValues(core::Point2(1, 2)), (std::vector<double>{1, 2}));
  EXPECT_EQ(ToValues(core::Point3(1, 2, 3)), (std::vector<double>{1, 2, 3}));
}

TEST(ToRowMajor, OrderIsRowByRow) {
  Eigen::MatrixXd m(2, 3);
  m << 1, 2, 3, 4, 5, 6;
  EXPECT_EQ(ToRowMajor(m), (std::vector<double>{1, 2, 3, 4, 5, 6}));
}

}  // namespace
}  // namespace slamd::server
