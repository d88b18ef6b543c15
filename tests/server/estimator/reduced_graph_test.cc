// The reduced pose graph: the composition rules against the exact marginal of the full graph
// (dense oracle), and the estimator's use of them (bounded graph on a revisited loop, exact
// estimates on consistent data, accuracy against the full graph on noisy data, duplicates,
// rejections, expiry, snapshot round trip).
#include "server/estimator/reduced_graph.h"

#include <gtest/gtest.h>

#include <random>

#include "core/factors/between_factor.h"
#include "core/factors/prior_factor.h"
#include "core/factors/relative_point_factor.h"
#include "core/geometry/pose3.h"
#include "server/snapshot/state_codec.h"
#include "tests/core/inference/dense_system.h"
#include "tests/server/estimator/estimator_test_messages.h"

namespace slamd::server::reduced_graph_test {
namespace {

using core::Key;
using core::Point2;
using core::Point3;
using core::Pose2;
using core::Pose3;
using estimator_test::ExpectNear;
using estimator_test::Loop;
using estimator_test::Make;
using estimator_test::Odo;
using estimator_test::OnlyRejection;
using estimator_test::PoseOf;
using estimator_test::Prior;
using estimator_test::Remove;
using ::slamd::testing::Noise;

Eigen::MatrixXd RandomCovariance(int n, std::mt19937* rng) {
  std::normal_distribution<double> g(0.0, 0.1);
  Eigen::MatrixXd a(n, n);
  for (int i = 0; i < a.size(); ++i) a(i) = g(*rng);
  return a * a.transpose() + 0.01 * Eigen::MatrixXd::Identity(n, n);
}

core::NoiseModel FromCov(const Eigen::MatrixXd& c) {
  return core::NoiseModel::FromCovariance(c).value();
}

// The covariance of `keys` in the Gaussian of `factors` linearised at θ.
Eigen::MatrixXd JointCovariance(const std::vector<core::FactorPtr>& factors,
                                const core::Values& theta, const core::KeyVector& all,
                                const core::KeyVector& keys) {
  const core::testing::DenseSystem s = core::testing::Dense(factors, theta, all);
  const Eigen::MatrixXd cov = s.H.inverse();
  std::vector<int> cols;
  for (Key k : keys) {
    const auto at = std::find(all.begin(), all.end(), k) - all.begin();
    for (int c = s.column[at]; c < s.column[at + 1]; ++c) cols.push_back(c);
  }
  Eigen::MatrixXd out(cols.size(), cols.size());
  for (std::size_t i = 0; i < cols.size(); ++i) {
    for (std::size_t j = 0; j < cols.size(); ++j) out(i, j) = cov(cols[i], cols[j]);
  }
  return out;
}

const Key kX0 = core::MakeKey('x', 0), kX1 = core::MakeKey('x', 1), kX2 = core::MakeKey('x', 2);
const Key kX3 = core::MakeKey('x', 3), kL = core::MakeKey('l', 0);

// x0 -z1-> x1 -z2-> x2 and x2 -z3-> x3 with x2 an alias of x0: the composed factor on (x0, x3)
// gives (x0, x3) exactly the joint covariance of the full chain (linearised at the measurements,
// where composition is exact), for Pose3 with correlated noise.
TEST(ReducedGraphTest, ComposedOdometryKeepsTheChainsMarginal) {
  std::mt19937 rng(3);
  const Pose3 z1 = Pose3::Exp((core::Vector6() << 0.3, -0.2, 0.1, 1.0, 0.2, -0.1).finished());
  const Pose3 z2 = Pose3::Exp((core::Vector6() << -0.1, 0.4, 0.2, 0.5, -0.3, 0.2).finished());
  const Pose3 z3 = Pose3::Exp((core::Vector6() << 0.2, 0.1, -0.3, 0.8, 0.1, 0.3).finished());
  const Eigen::MatrixXd c1 = RandomCovariance(6, &rng), c2 = RandomCovariance(6, &rng);
  const Eigen::MatrixXd c3 = RandomCovariance(6, &rng);
  const auto prior = std::make_shared<core::PriorFactor<Pose3>>(kX0, Pose3(), Noise(6, 0.1));
  core::Values theta;
  ASSERT_TRUE(theta.Insert(kX0, Pose3()).ok());
  ASSERT_TRUE(theta.Insert(kX1, z1).ok());
  ASSERT_TRUE(theta.Insert(kX2, z1 * z2).ok());
  ASSERT_TRUE(theta.Insert(kX3, z1 * z2 * z3).ok());
  const std::vector<core::FactorPtr> full = {
      prior, std::make_shared<core::BetweenFactor<Pose3>>(kX0, kX1, z1, FromCov(c1)),
      std::make_shared<core::BetweenFactor<Pose3>>(kX1, kX2, z2, FromCov(c2)),
      std::make_shared<core::BetweenFactor<Pose3>>(kX2, kX3, z3, FromCov(c3))};
  const PoseAlias x1 = ComposeAlias(NodeAlias(kX0, Pose3()), {z1, c1});
  const PoseAlias x2 = ComposeAlias(x1, {z2, c2});
  const ComposedMeasurement m = ComposeBetween(x2, {z3, c3}, NodeAlias(kX3, Pose3()));
  EXPECT_EQ(x2.anchor, kX0);
  EXPECT_LT(core::LocalCoordinates(m.measured, z1 * z2 * z3).norm(), 1e-12);
  const std::vector<core::FactorPtr> reduced = {
      prior, std::make_shared<core::BetweenFactor<Pose3>>(kX0, kX3, std::get<Pose3>(m.measured),
                                                          FromCov(m.covariance))};
  core::Values theta_reduced;
  ASSERT_TRUE(theta_reduced.Insert(kX0, Pose3()).ok());
  ASSERT_TRUE(theta_reduced.Insert(kX3, z1 * z2 * z3).ok());
  const Eigen::MatrixXd expected = JointCovariance(full, theta, {kX0, kX1, kX2, kX3}, {kX0, kX3});
  const Eigen::MatrixXd got = JointCovariance(reduced, theta_reduced, {kX0, kX3}, {kX0, kX3});
  EXPECT_LT((got - expected).norm(), 1e-9 * expected.norm()) << got << "\n\n" << expected;
  // Both ends aliases (a closure between two chains) and the inverse: the same rule.
  const ComposedMeasurement back = InverseRelative(m);
  EXPECT_LT(core::LocalCoordinates(back.measured, (z1 * z2 * z3).Inverse()).norm(), 1e-12);
}

// A removed pose's alias from the joint marginal of it and its anchor (RelativeAlias, the
// lifelong window's): on a chain x0 -z1-> x1 -z2-> x2 under a prior, x2 relative to x0 from the
// dense joint of (x0, x2) is the chain's composed odometry, whatever x0's own uncertainty (the
// cross-covariance cancels it); with a closure x0 -z3-> x2 as well it is the dense marginal of
// the relative pose, a sharper one. Pose3, correlated noise, linearised at the measurements.
TEST(ReducedGraphTest, RelativeAliasIsTheJointMarginalsRelativePose) {
  std::mt19937 rng(11);
  const Pose3 z1 = Pose3::Exp((core::Vector6() << 0.3, -0.2, 0.1, 1.0, 0.2, -0.1).finished());
  const Pose3 z2 = Pose3::Exp((core::Vector6() << -0.1, 0.4, 0.2, 0.5, -0.3, 0.2).finished());
  const Eigen::MatrixXd c1 = RandomCovariance(6, &rng), c2 = RandomCovariance(6, &rng);
  const Eigen::MatrixXd c3 = RandomCovariance(6, &rng);
  const Pose3 x0 = Pose3::Exp((core::Vector6() << 0.2, 0.1, -0.3, 2.0, -1.0, 0.5).finished());
  core::Values theta;
  ASSERT_TRUE(theta.Insert(kX0, x0).ok());
  ASSERT_TRUE(theta.Insert(kX1, x0 * z1).ok());
  ASSERT_TRUE(theta.Insert(kX2, x0 * z1 * z2).ok());
  std::vector<core::FactorPtr> factors = {
      std::make_shared<core::PriorFactor<Pose3>>(kX0, x0, FromCov(RandomCovariance(6, &rng))),
      std::make_shared<core::BetweenFactor<Pose3>>(kX0, kX1, z1, FromCov(c1)),
      std::make_shared<core::BetweenFactor<Pose3>>(kX1, kX2, z2, FromCov(c2))};
  const core::KeyVector all = {kX0, kX1, kX2};
  const PoseAlias chain = ComposeAlias(ComposeAlias(NodeAlias(kX0, Pose3()), {z1, c1}), {z2, c2});
  const PoseAlias got =
      RelativeAlias(kX0, x0, x0 * z1 * z2, JointCovariance(factors, theta, all, {kX0, kX2}));
  EXPECT_EQ(got.anchor, kX0);
  EXPECT_LT(core::LocalCoordinates(got.offset, z1 * z2).norm(), 1e-12);
  EXPECT_LT((got.covariance - chain.covariance).norm(), 1e-9 * chain.covariance.norm())
      << got.covariance << "\n\n"
      << chain.covariance;
  // With the closure: two independent measurements of x0⁻¹ x2 (the chain's composed one and
  // z3), so the relative pose's covariance is that of their fusion, (chain⁻¹ + c3⁻¹)⁻¹.
  factors.push_back(std::make_shared<core::BetweenFactor<Pose3>>(kX0, kX2, z1 * z2, FromCov(c3)));
  const PoseAlias closed =
      RelativeAlias(kX0, x0, x0 * z1 * z2, JointCovariance(factors, theta, all, {kX0, kX2}));
  const Eigen::MatrixXd expected = (chain.covariance.inverse() + c3.inverse()).inverse();
  EXPECT_LT((closed.covariance - expected).norm(), 1e-9 * expected.norm())
      << closed.covariance << "\n\n"
      << expected;
  EXPECT_LT(closed.covariance.trace(), chain.covariance.trace());
}

// A landmark seen from an alias (x0 ∘ z in 2D) and from x0 itself: the relative point composed
// onto x0 beside x0's own gives (x0, l) the full graph's joint covariance.
TEST(ReducedGraphTest, ComposedPointsKeepTheMarginal) {
  std::mt19937 rng(5);
  const Pose2 z(1.0, 0.5, 0.7);
  const Point2 p(2.0, -1.0);
  const Eigen::MatrixXd cz = RandomCovariance(3, &rng), cp = RandomCovariance(2, &rng);
  const Eigen::MatrixXd cq = RandomCovariance(2, &rng);
  const auto prior = std::make_shared<core::PriorFactor<Pose2>>(kX0, Pose2(), Noise(3, 0.1));
  const Point2 l = z.TransformFrom(p);
  core::Values theta;
  ASSERT_TRUE(theta.Insert(kX0, Pose2()).ok());
  ASSERT_TRUE(theta.Insert(kX1, z).ok());
  ASSERT_TRUE(theta.Insert(kL, l).ok());
  const std::vector<core::FactorPtr> full = {
      prior, std::make_shared<core::BetweenFactor<Pose2>>(kX0, kX1, z, FromCov(cz)),
      std::make_shared<core::RelativePointFactor<Pose2, Point2>>(kX1, kL, p, FromCov(cp)),
      std::make_shared<core::RelativePointFactor<Pose2, Point2>>(kX0, kL, l, FromCov(cq))};
  const ComposedMeasurement composed =
      ComposePoint(ComposeAlias(NodeAlias(kX0, Pose2()), {z, cz}), {p, cp});
  EXPECT_LT((std::get<Point2>(composed.measured) - l).norm(), 1e-12);
  const std::vector<core::FactorPtr> reduced = {
      prior,
      std::make_shared<core::RelativePointFactor<Pose2, Point2>>(
          kX0, kL, std::get<Point2>(composed.measured), FromCov(composed.covariance)),
      std::make_shared<core::RelativePointFactor<Pose2, Point2>>(kX0, kL, l, FromCov(cq))};
  core::Values theta_reduced;
  ASSERT_TRUE(theta_reduced.Insert(kX0, Pose2()).ok());
  ASSERT_TRUE(theta_reduced.Insert(kL, l).ok());
  const Eigen::MatrixXd expected = JointCovariance(full, theta, {kX0, kX1, kL}, {kX0, kL});
  const Eigen::MatrixXd got = JointCovariance(reduced, theta_reduced, {kX0, kL}, {kX0, kL});
  EXPECT_LT((got - expected).norm(), 1e-9 * expected.norm()) << got << "\n\n" << expected;
}

inline Inbound Point(const std::string& robot, std::uint64_t pose, std::uint64_t id,
                     const Point2& p, double sigma) {
  return {
      LandmarkMeasurement{4, robot, pose, id, LandmarkKind::kRelativePoint2, p, Noise(2, sigma)},
      0};
}

// A robot driving a circle of 36 one-metre steps three times, seeing 8 landmarks around it:
// the true poses, and the messages of each step (odometry and the landmarks within 9 m), with
// noise of the given sigmas (0: exact).
struct Circle {
  std::vector<Pose2> truth;
  std::vector<std::vector<Inbound>> steps;
};
Circle DriveCircle(int laps, double odo_sigma, double point_sigma, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  const Pose2 step(1.0, 0.0, 2 * M_PI / 36);
  std::vector<Point2> landmarks;
  for (int i = 0; i < 8; ++i) {
    landmarks.emplace_back(3.0 + 8.0 * std::cos(i * M_PI / 4), 5.7 + 8.0 * std::sin(i * M_PI / 4));
  }
  Circle c{{Pose2()}, {{Prior("r", 0, Pose2())}}};
  for (int i = 0; i < 36 * laps; ++i) {
    const Pose2 z = step * Pose2(odo_sigma * g(rng), odo_sigma * g(rng), odo_sigma * g(rng));
    c.truth.push_back(c.truth.back() * step);
    std::vector<Inbound> batch = {{OdometryMeasurement{1, "r", static_cast<std::uint64_t>(i),
                                                       static_cast<std::uint64_t>(i + 1), z,
                                                       Noise(3, std::max(odo_sigma, 1e-3))},
                                   0}};
    for (std::size_t j = 0; j < landmarks.size(); ++j) {
      const Point2 p = c.truth.back().TransformTo(landmarks[j]);
      if (p.norm() > 9.0) continue;
      batch.push_back(Point("r", i + 1, j, p + point_sigma * Point2(g(rng), g(rng)),
                            std::max(point_sigma, 1e-3)));
    }
    c.steps.push_back(std::move(batch));
  }
  return c;
}

EstimatorParams Reduced(double distance_m) {
  EstimatorParams p{.chi2_interval_s = 0.0};
  p.reduced.distance_m = distance_m;
  return p;
}

// Consistent data: the second and third laps add no nodes and no factors (their measurements
// are composed onto pairs that have their composed factors: left out), and every pose, node or
// alias, is where it truly is.
TEST(ReducedGraphTest, RevisitingAMappedAreaAddsNoNodes) {
  const Circle c = DriveCircle(3, 0.0, 0.0, 1);
  auto e = Make(Reduced(2.0));
  std::int64_t variables_after_lap1 = 0, factors_after_lap2 = 0;
  std::int64_t left_out_after_lap2 = 0;
  for (std::size_t i = 0; i < c.steps.size(); ++i) {
    const ProcessResult r = e->Process(c.steps[i]);
    ASSERT_TRUE(r.status.ok()) << r.status.ToString();
    ASSERT_TRUE(r.rejections.empty()) << r.rejections[0].verdict.message;
    if (i == 36) variables_after_lap1 = e->snapshot()->num_variables;
    if (i == 72) factors_after_lap2 = e->snapshot()->num_factors;
    if (i == 72) left_out_after_lap2 = e->snapshot()->counters.reduced_left_out;
  }
  const auto& snap = *e->snapshot();
  EXPECT_LT(variables_after_lap1, 8 + 36);  // nodes ~2 m apart, plus the landmarks
  EXPECT_EQ(snap.num_variables, variables_after_lap1);
  EXPECT_EQ(snap.num_factors, factors_after_lap2);
  // The third lap's observations of the landmarks (2-4 a pose) were merged and left out.
  EXPECT_GT(snap.counters.reduced_left_out, left_out_after_lap2 + 36 * 2);
  EXPECT_GT(snap.counters.merged_poses, 36 * 2);
  for (std::uint64_t i = 0; i < c.truth.size(); i += 7) {
    ExpectNear(PoseOf(*e, "r", i), c.truth[i], 1e-6);
  }
  ExpectNear(PoseOf(*e, "r", c.truth.size() - 1), c.truth.back(), 1e-6);
  // The published newest pose follows the alias though the last steps added no factor.
  ASSERT_EQ(snap.robots.size(), 1u);
  ExpectNear(std::get<Pose2>(snap.robots[0].pose), c.truth.back(), 1e-6);
}

// Noisy odometry and landmarks: on the poses the reduced graph keeps (its nodes), its error
// stays close to the full graph's on the same poses. Its other poses are dead reckoning from
// a node until a loop closure re-anchors them: with a closure every 6 steps to the pose of the
// first lap at that place (as tight as the odometry), the newest pose stays close to the truth.
TEST(ReducedGraphTest, AccuracyCloseToTheFullGraph) {
  double full_error = 0.0, reduced_error = 0.0;
  int nodes = 0;
  for (unsigned seed = 1; seed <= 3; ++seed) {
    const Circle c = DriveCircle(3, 0.02, 0.05, seed);
    auto full = Make();
    auto reduced = Make(Reduced(2.0));
    for (const auto& step : c.steps) {
      ASSERT_TRUE(full->Process(step).status.ok());
      ASSERT_TRUE(reduced->Process(step).status.ok());
    }
    full->Refine(10.0);
    reduced->Refine(10.0);
    for (std::uint64_t i = 0; i < c.truth.size(); ++i) {
      if (!reduced->KeyOf({"r", KeyKind::kPose, i})) continue;
      ++nodes;
      full_error += (PoseOf(*full, "r", i).translation() - c.truth[i].translation()).squaredNorm();
      reduced_error +=
          (PoseOf(*reduced, "r", i).translation() - c.truth[i].translation()).squaredNorm();
    }
  }
  EXPECT_GT(nodes, 3 * 12);
  EXPECT_LT(std::sqrt(reduced_error), 1.3 * std::sqrt(full_error))  // 1.31 against 1.13
      << "full " << std::sqrt(full_error) << " reduced " << std::sqrt(reduced_error);

  const Circle c = DriveCircle(3, 0.02, 0.05, 7);
  auto reduced = Make(Reduced(2.0));
  double worst_newest = 0.0;
  for (std::size_t i = 0; i < c.steps.size(); ++i) {
    std::vector<Inbound> step = c.steps[i];
    if (i >= 40 && i % 6 == 0) {  // pose i of this lap seen from pose i - 36k of the first
      const std::uint64_t now = i, then = i % 36;
      step.push_back(
          {LoopClosureMeasurement{
               2, "r", now, "r", then, c.truth[now].Between(c.truth[then]), Noise(3, 0.02), {}},
           0});
    }
    // As the daemon runs it: the newest poses solved first (an alias's anchor: the new one when
    // this closure re-anchors it), the rest after.
    ASSERT_TRUE(reduced->Process(step, /*finish_later=*/true).status.ok());
    reduced->FinishUpdate();
    const std::uint64_t newest = i;
    worst_newest = std::max(
        worst_newest,
        (PoseOf(*reduced, "r", newest).translation() - c.truth[newest].translation()).norm());
  }
  EXPECT_LT(worst_newest, 0.35);  // about the map's own error; 2.6 m without re-anchoring
}

// link_mapped_landmarks false: an alias's observation of a landmark the map has adds no
// (node, landmark) factor (it is left out and counted); a new landmark still enters.
TEST(ReducedGraphTest, MappedLandmarksGainNoFactorsFromAliasesUnlessLinked) {
  const Pose2 step(1, 0, 0);
  std::vector<Inbound> drive = {Prior("r", 0, Pose2()), Point("r", 0, 7, Point2(3, 1), 0.05)};
  for (std::uint64_t i = 0; i < 3; ++i) drive.push_back(Odo("r", i, i + 1, step));
  // x1 is an alias of x0, x2 a node (2 m on), x3 an alias of x2.
  const std::vector<Inbound> seen = {
      Point("r", 1, 7, Point2(2, 1), 0.05),    // onto x0, which saw l7 itself (not composed)
      Point("r", 3, 7, Point2(0, 1), 0.05),    // onto x2
      Point("r", 3, 8, Point2(1, -1), 0.05)};  // l8 is new: it enters either way
  std::int64_t factors[2];
  for (const bool link : {true, false}) {
    EstimatorParams p = Reduced(2.0);
    p.reduced.link_mapped_landmarks = link;
    auto e = Make(p);
    for (const Inbound& m : drive) ASSERT_TRUE(e->Process({m}).status.ok());
    ASSERT_TRUE(e->KeyOf({"r", KeyKind::kPose, 2}).has_value());
    ASSERT_FALSE(e->KeyOf({"r", KeyKind::kPose, 3}).has_value());
    const std::int64_t before = e->snapshot()->num_factors;
    for (const Inbound& m : seen) {
      const ProcessResult r = e->Process({m});
      ASSERT_TRUE(r.status.ok());
      EXPECT_TRUE(r.rejections.empty());
      EXPECT_EQ(r.applied, 1);
    }
    factors[link] = e->snapshot()->num_factors - before;
    // Left out (and counted) once: sent again, the observation is recognised as held.
    EXPECT_EQ(e->snapshot()->counters.reduced_left_out, link ? 0 : 2);
    ASSERT_TRUE(e->Process({seen[1]}).rejections.empty());
    EXPECT_EQ(e->snapshot()->counters.already_held, 1);
    EXPECT_EQ(e->snapshot()->counters.reduced_left_out, link ? 0 : 2);
    ASSERT_TRUE(e->KeyOf({"r", KeyKind::kLandmark, 8}).has_value());
    const core::Values est = e->solver().CalculateEstimate();
    EXPECT_LT((est.At<Point2>(*e->KeyOf({"r", KeyKind::kLandmark, 7})) - Point2(3, 1)).norm(),
              1e-6);
    EXPECT_LT((est.At<Point2>(*e->KeyOf({"r", KeyKind::kLandmark, 8})) - Point2(4, -1)).norm(),
              1e-6);
  }
  EXPECT_EQ(factors[true], 3);   // composed (x0, l7), (x2, l7) and (x2, l8)
  EXPECT_EQ(factors[false], 1);  // (x2, l8)
}

// A pair of variables gets one composed factor of each kind, the first: a landmark seen from
// two aliases of one node, or the odometry from one node's aliases to another's on two passes,
// informs the map once (the two share the errors of the first alias's offset). The later
// measurement, however different, changes nothing and is counted.
TEST(ReducedGraphTest, APairKeepsItsFirstComposedFactor) {
  auto e = Make(Reduced(2.0));
  const Pose2 half(0.5, 0, 0);
  // x0 a node, x1..x3 aliases of it, x4 (2 m on) a node.
  std::vector<Inbound> drive = {Prior("r", 0, Pose2())};
  for (std::uint64_t i = 0; i < 4; ++i) drive.push_back(Odo("r", i, i + 1, half));
  for (const Inbound& m : drive) ASSERT_TRUE(e->Process({m}).status.ok());
  ASSERT_FALSE(e->KeyOf({"r", KeyKind::kPose, 1}).has_value());
  ASSERT_TRUE(e->KeyOf({"r", KeyKind::kPose, 4}).has_value());
  // l7 seen from x1 (composed onto x0: at (3.5, 1)), then from x2 1 m off.
  ASSERT_TRUE(e->Process({Point("r", 1, 7, Point2(3, 1), 0.05)}).rejections.empty());
  const std::int64_t factors = e->snapshot()->num_factors;
  ProcessResult r = e->Process({Point("r", 2, 7, Point2(2.5 + 1.0, 1), 0.05)});
  ASSERT_TRUE(r.rejections.empty());
  EXPECT_EQ(r.applied, 1);
  EXPECT_EQ(e->snapshot()->num_factors, factors);
  EXPECT_EQ(e->snapshot()->counters.reduced_left_out, 1);
  const Key l7 = *e->KeyOf({"r", KeyKind::kLandmark, 7});
  EXPECT_LT((e->solver().CalculateEstimate().At<Point2>(l7) - Point2(3.5, 1)).norm(), 1e-6);
  // A closure from x3 (an alias of x0) to x4 (a node) composes onto (x0, x4), which the
  // odometry composed when x4 was made already links: left out, x4 stays where it is.
  r = e->Process({Loop("r", 3, "r", 4, Pose2(0.9, 0, 0))});
  ASSERT_TRUE(r.rejections.empty());
  EXPECT_EQ(e->snapshot()->num_factors, factors);
  EXPECT_EQ(e->snapshot()->counters.reduced_left_out, 2);
  ExpectNear(PoseOf(*e, "r", 4), Pose2(2, 0, 0), 1e-6);
  // Robust closures onto (x0, x4): the first is a factor of its own (not a Gaussian to leave
  // out for the odometry's), the next is left out, so revisits with robust closures do not
  // grow the graph either.
  const core::RobustKernel huber =
      core::RobustKernel::Create(core::RobustKernel::Kind::kHuber, 1.345).value();
  for (const std::uint64_t from : {2, 1}) {
    Inbound closure = Loop("r", from, "r", 4, Pose2(2.0 - 0.5 * from, 0, 0));
    std::get<LoopClosureMeasurement>(closure.measurement).robust = huber;
    r = e->Process({closure});
    ASSERT_TRUE(r.rejections.empty());
  }
  EXPECT_EQ(e->snapshot()->num_factors, factors + 1);
  EXPECT_EQ(e->snapshot()->counters.reduced_left_out, 3);
}

TEST(ReducedGraphTest, DuplicatesRejectionsAndExpiry) {
  const Circle c = DriveCircle(2, 0.0, 0.0, 1);
  EstimatorParams p = Reduced(2.0);
  p.reduced.keep_aliases = 10;
  auto e = Make(p);
  for (const auto& step : c.steps) ASSERT_TRUE(e->Process(step).status.ok());
  const std::uint64_t newest = c.truth.size() - 1;  // an alias (second lap)
  ASSERT_FALSE(e->KeyOf({"r", KeyKind::kPose, newest}).has_value());
  // The same odometry again: already held; a different one between the same poses: duplicate.
  ProcessResult r = e->Process({c.steps.back()[0]});
  EXPECT_TRUE(r.rejections.empty());
  EXPECT_EQ(e->snapshot()->counters.already_held, 1);
  r = e->Process({Odo("r", newest - 1, newest, Pose2(5, 0, 0))});
  EXPECT_EQ(OnlyRejection(r), RejectReason::kDuplicate);
  // A composed measurement cannot be removed.
  r = e->Process({Remove(RemoveTarget::kOdometry, "r", newest - 1, "r", newest)});
  ASSERT_EQ(OnlyRejection(r), RejectReason::kUnknownFactor);
  EXPECT_NE(r.rejections[0].verdict.message.find("reduced pose graph"), std::string::npos);
  // A prior on an older alias cannot be composed; on the newest it makes the pose a node.
  r = e->Process({Prior("r", newest - 3, c.truth[newest - 3])});
  ASSERT_EQ(OnlyRejection(r), RejectReason::kUnknownPose);
  EXPECT_NE(r.rejections[0].verdict.message.find("is no node but an alias of"), std::string::npos)
      << r.rejections[0].verdict.message;
  r = e->Process({Prior("r", newest, c.truth[newest])});
  EXPECT_TRUE(r.rejections.empty());
  EXPECT_TRUE(e->KeyOf({"r", KeyKind::kPose, newest}).has_value());
  // Aliases beyond keep_aliases are forgotten: a closure to one names an unknown pose.
  r = e->Process({Loop("r", newest, "r", newest - 20, Pose2())});
  EXPECT_EQ(OnlyRejection(r), RejectReason::kUnknownPose);
  EXPECT_FALSE(e->PoseEstimate("r", newest - 20).ok());
  EXPECT_TRUE(e->PoseEstimate("r", newest - 5).ok());
}

// A snapshot (through the snapshot codec) of a reduced graph restores its aliases and merged
// measurements: the restored estimator answers the same and goes on as the original does.
TEST(ReducedGraphTest, ExportAndRestore) {
  const Circle c = DriveCircle(3, 0.01, 0.02, 4);
  auto original = Make(Reduced(2.0));
  for (std::size_t i = 0; i < 80; ++i) ASSERT_TRUE(original->Process(c.steps[i]).status.ok());
  JournalPosition position;
  const core::Result<EstimatorState> decoded =
      DecodeState(EncodeState(original->ExportState(), {}), &position);
  ASSERT_TRUE(decoded.ok()) << decoded.status().ToString();
  ASSERT_FALSE(decoded.value().aliases.empty());
  ASSERT_FALSE(decoded.value().merged.empty());
  auto restored = Estimator::Restore(Reduced(2.0), {}, decoded.value()).value();
  EXPECT_EQ(restored->ExportState().aliases.size(), original->ExportState().aliases.size());
  ExpectNear(PoseOf(*restored, "r", 79), PoseOf(*original, "r", 79), 1e-6);
  // The last step again is recognised as held already.
  EXPECT_TRUE(restored->Process({c.steps[79]}).rejections.empty());
  EXPECT_EQ(
      restored->snapshot()->counters.already_held,
      original->snapshot()->counters.already_held + static_cast<std::int64_t>(c.steps[79].size()));
  for (std::size_t i = 80; i < c.steps.size(); ++i) {
    ASSERT_TRUE(original->Process(c.steps[i]).status.ok());
    ASSERT_TRUE(restored->Process(c.steps[i]).status.ok());
  }
  EXPECT_EQ(restored->snapshot()->num_variables, original->snapshot()->num_variables);
  EXPECT_EQ(restored->snapshot()->num_factors, original->snapshot()->num_factors);
  ExpectNear(PoseOf(*restored, "r", c.truth.size() - 1), PoseOf(*original, "r", c.truth.size() - 1),
             1e-6);
}

// Wrong loop closures (far from what the odometry says) on a robot circling a ring: they do
// not re-anchor it (they would pull its aliases, and the nodes it adds, off the ring, and the
// composed factors against each other: refinement then oscillated for ever); the graph stays
// bounded and the estimate settles.
TEST(ReducedGraphTest, WrongClosuresDoNotReanchor) {
  auto e = Make(Reduced(2.0));
  std::mt19937 rng(1);
  std::normal_distribution<double> n(0.0, 0.05);
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2())}).status.ok());
  for (std::uint64_t i = 0; i < 400; ++i) {
    std::vector<Inbound> b = {
        {OdometryMeasurement{1, "r", i, i + 1, Pose2(1 + n(rng), n(rng), 0.3 + n(rng)),
                             Noise(3, 0.05)},
         0}};
    if (i >= 20 && i % 10 == 0) b.push_back(Loop("r", i + 1, "r", i - 20, Pose2(0.4, -0.3, 1)));
    const ProcessResult r = e->Process(b);
    ASSERT_TRUE(r.rejections.empty()) << i << ": " << r.rejections[0].verdict.message;
  }
  EXPECT_LT(e->snapshot()->num_variables, 60);
  EXPECT_TRUE(e->Refine(5.0).converged);
}

TEST(ReducedGraphTest, Validation) {
  EstimatorParams p = Reduced(-1.0);
  EXPECT_EQ(p.Validate().message(),
            "estimator.reduced.distance_m = -1.000000; violates >= 0 and < 1e6");
  p = Reduced(1.0);
  p.robot_reduced = {{.robot = "a", .reduced = {.distance_m = 1.0, .angle_deg = 0.0}}};
  EXPECT_EQ(p.Validate().message(),
            "estimator.robot_reduced[0].angle_deg = 0.000000; violates > 0 and <= 180");
  p.robot_reduced = {{.robot = "a"}, {.robot = "a"}};
  EXPECT_EQ(p.Validate().message(),
            "estimator.robot_reduced[1].robot = \"a\"; already given a reduced graph");
  p.robot_reduced = {{.robot = "a", .reduced = {.distance_m = 0.0}}};
  EXPECT_TRUE(p.Validate().ok());
  EXPECT_EQ(p.ReducedOf("a").distance_m, 0.0);
  EXPECT_EQ(p.ReducedOf("b").distance_m, 1.0);
}

}  // namespace
}  // namespace slamd::server::reduced_graph_test
