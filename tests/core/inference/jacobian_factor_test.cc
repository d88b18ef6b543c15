#include "core/inference/jacobian_factor.h"

#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "core/factors/between_factor.h"

namespace slamd::core {
namespace {

TEST(JacobianFactorTest, CreateLaysOutBlocksContiguously) {
  Eigen::MatrixXd A0(2, 3), A1(2, 1);
  A0 << 1, 2, 3, 4, 5, 6;
  A1 << 7, 8;
  const Eigen::VectorXd b = Eigen::Vector2d(9, 10);
  auto f = JacobianFactor::Create(std::vector<int>{4, 1}, std::vector<Eigen::MatrixXd>{A0, A1}, b);
  ASSERT_TRUE(f.ok()) << f.status().ToString();
  EXPECT_EQ(f->rows(), 2);
  EXPECT_EQ(f->num_vars(), 2);
  EXPECT_EQ(f->var(0), 4);
  EXPECT_EQ(f->dim(0), 3);
  EXPECT_EQ(f->offset(1), 3);
  EXPECT_EQ(f->Dim(), 4);
  EXPECT_EQ(f->A(0), A0);
  EXPECT_EQ(f->A(1), A1);
  EXPECT_EQ(f->b(), b);
  Eigen::MatrixXd Ab(2, 5);
  Ab << A0, A1, b;
  EXPECT_EQ(f->Ab(), Ab);
  // Error: |A0 δ4 + A1 δ1 + b|² with stacked δ (var 1 at 0, var 4 at 1..3).
  const std::vector<int> offsets = {0, 0, 1, 1, 1, 4};
  Eigen::VectorXd delta(4);
  delta << 0.5, 1, -1, 2;
  const Eigen::Vector2d r = A0 * delta.segment(1, 3) + A1 * delta.segment(0, 1) + b;
  EXPECT_DOUBLE_EQ(f->Error(offsets, delta), r.squaredNorm());
}

TEST(JacobianFactorTest, RejectsMalformedInput) {
  const Eigen::MatrixXd A = Eigen::MatrixXd::Identity(2, 2);
  const Eigen::VectorXd b = Eigen::Vector2d(1, 2);
  EXPECT_FALSE(
      JacobianFactor::Create(std::vector<int>{1, 1}, std::vector<Eigen::MatrixXd>{A, A}, b).ok());
  EXPECT_FALSE(
      JacobianFactor::Create(std::vector<int>{-1}, std::vector<Eigen::MatrixXd>{A}, b).ok());
  EXPECT_FALSE(JacobianFactor::Create(std::vector<int>{0}, std::vector<Eigen::MatrixXd>{A},
                                      Eigen::VectorXd(3))
                   .ok());
  EXPECT_FALSE(JacobianFactor::Create(std::vector<int>{}, std::vector<Eigen::MatrixXd>{}, b).ok());
  // Any number of variables (a container factor over a Markov blanket).
  auto five = JacobianFactor::Create(std::vector<int>{0, 1, 2, 3, 4},
                                     std::vector<Eigen::MatrixXd>(5, A), b);
  ASSERT_TRUE(five.ok());
  EXPECT_EQ(five->num_vars(), 5);
  EXPECT_EQ(five->Dim(), 10);
  Eigen::MatrixXd bad = A;
  bad(0, 1) = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(
      JacobianFactor::Create(std::vector<int>{0}, std::vector<Eigen::MatrixXd>{bad}, b).ok());
  JacobianFactor f;
  EXPECT_FALSE(f.Reset(0, std::vector<int>{0}, std::vector<int>{2}).ok());
  EXPECT_FALSE(f.Reset(2, std::vector<int>{0}, std::vector<int>{0}).ok());
  EXPECT_FALSE(f.Reset(2, std::vector<int>{0, 1}, std::vector<int>{2}).ok());
}

TEST(JacobianFactorTest, AssignFromLinearizedFactorReusesStorage) {
  const BetweenFactor<Pose2> between(MakeKey('x', 0), MakeKey('x', 1), Pose2(1, 0.5, 0.1),
                                     *NoiseModel::Diagonal(Eigen::Vector3d(0.1, 0.2, 0.05)));
  Values values;
  ASSERT_TRUE(values.Insert(MakeKey('x', 0), Pose2(0.1, 0.2, 0.3)).ok());
  ASSERT_TRUE(values.Insert(MakeKey('x', 1), Pose2(1.2, 0.9, 0.2)).ok());
  LinearizedFactor lf;
  between.Linearize(values, &lf);
  JacobianFactor f;
  ASSERT_TRUE(f.Assign(lf, std::vector<int>{7, 3}).ok());
  EXPECT_EQ(f.rows(), 3);
  EXPECT_EQ(f.var(0), 7);
  EXPECT_EQ(f.var(1), 3);
  EXPECT_EQ(f.A(0), lf.Block(0));
  EXPECT_EQ(f.A(1), lf.Block(1));
  EXPECT_EQ(f.b(), lf.Rhs());
  const double* storage = f.data();
  ASSERT_TRUE(f.Assign(lf, std::vector<int>{7, 3}).ok());
  EXPECT_EQ(f.data(), storage);  // same shape: no reallocation
  EXPECT_FALSE(f.Assign(lf, std::vector<int>{7}).ok());
  EXPECT_FALSE(f.Assign(lf, std::vector<int>{3, 3}).ok());
}

}  // namespace
}  // namespace slamd::core
