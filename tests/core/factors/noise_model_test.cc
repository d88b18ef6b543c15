#include "core/factors/noise_model.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <random>
#include <vector>

#include "tests/testing/factor_testing.h"

namespace slamd::core {
namespace {

TEST(NoiseModelTest, CovarianceInformationAndSqrtInformationAgree) {
  std::mt19937 rng(7);
  for (int n = 1; n <= 6; ++n) {
    const Eigen::MatrixXd cov = testing::RandomSpd(rng, n);
    const Result<NoiseModel> a = NoiseModel::FromCovariance(cov);
    ASSERT_TRUE(a.ok()) << a.status().ToString();
    const Result<NoiseModel> b = NoiseModel::FromInformation(cov.inverse());
    ASSERT_TRUE(b.ok());
    const Eigen::MatrixXd R = a->sqrt_information();
    const Result<NoiseModel> c = NoiseModel::FromSqrtInformation(R);
    ASSERT_TRUE(c.ok());
    EXPECT_TRUE(a->Equals(*b, 1e-8));
    EXPECT_TRUE(a->Equals(*c, 1e-8));
    EXPECT_TRUE((R.transpose() * R - cov.inverse()).isZero(1e-8));
    EXPECT_TRUE(R.isUpperTriangular());
    EXPECT_TRUE((a->Covariance() - cov).isZero(1e-8));
    // Mahalanobis distance = eᵀ Σ⁻¹ e.
    const Eigen::VectorXd e = Eigen::VectorXd::LinSpaced(n, -1.0, 2.0);
    EXPECT_NEAR(a->SquaredMahalanobis(e), e.dot(cov.inverse() * e), 1e-9);
  }
}

TEST(NoiseModelTest, NonTriangularSqrtInformationIsRefactored) {
  Eigen::Matrix2d S;
  S << 1, 0, 2, 3;  // lower triangular: Ω = SᵀS
  const Result<NoiseModel> m = NoiseModel::FromSqrtInformation(S);
  ASSERT_TRUE(m.ok());
  EXPECT_TRUE((m->Information() - S.transpose() * S).isZero(1e-12));
}

TEST(NoiseModelTest, DiagonalAndIsotropic) {
  const Result<NoiseModel> d = NoiseModel::Diagonal(Eigen::Vector3d(0.1, 0.2, 0.05));
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->kind(), NoiseModel::Kind::kDiagonal);
  EXPECT_TRUE((d->Sigmas() - Eigen::Vector3d(0.1, 0.2, 0.05)).isZero(1e-12));
  const Result<NoiseModel> i = NoiseModel::Isotropic(2, 0.5);
  ASSERT_TRUE(i.ok());
  EXPECT_TRUE((i->Information() - 4.0 * Eigen::Matrix2d::Identity()).isZero(1e-12));
}

TEST(NoiseModelTest, WhitenFixedSize) {
  std::mt19937 rng(3);
  const Eigen::MatrixXd cov = testing::RandomSpd(rng, 3);
  const NoiseModel m = *NoiseModel::FromCovariance(cov);
  Eigen::Vector3d e(1, -2, 0.5);
  const Eigen::Vector3d expected = Eigen::MatrixXd(m.sqrt_information()) * e;
  m.WhitenInPlace(&e);
  EXPECT_TRUE((e - expected).isZero(1e-12));
  Eigen::Matrix<double, 3, 2> J = Eigen::Matrix<double, 3, 2>::Ones();
  const Eigen::Matrix<double, 3, 2> expected_J = Eigen::MatrixXd(m.sqrt_information()) * J;
  m.WhitenInPlace(&J);
  EXPECT_TRUE((J - expected_J).isZero(1e-12));
}

// R is kept packed, inside the model up to dimension 3 and on the heap beyond: whitening, the
// Mahalanobis distance, copies and moves give the same R at every dimension, against the dense
// Cholesky factor of the information.
TEST(NoiseModelTest, PackedRAtEveryDimension) {
  std::mt19937 rng(8);
  for (int n = 1; n <= 12; ++n) {
    SCOPED_TRACE(n);
    const Eigen::MatrixXd cov = testing::RandomSpd(rng, n);
    const Eigen::MatrixXd R = Eigen::LLT<Eigen::MatrixXd>(cov.inverse()).matrixU();
    const NoiseModel m = *NoiseModel::FromCovariance(cov);
    ASSERT_EQ(m.dim(), n);
    EXPECT_TRUE((m.sqrt_information() - R).isZero(1e-9 * R.norm()));
    const Eigen::VectorXd e = Eigen::VectorXd::LinSpaced(n, -1.0, 2.0);
    Eigen::VectorXd w(n);
    m.Whiten(e.data(), w.data());
    EXPECT_TRUE((w - R * e).isZero(1e-9 * (R * e).norm()));
    EXPECT_NEAR(m.SquaredMahalanobis(e), e.dot(cov.inverse() * e),
                1e-9 * e.squaredNorm() * R.squaredNorm());
    NoiseModel copy = m;
    EXPECT_TRUE(copy.Equals(m, 0.0));
    NoiseModel other = NoiseModel::Unit(n == 4 ? 2 : 4);  // another size, inline or not
    other = copy;
    EXPECT_TRUE(other.Equals(m, 0.0));
    const NoiseModel moved = std::move(copy);
    EXPECT_TRUE(moved.Equals(m, 0.0));
    EXPECT_EQ(moved.kind(), NoiseModel::Kind::kGaussian);
    other = NoiseModel::Unit(n);
    EXPECT_FALSE(other.Equals(m));
    EXPECT_TRUE(other.Equals(NoiseModel::Unit(n), 0.0));
  }
  EXPECT_FALSE(NoiseModel::Unit(2).Equals(NoiseModel::Unit(3)));
  // A 2D pose or point measurement's model allocates nothing beside itself.
  EXPECT_LE(sizeof(NoiseModel), 6 * sizeof(double) + sizeof(double));
}

// WhitenInPlace multiplies by R densely: every constructor must leave R's strictly lower part
// zero (RᵀR = Ω alone would not say so), even from a full square root.
TEST(NoiseModelTest, SqrtInformationIsUpperTriangular) {
  std::mt19937 rng(5);
  const Eigen::MatrixXd cov = testing::RandomSpd(rng, 6);
  const Eigen::MatrixXd full_root =
      Eigen::MatrixXd::Random(4, 4) + 4.0 * Eigen::MatrixXd::Identity(4, 4);
  const std::vector<NoiseModel> models = {*NoiseModel::FromCovariance(cov),
                                          *NoiseModel::FromInformation(cov),
                                          *NoiseModel::FromSqrtInformation(full_root),
                                          *NoiseModel::Diagonal(Eigen::Vector3d(1, 2, 3)),
                                          *NoiseModel::Isotropic(2, 0.5),
                                          NoiseModel::Unit(6)};
  for (const NoiseModel& m : models) {
    const Eigen::MatrixXd R = m.sqrt_information();
    EXPECT_EQ(R.triangularView<Eigen::StrictlyLower>().toDenseMatrix().cwiseAbs().maxCoeff(), 0.0);
    EXPECT_TRUE((R.transpose() * R - m.Information()).isZero(1e-9 * m.Information().norm()));
  }
}

TEST(NoiseModelTest, RejectsBadInputWithReasons) {
  Eigen::Matrix2d indefinite;
  indefinite << 1, 2, 2, 1;
  Result<NoiseModel> r = NoiseModel::FromCovariance(indefinite);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("not positive definite"), std::string::npos);

