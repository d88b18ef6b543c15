#include "server/estimator/estimator.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <map>
#include <numeric>
#include <set>
#include <thread>

#include "tests/testing/noise.h"

namespace slamd::server {
namespace {

using core::Pose2;

using testing::Noise;

Inbound Odo(const std::string& robot, std::uint64_t from, std::uint64_t to, const Pose2& z) {
  return {OdometryMeasurement{1, robot, from, to, z, Noise(3, 0.1)}, 0};
}
Inbound Loop(const std::string& a, std::uint64_t pa, const std::string& b, std::uint64_t pb,
             const Pose2& z) {
  return {LoopClosureMeasurement{2, a, pa, b, pb, z, Noise(3, 0.2), {}}, 0};
}
Inbound Prior(const std::string& robot, std::uint64_t index, const Pose2& p) {
  return {PriorMeasurement{3, robot, index, PriorKind::kPose2, p, Noise(3, 0.01)}, 0};
}
Inbound Landmark(const std::string& robot, std::uint64_t pose, std::uint64_t id, double b,
                 double r) {
  return {LandmarkMeasurement{4, robot, pose, id, LandmarkKind::kBearingRange2, BearingRange{b, r},
                              Noise(2, 0.05)},
          0};
}

// chi2 after every update (the tests compare it), unless a test says otherwise.
std::unique_ptr<Estimator> Make(EstimatorParams p = {.chi2_interval_s = 0.0}, int skip = 1) {
  core::Isam2Params isam2;
  isam2.relinearization.skip = skip;
  return Estimator::Create(p, isam2).value();
}

Pose2 PoseOf(const Estimator& e, const std::string& robot, std::uint64_t i) {
  return std::get<Pose2>(e.PoseEstimate(robot, i).value());
}

void ExpectNear(const Pose2& a, const Pose2& b, double tol) {
  EXPECT_NEAR(a.x(), b.x(), tol);
  EXPECT_NEAR(a.y(), b.y(), tol);
  EXPECT_NEAR(std::remainder(a.theta() - b.theta(), 2 * M_PI), 0.0, tol);
}

RejectReason OnlyRejection(const ProcessResult& r) {
  EXPECT_EQ(r.rejections.size(), 1u);
  return r.rejections.empty() ? RejectReason::kNone : r.rejections[0].verdict.reason;
}

const Pose2 kStep(1.0, 0.1, 0.2);

TEST(EstimatorTest, ChainFollowsOdometryAndSnapshotCounts) {
  auto e = Make();
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2(1, 2, 0.3))}).status.ok());
  const ProcessResult r = e->Process({Odo("r", 0, 1, kStep), Odo("r", 1, 2, kStep)});
  ASSERT_TRUE(r.status.ok());
  EXPECT_EQ(r.applied, 2);
  EXPECT_TRUE(r.rejections.empty());
  ExpectNear(PoseOf(*e, "r", 2), Pose2(1, 2, 0.3) * kStep * kStep, 1e-9);
  const auto snap = e->snapshot();
  EXPECT_EQ(snap->update_sequence, 2);
  ASSERT_EQ(snap->robots.size(), 1u);
  EXPECT_EQ(snap->robots[0].name, "r");
  EXPECT_EQ(snap->robots[0].id, 'a');
  EXPECT_EQ(snap->robots[0].pose_index, 2u);
  EXPECT_EQ(snap->robots[0].moved_sequence, 2);
  EXPECT_EQ(snap->num_variables, 3);
  EXPECT_EQ(snap->num_factors, 3);
  EXPECT_EQ(snap->residual_dimension, 9);
  EXPECT_EQ(snap->counters.updates, 2);
  EXPECT_EQ(snap->counters.applied, 3);
  EXPECT_NEAR(snap->chi2, 0.0, 1e-12);
}

// Coalesced == lock-step when only the last message of the batch closes a loop (skip = 1,
// no refinement): see estimator.h.
TEST(EstimatorTest, CoalescedUpdateEqualsLockStep) {
  std::vector<Inbound> msgs = {Prior("r", 0, Pose2(0, 0, 0))};
  for (int i = 0; i < 8; ++i) msgs.push_back(Odo("r", i, i + 1, Pose2(1.0, 0.05 * i, M_PI / 4)));
  msgs.push_back(Loop("r", 8, "r", 0, Pose2(0.3, -0.2, 0.1)));
  auto lock = Make();
  for (const Inbound& m : msgs) ASSERT_TRUE(lock->Process({m}).status.ok());
  auto coalesced = Make();
  ASSERT_TRUE(coalesced->Process({msgs[0]}).status.ok());
  const ProcessResult r = coalesced->Process({msgs.begin() + 1, msgs.end()});
  ASSERT_TRUE(r.status.ok());
  EXPECT_EQ(r.applied, 9);
  EXPECT_EQ(coalesced->snapshot()->counters.updates, 2);
  EXPECT_EQ(lock->snapshot()->counters.updates, 10);
  for (int i = 0; i <= 8; ++i) ExpectNear(PoseOf(*coalesced, "r", i), PoseOf(*lock, "r", i), 1e-9);
  EXPECT_NEAR(coalesced->snapshot()->chi2, lock->snapshot()->chi2, 1e-9);
  EXPECT_GT(lock->snapshot()->chi2, 1e-3);  // the loop closure really pulled
}

