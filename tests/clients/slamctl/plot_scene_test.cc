// Tests of the PlotScene builders: ellipse geometry, the body-to-world rotation of pose
// covariances (against finite differences of the chart), loop-closure detection, subsampling,
// bounds, and the marginals (against a dense inverse of the Hessian on a small graph).
#include "clients/slamctl/plot_scene.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <numbers>
#include <random>

#include "core/batch/batch_solver.h"
#include "core/geometry/pose2.h"
#include "core/geometry/pose3.h"
#include "tests/testing/datasets.h"

namespace slamd::clients::plot {
namespace {

using std::numbers::pi;

Eigen::Matrix2d Rot(double angle) {
  Eigen::Matrix2d R;
  R << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);
  return R;
}

TEST(CovarianceEllipseTest, RotatedDiagonal) {
  // Σ = R(30°) diag(4, 1) R(30°)ᵀ: 3σ semi-axes 3·2 and 3·1, the major one at 30°.
  const Eigen::Matrix2d cov =
      Rot(pi / 6) * Eigen::Vector2d(4.0, 1.0).asDiagonal() * Rot(pi / 6).transpose();
  const Ellipse e = CovarianceEllipse({1.0, 2.0}, cov, 3.0);
  EXPECT_NEAR(e.semi_major, 6.0, 1e-12);
  EXPECT_NEAR(e.semi_minor, 3.0, 1e-12);
  EXPECT_NEAR(e.angle, pi / 6, 1e-12);
  EXPECT_EQ(e.center, Eigen::Vector2d(1.0, 2.0));
}

TEST(CovarianceEllipseTest, AngleFoldedIntoHalfOpenRange) {
  const Eigen::Matrix2d cov =
      Rot(2 * pi / 3) * Eigen::Vector2d(9.0, 4.0).asDiagonal() * Rot(2 * pi / 3).transpose();
  const Ellipse e = CovarianceEllipse({0.0, 0.0}, cov, 1.0);
  EXPECT_NEAR(e.semi_major, 3.0, 1e-12);
  EXPECT_NEAR(e.semi_minor, 2.0, 1e-12);
  EXPECT_NEAR(e.angle, -pi / 3, 1e-12);  // 120° is the same axis as −60°
  const Ellipse vertical = CovarianceEllipse({0.0, 0.0}, Eigen::Vector2d(1.0, 4.0).asDiagonal(), 1.0);
  EXPECT_NEAR(vertical.angle, pi / 2, 1e-12);
}

TEST(CovarianceEllipseTest, SingularCovarianceGivesFlatEllipse) {
  Eigen::Matrix2d cov;
  cov << 1.0, 1.0, 1.0, 1.0 - 1e-17;  // rank one up to round-off, possibly a tiny negative eigenvalue
  const Ellipse e = CovarianceEllipse({0.0, 0.0}, cov, 3.0);
  EXPECT_NEAR(e.semi_major, 3.0 * std::sqrt(2.0), 1e-9);
  EXPECT_GE(e.semi_minor, 0.0);
  EXPECT_LT(e.semi_minor, 1e-6);
  EXPECT_NEAR(e.angle, pi / 4, 1e-9);
}

TEST(EllipseTest, BoundsAreTight) {
  const Ellipse e{.center = {2.0, -1.0}, .semi_major = 5.0, .semi_minor = 2.0, .angle = 0.7};
  // Reference: sample the boundary densely.
  Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
  for (int k = 0; k < 100000; ++k) {
    const double t = 2 * pi * k / 100000;
    const Eigen::Vector2d p = e.center + Rot(e.angle) * Eigen::Vector2d(5.0 * std::cos(t), 2.0 * std::sin(t));
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Box b = e.Bounds();
  EXPECT_NEAR((b.min - lo).norm(), 0.0, 1e-6);
  EXPECT_NEAR((b.max - hi).norm(), 0.0, 1e-6);
}

// Reference for WorldXyCovariance: J = ∂ xy(X ⊕ δ) / ∂δ by central differences, Σ_xy = J Σ Jᵀ.
template <typename Pose, int D>
Eigen::Matrix2d NumericalWorldXy(const Pose& X, const Eigen::Matrix<double, D, D>& cov) {
  Eigen::Matrix<double, 2, D> J;
  const double h = 1e-6;
  for (int i = 0; i < D; ++i) {
    Eigen::Matrix<double, D, 1> d = Eigen::Matrix<double, D, 1>::Zero();
    d(i) = h;
    const Eigen::Vector2d plus = X.Retract(d).translation().template head<2>();
    const Eigen::Vector2d minus = X.Retract(-d).translation().template head<2>();
    J.col(i) = (plus - minus) / (2 * h);
  }
  return J * cov * J.transpose();
}

template <int D>
Eigen::Matrix<double, D, D> RandomCovariance(std::mt19937* rng) {
  std::normal_distribution<double> n;
  Eigen::Matrix<double, D, D> A;
  for (int i = 0; i < D * D; ++i) A.data()[i] = n(*rng);
  return A * A.transpose() + 0.1 * Eigen::Matrix<double, D, D>::Identity();
}

TEST(WorldXyCovarianceTest, Pose2RotatesBodyTranslationIntoWorld) {
  // At θ = 90° the body x axis is world y: diag(4, 1) in the body is diag(1, 4) in the world.
  const core::Pose2 X(3.0, 4.0, pi / 2);
  const Eigen::Matrix3d body = Eigen::Vector3d(4.0, 1.0, 0.5).asDiagonal();
  const Eigen::Matrix2d world = core::PlanarCovariance(X, body);
  EXPECT_NEAR((world - Eigen::Matrix2d(Eigen::Vector2d(1.0, 4.0).asDiagonal())).norm(), 0.0, 1e-12) << world;
  std::mt19937 rng(7);
  for (double theta : {-2.5, 0.3, 1.9}) {
    const core::Pose2 Y(1.0, -2.0, theta);
    const Eigen::Matrix3d cov = RandomCovariance<3>(&rng);
    EXPECT_NEAR((core::PlanarCovariance(Y, cov) - NumericalWorldXy<core::Pose2, 3>(Y, cov)).norm(),
                0.0, 1e-8);
  }
}

TEST(WorldXyCovarianceTest, Pose3RotatesTranslationBlockBeforeProjecting) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 3; ++trial) {
    core::Vector6 xi;
    std::normal_distribution<double> n;
    for (int i = 0; i < 6; ++i) xi(i) = n(rng);
    const core::Pose3 X = core::Pose3::Exp(xi);
    const core::Matrix6 cov = RandomCovariance<6>(&rng);
    const Eigen::Matrix2d world = core::PlanarCovariance(X, cov);
    EXPECT_NEAR((world - NumericalWorldXy<core::Pose3, 6>(X, cov)).norm(), 0.0, 1e-7);
    // Taking the x-y block before rotating would be wrong for a tilted pose.
    EXPECT_GT((world - (X.rotation().matrix().topLeftCorner<2, 2>() * cov.topLeftCorner<2, 2>() *
                        X.rotation().matrix().topLeftCorner<2, 2>().transpose()))
                  .norm(),
              1e-6);
  }
}

