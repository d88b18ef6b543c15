#include "core/geometry/camera.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

namespace slamd::core {
namespace {

// Inverts Uncalibrate(K, ·) = uv from the guess p by Gauss-Newton. Two equations in two
// unknowns: the step solves H_p·step = residual exactly (Newton's step on the distortion).
template <typename Cal>
Vector2 InvertDistortion(const Cal& K, const Vector2& uv, Vector2 p) {
  constexpr int kMaxIterations = 20;
  constexpr double kTolerance = 1e-12;
  for (int i = 0; i < kMaxIterations; ++i) {
    Matrix2 H;
    const Vector2 residual = Uncalibrate(K, p, &H) - uv;
    // A singular H_p marks the edge of the range where the distortion is invertible: keep the
    // last iterate rather than jump to infinity.
    const double det = H.determinant();
    if (!(std::abs(det) > 0.0)) break;
    const Vector2 step = H.inverse() * residual;
    if (!step.allFinite()) break;
    p -= step;
    if (step.norm() <= kTolerance * std::max(1.0, p.norm())) break;
  }
  return p;
}

}  // namespace

Vector2 Calibrate(const Cal3_S2& K, const Vector2& uv) {
  const double y = (uv.y() - K.v0()) / K.fy();
  return Vector2((uv.x() - K.u0() - K.skew() * y) / K.fx(), y);
}

Vector2 Calibrate(const Cal3DS2& K, const Vector2& uv) {
  return InvertDistortion(K, uv, Calibrate(K.pinhole(), uv));
}

Vector2 Calibrate(const Cal3Bundler& K, const Vector2& uv) {
  return InvertDistortion(K, uv, Vector2(uv / K.f()));
}

StereoProjection ProjectStereo(const Pose3& pose_wc, const Cal3_S2Stereo& K, const Point3& p_w,
                               Matrix36* H_pose, Matrix3* H_point) {
  Matrix36 H_pose_c;
  Matrix3 H_point_c;
  const Point3 p_c =
      pose_wc.TransformTo(p_w, H_pose ? &H_pose_c : nullptr, H_point ? &H_point_c : nullptr);
  const bool jacobians = H_pose || H_point;
  Matrix23 H_left;  // ∂(uL, v)/∂P_c
  const Projection left = ProjectCameraFrame(K.K(), p_c, jacobians ? &H_left : nullptr);
  const double fx_b = K.K().fx() * K.baseline();
  const double inv_z = 1.0 / p_c.z();
  const StereoProjection out{.uuv = Vector3(left.uv.x(), left.uv.x() - fx_b * inv_z, left.uv.y()),
                             .depth = p_c.z()};
  if (jacobians) {
    // uR = uL - fx·b/z: uL's row plus ∂(-fx·b/z)/∂z = fx·b/z² in the z column.
    Matrix3 H_c;
    H_c.row(0) = H_left.row(0);
    H_c.row(1) = H_left.row(0);
    H_c(1, 2) += fx_b * inv_z * inv_z;
    H_c.row(2) = H_left.row(1);
    if (H_pose) *H_pose = H_c * H_pose_c;
    if (H_point) *H_point = H_c * H_point_c;
  }
  return out;
}

Point3 BackprojectStereo(const Cal3_S2Stereo& K, const Vector3& uuv) {
  const double z = K.K().fx() * K.baseline() / (uuv[0] - uuv[1]);
  const Vector2 p = Calibrate(K.K(), Vector2(uuv[0], uuv[2]));
  return Point3(p.x() * z, p.y() * z, z);
}

}  // namespace slamd::core