// A different measurement between the same variables is refused; the same one again (a robot
// re-sending after a restart) is acknowledged as held already: nothing changes, nothing rejected.
TEST(EstimatorTest, DuplicateMeasurementRejectedUnlessTheSame) {
  auto e = Make();
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2()), Odo("r", 0, 1, kStep)}).status.ok());
  const Pose2 before = PoseOf(*e, "r", 1);
  const ProcessResult r = e->Process({Odo("r", 0, 1, Pose2(5, 5, 1))});
  EXPECT_EQ(OnlyRejection(r), RejectReason::kDuplicate);
  EXPECT_TRUE(r.updates.empty());
  ExpectNear(PoseOf(*e, "r", 1), before, 0.0);
  const ProcessResult same = e->Process({Odo("r", 0, 1, kStep), Prior("r", 0, Pose2())});
  EXPECT_TRUE(same.rejections.empty());
  EXPECT_TRUE(same.updates.empty());
  EXPECT_EQ(same.applied, 0);
  EXPECT_EQ(same.already_held_robots, std::set<std::string>{"r"});
  EXPECT_EQ(e->snapshot()->counters.already_held, 2);
  ExpectNear(PoseOf(*e, "r", 1), before, 0.0);
  // Also within one batch, and for loop closures written either way round.
  const ProcessResult r2 = e->Process({Odo("r", 1, 2, kStep), Odo("r", 1, 2, kStep)});
  EXPECT_TRUE(r2.rejections.empty());
  EXPECT_EQ(r2.applied, 1);
  const ProcessResult r3 = e->Process({Odo("r", 1, 2, kStep), Odo("r", 1, 2, Pose2(0, 1, 0))});
  EXPECT_EQ(OnlyRejection(r3), RejectReason::kDuplicate);
  ASSERT_TRUE(e->Process({Loop("r", 2, "r", 0, kStep)}).status.ok());
  EXPECT_EQ(OnlyRejection(e->Process({Loop("r", 0, "r", 2, kStep)})), RejectReason::kDuplicate);
  EXPECT_TRUE(e->Process({Loop("r", 2, "r", 0, kStep)}).rejections.empty());
  EXPECT_EQ(e->snapshot()->counters.rejects_by_reason[int(RejectReason::kDuplicate)], 3);
  EXPECT_EQ(e->snapshot()->counters.already_held, 5);
}

TEST(EstimatorTest, LoopClosureToUnknownRobotOrPoseRejected) {
  auto e = Make();
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2()), Odo("r", 0, 1, kStep)}).status.ok());
  ASSERT_TRUE(e->Process({Prior("s", 0, Pose2(5, 0, 0))}).status.ok());
  // Neither pose known, robot never seen.
  EXPECT_EQ(OnlyRejection(e->Process({Loop("ghost", 0, "nobody", 1, kStep)})),
            RejectReason::kUnknownRobot);
  // Known robot, pose not in the graph (the other side known).
  const ProcessResult r = e->Process({Loop("r", 1, "r", 7, kStep)});
  EXPECT_EQ(OnlyRejection(r), RejectReason::kUnknownPose);
  EXPECT_NE(r.rejections[0].verdict.message.find("pose_b"), std::string::npos);
  EXPECT_EQ(OnlyRejection(e->Process({Loop("s", 4, "r", 1, kStep)})), RejectReason::kUnknownPose);
  // Both robots anchored, neither pose known.
  EXPECT_EQ(OnlyRejection(e->Process({Loop("r", 9, "s", 9, kStep)})), RejectReason::kUnknownPose);
  EXPECT_EQ(e->snapshot()->num_factors, 3);
}

TEST(EstimatorTest, OutOfOrderOdometryHeldUntilGapFills) {
  auto e = Make();
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2())}).status.ok());
  ProcessResult r = e->Process({Odo("r", 2, 3, kStep)});  // 1 and 2 not there yet
  EXPECT_TRUE(r.rejections.empty());
  EXPECT_TRUE(r.updates.empty());
  EXPECT_EQ(e->held_messages(), 1);
  r = e->Process({Odo("r", 1, 2, kStep)});
  EXPECT_EQ(e->held_messages(), 2);
  r = e->Process({Odo("r", 0, 1, kStep)});  // fills the gap: all three in one update
  ASSERT_TRUE(r.status.ok());
  EXPECT_EQ(r.applied, 3);
  EXPECT_EQ(e->held_messages(), 0);
  ExpectNear(PoseOf(*e, "r", 3), kStep * kStep * kStep, 1e-9);
  EXPECT_EQ(e->snapshot()->counters.held, 2);
}

TEST(EstimatorTest, HeldTooLongOrTooManyRejected) {
  EstimatorParams p;
  p.max_hold_updates = 2;
  p.max_held_messages = 2;
  auto e = Make(p);
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2())}).status.ok());
  EXPECT_TRUE(e->Process({Odo("r", 5, 6, kStep)}).rejections.empty());  // waited 1
  EXPECT_TRUE(e->Process({}).rejections.empty());                       // waited 2
  ProcessResult r = e->Process({});                                     // 3 > 2
  EXPECT_EQ(OnlyRejection(r), RejectReason::kOutOfOrderTimeout);
  EXPECT_EQ(e->held_messages(), 0);
  r = e->Process({Odo("r", 5, 6, kStep), Odo("r", 6, 7, kStep), Odo("r", 7, 8, kStep)});
  EXPECT_EQ(OnlyRejection(r), RejectReason::kOutOfOrderTimeout);  // the oldest goes
  EXPECT_EQ(std::get<OdometryMeasurement>(r.rejections[0].message.measurement).from_index, 5u);
  EXPECT_EQ(e->held_messages(), 2);
}

TEST(EstimatorTest, NewRobotHeldUntilConnectedByLoopClosure) {
  auto e = Make();  // kHoldUntilConnected
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2(1, 1, 0))}).status.ok());
  ProcessResult r = e->Process({Odo("s", 0, 1, kStep)});
  EXPECT_TRUE(r.updates.empty());
  EXPECT_EQ(e->held_messages(), 1);
  EXPECT_FALSE(e->PoseEstimate("s", 0).ok());
  const Pose2 z(0.5, 0.0, 0.0);
  r = e->Process({Loop("r", 0, "s", 0, z)});  // connects s: its held odometry follows
  ASSERT_TRUE(r.status.ok());
  EXPECT_EQ(r.applied, 2);
  ExpectNear(PoseOf(*e, "s", 1), Pose2(1, 1, 0) * z * kStep, 1e-9);
  EXPECT_EQ(e->snapshot()->robots.size(), 2u);
}

