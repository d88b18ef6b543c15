// Camera landmarks in the estimator: camera_info_t and frame_observations_t, landmarks held in
// tracks until their views determine them, then triangulated into the graph.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "core/geometry/camera.h"
#include "server/estimator/estimator.h"
#include "server/snapshot/state_codec.h"
#include "tests/server/estimator/camera_test_messages.h"
#include "tests/server/estimator/estimator_test_messages.h"

namespace slamd::server {
namespace {

using core::Point3;
using core::Pose3;
using core::Rot3;
using estimator_test::Make;
using namespace camera_test;  // NOLINT: the camera messages of these tests
using ::slamd::testing::Noise;

bool InGraph(const Estimator& e, core::Key key) {
  return e.solver().linearization_point().Contains(key);
}
core::Key L(std::uint64_t id) { return core::MakeKey('l', id, 'a'); }

Point3 LandmarkEstimate(const Estimator& e, core::Key key) {
  return std::get<Point3>(e.solver().CalculateEstimate(key));
}

TEST(CameraLandmarks, AMonoLandmarkWaitsForParallaxThenEntersTriangulated) {
  auto e = Make();
  ASSERT_TRUE(e->Process(Robot("r", 3)).status.ok());
  ProcessResult r = e->Process({Frame("r", 0, BodyPose(0), {{1, kP1}, {2, kP2}})});
  EXPECT_TRUE(r.rejections.empty());
  EXPECT_EQ(e->tracks().num_tracks(), 2);  // one view each: not determined
  EXPECT_FALSE(InGraph(*e, L(1)));
  r = e->Process({Frame("r", 1, BodyPose(1), {{1, kP1}, {2, kP2}})});
  ASSERT_TRUE(r.status.ok());
  EXPECT_TRUE(r.rejections.empty());
  EXPECT_EQ(e->tracks().num_tracks(), 0);  // 0.5 m at 5-6 m: 5 deg of parallax
  ASSERT_TRUE(InGraph(*e, L(1)) && InGraph(*e, L(2)));
  EXPECT_LT((LandmarkEstimate(*e, L(1)) - kP1).norm(), 1e-6);
  EXPECT_LT((LandmarkEstimate(*e, L(2)) - kP2).norm(), 1e-6);
  EXPECT_EQ(e->snapshot()->num_factors, 3 + 4);  // prior, 2 odometry, 4 projections
  // A third view of a landmark in the graph is one more factor.
  r = e->Process({Frame("r", 2, BodyPose(2), {{1, kP1}})});
  EXPECT_EQ(r.applied, 1);
  EXPECT_EQ(e->snapshot()->num_factors, 8);
}

TEST(CameraLandmarks, OneStereoViewDeterminesALandmark) {
  auto e = Make();
  ASSERT_TRUE(e->Process(Robot("r", 1, 0.5)).status.ok());
  const ProcessResult r = e->Process({Frame("r", 0, BodyPose(0), {{3, kP3}}, true)});
  ASSERT_TRUE(r.status.ok());
  EXPECT_TRUE(r.rejections.empty());
  ASSERT_TRUE(InGraph(*e, L(3)));
  EXPECT_LT((LandmarkEstimate(*e, L(3)) - kP3).norm(), 1e-6);
}

TEST(CameraLandmarks, AnUndeterminedLandmarkIsDroppedWithTheReason) {
  auto e = Make({.chi2_interval_s = 0.0, .landmark_max_wait_updates = 3});
  ASSERT_TRUE(e->Process(Robot("r", 1)).status.ok());
  ASSERT_TRUE(e->Process({Frame("r", 0, BodyPose(0), {{1, kP1}})}).rejections.empty());
  std::vector<Rejection> rejections;
  for (int i = 0; i < 4 && rejections.empty(); ++i) rejections = e->Process({}).rejections;
  ASSERT_EQ(rejections.size(), 1u);
  EXPECT_EQ(rejections[0].verdict.reason, RejectReason::kOutOfOrderTimeout);
  EXPECT_NE(rejections[0].verdict.message.find("landmark 1 of robot 'r'"), std::string::npos)
      << rejections[0].verdict.message;
  EXPECT_NE(rejections[0].verdict.message.find("1 view(s)"), std::string::npos);
  EXPECT_EQ(std::string(MessageTypeName(rejections[0].message)), "frame_observations_t");
  EXPECT_EQ(e->tracks().num_tracks(), 0);
  EXPECT_EQ(e->snapshot()->counters.landmarks_dropped, 1);
}

TEST(CameraLandmarks, PureRotationAndADistantPointGiveNoParallax) {
  auto e = Make();
  // Pose 1 turns in place by 10 degrees: no baseline.
  const Pose3 turned(Rot3::FromRollPitchYaw(0, 0, 0.17), BodyPose(0).translation());
  ASSERT_TRUE(e->Process({Camera("r"), PriorAt0("r"), Odo3("r", 0, 1, BodyPose(0), turned),
                          Odo3("r", 1, 2, turned, BodyPose(1))})
                  .status.ok());
  const Point3 far(400.0, 1.0, 0.0);  // 0.5 m of baseline at 400 m: 0.07 deg
  ASSERT_TRUE(e->Process({Frame("r", 0, BodyPose(0), {{1, kP1}, {2, far}})}).status.ok());
  ASSERT_TRUE(e->Process({Frame("r", 1, turned, {{1, kP1}})}).status.ok());
  EXPECT_FALSE(InGraph(*e, L(1)));
  EXPECT_NE(e->tracks().Find(L(1))->why.find("parallax"), std::string::npos);
  ASSERT_TRUE(e->Process({Frame("r", 2, BodyPose(1), {{1, kP1}, {2, far}})}).status.ok());
  EXPECT_TRUE(InGraph(*e, L(1)));  // the translated view gives it parallax
  EXPECT_FALSE(InGraph(*e, L(2)));
  EXPECT_NE(e->tracks().Find(L(2))->why.find("parallax"), std::string::npos);
}

TEST(CameraLandmarks, ALandmarkBehindACameraNeverEnters) {
  auto e = Make();
  ASSERT_TRUE(e->Process(Robot("r", 2)).status.ok());
  ASSERT_TRUE(e->Process({Frame("r", 0, BodyPose(0), {{1, kP1}})}).status.ok());
  // Pose 1 reports the pixel of a point on pose 0's ray but behind both cameras: the two rays
  // meet there, and nowhere in front.
  const Point3 c0 = (BodyPose(0) * kMount).translation();
  const Point3 behind = c0 - (kP1 - c0);
  FrameObservations f =
      std::get<FrameObservations>(Frame("r", 1, BodyPose(1), {{1, kP1}}).measurement);
  f.features[0].uv = core::Project(BodyPose(1) * kMount, kCamK, behind).uv;
  ASSERT_TRUE(kCamK.vector().allFinite() && f.features[0].uv.x() >= 0 &&
              f.features[0].uv.x() < 640 && f.features[0].uv.y() >= 0 &&
              f.features[0].uv.y() < 480);
  ASSERT_TRUE(e->Process({{f, 0}}).status.ok());
  EXPECT_FALSE(InGraph(*e, L(1)));
  ASSERT_NE(e->tracks().Find(L(1)), nullptr);
  EXPECT_NE(e->tracks().Find(L(1))->why.find("behind"), std::string::npos)
      << e->tracks().Find(L(1))->why;
}

TEST(CameraLandmarks, AMovingOutlierIsRejectedByItsFeatureAlone) {
  auto e = Make();
  ASSERT_TRUE(e->Process(Robot("r", 3)).status.ok());
  ASSERT_TRUE(e->Process({Frame("r", 0, BodyPose(0), {{1, kP1}, {2, kP2}})}).status.ok());
  ASSERT_TRUE(e->Process({Frame("r", 1, BodyPose(1), {{1, kP1}, {2, kP2}})}).status.ok());
  ASSERT_TRUE(InGraph(*e, L(1)));
  // Landmark 1 moved by 2 m (a car): 100+ px off; landmark 2 is fine.
  const ProcessResult r =
      e->Process({Frame("r", 2, BodyPose(2), {{2, kP2}, {1, kP1 + core::Vector3(0, 2, 0)}})});
  EXPECT_EQ(r.applied, 1);
  ASSERT_EQ(r.rejections.size(), 1u);
  EXPECT_EQ(r.rejections[0].verdict.reason, RejectReason::kBadMeasurement);
  EXPECT_NE(r.rejections[0].verdict.message.find("frame_observations_t.values[2]: landmark 1"),
            std::string::npos)
      << r.rejections[0].verdict.message;
  EXPECT_NE(r.rejections[0].verdict.message.find("max_landmark_error_px"), std::string::npos);
  EXPECT_LT((LandmarkEstimate(*e, L(1)) - kP1).norm(), 1e-6);
}

TEST(CameraLandmarks, PixelsOutsideTheImageAreRejectedOneByOne) {
  auto e = Make();
  ASSERT_TRUE(e->Process(Robot("r", 1)).status.ok());
  Inbound in = Frame("r", 0, BodyPose(0), {{1, kP1}, {2, kP2}});
  std::get<FrameObservations>(in.measurement).features[1].uv.x() = 700.0;
  const ProcessResult r = e->Process({in});
  ASSERT_EQ(r.rejections.size(), 1u);
  EXPECT_NE(r.rejections[0].verdict.message.find("values[2]: landmark 2: the pixel is outside"),
            std::string::npos)
      << r.rejections[0].verdict.message;
  EXPECT_EQ(e->tracks().num_tracks(), 1);
}

TEST(CameraLandmarks, AFrameWaitsForItsCameraAndPose) {
  auto e = Make();
  ASSERT_TRUE(e->Process({PriorAt0("r")}).status.ok());
  ProcessResult r = e->Process({Frame("r", 0, BodyPose(0), {{3, kP3}}, true)});
  EXPECT_TRUE(r.rejections.empty());
  EXPECT_EQ(e->held_messages(), 1);
  r = e->Process({Camera("r", 0.5)});
  EXPECT_EQ(e->held_messages(), 0);
  EXPECT_TRUE(InGraph(*e, L(3)));
}

TEST(CameraLandmarks, ARecalibrationAppliesFromItsPoseOn) {
  auto e = Make();
  ASSERT_TRUE(e->Process(Robot("r", 3)).status.ok());
  Inbound recal = Camera("r", 0.0, 2);
  std::get<CameraInfo>(recal.measurement).camera.width = 320;
  ASSERT_TRUE(e->Process({recal}).status.ok());
  EXPECT_EQ(e->cameras().Find('a', 0, 1)->width, 640);
  EXPECT_EQ(e->cameras().Find('a', 0, 2)->width, 320);
  // The same values again are held already; other values for the same pose are a duplicate.
  EXPECT_TRUE(e->Process({recal}).rejections.empty());
  std::get<CameraInfo>(recal.measurement).camera.width = 300;
  EXPECT_EQ(estimator_test::OnlyRejection(e->Process({recal})), RejectReason::kDuplicate);
}

TEST(CameraLandmarks, RobotsShareLandmarksOfTheMapNamespace) {
  auto e = Make();
  std::vector<Inbound> batch = Robot("a", 1);
  batch.push_back(Camera("b"));
  batch.push_back(PriorAt0("b", BodyPose(1)));
  ASSERT_TRUE(e->Process(batch).status.ok());
  ASSERT_TRUE(
      e->Process({Frame("a", 0, BodyPose(0), {{7, kP1}}, false, 0.0, LandmarkNamespace::kMap)})
          .status.ok());
  ASSERT_TRUE(
      e->Process({Frame("b", 0, BodyPose(1), {{7, kP1}}, false, 0.0, LandmarkNamespace::kMap)})
          .status.ok());
  const core::Key shared = core::MakeKey('m', 7, 0);
  ASSERT_TRUE(InGraph(*e, shared));
  EXPECT_LT((LandmarkEstimate(*e, shared) - kP1).norm(), 1e-6);
  // On the wire it is the map landmark 7 of no robot, not a landmark of either robot.
  EXPECT_EQ(e->KeyOf({.robot = "", .kind = KeyKind::kMapLandmark, .index = 7}), shared);
  EXPECT_EQ(e->KeyOf({.robot = "a", .kind = KeyKind::kLandmark, .index = 7}), std::nullopt);
}

TEST(CameraLandmarks, CamerasTracksAndProjectionsSurviveASnapshot) {
  auto e = Make();
  ASSERT_TRUE(e->Process(Robot("r", 2, 0.5)).status.ok());
  // Landmark 2 enters (stereo, with projection factors); landmark 1 waits in its track.
  ASSERT_TRUE(e->Process({Frame("r", 0, BodyPose(0), {{2, kP2}}, true)}).status.ok());
  ASSERT_TRUE(e->Process({Frame("r", 0, BodyPose(0), {{1, kP1}})}).status.ok());
  ASSERT_TRUE(InGraph(*e, L(2)));
  const std::string bytes = EncodeState(e->ExportState(), {});
  JournalPosition position;
  core::Result<EstimatorState> state = DecodeState(bytes, &position);
  ASSERT_TRUE(state.ok()) << state.status().message();
  auto restored = Estimator::Restore({.chi2_interval_s = 0.0}, {}, *state);
  ASSERT_TRUE(restored.ok()) << restored.status().message();
  Estimator& e2 = **restored;
  EXPECT_EQ(e2.cameras().size(), 1);
  EXPECT_EQ(e2.tracks().num_observations(), 1);
  EXPECT_EQ(e2.snapshot()->num_factors, e->snapshot()->num_factors);
  EXPECT_LT((LandmarkEstimate(e2, L(2)) - kP2).norm(), 1e-6);
  ASSERT_TRUE(e2.Process({Frame("r", 1, BodyPose(1), {{1, kP1}})}).status.ok());
  ASSERT_TRUE(InGraph(e2, L(1)));
  EXPECT_LT((LandmarkEstimate(e2, L(1)) - kP1).norm(), 1e-6);
}

}  // namespace
}  // namespace slamd::server
