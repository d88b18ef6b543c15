// LandmarkSchur against dense references: the Schur complement S = Hrr − Hrl Hll⁻¹ Hlr and its
// right-hand side computed from the dense H, and the solution δ = H⁻¹ b of the whole system.
#include "core/linear/landmark_schur.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>
#include <vector>

#include "core/linear/ordering.h"
#include "tests/core/linear/random_block_problem.h"

namespace slamd::core {
namespace {

using testing::RandomBlockProblem;
using testing::RandomFactor;

// Poses (6), calibrations (3, 5 or 9: every kernel shape) and landmarks (3, some 2): a prior and
// odometry on the poses, and 2-4 observations of every landmark by random poses, each with
// m = 2 or 3 rows on (pose, landmark) or (pose, landmark, calibration). The landmarks are the
// variables from `first_landmark` on.
struct LandmarkProblem {
  RandomBlockProblem p;
  int first_landmark = 0;
  int num_landmarks = 0;
};

void AddRandomFactor(const std::vector<int>& vars, int m, std::mt19937* rng,
                     RandomBlockProblem* p) {
  std::normal_distribution<double> normal(0.0, 1.0);
  RandomFactor factor;
  for (int v : vars) {
    Eigen::MatrixXd jk(m, p->dims[v]);
    for (int i = 0; i < jk.size(); ++i) jk.data()[i] = normal(*rng);
    factor.jacobians.push_back(jk);
  }
  factor.error.resize(m);
  for (int i = 0; i < m; ++i) factor.error[i] = normal(*rng);
  p->incidence.AddFactor(vars);
  p->factors.push_back(std::move(factor));
}

LandmarkProblem MakeLandmarkProblem(int num_poses, int num_landmarks, std::mt19937* rng) {
  LandmarkProblem out;
  RandomBlockProblem& p = out.p;
  const int calibrations = 3;
  for (int i = 0; i < num_poses; ++i) p.dims.push_back(6);
  for (int d : {3, 5, 9}) p.dims.push_back(d);
  out.first_landmark = num_poses + calibrations;
  out.num_landmarks = num_landmarks;
  for (int j = 0; j < num_landmarks; ++j) p.dims.push_back(j % 4 == 3 ? 2 : 3);
  for (int i = 0; i < num_poses + calibrations; ++i) AddRandomFactor({i}, p.dims[i], rng, &p);
  for (int i = 0; i + 1 < num_poses; ++i) AddRandomFactor({i, i + 1}, 6, rng, &p);
  std::uniform_int_distribution<int> pose(0, num_poses - 1), views(2, 4), rows(2, 3),
      calibration(-1, calibrations - 1);
  for (int j = 0; j < num_landmarks; ++j) {
    const int landmark = out.first_landmark + j;
    std::vector<int> seen;
    const int n = std::min(views(*rng), num_poses);
    while (static_cast<int>(seen.size()) < n) {
      const int i = pose(*rng);
      if (std::find(seen.begin(), seen.end(), i) != seen.end()) continue;
      seen.push_back(i);
      const int k = calibration(*rng);
      std::vector<int> vars = {i, landmark};
      if (k >= 0) vars.push_back(num_poses + k);
      AddRandomFactor(vars, rows(*rng), rng, &p);
    }
  }
  return out;
}

// Landmarks first (in a random order), then the rest in CCOLAMD's order.
std::vector<int> LandmarksFirst(const LandmarkProblem& lp) {
  const int n = static_cast<int>(lp.p.dims.size());
  std::vector<int> group(n, 1);
  for (int j = 0; j < lp.num_landmarks; ++j) group[lp.first_landmark + j] = 0;
  auto order = ConstrainedColamdOrdering(n, lp.p.incidence, group);
  EXPECT_TRUE(order.ok());
  return *order;
}

TEST(LandmarkSchurTest, ReducedSystemAndSolutionMatchDenseReferences) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 6; ++trial) {
    const LandmarkProblem lp = MakeLandmarkProblem(3 + trial, 5 + 4 * trial, &rng);
    const std::vector<int> order = LandmarksFirst(lp);
    auto h = BlockSparseSystem::Create(lp.p.dims, order, lp.p.incidence);
    ASSERT_TRUE(h.ok()) << h.status().ToString();
    lp.p.Assemble(&*h);
    const double lambda = trial % 2 ? 0.5 : 0.0;  // damping is read from H like the rest
    h->AddToDiagonal(lambda);

    auto schur = LandmarkSchur::Create(*h, lp.num_landmarks);
    ASSERT_TRUE(schur.ok()) << schur.status().ToString();
    int failed = -1;
    ASSERT_TRUE((*schur)->Reduce(*h, &failed).ok());

    // Dense references in the permuted order: H = [Hll Hlr; Hrl Hrr].
    Eigen::MatrixXd h_dense;
    Eigen::VectorXd b_dense;
    lp.p.DenseNormalEquations(&h_dense, &b_dense);
    h_dense.diagonal().array() += lambda;
    Eigen::VectorXd b_permuted;
    h->FromOriginalOrder(b_dense, &b_permuted);
    Eigen::MatrixXd h_permuted(h->Dim(), h->Dim());
    {
      Eigen::VectorXd e = Eigen::VectorXd::Zero(h->Dim()), column, permuted;
      for (int j = 0; j < h->Dim(); ++j) {
        e.setZero();
        e[j] = 1.0;
        h->MultiplyPermuted(e, &column);
        h_permuted.col(j) = column;
      }
    }
    const int L = (*schur)->LandmarkDim();
    const int R = h->Dim() - L;
    const Eigen::MatrixXd hll = h_permuted.topLeftCorner(L, L);
    const Eigen::MatrixXd hlr = h_permuted.topRightCorner(L, R);
    const Eigen::MatrixXd s_ref =
        h_permuted.bottomRightCorner(R, R) - hlr.transpose() * hll.llt().solve(hlr);
    const Eigen::VectorXd rhs_ref =
        b_permuted.tail(R) - hlr.transpose() * hll.llt().solve(b_permuted.head(L));
    // The reduced system's original order is its permuted order (identity order).
    EXPECT_LT(((*schur)->reduced().ToDense() - s_ref).cwiseAbs().maxCoeff(),
              1e-9 * s_ref.cwiseAbs().maxCoeff())
        << "trial " << trial;
    EXPECT_LT(((*schur)->reduced().rhs() - rhs_ref).cwiseAbs().maxCoeff(),
              1e-9 * rhs_ref.cwiseAbs().maxCoeff());

    const Eigen::VectorXd delta_rest = s_ref.llt().solve((*schur)->reduced().rhs());
    Eigen::VectorXd delta;
    (*schur)->BackSubstitute(*h, delta_rest, &delta);
    const Eigen::VectorXd delta_ref = h_permuted.llt().solve(b_permuted);
    EXPECT_LT((delta - delta_ref).norm(), 1e-9 * delta_ref.norm()) << "trial " << trial;
  }
}