  Eigen::Matrix2d asymmetric;
  asymmetric << 1, 0.5, 0, 1;
  r = NoiseModel::FromInformation(asymmetric);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("not symmetric"), std::string::npos);

  Eigen::Matrix2d nan = Eigen::Matrix2d::Identity();
  nan(1, 1) = std::nan("");
  r = NoiseModel::FromInformation(nan);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("NaN"), std::string::npos);

  r = NoiseModel::FromInformation(Eigen::MatrixXd::Identity(2, 3));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("not square"), std::string::npos);

  r = NoiseModel::FromInformation(Eigen::MatrixXd(0, 0));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("empty"), std::string::npos);
  // Any size up to kMaxDim is fine (a dense container factor's residual may be large).
  r = NoiseModel::FromInformation(Eigen::MatrixXd::Identity(17, 17));
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->dim(), 17);
  r = NoiseModel::Isotropic(NoiseModel::kMaxDim + 1, 1.0);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("65535"), std::string::npos) << r.status().ToString();
  r = NoiseModel::Diagonal(Eigen::VectorXd::Ones(NoiseModel::kMaxDim + 1));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("more than a noise model's 65535"), std::string::npos);

  Eigen::Matrix2d ill = Eigen::Matrix2d::Identity();
  ill(1, 1) = 1e-16;
  r = NoiseModel::FromInformation(ill);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("ill-conditioned"), std::string::npos);

  EXPECT_FALSE(NoiseModel::Isotropic(3, 0.0).ok());
  EXPECT_FALSE(NoiseModel::Isotropic(3, -1.0).ok());
  EXPECT_FALSE(NoiseModel::Diagonal(Eigen::Vector2d(1.0, std::nan(""))).ok());
  EXPECT_FALSE(NoiseModel::Diagonal(Eigen::Vector2d(1.0, -1.0)).ok());
}

}  // namespace
}  // namespace slamd::core
