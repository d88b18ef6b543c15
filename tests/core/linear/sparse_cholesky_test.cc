#include "core/linear/sparse_cholesky.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/linear/block_sparse_system.h"
#include "core/linear/ordering.h"
#include "tests/core/linear/random_block_problem.h"

namespace slamd::core {
namespace {

using testing::MakeRandomBlockProblem;
using testing::RandomBlockProblem;

using Method = SparseCholesky::Method;

std::string MethodName(const ::testing::TestParamInfo<Method>& info) {
  switch (info.param) {
    case Method::kAuto: return "Auto";
    case Method::kSimplicial: return "Simplicial";
    case Method::kSupernodal: return "Supernodal";
  }
  return "Unknown";
}

class SparseCholeskyTest : public ::testing::TestWithParam<Method> {
 protected:
  std::unique_ptr<SparseCholesky> MakeSolver() const {
    return SparseCholesky::Create(SparseCholesky::Options{.method = GetParam()});
  }

  // Factorizes and solves `system` and returns the solution in ORIGINAL order.
  static Eigen::VectorXd FactorizeAndSolve(SparseCholesky* solver,
                                           const BlockSparseSystem& system) {
    std::string message;
    int failed = 0;
    const LinearSolverTermination t =
        solver->Factorize(system.Dim(), system.col_ptr().data(), system.row_idx().data(),
                          system.values().data(), &message, &failed);
    EXPECT_EQ(t, LinearSolverTermination::kSuccess) << message;
    EXPECT_EQ(failed, -1);
    Eigen::VectorXd x_perm(system.Dim());
    EXPECT_EQ(solver->Solve(system.rhs().data(), x_perm.data(), &message),
              LinearSolverTermination::kSuccess)
        << message;
    Eigen::VectorXd x;
    system.ToOriginalOrder(x_perm, &x);
    return x;
  }

