#include "core/ba/point_initialization.h"

#include <gtest/gtest.h>

#include "core/ba/bundle_adjuster.h"
#include "tests/testing/ba_worlds.h"

namespace slamd::core {
namespace {

// Points without a usable start (at the origin far off their rays, or behind the cameras) are
// triangulated again, the others kept, and bundle adjustment from there reaches the optimum it
// reaches from the true points.
TEST(PointInitializationTest, PoorPointsAreTriangulatedAgain) {
  const Reconstruction truth = testing::BaWorld(Cal3Bundler(500.0, -0.05, 0.01), 8, 30, 0.5, 31);
  Reconstruction r = truth;
  r.points[3].position = Point3(0.0, 0.0, 40.0);    // far off every ray
  r.points[7].position = Point3(30.0, -20.0, 5.0);  // behind several of its cameras
  const Point3 kept = r.points[5].position;
  const Result<PointInitializationReport> report = RetriangulatePoorPoints(&r);
  ASSERT_TRUE(report.ok()) << report.status().ToString();
  EXPECT_EQ(report->poor, 2);
  EXPECT_EQ(report->replaced, 2);
  EXPECT_EQ(r.points[5].position, kept);
  for (int j : {3, 7}) {
    EXPECT_LT((r.points[j].position - truth.points[j].position).norm(), 0.05) << "point " << j;
  }
  Reconstruction from_truth = truth;
  const Result<BundleAdjusterSummary> a = BundleAdjust({}, &r);
  const Result<BundleAdjusterSummary> b = BundleAdjust({}, &from_truth);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_NEAR(a->final_cost, b->final_cost, 1e-6 * b->final_cost);
}

TEST(PointInitializationTest, RejectsBadArguments) {
  Reconstruction r = testing::BaWorld(Cal3Bundler(500.0, 0.0, 0.0), 3, 5, 0.0, 32);
  EXPECT_EQ(RetriangulatePoorPoints(&r, 0.0).status().code(), StatusCode::kInvalidArgument);
  r.observations[0].image = 9;
  EXPECT_EQ(RetriangulatePoorPoints(&r).status().code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace slamd::core