TEST(EstimatorTest, NewRobotAnchoredAtOriginWhenConfigured) {
  EstimatorParams p;
  p.new_robot_anchor = AnchorPolicy::kAnchorAtOrigin;
  auto e = Make(p);
  const ProcessResult r = e->Process({Odo("s", 3, 4, kStep)});
  ASSERT_TRUE(r.status.ok());
  ExpectNear(PoseOf(*e, "s", 3), Pose2(), 1e-12);
  ExpectNear(PoseOf(*e, "s", 4), kStep, 1e-9);
  EXPECT_EQ(e->snapshot()->num_factors, 2);  // anchor prior + odometry
}

TEST(EstimatorTest, DimensionMismatchRejected) {
  auto e = Make();
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2())}).status.ok());
  Inbound odo3 = {OdometryMeasurement{1, "r", 0, 1, core::Pose3(), Noise(6, 0.1)}, 0};
  EXPECT_EQ(OnlyRejection(e->Process({odo3})), RejectReason::kBadMeasurement);
  EXPECT_EQ(e->snapshot()->num_variables, 1);
}

TEST(EstimatorTest, LandmarkPlacedByFirstObservationAndHeldForUnknownPose) {
  auto e = Make();
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2(1, 0, M_PI / 2))}).status.ok());
  ProcessResult r = e->Process({Landmark("r", 1, 7, 0.0, 2.0)});  // pose 1 not yet there
  EXPECT_EQ(e->held_messages(), 1);
  r = e->Process({Landmark("r", 0, 3, 0.0, 2.0), Odo("r", 0, 1, kStep)});
  ASSERT_TRUE(r.status.ok());
  EXPECT_EQ(r.applied, 3);
  const core::Values est = e->solver().CalculateEstimate();
  const core::Point2& l3 = est.At<core::Point2>(core::MakeKey('l', 3, 'a'));
  EXPECT_NEAR(l3.x(), 1.0, 1e-9);  // 2 m along the pose's x axis, which points along world y
  EXPECT_NEAR(l3.y(), 2.0, 1e-9);
  EXPECT_TRUE(e->Process({Landmark("r", 0, 3, 0.0, 2.0)}).rejections.empty());  // held already
  EXPECT_EQ(OnlyRejection(e->Process({Landmark("r", 0, 3, 0.0, 2.5)})), RejectReason::kDuplicate);
}

TEST(EstimatorTest, PositionPriorOnUnknownPoseIsHeldThenApplied) {
  auto e = Make();
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2())}).status.ok());
  Inbound gps = {
      PriorMeasurement{5, "r", 1, PriorKind::kPosition2, core::Point2(1, 0.1), Noise(2, 1.0)}, 0};
  EXPECT_TRUE(e->Process({gps}).updates.empty());
  const ProcessResult r = e->Process({Odo("r", 0, 1, kStep)});
  EXPECT_EQ(r.applied, 2);
  EXPECT_EQ(e->snapshot()->num_factors, 3);
}

Inbound Remove(RemoveTarget target, const std::string& a, std::uint64_t ia, const std::string& b,
               std::uint64_t ib, std::int8_t kind = 0) {
  return {RemoveFactorRequest{6, target, a, ia, b, ib, kind}, 0};
}

// Removing a loop closure gives what never having it gives (both settled to their optimum);
// the measurement may then be sent again.
TEST(EstimatorTest, RemovedLoopClosureEqualsNeverAdded) {
  std::vector<Inbound> chain = {Prior("r", 0, Pose2())};
  for (int i = 0; i < 6; ++i) chain.push_back(Odo("r", i, i + 1, kStep));
  const Inbound loop = Loop("r", 6, "r", 1, Pose2(0.5, -0.4, 0.3));
  auto with = Make();
  auto without = Make();
  ASSERT_TRUE(with->Process(chain).status.ok());
  ASSERT_TRUE(without->Process(chain).status.ok());
  ASSERT_TRUE(with->Process({loop}).status.ok());
  EXPECT_GT(with->snapshot()->chi2, 1e-3);
  // The other direction does not name it; the right one does.
  EXPECT_EQ(OnlyRejection(with->Process({Remove(RemoveTarget::kLoopClosure, "r", 1, "r", 6)})),
            RejectReason::kUnknownFactor);
  const ProcessResult r = with->Process({Remove(RemoveTarget::kLoopClosure, "r", 6, "r", 1)});
  ASSERT_TRUE(r.status.ok());
  EXPECT_EQ(r.applied, 1);
  EXPECT_TRUE(r.rejections.empty());
  ASSERT_TRUE(with->Refine(5.0).converged);
  ASSERT_TRUE(without->Refine(5.0).converged);
  for (int i = 0; i <= 6; ++i) ExpectNear(PoseOf(*with, "r", i), PoseOf(*without, "r", i), 1e-6);
  EXPECT_EQ(with->snapshot()->num_factors, without->snapshot()->num_factors);
  EXPECT_EQ(with->snapshot()->residual_dimension, without->snapshot()->residual_dimension);
  EXPECT_NEAR(with->snapshot()->chi2, without->snapshot()->chi2, 1e-9);
  const ProcessResult again = with->Process({loop});
  EXPECT_TRUE(again.rejections.empty());
  EXPECT_EQ(again.applied, 1);
}

