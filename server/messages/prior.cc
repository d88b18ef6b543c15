#include "server/messages/prior.h"

#include <memory>

#include "core/factors/position_prior_factor.h"
#include "core/factors/prior_factor.h"
#include "server/ingest/field_checks.h"
#include "server/messages/wire_values.h"
#include "slamd/prior_t.hpp"

namespace slamd::server {
namespace {

using P = ::slamd::prior_t;
static_assert(static_cast<int>(PriorKind::kPose2) == P::KIND_POSE_2D);
static_assert(static_cast<int>(PriorKind::kPose3) == P::KIND_POSE_3D);
static_assert(static_cast<int>(PriorKind::kPosition2) == P::KIND_POSITION_2D);
static_assert(static_cast<int>(PriorKind::kPosition3) == P::KIND_POSITION_3D);

using internal::CheckIndex;
using internal::CheckKindRange;
using internal::CheckMeasurement;
using internal::CheckName;
using internal::CheckUtime;
using internal::kPriorKinds;
using internal::Layout;

}  // namespace

Verdict Validate(const slamd::prior_t& msg, const Limits& limits,
                 std::optional<core::NoiseModel>* noise) {
  using M = slamd::prior_t;
  SLAMD_RETURN_IF_REJECTED(CheckUtime("prior_t.utime", msg.utime));
  SLAMD_RETURN_IF_REJECTED(CheckName("prior_t.robot", msg.robot, limits.max_robot_name_length));
  SLAMD_RETURN_IF_REJECTED(CheckIndex("prior_t.pose_index", msg.pose_index));
  SLAMD_RETURN_IF_REJECTED(
      CheckKindRange("prior_t.kind", msg.kind, M::KIND_POSE_2D, M::KIND_POSITION_3D, kPriorKinds));
  static constexpr Layout kLayouts[] = {
      {3, 3, false, "kind 1 (x, y, theta)"},
      {7, 6, true, "kind 2 (x, y, z, qw, qx, qy, qz)"},
      {2, 2, false, "kind 3 (x, y)"},
      {3, 3, false, "kind 4 (x, y, z)"},
  };
  return CheckMeasurement(msg, SLAMD_MEASUREMENT_FIELDS("prior_t"), kLayouts[msg.kind - 1], limits,
                          noise, []() -> Verdict { return {}; });
}

Checked<PriorMeasurement> Convert(const slamd::prior_t& msg, const Limits& limits) {
  std::optional<core::NoiseModel> noise;
  Verdict verdict = Validate(msg, limits, &noise);
  if (!verdict.ok()) return verdict;
  const auto kind = static_cast<PriorKind>(msg.kind);
  const std::vector<double>& v = msg.values;
  std::variant<core::Pose2, core::Pose3, core::Point2, core::Point3> measured;
  switch (kind) {
    case PriorKind::kPose2:
      measured = std::get<core::Pose2>(ToPose(v));
      break;
    case PriorKind::kPose3:
      measured = std::get<core::Pose3>(ToPose(v));
      break;
    case PriorKind::kPosition2:
      measured = core::Point2(v[0], v[1]);
      break;
    case PriorKind::kPosition3:
      measured = core::Point3(v[0], v[1], v[2]);
      break;
  }
  return PriorMeasurement{.utime = msg.utime,
                          .robot = msg.robot,
                          .pose_index = static_cast<std::uint64_t>(msg.pose_index),
                          .kind = kind,
                          .measured = measured,
                          .noise = std::move(*noise)};
}

void ToLcm(const PriorMeasurement& m, slamd::prior_t* out) {
  out->utime = m.utime;
  out->robot = m.robot;
  out->pose_index = static_cast<std::int64_t>(m.pose_index);
  out->kind = static_cast<std::int8_t>(m.kind);
  SetMeasurement(std::visit([](const auto& v) { return ToValues(v); }, m.measured), m.noise, out);
}

core::FactorPtr PriorSpec::Factor(const Value& m, core::Key pose) {
  return std::visit(
      [&](const auto& z) -> core::FactorPtr {
        using T = std::decay_t<decltype(z)>;
        if constexpr (std::is_same_v<T, core::Point2>) {
          return std::make_shared<core::PositionPriorFactor<core::Pose2>>(pose, z, m.noise);
        } else if constexpr (std::is_same_v<T, core::Point3>) {
          return std::make_shared<core::PositionPriorFactor<core::Pose3>>(pose, z, m.noise);
        } else {
          return std::make_shared<core::PriorFactor<T>>(pose, z, m.noise);
        }
      },
      m.measured);
}

Outcome PriorSpec::Apply(const Value& m, GraphBuilder& g, Verdict* v) {
  const std::optional<std::uint8_t> id = g.FindOrAddRobot(m.robot);
  if (!id) {
    *v = {RejectReason::kTooManyElements, "prior_t.robot: more than 255 robots"};
    return Outcome::kRejected;
  }
  const core::Key key = core::MakeKey('x', m.pose_index, *id);
  const bool is_pose = m.kind == PriorKind::kPose2 || m.kind == PriorKind::kPose3;
  const bool needs3d = m.kind == PriorKind::kPose3 || m.kind == PriorKind::kPosition3;
  const bool known = g.Known(key);
  // A pose prior anchors a robot with no pose yet; anything else waits for its pose.
  if (!known && !(is_pose && !g.Anchored(*id))) return Outcome::kHeld;
  if (known && std::holds_alternative<core::Pose3>(g.Estimate(key)) != needs3d) {
    *v = {RejectReason::kBadMeasurement,
          "prior_t.kind: does not match " + PoseName(m.robot, m.pose_index)};
    return Outcome::kRejected;
  }
  g.FirstTime({kIdentity, key, 0, static_cast<int>(m.kind)});
  if (!known) {
    g.AddPose(*id, m.pose_index,
              std::visit([](const auto& z) -> core::Variable { return z; }, m.measured));
  }
  const Outcome outcome = g.AddMeasured(Factor(m, key), key, kType, v);
  if (outcome == Outcome::kApplied) g.Touch(*id);
  return outcome;
}

}  // namespace slamd::server
