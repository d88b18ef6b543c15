// How bundle adjustment picks its linear solver (BaLinearSolver::kAuto, bundle_adjuster.cc):
// the block symbolic factorisation's flop count against a brute-force elimination of the block
// pattern, and the choice on the two shapes of co-visibility: a sequence (each point seen by a
// few neighbouring cameras: sparse Cholesky) and cameras all around an object (every pair of
// cameras shares points: conjugate gradients once S is too large for the dense solver).
#include <gtest/gtest.h>

#include <random>
#include <set>
#include <vector>

#include "core/ba/bundle_adjuster.h"
#include "core/ba/reduced_camera_matrix.h"
#include "tests/testing/ba_worlds.h"

namespace slamd::core {
namespace {

// Σ_j (c_j + 1)² D³ with c_j the blocks below the diagonal of column j of the factor, by
// eliminating a dense boolean matrix (fill: every pair of column j's rows becomes an entry).
double BruteForceFlops(int block_dim, const std::vector<std::vector<int>>& neighbours) {
  const int n = static_cast<int>(neighbours.size());
  std::vector<std::vector<bool>> a(n, std::vector<bool>(n, false));
  for (int i = 0; i < n; ++i) {
    for (int k : neighbours[i]) a[i][k] = a[k][i] = true;
  }
  const double d3 = static_cast<double>(block_dim) * block_dim * block_dim;
  double flops = 0.0;
  for (int j = 0; j < n; ++j) {
    std::vector<int> rows;
    for (int i = j + 1; i < n; ++i) {
      if (a[i][j]) rows.push_back(i);
    }
    for (int p : rows) {
      for (int q : rows) a[p][q] = true;
    }
    flops += (rows.size() + 1.0) * (rows.size() + 1.0) * d3;
  }
  return flops;
}

TEST(LinearSolverChoiceTest, BlockCholeskyFlopsMatchABruteForceElimination) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    const int n = 5 + trial * 3;
    const double density = 0.02 + 0.02 * (trial % 5);
    std::bernoulli_distribution edge(density);
    std::vector<std::vector<int>> neighbours(n);
    for (int i = 0; i < n; ++i) {
      neighbours[i].push_back(i);
      for (int k = i + 1; k < n; ++k) {
        if (edge(rng)) neighbours[i].push_back(k);
      }
    }
    EXPECT_EQ(internal::BlockCholeskyFlops(9, neighbours), BruteForceFlops(9, neighbours))
        << "trial " << trial;
  }
  // No fill: block diagonal, n D³; dense: Σ (n − j)² D³.
  const std::vector<std::vector<int>> diagonal = {{0}, {1}, {2}};
  EXPECT_EQ(internal::BlockCholeskyFlops(6, diagonal), 3.0 * 216.0);
  const std::vector<std::vector<int>> dense = {{0, 1, 2}, {1, 2}, {2}};
  EXPECT_EQ(internal::BlockCholeskyFlops(6, dense), (9.0 + 4.0 + 1.0) * 216.0);
}

// Cameras at x = 0, 1, ... looking along +y at points on the line y = 5 every half metre, each
// point seen by the cameras within a metre of it: S is a band.
Reconstruction Sequence(int num_cameras) {
  const Cal3Bundler cal(500.0, 0.0, 0.0);
  Reconstruction r;
  core::Matrix3 R;
  R.col(0) = Vector3(1.0, 0.0, 0.0);
  R.col(1) = Vector3(0.0, 0.0, -1.0);
  R.col(2) = Vector3(0.0, 1.0, 0.0);
  for (int i = 0; i < num_cameras; ++i) {
    r.images.push_back({.pose = Pose3(Rot3(R), Point3(i, 0.0, 0.0)), .intrinsics = i});
    r.intrinsics.push_back({.calibration = cal});
  }
  for (int j = 0; 0.5 * j <= num_cameras - 1; ++j) {
    const Point3 point(0.5 * j, 5.0, 0.3 * std::sin(j));
    r.points.push_back({.position = point});
    for (int i = 0; i < num_cameras; ++i) {
      if (std::abs(i - point.x()) > 1.0) continue;
      r.observations.push_back({.image = i,
                                .point = static_cast<int>(r.points.size()) - 1,
                                .uv = Project(r.images[i].pose, cal, point).uv});
    }
  }
  return r;
}

BaLinearSolver Chosen(Reconstruction r) {
  testing::BaPerturb(&r, 0.001, 0.01, 3);
  const Result<BundleAdjusterSummary> s = BundleAdjust({.max_iterations = 1}, &r);
  EXPECT_TRUE(s.ok()) << s.status().ToString();
  return s.ok() ? s.value().linear_solver : BaLinearSolver::kAuto;
}

TEST(LinearSolverChoiceTest, AutoPicksByTheWorkOfEachSolver) {
  const Cal3Bundler cal(500.0, -0.05, 0.01);
  // Few cameras: S is small, dense LLᵀ.
  EXPECT_EQ(Chosen(testing::BaWorld(cal, 8, 40, 0.5, 1)), BaLinearSolver::kDenseSchur);
  // 300 cameras x 9 unknowns: too large for the dense solver; a band factors cheaply.
  EXPECT_EQ(Chosen(Sequence(300)), BaLinearSolver::kSparseSchur);
  // 240 cameras around an object, each point seen by ~160 of them: assembling and factoring S
  // costs more than conjugate gradients' passes over the observations.
  EXPECT_EQ(Chosen(testing::BaWorld(cal, 240, 60, 0.5, 2)), BaLinearSolver::kIterativeSchur);
  // Above sparse_max_cameras: iterative whatever the pattern.
  Reconstruction short_sequence = Sequence(30);
  testing::BaPerturb(&short_sequence, 0.001, 0.01, 3);
  const Result<BundleAdjusterSummary> s =
      BundleAdjust({.sparse_max_cameras = 20, .max_iterations = 1}, &short_sequence);
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(s.value().linear_solver, BaLinearSolver::kIterativeSchur);
}

}  // namespace
}  // namespace slamd::core