TEST(EstimatorTest, RemovalOfUnknownOrDisconnectingMeasurementRejected) {
  auto e = Make();
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2()), Odo("r", 0, 1, kStep),
                          Landmark("r", 1, 4, 0.1, 2.0), Landmark("r", 0, 4, 0.3, 2.5)})
                  .status.ok());
  EXPECT_EQ(OnlyRejection(e->Process({Remove(RemoveTarget::kOdometry, "ghost", 0, "", 1)})),
            RejectReason::kUnknownFactor);
  EXPECT_EQ(OnlyRejection(e->Process({Remove(RemoveTarget::kOdometry, "r", 1, "", 2)})),
            RejectReason::kUnknownFactor);
  // The only factor linking pose 1 to the rest besides the landmark: removing the landmark's
  // second observation leaves it observed once (bearing-range: still determined), fine; the
  // odometry then is the last link of pose 1 apart from one observation: refused.
  const auto before = e->snapshot();
  const ProcessResult r =
      e->Process({Remove(RemoveTarget::kLandmarkObservation, "r", 0, "", 4,
                         static_cast<std::int8_t>(LandmarkKind::kBearingRange2))});
  EXPECT_TRUE(r.rejections.empty());
  EXPECT_EQ(e->snapshot()->num_factors, before->num_factors - 1);
  const ProcessResult refused = e->Process({Remove(RemoveTarget::kOdometry, "r", 0, "", 1)});
  EXPECT_EQ(OnlyRejection(refused), RejectReason::kWouldDisconnect);
  EXPECT_EQ(e->snapshot()->num_factors, before->num_factors - 1);
  ExpectNear(PoseOf(*e, "r", 1), kStep, 1e-6);
}

// A removal splits its batch: the messages before and after it are separate updates.
TEST(EstimatorTest, RemovalSplitsTheBatch) {
  auto e = Make();
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2()), Odo("r", 0, 1, kStep)}).status.ok());
  const ProcessResult r =
      e->Process({Odo("r", 1, 2, kStep), Loop("r", 2, "r", 0, kStep * kStep),
                  Remove(RemoveTarget::kLoopClosure, "r", 2, "r", 0), Odo("r", 2, 3, kStep)});
  ASSERT_TRUE(r.status.ok());
  EXPECT_EQ(r.updates.size(), 3u);
  EXPECT_EQ(r.applied, 4);
  EXPECT_EQ(e->snapshot()->num_factors, 4);
}

// Reference: prior sigma a on x0, identity odometry sigma b: Σ(x1) = (a² + b²) I, and the
// joint of (x0, x1) has a² I off the diagonal.
TEST(EstimatorTest, MarginalsAtTheEstimate) {
  auto e = Make();
  const Inbound odo = {OdometryMeasurement{1, "r", 0, 1, Pose2(), Noise(3, 0.1)}, 0};
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2()), odo}).status.ok());
  const core::Key x0 = e->KeyOf({"r", KeyKind::kPose, 0}).value();
  const core::Key x1 = e->KeyOf({"r", KeyKind::kPose, 1}).value();
  EXPECT_FALSE(e->KeyOf({"r", KeyKind::kPose, 2}).has_value());
  EXPECT_FALSE(e->KeyOf({"r", KeyKind::kLandmark, 1}).has_value());
  EXPECT_FALSE(e->KeyOf({"q", KeyKind::kPose, 0}).has_value());
  Eigen::MatrixXd cov;
  ASSERT_TRUE(e->Marginal(x1, &cov).ok());
  EXPECT_TRUE(cov.isApprox(Eigen::Matrix3d::Identity() * (1e-4 + 1e-2), 1e-12)) << cov;
  const std::vector<core::Key> keys = {x0, x1};
  ASSERT_TRUE(e->JointMarginal(keys, &cov).ok());
  ASSERT_EQ(cov.rows(), 6);
  EXPECT_TRUE((cov.block<3, 3>(0, 3).isApprox(Eigen::Matrix3d::Identity() * 1e-4, 1e-12)));
}

// The configured default kernel applies to loop closures that name none: a gross outlier
// pulls the chain far less; one that names its own kernel keeps it.
TEST(EstimatorTest, DefaultLoopClosureKernelLimitsAnOutlier) {
  std::vector<Inbound> chain = {Prior("r", 0, Pose2())};
  for (int i = 0; i < 6; ++i) chain.push_back(Odo("r", i, i + 1, kStep));
  const Inbound wrong = Loop("r", 6, "r", 0, Pose2(20, -15, 2.0));
  EstimatorParams robust;
  robust.loop_closure_kernel = "cauchy";
  robust.loop_closure_kernel_parameter = 1.0;
  EXPECT_TRUE(robust.Validate().ok());
  auto plain = Make();
  auto with = Make(robust);
  for (Estimator* e : {plain.get(), with.get()}) {
    ASSERT_TRUE(e->Process(chain).status.ok());
    ASSERT_TRUE(e->Process({wrong}).status.ok());
    e->Refine(1.0);  // towards the optimum (convergence is not the point here)
  }
  const Pose2 truth = kStep * kStep * kStep * kStep * kStep * kStep;
  const Pose2 moved_plain = PoseOf(*plain, "r", 6);
  const Pose2 moved_robust = PoseOf(*with, "r", 6);
  const double pull_plain = (moved_plain.translation() - truth.translation()).norm();
  const double pull_robust = (moved_robust.translation() - truth.translation()).norm();
  EXPECT_GT(pull_plain, 1.0);
  EXPECT_LT(pull_robust, 0.1 * pull_plain) << pull_robust << " vs " << pull_plain;

  EstimatorParams bad = robust;
  bad.loop_closure_kernel = "tukey";
  EXPECT_NE(bad.Validate().message().find("estimator.loop_closure_kernel"), std::string::npos);
  bad = robust;
  bad.loop_closure_kernel_parameter = -1;
  EXPECT_NE(bad.Validate().message().find("loop_closure_kernel_parameter"), std::string::npos);
}

