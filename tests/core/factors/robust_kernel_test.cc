#include "core/factors/robust_kernel.h"

#include <gtest/gtest.h>

#include <cmath>

namespace slamd::core {
namespace {

using Kind = RobustKernel::Kind;

class RobustKernelTest : public ::testing::TestWithParam<Kind> {};

TEST_P(RobustKernelTest, WeightIsTheDerivativeOfTheCost) {
  const RobustKernel k = *RobustKernel::Create(GetParam(), 1.5);
  for (double s : {0.01, 0.5, 1.0, 2.0, 2.3, 5.0, 40.0, 1e3}) {
    const double h = 1e-6 * std::max(1.0, s);
    const double numerical = (k.Cost(s + h) - k.Cost(s - h)) / (2 * h);
    EXPECT_NEAR(k.Weight(s), numerical, 1e-6) << RobustKernel::KindName(GetParam()) << " s=" << s;
  }
}

TEST_P(RobustKernelTest, QuadraticNearZeroAndBoundedInfluence) {
  const RobustKernel k = *RobustKernel::Create(GetParam(), 1.5);
  EXPECT_NEAR(k.Cost(1e-8), 1e-8, 1e-12);
  EXPECT_NEAR(k.Weight(1e-8), 1.0, 1e-6);
  // Influence √s·w(s) (the pull of one residual) grows slower than for least squares.
  EXPECT_LT(k.Weight(1e4), 0.1);
  // Continuous where the piecewise kernels switch.
  for (double s : {2.25 - 1e-9, 1.5 - 1e-9}) {
    EXPECT_NEAR(k.Cost(s), k.Cost(s + 2e-9), 1e-7);
  }
}

INSTANTIATE_TEST_SUITE_P(AllKernels, RobustKernelTest,
                         ::testing::Values(Kind::kHuber, Kind::kCauchy, Kind::kGemanMcClure,
                                           Kind::kDcs));

TEST(RobustKernelTest, KnownValues) {
  const RobustKernel huber = *RobustKernel::Create(Kind::kHuber, 2.0);
  EXPECT_DOUBLE_EQ(huber.Cost(1.0), 1.0);
  EXPECT_DOUBLE_EQ(huber.Cost(9.0), 2 * 2.0 * 3.0 - 4.0);
  const RobustKernel dcs = *RobustKernel::Create(Kind::kDcs, 1.0);
  // DCS weight is the square of its scale min(1, 2Φ/(Φ + s)).
  EXPECT_DOUBLE_EQ(dcs.Weight(3.0), 0.25);
  EXPECT_TRUE(RobustKernel().is_none());
  EXPECT_DOUBLE_EQ(RobustKernel().Cost(7.0), 7.0);
}

TEST(RobustKernelTest, ParsesNamesAndRejectsBadParameters) {
  EXPECT_EQ(*RobustKernel::ParseKind("Geman-McClure"), Kind::kGemanMcClure);
  EXPECT_EQ(*RobustKernel::ParseKind("huber"), Kind::kHuber);
  const Result<Kind> bad = RobustKernel::ParseKind("tukey");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("tukey"), std::string::npos);
  EXPECT_FALSE(RobustKernel::Create(Kind::kHuber, 0.0).ok());
  EXPECT_FALSE(RobustKernel::Create(Kind::kCauchy, std::nan("")).ok());
}

}  // namespace
}  // namespace slamd::core
