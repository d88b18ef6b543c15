#include "server/messages/landmark_observation.h"

#include <memory>

#include "core/factors/bearing_range_factor.h"
#include "core/factors/relative_point_factor.h"
#include "server/ingest/field_checks.h"
#include "server/messages/wire_values.h"
#include "slamd/landmark_observation_t.hpp"

namespace slamd::server {
namespace {

using L = ::slamd::landmark_observation_t;
static_assert(static_cast<int>(LandmarkKind::kBearingRange2) == L::KIND_BEARING_RANGE_2D);
static_assert(static_cast<int>(LandmarkKind::kRelativePoint2) == L::KIND_RELATIVE_POINT_2D);
static_assert(static_cast<int>(LandmarkKind::kRelativePoint3) == L::KIND_RELATIVE_POINT_3D);
static_assert(static_cast<int>(LandmarkNamespace::kRobot) == L::NAMESPACE_ROBOT);
static_assert(static_cast<int>(LandmarkNamespace::kMap) == L::NAMESPACE_MAP);

using internal::CheckIndex;
using internal::CheckKindRange;
using internal::CheckMeasurement;
using internal::CheckName;
using internal::CheckUtime;
using internal::FormatNumber;
using internal::kLandmarkKinds;
using internal::Layout;
using internal::Reject;

}  // namespace

Verdict Validate(const slamd::landmark_observation_t& msg, const Limits& limits,
                 std::optional<core::NoiseModel>* noise) {
  using M = slamd::landmark_observation_t;
  SLAMD_RETURN_IF_REJECTED(CheckUtime("landmark_observation_t.utime", msg.utime));
  SLAMD_RETURN_IF_REJECTED(
      CheckName("landmark_observation_t.robot", msg.robot, limits.max_robot_name_length));
  SLAMD_RETURN_IF_REJECTED(CheckIndex("landmark_observation_t.pose_index", msg.pose_index));
  SLAMD_RETURN_IF_REJECTED(CheckIndex("landmark_observation_t.landmark_id", msg.landmark_id));
  SLAMD_RETURN_IF_REJECTED(CheckKindRange("landmark_observation_t.kind", msg.kind,
                                          M::KIND_BEARING_RANGE_2D, M::KIND_RELATIVE_POINT_3D,
                                          kLandmarkKinds));
  SLAMD_RETURN_IF_REJECTED(CheckKindRange("landmark_observation_t.landmark_namespace",
                                          msg.landmark_namespace, M::NAMESPACE_ROBOT,
                                          M::NAMESPACE_MAP, "0 (robot), 1 (map)"));
  static constexpr Layout kLayouts[] = {
      {2, 2, false, "kind 1 (bearing, range)"},
      {2, 2, false, "kind 2 (x, y)"},
      {3, 3, false, "kind 3 (x, y, z)"},
  };
  return CheckMeasurement(msg, SLAMD_MEASUREMENT_FIELDS("landmark_observation_t"),
                          kLayouts[msg.kind - 1], limits, noise, [&]() -> Verdict {
                            if (msg.kind == M::KIND_BEARING_RANGE_2D && msg.values[1] < 0.0) {
                              return Reject(
                                  RejectReason::kBadMeasurement, "landmark_observation_t.values[1]",
                                  "range " + FormatNumber(msg.values[1]) + " m is negative");
                            }
                            return {};
                          });
}

Checked<LandmarkMeasurement> Convert(const slamd::landmark_observation_t& msg,
                                     const Limits& limits) {
  std::optional<core::NoiseModel> noise;
  Verdict verdict = Validate(msg, limits, &noise);
  if (!verdict.ok()) return verdict;
  const auto kind = static_cast<LandmarkKind>(msg.kind);
  const std::vector<double>& v = msg.values;
  std::variant<BearingRange, core::Point2, core::Point3> measured;
  switch (kind) {
    case LandmarkKind::kBearingRange2:
      measured = BearingRange{.bearing = v[0], .range = v[1]};
      break;
    case LandmarkKind::kRelativePoint2:
      measured = core::Point2(v[0], v[1]);
      break;
    case LandmarkKind::kRelativePoint3:
      measured = core::Point3(v[0], v[1], v[2]);
      break;
  }
  return LandmarkMeasurement{
      .utime = msg.utime,
      .robot = msg.robot,
      .pose_index = static_cast<std::uint64_t>(msg.pose_index),
      .landmark_id = static_cast<std::uint64_t>(msg.landmark_id),
      .kind = kind,
      .measured = measured,
      .noise = std::move(*noise),
      .landmark_namespace = static_cast<LandmarkNamespace>(msg.landmark_namespace)};
}

void ToLcm(const LandmarkMeasurement& m, slamd::landmark_observation_t* out) {
  out->utime = m.utime;
  out->robot = m.robot;
  out->pose_index = static_cast<std::int64_t>(m.pose_index);
  out->landmark_id = static_cast<std::int64_t>(m.landmark_id);
  out->kind = static_cast<std::int8_t>(m.kind);
  out->landmark_namespace = static_cast<std::int8_t>(m.landmark_namespace);
  std::vector<double> values = std::visit(
      [](const auto& v) -> std::vector<double> {
        if constexpr (std::is_same_v<std::decay_t<decltype(v)>, BearingRange>) {
          return {v.bearing, v.range};
        } else {
          return ToValues(v);
        }
      },
      m.measured);
  SetMeasurement(std::move(values), m.noise, out);
}

core::FactorPtr LandmarkObservationSpec::Factor(const Value& m, core::Key pose,
                                                core::Key landmark) {
  if (const BearingRange* br = std::get_if<BearingRange>(&m.measured)) {
    return std::make_shared<core::BearingRangeFactor>(pose, landmark, br->bearing, br->range,
                                                      m.noise);
  }
  if (const core::Point2* p2 = std::get_if<core::Point2>(&m.measured)) {
    return std::make_shared<core::RelativePointFactor<core::Pose2, core::Point2>>(pose, landmark,
                                                                                  *p2, m.noise);
  }
  return std::make_shared<core::RelativePointFactor<core::Pose3, core::Point3>>(
      pose, landmark, std::get<core::Point3>(m.measured), m.noise);
}

Outcome LandmarkObservationSpec::Apply(const Value& m, GraphBuilder& g, Verdict* v) {
  const std::optional<std::uint8_t> id = g.FindOrAddRobot(m.robot);
  if (!id) {
    *v = {RejectReason::kTooManyElements, "landmark_observation_t.robot: more than 255 robots"};
    return Outcome::kRejected;
  }
  const core::Key pose = core::MakeKey('x', m.pose_index, *id);
  if (!g.Known(pose)) return Outcome::kHeld;
  const core::Key landmark = LandmarkKey(m.landmark_namespace, m.landmark_id, *id);
  const core::Variable x = g.Estimate(pose);
  const bool needs3d = m.kind == LandmarkKind::kRelativePoint3;
  if (std::holds_alternative<core::Pose3>(x) != needs3d) {
    *v = {RejectReason::kBadMeasurement,
          "landmark_observation_t.kind: does not match " + PoseName(m.robot, m.pose_index)};
    return Outcome::kRejected;
  }
  const bool known = g.Known(landmark);
  if (known && (std::holds_alternative<core::Point3>(g.Estimate(landmark)) != needs3d)) {
    *v = {RejectReason::kBadMeasurement,
          "landmark_observation_t.kind: " +
              LandmarkName(m.landmark_namespace, m.robot, m.landmark_id) +
              " has the other dimension"};
    return Outcome::kRejected;
  }
  g.FirstTime({kIdentity, pose, landmark, static_cast<int>(m.kind)});
  core::FactorPtr factor = Factor(m, pose, landmark);
  // A new landmark where this first observation puts it.
  const std::optional<core::Variable> guess = known ? std::nullopt : factor->Predict(0, x);
  const Outcome outcome = g.AddMeasured(std::move(factor), pose, kType, v);
  if (outcome != Outcome::kApplied) return outcome;
  if (!known) g.AddVariable(landmark, *guess);
  g.Touch(*id);
  return outcome;
}

}  // namespace slamd::server