TEST(WorldXyCovarianceTest, PointsAreAdditive) {
  const Eigen::Matrix3d cov = Eigen::Vector3d(2.0, 3.0, 4.0).asDiagonal();
  const Eigen::Matrix2d expected = Eigen::Vector2d(2.0, 3.0).asDiagonal();
  EXPECT_EQ(core::PlanarCovariance(core::Point3(1.0, 2.0, 3.0), cov), expected);
  const Eigen::Matrix2d block = cov.topLeftCorner<2, 2>();
  EXPECT_EQ(core::PlanarCovariance(core::Point2(1.0, 2.0), block), block);
}

core::Dataset SmallDataset() {
  core::Result<core::Dataset> data = core::ReadDataset(testing::TestDataPath("small_slam2d.g2o"));
  SLAMD_CHECK(data.ok()) << data.status().ToString();
  return std::move(data).value();
}

TEST(BuildRobotTest, TrajectoryLandmarksAndLoopClosures) {
  const core::Dataset data = SmallDataset();
  const core::Result<PlotRobot> robot = BuildRobot("small", data, data.initial, {}, nullptr);
  ASSERT_TRUE(robot.ok()) << robot.status().ToString();
  EXPECT_EQ(robot->name, "small");
  ASSERT_EQ(robot->trajectory.size(), 5u);
  EXPECT_EQ(robot->trajectory[1], Eigen::Vector2d(1.0, 0.1));
  EXPECT_EQ(robot->landmarks.size(), 2u);
  EXPECT_EQ(robot->landmarks[0], Eigen::Vector2d(1.5, 2.0));
  // Pose ids 0 1 2 3 5: the edge 5 -> 3 joins neighbours in pose order (odometry); 3 -> 0 is the
  // only loop closure.
  ASSERT_EQ(robot->loop_closures.size(), 1u);
  EXPECT_EQ(robot->loop_closures[0].first, robot->trajectory[3]);
  EXPECT_EQ(robot->loop_closures[0].second, robot->trajectory[0]);
  EXPECT_TRUE(robot->pose_ellipses.empty());

  PlotScene scene;
  scene.robots.push_back(*robot);
  const Box box = scene.Bounds();
  Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
  for (core::Key key : data.initial.keys()) {
    lo = lo.cwiseMin(*core::PlanarPosition(data.initial.Get(key)));
    hi = hi.cwiseMax(*core::PlanarPosition(data.initial.Get(key)));
  }
  EXPECT_EQ(box.min, lo);
  EXPECT_EQ(box.max, hi);
  EXPECT_EQ(scene.NumPoses(), 5u);
  EXPECT_EQ(scene.NumLandmarks(), 2u);
  EXPECT_EQ(scene.NumLoopClosures(), 1u);
}

