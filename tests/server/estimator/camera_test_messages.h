// Camera messages for estimator and query tests: a robot with a pinhole camera looking along its
// body's x axis, moving sideways (0.5 m per pose), and its noise-free frames of given points.
#pragma once

#include <string>
#include <vector>

#include "core/geometry/camera.h"
#include "server/estimator/estimator.h"
#include "tests/testing/noise.h"

namespace slamd::server::camera_test {

using core::Point3;
using core::Pose3;
using core::Rot3;
using ::slamd::testing::Noise;

inline const core::Cal3_S2 kCamK(400.0, 400.0, 0.0, 320.0, 240.0);
// The camera looks along the body's x axis (camera z = body x, x = -body y, y = -body z).
inline const Pose3 kMount(Rot3((core::Matrix3() << 0, 0, 1, -1, 0, 0, 0, -1, 0).finished()),
                          Point3(0.1, 0.0, 0.2));

// Robot pose i: i * 0.5 m along y (sideways to the camera), heading x.
inline Pose3 BodyPose(std::uint64_t i) { return Pose3(Rot3(), Point3(0.0, 0.5 * i, 0.0)); }

inline Inbound PriorAt0(const std::string& robot, const Pose3& p = BodyPose(0)) {
  return {PriorMeasurement{1, robot, 0, PriorKind::kPose3, p, Noise(6, 1e-3)}, 0};
}
// Odometry from pose `from` at `a` to pose `to` at `b`, noise-free.
inline Inbound Odo3(const std::string& robot, std::uint64_t from, std::uint64_t to, const Pose3& a,
                    const Pose3& b) {
  return {OdometryMeasurement{2, robot, from, to, a.Inverse() * b, Noise(6, 1e-3)}, 0};
}

inline Inbound Camera(const std::string& robot, double baseline = 0.0, std::uint64_t from = 0) {
  return {CameraInfo{.utime = 3,
                     .robot = robot,
                     .camera_id = 0,
                     .from_pose_index = from,
                     .camera = {.calibration = kCamK,
                                .baseline = baseline,
                                .body_P_camera = kMount,
                                .width = 640,
                                .height = 480}},
          0};
}

struct Seen {
  std::uint64_t id;
  Point3 point;
};

// A frame of `robot` at pose `index` (body at `body`) seeing `points`, noise-free.
inline Inbound Frame(const std::string& robot, std::uint64_t index, const Pose3& body,
                     const std::vector<Seen>& points, bool stereo = false, double baseline = 0.5,
                     LandmarkNamespace ns = LandmarkNamespace::kRobot) {
  FrameObservations f{.utime = 4,
                      .robot = robot,
                      .pose_index = index,
                      .camera_id = 0,
                      .stereo = stereo,
                      .landmark_namespace = ns,
                      .features = {},
                      .robust = {}};
  const Pose3 camera = body * kMount;
  for (const Seen& s : points) {
    FrameFeature feature{.landmark_id = s.id,
                         .uv = {},
                         .noise = Noise(stereo ? 3 : 2, 1.0),
                         .index = static_cast<int>(f.features.size())};
    if (stereo) {
      const core::Vector3 uuv =
          core::ProjectStereo(camera, core::Cal3_S2Stereo(kCamK, baseline), s.point).uuv;
      feature.uv = core::Vector2(uuv[0], uuv[2]);
      feature.u_right = uuv[1];
    } else {
      feature.uv = core::Project(camera, kCamK, s.point).uv;
    }
    f.features.push_back(feature);
  }
  return {f, 0};
}

inline const Point3 kP1(6.0, 0.4, 0.3), kP2(5.0, -0.6, -0.2), kP3(8.0, 1.0, 0.5);

// A robot with a camera, poses 0..n-1 (prior and odometry), in one batch.
inline std::vector<Inbound> Robot(const std::string& robot, int n, double baseline = 0.0) {
  std::vector<Inbound> batch = {Camera(robot, baseline), PriorAt0(robot)};
  for (int i = 1; i < n; ++i) batch.push_back(Odo3(robot, i - 1, i, BodyPose(i - 1), BodyPose(i)));
  return batch;
}

}  // namespace slamd::server::camera_test
