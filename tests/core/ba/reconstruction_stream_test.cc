// A reconstruction replayed camera by camera: points enter once determined (views, parallax),
// every observation enters exactly once, and Isam2 fed the steps settles at the batch optimum of
// the same graph.
#include "core/ba/reconstruction_stream.h"

#include <gtest/gtest.h>

#include <algorithm>
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

TEST(ReconstructionStreamTest, PointsWaitForViewsAndParallaxImagesForPointsIn) {
  // Four cameras: 0 and 1 at the same centre (a pure rotation), 2 a metre to the side, 3 two
  // metres; five points 5 m ahead, seen by all four.
  const Cal3Bundler K(500.0, 0.0, 0.0);
  Reconstruction r;
  const Rot3 turned = Rot3::Exp(Vector3(0.0, 0.05, 0.0));
  r.images.push_back({.pose = Pose3(), .intrinsics = 0});
  r.images.push_back({.pose = Pose3(turned, Point3::Zero()), .intrinsics = 1});
  r.images.push_back({.pose = Pose3(Rot3(), Point3(1.0, 0.0, 0.0)), .intrinsics = 2});
  r.images.push_back({.pose = Pose3(Rot3(), Point3(2.0, 0.0, 0.0)), .intrinsics = 3});
  for (int i = 0; i < 4; ++i) r.intrinsics.push_back({.calibration = K});
  for (int j = 0; j < 5; ++j) {
    const Point3 X(0.2 * j, 0.1 * (j % 2), 5.0);
    r.points.push_back({.position = X});
    for (int i = 0; i < 4; ++i) {
      r.observations.push_back({.image = i, .point = j, .uv = Project(r.images[i].pose, K, X).uv});
    }
  }
  Result<ReconstructionStream> stream = ReconstructionStream::Create(r);
  ASSERT_TRUE(stream.ok());
  EXPECT_EQ(stream->Next().images_entered, std::vector<int>{0});
  // Camera 1 determines no point (no parallax with camera 0): held, and its observations.
  const ReconstructionStep second = stream->Next();
  EXPECT_TRUE(second.images_entered.empty());
  EXPECT_EQ(second.points_entered, 0);
  EXPECT_EQ(stream->held_images(), 1);
  EXPECT_EQ(stream->held_observations(), 10);
  // Camera 2 (11° from camera 0) determines all five: it registers, they enter with the views of
  // cameras 0 and 2, and camera 1, now seeing five points in, registers after them.
  const ReconstructionStep third = stream->Next();
  EXPECT_EQ(third.images_entered, (std::vector<int>{2, 1}));
  EXPECT_EQ(third.points_entered, 5);
  EXPECT_EQ(third.observations_entered, 15);
  EXPECT_EQ(stream->held_observations(), 0);
  EXPECT_EQ(stream->held_images(), 0);

  // Asking for three views: the initial pair's points still enter with its two (they fix the
  // scale); a point first seen after them waits for a third view.
  r.points.push_back({.position = Point3(0.3, -0.2, 6.0)});
  for (int i : {2, 3}) {
    r.observations.push_back(
        {.image = i, .point = 5, .uv = Project(r.images[i].pose, K, r.points[5].position).uv});
  }
  Result<ReconstructionStream> three = ReconstructionStream::Create(r, {.min_views = 3});
  ASSERT_TRUE(three.ok());
  for (int i = 0; i < 2; ++i) EXPECT_EQ(three->Next().points_entered, 0) << "step " << i;
  EXPECT_EQ(three->Next().points_entered, 5);
  EXPECT_EQ(three->Next().points_entered, 0);  // point 5: two views, held
  EXPECT_EQ(three->held_observations(), 2);
}