TEST(BuildRobotTest, EllipsesAreSubsampledAndIncludeTheLastPose) {
  const core::Dataset data = SmallDataset();
  MarginalTable table;
  for (core::Key key : data.poses) table[key] = 0.01 * Eigen::Matrix3d::Identity();
  for (core::Key key : data.landmarks) table[key] = Eigen::Vector2d(4.0, 1.0).asDiagonal();
  const auto count = [&](int every, bool landmarks) {
    const core::Result<PlotRobot> r =
        BuildRobot("s", data, data.initial, {.ellipse_every = every, .landmark_ellipses = landmarks}, &table);
    SLAMD_CHECK(r.ok());
    return std::make_pair(r->pose_ellipses.size(), r->landmark_ellipses.size());
  };
  EXPECT_EQ(count(1, true), std::make_pair(std::size_t{5}, std::size_t{2}));
  EXPECT_EQ(count(2, true).first, 3u);   // 0, 2, 4
  EXPECT_EQ(count(3, true).first, 3u);   // 0, 3 and the last, 4
  EXPECT_EQ(count(10, false), std::make_pair(std::size_t{2}, std::size_t{0}));

  const core::Result<PlotRobot> r = BuildRobot("s", data, data.initial, {.sigma = 3.0}, &table);
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r->landmark_ellipses[0].semi_major, 6.0, 1e-12);
  EXPECT_NEAR(r->landmark_ellipses[0].semi_minor, 3.0, 1e-12);
  EXPECT_NEAR(r->pose_ellipses[0].semi_major, 0.3, 1e-12);
  // The scene's bounds grow to hold the landmark ellipses (semi-major 6 m along x).
  PlotScene scene;
  scene.robots.push_back(*r);
  EXPECT_NEAR(scene.Bounds().min.x(), 1.5 - 6.0, 1e-9);
}

TEST(BuildRobotTest, RejectsMissingValuesAndBadOptions) {
  const core::Dataset data = SmallDataset();
  core::Values partial = data.initial;
  ASSERT_TRUE(partial.Erase(data.poses[2]).ok());
  EXPECT_EQ(BuildRobot("s", data, partial, {}, nullptr).status().code(), core::StatusCode::kInvalidArgument);
  EXPECT_FALSE(BuildRobot("s", data, data.initial, {.ellipse_every = 0}, nullptr).ok());
}

// Dense reference: H = Σ AᵀA of the whitened linearisation at `values`, Σ = H⁻¹.
Eigen::MatrixXd DenseCovariance(const core::FactorGraph& graph, const core::Values& values,
                                std::vector<int>* offsets) {
  offsets->assign(values.size() + 1, 0);
  for (std::size_t s = 0; s < values.size(); ++s) (*offsets)[s + 1] = (*offsets)[s] + values.DimAt(static_cast<int>(s));
  const int n = offsets->back();
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, n);
  core::LinearizedFactor lin;
  for (const core::FactorPtr& f : graph) {
    f->Linearize(values, &lin);
    for (int i = 0; i < lin.num_keys(); ++i) {
      for (int j = 0; j < lin.num_keys(); ++j) {
        const int oi = (*offsets)[values.SlotOf(f->keys()[i])], oj = (*offsets)[values.SlotOf(f->keys()[j])];
        H.block(oi, oj, lin.Block(i).cols(), lin.Block(j).cols()) +=
            lin.Block(i).transpose() * lin.Block(j);
      }
    }
  }
  return H.inverse();
}

TEST(ComputeMarginalsTest, MatchesDenseInverse) {
  const core::Dataset data = SmallDataset();
  core::FactorGraph graph = data.graph;
  ASSERT_TRUE(core::AddGaugePrior(data.initial, data.poses.front(), 0.01, &graph).ok());
  const core::BatchResult solved = core::Optimize(graph, data.initial);
  ASSERT_TRUE(solved.status.ok());
  const core::Values& values = solved.values;
  std::vector<core::Key> keys = data.poses;
  keys.insert(keys.end(), data.landmarks.begin(), data.landmarks.end());
  const core::Result<MarginalTable> table = ComputeMarginals(graph, values, keys);
  ASSERT_TRUE(table.ok()) << table.status().ToString();
  std::vector<int> offsets;
  const Eigen::MatrixXd dense = DenseCovariance(graph, values, &offsets);
  for (core::Key key : keys) {
    const int s = values.SlotOf(key), d = values.DimAt(s);
    const Eigen::MatrixXd expected = dense.block(offsets[s], offsets[s], d, d);
    const Eigen::MatrixXd& got = table->at(key);
    EXPECT_NEAR((got - expected).norm(), 0.0, 1e-9 * expected.norm()) << core::KeyToString(key);
  }
  EXPECT_EQ(ComputeMarginals(graph, values, {core::MakeKey('x', 99)}).status().code(), core::StatusCode::kNotFound);
}

}  // namespace
}  // namespace slamd::clients::plot
