// PlotScene: a plain description of what `slamctl plot` draws, in world metres, independent of
// where the data came from (a dataset, an optimised dataset, the live server's map_t, a
// structure-from-motion reconstruction) and of how it is drawn (plot_render.h takes a PlotScene
// and nothing else).
//
// The picture of robots is a top-down view of the world x-y plane: Pose3 and Point3 values are
// projected by dropping z. A reconstruction is seen in the plane plot_reconstruction.h chooses
// (PlotScene::x_label and y_label name its axes). Covariance ellipses are of the x-y marginal in
// the WORLD frame:
//   * Pose2: slamd's chart is X·Pose2(δ), δ = (dx, dy, dθ), so to first order the position moves
//     by R·(dx, dy): Σ_xy = R Σ_tt Rᵀ with Σ_tt the top-left 2x2 block of the 3x3 marginal.
//   * Pose3: X·Exp(ξ), ξ = (v, ω) translation first; to first order t moves by R·v, so the world
//     translation covariance is R Σ_vv Rᵀ (3x3) and the ellipse uses its x-y block.
//   * Point2 / Point3: the chart is plain addition; Σ_xy is the (top-left) 2x2 block.
// The covariances given must be in the tangent space AT THE VALUES PLOTTED (e.g. Isam2Marginals
// with Frame::kLinearizationPoint after linearising at those values; see ComputeMarginals).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/base/key.h"
#include "core/base/status.h"
#include "core/factors/factor_graph.h"
#include "core/factors/values.h"
#include "core/io/dataset.h"
#include "core/variables/variable.h"

namespace slamd::clients::plot {

// An axis-aligned box in world metres. Empty (min > max) until something is added.
struct Box {
  Eigen::Vector2d min{1.0, 1.0};
  Eigen::Vector2d max{-1.0, -1.0};
  bool empty() const { return !(min.x() <= max.x() && min.y() <= max.y()); }
  void Add(const Eigen::Vector2d& p);
  void Add(const Box& b);
};

// The k-sigma ellipse {p : (p − c)ᵀ Σ⁻¹ (p − c) = k²}.
struct Ellipse {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();  // metres
  double semi_major = 0.0;  // k·√λ_max, metres
  double semi_minor = 0.0;  // k·√λ_min, metres
  double angle = 0.0;       // of the major axis from +x, counter-clockwise, radians in (−π/2, π/2]
  Box Bounds() const;       // tight axis-aligned bounding box
};

// One trajectory: one robot's (one dataset's) poses, landmarks and loop closures.
struct PlotRobot {
  std::string name;                           // legend label (e.g. the dataset's file name)
  std::vector<Eigen::Vector2d> trajectory;    // pose positions in pose order (ascending id)
  std::vector<Eigen::Vector2d> landmarks;     // landmark positions
  // Pose-pose constraints that are not odometry (the two poses are not neighbours in pose
  // order): segments between the two positions. Odometry is the trajectory line itself.
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> loop_closures;
  std::vector<Ellipse> pose_ellipses;         // subsampled (SceneOptions::ellipse_every)
  std::vector<Ellipse> landmark_ellipses;
};

// One camera of a reconstruction: a wedge from its centre showing where it looks.
struct PlotCamera {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();  // metres, in the picture's plane
  // The unit directions of the edges of its view (plot_reconstruction.h) projected into the
  // picture's plane: length 1 when the camera looks along the plane, shorter as it looks across
  // it. The renderer draws them at a fixed length on the page.
  Eigen::Vector2d left_edge = Eigen::Vector2d::Zero();
  Eigen::Vector2d right_edge = Eigen::Vector2d::Zero();
};

// One 3-D point of a reconstruction, drawn as a small dot in its colour.
struct PlotPoint {
  Eigen::Vector2d position = Eigen::Vector2d::Zero();   // metres, in the picture's plane
  std::array<std::uint8_t, 3> color = {128, 128, 128};  // RGB
};

// A structure-from-motion reconstruction (plot_reconstruction.h builds it).
struct PlotReconstruction {
  std::vector<PlotCamera> cameras;
  std::vector<PlotPoint> points;
  // The k-sigma ellipses of the camera centres' marginal covariances in the picture's plane, one
  // per camera, when they are known (empty otherwise): drawn like pose ellipses, counted by
  // PlotScene::NumEllipses.
  std::vector<Ellipse> camera_ellipses;
  // What the picture must show: every camera and the bulk of the points (a few far-away points
  // would otherwise shrink the rest to a dot); points outside are clipped.
  Box extent;
};

struct PlotScene {
  std::string title;     // first line, e.g. "intel.g2o: 1228 poses, 1483 edges"
  std::string subtitle;  // second line (may be empty), e.g. "optimised; 3σ ellipses every 10th pose"
  double sigma = 3.0;    // the k of the ellipses, for the legend
  std::vector<PlotRobot> robots;  // one colour each, in this order
  PlotReconstruction reconstruction;  // empty unless a reconstruction is plotted
  std::string x_label = "x [m]";      // axis titles
  std::string y_label = "y [m]";

  // Everything drawn: positions, loop-closure ends, the ellipses' bounding boxes and the
  // reconstruction's extent.
  Box Bounds() const;
  std::size_t NumPoses() const;
  std::size_t NumLandmarks() const;
  std::size_t NumLoopClosures() const;
  std::size_t NumEllipses() const;  // the robots' and the cameras'
};

struct SceneOptions {
  // Pose ellipses for poses 0, K, 2K, ... in pose order (and the last pose). >= 1.
  int ellipse_every = 10;
  // Landmark ellipses (when marginals are given): every landmark.
  bool landmark_ellipses = true;
  // k of the k-sigma ellipses. > 0.
  double sigma = 3.0;
};

// Marginal covariances by key, in the tangent space at the plotted values (see file comment).
using MarginalTable = std::unordered_map<core::Key, Eigen::MatrixXd>;

// The k-sigma ellipse of a 2x2 covariance (symmetrised first; negative eigenvalues from
// round-off are clamped to 0).
Ellipse CovarianceEllipse(const Eigen::Vector2d& center, const Eigen::Matrix2d& cov, double sigma);

// One robot from a dataset: positions from `values` (the dataset's initial guess or an optimised
// estimate; every key of data.poses / data.landmarks must be in it, else kInvalidArgument),
// loop closures from data.graph, ellipses from `marginals` when it is not null (keys missing
// from it get no ellipse).
core::Result<PlotRobot> BuildRobot(const std::string& name, const core::Dataset& data,
                                   const core::Values& values, const SceneOptions& options,
                                   const MarginalTable* marginals);

// Marginal covariances of `keys` for `graph` linearised at `values` (the graph must fix the
// gauge, e.g. with core::AddGaugePrior): runs core::Isam2 over the whole graph in one update and
// reads every clique's joint in one top-down pass (core::Isam2Marginals), so the cost is that of
// one sparse factorisation plus O(Σ clique sizes³): fine for large graphs (no dense inverse).
// Errors: the solver's (e.g. an indeterminate system), or kNotFound for a key not in `values`.
core::Result<MarginalTable> ComputeMarginals(const core::FactorGraph& graph,
                                             const core::Values& values,
                                             const std::vector<core::Key>& keys);

}  // namespace slamd::clients::plot
