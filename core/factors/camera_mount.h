// CameraMount: a camera rigidly mounted on a body (a robot, a rig), for the factors that observe a
// landmark through it (projection_factor.h, stereo_projection_factor.h).
//
// Frames: the factors' pose variable is the body's T_wb; the camera sits at
// T_wc = T_wb·body_P_camera (body_P_camera: camera frame -> body frame; identity when the body IS
// the camera). Projections here take the body pose and give Jacobians with respect to a right
// perturbation T_wb·Exp(ξ) of it (pose3.h's convention): since
//   T_wb·Exp(ξ)·B = T_wb·B·Exp(Ad(B⁻¹)·ξ),
// a camera-pose Jacobian becomes a body-pose one by one product with the constant Ad(B⁻¹),
// computed once at construction.
//
// Also the record layout the camera factors share (factor_registry.h): their measurement, then
// their fixed calibration's parameters (none when the calibration is a variable), then
// body_P_camera in the Pose3 encoding (variables/pose_traits.h: t, then R row by row).
// A small value type: immutable, cheap to copy, never allocates.
#pragma once

#include <span>
#include <vector>

#include "core/factors/factor_record.h"
#include "core/geometry/camera.h"

namespace slamd::core {

class CameraMount {
 public:
  explicit CameraMount(const Pose3& body_P_camera = Pose3())
      : body_P_camera_(body_P_camera), camera_from_body_(body_P_camera.Inverse().AdjointMap()) {}

  const Pose3& body_P_camera() const { return body_P_camera_; }
  // T_wc of the camera on a body at `body_pose` (T_wb).
  Pose3 CameraPose(const Pose3& body_pose) const { return body_pose * body_P_camera_; }

  // camera.h's Project and ProjectStereo from the body's pose; H_pose with respect to the body.
  template <typename Cal>
  Projection Project(const Pose3& body_pose, const Cal& K, const Point3& p_w, Matrix26* H_pose,
                     Matrix23* H_point, CalibrationJacobian<Cal>* H_cal = nullptr) const {
    Matrix26 H_camera;
    const Projection p =
        core::Project(CameraPose(body_pose), K, p_w, H_pose ? &H_camera : nullptr, H_point, H_cal);
    if (H_pose) *H_pose = H_camera * camera_from_body_;
    return p;
  }
  StereoProjection ProjectStereo(const Pose3& body_pose, const Cal3_S2Stereo& K, const Point3& p_w,
                                 Matrix36* H_pose, Matrix3* H_point) const;

  // P_c.z of world point p_w: positive when the point is in front of the camera.
  double Depth(const Pose3& body_pose, const Point3& p_w) const {
    return CameraPose(body_pose).TransformTo(p_w).z();
  }

  // Appends body_P_camera's encoding (12 numbers).
  void Encode(std::vector<double>* out) const;

 private:
  Pose3 body_P_camera_;
  Matrix6 camera_from_body_;  // Ad(body_P_camera⁻¹) = ∂(camera pose)/∂(body pose)
};

namespace internal {

// A camera factor's record split into its parts (see the file comment).
struct CameraRecord {
  std::span<const double> measured;
  std::span<const double> calibration;  // empty when the calibration is a variable
  CameraMount mount;
};

// InvalidArgument naming the expected layout when r.measured is not `measured_size` +
// `calibration_size` + 12 numbers, when the measurement is not finite, or when the mount is no
// valid pose. `layout` describes the measurement and calibration for that message, e.g.
// "(u, v), Cal3DS2 (9)".
Result<CameraRecord> SplitCameraRecord(const FactorRecord& r, int measured_size,
                                       int calibration_size, const char* layout);

}  // namespace internal
}  // namespace slamd::core
