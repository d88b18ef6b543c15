// Whether the camera views of a landmark determine it, and where: the rule a live system applies
// before a landmark enters its graph. A landmark seen in one image, or along nearly parallel
// rays (pure rotation, a distant point), leaves its depth to the solver's round-off (GTSAM's
// "indeterminant linear system"); one behind a camera or far from its pixels is a wrong match.
// Until the views determine it, its observations wait (server/estimator/landmark_tracks.h).
//
// Determined when either
//   * a stereo view (rectified pair, Cal3_S2 + baseline) sees it with at least
//     min_disparity_px: the point is that view's back-projection; or
//   * at least min_views views (stereo views count by their left pixel) triangulate it
//     (core/sfm/triangulation.h: parallax of at least min_parallax_deg, DLT + Gauss-Newton);
// and it is then in front of every view and its RMS reprojection error over the views (stereo
// views: the norm of the (uL, uR, v) error) is at most max_reprojection_px.
#pragma once

#include <span>

#include "core/base/status.h"
#include "core/geometry/calibration.h"
#include "core/geometry/eigen_types.h"
#include "core/geometry/pose3.h"

namespace slamd::core {

struct LandmarkView {
  Pose3 camera_pose;  // T_wc (camera -> world) at the current estimate
  Calibration calibration = Cal3_S2();
  Vector2 uv = Vector2::Zero();  // the pixel (the left image's for a stereo view)
  double baseline = 0.0;         // > 0: a stereo view (calibration must be a Cal3_S2)
  double u_right = 0.0;          // stereo: u in the right image

  bool stereo() const { return baseline > 0.0; }
};

struct LandmarkInitializationParams {
  int min_views = 2;                 // >= 2: views needed when no stereo view places it
  double min_parallax_deg = 1.0;     // >= 0, < 180
  double max_reprojection_px = 4.0;  // > 0
  double min_disparity_px = 10.0;    // > 0: a stereo view places the point above this

  Status Validate() const;
};

// |error|² of `view` at world point X [px²] (stereo: of (uL, uR, v)), and in *depth the point's
// depth in the (left) camera [m]: > 0 in front.
double SquaredReprojectionError(const LandmarkView& view, const Point3& X, double* depth);

// The landmark's position (world frame) when `views` determine it. kFailedPrecondition with the
// reason when they do not (yet): "1 view (2 needed)", "parallax 0.2 deg is below ...", "the
// point is behind view 1 ...", "RMS reprojection error 9.1 px exceeds ...". kInvalidArgument
// for invalid params, a stereo view whose calibration is not a Cal3_S2, or values not finite.
Result<Point3> InitializeLandmark(std::span<const LandmarkView> views,
                                  const LandmarkInitializationParams& params = {});

}  // namespace slamd::core
