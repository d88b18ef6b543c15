#include "server/estimator/estimator.h"

#include <gtest/gtest.h>

#include <cmath>

namespace slamd::server {
namespace {

using core::Pose2;

core::NoiseModel Noise(int dim, double sigma) {
  return core::NoiseModel::Isotropic(dim, sigma).value();
}

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

std::unique_ptr<Estimator> Make(EstimatorParams p = {}, int skip = 1) {
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

TEST(EstimatorTest, DuplicateMeasurementRejected) {
  auto e = Make();
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2()), Odo("r", 0, 1, kStep)}).status.ok());
  const Pose2 before = PoseOf(*e, "r", 1);
  const ProcessResult r = e->Process({Odo("r", 0, 1, Pose2(5, 5, 1))});
  EXPECT_EQ(OnlyRejection(r), RejectReason::kDuplicate);
  EXPECT_FALSE(r.updated);
  ExpectNear(PoseOf(*e, "r", 1), before, 0.0);
  // Also within one batch, and for loop closures written either way round.
  const ProcessResult r2 = e->Process({Odo("r", 1, 2, kStep), Odo("r", 1, 2, kStep)});
  EXPECT_EQ(OnlyRejection(r2), RejectReason::kDuplicate);
  EXPECT_EQ(r2.applied, 1);
  ASSERT_TRUE(e->Process({Loop("r", 2, "r", 0, kStep)}).status.ok());
  EXPECT_EQ(OnlyRejection(e->Process({Loop("r", 0, "r", 2, kStep)})), RejectReason::kDuplicate);
  EXPECT_EQ(e->snapshot()->counters.rejects_by_reason[int(RejectReason::kDuplicate)], 3);
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
  EXPECT_FALSE(r.updated);
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
  EXPECT_FALSE(r.updated);
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
  EXPECT_EQ(OnlyRejection(e->Process({Landmark("r", 0, 3, 0.0, 2.0)})), RejectReason::kDuplicate);
}

TEST(EstimatorTest, PositionPriorOnUnknownPoseIsHeldThenApplied) {
  auto e = Make();
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2())}).status.ok());
  Inbound gps = {
      PriorMeasurement{5, "r", 1, PriorKind::kPosition2, core::Point2(1, 0.1), Noise(2, 1.0)}, 0};
  EXPECT_FALSE(e->Process({gps}).updated);
  const ProcessResult r = e->Process({Odo("r", 0, 1, kStep)});
  EXPECT_EQ(r.applied, 2);
  EXPECT_EQ(e->snapshot()->num_factors, 3);
}

}  // namespace
}  // namespace slamd::server
