// Cameras: where a 3-D point appears in an image, through the calibrations of calibration.h, and
// in a rectified stereo pair.
//
// Frames: a camera's pose is T_wc (Pose3: camera frame -> world); the camera looks down its +z
// axis, image x to the right and y down (OpenCV, COLMAP). A world point P goes to the camera
// frame as P_c = T_wc.TransformTo(P), to normalised coordinates p = (P_c.x / P_c.z,
// P_c.y / P_c.z), then to pixels by the calibration:
//   Cal3_S2:     u = fx·x + s·y + u0,  v = fy·y + v0
//   Cal3DS2:     r² = x² + y², g = 1 + k1·r² + k2·r⁴,
//                x' = g·x + 2·p1·x·y + p2·(r² + 2x²),  y' = g·y + p1·(r² + 2y²) + 2·p2·x·y,
//                then Cal3_S2 on (x', y')  (OpenCV's radial-tangential model)
//   Cal3Bundler: g = 1 + k1·r² + k2·r⁴,  (u, v) = f·g·(x, y)  (no principal point: pixels from
//                the image centre, as in BAL; BAL's own camera looks down -z with y up, which its
//                reader turns into this convention, core/io/sfm_io.h)
//   stereo:      Cal3_S2Stereo, a rectified pair whose right camera sits `baseline` metres along
//                the left camera's +x: (uL, uR, v) with uR = uL - fx·baseline / P_c.z.
//
// Cheirality: a point at or behind the camera (P_c.z <= 0) has no image. Projections say so
// (Projection::in_front); the pixel and the Jacobians are still the formula's (finite for any
// P_c.z != 0; a point exactly on the camera plane gives non-finite numbers), so a caller that
// checks nothing still sees the error grow rather than a constant with zero Jacobians.
//
// Jacobians: with respect to a right perturbation T_wc·Exp(ξ) of the pose (ξ = (v, ω), the
// tangent order of pose3.h), plain addition for points and for the calibration's parameters (in
// its parameter order, calibration.h). Out-params are raw pointers; nullptr skips the work.
// Everything here is fixed-size and allocation-free: the bundle adjuster calls it per
// observation.
#pragma once

#include "core/geometry/calibration.h"
#include "core/geometry/eigen_types.h"
#include "core/geometry/pose3.h"

namespace slamd::core {

// A rectified stereo pair: the left camera's pinhole calibration and the baseline (metres).
class Cal3_S2Stereo {
 public:
  Cal3_S2Stereo() = default;
  Cal3_S2Stereo(const Cal3_S2& K, double baseline) : K_(K), baseline_(baseline) {}
  const Cal3_S2& K() const { return K_; }
  double baseline() const { return baseline_; }

 private:
  Cal3_S2 K_;
  double baseline_ = 0.0;
};

// The Jacobian of a pixel with respect to the parameters of calibration Cal.
template <typename Cal>
using CalibrationJacobian = Eigen::Matrix<double, 2, Cal::kDim>;

// A monocular projection: the pixel and whether the point is in front of the camera.
struct Projection {
  Vector2 uv = Vector2::Zero();
  double depth = 0.0;  // P_c.z, metres
  bool in_front() const { return depth > 0.0; }
};

// Normalised coordinates of a camera-frame point; H = ∂p/∂P_c.
Vector2 ProjectToNormalized(const Point3& p_c, Matrix23* H = nullptr);

// The pixel of normalised coordinates p; H_p = ∂uv/∂p, H_cal = ∂uv/∂(calibration parameters).
Vector2 Uncalibrate(const Cal3_S2& K, const Vector2& p, Matrix2* H_p = nullptr,
                    CalibrationJacobian<Cal3_S2>* H_cal = nullptr);
Vector2 Uncalibrate(const Cal3DS2& K, const Vector2& p, Matrix2* H_p = nullptr,
                    CalibrationJacobian<Cal3DS2>* H_cal = nullptr);
Vector2 Uncalibrate(const Cal3Bundler& K, const Vector2& p, Matrix2* H_p = nullptr,
                    CalibrationJacobian<Cal3Bundler>* H_cal = nullptr);

// The normalised coordinates whose pixel is uv (the inverse of Uncalibrate): closed form for
// Cal3_S2, Gauss-Newton from the undistorted guess for the distorting models (converged to 1e-12
// relative, at most 20 iterations: beyond the distortion's invertible range the last iterate).
Vector2 Calibrate(const Cal3_S2& K, const Vector2& uv);
Vector2 Calibrate(const Cal3DS2& K, const Vector2& uv);
Vector2 Calibrate(const Cal3Bundler& K, const Vector2& uv);

// The pixel of a camera-frame point: ProjectToNormalized then Uncalibrate, chained.
template <typename Cal>
Projection ProjectCameraFrame(const Cal& K, const Point3& p_c, Matrix23* H_point = nullptr,
                              CalibrationJacobian<Cal>* H_cal = nullptr);

// The pixel of world point `p_w` seen by a camera at `pose_wc` with calibration K.
template <typename Cal>
Projection Project(const Pose3& pose_wc, const Cal& K, const Point3& p_w, Matrix26* H_pose = nullptr,
                   Matrix23* H_point = nullptr, CalibrationJacobian<Cal>* H_cal = nullptr);

// A stereo projection: (uL, uR, v) and whether the point is in front of the pair.
struct StereoProjection {
  Vector3 uuv = Vector3::Zero();
  double depth = 0.0;  // P_c.z in the left camera, metres
  bool in_front() const { return depth > 0.0; }
};

StereoProjection ProjectStereo(const Pose3& pose_wc, const Cal3_S2Stereo& K, const Point3& p_w,
                               Matrix36* H_pose = nullptr, Matrix3* H_point = nullptr);

// The camera-frame point of a stereo measurement (uL, uR, v): depth fx·baseline / (uL - uR).
// Not finite for zero disparity.
Point3 BackprojectStereo(const Cal3_S2Stereo& K, const Vector3& uuv);

}  // namespace slamd::core
