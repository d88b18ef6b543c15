#include "server/messages/loop_closure.h"

#include <algorithm>
#include <memory>
#include <span>

#include "core/factors/between_factor.h"
#include "server/ingest/field_checks.h"
#include "server/messages/wire_values.h"
#include "slamd/loop_closure_t.hpp"

namespace slamd::server {
namespace {

using internal::CheckDimension;
using internal::CheckFinite;
using internal::CheckIndex;
using internal::CheckMeasurement;
using internal::CheckName;
using internal::CheckRobustKernel;
using internal::CheckUtime;
using internal::Layout;
using internal::Reject;

}  // namespace

Verdict Validate(const slamd::loop_closure_t& msg, const Limits& limits,
                 std::optional<core::NoiseModel>* noise, core::RobustKernel* robust) {
  SLAMD_RETURN_IF_REJECTED(CheckUtime("loop_closure_t.utime", msg.utime));
  SLAMD_RETURN_IF_REJECTED(
      CheckName("loop_closure_t.robot_a", msg.robot_a, limits.max_robot_name_length));
  SLAMD_RETURN_IF_REJECTED(CheckIndex("loop_closure_t.pose_a", msg.pose_a));
  SLAMD_RETURN_IF_REJECTED(
      CheckName("loop_closure_t.robot_b", msg.robot_b, limits.max_robot_name_length));
  SLAMD_RETURN_IF_REJECTED(CheckIndex("loop_closure_t.pose_b", msg.pose_b));
  const Layout* layout = nullptr;
  SLAMD_RETURN_IF_REJECTED(CheckDimension("loop_closure_t.dimension", msg.dimension, &layout));
  SLAMD_RETURN_IF_REJECTED(CheckMeasurement(
      msg, SLAMD_MEASUREMENT_FIELDS("loop_closure_t"), *layout, limits, noise, [&]() -> Verdict {
        const double parameter = msg.robust_parameter;
        SLAMD_RETURN_IF_REJECTED(
            CheckFinite("loop_closure_t.robust_parameter", std::span(&parameter, 1)));
        if (msg.robot_a == msg.robot_b && msg.pose_a == msg.pose_b) {
          return Reject(RejectReason::kSelfLoop, "loop_closure_t.pose_b",
                        "(robot_b, pose_b) equals (robot_a, pose_a) = (" + msg.robot_a + ", " +
                            std::to_string(msg.pose_a) + ")");
        }
        return {};
      }));
  return CheckRobustKernel("loop_closure_t.robust_kernel", "loop_closure_t.robust_parameter",
                           msg.robust_kernel, msg.robust_parameter, limits, robust);
}

Checked<LoopClosureMeasurement> Convert(const slamd::loop_closure_t& msg, const Limits& limits) {
  std::optional<core::NoiseModel> noise;
  core::RobustKernel robust;
  Verdict verdict = Validate(msg, limits, &noise, &robust);
  if (!verdict.ok()) return verdict;
  return LoopClosureMeasurement{.utime = msg.utime,
                                .robot_a = msg.robot_a,
                                .pose_a = static_cast<std::uint64_t>(msg.pose_a),
                                .robot_b = msg.robot_b,
                                .pose_b = static_cast<std::uint64_t>(msg.pose_b),
                                .measured = ToPose(msg.values),
                                .noise = std::move(*noise),
                                .robust = robust};
}

void ToLcm(const LoopClosureMeasurement& m, slamd::loop_closure_t* out) {
  out->utime = m.utime;
  out->robot_a = m.robot_a;
  out->pose_a = static_cast<std::int64_t>(m.pose_a);
  out->robot_b = m.robot_b;
  out->pose_b = static_cast<std::int64_t>(m.pose_b);
  out->dimension = PoseDimension(m.measured);
  SetMeasurement(PoseValues(m.measured), m.noise, out);
  out->robust_kernel = m.robust.is_none() ? "" : core::RobustKernel::KindName(m.robust.kind());
  out->robust_parameter = m.robust.parameter();
}

core::FactorPtr LoopClosureSpec::Factor(const Value& m, core::Key a, core::Key b,
                                        const core::RobustKernel& default_kernel) {
  const core::RobustKernel& robust = m.robust.is_none() ? default_kernel : m.robust;
  return std::visit(
      [&](const auto& z) -> core::FactorPtr {
        using T = std::decay_t<decltype(z)>;
        return std::make_shared<core::BetweenFactor<T>>(a, b, z, m.noise, robust);
      },
      m.measured);
}

Outcome LoopClosureSpec::Apply(const Value& m, GraphBuilder& g, Verdict* v) {
  const auto ida = g.FindRobot(m.robot_a);
  const auto idb = g.FindRobot(m.robot_b);
  const bool known_a = ida && g.Known(core::MakeKey('x', m.pose_a, *ida));
  const bool known_b = idb && g.Known(core::MakeKey('x', m.pose_b, *idb));
  if (!known_a && !known_b) {
    if (!ida || !g.Anchored(*ida)) {
      *v = {RejectReason::kUnknownRobot,
            "loop_closure_t.robot_a: robot '" + m.robot_a + "' has no pose in the graph"};
    } else if (!idb || !g.Anchored(*idb)) {
      *v = {RejectReason::kUnknownRobot,
            "loop_closure_t.robot_b: robot '" + m.robot_b + "' has no pose in the graph"};
    } else {
      // Both poses may still come: held until they do. One that cannot is named.
      const bool ahead_a = g.Ahead(core::MakeKey('x', m.pose_a, *ida));
      if (ahead_a && g.Ahead(core::MakeKey('x', m.pose_b, *idb))) return Outcome::kHeld;
      const std::string past = ahead_a ? "pose_b: " + PoseName(m.robot_b, m.pose_b)
                                       : "pose_a: " + PoseName(m.robot_a, m.pose_a);
      *v = {RejectReason::kUnknownPose, "loop_closure_t." + past + " is not in the graph"};
    }
    return Outcome::kRejected;
  }
  // Exactly one side known: it may connect (and anchor) a robot with no pose yet, or name a
  // pose of a robot another shard owns (kept here as a shared pose, placed by this closure).
  if (known_a != known_b) {
    const std::string& robot = known_a ? m.robot_b : m.robot_a;
    const std::optional<std::uint8_t> id = known_a ? idb : ida;
    const std::uint64_t index = known_a ? m.pose_b : m.pose_a;
    if (id && g.Anchored(*id) && g.policy().shards.Owns(robot)) {
      if (g.Ahead(core::MakeKey('x', index, *id))) return Outcome::kHeld;  // it may still come
      *v = {RejectReason::kUnknownPose, std::string("loop_closure_t.") +
                                            (known_a ? "pose_b: " : "pose_a: ") +
                                            PoseName(robot, index) + " is not in the graph"};
      return Outcome::kRejected;
    }
  }
  const core::Key known_key =
      known_a ? core::MakeKey('x', m.pose_a, *ida) : core::MakeKey('x', m.pose_b, *idb);
  if (!SamePoseType(g.Estimate(known_key), m.measured) ||
      (known_a && known_b &&
       !SamePoseType(g.Estimate(core::MakeKey('x', m.pose_b, *idb)), m.measured))) {
    *v = {RejectReason::kBadMeasurement, "loop_closure_t.dimension: does not match the poses"};
    return Outcome::kRejected;
  }
  std::optional<std::uint8_t> a = ida, b = idb;
  if (!a) a = g.FindOrAddRobot(m.robot_a);
  if (!b) b = g.FindOrAddRobot(m.robot_b);
  if (!a || !b) {
    *v = {RejectReason::kTooManyElements, "loop_closure_t.robot_b: more than 255 robots"};
    return Outcome::kRejected;
  }
  const core::Key ka = core::MakeKey('x', m.pose_a, *a);
  const core::Key kb = core::MakeKey('x', m.pose_b, *b);
  g.FirstTime({kIdentity, std::min(ka, kb), std::max(ka, kb), 0});
  core::FactorPtr factor = Factor(m, ka, kb, g.policy().loop_closure_kernel);
  const auto add = [&](const std::string& robot, std::uint8_t id, std::uint64_t index,
                       const core::Variable& value) {
    if (g.policy().shards.Owns(robot)) {
      g.AddPose(id, index, value);
    } else {
      g.AddVariable(core::MakeKey('x', index, id), value);
    }
  };
  if (!known_b) add(m.robot_b, *b, m.pose_b, *factor->Predict(0, g.Estimate(ka)));
  if (!known_a) add(m.robot_a, *a, m.pose_a, *factor->Predict(1, g.Estimate(kb)));
  const Outcome outcome = g.AddMeasured(std::move(factor), ka, kType, v);
  if (outcome == Outcome::kApplied) g.Touch(*a);
  return outcome;
}

}  // namespace slamd::server
