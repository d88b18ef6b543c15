// Bundle adjustment (core/ba/bundle_adjuster.h): the Schur step against a dense solve of the
// full damped normal equations with finite-difference Jacobians, the implicit product against the
// formed S, convergence of every linear solver to the same optimum, robust kernels, and errors.
#include "core/ba/bundle_adjuster.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "core/ba/ba_problem.h"
#include "tests/testing/ba_worlds.h"

namespace slamd::core {
namespace {

using testing::BaPerturb;
using testing::BaWorld;

const Cal3Bundler kBundler(500.0, -0.05, 0.01);

// The Schur complement's step equals the dense solution of the full damped normal equations
// (JᵀJ + λ·clamp(diag JᵀJ)) δ = −Jᵀr, with J by central differences of the residuals.
TEST(BundleAdjusterTest, SchurStepEqualsDenseSolveOfTheFullSystem) {
  Reconstruction r = BaWorld(kBundler, 4, 6, 0.5, 1);
  BaPerturb(&r, 0.01, 0.05, 2);
  using Problem = internal::BaProblem<Cal3Bundler, true>;
  constexpr int kD = Problem::kD;
  WorkerPool pool(1);
  Problem problem(r, RobustKernel(), {0, 1, 2, 3}, &pool);
  const Problem::State x = Problem::StateOf(r);
  problem.Linearize(x);
  const double lambda = 1e-3;
  internal::ReducedCameraMatrix s(kD, problem.CoVisibility());
  Eigen::VectorXd b, dc(kD * 4);
  problem.EliminatePoints(lambda, &s, nullptr, &b);
  ASSERT_TRUE(s.SolveDense(b, &dc).ok());
  std::vector<Vector3> dp;
  problem.BackSubstitute(dc, Eigen::VectorXd(), &dp);

  Eigen::VectorXd residuals;
  const Eigen::MatrixXd J = testing::BaNumericalJacobian(r, true, &residuals);
  Eigen::MatrixXd H = J.transpose() * J;
  const Eigen::VectorXd diag = H.diagonal().cwiseMax(1e-6).cwiseMin(1e32);
  H.diagonal() += lambda * diag;
  const Eigen::VectorXd delta = H.ldlt().solve(-J.transpose() * residuals);
  for (int k = 0; k < kD * 4; ++k) EXPECT_NEAR(dc[k], delta[k], 1e-5 * (1.0 + std::abs(delta[k])));
  for (int j = 0; j < 6; ++j) {
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(dp[j][k], delta[kD * 4 + 3 * j + k], 1e-5 * (1.0 + std::abs(delta[k])));
    }
  }
  // The implicit product is S·x.
  const Eigen::VectorXd v = Eigen::VectorXd::LinSpaced(kD * 4, -1.0, 2.0);
  Eigen::VectorXd sv;
  problem.MultiplyReduced(v, &sv);
  const Eigen::VectorXd expected = s.ToDense() * v;
  EXPECT_LT((sv - expected).norm(), 1e-9 * expected.norm());
}

TEST(BundleAdjusterTest, EveryLinearSolverReachesTheSameOptimum) {
  const Reconstruction noisy = BaWorld(kBundler, 8, 40, 0.5, 3);
  Reconstruction start = noisy;
  BaPerturb(&start, 0.02, 0.1, 4);
  double truth_cost = 0.0;
  for (const SfmObservation& o : noisy.observations) {
    truth_cost +=
        0.5 *
        (Project(noisy.images[o.image].pose, kBundler, noisy.points[o.point].position).uv - o.uv)
            .squaredNorm();
  }
  std::vector<double> costs;
  for (BaLinearSolver solver : {BaLinearSolver::kDenseSchur, BaLinearSolver::kSparseSchur,
                                BaLinearSolver::kIterativeSchur}) {
    for (int threads : {1, 2}) {
      Reconstruction r = start;
      BundleAdjusterParams params{.linear_solver = solver, .num_threads = threads};
      params.cg_tolerance = 1e-6;
      params.max_iterations = 100;
      const Result<BundleAdjusterSummary> s = BundleAdjust(params, &r);
      ASSERT_TRUE(s.ok()) << s.status().ToString();
      EXPECT_EQ(s->linear_solver, solver);
      EXPECT_EQ(s->camera_block_dim, 9);
      EXPECT_LT(s->final_cost, truth_cost);  // the optimum is below the truth
      EXPECT_EQ(s->points_behind_cameras, 0);
      // ~0.5 px noise on each of 2 coordinates: rms about 0.5·√2·(1 − unknowns/residuals)^½.
      EXPECT_GT(s->rms_reprojection_px, 0.2);
      EXPECT_LT(s->rms_reprojection_px, 0.8);
      ASSERT_FALSE(s->iterations.empty());
      EXPECT_EQ(s->iterations.back().cost, s->final_cost);
      costs.push_back(s->final_cost);
    }
  }
  for (double c : costs) EXPECT_NEAR(c, costs.front(), 1e-6 * costs.front());
}

// Cameras that share no point leave blocks of S empty: every solver agrees with the dense S of
// a reconstruction where two groups of cameras are linked by a few points only.
TEST(BundleAdjusterTest, SolversAgreeWhereCamerasShareNoPoint) {
  Reconstruction r = BaWorld(kBundler, 8, 40, 0.5, 16);
  std::vector<SfmObservation> kept;
  for (const SfmObservation& o : r.observations) {
    const int group = o.image < 4 ? 0 : 1;  // cameras 0-3 see points 0-19, 4-7 see 20-39,
    if (group == (o.point < 20 ? 0 : 1) || o.point % 10 == 0) kept.push_back(o);  // a few both
  }
  r.observations = kept;
  BaPerturb(&r, 0.01, 0.05, 17);
  std::vector<Reconstruction> results;
  for (BaLinearSolver solver : {BaLinearSolver::kDenseSchur, BaLinearSolver::kSparseSchur,
                                BaLinearSolver::kIterativeSchur}) {
    Reconstruction out = r;
    BundleAdjusterParams params{.linear_solver = solver, .max_iterations = 100};
    params.cg_tolerance = 1e-8;
    params.function_tolerance = 1e-12;
    ASSERT_TRUE(BundleAdjust(params, &out).ok());
    results.push_back(out);
  }
  for (size_t j = 0; j < r.points.size(); ++j) {
    for (size_t k = 1; k < results.size(); ++k) {
      EXPECT_LT((results[k].points[j].position - results[0].points[j].position).norm(), 1e-6)
          << "point " << j << ", solver " << k;
    }
  }
}

TEST(BundleAdjusterTest, NoiseFreeProblemsConvergeToZeroForEveryModel) {
  auto converge = [](Reconstruction r, bool refine) {
    BaPerturb(&r, 0.01, 0.05, 5);
    BundleAdjusterParams params{.refine_intrinsics = refine, .max_iterations = 100};
    const Result<BundleAdjusterSummary> s = BundleAdjust(params, &r);
    EXPECT_TRUE(s.ok()) << s.status().ToString();
    if (!s.ok()) return -1;
    EXPECT_LT(s->final_cost, 1e-6) << "initial " << s->initial_cost;  // pixels²
    return s->camera_block_dim;
  };
  const Cal3_S2 pinhole(500.0, 480.0, 0.0, 320.0, 240.0);
  const Cal3DS2 opencv(pinhole, -0.2, 0.05, 1e-3, -1e-3);
  EXPECT_EQ(converge(BaWorld(pinhole, 6, 30, 0.0, 6), false), 6);
  EXPECT_EQ(converge(BaWorld(opencv, 6, 30, 0.0, 7), true), 15);
  EXPECT_EQ(converge(BaWorld(kBundler, 6, 30, 0.0, 8), true), 9);
}

TEST(BundleAdjusterTest, HuberKernelResistsOutliers) {
  const Reconstruction truth = BaWorld(kBundler, 8, 40, 0.0, 11);
  Reconstruction bad = truth;
  for (size_t o = 0; o < bad.observations.size(); o += 17)
    bad.observations[o].uv += Vector2(40, -30);
  auto point_error = [&](const Reconstruction& r) {
    // The estimate is defined up to a similarity: compare distances between points instead.
    double e = 0.0;
    for (size_t j = 1; j < r.points.size(); ++j) {
      e += std::abs((r.points[j].position - r.points[0].position).norm() -
                    (truth.points[j].position - truth.points[0].position).norm());
    }
    return e / static_cast<double>(r.points.size());
  };
  Reconstruction plain = bad, robust = bad;
  ASSERT_TRUE(BundleAdjust({.refine_intrinsics = false}, &plain).ok());
  BundleAdjusterParams params{.refine_intrinsics = false};
  params.robust = RobustKernel::Create(RobustKernel::Kind::kHuber, 1.0).value();
  const Result<BundleAdjusterSummary> s = BundleAdjust(params, &robust);
  ASSERT_TRUE(s.ok());
  // Ceres's cost: ½ Σ ρ(s), ρ linear beyond 1 px.
  double expected = 0.0;
  for (const SfmObservation& o : robust.observations) {
    const SfmImage& image = robust.images[o.image];
    const double sq =
        (Project(image.pose, std::get<Cal3Bundler>(robust.intrinsics[image.intrinsics].calibration),
                 robust.points[o.point].position)
             .uv -
         o.uv)
            .squaredNorm();
    expected += 0.5 * (sq <= 1.0 ? sq : 2.0 * std::sqrt(sq) - 1.0);
  }
  EXPECT_NEAR(s->final_cost, expected, 1e-9 * expected);
  EXPECT_LT(point_error(robust), 0.2 * point_error(plain));
}

TEST(BundleAdjusterTest, RejectsWhatItCannotAdjust) {
  Reconstruction empty = BaWorld(kBundler, 3, 4, 0.0, 12);
  empty.observations.clear();
  EXPECT_EQ(BundleAdjust({}, &empty).status().code(), StatusCode::kInvalidArgument);
  Reconstruction mixed = BaWorld(kBundler, 3, 4, 0.0, 13);
  mixed.intrinsics[1].calibration = Cal3_S2(500, 500, 0, 0, 0);
  const Status s = BundleAdjust({}, &mixed).status();
  EXPECT_NE(s.message().find("intrinsics 1"), std::string::npos) << s.ToString();
  Reconstruction bad_index = BaWorld(kBundler, 3, 4, 0.0, 14);
  bad_index.observations[0].point = 99;
  EXPECT_EQ(BundleAdjust({}, &bad_index).status().code(), StatusCode::kInvalidArgument);
  Reconstruction r = BaWorld(kBundler, 3, 4, 0.0, 15);
  const Status invalid = BundleAdjust({.num_threads = 0}, &r).status();
  EXPECT_NE(invalid.message().find("num_threads"), std::string::npos) << invalid.ToString();
}

}  // namespace
}  // namespace slamd::core
