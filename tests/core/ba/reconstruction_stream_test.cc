// A reconstruction replayed camera by camera: points enter once determined (views, parallax),
// every observation enters exactly once, and Isam2 fed the steps settles at the batch optimum of
// the same graph.
#include "core/ba/reconstruction_stream.h"

#include <gtest/gtest.h>

#include <set>

#include "core/batch/batch_solver.h"
#include "core/factors/projection_factor.h"
#include "core/isam/isam2.h"
#include "tests/testing/ba_worlds.h"

namespace slamd::core {
namespace {

Reconstruction World() {
  Reconstruction r = testing::BaWorld(Cal3Bundler(500.0, 0.01, -0.002), 8, 40, 0.5, 31);
  testing::BaPerturb(&r, 0.01, 0.05, 32);
  return r;
}

TEST(ReconstructionStreamTest, EveryObservationEntersOnceWithItsVariables) {
  const Reconstruction r = World();
  Result<ReconstructionStream> stream = ReconstructionStream::Create(r);
  ASSERT_TRUE(stream.ok()) << stream.status().ToString();
  std::set<Key> known;
  int observations = 0, points = 0;
  for (int i = 0; i < stream->num_steps(); ++i) {
    const ReconstructionStep step = stream->Next();
    for (Key key : step.values.keys()) EXPECT_TRUE(known.insert(key).second) << KeyToString(key);
    for (const FactorPtr& f : step.factors) {
      for (Key key : f->keys()) EXPECT_TRUE(known.count(key)) << KeyToString(key) << " unknown";
    }
    if (i == 0) {
      EXPECT_EQ(step.points_entered, 0);  // one view determines nothing
    }
    observations += step.observations_entered;
    points += step.points_entered;
  }
  EXPECT_EQ(points, stream->points_in());
  EXPECT_EQ(observations + stream->held_observations(), static_cast<int>(r.observations.size()));
  EXPECT_EQ(points, static_cast<int>(r.points.size()));  // every point seen from the ring
  EXPECT_EQ(stream->held_observations(), 0);
}

TEST(ReconstructionStreamTest, Isam2SettlesAtTheBatchOptimumOfTheSameGraph) {
  Result<ReconstructionStream> stream = ReconstructionStream::Create(World());
  ASSERT_TRUE(stream.ok());
  Result<std::unique_ptr<Isam2>> isam = Isam2::Create();
  ASSERT_TRUE(isam.ok());
  FactorGraph graph;
  Values initial;
  for (int i = 0; i < stream->num_steps(); ++i) {
    const ReconstructionStep step = stream->Next();
    const Isam2Result u = (*isam)->Update(step.factors, step.values);
    ASSERT_TRUE(u.status.ok()) << "image " << i << ": " << u.status.ToString();
    for (const FactorPtr& f : step.factors) graph.Add(f);
    for (int s = 0; s < static_cast<int>(step.values.size()); ++s) {
      ASSERT_TRUE(initial.Insert(step.values.KeyAt(s), step.values.VariableAt(s)).ok());
    }
  }
  (*isam)->Refine(10.0);
  const BatchResult batch =
      Optimize(graph, initial, {.relative_tolerance = 1e-12, .absolute_tolerance = 0.0});
  ASSERT_TRUE(batch.status.ok()) << batch.status.ToString();
  const double settled = graph.Cost((*isam)->CalculateEstimate());
  EXPECT_LT(batch.summary.final_cost, 0.1 * batch.summary.initial_cost);
  EXPECT_NEAR(settled, batch.summary.final_cost, 1e-6 * batch.summary.final_cost);
}

TEST(ReconstructionStreamTest, PointsWaitForViewsAndParallax) {
  // Three cameras: 0 and 1 at the same centre (a pure rotation), 2 a metre to the side.
  const Cal3Bundler K(500.0, 0.0, 0.0);
  Reconstruction r;
  for (int i = 0; i < 3; ++i) r.intrinsics.push_back({.calibration = K});
  const Point3 X(0.0, 0.0, 5.0);
  const Rot3 turned = Rot3::Exp(Vector3(0.0, 0.05, 0.0));
  r.images.push_back({.pose = Pose3(), .intrinsics = 0});
  r.images.push_back({.pose = Pose3(turned, Point3::Zero()), .intrinsics = 1});
  r.images.push_back({.pose = Pose3(Rot3(), Point3(1.0, 0.0, 0.0)), .intrinsics = 2});
  r.points.push_back({.position = X});
  for (int i = 0; i < 3; ++i) {
    r.observations.push_back({.image = i, .point = 0, .uv = Project(r.images[i].pose, K, X).uv});
  }
  Result<ReconstructionStream> stream = ReconstructionStream::Create(r);
  ASSERT_TRUE(stream.ok());
  EXPECT_EQ(stream->Next().points_entered, 0);
  EXPECT_EQ(stream->Next().points_entered, 0);  // two views, no parallax
  EXPECT_EQ(stream->held_observations(), 2);
  const ReconstructionStep third = stream->Next();  // 11° from camera 2
  EXPECT_EQ(third.points_entered, 1);
  EXPECT_EQ(third.observations_entered, 3);
  EXPECT_EQ(stream->held_observations(), 0);

  // Asking for three views: the same point waits for the third either way.
  Result<ReconstructionStream> three = ReconstructionStream::Create(r, {.min_views = 3});
  ASSERT_TRUE(three.ok());
  EXPECT_EQ(three->Next().points_entered + three->Next().points_entered, 0);
  EXPECT_EQ(three->Next().points_entered, 1);
}

TEST(ReconstructionStreamTest, FixedIntrinsicsAddNoCalibrationVariables) {
  const Reconstruction r = World();
  Result<ReconstructionStream> stream =
      ReconstructionStream::Create(r, {.refine_intrinsics = false});
  ASSERT_TRUE(stream.ok());
  int observations = 0;
  for (int i = 0; i < stream->num_steps(); ++i) {
    const ReconstructionStep step = stream->Next();
    for (Key key : step.values.keys()) EXPECT_NE(KeyToString(key)[0], 'k') << KeyToString(key);
    for (const FactorPtr& f : step.factors) {
      if (f->keys().size() == 2 && KeyToString(f->keys()[1])[0] == 'l') {
        EXPECT_NE(dynamic_cast<const ProjectionFactor<Cal3Bundler>*>(f.get()), nullptr);
        ++observations;
      }
    }
  }
  EXPECT_EQ(observations, static_cast<int>(r.observations.size()));
}

TEST(ReconstructionStreamTest, RejectsBadParams) {
  const Status views = ReconstructionStream::Create(World(), {.min_views = 1}).status();
  EXPECT_EQ(views.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(views.message().find("min_views"), std::string::npos) << views.ToString();
  EXPECT_FALSE(ReconstructionStream::Create(World(), {.anchor_sigma = 0.0}).ok());
}

}  // namespace
}  // namespace slamd::core
