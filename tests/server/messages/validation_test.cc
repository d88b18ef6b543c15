// Every stateless rejection reason of every inbound type (one case per reason per type where it
// applies; the camera types' in camera_validation_test.cc), acceptance of good messages, and
// Limits::Validate.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include "server/messages/inbound.h"
#include "tests/server/ingest/test_messages.h"
#include "tests/server/messages/rejection_cases.h"

namespace slamd::server {
namespace {

using namespace testing;          // NOLINT: the example messages
using namespace rejection_cases;  // NOLINT: Case, Make, RejectionTest

std::vector<Case> OdometryCases() {
  using M = slamd::odometry_t;
  const M g2 = Odometry2(), g3 = Odometry3();
  return {
      Make<M>(
          "BadTimestamp", g2, [](M& m) { m.utime = -1; }, R::kBadTimestamp, "odometry_t.utime"),
      Make<M>(
          "EmptyRobot", g2, [](M& m) { m.robot = ""; }, R::kBadName, "odometry_t.robot: empty"),
      Make<M>(
          "RobotBadChar", g2, [](M& m) { m.robot = "al pha"; }, R::kBadName,
          "odometry_t.robot: character 2"),
      Make<M>(
          "RobotTooLong", g2, [](M& m) { m.robot = std::string(65, 'a'); }, R::kStringTooLong,
          "odometry_t.robot"),
      Make<M>(
          "FromNegative", g2, [](M& m) { m.from_index = -1; }, R::kIndexOutOfRange,
          "odometry_t.from_index"),
      Make<M>(
          "ToTooBig", g2, [](M& m) { m.to_index = kTooBig; }, R::kIndexOutOfRange,
          "odometry_t.to_index"),
      Make<M>(
          "Dimension4", g2, [](M& m) { m.dimension = 4; }, R::kBadKind, "odometry_t.dimension: 4"),
      Make<M>(
          "CountDisagreesWithVector", g2, [](M& m) { m.num_values = 2; }, R::kSizeMismatch,
          "odometry_t.num_values"),
      Make<M>(
          "ValuesFor3dIn2d", g2,
          [](M& m) {
            m.values = Pose3Values();
            m.num_values = 7;
          },
          R::kSizeMismatch, "odometry_t.num_values: 7 elements, but dimension 2"),
      Make<M>(
          "CovarianceSize", g3,
          [](M& m) {
            m.covariance = SpdCovariance(3);
            m.num_covariance = 9;
          },
          R::kSizeMismatch, "odometry_t.num_covariance"),
      Make<M>(
          "NaNValue", g2, [](M& m) { m.values[2] = kNaN; }, R::kNotFinite,
          "odometry_t.values[2]: not finite (nan)"),
      Make<M>(
          "InfCovariance", g3, [](M& m) { m.covariance[7] = kInf; }, R::kNotFinite,
          "odometry_t.covariance[7]"),
      Make<M>(
          "HugeTranslation", g2, [](M& m) { m.values[0] = -2e7; }, R::kBadMeasurement,
          "odometry_t.values[0]: -2e+07 is beyond 1e+07"),
      Make<M>(
          "TinyCovariance", g2,
          [](M& m) {
            for (double& c : m.covariance) c *= 1e-20;
          },
          R::kCovarianceIllConditioned, "odometry_t.covariance: smallest eigenvalue"),
      Make<M>(
          "SelfLoop", g2, [](M& m) { m.to_index = m.from_index; }, R::kSelfLoop,
          "odometry_t.to_index"),
      Make<M>(
          "QuaternionNotUnit", g3, [](M& m) { m.values[3] *= 1.1; }, R::kQuaternionNotUnit,
          "odometry_t.values[3..6]"),
      Make<M>(
          "ZeroQuaternion", g3,
          [](M& m) { m.values[3] = m.values[4] = m.values[5] = m.values[6] = 0; },
          R::kQuaternionNotUnit, "norm 0"),
      Make<M>("CovarianceAsymmetric", g2, Asymmetric<M>, R::kCovarianceNotSymmetric,
              "odometry_t.covariance: not symmetric"),
      Make<M>("CovarianceIndefinite", g3, Indefinite<M>, R::kCovarianceNotPositiveDefinite,
              "odometry_t.covariance: not positive definite (smallest eigenvalue -0.2"),
      Make<M>("CovarianceIllConditioned", g2, IllConditioned<M>, R::kCovarianceIllConditioned,
              "odometry_t.covariance: ill-conditioned"),
  };
}

std::vector<Case> LandmarkCases() {
  using M = slamd::landmark_observation_t;
  const M br = Landmark(1), p2 = Landmark(2), p3 = Landmark(3);
  return {
      Make<M>(
          "BadTimestamp", br, [](M& m) { m.utime = -5; }, R::kBadTimestamp,
          "landmark_observation_t.utime"),
      Make<M>(
          "EmptyRobot", br, [](M& m) { m.robot = ""; }, R::kBadName,
          "landmark_observation_t.robot"),
      Make<M>(
          "RobotTooLong", br, [](M& m) { m.robot = std::string(100, 'r'); }, R::kStringTooLong,
          "landmark_observation_t.robot"),
      Make<M>(
          "PoseNegative", br, [](M& m) { m.pose_index = -3; }, R::kIndexOutOfRange,
          "landmark_observation_t.pose_index"),
      Make<M>(
          "LandmarkTooBig", p2, [](M& m) { m.landmark_id = kTooBig; }, R::kIndexOutOfRange,
          "landmark_observation_t.landmark_id"),
      Make<M>(
          "Kind0", br, [](M& m) { m.kind = 0; }, R::kBadKind, "landmark_observation_t.kind: 0"),
      Make<M>(
          "Kind4", br, [](M& m) { m.kind = 4; }, R::kBadKind, "landmark_observation_t.kind: 4"),
      Make<M>(
          "Namespace2", p2, [](M& m) { m.landmark_namespace = 2; }, R::kBadKind,
          "landmark_observation_t.landmark_namespace: 2"),
      Make<M>(
          "NamespaceNegative", br, [](M& m) { m.landmark_namespace = -1; }, R::kBadKind,
          "landmark_observation_t.landmark_namespace: -1"),
      Make<M>(
          "ValuesForKind", p3,
          [](M& m) {
            m.values.pop_back();
            m.num_values = 2;
          },
          R::kSizeMismatch, "landmark_observation_t.num_values: 2 elements, but kind 3"),
      Make<M>(
          "CovarianceCount", p2, [](M& m) { m.num_covariance = 9; }, R::kSizeMismatch,
          "landmark_observation_t.num_covariance"),
      Make<M>(
          "NaNValue", p3, [](M& m) { m.values[1] = -kNaN; }, R::kNotFinite,
          "landmark_observation_t.values[1]"),
      Make<M>(
          "NaNCovariance", br, [](M& m) { m.covariance[3] = kNaN; }, R::kNotFinite,
          "landmark_observation_t.covariance[3]"),
      Make<M>(
          "NegativeRange", br, [](M& m) { m.values[1] = -1.0; }, R::kBadMeasurement,
          "landmark_observation_t.values[1]: range -1 m is negative"),
      Make<M>(
          "AbsurdRange", br, [](M& m) { m.values[1] = 8.03e283; }, R::kBadMeasurement,
          "landmark_observation_t.values[1]: 8.03e+283 is beyond 1e+07"),
      Make<M>("CovarianceAsymmetric", p3, Asymmetric<M>, R::kCovarianceNotSymmetric,
              "landmark_observation_t.covariance"),
      Make<M>("CovarianceIndefinite", br, Indefinite<M>, R::kCovarianceNotPositiveDefinite,
              "landmark_observation_t.covariance"),
      Make<M>("CovarianceIllConditioned", p3, IllConditioned<M>, R::kCovarianceIllConditioned,
              "landmark_observation_t.covariance"),
  };
}

std::vector<Case> LoopClosureCases() {
  using M = slamd::loop_closure_t;
  const M g2 = LoopClosure2(), g3 = LoopClosure3();
  return {
      Make<M>(
          "BadTimestamp", g2, [](M& m) { m.utime = -1; }, R::kBadTimestamp, "loop_closure_t.utime"),
      Make<M>(
          "RobotAEmpty", g2, [](M& m) { m.robot_a = ""; }, R::kBadName, "loop_closure_t.robot_a"),
      Make<M>(
          "RobotBBadChar", g2, [](M& m) { m.robot_b = "br/avo"; }, R::kBadName,
          "loop_closure_t.robot_b"),
      Make<M>(
          "RobotBTooLong", g2, [](M& m) { m.robot_b = std::string(65, 'b'); }, R::kStringTooLong,
          "loop_closure_t.robot_b"),
      Make<M>(
          "PoseANegative", g2, [](M& m) { m.pose_a = -1; }, R::kIndexOutOfRange,
          "loop_closure_t.pose_a"),
      Make<M>(
          "PoseBTooBig", g2, [](M& m) { m.pose_b = kTooBig; }, R::kIndexOutOfRange,
          "loop_closure_t.pose_b"),
      Make<M>(
          "Dimension0", g2, [](M& m) { m.dimension = 0; }, R::kBadKind, "loop_closure_t.dimension"),
      Make<M>(
          "ValuesCount", g3, [](M& m) { m.num_values = 8; }, R::kSizeMismatch,
          "loop_closure_t.num_values"),
      Make<M>(
          "CovarianceFor2dIn3d", g3,
          [](M& m) {
            m.covariance = SpdCovariance(3);
            m.num_covariance = 9;
          },
          R::kSizeMismatch, "loop_closure_t.num_covariance: 9 elements, but dimension 3"),
      Make<M>(
          "InfValue", g2, [](M& m) { m.values[0] = kInf; }, R::kNotFinite,
          "loop_closure_t.values[0]"),
      Make<M>(
          "NaNRobustParameter", g2, [](M& m) { m.robust_parameter = kNaN; }, R::kNotFinite,
          "loop_closure_t.robust_parameter"),
      Make<M>(
          "SelfLoop", g2,
          [](M& m) {
            m.robot_b = m.robot_a;
            m.pose_b = m.pose_a;
          },
          R::kSelfLoop, "loop_closure_t.pose_b"),
      Make<M>(
          "QuaternionNotUnit", g3, [](M& m) { m.values[6] += 0.01; }, R::kQuaternionNotUnit,
          "loop_closure_t.values[3..6]"),
      Make<M>("CovarianceAsymmetric", g3, Asymmetric<M>, R::kCovarianceNotSymmetric,
              "loop_closure_t.covariance"),
      Make<M>("CovarianceIndefinite", g2, Indefinite<M>, R::kCovarianceNotPositiveDefinite,
              "loop_closure_t.covariance"),
      Make<M>("CovarianceIllConditioned", g3, IllConditioned<M>, R::kCovarianceIllConditioned,
              "loop_closure_t.covariance"),
      Make<M>(
          "UnknownKernel", g2, [](M& m) { m.robust_kernel = "tukey"; }, R::kUnknownRobustKernel,
          "loop_closure_t.robust_kernel: unknown robust kernel 'tukey'"),
      Make<M>(
          "KernelNameTooLong", g2, [](M& m) { m.robust_kernel = std::string(33, 'h'); },
          R::kStringTooLong, "loop_closure_t.robust_kernel"),
      Make<M>(
          "HuberZeroParameter", g2, [](M& m) { m.robust_parameter = 0.0; }, R::kBadRobustParameter,
          "loop_closure_t.robust_parameter: 0 is not valid for huber"),
      Make<M>(
          "DcsNegativeParameter", g3,
          [](M& m) {
            m.robust_kernel = "DCS";
            m.robust_parameter = -1.0;
          },
          R::kBadRobustParameter, "loop_closure_t.robust_parameter"),
  };
}

std::vector<Case> PriorCases() {
  using M = slamd::prior_t;
  const M pose2 = Prior(1), pose3 = Prior(2), pos2 = Prior(3), pos3 = Prior(4);
  return {
      Make<M>(
          "BadTimestamp", pose2, [](M& m) { m.utime = -1; }, R::kBadTimestamp, "prior_t.utime"),
      Make<M>(
          "EmptyRobot", pos2, [](M& m) { m.robot = ""; }, R::kBadName, "prior_t.robot"),
      Make<M>(
          "RobotTooLong", pos2, [](M& m) { m.robot = std::string(65, 'x'); }, R::kStringTooLong,
          "prior_t.robot"),
      Make<M>(
          "PoseTooBig", pose3, [](M& m) { m.pose_index = kTooBig; }, R::kIndexOutOfRange,
          "prior_t.pose_index"),
      Make<M>(
          "Kind5", pose2, [](M& m) { m.kind = 5; }, R::kBadKind, "prior_t.kind: 5"),
      // Position 2D values (2) sent as a pose 2D prior (3). (Position 3D -> pose 2D has the same
      // sizes and cannot be caught: the kind field is the only witness.)
      Make<M>(
          "PoseKindWithPositionValues", pos2, [](M& m) { m.kind = 1; }, R::kSizeMismatch,
          "prior_t.num_values: 2 elements, but kind 1"),
      Make<M>(
          "PositionCovariance", pos2,
          [](M& m) {
            m.covariance = SpdCovariance(3);
            m.num_covariance = 9;
          },
          R::kSizeMismatch, "prior_t.num_covariance: 9 elements, but kind 3"),
      Make<M>(
          "CovarianceCountDisagrees", pos3, [](M& m) { m.covariance.pop_back(); }, R::kSizeMismatch,
          "prior_t.num_covariance: 9 but the array holds 8"),
      Make<M>(
          "NaNValue", pos3, [](M& m) { m.values[2] = kNaN; }, R::kNotFinite, "prior_t.values[2]"),
      Make<M>(
          "QuaternionNotUnit", pose3, [](M& m) { m.values[4] += 0.5; }, R::kQuaternionNotUnit,
          "prior_t.values[3..6]"),
      Make<M>("CovarianceAsymmetric", pose2, Asymmetric<M>, R::kCovarianceNotSymmetric,
              "prior_t.covariance"),
      Make<M>("CovarianceIndefinite", pos2, Indefinite<M>, R::kCovarianceNotPositiveDefinite,
              "prior_t.covariance"),
      Make<M>("CovarianceIllConditioned", pose3, IllConditioned<M>, R::kCovarianceIllConditioned,
              "prior_t.covariance"),
  };
}

std::vector<Case> RemoveFactorCases() {
  using M = slamd::remove_factor_t;
  const M odo = RemoveFactor(1), lm = RemoveFactor(2), lc = RemoveFactor(3), pr = RemoveFactor(4);
  return {
      Make<M>(
          "BadTimestamp", odo, [](M& m) { m.utime = -1; }, R::kBadTimestamp,
          "remove_factor_t.utime"),
      Make<M>(
          "Target0", odo, [](M& m) { m.target = 0; }, R::kBadKind, "remove_factor_t.target: 0"),
      Make<M>(
          "Target6", odo, [](M& m) { m.target = 6; }, R::kBadKind, "remove_factor_t.target: 6"),
      Make<M>(
          "MapLandmarkRobotBSet", lm,
          [](M& m) {
            m.target = M::TARGET_MAP_LANDMARK_OBSERVATION;
            m.robot_b = "alpha";
          },
          R::kUnusedFieldSet, "remove_factor_t.robot_b"),
      Make<M>(
          "RobotAEmpty", lm, [](M& m) { m.robot_a = ""; }, R::kBadName, "remove_factor_t.robot_a"),
      Make<M>(
          "RobotATooLong", lm, [](M& m) { m.robot_a = std::string(65, 'a'); }, R::kStringTooLong,
          "remove_factor_t.robot_a"),
      Make<M>(
          "IndexANegative", odo, [](M& m) { m.index_a = -1; }, R::kIndexOutOfRange,
          "remove_factor_t.index_a"),
      Make<M>(
          "IndexBTooBig", lc, [](M& m) { m.index_b = kTooBig; }, R::kIndexOutOfRange,
          "remove_factor_t.index_b"),
      Make<M>(
          "OdometryRobotBSet", odo, [](M& m) { m.robot_b = "bravo"; }, R::kUnusedFieldSet,
          "remove_factor_t.robot_b: 'bravo' must be empty for odometry"),
      Make<M>(
          "OdometryKindSet", odo, [](M& m) { m.kind = 1; }, R::kUnusedFieldSet,
          "remove_factor_t.kind"),
      Make<M>(
          "OdometrySelfLoop", odo, [](M& m) { m.index_b = m.index_a; }, R::kSelfLoop,
          "remove_factor_t.index_b"),
      Make<M>(
          "LandmarkRobotBSet", lm, [](M& m) { m.robot_b = "alpha"; }, R::kUnusedFieldSet,
          "remove_factor_t.robot_b"),
      Make<M>(
          "LandmarkKind0", lm, [](M& m) { m.kind = 0; }, R::kBadKind, "remove_factor_t.kind: 0"),
      Make<M>(
          "LoopClosureRobotBEmpty", lc, [](M& m) { m.robot_b = ""; }, R::kBadName,
          "remove_factor_t.robot_b: empty"),
      Make<M>(
          "LoopClosureKindSet", lc, [](M& m) { m.kind = 2; }, R::kUnusedFieldSet,
          "remove_factor_t.kind"),
      Make<M>(
          "LoopClosureSelfLoop", lc,
          [](M& m) {
            m.robot_b = m.robot_a;
            m.index_b = m.index_a;
          },
          R::kSelfLoop, "remove_factor_t.index_b"),
      Make<M>(
          "PriorIndexBSet", pr, [](M& m) { m.index_b = 3; }, R::kUnusedFieldSet,
          "remove_factor_t.index_b: 3 must be 0"),
      Make<M>(
          "PriorRobotBSet", pr,
          [](M& m) {
            m.robot_b.assign(1, 'x'); /* not = "x": GCC 12 -Wrestrict misfires */
          },
          R::kUnusedFieldSet, "remove_factor_t.robot_b"),
      Make<M>(
          "PriorKind7", pr, [](M& m) { m.kind = 7; }, R::kBadKind, "remove_factor_t.kind: 7"),
  };
}

std::vector<Case> QueryCases() {
  using M = slamd::query_t;
  const M q = Query();
  return {
      Make<M>(
          "BadTimestamp", q, [](M& m) { m.utime = -1; }, R::kBadTimestamp, "query_t.utime"),
      Make<M>(
          "ClientBadChar", q, [](M& m) { m.client = "me\n"; }, R::kBadName, "query_t.client"),
      Make<M>(
          "ClientTooLong", q, [](M& m) { m.client = std::string(65, 'c'); }, R::kStringTooLong,
          "query_t.client"),
      Make<M>(
          "KeyCountDisagrees", q, [](M& m) { m.num_keys = 4; }, R::kSizeMismatch,
          "query_t.num_keys"),
      Make<M>(
          "TooManyKeys", q,
          [](M& m) {
            m.want_joint_marginal = false;
            m.keys.assign(101, Key("alpha", 1, 1));
            m.num_keys = 101;
          },
          R::kTooManyElements, "query_t.keys: 101 keys"),
      Make<M>(
          "TooManyJointKeys", q,
          [](M& m) {
            m.keys.assign(11, Key("alpha", 1, 1));
            m.num_keys = 11;
          },
          R::kTooManyElements, "for a joint marginal"),
      Make<M>(
          "KeyRobotEmpty", q, [](M& m) { m.keys[1].robot = ""; }, R::kBadName,
          "query_t.keys[1].robot: empty"),
      Make<M>(
          "KeyRobotTooLong", q, [](M& m) { m.keys[2].robot = std::string(65, 'k'); },
          R::kStringTooLong, "query_t.keys[2].robot"),
      Make<M>(
          "KeyKind4", q, [](M& m) { m.keys[0].kind = 4; }, R::kBadKind, "query_t.keys[0].kind: 4"),
      Make<M>(
          "MapLandmarkWithARobot", q,
          [](M& m) { m.keys[0].kind = slamd::key_t::KIND_MAP_LANDMARK; }, R::kUnusedFieldSet,
          "query_t.keys[0].robot: 'alpha' for a map landmark"),
      Make<M>(
          "KeyIndexNegative", q, [](M& m) { m.keys[2].index = -7; }, R::kIndexOutOfRange,
          "query_t.keys[2].index"),
      Make<M>(
          "MapRobotBadChar", q, [](M& m) { m.map_robot = "a*"; }, R::kBadName, "query_t.map_robot"),
  };
}

TEST_P(RejectionTest, RejectsWithReasonNamingTheField) {
  const Case& c = GetParam();
  const Verdict v = c.run();
  EXPECT_FALSE(v.ok());
  EXPECT_EQ(v.reason, c.reason) << RejectReasonName(v.reason) << ": " << v.message;
  EXPECT_NE(v.message.find(c.message_part), std::string::npos)
      << "message '" << v.message << "' lacks '" << c.message_part << "'";
}

INSTANTIATE_TEST_SUITE_P(Odometry, RejectionTest, ::testing::ValuesIn(OdometryCases()), CaseName);
INSTANTIATE_TEST_SUITE_P(LandmarkObservation, RejectionTest, ::testing::ValuesIn(LandmarkCases()),
                         CaseName);
INSTANTIATE_TEST_SUITE_P(LoopClosure, RejectionTest, ::testing::ValuesIn(LoopClosureCases()),
                         CaseName);
INSTANTIATE_TEST_SUITE_P(Prior, RejectionTest, ::testing::ValuesIn(PriorCases()), CaseName);
INSTANTIATE_TEST_SUITE_P(RemoveFactor, RejectionTest, ::testing::ValuesIn(RemoveFactorCases()),
                         CaseName);
INSTANTIATE_TEST_SUITE_P(Query, RejectionTest, ::testing::ValuesIn(QueryCases()), CaseName);

// Every stateless reason (2..18; 1 is the transport's decode error) is exercised above.
TEST(RejectionCoverage, EveryStatelessReasonIsTested) {
  std::set<R> seen;
  for (const auto& cases : {OdometryCases(), LandmarkCases(), LoopClosureCases(), PriorCases(),
                            RemoveFactorCases(), QueryCases()}) {
    for (const Case& c : cases) seen.insert(c.reason);
  }
  for (int code = 2; code <= 18; ++code) {
    EXPECT_TRUE(seen.count(static_cast<R>(code)))
        << "no case for " << RejectReasonName(static_cast<R>(code));
  }
}

// --- Acceptance ---

TEST(Accepts, GoodMessagesOfEveryKind) {
  for (const auto& m : {Odometry2(), Odometry3()})
    EXPECT_TRUE(Validate(m).ok()) << Validate(m).message;
  for (int kind = 1; kind <= 3; ++kind)
    EXPECT_TRUE(Validate(Landmark(kind)).ok()) << Validate(Landmark(kind)).message;
  for (const auto& m : {LoopClosure2(), LoopClosure3()})
    EXPECT_TRUE(Validate(m).ok()) << Validate(m).message;
  for (int kind = 1; kind <= 4; ++kind)
    EXPECT_TRUE(Validate(Prior(kind)).ok()) << Validate(Prior(kind)).message;
  for (int target = 1; target <= 4; ++target) {
    EXPECT_TRUE(Validate(RemoveFactor(target)).ok()) << Validate(RemoveFactor(target)).message;
  }
  EXPECT_TRUE(Validate(Query()).ok()) << Validate(Query()).message;
}

TEST(Accepts, BoundaryValues) {
  auto odo = Odometry2();
  odo.utime = 0;
  odo.from_index = 0;
  odo.to_index = kTooBig - 1;  // 2^48-1, the largest key index
  odo.robot = std::string(64, 'z');
  odo.values[2] = 100.0;  // any finite angle (it is wrapped)
  EXPECT_TRUE(Validate(odo).ok()) << Validate(odo).message;

  auto lm = Landmark(1);
  lm.values[1] = 0.0;  // zero range: the factor handles it
  EXPECT_TRUE(Validate(lm).ok()) << Validate(lm).message;

  auto lc = LoopClosure2();
  lc.pose_b = lc.pose_a;  // same index on another robot: not a self loop
  lc.robust_kernel = "none";
  lc.robust_parameter = -3.0;  // ignored without a kernel
  EXPECT_TRUE(Validate(lc).ok()) << Validate(lc).message;
  lc.robust_kernel = "Geman-McClure";
  lc.robust_parameter = 2.0;
  EXPECT_TRUE(Validate(lc).ok()) << Validate(lc).message;

  auto q = Query();
  q.client = "";      // anonymous
  q.map_robot = "*";  // every robot
  EXPECT_TRUE(Validate(q).ok()) << Validate(q).message;
  q.keys.clear();
  q.num_keys = 0;
  EXPECT_TRUE(Validate(q).ok()) << Validate(q).message;
}

TEST(Accepts, NearlySymmetricAndNearlyUnitWithinTolerance) {
  auto odo = Odometry3();
  odo.covariance[1] *= 1.0 + 1e-9;                       // float round-off in a client
  for (int i = 3; i < 7; ++i) odo.values[i] *= 1.00005;  // |q| = 1.00005
  EXPECT_TRUE(Validate(odo).ok()) << Validate(odo).message;
}

TEST(Accepts, TinyButWellConditionedCovariance) {
  auto odo = Odometry2();
  odo.covariance = SpdCovariance(3, 1e-12);  // µm-level sensor: absolute scale must not matter
  EXPECT_TRUE(Validate(odo).ok()) << Validate(odo).message;
}

TEST(Validate, ReturnsNoiseModelAndKernelWhenAsked) {
  std::optional<core::NoiseModel> noise;
  core::RobustKernel robust;
  const auto lc = LoopClosure2();
  ASSERT_TRUE(Validate(lc, {}, &noise, &robust).ok());
  ASSERT_TRUE(noise.has_value());
  EXPECT_EQ(noise->dim(), 3);
  EXPECT_EQ(robust.kind(), core::RobustKernel::Kind::kHuber);
  EXPECT_DOUBLE_EQ(robust.parameter(), 1.345);
}

TEST(Validate, CustomLimitsApply) {
  Limits limits;
  limits.max_robot_name_length = 3;
  EXPECT_EQ(Validate(Odometry2(), limits).reason, R::kStringTooLong);
  limits = Limits{};
  limits.max_condition_number = 2.0;
  EXPECT_EQ(Validate(Odometry2(), limits).reason, R::kCovarianceIllConditioned);
  limits = Limits{};
  limits.max_query_keys = 2;
  EXPECT_EQ(Validate(Query(), limits).reason, R::kTooManyElements);
}

TEST(LimitsValidate, DefaultsAreValidAndEachRangeIsChecked) {
  EXPECT_TRUE(Limits{}.Validate().ok());
  auto expect_bad = [](Limits l, const char* field) {
    const core::Status s = l.Validate();
    EXPECT_FALSE(s.ok()) << field;
    EXPECT_NE(s.message().find(field), std::string::npos) << s.message();
  };
  expect_bad(Limits{.max_robot_name_length = 0}, "max_robot_name_length");
  expect_bad(Limits{.max_client_name_length = 0}, "max_client_name_length");
  expect_bad(Limits{.max_robust_kernel_name_length = 0}, "max_robust_kernel_name_length");
  expect_bad(Limits{.max_query_keys = 0}, "max_query_keys");
  expect_bad(Limits{.max_joint_marginal_keys = -1}, "max_joint_marginal_keys");
  expect_bad(Limits{.max_condition_number = 1e15}, "max_condition_number");
  expect_bad(Limits{.quaternion_norm_tolerance = 0.0}, "quaternion_norm_tolerance");
  expect_bad(Limits{.symmetry_tolerance = 0.1}, "symmetry_tolerance");
}

}  // namespace
}  // namespace slamd::server
