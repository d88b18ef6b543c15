// A reconstruction as a factor graph: its cost is twice the bundle adjuster's (an independent
// implementation), the batch solver on it reaches the adjuster's optimum through the landmark
// elimination, and the estimate goes back into the reconstruction.
#include "core/ba/reconstruction_graph.h"

#include <gtest/gtest.h>

#include "core/ba/bundle_adjuster.h"
#include "core/batch/batch_solver.h"
#include "core/factors/projection_factor.h"
#include "tests/testing/ba_worlds.h"

namespace slamd::core {
namespace {

using testing::BaPerturb;
using testing::BaWorld;

Reconstruction PerturbedWorld() {
  Reconstruction r = BaWorld(Cal3Bundler(500.0, 0.01, -0.002), 6, 40, 0.5, 11);
  BaPerturb(&r, 0.01, 0.05, 12);
  return r;
}

TEST(ReconstructionGraphTest, CostIsTwiceTheAdjustersAndBatchReachesItsOptimum) {
  const Reconstruction start = PerturbedWorld();
  Result<ReconstructionGraph> built = BuildReconstructionGraph(start);
  ASSERT_TRUE(built.ok()) << built.status().ToString();
  EXPECT_EQ(built->graph.size(), start.observations.size());
  EXPECT_EQ(built->values.size(),
            start.images.size() + start.points.size() + start.intrinsics.size());

  Reconstruction adjusted = start;
  Result<BundleAdjusterSummary> ba = BundleAdjust({.function_tolerance = 1e-12}, &adjusted);
  ASSERT_TRUE(ba.ok()) << ba.status().ToString();
  EXPECT_NEAR(built->graph.Cost(built->values), 2.0 * ba->initial_cost, 1e-9 * ba->initial_cost);

  const BatchResult batch = Optimize(built->graph, built->values,
                                     {.relative_tolerance = 1e-12, .absolute_tolerance = 0.0});
  ASSERT_TRUE(batch.status.ok()) << batch.status.ToString();
  EXPECT_EQ(batch.summary.landmarks_first, static_cast<int>(start.points.size()));
  EXPECT_NEAR(batch.summary.final_cost, 2.0 * ba->final_cost, 1e-6 * ba->final_cost);

  // Written back, the estimate has the cost the solver reported.
  Reconstruction solved = start;
  UpdateReconstruction(*built, batch.values, &solved);
  Result<ReconstructionGraph> again = BuildReconstructionGraph(solved);
  ASSERT_TRUE(again.ok());
  EXPECT_NEAR(again->graph.Cost(again->values), batch.summary.final_cost,
              1e-9 * batch.summary.final_cost);
  EXPECT_NE(std::get<Cal3Bundler>(solved.intrinsics[0].calibration).vector(),
            std::get<Cal3Bundler>(start.intrinsics[0].calibration).vector());
}

// A calibration variable refines every parameter: a model that cannot write them all back
// (SIMPLE_RADIAL has no k2) is held, one that can (RADIAL) is a variable.
TEST(ReconstructionGraphTest, CalibrationsWhoseModelCannotHoldEveryParameterAreHeld) {
  Reconstruction start = PerturbedWorld();
  start.intrinsics[0].model = "SIMPLE_RADIAL";
  start.intrinsics[1].model = "RADIAL";
  Result<ReconstructionGraph> built = BuildReconstructionGraph(start);
  ASSERT_TRUE(built.ok());
  ASSERT_EQ(built->calibrations.size(), start.intrinsics.size());
  EXPECT_FALSE(built->calibrations[0].has_value());
  EXPECT_TRUE(built->calibrations[1].has_value());
  EXPECT_EQ(built->values.size(),
            start.images.size() + start.points.size() + start.intrinsics.size() - 1);
  for (const SfmObservation& o : start.observations) {  // in order: one factor each
    const Factor* f = built->graph[&o - start.observations.data()].get();
    const bool held = start.images[o.image].intrinsics == 0;
    EXPECT_EQ(dynamic_cast<const ProjectionFactor<Cal3Bundler>*>(f) != nullptr, held);
  }
}

TEST(ReconstructionGraphTest, FixedIntrinsicsUseFixedCalibrationFactors) {
  const Reconstruction start = PerturbedWorld();
  Result<ReconstructionGraph> built = BuildReconstructionGraph(start, {.refine_intrinsics = false});
  ASSERT_TRUE(built.ok());
  EXPECT_TRUE(built->calibrations.empty());
  EXPECT_EQ(built->values.size(), start.images.size() + start.points.size());
  EXPECT_NE(dynamic_cast<const ProjectionFactor<Cal3Bundler>*>(built->graph[0].get()), nullptr);

  Reconstruction adjusted = start;
  Result<BundleAdjusterSummary> ba =
      BundleAdjust({.refine_intrinsics = false, .function_tolerance = 1e-12}, &adjusted);
  ASSERT_TRUE(ba.ok());
  const BatchResult batch = Optimize(built->graph, built->values,
                                     {.relative_tolerance = 1e-12, .absolute_tolerance = 0.0});
  ASSERT_TRUE(batch.status.ok()) << batch.status.ToString();
  EXPECT_NEAR(batch.summary.final_cost, 2.0 * ba->final_cost, 1e-6 * ba->final_cost);
}

TEST(ReconstructionGraphTest, RejectsBadParamsAndReconstructions) {
  Reconstruction r = PerturbedWorld();
  Result<ReconstructionGraph> bad_sigma = BuildReconstructionGraph(r, {.pixel_sigma = 0.0});
  ASSERT_FALSE(bad_sigma.ok());
  EXPECT_NE(bad_sigma.status().message().find("pixel_sigma"), std::string::npos);
  r.observations[3].point = static_cast<int>(r.points.size());
  EXPECT_EQ(BuildReconstructionGraph(r).status().code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace slamd::core
