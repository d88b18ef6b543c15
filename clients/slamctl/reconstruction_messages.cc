#include "clients/slamctl/reconstruction_messages.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <variant>

#include "server/messages/inbound.h"

namespace slamd::clients {
namespace {

core::NoiseModel Isotropic(int dim, double sigma) {
  return core::NoiseModel::Isotropic(dim, sigma).value();  // sigma validated
}

// The camera of intrinsics k, sized from its own pixels when the file gives no size.
server::CameraModel CameraOf(const core::Reconstruction& r, int k, double baseline) {
  const core::SfmIntrinsics& in = r.intrinsics[k];
  server::CameraModel camera{.calibration = in.calibration,
                             .baseline = baseline,
                             .body_P_camera = {},
                             .width = in.width,
                             .height = in.height};
  if (camera.width <= 0 || camera.height <= 0) {
    double u = 1.0, v = 1.0;
    for (const core::SfmObservation& o : r.observations) {
      if (r.images[o.image].intrinsics != k) continue;
      u = std::max(u, std::abs(o.uv.x()));
      v = std::max(v, std::abs(o.uv.y()));
    }
    camera.width = 2 * static_cast<int>(std::ceil(u)) + 2;
    camera.height = 2 * static_cast<int>(std::ceil(v)) + 2;
  }
  return camera;
}

}  // namespace

core::Result<std::vector<StepMessages>> MakeReconstructionMessages(
    const core::Reconstruction& r, const ReconstructionMessageOptions& o) {
  SLAMD_RETURN_IF_ERROR(r.Validate());
  if (!IsValidRobotName(o.robot)) {
    return core::InvalidArgument("robot name '" + o.robot + "': 1..64 chars of [A-Za-z0-9_.-]");
  }
  if (!(o.anchor_sigma > 0) || !(o.odometry_sigma > 0) || !(o.pixel_sigma > 0) ||
      o.utime_start_us < 0 || o.utime_step_us < 0 || (!o.stereo.empty() && !(o.baseline > 0))) {
    return core::InvalidArgument(
        "reconstruction messages: anchor_sigma, odometry_sigma, pixel_sigma (and baseline with "
        "stereo) must be positive, the utimes non-negative");
  }
  const bool stereo = !o.stereo.empty();
  std::vector<int> stereo_of(r.observations.size(), -1);
  for (std::size_t s = 0; s < o.stereo.size(); ++s) {
    const int obs = o.stereo[s].observation;
    if (obs < 0 || obs >= static_cast<int>(r.observations.size())) {
      return core::InvalidArgument("stereo measurement " + std::to_string(s) + ": observation " +
                                   std::to_string(obs) + " is out of range");
    }
    if (!std::holds_alternative<core::Cal3_S2>(
            r.intrinsics[r.images[r.observations[obs].image].intrinsics].calibration)) {
      return core::InvalidArgument("stereo measurements need Cal3_S2 (pinhole) intrinsics");
    }
    stereo_of[obs] = static_cast<int>(s);
  }
  std::vector<std::vector<int>> of_image(r.images.size());
  for (std::size_t i = 0; i < r.observations.size(); ++i) {
    of_image[r.observations[i].image].push_back(static_cast<int>(i));
  }

  // Each intrinsics' camera, once: the size of a BAL camera comes from a pass over the pixels.
  std::vector<server::CameraModel> cameras;
  for (std::size_t k = 0; k < r.intrinsics.size(); ++k) {
    cameras.push_back(CameraOf(r, static_cast<int>(k), stereo ? o.baseline : 0.0));
  }

  std::vector<StepMessages> out;
  int last_intrinsics = -1;
  for (std::size_t i = 0; i < r.images.size(); ++i) {
    const core::SfmImage& image = r.images[i];
    const std::int64_t utime = o.utime_start_us + static_cast<std::int64_t>(i) * o.utime_step_us;
    StepMessages step{.pose_index = i, .introduces_pose = true, .messages = {}};
    auto add = [&](const auto& value, auto lcm) {
      server::ToLcm(value, &lcm);
      step.messages.emplace_back(std::move(lcm));
    };
    if (last_intrinsics < 0 || !(cameras[image.intrinsics] == cameras[last_intrinsics])) {
      add(server::CameraInfo{.utime = utime,
                             .robot = o.robot,
                             .camera_id = 0,
                             .from_pose_index = i,
                             .camera = cameras[image.intrinsics]},
          slamd::camera_info_t{});
    }
    last_intrinsics = image.intrinsics;
    if (i == 0) {
      add(server::PriorMeasurement{.utime = utime,
                                   .robot = o.robot,
                                   .pose_index = 0,
                                   .kind = server::PriorKind::kPose3,
                                   .measured = image.pose,
                                   .noise = Isotropic(6, o.anchor_sigma)},
          slamd::prior_t{});
    } else {
      add(server::OdometryMeasurement{.utime = utime,
                                      .robot = o.robot,
                                      .from_index = i - 1,
                                      .to_index = i,
                                      .measured = r.images[i - 1].pose.Between(image.pose),
                                      .noise = Isotropic(6, o.odometry_sigma)},
          slamd::odometry_t{});
    }
    // The frame: mono features, then stereo ones, each in messages of at most
    // kMaxFrameFeatures.
    for (const bool as_stereo : {false, true}) {
      server::FrameObservations frame{.utime = utime,
                                      .robot = o.robot,
                                      .pose_index = i,
                                      .camera_id = 0,
                                      .stereo = as_stereo,
                                      .landmark_namespace = server::LandmarkNamespace::kRobot,
                                      .features = {},
                                      .robust = {}};
      auto flush = [&] {
        if (frame.features.empty()) return;
        add(frame, slamd::frame_observations_t{});
        frame.features.clear();
      };
      for (const int obs : of_image[i]) {
        const int s = stereo_of[obs];
        if ((s >= 0) != as_stereo) continue;
        const core::SfmObservation& ob = r.observations[obs];
        server::FrameFeature f{.landmark_id = static_cast<std::uint64_t>(ob.point),
                               .uv = ob.uv,
                               .u_right = 0.0,
                               .noise = Isotropic(as_stereo ? 3 : 2, o.pixel_sigma),
                               .index = static_cast<int>(frame.features.size())};
        if (as_stereo) {
          const core::Vector3& uuv = o.stereo[s].uuv;
          f.uv = core::Vector2(uuv[0], uuv[2]);
          f.u_right = uuv[1];
        }
        frame.features.push_back(std::move(f));
        if (static_cast<int>(frame.features.size()) == server::kMaxFrameFeatures) flush();
      }
      flush();
    }
    out.push_back(std::move(step));
  }
  return out;
}

}  // namespace slamd::clients
