// The batch solver's landmark elimination (BatchParams::Ordering): on a visual SLAM graph
// (odometry plus projections) kAuto eliminates the points first through the Schur complement and
// reaches the same optimum as plain COLAMD; with few landmarks it keeps COLAMD; a point seen
// once is named when the system is indeterminate.
#include <gtest/gtest.h>

#include "core/ba/reconstruction_graph.h"
#include "core/batch/batch_solver.h"
#include "core/factors/between_factor.h"
#include "core/factors/prior_factor.h"
#include "core/factors/projection_factor.h"
#include "tests/testing/ba_worlds.h"

namespace slamd::core {
namespace {

// Cameras of BaWorld with odometry between consecutive ones and a prior on the first: a robot
// driving a circle with a calibrated camera. The start is perturbed.
ReconstructionGraph VisualSlamGraph(int cameras, int points) {
  const Reconstruction truth =
      testing::BaWorld(Cal3_S2(400, 400, 0, 320, 240), cameras, points, 0.5, 21);
  Reconstruction start = truth;
  testing::BaPerturb(&start, 0.01, 0.05, 22);
  Result<ReconstructionGraph> built = BuildReconstructionGraph(start, {.refine_intrinsics = false});
  EXPECT_TRUE(built.ok()) << built.status().ToString();
  const NoiseModel odometry = NoiseModel::Isotropic(6, 0.02).value();
  for (int i = 0; i + 1 < cameras; ++i) {
    built->graph.Emplace<BetweenFactor<Pose3>>(
        built->images[i], built->images[i + 1],
        truth.images[i].pose.Between(truth.images[i + 1].pose), odometry);
  }
  built->graph.Emplace<PriorFactor<Pose3>>(built->images[0], truth.images[0].pose,
                                           NoiseModel::Isotropic(6, 1e-3).value());
  return std::move(built).value();
}

double MaxDifference(const Values& a, const Values& b) {
  double worst = 0.0;
  for (int s = 0; s < static_cast<int>(a.size()); ++s) {
    const Variable& va = a.VariableAt(s);
    const Variable& vb = b.Get(a.KeyAt(s));
    const Eigen::VectorXd d = LocalCoordinates(va, vb);
    worst = std::max(worst, d.cwiseAbs().maxCoeff());
  }
  return worst;
}

BatchResult Solve(const ReconstructionGraph& g, BatchParams::Ordering ordering) {
  return Optimize(g.graph, g.values,
                  {.ordering = ordering, .relative_tolerance = 1e-12, .absolute_tolerance = 0.0});
}

TEST(LandmarkEliminationTest, VisualSlamEliminatesPointsFirstAndMatchesColamd) {
  const ReconstructionGraph g = VisualSlamGraph(8, 60);
  const BatchResult schur = Solve(g, BatchParams::Ordering::kAuto);
  const BatchResult colamd = Solve(g, BatchParams::Ordering::kColamd);
  ASSERT_TRUE(schur.status.ok()) << schur.status.ToString();
  ASSERT_TRUE(colamd.status.ok()) << colamd.status.ToString();
  EXPECT_EQ(schur.summary.landmarks_first, 60);
  EXPECT_EQ(colamd.summary.landmarks_first, 0);
  EXPECT_LT(schur.summary.final_chi2, 1e-2 * schur.summary.initial_chi2);
  EXPECT_NEAR(schur.summary.final_chi2, colamd.summary.final_chi2,
              1e-9 * colamd.summary.final_chi2);
  EXPECT_LT(MaxDifference(schur.values, colamd.values), 1e-7);
}

TEST(LandmarkEliminationTest, FewLandmarksKeepColamdUnlessAsked) {
  const ReconstructionGraph g = VisualSlamGraph(12, 5);  // 5 points, 12 poses
  const BatchResult automatic = Solve(g, BatchParams::Ordering::kAuto);
  const BatchResult forced = Solve(g, BatchParams::Ordering::kLandmarksFirst);
  ASSERT_TRUE(automatic.status.ok()) << automatic.status.ToString();
  ASSERT_TRUE(forced.status.ok()) << forced.status.ToString();
  EXPECT_EQ(automatic.summary.landmarks_first, 0);
  EXPECT_EQ(forced.summary.landmarks_first, 5);
  EXPECT_LT(MaxDifference(automatic.values, forced.values), 1e-7);
}

// Nothing but points (each with its prior): nothing to reduce to, so COLAMD.
TEST(LandmarkEliminationTest, OnlyPointsKeepColamd) {
  FactorGraph graph;
  Values values;
  for (int j = 0; j < 4; ++j) {
    ASSERT_TRUE(values.Insert(MakeKey('l', j), Point3(j, 0, 0)).ok());
    graph.Emplace<PriorFactor<Point3>>(MakeKey('l', j), Point3(j, 1, 0),
                                       NoiseModel::Isotropic(3, 0.1).value());
  }
  for (auto ordering : {BatchParams::Ordering::kAuto, BatchParams::Ordering::kLandmarksFirst}) {
    const BatchResult r = Optimize(graph, values, {.ordering = ordering});
    ASSERT_TRUE(r.status.ok()) << r.status.ToString();
    EXPECT_EQ(r.summary.landmarks_first, 0);
    EXPECT_LT(r.summary.final_chi2, 1e-12);
  }
}

TEST(LandmarkEliminationTest, PointSeenOnceIsNamed) {
  ReconstructionGraph g = VisualSlamGraph(8, 30);
  const Key lonely = MakeKey('l', 999);
  ASSERT_TRUE(g.values.Insert(lonely, Point3(0.1, 0.2, 0.3)).ok());
  g.graph.Emplace<ProjectionFactor<Cal3_S2>>(g.images[0], lonely, Vector2(320, 240),
                                             Cal3_S2(400, 400, 0, 320, 240),
                                             NoiseModel::Isotropic(2, 1.0).value());
  const BatchResult gn =
      Optimize(g.graph, g.values, {.algorithm = BatchParams::Algorithm::kGaussNewton});
  ASSERT_FALSE(gn.status.ok());
  EXPECT_EQ(gn.status.code(), StatusCode::kNumericalFailure);
  EXPECT_NE(gn.status.message().find("landmark " + KeyToString(lonely)), std::string::npos)
      << gn.status.ToString();
}

}  // namespace
}  // namespace slamd::core