TEST(LandmarkSchurTest, UnderdeterminedLandmarkIsNamed) {
  std::mt19937 rng(3);
  LandmarkProblem lp = MakeLandmarkProblem(4, 6, &rng);
  // One more landmark seen once, by two rows: its 3x3 block has rank 2.
  lp.p.dims.push_back(3);
  const int lonely = static_cast<int>(lp.p.dims.size()) - 1;
  ++lp.num_landmarks;
  AddRandomFactor({0, lonely}, 2, &rng, &lp.p);
  auto h = BlockSparseSystem::Create(lp.p.dims, LandmarksFirst(lp), lp.p.incidence);
  ASSERT_TRUE(h.ok());
  lp.p.Assemble(&*h);
  auto schur = LandmarkSchur::Create(*h, lp.num_landmarks);
  ASSERT_TRUE(schur.ok());
  int failed = -1;
  const Status reduced = (*schur)->Reduce(*h, &failed);
  EXPECT_EQ(reduced.code(), StatusCode::kNumericalFailure) << reduced.ToString();
  EXPECT_EQ(failed, lonely);
  h->AddToDiagonal(1e-3);  // damping makes it solvable
  EXPECT_TRUE((*schur)->Reduce(*h, &failed).ok());
}

TEST(LandmarkSchurTest, RejectsLandmarksThatShareAFactor) {
  std::mt19937 rng(5);
  LandmarkProblem lp = MakeLandmarkProblem(3, 4, &rng);
  AddRandomFactor({lp.first_landmark, lp.first_landmark + 1}, 3, &rng, &lp.p);
  auto h = BlockSparseSystem::Create(lp.p.dims, LandmarksFirst(lp), lp.p.incidence);
  ASSERT_TRUE(h.ok());
  auto schur = LandmarkSchur::Create(*h, lp.num_landmarks);
  ASSERT_FALSE(schur.ok());
  EXPECT_EQ(schur.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(schur.status().message().find("shares a factor with another landmark"),
            std::string::npos)
      << schur.status().ToString();
}

TEST(LandmarkSchurTest, RejectsNoLandmarksOrNothingElse) {
  std::mt19937 rng(9);
  const LandmarkProblem lp = MakeLandmarkProblem(3, 4, &rng);
  auto h = BlockSparseSystem::Create(lp.p.dims, LandmarksFirst(lp), lp.p.incidence);
  ASSERT_TRUE(h.ok());
  EXPECT_FALSE(LandmarkSchur::Create(*h, 0).ok());
  EXPECT_FALSE(LandmarkSchur::Create(*h, h->NumVariables()).ok());
}

}  // namespace
}  // namespace slamd::core