  static BlockSparseSystem Build(const RandomBlockProblem& p, const std::vector<int>& order) {
    auto system = BlockSparseSystem::Create(p.dims, order, p.incidence);
    EXPECT_TRUE(system.ok()) << system.status().ToString();
    p.Assemble(&*system);
    return std::move(system).value();
  }
};

TEST_P(SparseCholeskyTest, MatchesDenseSolveOnRandomSpdSystems) {
  std::mt19937 rng(1234);
  for (int trial = 0; trial < 10; ++trial) {
    const RandomBlockProblem p = MakeRandomBlockProblem(10 + 15 * trial, 4 * trial + 3, true, &rng);
    const auto order = ColamdOrdering(static_cast<int>(p.dims.size()), p.incidence);
    ASSERT_TRUE(order.ok());
    const BlockSparseSystem system = Build(p, *order);
    Eigen::MatrixXd h;
    Eigen::VectorXd b;
    p.DenseNormalEquations(&h, &b);
    const Eigen::VectorXd x_ref = h.llt().solve(b);
    auto solver = MakeSolver();
    const Eigen::VectorXd x = FactorizeAndSolve(solver.get(), system);
    EXPECT_LT((x - x_ref).cwiseAbs().maxCoeff(), 1e-9 * (1.0 + x_ref.cwiseAbs().maxCoeff()))
        << "trial " << trial;
    EXPECT_GT(solver->FactorNonZeros(), 0);
  }
}

TEST_P(SparseCholeskyTest, ReusesSymbolicAnalysisWhileThePatternIsUnchanged) {
  std::mt19937 rng(77);
  const RandomBlockProblem p = MakeRandomBlockProblem(60, 40, true, &rng);
  const auto order = ColamdOrdering(60, p.incidence);
  ASSERT_TRUE(order.ok());
  BlockSparseSystem system = Build(p, *order);
  const std::vector<double> undamped = system.values();
  Eigen::MatrixXd h;
  Eigen::VectorXd b;
  p.DenseNormalEquations(&h, &b);
  auto solver = MakeSolver();
  for (double lambda : {0.0, 1e-3, 1.0, 100.0}) {
    system.values() = undamped;
    system.AddToDiagonal(lambda);
    Eigen::MatrixXd damped = h;
    damped.diagonal().array() += lambda;
    const Eigen::VectorXd x_ref = damped.ldlt().solve(b);
    const Eigen::VectorXd x = FactorizeAndSolve(solver.get(), system);
    EXPECT_LT((x - x_ref).cwiseAbs().maxCoeff(), 1e-9 * (1.0 + x_ref.cwiseAbs().maxCoeff()))
        << "lambda " << lambda;
  }
  EXPECT_EQ(solver->NumAnalyses(), 1);
}

TEST_P(SparseCholeskyTest, ReanalysesWhenThePatternChanges) {
  std::mt19937 rng(78);
  auto solver = MakeSolver();
  for (int trial = 0; trial < 3; ++trial) {
    const RandomBlockProblem p = MakeRandomBlockProblem(30 + trial, 25, true, &rng);
    const auto order = ColamdOrdering(static_cast<int>(p.dims.size()), p.incidence);
    ASSERT_TRUE(order.ok());
    const BlockSparseSystem system = Build(p, *order);
    Eigen::MatrixXd h;
    Eigen::VectorXd b;
    p.DenseNormalEquations(&h, &b);
    const Eigen::VectorXd x_ref = h.llt().solve(b);
    const Eigen::VectorXd x = FactorizeAndSolve(solver.get(), system);
    EXPECT_LT((x - x_ref).cwiseAbs().maxCoeff(), 1e-9 * (1.0 + x_ref.cwiseAbs().maxCoeff()));
    EXPECT_EQ(solver->NumAnalyses(), trial + 1);
  }
  // Same size, different pattern: one entry moved within a column.
  const std::vector<int> col_ptr = {0, 1, 3, 5};
  const std::vector<int> rows_a = {0, 0, 1, 1, 2};
  const std::vector<int> rows_b = {0, 0, 1, 0, 2};
  const std::vector<double> values = {4, 1, 4, 1, 4};
  ASSERT_EQ(solver->Factorize(3, col_ptr.data(), rows_a.data(), values.data(), nullptr, nullptr),
            LinearSolverTermination::kSuccess);
  const int before = solver->NumAnalyses();
  ASSERT_EQ(solver->Factorize(3, col_ptr.data(), rows_b.data(), values.data(), nullptr, nullptr),
            LinearSolverTermination::kSuccess);
  EXPECT_EQ(solver->NumAnalyses(), before + 1);
  Eigen::Matrix3d dense;
  dense << 4, 1, 1, 1, 4, 0, 1, 0, 4;
  const Eigen::Vector3d rhs(1, 2, 3);
  Eigen::Vector3d x;
  ASSERT_EQ(solver->Solve(rhs.data(), x.data(), nullptr), LinearSolverTermination::kSuccess);
  EXPECT_LT((x - dense.llt().solve(rhs)).norm(), 1e-12);
}

TEST_P(SparseCholeskyTest, IndefiniteMatrixIsANumericalFailureAndRecovers) {
  std::mt19937 rng(99);
  const RandomBlockProblem p = MakeRandomBlockProblem(40, 30, true, &rng);
  const auto order = ColamdOrdering(40, p.incidence);
  ASSERT_TRUE(order.ok());
  BlockSparseSystem system = Build(p, *order);
  const std::vector<double> good = system.values();
  Eigen::MatrixXd h;
  Eigen::VectorXd b;
  p.DenseNormalEquations(&h, &b);
  // Make it indefinite: a large negative shift of one diagonal entry.
  Eigen::VectorXd shift = Eigen::VectorXd::Zero(system.Dim());
  const int original_column = system.OriginalOffset(17);
  shift[original_column] = -10.0 * h.diagonal().maxCoeff();
  system.AddDiagonal(shift);
  auto solver = MakeSolver();
  std::string message;
  int failed = -2;
  EXPECT_EQ(solver->Factorize(system.Dim(), system.col_ptr().data(), system.row_idx().data(),
                              system.values().data(), &message, &failed),
            LinearSolverTermination::kNumericalFailure);
  EXPECT_NE(message.find("not positive definite"), std::string::npos) << message;
  EXPECT_GE(failed, 0);
  EXPECT_LT(failed, system.Dim());
  // Pivots eliminated before the shifted column are unaffected (and positive), and its own pivot
  // is below H_ss + shift < 0: the failure is exactly there (permuted numbering).
  EXPECT_EQ(failed, system.Offset(17)) << message;
  Eigen::VectorXd x(system.Dim());
  EXPECT_EQ(solver->Solve(system.rhs().data(), x.data(), &message),
            LinearSolverTermination::kFatal);

  // Same pattern, good values: the same solver object recovers without re-analysis.
  system.values() = good;
  const Eigen::VectorXd x_ok = FactorizeAndSolve(solver.get(), system);
  const Eigen::VectorXd x_ref = h.llt().solve(b);
  EXPECT_LT((x_ok - x_ref).cwiseAbs().maxCoeff(), 1e-9 * (1.0 + x_ref.cwiseAbs().maxCoeff()));
  EXPECT_EQ(solver->NumAnalyses(), 1);
}

TEST_P(SparseCholeskyTest, FailedColumnIsExactOnADecoupledMatrix) {
  // Diagonal matrix with one non-positive entry: the failure is at that column exactly.
  const int n = 12;
  std::vector<int> col_ptr(n + 1), rows(n);
  for (int j = 0; j <= n; ++j) col_ptr[j] = j;
  for (int j = 0; j < n; ++j) rows[j] = j;
  for (int bad : {0, 5, 11}) {
    for (double bad_value : {-1.0, 0.0, std::numeric_limits<double>::quiet_NaN()}) {
      std::vector<double> values(n, 2.0);
      values[bad] = bad_value;
      auto solver = MakeSolver();
      int failed = -2;
      std::string message;
      EXPECT_EQ(solver->Factorize(n, col_ptr.data(), rows.data(), values.data(), &message,
                                  &failed),
                LinearSolverTermination::kNumericalFailure);
      EXPECT_EQ(failed, bad) << message;
    }
  }
}

TEST_P(SparseCholeskyTest, UntouchedVariableGivesNumericalFailureNotAbort) {
  FactorIncidence incidence;
  incidence.AddFactor({0});
  incidence.AddFactor({0, 2});
  auto system = BlockSparseSystem::Create({3, 3, 3}, {0, 1, 2}, incidence);
  ASSERT_TRUE(system.ok());
  const Eigen::Matrix3d j = Eigen::Matrix3d::Identity();
  const Eigen::Vector3d e(1, 1, 1);
  const double* one[] = {j.data()};
  const double* two[] = {j.data(), j.data()};
  system->AddFactor(0, one, e.data(), 3);
  system->AddFactor(1, two, e.data(), 3);
  auto solver = MakeSolver();
  int failed = -2;
  EXPECT_EQ(solver->Factorize(system->Dim(), system->col_ptr().data(), system->row_idx().data(),
                              system->values().data(), nullptr, &failed),
            LinearSolverTermination::kNumericalFailure);
  // Variable 1 has no information; its three columns are decoupled, so the postorder may visit
  // any of them first.
  EXPECT_GE(failed, system->Offset(1));
  EXPECT_LT(failed, system->Offset(1) + 3);
}

TEST_P(SparseCholeskyTest, MisuseIsFatalAndSilent) {
  auto solver = MakeSolver();
  std::string message;
  double b[2] = {1, 2}, x[2];
  EXPECT_EQ(solver->Solve(b, x, &message), LinearSolverTermination::kFatal);
  EXPECT_FALSE(message.empty());

  // A lower-triangular entry violates the contract.
  const std::vector<int> col_ptr = {0, 2, 3};
  const std::vector<int> rows = {0, 1, 1};
  const std::vector<double> values = {2, 1, 2};
  ::testing::internal::CaptureStdout();
  ::testing::internal::CaptureStderr();
  const LinearSolverTermination t =
      solver->Factorize(2, col_ptr.data(), rows.data(), values.data(), &message, nullptr);
  // And an indefinite one, to check CHOLMOD's warning is not printed either.
  const std::vector<int> cp = {0, 1, 2};
  const std::vector<int> diag_rows = {0, 1};
  const std::vector<double> indefinite = {1, -1};
  std::string message2;
  const LinearSolverTermination t2 =
      solver->Factorize(2, cp.data(), diag_rows.data(), indefinite.data(), &message2, nullptr);
  const std::string out = ::testing::internal::GetCapturedStdout();
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(t, LinearSolverTermination::kFatal);
  EXPECT_FALSE(message.empty());
  EXPECT_EQ(t2, LinearSolverTermination::kNumericalFailure);
  EXPECT_TRUE(out.empty()) << out;
  EXPECT_TRUE(err.empty()) << err;
  EXPECT_EQ(solver->Factorize(-1, nullptr, nullptr, nullptr, &message, nullptr),
            LinearSolverTermination::kFatal);
}

TEST_P(SparseCholeskyTest, SolveAllowsAliasingAndEmptySystems) {
  const std::vector<int> col_ptr = {0, 1, 3};
  const std::vector<int> rows = {0, 0, 1};
  const std::vector<double> values = {4, 2, 3};
  auto solver = MakeSolver();
  ASSERT_EQ(solver->Factorize(2, col_ptr.data(), rows.data(), values.data(), nullptr, nullptr),
            LinearSolverTermination::kSuccess);
  Eigen::Vector2d v(2, 1);
  Eigen::Matrix2d a;
  a << 4, 2, 2, 3;
  const Eigen::Vector2d expected = a.llt().solve(v);
  ASSERT_EQ(solver->Solve(v.data(), v.data(), nullptr), LinearSolverTermination::kSuccess);
  EXPECT_LT((v - expected).norm(), 1e-14);

  const int zero = 0;
  EXPECT_EQ(solver->Factorize(0, &zero, nullptr, nullptr, nullptr, nullptr),
            LinearSolverTermination::kSuccess);
  EXPECT_EQ(solver->Solve(nullptr, nullptr, nullptr), LinearSolverTermination::kSuccess);
}

INSTANTIATE_TEST_SUITE_P(Methods, SparseCholeskyTest,
                         ::testing::Values(Method::kSimplicial, Method::kSupernodal, Method::kAuto),
                         MethodName);

TEST_P(SparseCholeskyTest, ReportsTheMethodUsed) {
  std::mt19937 rng(3);
  const RandomBlockProblem p = MakeRandomBlockProblem(50, 60, true, &rng);
  const auto order = ColamdOrdering(50, p.incidence);
  ASSERT_TRUE(order.ok());
  const BlockSparseSystem system = Build(p, *order);
  auto solver = MakeSolver();
  EXPECT_FALSE(solver->IsSupernodal());
  FactorizeAndSolve(solver.get(), system);
  if (GetParam() == Method::kSupernodal) {
    EXPECT_TRUE(solver->IsSupernodal());
  } else if (GetParam() == Method::kSimplicial) {
    EXPECT_FALSE(solver->IsSupernodal());
  }
}

// kAuto follows the flops / nnz(L) threshold and stays correct on both sides of it.
TEST(SparseCholeskyAutoTest, SwitchThresholdSelectsTheMethod) {
  std::mt19937 rng(4);
  const RandomBlockProblem p = MakeRandomBlockProblem(80, 120, true, &rng);
  const auto order = ColamdOrdering(80, p.incidence);
  ASSERT_TRUE(order.ok());
  auto system = BlockSparseSystem::Create(p.dims, *order, p.incidence);
  ASSERT_TRUE(system.ok());
  p.Assemble(&*system);
  Eigen::MatrixXd h;
  Eigen::VectorXd b;
  p.DenseNormalEquations(&h, &b);
  const Eigen::VectorXd x_ref = h.llt().solve(b);
  for (double threshold : {0.0, 1e9}) {
    auto solver = SparseCholesky::Create(
        SparseCholesky::Options{.method = Method::kAuto, .supernodal_switch = threshold});
    Eigen::VectorXd x_perm(system->Dim()), x;
    ASSERT_EQ(solver->Factorize(system->Dim(), system->col_ptr().data(), system->row_idx().data(),
                                system->values().data(), nullptr, nullptr),
              LinearSolverTermination::kSuccess);
    ASSERT_EQ(solver->Solve(system->rhs().data(), x_perm.data(), nullptr),
              LinearSolverTermination::kSuccess);
    system->ToOriginalOrder(x_perm, &x);
    EXPECT_EQ(solver->IsSupernodal(), threshold == 0.0);
    EXPECT_LT((x - x_ref).cwiseAbs().maxCoeff(), 1e-9 * (1.0 + x_ref.cwiseAbs().maxCoeff()));
  }
}

TEST(SparseCholeskyOptionsTest, Validate) {
  EXPECT_TRUE(SparseCholesky::Options{}.Validate().ok());
  EXPECT_EQ(SparseCholesky::Options{.supernodal_switch = -1.0}.Validate().code(),
            StatusCode::kInvalidArgument);
}

TEST(SparseCholeskyNamesTest, TerminationNames) {
  EXPECT_STREQ(LinearSolverTerminationName(LinearSolverTermination::kSuccess), "Success");
  EXPECT_STREQ(LinearSolverTerminationName(LinearSolverTermination::kNumericalFailure),
               "NumericalFailure");
  EXPECT_STREQ(LinearSolverTerminationName(LinearSolverTermination::kFatal), "Fatal");
}

}  // namespace
}  // namespace slamd::core
