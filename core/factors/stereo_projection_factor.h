// StereoProjectionFactor: a landmark (Point3, world frame) observed at (uL, uR, v) by a rectified
// stereo pair (camera.h: Cal3_S2Stereo, the left camera's calibration and the baseline) mounted
// on a body whose pose (Pose3, T_wb) is the variable; the left camera sits at T_wb·body_P_camera
// (camera_mount.h; identity by default). The calibration is fixed.
//
// Error: e = ProjectStereo(T_wb·body_P_camera, K, landmark).uuv − measured, in pixels (the noise
// model's units). Jacobians: right perturbation of the pose, addition for the landmark.
//
// Cheirality as in projection_factor.h: the formula's error and Jacobians behind the camera,
// InFront to ask. Unlike a monocular pixel a stereo measurement has depth (fx·baseline /
// disparity), so Predict places the landmark from the pose (BackprojectStereo, then into the
// world); it does not place the pose from the landmark.
//
// Encoded as (uL, uR, v), then (fx, fy, s, u0, v0, baseline), then body_P_camera (12 numbers,
// camera_mount.h).
#pragma once

#include "core/factors/camera_mount.h"
#include "core/factors/factor.h"

namespace slamd::core {

class StereoProjectionFactor : public TypedFactor<StereoProjectionFactor, 3, Pose3, Point3> {
 public:
  static const char* TypeName() { return "StereoProjection"; }

  StereoProjectionFactor(Key pose, Key landmark, const Vector3& measured, const Cal3_S2Stereo& K,
                         NoiseModel noise, RobustKernel robust = {},
                         const Pose3& body_P_camera = Pose3())
      : TypedFactor({pose, landmark}, std::move(noise), robust),
        measured_(measured),
        K_(K),
        mount_(body_P_camera) {}
  static Result<FactorPtr> Decode(const FactorRecord& r, NoiseModel noise);

  const Vector3& measured() const { return measured_; }
  const Cal3_S2Stereo& calibration() const { return K_; }
  const Pose3& body_P_camera() const { return mount_.body_P_camera(); }
  void EncodeMeasured(std::vector<double>* out) const override;
  // The landmark keys()[1] from the pose (known = 0) only; not finite for zero disparity.
  std::optional<Variable> Predict(int known, const Variable& known_value) const override;
  // Whether the landmark is in front of the left camera at `values` (which must hold both keys).
  bool InFront(const Values& values) const {
    return mount_.Depth(values.At<Pose3>(keys()[0]), values.At<Point3>(keys()[1])) > 0.0;
  }

  ErrorVector Evaluate(const Pose3& pose, const Point3& landmark, Matrix36* H_pose,
                       Matrix3* H_landmark) const {
    return mount_.ProjectStereo(pose, K_, landmark, H_pose, H_landmark).uuv - measured_;
  }

 private:
  Vector3 measured_;
  Cal3_S2Stereo K_;
  CameraMount mount_;
};

}  // namespace slamd::core
