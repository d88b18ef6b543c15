// A simulated camera world streamed image by image (mono and stereo) into an estimator: every
// message taken, the landmarks entering by the lifecycle rule, and the estimate settling at the
// batch optimum of the same graph.
#include "clients/slamctl/reconstruction_messages.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <variant>

#include "clients/slamctl/sim_camera_world.h"
#include "tests/testing/stream_estimator.h"

namespace slamd::clients {
namespace {

// Refines to convergence, then compares the estimator's chi2 with the batch optimum of its own
// graph (its factors, from its estimate).
void ExpectSettlesAtTheBatchOptimum(server::Estimator& e) {
  for (int i = 0; i < 200 && !e.snapshot()->settled; ++i) e.Refine(1.0);
  ASSERT_TRUE(e.snapshot()->settled);
  const double optimum = testing::BatchOptimumChi2(e);
  EXPECT_NEAR(e.solver().Chi2(), optimum, 1e-4 * optimum);
}

// The initial guess (what the odometry is made of) as a visual odometry front end would give
// it: 1 cm and 1 mrad per image. A 0.6 m stereo baseline: with 0.3 m, a landmark placed by one
// noisy stereo view 4 m away is ±0.1 m deep (1σ), and a later view from another side can see
// it beyond EstimatorParams::max_landmark_error_px.
sim::CameraWorld World(bool stereo) {
  return sim::GenerateCameraWorld({.world = sim::CameraWorldKind::kObject,
                                   .seed = 3,
                                   .cameras = 16,
                                   .points = 300,
                                   .init_sigma_camera = 0.01,
                                   .init_sigma_rotation = 0.001,
                                   .stereo = stereo,
                                   .baseline = 0.6})
      .value();
}

TEST(ReconstructionMessages, AMonoWorldStreamsInAndSettlesAtTheBatchOptimum) {
  const sim::CameraWorld world = World(false);
  const auto steps = MakeReconstructionMessages(world.initial, {.robot = "cam"});
  ASSERT_TRUE(steps.ok()) << steps.status().message();
  ASSERT_EQ(steps->size(), world.initial.images.size());
  // Image 0: camera, prior, frame; the others: odometry and frame (one camera for all).
  EXPECT_TRUE(std::holds_alternative<slamd::camera_info_t>(steps->front().messages[0]));
  EXPECT_TRUE(std::holds_alternative<slamd::odometry_t>((*steps)[1].messages[0]));
  testing::StreamedEstimator s = testing::StreamSteps(*steps);
  EXPECT_TRUE(s.rejections.empty());
  EXPECT_EQ(s.features, static_cast<int>(world.initial.observations.size()));
  // Every point is seen twice or more: what never got enough parallax waits in a track.
  EXPECT_GE(s.features - s.estimator->tracks().num_observations(), 0.95 * s.features);
  ExpectSettlesAtTheBatchOptimum(*s.estimator);
}

TEST(ReconstructionMessages, WithTheTrustRegionAMonoWorldSettlesAtTheBatchOptimum) {
  const auto steps = MakeReconstructionMessages(World(false).initial, {.robot = "cam"});
  ASSERT_TRUE(steps.ok()) << steps.status().message();
  core::Isam2Params isam2;
  isam2.trust_region.enabled = true;
  testing::StreamedEstimator s = testing::StreamSteps(*steps, isam2);
  EXPECT_TRUE(s.rejections.empty());
  ExpectSettlesAtTheBatchOptimum(*s.estimator);
}

TEST(ReconstructionMessages, AStereoWorldStreamsInAndSettlesAtTheBatchOptimum) {
  const sim::CameraWorld world = World(true);
  ReconstructionMessageOptions options{.robot = "cam", .baseline = 0.6};
  for (const sim::StereoObservation& o : world.stereo)
    options.stereo.push_back({o.observation, o.uuv});
  ASSERT_FALSE(options.stereo.empty());
  const auto steps = MakeReconstructionMessages(world.initial, options);
  ASSERT_TRUE(steps.ok()) << steps.status().message();
  const auto& first = std::get<slamd::camera_info_t>(steps->front().messages[0]);
  EXPECT_EQ(first.model, slamd::camera_info_t::MODEL_STEREO);
  testing::StreamedEstimator s = testing::StreamSteps(*steps);
  EXPECT_TRUE(s.rejections.empty());
  EXPECT_EQ(s.features, static_cast<int>(world.initial.observations.size()));
  EXPECT_GE(s.features - s.estimator->tracks().num_observations(), 0.95 * s.features);
  ExpectSettlesAtTheBatchOptimum(*s.estimator);
}

TEST(ReconstructionMessages, BadOptionsAreRefused) {
  const sim::CameraWorld world = World(false);
  EXPECT_FALSE(MakeReconstructionMessages(world.initial, {.robot = "a b"}).ok());
  EXPECT_FALSE(MakeReconstructionMessages(world.initial, {.pixel_sigma = 0.0}).ok());
  ReconstructionMessageOptions stereo{.baseline = 0.3};
  stereo.stereo.push_back(
      {static_cast<int>(world.initial.observations.size()), core::Vector3(300.0, 290.0, 200.0)});
  EXPECT_FALSE(MakeReconstructionMessages(world.initial, stereo).ok());
}

}  // namespace
}  // namespace slamd::clients
