// Triangulation: the 3-D point that n >= 2 calibrated views of it observed, for structure from
// motion's new points and for initialising landmarks of projection factors
// (core/factors/projection_factor.h), which cannot place a landmark from one view.
//
// Conventions are camera.h's: poses T_wc (camera -> world), +z forward, pixels through the
// view's calibration. Algorithm:
//   1. normalised coordinates of every pixel (Calibrate) and its ray in the world;
//   2. the parallax check: the largest angle between any two views' rays must reach
//      min_parallax_deg, or the depth along the rays is not determined by the data;
//   3. linear DLT on normalised coordinates: the right singular vector of the 2n x 4 system
//      x·(P₃·X) − P₁·X = 0, y·(P₃·X) − P₂·X = 0 (Hartley & Zisserman, "Multiple View Geometry",
//      §12.2), world coordinates taken relative to the cameras' centroid and scaled by their mean
//      distance to it, so that far-from-origin scenes stay well conditioned;
//   4. Gauss-Newton on the reprojection error in pixels, Σ|Project(pose_i, K_i, X) − uv_i|², with
//      Project's point Jacobian; a step that does not lower the error ends the iteration;
//   5. the checks: in front of every camera, RMS reprojection error within
//      max_reprojection_px.
// Cost: O(n²) for the parallax (pairs of rays), O(n) per iteration otherwise; the DLT allocates
// its 2n x 4 system once per call. Stateless and thread-safe.
#pragma once

#include <span>

#include "core/base/status.h"
#include "core/geometry/calibration.h"
#include "core/geometry/eigen_types.h"
#include "core/geometry/pose3.h"

namespace slamd::core {

struct TriangulationParams {
  // Degrees, >= 0 and < 180: the largest angle between two views' rays must be at least this.
  // Default 1.
  double min_parallax_deg = 1.0;
  // Pixels, > 0: the largest RMS reprojection error (over the views, of each view's error norm)
  // accepted. Default 4.
  double max_reprojection_px = 4.0;
  // Gauss-Newton iterations after the DLT, >= 0 (0: the DLT point as is). Default 10.
  int max_iterations = 10;

  // Checks every field; the message names the field, its value and the constraint.
  Status Validate() const;
};

struct TriangulatedPoint {
  Point3 position = Point3::Zero();  // world frame, metres
  // (JᵀJ)⁻¹ at `position`, J the stacked 2n x 3 point Jacobian of the reprojection errors: the
  // covariance for pixel noise of sigma 1 px on each coordinate. For sigma σ px, scale by σ².
  Matrix3 covariance = Matrix3::Zero();
  double rms_reprojection_px = 0.0;  // sqrt(Σ_i |Project_i(position) − uv_i|² / n)
  int iterations = 0;                // Gauss-Newton steps taken
};

// The point seen at pixels[i] by the camera at poses_wc[i] with calibrations[i], for Cal =
// Cal3_S2, Cal3DS2, Cal3Bundler, or Calibration when the views have different models
// (instantiated in triangulation.cc; spell the template argument
// when passing containers: Triangulate<Cal3DS2>(poses, calibrations, pixels)). Failures:
//   kInvalidArgument     invalid params; spans of different sizes; fewer than 2 views; a pose,
//                        calibration or pixel that is not finite (the message names the view);
//   kFailedPrecondition  parallax below min_parallax_deg (the message gives the angle); the
//                        point at or behind a camera (names the view and the depth); RMS
//                        reprojection error above max_reprojection_px (gives the value);
//   kNumericalFailure    the DLT put the point at infinity, or JᵀJ is not positive definite.
template <typename Cal>
Result<TriangulatedPoint> Triangulate(std::span<const Pose3> poses_wc,
                                      std::span<const Cal> calibrations,
                                      std::span<const Vector2> pixels,
                                      const TriangulationParams& params = {});

extern template Result<TriangulatedPoint> Triangulate<Cal3_S2>(std::span<const Pose3>,
                                                               std::span<const Cal3_S2>,
                                                               std::span<const Vector2>,
                                                               const TriangulationParams&);
extern template Result<TriangulatedPoint> Triangulate<Cal3DS2>(std::span<const Pose3>,
                                                               std::span<const Cal3DS2>,
                                                               std::span<const Vector2>,
                                                               const TriangulationParams&);
extern template Result<TriangulatedPoint> Triangulate<Cal3Bundler>(std::span<const Pose3>,
                                                                   std::span<const Cal3Bundler>,
                                                                   std::span<const Vector2>,
                                                                   const TriangulationParams&);

extern template Result<TriangulatedPoint> Triangulate<Calibration>(std::span<const Pose3>,
                                                                   std::span<const Calibration>,
                                                                   std::span<const Vector2>,
                                                                   const TriangulationParams&);

}  // namespace slamd::core
