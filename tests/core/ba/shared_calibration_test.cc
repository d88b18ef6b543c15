// Calibrations shared by several images (a COLMAP camera per physical camera) refined by the
// bundle adjuster as the border of the reduced system (core/ba/calibration_border.h): the
// bordered step against a dense solve of the full damped normal equations with finite-difference
// Jacobians, the bordered product against the formed matrix, and every linear solver against the
// factor-graph batch solver's optimum on the same reconstruction (an independent implementation).
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "core/ba/border_elimination.h"
#include "core/ba/bundle_adjuster.h"
#include "core/ba/calibration_border.h"
#include "core/ba/camera_covariance.h"
#include "core/ba/reconstruction_graph.h"
#include "core/batch/batch_solver.h"
#include "tests/testing/ba_worlds.h"

namespace slamd::core {
namespace {

using testing::BaPerturb;
using testing::BaWorld;

// `cameras` images on BaWorld's circle, the first `first_group` through intrinsics 0 and the rest
// through intrinsics 1, whose calibrations start 2 % off the truth.
Reconstruction TwoCameraWorld(int cameras, int first_group, unsigned seed) {
  const Cal3Bundler truth(500.0, -0.05, 0.01);
  Reconstruction r = BaWorld(truth, cameras, 30, 0.5, seed);
  for (SfmImage& image : r.images) image.intrinsics = image.intrinsics < first_group ? 0 : 1;
  r.intrinsics.resize(2);
  r.intrinsics[0].calibration = Cal3Bundler(510.0, -0.04, 0.01);
  r.intrinsics[1].calibration = Cal3Bundler(492.0, -0.06, 0.012);
  BaPerturb(&r, 0.01, 0.05, seed + 1);
  return r;
}

// The Jacobian of every observation's pixel error by central differences over the stacked
// unknowns: each image's pose, each intrinsics' calibration (3), each point.
Eigen::MatrixXd SharedNumericalJacobian(const Reconstruction& r, Eigen::VectorXd* residuals_at_r) {
  const int n = static_cast<int>(r.images.size()), k = static_cast<int>(r.intrinsics.size());
  const int dim = 6 * n + 3 * k + 3 * static_cast<int>(r.points.size());
  const int m = 2 * static_cast<int>(r.observations.size());
  auto residuals = [&](const Eigen::VectorXd& d) {
    Eigen::VectorXd out(m);
    for (size_t o = 0; o < r.observations.size(); ++o) {
      const SfmObservation& obs = r.observations[o];
      const SfmImage& image = r.images[obs.image];
      const Pose3 pose = image.pose.Retract(d.segment<6>(6 * obs.image));
      const Cal3Bundler cal = std::get<Cal3Bundler>(r.intrinsics[image.intrinsics].calibration)
                                  .Retract(d.segment<3>(6 * n + 3 * image.intrinsics));
      const Point3 x = r.points[obs.point].position + d.segment<3>(6 * n + 3 * k + 3 * obs.point);
      out.segment<2>(2 * o) = Project(pose, cal, x).uv - obs.uv;
    }
    return out;
  };
  *residuals_at_r = residuals(Eigen::VectorXd::Zero(dim));
  return testing::CentralDifferences(residuals, dim);
}

TEST(SharedCalibrationTest, BorderedStepEqualsDenseSolveOfTheFullSystem) {
  const Reconstruction r = TwoCameraWorld(5, 3, 1);
  using Problem = internal::BaBorderedProblem<Cal3Bundler, false>;
  WorkerPool pool(1);  // two chunks: each sums its own part of the border
  Problem problem(r, RobustKernel(), {3, 0, 4, 1, 2}, &pool, {.shared = true});
  ASSERT_EQ(problem.shared_dim(), 6);
  problem.Linearize(Problem::StateOf(r));
  const double lambda = 1e-3;
  internal::ReducedCameraMatrix s(6, problem.CoVisibility());
  Eigen::VectorXd b, dc, dk;
  problem.EliminatePoints(lambda, &s, nullptr, &b);
  internal::CalibrationBorder border;
  problem.EliminateBorder(&border);
  const auto dense = [&](const Eigen::MatrixXd& rhs, Eigen::MatrixXd* x) {
    return s.SolveDense(rhs, x);
  };
  ASSERT_TRUE(internal::SolveBordered(dense, border, b, &dc, &dk).ok());
  std::vector<Vector3> dp;
  const double model = problem.BackSubstitute(dc, dk, &dp);

  Eigen::VectorXd residuals;
  const Eigen::MatrixXd J = SharedNumericalJacobian(r, &residuals);
  Eigen::MatrixXd H = J.transpose() * J;
  const Eigen::VectorXd g = J.transpose() * residuals;
  H.diagonal() += lambda * H.diagonal().cwiseMax(1e-6).cwiseMin(1e32);
  const Eigen::VectorXd delta = H.ldlt().solve(-g);
  const auto near = [](double a, double e) {
    return std::abs(a - e) <= 1e-5 * (1.0 + std::abs(e));
  };
  for (int i = 0; i < 5; ++i) {  // dc in positions order
    for (int c = 0; c < 6; ++c) {
      EXPECT_PRED2(near, dc[6 * problem.position(i) + c], delta[6 * i + c]) << "camera " << i;
    }
  }
  for (int c = 0; c < 6; ++c) EXPECT_PRED2(near, dk[c], delta[30 + c]) << "calibration " << c;
  for (size_t j = 0; j < r.points.size(); ++j) {
    for (int c = 0; c < 3; ++c) EXPECT_PRED2(near, dp[j][c], delta[36 + 3 * j + c]) << j;
  }
  // The model's decrease −(gᵀδ + ½|Jδ|²) of the undamped problem.
  const double expected_model = -(g.dot(delta) + 0.5 * (J * delta).squaredNorm());
  EXPECT_NEAR(model, expected_model, 1e-5 * std::abs(expected_model));

  // The bordered product against the formed [S E; Eᵀ F].
  const int n = s.dim(), m = border.dim();
  Eigen::MatrixXd full(n + m, n + m);
  full << s.ToDense(), border.e, border.e.transpose(), border.f;
  const Eigen::VectorXd v = Eigen::VectorXd::LinSpaced(n + m, -1.0, 2.0);
  Eigen::VectorXd product;
  internal::BorderedProduct(
      [&](const Eigen::VectorXd& x, Eigen::VectorXd* y) { problem.MultiplyReduced(x, y); }, border,
      v, &product);
  EXPECT_LT((product - full * v).norm(), 1e-9 * (full * v).norm());
}

TEST(SharedCalibrationTest, EveryLinearSolverReachesTheFactorGraphOptimum) {
  const Reconstruction start = TwoCameraWorld(8, 5, 3);
  Result<ReconstructionGraph> built = BuildReconstructionGraph(start);
  ASSERT_TRUE(built.ok()) << built.status().ToString();
  ASSERT_EQ(built->calibrations.size(), 2u);
  const BatchResult batch = Optimize(built->graph, built->values,
                                     {.relative_tolerance = 1e-12, .absolute_tolerance = 0.0});
  ASSERT_TRUE(batch.status.ok()) << batch.status.ToString();
  Reconstruction optimum = start;
  UpdateReconstruction(*built, batch.values, &optimum);
  for (BaLinearSolver solver : {BaLinearSolver::kDenseSchur, BaLinearSolver::kSparseSchur,
                                BaLinearSolver::kIterativeSchur}) {
    for (int threads : {1, 2}) {
      Reconstruction r = start;
      BundleAdjusterParams params{.linear_solver = solver, .num_threads = threads};
      params.cg_tolerance = 1e-8;
      params.function_tolerance = 1e-12;
      params.max_iterations = 100;
      const Result<BundleAdjusterSummary> s = BundleAdjust(params, &r);
      ASSERT_TRUE(s.ok()) << s.status().ToString();
      EXPECT_EQ(s->camera_block_dim, 6);
      EXPECT_EQ(s->shared_calibrations, 2);
      // The graph's cost is Σ |r|², twice Ceres's ½ Σ |r|².
      EXPECT_NEAR(s->final_cost, 0.5 * batch.summary.final_cost, 1e-6 * s->final_cost)
          << BaLinearSolverName(solver) << ", " << threads << " threads";
      for (int k = 0; k < 2; ++k) {
        const Vector3 got = std::get<Cal3Bundler>(r.intrinsics[k].calibration).vector();
        const Vector3 want = std::get<Cal3Bundler>(optimum.intrinsics[k].calibration).vector();
        EXPECT_LT((got - want).cwiseQuotient(want.cwiseAbs()).norm(), 1e-4)
            << "intrinsics " << k << ": " << got.transpose() << " against " << want.transpose();
      }
    }
  }
}

// COLMAP's models refine only what they can hold (no skew; one focal length for SIMPLE_PINHOLE),
// exactly, as WriteColmapText requires.
TEST(SharedCalibrationTest, ColmapModelsRefineWhatTheyCanWrite) {
  const Cal3_S2 truth(500.0, 500.0, 0.0, 320.0, 240.0);
  Reconstruction start = BaWorld(truth, 8, 30, 0.5, 21);
  for (SfmImage& image : start.images) image.intrinsics = 0;
  start.intrinsics.resize(1);
  start.intrinsics[0] = {.calibration = Cal3_S2(510.0, 510.0, 0.0, 322.0, 238.0),
                         .width = 640,
                         .height = 480,
                         .id = 1};
  BaPerturb(&start, 0.01, 0.05, 22);
  auto adjust = [&](const std::string& model, double* cost, bool principal_point = false) {
    Reconstruction r = start;
    r.intrinsics[0].model = model;
    const Result<BundleAdjusterSummary> s =
        BundleAdjust({.refine_principal_point = principal_point, .function_tolerance = 1e-12}, &r);
    EXPECT_TRUE(s.ok()) << s.status().ToString();
    *cost = s.ok() ? s->final_cost : -1.0;
    return std::get<Cal3_S2>(r.intrinsics[0].calibration);
  };
  double all_cost, free_cost, pinhole_cost, simple_cost;
  const Cal3_S2 all = adjust("", &all_cost, true);
  const Cal3_S2 free = adjust("", &free_cost);
  const Cal3_S2 pinhole = adjust("PINHOLE", &pinhole_cost);
  const Cal3_S2 simple = adjust("SIMPLE_PINHOLE", &simple_cost);
  EXPECT_NE(free.skew(), 0.0);  // the noise moves every free parameter
  EXPECT_NE(all.u0(), 322.0);
  EXPECT_NE(all.v0(), 238.0);
  for (const Cal3_S2& held : {free, pinhole, simple}) {  // the principal point only on request
    EXPECT_EQ(held.u0(), 322.0);
    EXPECT_EQ(held.v0(), 238.0);
  }
  EXPECT_EQ(pinhole.skew(), 0.0);
  EXPECT_NE(pinhole.fx(), pinhole.fy());
  EXPECT_EQ(simple.skew(), 0.0);
  EXPECT_EQ(simple.fx(), simple.fy());
  EXPECT_NE(simple.fx(), 510.0);  // refined
  // Fewer freedoms, a cost no lower.
  EXPECT_LE(all_cost, free_cost * (1.0 + 1e-9));
  EXPECT_LE(free_cost, pinhole_cost * (1.0 + 1e-9));
  EXPECT_LE(pinhole_cost, simple_cost * (1.0 + 1e-9));
}

// A parameter the model holds has no variance in the cameras' covariances.
TEST(SharedCalibrationTest, HeldParametersHaveNoVariance) {
  Reconstruction r = BaWorld(Cal3_S2(500.0, 500.0, 0.0, 320.0, 240.0), 6, 30, 0.5, 23);
  for (SfmIntrinsics& k : r.intrinsics) k.model = "PINHOLE";  // one per image
  ASSERT_TRUE(BundleAdjust({}, &r).ok());
  const Result<CameraCovariances> c = EstimateCameraCovariances(r, {});
  ASSERT_TRUE(c.ok()) << c.status().ToString();
  ASSERT_EQ(c->block_dim, 11);
  for (int i = 1; i < 6; ++i) {
    for (int held : {8, 9, 10}) {  // skew and principal point
      EXPECT_EQ(c->per_image[i](held, held), 0.0) << "parameter " << held << ", image " << i;
    }
    EXPECT_GT(c->per_image[i](6, 6), 0.0) << "fx of image " << i;
  }
}

// With shared calibrations the cameras' covariances include their uncertainty, and each shared
// calibration gets its own: the blocks of the dense inverse of the full JᵀJ (finite differences,
// the gauge and the parameter SIMPLE_RADIAL holds, k2, removed), in the dense and sparse paths.
TEST(SharedCalibrationTest, CovariancesEqualTheDenseInverseOfTheFullSystem) {
  Reconstruction r = TwoCameraWorld(6, 3, 31);
  r.intrinsics[1].model = "SIMPLE_RADIAL";
  ASSERT_TRUE(BundleAdjust({.max_iterations = 100}, &r).ok());
  const Result<CameraCovariances> dense = EstimateCameraCovariances(r, {});
  const Result<CameraCovariances> sparse = EstimateCameraCovariances(r, {}, 1.0, 0);
  ASSERT_TRUE(dense.ok()) << dense.status().ToString();
  ASSERT_TRUE(sparse.ok()) << sparse.status().ToString();
  ASSERT_EQ(dense->block_dim, 6);
  ASSERT_EQ(dense->per_intrinsics.size(), 2u);

  Eigen::VectorXd residuals;
  const Eigen::MatrixXd J = SharedNumericalJacobian(r, &residuals);
  const int n = 6, k2_of_1 = 6 * n + 3 + 2;
  std::vector<int> kept;
  for (int k = 0; k < J.cols(); ++k) {
    if (k < 6 || k == 6 * dense->scale_image + dense->scale_axis || k == k2_of_1) continue;
    kept.push_back(k);
  }
  Eigen::MatrixXd jk(J.rows(), kept.size());
  for (size_t a = 0; a < kept.size(); ++a) jk.col(a) = J.col(kept[a]);
  const Eigen::MatrixXd inverse = (jk.transpose() * jk).inverse();
  Eigen::MatrixXd full = Eigen::MatrixXd::Zero(J.cols(), J.cols());
  for (size_t a = 0; a < kept.size(); ++a) {
    for (size_t c = 0; c < kept.size(); ++c) full(kept[a], kept[c]) = inverse(a, c);
  }
  const auto expect_block = [](const Eigen::MatrixXd& got, const Eigen::MatrixXd& want,
                               const std::string& what) {
    EXPECT_LT((got - want).norm(), 1e-5 * want.norm() + 1e-12) << what << "\n"
                                                               << got << "\nexpected\n"
                                                               << want;
  };
  for (const CameraCovariances* c : {&*dense, &*sparse}) {
    const std::string path = c == &*dense ? "dense" : "sparse";
    for (int i = 0; i < n; ++i) {
      expect_block(c->per_image[i], full.block(6 * i, 6 * i, 6, 6),
                   path + " image " + std::to_string(i));
    }
    for (int k = 0; k < 2; ++k) {
      expect_block(c->per_intrinsics[k], full.block(6 * n + 3 * k, 6 * n + 3 * k, 3, 3),
                   path + " intrinsics " + std::to_string(k));
    }
    EXPECT_EQ(c->per_intrinsics[1](2, 2), 0.0);  // k2, held
  }
}

TEST(SharedCalibrationTest, HeldFixedWhenNotRefined) {
  Reconstruction r = TwoCameraWorld(5, 3, 9);
  const Result<BundleAdjusterSummary> s = BundleAdjust({.refine_intrinsics = false}, &r);
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  EXPECT_EQ(s->shared_calibrations, 0);
  EXPECT_EQ(std::get<Cal3Bundler>(r.intrinsics[0].calibration).f(), 510.0);
  EXPECT_EQ(std::get<Cal3Bundler>(r.intrinsics[1].calibration).f(), 492.0);
}

}  // namespace
}  // namespace slamd::core