// chi2 is O(factors): recomputed at most every chi2_interval_s while updates stream in, and
// once the estimate settles.
TEST(EstimatorTest, Chi2LagsWhileUpdatingAndIsCurrentWhenSettled) {
  auto e = Make({.chi2_interval_s = 1e6});
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2()), Odo("r", 0, 1, kStep)}).status.ok());
  // The estimator's first snapshot (empty graph, sequence 0) computed it; not due again yet.
  EXPECT_EQ(e->snapshot()->chi2_sequence, 0);
  for (int i = 1; i < 6; ++i) ASSERT_TRUE(e->Process({Odo("r", i, i + 1, kStep)}).status.ok());
  ASSERT_TRUE(e->Process({Loop("r", 6, "r", 0, Pose2(0.5, 0.5, 0.5))}).status.ok());
  EXPECT_EQ(e->snapshot()->chi2, 0.0);
  EXPECT_EQ(e->snapshot()->chi2_sequence, 0);
  ASSERT_TRUE(e->Refine(5.0).converged);
  EXPECT_EQ(e->snapshot()->chi2_sequence, e->snapshot()->update_sequence);
  EXPECT_NEAR(e->snapshot()->chi2, e->solver().Chi2(), 1e-12);
  EXPECT_GT(e->snapshot()->chi2, 1e-3);
}

// ... and, whatever chi2_interval_s says, at most 2% of the time: after a pass that took t, the
// next waits 50 t. A pass over 20000 factors takes far longer than the next update (a few
// microseconds later), which therefore finds chi2 not due although chi2_interval_s has long
// passed; 500 t later it is recomputed.
TEST(EstimatorTest, Chi2PassesTakeAtMostTwoPercentOfTheTime) {
  auto e = Make({.chi2_interval_s = 1e-9});
  std::vector<Inbound> chain = {Prior("r", 0, Pose2())};
  for (int i = 0; i < 20000; ++i) chain.push_back(Odo("r", i, i + 1, kStep));
  ASSERT_TRUE(e->Process(chain).status.ok());
  const std::int64_t computed = e->snapshot()->chi2_sequence;
  ASSERT_EQ(computed, e->snapshot()->update_sequence);
  const auto start = std::chrono::steady_clock::now();
  (void)e->solver().Chi2();
  const auto pass = std::chrono::steady_clock::now() - start;
  ASSERT_TRUE(e->Process({Odo("r", 20000, 20001, kStep)}).status.ok());
  EXPECT_EQ(e->snapshot()->chi2_sequence, computed) << "recomputed right after a pass";
  // Recomputed once 50x the pass has gone by. The gate uses the estimator's own pass, which may
  // have taken longer than this one on a loaded machine: wait in steps, for 10 s at most.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  for (int i = 20001; e->snapshot()->chi2_sequence != e->snapshot()->update_sequence; ++i) {
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "chi2 never recomputed";
    std::this_thread::sleep_for(50 * pass + std::chrono::milliseconds(20));
    ASSERT_TRUE(e->Process({Odo("r", i, i + 1, kStep)}).status.ok());
  }
  EXPECT_NEAR(e->snapshot()->chi2, e->solver().Chi2(), 1e-9);
}

TEST(EstimatorTest, RejectHeldAnswersEveryHeldMessage) {
  auto e = Make();
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2()), Odo("r", 3, 4, kStep), Odo("r", 5, 6, kStep)})
                  .status.ok());
  ASSERT_EQ(e->held_messages(), 2);
  const std::vector<Rejection> r = e->RejectHeld("stopping");
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[0].verdict.reason, RejectReason::kOutOfOrderTimeout);
  EXPECT_NE(r[1].verdict.message.find("stopping"), std::string::npos);
  EXPECT_EQ(e->held_messages(), 0);
  EXPECT_EQ(e->snapshot()->counters.rejected, 2);
}

// Background relinearisation (EstimatorParams::background_relinearization_above): updates due
// to relinearise more than 2 variables defer it and start a rebuild; each rebuild is finished
// only after more messages came (new poses, loop closures, a removal of a loop closure from
// before the rebuild started, a loop closure added and removed at once), so the catch-up has
// all of that to take. A removal after a swap finds its factor in the new solver. Settled, the
// result equals an estimator that relinearised every time in the update and never had the
// removed loop closures. Parameterised: live (the helper's rounds, if any, and the swap's
// catch-up), and replaying with catch-up rounds of two logged updates each (as a journal would
// give them), so that removals are mapped across rounds and within one.
class BackgroundRebuildTest : public ::testing::TestWithParam<bool> {};

