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
inline Vector2 ProjectToNormalized(const Point3& p_c, Matrix23* H = nullptr) {
  const double inv_z = 1.0 / p_c.z();
  const Vector2 p(p_c.x() * inv_z, p_c.y() * inv_z);
  if (H) *H << inv_z, 0.0, -p.x() * inv_z, 0.0, inv_z, -p.y() * inv_z;
  return p;
}

// The pixel of normalised coordinates p; H_p = ∂uv/∂p, H_cal = ∂uv/∂(calibration parameters).
inline Vector2 Uncalibrate(const Cal3_S2& K, const Vector2& p, Matrix2* H_p = nullptr,
                           CalibrationJacobian<Cal3_S2>* H_cal = nullptr) {
  if (H_p) *H_p << K.fx(), K.skew(), 0.0, K.fy();
  if (H_cal) *H_cal << p.x(), 0.0, p.y(), 1.0, 0.0, 0.0, p.y(), 0.0, 0.0, 1.0;
  return Vector2(K.fx() * p.x() + K.skew() * p.y() + K.u0(), K.fy() * p.y() + K.v0());
}

inline Vector2 Uncalibrate(const Cal3DS2& K, const Vector2& p, Matrix2* H_p = nullptr,
                           CalibrationJacobian<Cal3DS2>* H_cal = nullptr) {
  const double k1 = K.k1(), k2 = K.k2(), p1 = K.p1(), p2 = K.p2();
  const double x = p.x(), y = p.y();
  const double xx = x * x, yy = y * y, xy = x * y;
  const double r2 = xx + yy;
  const double g = 1.0 + r2 * (k1 + k2 * r2);
  const Vector2 distorted(g * x + 2.0 * p1 * xy + p2 * (r2 + 2.0 * xx),
                          g * y + p1 * (r2 + 2.0 * yy) + 2.0 * p2 * xy);
  Matrix2 H_distorted;  // ∂uv/∂(x', y'): the pinhole's H_p
  CalibrationJacobian<Cal3_S2> H_pinhole;
  const Vector2 uv = Uncalibrate(K.pinhole(), distorted, (H_p || H_cal) ? &H_distorted : nullptr,
                                 H_cal ? &H_pinhole : nullptr);
  if (H_p) {
    // ∂(x', y')/∂(x, y), with ∂g/∂x = 2x·dg and ∂g/∂y = 2y·dg for dg = k1 + 2·k2·r².
    const double dg = 2.0 * (k1 + 2.0 * k2 * r2);
    // The matrix is symmetric: ∂x'/∂y = ∂y'/∂x.
    const double cross = xy * dg + 2.0 * p1 * x + 2.0 * p2 * y;
    Matrix2 D;
    D << g + xx * dg + 2.0 * p1 * y + 6.0 * p2 * x, cross,  //
        cross, g + yy * dg + 6.0 * p1 * y + 2.0 * p2 * x;
    *H_p = H_distorted * D;
  }
  if (H_cal) {
    // ∂(x', y')/∂(k1, k2, p1, p2), then through the pinhole.
    Eigen::Matrix<double, 2, 4> D;
    D << x * r2, x * r2 * r2, 2.0 * xy, r2 + 2.0 * xx,  //
        y * r2, y * r2 * r2, r2 + 2.0 * yy, 2.0 * xy;
    H_cal->leftCols<5>() = H_pinhole;
    H_cal->rightCols<4>() = H_distorted * D;
  }
  return uv;
}

inline Vector2 Uncalibrate(const Cal3Bundler& K, const Vector2& p, Matrix2* H_p = nullptr,
                           CalibrationJacobian<Cal3Bundler>* H_cal = nullptr) {
  const double r2 = p.squaredNorm();
  const double g = 1.0 + r2 * (K.k1() + K.k2() * r2);
  if (H_p) {
    // f·(g·I + p·∇gᵀ) with ∇g = 2·(k1 + 2·k2·r²)·p.
    const double dg = 2.0 * (K.k1() + 2.0 * K.k2() * r2);
    *H_p = K.f() * (g * Matrix2::Identity() + dg * p * p.transpose());
  }
  if (H_cal) {
    H_cal->col(0) = g * p;
    H_cal->col(1) = K.f() * r2 * p;
    H_cal->col(2) = K.f() * r2 * r2 * p;
  }
  return K.f() * g * p;
}

// The normalised coordinates whose pixel is uv (the inverse of Uncalibrate): closed form for
// Cal3_S2, Gauss-Newton from the undistorted guess for the distorting models (until the step is
// under 1e-12·max(1, |p|), at most 20 iterations: beyond the distortion's invertible range, where
// ∂uv/∂p turns singular or the iteration diverges, the last finite iterate). Allocation-free.
Vector2 Calibrate(const Cal3_S2& K, const Vector2& uv);
Vector2 Calibrate(const Cal3DS2& K, const Vector2& uv);
Vector2 Calibrate(const Cal3Bundler& K, const Vector2& uv);

// The pixel of a camera-frame point: ProjectToNormalized then Uncalibrate, chained.
template <typename Cal>
Projection ProjectCameraFrame(const Cal& K, const Point3& p_c, Matrix23* H_point = nullptr,
                              CalibrationJacobian<Cal>* H_cal = nullptr) {
  Matrix23 H_normalized;
  Matrix2 H_p;
  const Vector2 p = ProjectToNormalized(p_c, H_point ? &H_normalized : nullptr);
  Projection out{.uv = Uncalibrate(K, p, H_point ? &H_p : nullptr, H_cal), .depth = p_c.z()};
  if (H_point) *H_point = H_p * H_normalized;
  return out;
}

// The pixel of world point `p_w` seen by a camera at `pose_wc` with calibration K.
template <typename Cal>
Projection Project(const Pose3& pose_wc, const Cal& K, const Point3& p_w,
                   Matrix26* H_pose = nullptr, Matrix23* H_point = nullptr,
                   CalibrationJacobian<Cal>* H_cal = nullptr) {
  Matrix36 H_pose_c;
  Matrix3 H_point_c;
  const Point3 p_c =
      pose_wc.TransformTo(p_w, H_pose ? &H_pose_c : nullptr, H_point ? &H_point_c : nullptr);
  Matrix23 H_c;  // ∂uv/∂P_c
  const Projection out = ProjectCameraFrame(K, p_c, (H_pose || H_point) ? &H_c : nullptr, H_cal);
  if (H_pose) *H_pose = H_c * H_pose_c;
  if (H_point) *H_point = H_c * H_point_c;
  return out;
}

// A stereo projection: (uL, uR, v) and whether the point is in front of the pair.
struct StereoProjection {
  Vector3 uuv = Vector3::Zero();
  double depth = 0.0;  // P_c.z in the left camera, metres
  bool in_front() const { return depth > 0.0; }
};

// H_pose = ∂(uL, uR, v)/∂ξ of the left camera's pose, H_point = ∂(uL, uR, v)/∂p_w.
StereoProjection ProjectStereo(const Pose3& pose_wc, const Cal3_S2Stereo& K, const Point3& p_w,
                               Matrix36* H_pose = nullptr, Matrix3* H_point = nullptr);

// The camera-frame point of a stereo measurement (uL, uR, v): depth fx·baseline / (uL - uR).
// Not finite for zero disparity.
Point3 BackprojectStereo(const Cal3_S2Stereo& K, const Vector3& uuv);

}  // namespace slamd::core
