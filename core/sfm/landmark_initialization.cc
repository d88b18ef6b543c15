#include "core/sfm/landmark_initialization.h"

#include <cmath>
#include <string>
#include <variant>
#include <vector>

#include "core/base/param_check.h"
#include "core/geometry/camera.h"
#include "core/sfm/triangulation.h"

namespace slamd::core {
namespace {

Status CheckViews(std::span<const LandmarkView> views) {
  for (std::size_t i = 0; i < views.size(); ++i) {
    const LandmarkView& v = views[i];
    const std::string name = "view " + std::to_string(i);
    if (v.stereo() && !std::holds_alternative<Cal3_S2>(v.calibration)) {
      return InvalidArgument(name + ": a stereo view needs a Cal3_S2 calibration");
    }
    const bool finite =
        v.camera_pose.matrix().allFinite() && v.uv.allFinite() && std::isfinite(v.u_right) &&
        std::isfinite(v.baseline) &&
        std::visit([](const auto& K) { return K.vector().allFinite(); }, v.calibration);
    if (!finite) return InvalidArgument(name + ": a value is not finite");
  }
  return Status::Ok();
}

// The position the views give, before the common checks.
Result<Point3> Candidate(std::span<const LandmarkView> views,
                         const LandmarkInitializationParams& params) {
  // The stereo view with the largest disparity, when it is large enough.
  int best = -1;
  double best_disparity = params.min_disparity_px;
  for (std::size_t i = 0; i < views.size(); ++i) {
    const double disparity = views[i].uv.x() - views[i].u_right;
    if (views[i].stereo() && disparity >= best_disparity) {
      best = static_cast<int>(i);
      best_disparity = disparity;
    }
  }
  if (best >= 0) {
    const LandmarkView& v = views[best];
    const Cal3_S2Stereo K(std::get<Cal3_S2>(v.calibration), v.baseline);
    return v.camera_pose.TransformFrom(
        BackprojectStereo(K, Vector3(v.uv.x(), v.u_right, v.uv.y())));
  }
  if (static_cast<int>(views.size()) < params.min_views) {
    return FailedPrecondition(
        std::to_string(views.size()) + " view(s) (" + std::to_string(params.min_views) + " needed" +
        (views.empty() || !views[0].stereo()
             ? ")"
             : ", or a stereo disparity of " + std::to_string(params.min_disparity_px) + " px)"));
  }
  std::vector<Pose3> poses;
  std::vector<Calibration> calibrations;
  std::vector<Vector2> pixels;
  for (const LandmarkView& v : views) {
    poses.push_back(v.camera_pose);
    calibrations.push_back(v.calibration);
    pixels.push_back(v.uv);
  }
  Result<TriangulatedPoint> t =
      Triangulate<Calibration>(poses, calibrations, pixels,
                               {.min_parallax_deg = params.min_parallax_deg,
                                .max_reprojection_px = params.max_reprojection_px});
  if (!t.ok()) return t.status();
  return t->position;
}

}  // namespace

Status LandmarkInitializationParams::Validate() const {
  SLAMD_PARAM_CHECK(LandmarkInitializationParams, min_views, >=, 2);
  SLAMD_PARAM_CHECK(LandmarkInitializationParams, min_parallax_deg, >=, 0.0);
  SLAMD_PARAM_CHECK(LandmarkInitializationParams, min_parallax_deg, <, 180.0);
  SLAMD_PARAM_CHECK(LandmarkInitializationParams, max_reprojection_px, >, 0.0);
  SLAMD_PARAM_CHECK(LandmarkInitializationParams, min_disparity_px, >, 0.0);
  return Status::Ok();
}

double SquaredReprojectionError(const LandmarkView& view, const Point3& X, double* depth) {
  if (view.stereo()) {
    const Cal3_S2Stereo K(std::get<Cal3_S2>(view.calibration), view.baseline);
    const StereoProjection p = ProjectStereo(view.camera_pose, K, X);
    *depth = p.depth;
    return (p.uuv - Vector3(view.uv.x(), view.u_right, view.uv.y())).squaredNorm();
  }
  return std::visit(
      [&](const auto& K) {
        const Projection p = Project(view.camera_pose, K, X);
        *depth = p.depth;
        return (p.uv - view.uv).squaredNorm();
      },
      view.calibration);
}

Result<Point3> InitializeLandmark(std::span<const LandmarkView> views,
                                  const LandmarkInitializationParams& params) {
  SLAMD_RETURN_IF_ERROR(params.Validate());
  SLAMD_RETURN_IF_ERROR(CheckViews(views));
  Result<Point3> X = Candidate(views, params);
  if (!X.ok()) return X.status();
  double sum = 0.0;
  for (std::size_t i = 0; i < views.size(); ++i) {
    double depth = 0.0;
    sum += SquaredReprojectionError(views[i], *X, &depth);
    if (!(depth > 0.0)) {
      return FailedPrecondition("the point is behind view " + std::to_string(i) + " (depth " +
                                std::to_string(depth) + " m)");
    }
  }
  const double rms = std::sqrt(sum / static_cast<double>(views.size()));
  if (!(rms <= params.max_reprojection_px)) {
    return FailedPrecondition(
        "RMS reprojection error " + std::to_string(rms) +
        " px exceeds max_reprojection_px = " + std::to_string(params.max_reprojection_px));
  }
  return *X;
}

}  // namespace slamd::core