TEST_P(BackgroundRebuildTest, TakesWhatCameMeanwhileAndSettlesOnTheSameOptimum) {
  const bool replay = GetParam();
  auto rebuilt = Make({.chi2_interval_s = 0.0, .background_relinearization_above = 2});
  auto inline_only = Make({.chi2_interval_s = 0.0, .background_relinearization_above = 0});
  rebuilt->SetReplaying(replay);
  int deferred = 0;  // updates of `rebuilt` that deferred a relinearisation
  int logged = 0;    // its updates since the rebuild in flight started
  bool in_flight = false;
  auto both = [&](std::vector<Inbound> batch) {
    const ProcessResult a = rebuilt->Process(batch);
    const ProcessResult b = inline_only->Process(batch);
    EXPECT_TRUE(a.status.ok()) << a.status.ToString();
    EXPECT_TRUE(b.status.ok()) << b.status.ToString();
    EXPECT_TRUE(a.rejections.empty()) << a.rejections[0].verdict.message;
    for (const core::Isam2Result& u : a.updates) {
      logged += in_flight;
      if (u.relinearization_deferred > 0 && !in_flight) in_flight = true, logged = 0;
      deferred += u.relinearization_deferred > 0;
    }
  };
  int swaps = 0, rounds = 0;
  auto finish = [&] {
    std::vector<int> replay_rounds;
    for (int left = logged; replay && left >= 2; left -= 2) replay_rounds.push_back(2);
    const core::Result<bool> swapped = rebuilt->FinishRebuild(replay_rounds);
    ASSERT_TRUE(swapped.ok()) << swapped.status().ToString();
    EXPECT_TRUE(swapped.value());
    if (replay) {
      EXPECT_EQ(rebuilt->last_swap_rounds(), replay_rounds);
    }
    rounds += static_cast<int>(rebuilt->last_swap_rounds().size());
    ++swaps;
    // The swap's catch-up may defer and start the next rebuild.
    in_flight = rebuilt->Rebuilding(), logged = 0;
  };
  both({Prior("r", 0, Pose2())});
  // Loop closures ~0.8 m and 0.3 rad off what the odometry says: the estimate keeps moving by
  // more than the thresholds (and there is one optimum, whichever way it is approached).
  Pose2 six = Pose2();
  for (int k = 0; k < 6; ++k) six = six * kStep;
  const Pose2 loop = six.Inverse() * Pose2(0.6, -0.5, 0.3);
  for (int i = 0; i < 60; ++i) {
    std::vector<Inbound> batch = {Odo("r", i, i + 1, kStep)};
    if (i >= 6 && i % 3 == 0) batch.push_back(Loop("r", i + 1, "r", i - 5, loop));
    // A loop closure from before, removed while a rebuild may be in flight.
    if (i >= 12 && i % 9 == 0) {
      const int j = i - 6 - (i - 6) % 3;
      batch.push_back(Remove(RemoveTarget::kLoopClosure, "r", j + 1, "r", j - 5));
    }
    // A loop closure added and at once removed (two updates, likely in one round).
    if (i % 7 == 5) {
      batch.push_back(Loop("r", i + 1, "r", i - 4, Pose2(2.0, 0.0, 0.5)));
      batch.push_back(Remove(RemoveTarget::kLoopClosure, "r", i + 1, "r", i - 4));
    }
    both(batch);
    if (i % 4 == 3 && rebuilt->Rebuilding()) finish();
  }
  EXPECT_GT(swaps, 2);
  if (replay) {
    EXPECT_GT(rounds, 2);
  }
  EXPECT_EQ(rebuilt->snapshot()->counters.rebuilds, swaps);
  EXPECT_EQ(inline_only->snapshot()->counters.rebuilds, 0);
  EXPECT_EQ(rebuilt->snapshot()->num_factors, inline_only->snapshot()->num_factors);
  // A removal of a measurement applied before the swaps.
  both({Remove(RemoveTarget::kLoopClosure, "r", 58, "r", 52)});
  // Each rebuild starts nearer the optimum.
  for (int k = 0; k < 20 && rebuilt->Rebuilding(); ++k) finish();
  ASSERT_FALSE(rebuilt->Rebuilding());
  EXPECT_GE(deferred, swaps - 20);
  ASSERT_TRUE(rebuilt->Refine(10.0).converged);
  ASSERT_TRUE(inline_only->Refine(10.0).converged);
  for (int i = 0; i <= 60; ++i) {
    ExpectNear(PoseOf(*rebuilt, "r", i), PoseOf(*inline_only, "r", i), 1e-6);
  }
  EXPECT_NEAR(rebuilt->snapshot()->chi2, inline_only->snapshot()->chi2,
              1e-8 * inline_only->snapshot()->chi2);
  EXPECT_FALSE(rebuilt->FinishRebuild().value());  // none in flight
}

INSTANTIATE_TEST_SUITE_P(LiveAndReplayedRounds, BackgroundRebuildTest, ::testing::Bool());

// A corridor walked back and forth, one batch per pose after the prior on pose 0: every 25
// poses a loop closure, 0.3 m off, to the pose 100 back. Large enough for a rebuild to take
// long against its updates.
std::vector<std::vector<Inbound>> CorridorBatches(int poses) {
  std::vector<std::vector<Inbound>> batches = {{Prior("r", 0, Pose2())}};
  Pose2 hundred = Pose2();
  for (int k = 0; k < 100; ++k) hundred = hundred * kStep;
  for (int i = 0; i < poses; ++i) {
    std::vector<Inbound> batch = {Odo("r", i, i + 1, kStep)};
    if (i >= 100 && i % 25 == 0) {
      batch.push_back(Loop("r", i + 1, "r", i - 99, hundred.Inverse() * Pose2(0.3, 0.0, 0.05)));
    }
    batches.push_back(std::move(batch));
  }
  return batches;
}

