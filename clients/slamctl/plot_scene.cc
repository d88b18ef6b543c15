// Building a PlotScene from a dataset, its values and optional marginals.
#include "clients/slamctl/plot_scene.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>

#include "core/base/check.h"
#include "core/isam/isam2.h"
#include "core/marginals/marginals.h"

namespace slamd::clients::plot {

void Box::Add(const Eigen::Vector2d& p) {
  if (empty()) {
    min = max = p;
    return;
  }
  min = min.cwiseMin(p);
  max = max.cwiseMax(p);
}

void Box::Add(const Box& b) {
  if (b.empty()) return;
  Add(b.min);
  Add(b.max);
}

Box Ellipse::Bounds() const {
  // Extreme x of c + a·cosφ·u·cos t − b·sinφ·sin t over t: half-width √(a²cos²φ + b²sin²φ).
  const double c = std::cos(angle), s = std::sin(angle);
  const double a2 = semi_major * semi_major, b2 = semi_minor * semi_minor;
  const Eigen::Vector2d half(std::sqrt(a2 * c * c + b2 * s * s), std::sqrt(a2 * s * s + b2 * c * c));
  Box box;
  box.Add(center - half);
  box.Add(center + half);
  return box;
}

Box PlotScene::Bounds() const {
  Box box;
  for (const PlotRobot& r : robots) {
    for (const Eigen::Vector2d& p : r.trajectory) box.Add(p);
    for (const Eigen::Vector2d& p : r.landmarks) box.Add(p);
    for (const auto& [a, b] : r.loop_closures) {
      box.Add(a);
      box.Add(b);
    }
    for (const Ellipse& e : r.pose_ellipses) box.Add(e.Bounds());
    for (const Ellipse& e : r.landmark_ellipses) box.Add(e.Bounds());
  }
  box.Add(reconstruction.extent);
  for (const Ellipse& e : reconstruction.camera_ellipses) box.Add(e.Bounds());
  return box;
}

std::size_t PlotScene::NumPoses() const {
  std::size_t n = 0;
  for (const PlotRobot& r : robots) n += r.trajectory.size();
  return n;
}
std::size_t PlotScene::NumLandmarks() const {
  std::size_t n = 0;
  for (const PlotRobot& r : robots) n += r.landmarks.size();
  return n;
}
std::size_t PlotScene::NumLoopClosures() const {
  std::size_t n = 0;
  for (const PlotRobot& r : robots) n += r.loop_closures.size();
  return n;
}
std::size_t PlotScene::NumEllipses() const {
  std::size_t n = reconstruction.camera_ellipses.size();
  for (const PlotRobot& r : robots) n += r.pose_ellipses.size() + r.landmark_ellipses.size();
  return n;
}

Ellipse CovarianceEllipse(const Eigen::Vector2d& center, const Eigen::Matrix2d& cov, double sigma) {
  const Eigen::Matrix2d sym = 0.5 * (cov + cov.transpose());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(sym);  // eigenvalues ascending
  const Eigen::Vector2d lambda = eig.eigenvalues().cwiseMax(0.0);
  const Eigen::Vector2d major = eig.eigenvectors().col(1);
  double angle = std::atan2(major.y(), major.x());
  // An axis has no direction: fold into (−π/2, π/2].
  if (angle <= -std::numbers::pi / 2) angle += std::numbers::pi;
  if (angle > std::numbers::pi / 2) angle -= std::numbers::pi;
  return Ellipse{.center = center,
                 .semi_major = sigma * std::sqrt(lambda(1)),
                 .semi_minor = sigma * std::sqrt(lambda(0)),
                 .angle = angle};
}

// The x-y position of a variable a plot draws (poses and points; VariableTraits::kPlotted).
core::Result<Eigen::Vector2d> DrawnPosition(const core::Values& values, core::Key key) {
  const core::Variable& v = values.Get(key);
  const std::optional<Eigen::Vector2d> p = core::PlanarPosition(v);
  if (!p) {
    return core::InvalidArgument(core::KeyToString(key) + " is a " +
                                 core::VariableTypeName(core::TypeOf(v)) +
                                 ", which a plot does not draw");
  }
  return *p;
}

core::Result<PlotRobot> BuildRobot(const std::string& name, const core::Dataset& data,
                                   const core::Values& values, const SceneOptions& options,
                                   const MarginalTable* marginals) {
  if (options.ellipse_every < 1 || !(options.sigma > 0.0)) {
    return core::InvalidArgument("SceneOptions: ellipse_every must be >= 1 and sigma > 0");
  }
  PlotRobot robot;
  robot.name = name;
  std::unordered_map<core::Key, std::size_t> order;  // pose key -> position in pose order
  robot.trajectory.reserve(data.poses.size());
  for (core::Key key : data.poses) {
    if (!values.Contains(key)) return core::InvalidArgument("no value for pose " + core::KeyToString(key));
    order.emplace(key, robot.trajectory.size());
    core::Result<Eigen::Vector2d> position = DrawnPosition(values, key);
    if (!position.ok()) return position.status();
    robot.trajectory.push_back(*position);
  }
  for (core::Key key : data.landmarks) {
    if (!values.Contains(key)) {
      return core::InvalidArgument("no value for landmark " + core::KeyToString(key));
    }
    core::Result<Eigen::Vector2d> position = DrawnPosition(values, key);
    if (!position.ok()) return position.status();
    robot.landmarks.push_back(*position);
  }
  for (const core::FactorPtr& f : data.graph) {
    if (f->keys().size() != 2) continue;
    const auto a = order.find(f->keys()[0]), b = order.find(f->keys()[1]);
    if (a == order.end() || b == order.end()) continue;  // not pose-pose
    const std::size_t i = a->second, j = b->second;
    if (i + 1 == j || j + 1 == i) continue;  // odometry: drawn as the trajectory
    robot.loop_closures.emplace_back(robot.trajectory[i], robot.trajectory[j]);
  }
  if (marginals == nullptr) return robot;
  const auto add_ellipse = [&](core::Key key, std::vector<Ellipse>* out) {
    const auto it = marginals->find(key);
    if (it == marginals->end()) return;
    const core::Variable& v = values.Get(key);
    out->push_back(CovarianceEllipse(*core::PlanarPosition(v),
                                     core::PlanarCovariance(v, it->second), options.sigma));
  };
  const std::size_t n = data.poses.size();
  for (std::size_t i = 0; i < n; i += options.ellipse_every) add_ellipse(data.poses[i], &robot.pose_ellipses);
  if (n > 0 && (n - 1) % options.ellipse_every != 0) add_ellipse(data.poses.back(), &robot.pose_ellipses);
  if (options.landmark_ellipses) {
    for (core::Key key : data.landmarks) add_ellipse(key, &robot.landmark_ellipses);
  }
  return robot;
}

core::Result<MarginalTable> ComputeMarginals(const core::FactorGraph& graph,
                                             const core::Values& values,
                                             const std::vector<core::Key>& keys) {
  for (core::Key key : keys) {
    if (!values.Contains(key)) return core::NotFound("no value for " + core::KeyToString(key));
  }
  core::Result<std::unique_ptr<core::Isam2>> created = core::Isam2::Create();
  if (!created.ok()) return created.status();
  core::Isam2& isam = **created;
  // One update linearises every factor at `values` and eliminates the whole graph; the tree's
  // marginals are then those of the Gaussian approximation at `values` (the frame we need).
  const core::Isam2Result result = isam.Update(graph, values);
  if (!result.status.ok()) return result.status;
  core::Isam2Marginals marginals(&isam);
  marginals.ComputeAll();
  MarginalTable table;
  table.reserve(keys.size());
  Eigen::MatrixXd cov;
  for (core::Key key : keys) {
    SLAMD_RETURN_IF_ERROR(
        marginals.CachedMarginal(key, core::Isam2Marginals::Frame::kLinearizationPoint, &cov));
    table[key] = cov;
  }
  return table;
}

}  // namespace slamd::clients::plot
