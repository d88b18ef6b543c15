// A reconstruction (BAL, COLMAP text, a simulated camera world) as the messages one robot's
// camera would send slamd, image by image in file order (what `slamctl replay` publishes for a
// reconstruction, and `slamctl bench` feeds an estimator):
//
//   image 0   camera_info_t (camera 0, from pose 0: the image's intrinsics, the camera mounted
//             at the body's origin, so the robot's pose i is image i's T_wc), prior_t on pose 0
//             at the image's pose (isotropic `anchor_sigma`), frame_observations_t;
//   image i   camera_info_t again (from pose i) when its intrinsics differ from image i-1's (BAL
//             files give each image its own), odometry_t from pose i-1 to pose i (the relative
//             pose of the two images' values, isotropic `odometry_sigma` in metres and radians:
//             the motion a visual odometry front end would report; it fixes the gauge and the
//             scale), then its frame: one frame_observations_t of its mono observations (landmark
//             id = the point's index, isotropic `pixel_sigma`), and with stereo measurements a
//             second one, KIND_STEREO, of the observations that have them.
// Stereo needs Cal3_S2 intrinsics: the camera is then MODEL_STEREO with `baseline`.
// Image size: the intrinsics' (COLMAP), or for files without one (BAL) the smallest even size
// whose centred image holds every pixel of that camera. Messages of more than
// server::kMaxFrameFeatures features are split. utime of image i's messages = utime_start_us +
// i * utime_step_us.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "clients/slamctl/dataset_messages.h"
#include "core/base/status.h"
#include "core/geometry/eigen_types.h"
#include "core/sfm/reconstruction.h"

namespace slamd::clients {

// A stereo measurement (uL, uR, v) of one of the reconstruction's observations.
struct StereoMeasurement {
  int observation = 0;
  core::Vector3 uuv = core::Vector3::Zero();
};

struct ReconstructionMessageOptions {
  std::string robot = "camera";                // 1..64 chars of [A-Za-z0-9_.-]
  double anchor_sigma = 1e-3;                  // > 0 [m, rad]
  double odometry_sigma = 0.1;                 // > 0 [m, rad]
  double pixel_sigma = 1.0;                    // > 0 [px]
  std::vector<StereoMeasurement> stereo = {};  // in observation order
  double baseline = 0.0;                       // > 0 with stereo [m]
  std::int64_t utime_start_us = 0;             // >= 0
  std::int64_t utime_step_us = 33333;          // >= 0 (30 frames/s)
};

// kInvalidArgument for bad options, stereo without Cal3_S2 intrinsics or an observation index
// out of range, or an invalid reconstruction.
core::Result<std::vector<StepMessages>> MakeReconstructionMessages(
    const core::Reconstruction& r, const ReconstructionMessageOptions& options);

}  // namespace slamd::clients