// Process(batch, finish_later = true) publishes the newest poses before the rest of the map is
// solved: its snapshot and the newest poses' marginals are those of a plain Process, bit for bit,
// while the solver still has part of its back-substitution to do; after FinishUpdate every pose
// and the chi2 are too. Two robots, loop closures, and a removal that splits a batch in two
// updates.
TEST(EstimatorTest, FinishingLaterPublishesTheSameNewestPosesAndEndsTheSame) {
  auto plain = Make();
  auto later = Make();
  std::vector<std::vector<Inbound>> batches = CorridorBatches(160);
  batches[0].push_back(Prior("s", 0, Pose2(0, 5, 0)));
  for (int i = 0; i < 160; ++i) {
    batches[i + 1].push_back(Odo("s", i, i + 1, kStep));
    if (i % 40 == 39) batches[i + 1].push_back(Loop("s", i + 1, "r", i + 1, Pose2(0, 5, 0)));
  }
  batches[120].push_back(Remove(RemoveTarget::kLoopClosure, "s", 80, "r", 80));
  batches[120].push_back(Odo("r", 200, 201, kStep));  // held: r is at 120
  int left = 0;
  for (const std::vector<Inbound>& batch : batches) {
    const ProcessResult a = plain->Process(batch);
    const ProcessResult b = later->Process(batch, /*finish_later=*/true);
    ASSERT_TRUE(a.status.ok() && b.status.ok());
    ASSERT_EQ(a.updates.size(), b.updates.size());
    const auto sa = plain->snapshot(), sb = later->snapshot();
    ASSERT_EQ(sb->update_sequence, sa->update_sequence);
    ASSERT_EQ(sb->robots.size(), sa->robots.size());
    for (size_t k = 0; k < sa->robots.size(); ++k) {
      const Pose2 pa = std::get<Pose2>(sa->robots[k].pose),
                  pb = std::get<Pose2>(sb->robots[k].pose);
      ASSERT_EQ(sb->robots[k].pose_index, sa->robots[k].pose_index);
      ASSERT_EQ(pb.x(), pa.x());
      ASSERT_EQ(pb.y(), pa.y());
      ASSERT_EQ(pb.theta(), pa.theta());
      const core::Key key = core::MakeKey('x', sa->robots[k].pose_index, sa->robots[k].id);
      Eigen::MatrixXd ca, cb;
      ASSERT_TRUE(plain->Marginal(key, &ca).ok() && later->Marginal(key, &cb).ok());
      ASSERT_EQ(ca, cb);
    }
    if (later->solver().back_substitution_pending()) ++left;
    later->FinishUpdate();
    ASSERT_FALSE(later->solver().back_substitution_pending());
    EXPECT_EQ(later->snapshot()->chi2, plain->snapshot()->chi2);
  }
  EXPECT_GT(left, 100);
  for (const char* robot : {"r", "s"}) {
    for (std::uint64_t i = 0; i <= 160; ++i) {
      const Pose2 a = PoseOf(*plain, robot, i), b = PoseOf(*later, robot, i);
      ASSERT_TRUE(a.x() == b.x() && a.y() == b.y() && a.theta() == b.theta()) << robot << i;
    }
  }
}

// A rebuild of a larger map takes long enough for many updates to be logged meanwhile: its
// helper catches up in rounds. An estimator replaying the same batches, with the same swaps and
// rounds (as the journal gives them), ends bit for bit where the live one did.
TEST(EstimatorTest, HelperCatchUpRoundsReplayBitForBit) {
  const EstimatorParams params = {.chi2_interval_s = 0.0, .background_relinearization_above = 8};
  auto live = Make(params);
  const std::vector<std::vector<Inbound>> batches = CorridorBatches(1500);
  std::map<size_t, std::vector<int>> swaps;  // after batch k: the swap's rounds
  int rounds = 0;
  for (size_t k = 0; k < batches.size(); ++k) {
    ASSERT_TRUE(live->Process(batches[k]).status.ok());
    if (!live->RebuildReady()) continue;
    ASSERT_TRUE(live->FinishRebuild().ok());
    swaps[k] = live->last_swap_rounds();
    rounds += static_cast<int>(swaps[k].size());
  }
  EXPECT_GT(swaps.size(), 2u);
  EXPECT_GT(rounds, 0);  // a 1500-pose rebuild against updates of ~50 µs
  // With rounds off the helper runs none, whatever waits; the swap takes it all.
  EstimatorParams no_rounds = params;
  no_rounds.rebuild_catch_up_rounds = 0;
  auto swap_only = Make(no_rounds);
  int swaps_without_rounds = 0;
  for (const std::vector<Inbound>& batch : batches) {
    ASSERT_TRUE(swap_only->Process(batch).status.ok());
    if (!swap_only->RebuildReady()) continue;
    ASSERT_TRUE(swap_only->FinishRebuild().ok());
    EXPECT_TRUE(swap_only->last_swap_rounds().empty());
    ++swaps_without_rounds;
  }
  EXPECT_GT(swaps_without_rounds, 2);

  auto replayed = Make(params);
  replayed->SetReplaying(true);
  for (size_t k = 0; k < batches.size(); ++k) {
    ASSERT_TRUE(replayed->Process(batches[k]).status.ok());
    const auto it = swaps.find(k);
    if (it == swaps.end()) continue;
    const core::Result<bool> swapped = replayed->FinishRebuild(it->second);
    ASSERT_TRUE(swapped.ok() && swapped.value());
    EXPECT_EQ(replayed->last_swap_rounds(), it->second);
  }
  EXPECT_EQ(replayed->Rebuilding(), live->Rebuilding());
  for (int i = 0; i <= 1500; ++i) {
    const Pose2 a = PoseOf(*live, "r", i), b = PoseOf(*replayed, "r", i);
    ASSERT_EQ(a.x(), b.x()) << "pose " << i;
    ASSERT_EQ(a.y(), b.y()) << "pose " << i;
    ASSERT_EQ(a.theta(), b.theta()) << "pose " << i;
  }
  EXPECT_EQ(replayed->snapshot()->chi2, live->snapshot()->chi2);
  // Rounds naming more updates than were logged (recorded for another rebuild, as after a
  // snapshot recovery) are ignored: the swap takes everything.
  if (replayed->Rebuilding()) {
    const core::Result<bool> swapped = replayed->FinishRebuild(std::vector<int>{1000000});
    ASSERT_TRUE(swapped.ok() && swapped.value()) << swapped.status().ToString();
    EXPECT_TRUE(replayed->last_swap_rounds().empty());
  }
}

