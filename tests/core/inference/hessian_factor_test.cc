#include "core/inference/hessian_factor.h"

#include <gtest/gtest.h>

#include <random>

#include "core/inference/jacobian_factor.h"
#include "tests/core/inference/random_linear_system.h"

namespace slamd::core {
namespace {

TEST(HessianFactorTest, FromJacobianHasTheSameError) {
  std::mt19937 rng(4);
  const Eigen::MatrixXd A0 = testing::RandomMatrix(4, 3, &rng);
  const Eigen::MatrixXd A1 = testing::RandomMatrix(4, 2, &rng);
  const Eigen::VectorXd b = testing::RandomMatrix(4, 1, &rng);
  const JacobianFactor j =
      JacobianFactor::Create(std::vector<int>{2, 0}, std::vector<Eigen::MatrixXd>{A0, A1}, b)
          .value();
  const HessianFactor h = HessianFactor::FromJacobian(j);
  ASSERT_EQ(h.num_vars(), 2);
  EXPECT_EQ(h.var(0), 2);
  EXPECT_EQ(h.var(1), 0);
  EXPECT_EQ(h.dim(0), 3);
  EXPECT_EQ(h.offset(1), 3);
  EXPECT_EQ(h.Dim(), 5);
  const Eigen::MatrixXd info = h.Info();
  EXPECT_EQ(info.rows(), 6);
  // Blocks: [[A0ᵀA0, A0ᵀA1, A0ᵀb], ...], symmetric.
  EXPECT_LT((info.block(0, 3, 3, 2) - A0.transpose() * A1).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((info.block(0, 5, 3, 1) - A0.transpose() * b).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(info(5, 5), b.squaredNorm(), 1e-12);
  EXPECT_EQ(info, info.transpose());
  // Packed by columns of the lower triangle: column 3 starts at info(3, 3), after 6 + 5 + 4.
  EXPECT_EQ(h.packed_info().size(), 21u);
  EXPECT_EQ(h.column(3), h.packed_info().data() + 15);
  EXPECT_EQ(h.column(3)[1], info(4, 3));
  // The pivot reference of a Jacobian-built factor is its diagonal.
  EXPECT_EQ(h.reference(), info.diagonal().head(5));
  const std::vector<int> offsets = {0, 2, 2, 5};
  const Eigen::VectorXd delta = testing::RandomMatrix(5, 1, &rng);
  EXPECT_NEAR(h.Error(offsets, delta), j.Error(offsets, delta), 1e-10);
}

TEST(HessianFactorTest, CreateValidates) {
  const Eigen::MatrixXd info = Eigen::MatrixXd::Identity(4, 4);
  EXPECT_TRUE(HessianFactor::Create(std::vector<int>{1}, std::vector<int>{3}, info).ok());
  EXPECT_FALSE(HessianFactor::Create(std::vector<int>{1}, std::vector<int>{2}, info).ok());
  EXPECT_FALSE(HessianFactor::Create(std::vector<int>{1, 1}, std::vector<int>{2, 1}, info).ok());
  EXPECT_FALSE(HessianFactor::Create(std::vector<int>{1}, std::vector<int>{0}, info).ok());
  Eigen::MatrixXd asym = info;
  asym(0, 1) = 0.5;
  EXPECT_FALSE(HessianFactor::Create(std::vector<int>{1}, std::vector<int>{3}, asym).ok());
  // A constant (no variables).
  auto constant = HessianFactor::Create({}, {}, Eigen::MatrixXd::Constant(1, 1, 2.5));
  ASSERT_TRUE(constant.ok());
  EXPECT_EQ(constant->Dim(), 0);
  EXPECT_EQ(constant->Info()(0, 0), 2.5);
  // What Create was given, both triangles, comes back.
  std::mt19937 rng(9);
  Eigen::MatrixXd full = testing::RandomMatrix(4, 4, &rng);
  full = (full * full.transpose()).eval();
  const auto created = HessianFactor::Create(std::vector<int>{7, 3}, std::vector<int>{1, 2}, full);
  ASSERT_TRUE(created.ok());
  EXPECT_EQ(created->Info(), full);
  // Default-constructed: the zero constant.
  const HessianFactor empty;
  EXPECT_EQ(empty.num_vars(), 0);
  EXPECT_EQ(empty.Info().rows(), 1);
  EXPECT_EQ(empty.Info()(0, 0), 0.0);
}

TEST(HessianFactorTest, ResetReusesStorage) {
  HessianFactor h;
  h.Reset(std::vector<int>{0, 1}, std::vector<int>{3, 3});
  EXPECT_EQ(h.Info().rows(), 7);
  EXPECT_EQ(h.Info().cwiseAbs().maxCoeff(), 0.0);
  const double* storage = h.data();
  std::ranges::fill(h.mutable_packed_info(), 1.0);
  h.mutable_reference().setOnes();
  h.Reset(std::vector<int>{5}, std::vector<int>{2});
  EXPECT_EQ(h.data(), storage);  // smaller: capacity kept
  EXPECT_EQ(h.Info().rows(), 3);
  EXPECT_EQ(h.Info().cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(h.reference().size(), 2);
  EXPECT_EQ(h.reference().cwiseAbs().maxCoeff(), 0.0);
}

TEST(HessianFactorTest, ReshapeSetsTheShapeLikeResetAndReusesStorage) {
  HessianFactor h;
  h.Reshape(std::vector<int>{4, 2, 9}, std::vector<int>{3, 6, 1});
  EXPECT_EQ(h.num_vars(), 3);
  EXPECT_EQ(h.var(1), 2);
  EXPECT_EQ(h.offset(2), 9);
  EXPECT_EQ(h.Dim(), 10);
  EXPECT_EQ(h.Info().rows(), 11);
  EXPECT_EQ(h.reference().size(), 10);
  const double* storage = h.data();
  h.Reshape(std::vector<int>{1}, std::vector<int>{9});
  EXPECT_EQ(h.data(), storage);  // smaller, within 1.25x: capacity kept (core/base/storage.h)
  EXPECT_EQ(h.Dim(), 9);
  EXPECT_EQ(h.Info().rows(), 10);
  // Reset after Reshape still zeroes everything.
  std::ranges::fill(h.mutable_packed_info(), 1.0);
  h.Reset(std::vector<int>{1}, std::vector<int>{9});
  EXPECT_EQ(h.Info().cwiseAbs().maxCoeff(), 0.0);
}

}  // namespace
}  // namespace slamd::core
