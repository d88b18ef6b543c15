#include "server/messages/remove_factor.h"

#include <algorithm>

#include "server/ingest/field_checks.h"
#include "server/messages/landmark_observation.h"
#include "server/messages/loop_closure.h"
#include "server/messages/odometry.h"
#include "server/messages/prior.h"
#include "slamd/remove_factor_t.hpp"

namespace slamd::server {
namespace {

using R = ::slamd::remove_factor_t;
static_assert(static_cast<int>(RemoveTarget::kOdometry) == R::TARGET_ODOMETRY);
static_assert(static_cast<int>(RemoveTarget::kLandmarkObservation) ==
              R::TARGET_LANDMARK_OBSERVATION);
static_assert(static_cast<int>(RemoveTarget::kLoopClosure) == R::TARGET_LOOP_CLOSURE);
static_assert(static_cast<int>(RemoveTarget::kPrior) == R::TARGET_PRIOR);
static_assert(static_cast<int>(RemoveTarget::kMapLandmarkObservation) ==
              R::TARGET_MAP_LANDMARK_OBSERVATION);

using internal::CheckIndex;
using internal::CheckKindRange;
using internal::CheckName;
using internal::CheckUtime;
using internal::kLandmarkKinds;
using internal::kPriorKinds;
using internal::MustBeEmpty;
using internal::MustBeZero;
using internal::Reject;

}  // namespace

Verdict Validate(const slamd::remove_factor_t& msg, const Limits& limits) {
  using M = slamd::remove_factor_t;
  SLAMD_RETURN_IF_REJECTED(CheckUtime("remove_factor_t.utime", msg.utime));
  SLAMD_RETURN_IF_REJECTED(CheckKindRange(
      "remove_factor_t.target", msg.target, M::TARGET_ODOMETRY, M::TARGET_MAP_LANDMARK_OBSERVATION,
      "1 (odometry), 2 (landmark observation), 3 (loop closure), 4 (prior), "
      "5 (map landmark observation)"));
  SLAMD_RETURN_IF_REJECTED(
      CheckName("remove_factor_t.robot_a", msg.robot_a, limits.max_robot_name_length));
  SLAMD_RETURN_IF_REJECTED(CheckIndex("remove_factor_t.index_a", msg.index_a));
  switch (msg.target) {
    case M::TARGET_ODOMETRY:
      SLAMD_RETURN_IF_REJECTED(MustBeEmpty("remove_factor_t.robot_b", msg.robot_b, "odometry"));
      SLAMD_RETURN_IF_REJECTED(CheckIndex("remove_factor_t.index_b", msg.index_b));
      SLAMD_RETURN_IF_REJECTED(MustBeZero("remove_factor_t.kind", msg.kind, "odometry"));
      if (msg.index_a == msg.index_b) {
        return Reject(RejectReason::kSelfLoop, "remove_factor_t.index_b",
                      "equals index_a (" + std::to_string(msg.index_a) + ")");
      }
      return {};
    case M::TARGET_LANDMARK_OBSERVATION:
    case M::TARGET_MAP_LANDMARK_OBSERVATION:
      SLAMD_RETURN_IF_REJECTED(
          MustBeEmpty("remove_factor_t.robot_b", msg.robot_b, "landmark observations"));
      SLAMD_RETURN_IF_REJECTED(CheckIndex("remove_factor_t.index_b", msg.index_b));
      return CheckKindRange("remove_factor_t.kind", msg.kind, 1, 3, kLandmarkKinds);
    case M::TARGET_LOOP_CLOSURE:
      SLAMD_RETURN_IF_REJECTED(
          CheckName("remove_factor_t.robot_b", msg.robot_b, limits.max_robot_name_length));
      SLAMD_RETURN_IF_REJECTED(CheckIndex("remove_factor_t.index_b", msg.index_b));
      SLAMD_RETURN_IF_REJECTED(MustBeZero("remove_factor_t.kind", msg.kind, "loop closures"));
      if (msg.robot_a == msg.robot_b && msg.index_a == msg.index_b) {
        return Reject(RejectReason::kSelfLoop, "remove_factor_t.index_b",
                      "(robot_b, index_b) equals (robot_a, index_a)");
      }
      return {};
    default:  // TARGET_PRIOR
      SLAMD_RETURN_IF_REJECTED(MustBeEmpty("remove_factor_t.robot_b", msg.robot_b, "priors"));
      SLAMD_RETURN_IF_REJECTED(MustBeZero("remove_factor_t.index_b", msg.index_b, "priors"));
      return CheckKindRange("remove_factor_t.kind", msg.kind, 1, 4, kPriorKinds);
  }
}

Checked<RemoveFactorRequest> Convert(const slamd::remove_factor_t& msg, const Limits& limits) {
  Verdict verdict = Validate(msg, limits);
  if (!verdict.ok()) return verdict;
  return RemoveFactorRequest{.utime = msg.utime,
                             .target = static_cast<RemoveTarget>(msg.target),
                             .robot_a = msg.robot_a,
                             .index_a = static_cast<std::uint64_t>(msg.index_a),
                             .robot_b = msg.robot_b,
                             .index_b = static_cast<std::uint64_t>(msg.index_b),
                             .kind = msg.kind};
}

void ToLcm(const RemoveFactorRequest& m, slamd::remove_factor_t* out) {
  out->utime = m.utime;
  out->target = static_cast<std::int8_t>(m.target);
  out->robot_a = m.robot_a;
  out->index_a = static_cast<std::int64_t>(m.index_a);
  out->robot_b = m.robot_b;
  out->index_b = static_cast<std::int64_t>(m.index_b);
  out->kind = m.kind;
}

std::optional<MeasurementId> RemoveFactorSpec::Identity(const Value& r, const GraphBuilder& g,
                                                        core::Key* first, std::string* why) {
  const auto a = g.FindRobot(r.robot_a);
  if (!a) {
    *why = "remove_factor_t.robot_a: robot '" + r.robot_a + "' is not known";
    return std::nullopt;
  }
  const core::Key pose = core::MakeKey('x', r.index_a, *a);
  *first = pose;
  switch (r.target) {
    case RemoveTarget::kOdometry:
      return MeasurementId{OdometrySpec::kIdentity, pose, core::MakeKey('x', r.index_b, *a), 0};
    case RemoveTarget::kLandmarkObservation:
    case RemoveTarget::kMapLandmarkObservation: {
      const LandmarkNamespace ns = r.target == RemoveTarget::kMapLandmarkObservation
                                       ? LandmarkNamespace::kMap
                                       : LandmarkNamespace::kRobot;
      return MeasurementId{LandmarkObservationSpec::kIdentity, pose, LandmarkKey(ns, r.index_b, *a),
                           r.kind};
    }
    case RemoveTarget::kPrior:
      return MeasurementId{PriorSpec::kIdentity, pose, 0, r.kind};
    case RemoveTarget::kLoopClosure: {
      const auto b = g.FindRobot(r.robot_b);
      if (!b) {
        *why = "remove_factor_t.robot_b: robot '" + r.robot_b + "' is not known";
        return std::nullopt;
      }
      const core::Key other = core::MakeKey('x', r.index_b, *b);
      return MeasurementId{LoopClosureSpec::kIdentity, std::min(pose, other), std::max(pose, other),
                           0};
    }
  }
  *why = "remove_factor_t.target: unknown";
  return std::nullopt;
}

}  // namespace slamd::server