// The helper is ready only once it has taken everything logged: an update logged while the
// rebuild was not ready (and rounds were left) never falls to the swap, also not one logged
// during the helper's chi2 pass.
TEST(EstimatorTest, SwapTakesOnlyWhatWasLoggedAfterTheRebuildWasReady) {
  const EstimatorParams params = {.chi2_interval_s = 1.0,
                                  .background_relinearization_above = 8,
                                  .rebuild_catch_up_rounds = 64};
  auto e = Make(params);
  int swaps = 0, taken_by_rounds = 0;
  size_t logged_before_ready = 0, logged = 0;
  for (const std::vector<Inbound>& batch : CorridorBatches(1500)) {
    const bool logs = e->Rebuilding();  // this update goes into the rebuild's log
    ASSERT_TRUE(e->Process(batch).status.ok());
    std::this_thread::sleep_for(std::chrono::microseconds(100));  // a stream, not one burst
    if (!logs) continue;
    ++logged;
    if (!e->RebuildReady()) {
      ++logged_before_ready;
      continue;
    }
    ASSERT_TRUE(e->FinishRebuild().ok());
    const std::vector<int>& rounds = e->last_swap_rounds();
    const size_t in_rounds = std::accumulate(rounds.begin(), rounds.end(), size_t{0});
    ASSERT_LT(rounds.size(), 64u);  // rounds were left: the helper stopped because nothing waited
    EXPECT_GE(in_rounds, logged_before_ready) << "swap " << swaps;
    EXPECT_LE(in_rounds, logged) << "swap " << swaps;
    taken_by_rounds += static_cast<int>(in_rounds);
    ++swaps;
    logged = logged_before_ready = 0;
  }
  EXPECT_GE(swaps, 2);
  EXPECT_GT(taken_by_rounds, 0);
}

// Odometry from pose i to i + 1 and, every 10 poses, a loop closure 0.3 m off to the pose 19
// back: enough relinearisation for background rebuilds with a small limit.
std::vector<Inbound> LoopingStep(int i) {
  std::vector<Inbound> batch = {Odo("r", i, i + 1, kStep)};
  if (i >= 20 && i % 10 == 0) batch.push_back(Loop("r", i + 1, "r", i - 19, Pose2(0.3, 0, 0)));
  return batch;
}

// Rounds that name more updates than were logged while the rebuild ran (a swap record of another
// rebuild, as after a recovery from a snapshot) are ignored: the swap takes everything, exactly
// as a swap without rounds, and the estimator goes on.
TEST(EstimatorTest, ReplayedRoundsThatDoNotFitTheLogAreIgnored) {
  const EstimatorParams params = {.chi2_interval_s = 0.0, .background_relinearization_above = 8};
  std::vector<std::vector<Inbound>> batches = {{Prior("r", 0, Pose2())}};
  for (int i = 0; i < 400; ++i) batches.push_back(LoopingStep(i));
  // Both replay the same batches; at the first rebuild, after three more updates are logged,
  // one swaps with rounds that do not fit, the other with none.
  auto mismatched = Make(params), plain = Make(params);
  mismatched->SetReplaying(true);
  plain->SetReplaying(true);
  int logged = -1;
  for (const std::vector<Inbound>& batch : batches) {
    ASSERT_TRUE(mismatched->Process(batch).status.ok());
    ASSERT_TRUE(plain->Process(batch).status.ok());
    ASSERT_EQ(mismatched->Rebuilding(), plain->Rebuilding());
    if (logged < 0 && mismatched->Rebuilding()) logged = 0;
    if (logged >= 0 && mismatched->Rebuilding() && ++logged == 4) {
      const core::Result<bool> a = mismatched->FinishRebuild(std::vector<int>{2, 1000000});
      ASSERT_TRUE(a.ok() && a.value()) << a.status().ToString();
      EXPECT_TRUE(mismatched->last_swap_rounds().empty());
      const core::Result<bool> b = plain->FinishRebuild();
      ASSERT_TRUE(b.ok() && b.value());
    }
  }
  ASSERT_GE(logged, 4) << "no rebuild was started";
  for (int i = 0; i <= 400; ++i) {
    const Pose2 a = PoseOf(*mismatched, "r", i), b = PoseOf(*plain, "r", i);
    ASSERT_EQ(a.x(), b.x()) << "pose " << i;
    ASSERT_EQ(a.theta(), b.theta()) << "pose " << i;
  }
}

// A swapped-in rebuild hands over the status chi2 its helper computed, so the estimator thread
// does not make that pass over every factor. With nothing logged while the rebuild ran, it is
// the chi2 of the live solver right after the swap, bit for bit.
TEST(EstimatorTest, SwapHandsOverTheChi2ItsHelperComputed) {
  // chi2_interval_s so long that the estimator thread computes chi2 only at its first update.
  auto e = Make({.chi2_interval_s = 1000.0, .background_relinearization_above = 8});
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2())}).status.ok());
  const std::int64_t first = e->snapshot()->chi2_sequence;
  for (int i = 0; i < 400 && !e->Rebuilding(); ++i) {
    ASSERT_TRUE(e->Process(LoopingStep(i)).status.ok());
  }
  ASSERT_TRUE(e->Rebuilding());
  const std::int64_t started = e->snapshot()->update_sequence;
  EXPECT_EQ(e->snapshot()->chi2_sequence, first);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!e->RebuildReady() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  const core::Result<bool> swapped = e->FinishRebuild();
  ASSERT_TRUE(swapped.ok() && swapped.value());
  EXPECT_EQ(e->snapshot()->chi2_sequence, started);
  EXPECT_GT(e->snapshot()->update_sequence, started);
  EXPECT_EQ(e->snapshot()->chi2, e->solver().Chi2());
}

}  // namespace
}  // namespace slamd::server
