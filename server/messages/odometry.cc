#include "server/messages/odometry.h"

#include <memory>

#include "core/factors/between_factor.h"
#include "core/factors/prior_factor.h"
#include "server/ingest/field_checks.h"
#include "server/messages/wire_values.h"
#include "slamd/odometry_t.hpp"

namespace slamd::server {
namespace {

using internal::CheckDimension;
using internal::CheckIndex;
using internal::CheckMeasurement;
using internal::CheckName;
using internal::CheckUtime;
using internal::Layout;
using internal::Reject;

}  // namespace

Verdict Validate(const slamd::odometry_t& msg, const Limits& limits,
                 std::optional<core::NoiseModel>* noise) {
  SLAMD_RETURN_IF_REJECTED(CheckUtime("odometry_t.utime", msg.utime));
  SLAMD_RETURN_IF_REJECTED(CheckName("odometry_t.robot", msg.robot, limits.max_robot_name_length));
  SLAMD_RETURN_IF_REJECTED(CheckIndex("odometry_t.from_index", msg.from_index));
  SLAMD_RETURN_IF_REJECTED(CheckIndex("odometry_t.to_index", msg.to_index));
  const Layout* layout = nullptr;
  SLAMD_RETURN_IF_REJECTED(CheckDimension("odometry_t.dimension", msg.dimension, &layout));
  return CheckMeasurement(
      msg, SLAMD_MEASUREMENT_FIELDS("odometry_t"), *layout, limits, noise, [&]() -> Verdict {
        if (msg.from_index == msg.to_index) {
          return Reject(RejectReason::kSelfLoop, "odometry_t.to_index",
                        "equals from_index (" + std::to_string(msg.from_index) + ")");
        }
        return {};
      });
}

Checked<OdometryMeasurement> Convert(const slamd::odometry_t& msg, const Limits& limits) {
  std::optional<core::NoiseModel> noise;
  Verdict verdict = Validate(msg, limits, &noise);
  if (!verdict.ok()) return verdict;
  return OdometryMeasurement{.utime = msg.utime,
                             .robot = msg.robot,
                             .from_index = static_cast<std::uint64_t>(msg.from_index),
                             .to_index = static_cast<std::uint64_t>(msg.to_index),
                             .measured = ToPose(msg.values),
                             .noise = std::move(*noise)};
}

void ToLcm(const OdometryMeasurement& m, slamd::odometry_t* out) {
  out->utime = m.utime;
  out->robot = m.robot;
  out->from_index = static_cast<std::int64_t>(m.from_index);
  out->to_index = static_cast<std::int64_t>(m.to_index);
  out->dimension = PoseDimension(m.measured);
  SetMeasurement(PoseValues(m.measured), m.noise, out);
}

core::FactorPtr OdometrySpec::Factor(const Value& m, core::Key from, core::Key to) {
  return std::visit(
      [&](const auto& z) -> core::FactorPtr {
        using T = std::decay_t<decltype(z)>;
        return std::make_shared<core::BetweenFactor<T>>(from, to, z, m.noise);
      },
      m.measured);
}

Outcome OdometrySpec::Apply(const Value& m, GraphBuilder& g, Verdict* v) {
  const std::optional<std::uint8_t> id = g.FindOrAddRobot(m.robot);
  if (!id) {
    *v = {RejectReason::kTooManyElements, "odometry_t.robot: more than 255 robots"};
    return Outcome::kRejected;
  }
  const core::Key from = core::MakeKey('x', m.from_index, *id);
  const core::Key to = core::MakeKey('x', m.to_index, *id);
  // A robot connected in the middle of its trajectory (a loop closure placed pose k) gets its
  // earlier poses from the odometry into k, backwards.
  const bool backwards = !g.Known(from) && g.Known(to);
  const bool origin =
      !g.Known(from) && !backwards && !g.Anchored(*id) && g.policy().anchor_at_origin;
  if (!g.Known(from) && !origin && !backwards) return Outcome::kHeld;  // ahead, or unanchored
  if (!origin && !backwards && !SamePoseType(g.Estimate(from), m.measured)) {
    *v = {RejectReason::kBadMeasurement,
          "odometry_t.dimension: does not match " + PoseName(m.robot, m.from_index)};
    return Outcome::kRejected;
  }
  if (g.Known(to) && !SamePoseType(g.Estimate(to), m.measured)) {
    *v = {RejectReason::kBadMeasurement,
          "odometry_t.dimension: does not match " + PoseName(m.robot, m.to_index)};
    return Outcome::kRejected;
  }
  g.FirstTime({kIdentity, from, to, 0});
  core::FactorPtr factor = Factor(m, from, to);
  if (origin) {
    const bool is2d = std::holds_alternative<core::Pose2>(m.measured);
    const core::NoiseModel anchor =
        core::NoiseModel::Isotropic(is2d ? 3 : 6, g.policy().anchor_sigma).value();
    g.AddPose(*id, m.from_index,
              is2d ? core::Variable(core::Pose2()) : core::Variable(core::Pose3()));
    if (is2d) {
      g.AddFactor(std::make_shared<core::PriorFactor<core::Pose2>>(from, core::Pose2(), anchor));
    } else {
      g.AddFactor(std::make_shared<core::PriorFactor<core::Pose3>>(from, core::Pose3(), anchor));
    }
  }
  if (backwards) {
    g.AddPose(*id, m.from_index, *factor->Predict(1, g.Estimate(to)));
  } else if (!g.Known(to)) {
    g.AddPose(*id, m.to_index, *factor->Predict(0, g.Estimate(from)));
  }
  const Outcome outcome = g.AddMeasured(std::move(factor), from, kType, v);
  if (outcome == Outcome::kApplied) g.Touch(*id);
  return outcome;
}

}  // namespace slamd::server
