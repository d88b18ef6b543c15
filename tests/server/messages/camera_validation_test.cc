// The stateless rejection cases of camera_info_t and frame_observations_t (run by
// validation_test.cc's RejectionTest), and acceptance of good ones.
#include <gtest/gtest.h>

#include <vector>

#include "server/messages/inbound.h"
#include "tests/server/ingest/test_messages.h"
#include "tests/server/messages/rejection_cases.h"

namespace slamd::server {
namespace {

using namespace testing;          // NOLINT: the example messages
using namespace rejection_cases;  // NOLINT: Case, Make, RejectionTest

std::vector<Case> CameraInfoCases() {
  using M = slamd::camera_info_t;
  const M c = CameraInfoMessage(1), stereo = CameraInfoMessage(4);
  return {
      Make<M>(
          "CameraIdOutOfRange", c, [](M& m) { m.camera_id = 256; }, R::kIndexOutOfRange,
          "camera_info_t.camera_id: 256"),
      Make<M>(
          "Model5", c, [](M& m) { m.model = 5; }, R::kBadKind, "camera_info_t.model: 5"),
      Make<M>(
          "IntrinsicsOfAnotherModel", c,
          [](M& m) {
            m.intrinsics.push_back(0.1);
            m.num_intrinsics = 6;
          },
          R::kSizeMismatch, "camera_info_t.num_intrinsics"),
      Make<M>(
          "IntrinsicNaN", c, [](M& m) { m.intrinsics[3] = kNaN; }, R::kNotFinite,
          "camera_info_t.intrinsics[3]"),
      Make<M>(
          "NegativeFocal", c, [](M& m) { m.intrinsics[1] = -400.0; }, R::kBadMeasurement,
          "camera_info_t.intrinsics[1]: focal length -400"),
      Make<M>(
          "ZeroBaseline", stereo, [](M& m) { m.intrinsics[5] = 0.0; }, R::kBadMeasurement,
          "camera_info_t.intrinsics[5]: baseline 0"),
      Make<M>(
          "MountNotUnit", c, [](M& m) { m.body_q_camera[0] *= 1.1; }, R::kQuaternionNotUnit,
          "camera_info_t.body_q_camera"),
      Make<M>(
          "MountInfinite", c, [](M& m) { m.body_t_camera[2] = kInf; }, R::kNotFinite,
          "camera_info_t.body_t_camera[2]"),
      Make<M>(
          "ZeroWidth", c, [](M& m) { m.width = 0; }, R::kBadMeasurement,
          "camera_info_t.width: 0 px"),
  };
}

std::vector<Case> FrameCases() {
  using M = slamd::frame_observations_t;
  const M mono = FrameMessage(1), stereo = FrameMessage(2), full = FrameMessage(1, true);
  return {
      Make<M>(
          "BadRobot", mono, [](M& m) { m.robot = "a b"; }, R::kBadName,
          "frame_observations_t.robot"),
      Make<M>(
          "Kind3", mono, [](M& m) { m.kind = 3; }, R::kBadKind, "frame_observations_t.kind: 3"),
      Make<M>(
          "Namespace2", mono, [](M& m) { m.landmark_namespace = 2; }, R::kBadKind,
          "frame_observations_t.landmark_namespace"),
      Make<M>(
          "NoFeatures", mono,
          [](M& m) {
            m.num_features = 0;
            m.landmark_ids.clear();
          },
          R::kTooManyElements, "frame_observations_t.num_features: 0"),
      Make<M>(
          "ValuesOfAnotherKind", mono, [](M& m) { m.kind = 2; }, R::kSizeMismatch,
          "frame_observations_t.num_values"),
      Make<M>(
          "LandmarkIdTooBig", mono, [](M& m) { m.landmark_ids[2] = kTooBig; }, R::kIndexOutOfRange,
          "frame_observations_t.landmark_ids[2]"),
      Make<M>(
          "LandmarkTwice", mono, [](M& m) { m.landmark_ids[2] = 10; }, R::kDuplicate,
          "frame_observations_t.landmark_ids[2]: landmark 10 is also feature 0"),
      Make<M>(
          "PixelNaN", mono, [](M& m) { m.values[3] = kNaN; }, R::kNotFinite,
          "frame_observations_t.values[3]"),
      Make<M>(
          "NegativeDisparity", stereo, [](M& m) { m.values[4] = 330.0; }, R::kBadMeasurement,
          "frame_observations_t.values[4]: u_right 330 exceeds u_left 320"),
      Make<M>(
          "TwoSigmasForThreeFeatures", mono,
          [](M& m) {
            m.sigmas.pop_back();
            m.num_sigmas = 2;
          },
          R::kSizeMismatch, "frame_observations_t.num_sigmas: 2"),
      Make<M>(
          "ZeroSigma", mono, [](M& m) { m.sigmas[1] = 0.0; }, R::kBadMeasurement,
          "frame_observations_t.sigmas[1]: sigma 0"),
      Make<M>(
          "HugeSigma", mono, [](M& m) { m.sigmas[2] = 1e300; }, R::kBadMeasurement,
          "frame_observations_t.sigmas[2]: sigma 1e+300 px is outside"),
      Make<M>(
          "NegativeSigma", mono, [](M& m) { m.sigmas[0] = -3.0; }, R::kBadMeasurement,
          "frame_observations_t.sigmas[0]: sigma -3 px is outside"),
      Make<M>(
          "IndefiniteCovariance", full, [](M& m) { m.covariance[7] = -0.2; },
          R::kCovarianceNotPositiveDefinite, "frame_observations_t.covariance[4]"),
      Make<M>(
          "UnknownKernel", mono, [](M& m) { m.robust_kernel = "tukey"; }, R::kUnknownRobustKernel,
          "frame_observations_t.robust_kernel"),
  };
}

INSTANTIATE_TEST_SUITE_P(CameraInfo, RejectionTest, ::testing::ValuesIn(CameraInfoCases()),
                         CaseName);
INSTANTIATE_TEST_SUITE_P(FrameObservations, RejectionTest, ::testing::ValuesIn(FrameCases()),
                         CaseName);

TEST(Accepts, GoodCameraAndFrameMessages) {
  for (int model = 1; model <= 4; ++model) {
    EXPECT_TRUE(Validate(CameraInfoMessage(model)).ok())
        << Validate(CameraInfoMessage(model)).message;
  }
  for (const auto& m :
       {FrameMessage(1), FrameMessage(2), FrameMessage(1, true), FrameMessage(2, true)}) {
    EXPECT_TRUE(Validate(m).ok()) << Validate(m).message;
  }
}

}  // namespace
}  // namespace slamd::server
