#include "core/sfm/landmark_initialization.h"

#include <gtest/gtest.h>

#include <vector>

#include "core/geometry/camera.h"
#include "tests/testing/camera_examples.h"

namespace slamd::core {
namespace {

using testing::LookAt;

const Cal3_S2 kInitK(500.0, 500.0, 0.0, 320.0, 240.0);

// A mono view of X from a camera at `eye` looking at `aim`, its pixel moved by `offset`.
LandmarkView MonoView(const Point3& eye, const Point3& aim, const Point3& X,
                      const Calibration& K = kInitK, const Vector2& offset = Vector2::Zero()) {
  LandmarkView v{.camera_pose = LookAt(eye, aim), .calibration = K};
  v.uv = std::visit([&](const auto& k) { return Project(v.camera_pose, k, X).uv; }, K) + offset;
  return v;
}

LandmarkView StereoView(const Point3& eye, const Point3& aim, const Point3& X, double baseline) {
  LandmarkView v{.camera_pose = LookAt(eye, aim), .calibration = kInitK, .baseline = baseline};
  const Vector3 uuv = ProjectStereo(v.camera_pose, Cal3_S2Stereo(kInitK, baseline), X).uuv;
  v.uv = Vector2(uuv[0], uuv[2]);
  v.u_right = uuv[1];
  return v;
}

bool FailsWith(const Result<Point3>& r, const std::string& what) {
  return !r.ok() && r.status().code() == StatusCode::kFailedPrecondition &&
         r.status().message().find(what) != std::string::npos;
}

const Point3 kInitX(0.3, -0.2, 5.0);

TEST(LandmarkInitialization, TwoViewsWithParallaxGiveThePoint) {
  const std::vector<LandmarkView> views = {MonoView({0, 0, 0}, kInitX, kInitX),
                                           MonoView({1, 0, 0}, kInitX, kInitX)};
  Result<Point3> X = InitializeLandmark(views);
  ASSERT_TRUE(X.ok()) << X.status().message();
  EXPECT_LT((*X - kInitX).norm(), 1e-9);
}

TEST(LandmarkInitialization, ViewsOfDifferentModelsTriangulateTogether) {
  const Cal3DS2 radtan(Cal3_S2(480.0, 470.0, 0.0, 300.0, 250.0), -0.1, 0.02, 1e-3, -1e-3);
  const Cal3Bundler bundler(600.0, 0.01, -0.001);
  const std::vector<LandmarkView> views = {MonoView({0, 0, 0}, kInitX, kInitX),
                                           MonoView({1, 0, 0}, kInitX, kInitX, radtan),
                                           MonoView({0, 1, 0}, kInitX, kInitX, bundler)};
  Result<Point3> X = InitializeLandmark(views);
  ASSERT_TRUE(X.ok()) << X.status().message();
  EXPECT_LT((*X - kInitX).norm(), 1e-8);
}

TEST(LandmarkInitialization, OneMonoViewIsNotEnough) {
  const std::vector<LandmarkView> views = {MonoView({0, 0, 0}, kInitX, kInitX)};
  EXPECT_TRUE(FailsWith(InitializeLandmark(views), "1 view(s) (2 needed)"));
}

TEST(LandmarkInitialization, PureRotationHasNoParallax) {
  const std::vector<LandmarkView> views = {MonoView({0, 0, 0}, kInitX, kInitX),
                                           MonoView({0, 0, 0}, kInitX + Vector3(1, 0, 0), kInitX)};
  EXPECT_TRUE(FailsWith(InitializeLandmark(views), "parallax"));
}

TEST(LandmarkInitialization, ADistantPointWaitsForParallax) {
  const Point3 far(500.0, 0.0, 0.0);  // 1 m baseline: 0.11 deg
  const std::vector<LandmarkView> views = {MonoView({0, 0, 0}, far, far),
                                           MonoView({0, 1, 0}, far, far)};
  EXPECT_TRUE(FailsWith(InitializeLandmark(views), "parallax"));
  EXPECT_TRUE(InitializeLandmark(views, {.min_parallax_deg = 0.05}).ok());
}

TEST(LandmarkInitialization, APointBehindACameraIsRefused) {
  // The second camera faces away: its pixel is where the point's mirror image projects.
  const Point3 eye(1, 0, 0);
  LandmarkView behind{.camera_pose = LookAt(eye, eye + (eye - kInitX)), .calibration = kInitK};
  behind.uv = Project(behind.camera_pose, kInitK, eye - (kInitX - eye)).uv;
  const std::vector<LandmarkView> views = {MonoView({0, 0, 0}, kInitX, kInitX), behind};
  EXPECT_TRUE(FailsWith(InitializeLandmark(views), "behind"))
      << InitializeLandmark(views).status().message();
}

TEST(LandmarkInitialization, AMovingOutlierFailsTheReprojectionCheck) {
  // The third view saw a point that had moved by 0.5 m.
  const std::vector<LandmarkView> views = {
      MonoView({0, 0, 0}, kInitX, kInitX), MonoView({1, 0, 0}, kInitX, kInitX),
      MonoView({0, 1, 0}, kInitX, kInitX + Vector3(0.5, 0, 0))};
  EXPECT_TRUE(FailsWith(InitializeLandmark(views), "reprojection"));
}

TEST(LandmarkInitialization, OneStereoViewPlacesThePoint) {
  const std::vector<LandmarkView> views = {StereoView({0, 0, 0}, kInitX, kInitX, 0.12)};
  Result<Point3> X = InitializeLandmark(views);
  ASSERT_TRUE(X.ok()) << X.status().message();
  EXPECT_LT((*X - kInitX).norm(), 1e-9);
}

TEST(LandmarkInitialization, AStereoViewWithoutDisparityIsAMonoView) {
  const Point3 far(400.0, 0.0, 0.0);  // disparity 500 * 0.12 / 400 = 0.15 px
  std::vector<LandmarkView> views = {StereoView({0, 0, 0}, far, far, 0.12)};
  EXPECT_TRUE(FailsWith(InitializeLandmark(views), "stereo disparity"));
  views.push_back(MonoView({0, 20, 0}, far, far));  // 2.9 deg of parallax
  Result<Point3> X = InitializeLandmark(views);
  ASSERT_TRUE(X.ok()) << X.status().message();
  EXPECT_LT((*X - far).norm(), 1e-6);
}

TEST(LandmarkInitialization, BadInputIsAnInvalidArgument) {
  std::vector<LandmarkView> views = {StereoView({0, 0, 0}, kInitX, kInitX, 0.12)};
  views[0].calibration = Cal3Bundler(500.0, 0.0, 0.0);
  EXPECT_EQ(InitializeLandmark(views).status().code(), StatusCode::kInvalidArgument);
  views = {MonoView({0, 0, 0}, kInitX, kInitX), MonoView({1, 0, 0}, kInitX, kInitX)};
  views[1].uv.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(InitializeLandmark(views).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(InitializeLandmark(views, {.min_views = 1}).status().code(),
            StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace slamd::core
