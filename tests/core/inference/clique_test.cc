#include "core/inference/clique.h"

#include <gtest/gtest.h>

namespace slamd::core {
namespace {

TEST(CliqueTest, ResetShapesTheViews) {
  Clique c;
  c.Reset(std::vector<int>{4, 2}, std::vector<int>{3, 1}, std::vector<int>{7, 0},
          std::vector<int>{6, 2});
  EXPECT_EQ(c.num_frontals(), 2);
  EXPECT_EQ(c.frontal(1), 2);
  EXPECT_EQ(c.frontal_offset(1), 3);
  EXPECT_EQ(c.frontal_dim(1), 1);
  EXPECT_EQ(c.FrontalDim(), 4);
  EXPECT_EQ(c.num_separator(), 2);
  EXPECT_EQ(c.separator()[0], 7);
  EXPECT_EQ(c.separator_offset(1), 6);
  EXPECT_EQ(c.separator_dim(1), 2);
  EXPECT_EQ(c.SeparatorDim(), 8);
  EXPECT_EQ(c.conditional().rows(), 4);
  EXPECT_EQ(c.conditional().cols(), 13);
  EXPECT_EQ(c.cached_factor().info().rows(), 9);
  EXPECT_EQ(c.parent(), Clique::kNone);
  EXPECT_TRUE(c.children().empty());

  // R, S, d are the column ranges of [R S d].
  auto cond = c.mutable_conditional();
  for (int j = 0; j < cond.cols(); ++j) cond.col(j).setConstant(j);
  EXPECT_EQ(c.R()(0, 3), 3.0);
  EXPECT_EQ(c.S()(2, 0), 4.0);
  EXPECT_EQ(c.S()(1, 7), 11.0);
  EXPECT_EQ(c.d()(3), 12.0);
  EXPECT_EQ(c.R().cols(), 4);
  EXPECT_EQ(c.S().cols(), 8);

  // Re-shaping zeroes everything.
  c.Reset(std::vector<int>{1}, std::vector<int>{2}, {}, {});
  EXPECT_EQ(c.SeparatorDim(), 0);
  EXPECT_EQ(c.conditional().cols(), 3);
  EXPECT_EQ(c.conditional().cwiseAbs().maxCoeff(), 0.0);
}

}  // namespace
}  // namespace slamd::core
