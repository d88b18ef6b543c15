// The field-level checks, at their boundaries; the noise model against core's own construction.
#include "server/ingest/field_checks.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/QR>
#include <cmath>
#include <limits>
#include <vector>

namespace slamd::server::internal {
namespace {

std::vector<double> RowMajor(const Eigen::MatrixXd& m) {
  std::vector<double> out;
  for (int i = 0; i < m.rows(); ++i)
    for (int j = 0; j < m.cols(); ++j) out.push_back(m(i, j));
  return out;
}

// Q diag(eigenvalues) Qᵀ with a fixed rotation Q: a covariance with known eigenvalues.
Eigen::MatrixXd WithEigenvalues(const Eigen::VectorXd& eigenvalues) {
  const int d = static_cast<int>(eigenvalues.size());
  Eigen::MatrixXd A(d, d);
  for (int i = 0; i < d; ++i)
    for (int j = 0; j < d; ++j) A(i, j) = std::sin(1.0 + 3.0 * i + 7.0 * j);
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(A);
  const Eigen::MatrixXd Q = qr.householderQ();
  return Q * eigenvalues.asDiagonal() * Q.transpose();
}

TEST(CheckCovariance, ConditionNumberBoundary) {
  const Limits limits;  // 1e12
  for (double cond : {0.9e12, 1.1e12}) {
    Eigen::VectorXd ev(4);
    ev << 1e-6, 1e-3, 2e-2, cond * 1e-6;
    const std::vector<double> c = RowMajor(WithEigenvalues(ev));
    const Verdict v = CheckCovariance("t.covariance", c, 4, limits, nullptr);
    if (cond < 1e12) {
      EXPECT_TRUE(v.ok()) << v.message;
    } else {
      EXPECT_EQ(v.reason, RejectReason::kCovarianceIllConditioned);
      // The smallest eigenvalue is only known to ~eps * largest, so cond is ~1e-4 accurate here.
      EXPECT_NE(v.message.find("ill-conditioned (condition number 1.09"), std::string::npos)
          << v.message;
      EXPECT_NE(v.message.find("> 1e+12"), std::string::npos) << v.message;
    }
  }
}

TEST(CheckCovariance, ReportsTheSmallestEigenvalue) {
  Eigen::VectorXd ev(3);
  ev << 1.0, -0.25, 2.0;
  const std::vector<double> c = RowMajor(WithEigenvalues(ev));
  const Verdict v = CheckCovariance("odometry_t.covariance", c, 3, Limits{}, nullptr);
  EXPECT_EQ(v.reason, RejectReason::kCovarianceNotPositiveDefinite);
  EXPECT_EQ(v.message, "odometry_t.covariance: not positive definite (smallest eigenvalue -0.25)");
}

TEST(CheckCovariance, SingularIsNotPositiveDefinite) {
  const std::vector<double> c = {1.0, 1.0, 1.0, 1.0};  // rank 1
  EXPECT_EQ(CheckCovariance("f", c, 2, Limits{}, nullptr).reason,
            RejectReason::kCovarianceNotPositiveDefinite);
}

TEST(CheckCovariance, SymmetryToleranceIsRelativeToTheLargestEntry) {
  Limits limits;  // 1e-6
  std::vector<double> c = {1e-8, 0.0, 0.0, 2e-8};
  c[1] = 0.5e-6 * 2e-8;  // relative asymmetry 5e-7: accepted
  EXPECT_TRUE(CheckCovariance("f", c, 2, limits, nullptr).ok());
  c[1] = 2e-6 * 2e-8;  // 2e-6: rejected even though the absolute difference is 4e-14
  const Verdict v = CheckCovariance("f", c, 2, limits, nullptr);
  EXPECT_EQ(v.reason, RejectReason::kCovarianceNotSymmetric);
  EXPECT_NE(v.message.find("f: not symmetric"), std::string::npos) << v.message;
}

TEST(CheckCovariance, NoiseModelIsCoresModelOfTheSymmetricPart) {
  Eigen::VectorXd ev(6);
  ev << 0.01, 0.02, 0.04, 0.001, 0.002, 0.003;
  Eigen::MatrixXd C = WithEigenvalues(ev);
  std::vector<double> c = RowMajor(C);
  c[1] += 1e-10;  // within tolerance: the model uses (C + Cᵀ) / 2
  std::optional<core::NoiseModel> noise;
  ASSERT_TRUE(CheckCovariance("f", c, 6, Limits{}, &noise).ok());
  ASSERT_TRUE(noise.has_value());
  Eigen::MatrixXd S = Eigen::Map<const Eigen::Matrix<double, 6, 6, Eigen::RowMajor>>(c.data());
  S = 0.5 * (S + S.transpose()).eval();
  const core::NoiseModel expected = core::NoiseModel::FromCovariance(S).value();
  EXPECT_TRUE(noise->Equals(expected, 1e-9));
  EXPECT_LT((noise->Covariance() - S).cwiseAbs().maxCoeff(), 1e-14);
}

TEST(CheckName, Rules) {
  EXPECT_TRUE(CheckName("f", "robot_1.a-B", 64).ok());
  EXPECT_EQ(CheckName("f", "", 64).reason, RejectReason::kBadName);
  EXPECT_TRUE(CheckName("f", "", 64, /*allow_empty=*/true).ok());
  EXPECT_EQ(CheckName("f", "ab", 1).reason, RejectReason::kStringTooLong);
  const Verdict v = CheckName("f", std::string("a\0b", 3), 64);
  EXPECT_EQ(v.reason, RejectReason::kBadName);
  EXPECT_EQ(v.message, "f: character 1 (byte 0x0) is not one of [A-Za-z0-9_.-]");
  EXPECT_EQ(CheckName("f", "caf\xc3\xa9", 64).reason, RejectReason::kBadName);  // non-ASCII
}

TEST(CheckIndex, Range) {
  EXPECT_TRUE(CheckIndex("f", 0).ok());
  EXPECT_TRUE(CheckIndex("f", (std::int64_t{1} << 48) - 1).ok());
  EXPECT_EQ(CheckIndex("f", std::int64_t{1} << 48).reason, RejectReason::kIndexOutOfRange);
  EXPECT_EQ(CheckIndex("f", -1).reason, RejectReason::kIndexOutOfRange);
  EXPECT_EQ(CheckIndex("f", std::numeric_limits<std::int64_t>::min()).reason,
            RejectReason::kIndexOutOfRange);
}

TEST(CheckCount, AgreementAndExpectation) {
  EXPECT_TRUE(CheckCount("n", 3, 3, 3, "x").ok());
  EXPECT_TRUE(CheckCount("n", 5, 5, -1, "").ok());
  EXPECT_EQ(CheckCount("n", -1, 0, -1, "").reason, RejectReason::kSizeMismatch);
  EXPECT_EQ(CheckCount("n", 3, 2, 3, "x").message, "n: 3 but the array holds 2 elements");
  EXPECT_EQ(CheckCount("n", 2, 2, 3, "dimension 2").message,
            "n: 2 elements, but dimension 2 needs 3");
}

TEST(CheckFinite, NamesTheFirstBadElement) {
  const std::vector<double> v = {1.0, 2.0, -std::numeric_limits<double>::infinity(), NAN};
  const Verdict verdict = CheckFinite("m.values", v);
  EXPECT_EQ(verdict.reason, RejectReason::kNotFinite);
  EXPECT_EQ(verdict.message, "m.values[2]: not finite (-inf)");
  EXPECT_TRUE(CheckFinite("m.values", std::vector<double>{}).ok());
}

TEST(CheckUnitQuaternion, Tolerance) {
  EXPECT_TRUE(CheckUnitQuaternion("q", 1.0, 0.0, 0.0, 0.0, 1e-4).ok());
  EXPECT_TRUE(CheckUnitQuaternion("q", 0.0, 0.0, 0.0, -1.00009, 1e-4).ok());
  EXPECT_EQ(CheckUnitQuaternion("q", 0.0, 0.0, 0.0, 1.00011, 1e-4).reason,
            RejectReason::kQuaternionNotUnit);
  EXPECT_EQ(CheckUnitQuaternion("q", 0.5, 0.5, 0.5, 0.4, 1e-4).reason,
            RejectReason::kQuaternionNotUnit);
}

TEST(CheckUtime, NegativeOnly) {
  EXPECT_TRUE(CheckUtime("u", 0).ok());
  EXPECT_EQ(CheckUtime("u", -1).reason, RejectReason::kBadTimestamp);
}

TEST(CheckRobustKernel, NamesAndParameters) {
  Limits limits;
  core::RobustKernel k;
  EXPECT_TRUE(CheckRobustKernel("n", "p", "", 0.0, limits, &k).ok());
  EXPECT_TRUE(k.is_none());
  EXPECT_TRUE(CheckRobustKernel("n", "p", "NONE", -1.0, limits, &k).ok());
  EXPECT_TRUE(CheckRobustKernel("n", "p", "cauchy", 0.5, limits, &k).ok());
  EXPECT_EQ(k.kind(), core::RobustKernel::Kind::kCauchy);
  EXPECT_EQ(CheckRobustKernel("n", "p", "l1", 1.0, limits, &k).reason,
            RejectReason::kUnknownRobustKernel);
  EXPECT_EQ(CheckRobustKernel("n", "p", "huber", -1.0, limits, &k).reason,
            RejectReason::kBadRobustParameter);
  EXPECT_EQ(CheckRobustKernel("n", "p", std::string(40, 'a'), 1.0, limits, &k).reason,
            RejectReason::kStringTooLong);
}

TEST(FormatNumber, ShortForms) {
  EXPECT_EQ(FormatNumber(-0.2), "-0.2");
  EXPECT_EQ(FormatNumber(1e13), "1e+13");
  EXPECT_EQ(FormatNumber(std::numeric_limits<double>::quiet_NaN()), "nan");
}

}  // namespace
}  // namespace slamd::server::internal
