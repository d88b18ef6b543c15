#include "core/ba/point_initialization.h"

#include <cmath>
#include <string>
#include <vector>

#include "core/ba/problem_dispatch.h"
#include "core/geometry/camera.h"

namespace slamd::core {
namespace {

// The RMS reprojection error of `x` in the views, and how many views see it at or behind them.
template <typename Cal>
double Rms(const std::vector<Pose3>& poses, const std::vector<Cal>& cals,
           const std::vector<Vector2>& pixels, const Point3& x, int* behind) {
  double sq = 0.0;
  *behind = 0;
  for (size_t v = 0; v < poses.size(); ++v) {
    const Projection p = Project(poses[v], cals[v], x);
    *behind += !p.in_front();
    sq += (p.uv - pixels[v]).squaredNorm();
  }
  return std::sqrt(sq / static_cast<double>(poses.size()));
}

template <typename Cal>
PointInitializationReport Retriangulate(Reconstruction* r, double poor_rms_px,
                                        const TriangulationParams& params) {
  std::vector<std::vector<int>> observations_of(r->points.size());
  for (size_t o = 0; o < r->observations.size(); ++o) {
    observations_of[r->observations[o].point].push_back(static_cast<int>(o));
  }
  PointInitializationReport report;
  std::vector<Pose3> poses;
  std::vector<Cal> cals;
  std::vector<Vector2> pixels;
  for (size_t j = 0; j < r->points.size(); ++j) {
    if (observations_of[j].empty()) continue;
    poses.clear(), cals.clear(), pixels.clear();
    for (int o : observations_of[j]) {
      const SfmImage& image = r->images[r->observations[o].image];
      poses.push_back(image.pose);
      cals.push_back(std::get<Cal>(r->intrinsics[image.intrinsics].calibration));
      pixels.push_back(r->observations[o].uv);
    }
    int behind = 0;
    const double rms = Rms(poses, cals, pixels, r->points[j].position, &behind);
    if (rms <= poor_rms_px && 2 * behind <= static_cast<int>(poses.size())) continue;
    ++report.poor;
    const Result<TriangulatedPoint> t = Triangulate<Cal>(poses, cals, pixels, params);
    if (!t.ok()) continue;
    int behind_after = 0;
    if (Rms(poses, cals, pixels, t->position, &behind_after) < rms || behind_after < behind) {
      r->points[j].position = t->position;
      ++report.replaced;
    }
  }
  return report;
}

}  // namespace

Result<PointInitializationReport> RetriangulatePoorPoints(Reconstruction* reconstruction,
                                                          double poor_rms_px,
                                                          const TriangulationParams& params) {
  if (!(poor_rms_px > 0.0)) {
    return InvalidArgument("RetriangulatePoorPoints: poor_rms_px = " + std::to_string(poor_rms_px) +
                           "; must be positive");
  }
  if (Status s = params.Validate(); !s.ok()) return s;
  if (Status s = internal::CheckAdjustable(*reconstruction, "RetriangulatePoorPoints"); !s.ok()) {
    return s;
  }
  return std::visit(
      [&](const auto& calibration) {
        using Cal = std::decay_t<decltype(calibration)>;
        return Result<PointInitializationReport>(
            Retriangulate<Cal>(reconstruction, poor_rms_px, params));
      },
      reconstruction->intrinsics.front().calibration);
}

}  // namespace slamd::core
