// frame_observations_t (msgs/lcm/frame_observations_t.lcm): the features one camera image of a
// robot shows, each the pixel of a landmark.
//
// Applied feature by feature, on a Pose3 pose that is known (the whole frame is held until it
// is) through a camera camera_info_t described (held until one is known, too):
//   * a landmark in the graph: a projection factor (ProjectionFactor<Cal> for a mono feature,
//     StereoProjectionFactor for a stereo one) with the camera's calibration and mount, when the
//     landmark is in front of the camera at the current estimate and reprojects within
//     MeasurementPolicy::max_landmark_error_px of the pixel; otherwise that feature is
//     rejected (kBadMeasurement naming its index), the others go on;
//   * a landmark not in the graph: the feature joins the landmark's track (LandmarkTracks),
//     and when the track's views now determine the landmark (core/sfm/landmark_initialization.h,
//     at the current pose estimates) the landmark enters, triangulated, with a factor for every
//     observation of its track.
// A pixel outside the camera's image rejects that feature. Landmark keys: 'l' id in the
// robot's namespace (key robot = the robot's id), or 'm' id in the shared map namespace (no
// robot). Identity of a feature: ('f', pose, landmark, camera id).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/factors/noise_model.h"
#include "core/factors/robust_kernel.h"
#include "core/geometry/eigen_types.h"
#include "server/ingest/conversion.h"
#include "server/messages/camera_info.h"
#include "server/messages/message_spec.h"
#include "slamd/frame_observations_t.hpp"

namespace slamd::server {

struct FrameFeature {
  std::uint64_t landmark_id;
  core::Vector2 uv;        // pixel (the left image's for stereo)
  double u_right = 0.0;    // stereo only
  core::NoiseModel noise;  // dim 2 (mono) or 3 (stereo: uL, uR, v)
  int index = 0;           // its position in the message as sent (for rejections)
};

struct FrameObservations {
  std::int64_t utime;
  std::string robot;
  std::uint64_t pose_index;
  int camera_id;
  bool stereo;
  LandmarkNamespace landmark_namespace;
  std::vector<FrameFeature> features;
  core::RobustKernel robust;
};

// Limits on a message: features per message.
inline constexpr int kMaxFrameFeatures = 2000;

Verdict Validate(const slamd::frame_observations_t& msg, const Limits& limits = {});
Checked<FrameObservations> Convert(const slamd::frame_observations_t& msg,
                                   const Limits& limits = {});
void ToLcm(const FrameObservations& m, slamd::frame_observations_t* out);

// m with only feature `k` (a track's observation; a rejection naming that feature).
FrameObservations OneFeature(const FrameObservations& m, std::size_t k);

struct FrameObservationsSpec {
  using Lcm = slamd::frame_observations_t;
  using Value = FrameObservations;
  static constexpr const char* kType = "frame_observations_t";
  static constexpr const char* kChannel = "FRAME";
  static constexpr MessageRole kRole = MessageRole::kMeasurement;
  static constexpr char kIdentity = 'f';

  template <typename M>
  static const std::string& Robot(const M& m) {
    return m.robot;
  }
  // The factor of feature `f` of `m` (a one-feature frame or a whole one) through `camera`.
  static core::FactorPtr Factor(const Value& m, const FrameFeature& f, const CameraModel& camera,
                                core::Key pose, core::Key landmark);
  static Outcome Apply(const Value& m, GraphBuilder& graph, Verdict* verdict);
};

}  // namespace slamd::server
