// Reconstructions in a plot: detecting their files, choosing the plane, cameras and points.
#include "clients/slamctl/plot_reconstruction.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>

namespace slamd::clients::plot {
namespace {

// The world axes across and up the page.
std::pair<int, int> PlaneAxes(ViewPlane plane) {
  switch (plane) {
    case ViewPlane::kXY:
      return {0, 1};
    case ViewPlane::kXZ:
      return {0, 2};
    case ViewPlane::kYZ:
      return {1, 2};
  }
  return {0, 1};
}

Eigen::Vector2d InPlane(const Eigen::Vector3d& v, ViewPlane plane) {
  const auto [across, up] = PlaneAxes(plane);
  return {v(across), v(up)};
}

std::string AxisLabel(int axis) { return std::string(1, static_cast<char>('x' + axis)) + " [m]"; }

// The q-quantile (0 <= q <= 1) of `values` by rank, rounded outwards: towards the minimum below
// the median, the maximum above (reorders `values`).
double Quantile(std::vector<double>* values, double q) {
  const double rank = q * (values->size() - 1);
  const std::size_t k = static_cast<std::size_t>(q < 0.5 ? std::floor(rank) : std::ceil(rank));
  std::nth_element(values->begin(), values->begin() + k, values->end());
  return (*values)[k];
}

}  // namespace

const char* ViewPlaneName(ViewPlane plane) {
  switch (plane) {
    case ViewPlane::kXY:
      return "xy";
    case ViewPlane::kXZ:
      return "xz";
    case ViewPlane::kYZ:
      return "yz";
  }
  return "?";
}

core::Result<ViewPlane> ParseViewPlane(const std::string& name) {
  for (ViewPlane plane : {ViewPlane::kXY, ViewPlane::kXZ, ViewPlane::kYZ}) {
    if (name == ViewPlaneName(plane)) return plane;
  }
  return core::InvalidArgument("unknown view plane '" + name + "' (use xy, xz or yz)");
}

bool IsReconstructionPath(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return true;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    const std::size_t start = line.find_first_not_of(" \t\r");
    if (start == std::string::npos || line[start] == '#') continue;
    const std::size_t end = line.find_first_of(" \t\r", start);
    const std::string word = line.substr(start, end - start);
    return std::all_of(word.begin(), word.end(),
                       [](unsigned char c) { return std::isdigit(c) != 0; });
  }
  return false;
}

ViewPlane ChooseViewPlane(const core::Reconstruction& r) {
  if (r.images.empty()) return ViewPlane::kXY;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const core::SfmImage& image : r.images) mean += image.pose.translation();
  mean /= static_cast<double>(r.images.size());
  Eigen::Vector3d variance = Eigen::Vector3d::Zero();
  for (const core::SfmImage& image : r.images) {
    variance += (image.pose.translation() - mean).cwiseAbs2();
  }
  // Left out: the least spread, z when tied, then y.
  int left_out = 2;
  for (int axis : {1, 0}) {
    if (variance(axis) < variance(left_out)) left_out = axis;
  }
  return left_out == 2 ? ViewPlane::kXY : left_out == 1 ? ViewPlane::kXZ : ViewPlane::kYZ;
}

PlotReconstruction BuildReconstruction(const core::Reconstruction& r, ViewPlane plane) {
  PlotReconstruction out;
  const Eigen::Vector3d left = Eigen::Vector3d(-kWedgeHalfWidth, 0.0, 1.0).normalized();
  const Eigen::Vector3d right = Eigen::Vector3d(kWedgeHalfWidth, 0.0, 1.0).normalized();
  out.cameras.reserve(r.images.size());
  for (const core::SfmImage& image : r.images) {
    const Eigen::Matrix3d& R_wc = image.pose.rotation().matrix();
    PlotCamera camera{.center = InPlane(image.pose.translation(), plane),
                      .left_edge = InPlane(R_wc * left, plane),
                      .right_edge = InPlane(R_wc * right, plane)};
    out.extent.Add(camera.center);
    out.cameras.push_back(camera);
  }
  out.points.reserve(r.points.size());
  std::vector<double> across, up;
  for (const core::SfmPoint& p : r.points) {
    out.points.push_back({.position = InPlane(p.position, plane), .color = p.color});
    across.push_back(out.points.back().position.x());
    up.push_back(out.points.back().position.y());
  }
  if (!out.points.empty()) {
    out.extent.Add(Eigen::Vector2d(Quantile(&across, 0.01), Quantile(&up, 0.01)));
    out.extent.Add(Eigen::Vector2d(Quantile(&across, 0.99), Quantile(&up, 0.99)));
  }
  return out;
}

std::vector<Ellipse> CameraEllipses(const core::Reconstruction& r,
                                    const core::CameraCovariances& covariances, ViewPlane plane,
                                    double sigma) {
  const auto [across, up] = PlaneAxes(plane);
  std::vector<Ellipse> out;
  for (size_t i = 0; i < r.images.size() && i < covariances.per_image.size(); ++i) {
    const Eigen::Matrix3d R_wc = r.images[i].pose.rotation().matrix();
    const Eigen::Matrix3d centre =
        R_wc * covariances.per_image[i].topLeftCorner<3, 3>() * R_wc.transpose();
    if (centre.isZero()) continue;  // the gauge
    Eigen::Matrix2d in_plane;
    in_plane << centre(across, across), centre(across, up), centre(up, across), centre(up, up);
    out.push_back(
        CovarianceEllipse(InPlane(r.images[i].pose.translation(), plane), in_plane, sigma));
  }
  return out;
}

std::string HorizontalLabel(ViewPlane plane) { return AxisLabel(PlaneAxes(plane).first); }
std::string VerticalLabel(ViewPlane plane) { return AxisLabel(PlaneAxes(plane).second); }

}  // namespace slamd::clients::plot