// Camera 2 shares points only with camera 0 and none already in: had it entered at its step, it
// would have brought a second scale nothing fixes (the update indeterminate, as a sim city's
// third image did). Cameras 1 m apart looking along +z; cluster A seen by cameras 0, 1 and 3,
// B by 0 and 2, C by 1, 2 and 3. Camera 2 waits for camera 3, which registers on A and
// determines C, through which camera 2 registers and B enters. Every update succeeds and the
// increments settle at the batch optimum of the same graph.
TEST(ReconstructionStreamTest, ACameraWhoseScaleNothingFixesWaitsUntilPointsInFixIt) {
  const Cal3Bundler K(500.0, 0.0, 0.0);
  Reconstruction r;
  for (int i = 0; i < 4; ++i) {
    r.images.push_back({.pose = Pose3(Rot3(), Point3(i, 0.0, 0.0)), .intrinsics = i});
    r.intrinsics.push_back({.calibration = K});
  }
  const std::vector<std::vector<int>> clusters = {{0, 1, 3}, {0, 2}, {1, 2, 3}};
  for (const std::vector<int>& seen_by : clusters) {
    for (int j = 0; j < 8; ++j) {
      const Point3 X(-0.5 + 0.5 * j, 0.3 * std::sin(j), 8.0 + 0.5 * (j % 3));
      r.points.push_back({.position = X});
      for (int i : seen_by) {
        r.observations.push_back({.image = i,
                                  .point = static_cast<int>(r.points.size()) - 1,
                                  .uv = Project(r.images[i].pose, K, X).uv});
      }
    }
  }
  testing::BaPerturb(&r, 0.002, 0.02, 5);
  Result<ReconstructionStream> stream =
      ReconstructionStream::Create(r, {.refine_intrinsics = false});
  ASSERT_TRUE(stream.ok());
  Result<std::unique_ptr<Isam2>> isam = Isam2::Create({});
  ASSERT_TRUE(isam.ok());
  FactorGraph graph;
  Values initial;
  std::vector<std::vector<int>> entered;
  for (int i = 0; i < stream->num_steps(); ++i) {
    const ReconstructionStep step = stream->Next();
    entered.push_back(step.images_entered);
    const Isam2Result u = (*isam)->Update(step.factors, step.values);
    ASSERT_TRUE(u.status.ok()) << "step " << i << ": " << u.status.ToString();
    for (const FactorPtr& f : step.factors) graph.Add(f);
    for (int s = 0; s < static_cast<int>(step.values.size()); ++s) {
      ASSERT_TRUE(initial.Insert(step.values.KeyAt(s), step.values.VariableAt(s)).ok());
    }
  }
  EXPECT_EQ(entered, (std::vector<std::vector<int>>{{0}, {1}, {}, {3, 2}}));
  EXPECT_EQ(stream->held_images(), 0);
  EXPECT_EQ(stream->held_observations(), 0);
  ASSERT_TRUE((*isam)->Refine(10.0).status.ok());
  const BatchResult batch = Optimize(graph, initial, {});
  ASSERT_TRUE(batch.status.ok()) << batch.status.ToString();
  const double settled = graph.Cost((*isam)->CalculateEstimate());
  EXPECT_NEAR(settled, batch.summary.final_cost, 1e-6 * (1.0 + batch.summary.final_cost));
}

// A dropped point's later observations are counted, not emitted; the point that fixes the scale
// cannot be dropped; ImagesSeeing lists only images in the graph.
TEST(ReconstructionStreamTest, ADroppedPointsLaterObservationsAreLeftOut) {
  const Reconstruction r = World();
  Result<ReconstructionStream> stream = ReconstructionStream::Create(r);
  ASSERT_TRUE(stream.ok());
  int step_index = 0, scale_point = -1;
  while (stream->points_in() == 0) {
    const ReconstructionStep step = stream->Next();
    ++step_index;
    for (const FactorPtr& f : step.factors) {
      if (f->keys().size() == 1 && KeySymbol(f->keys()[0]) == 'l') {  // the range prior
        scale_point = static_cast<int>(KeyIndex(f->keys()[0]));
      }
    }
  }
  ASSERT_GE(scale_point, 0);
  EXPECT_FALSE(stream->Droppable(scale_point));
  int dropped = -1;
  for (int j = 0; j < static_cast<int>(r.points.size()) && dropped < 0; ++j) {
    if (stream->Droppable(j)) dropped = j;
  }
  ASSERT_GE(dropped, 0);
  EXPECT_EQ(static_cast<int>(stream->ImagesSeeing(dropped).size()), step_index);
  stream->Drop(dropped);
  EXPECT_FALSE(stream->Droppable(dropped));
  int later = 0;  // the point's observations by the images still to come
  for (const SfmObservation& o : r.observations)
    later += o.point == dropped && o.image >= step_index;
  ASSERT_GT(later, 0);
  while (step_index < stream->num_steps()) {
    const ReconstructionStep step = stream->Next();
    ++step_index;
    for (const FactorPtr& f : step.factors) {
      for (Key key : f->keys()) EXPECT_NE(key, stream->keys().points[dropped]);
    }
  }
  EXPECT_EQ(stream->dropped_points(), 1);
  EXPECT_EQ(stream->dropped_observations(), later);
  EXPECT_EQ(
      static_cast<int>(stream->ImagesSeeing(dropped).size()),
      static_cast<int>(std::count_if(r.observations.begin(), r.observations.end(),
                                     [&](const SfmObservation& o) { return o.point == dropped; })));
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
  const Status registration =
      ReconstructionStream::Create(World(), {.min_registration_points = 2}).status();
  EXPECT_NE(registration.message().find("min_registration_points"), std::string::npos)
      << registration.ToString();
}

}  // namespace
}  // namespace slamd::core
