#include "server/ingest/conversion.h"

#include <type_traits>
#include <variant>

#include "server/publish/wire_values.h"
#include "slamd/key_t.hpp"
#include "slamd/landmark_observation_t.hpp"
#include "slamd/loop_closure_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "slamd/query_t.hpp"
#include "slamd/remove_factor_t.hpp"

namespace slamd::server {
namespace {

using L = ::slamd::landmark_observation_t;
using P = ::slamd::prior_t;
using R = ::slamd::remove_factor_t;
using K = ::slamd::key_t;
static_assert(static_cast<int>(LandmarkKind::kBearingRange2) == L::KIND_BEARING_RANGE_2D);
static_assert(static_cast<int>(LandmarkKind::kRelativePoint2) == L::KIND_RELATIVE_POINT_2D);
static_assert(static_cast<int>(LandmarkKind::kRelativePoint3) == L::KIND_RELATIVE_POINT_3D);
static_assert(static_cast<int>(PriorKind::kPose2) == P::KIND_POSE_2D);
static_assert(static_cast<int>(PriorKind::kPose3) == P::KIND_POSE_3D);
static_assert(static_cast<int>(PriorKind::kPosition2) == P::KIND_POSITION_2D);
static_assert(static_cast<int>(PriorKind::kPosition3) == P::KIND_POSITION_3D);
static_assert(static_cast<int>(RemoveTarget::kOdometry) == R::TARGET_ODOMETRY);
static_assert(static_cast<int>(RemoveTarget::kLandmarkObservation) ==
              R::TARGET_LANDMARK_OBSERVATION);
static_assert(static_cast<int>(RemoveTarget::kLoopClosure) == R::TARGET_LOOP_CLOSURE);
static_assert(static_cast<int>(RemoveTarget::kPrior) == R::TARGET_PRIOR);
static_assert(static_cast<int>(KeyKind::kPose) == K::KIND_POSE);
static_assert(static_cast<int>(KeyKind::kLandmark) == K::KIND_LANDMARK);

// values has 3 (2D) or 7 (3D) entries: checked by validation.
RelativePose ToPose(const std::vector<double>& v) {
  if (v.size() == 3) return core::Pose2(v[0], v[1], v[2]);
  return core::Pose3(core::Rot3::FromQuaternion(v[3], v[4], v[5], v[6]),
                     core::Point3(v[0], v[1], v[2]));
}

}  // namespace

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
  return LandmarkMeasurement{.utime = msg.utime,
                             .robot = msg.robot,
                             .pose_index = static_cast<std::uint64_t>(msg.pose_index),
                             .landmark_id = static_cast<std::uint64_t>(msg.landmark_id),
                             .kind = kind,
                             .measured = measured,
                             .noise = std::move(*noise)};
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

Checked<QueryRequest> Convert(const slamd::query_t& msg, const Limits& limits) {
  Verdict verdict = Validate(msg, limits);
  if (!verdict.ok()) return verdict;
  QueryRequest query{.utime = msg.utime,
                     .client = msg.client,
                     .request_id = msg.request_id,
                     .keys = {},
                     .want_marginals = msg.want_marginals != 0,
                     .want_joint_marginal = msg.want_joint_marginal != 0,
                     .map_robot = msg.map_robot};
  query.keys.reserve(msg.keys.size());
  for (const slamd::key_t& key : msg.keys) {
    query.keys.push_back(WireKey{.robot = key.robot,
                                 .kind = static_cast<KeyKind>(key.kind),
                                 .index = static_cast<std::uint64_t>(key.index)});
  }
  return query;
}

namespace {

// Fills a message's values/covariance pairs (counts from the vectors, so they always agree).
template <typename Msg>
void SetMeasurement(std::vector<double> values, const core::NoiseModel& noise, Msg* out) {
  out->values = std::move(values);
  out->num_values = static_cast<std::int32_t>(out->values.size());
  out->covariance = ToRowMajor(noise.Covariance());
  out->num_covariance = static_cast<std::int32_t>(out->covariance.size());
}

std::vector<double> PoseValues(const RelativePose& pose) {
  return std::visit([](const auto& p) { return ToValues(p); }, pose);
}

std::int8_t PoseDimension(const RelativePose& pose) {
  return std::holds_alternative<core::Pose2>(pose) ? 2 : 3;
}

}  // namespace

void ToLcm(const OdometryMeasurement& m, slamd::odometry_t* out) {
  out->utime = m.utime;
  out->robot = m.robot;
  out->from_index = static_cast<std::int64_t>(m.from_index);
  out->to_index = static_cast<std::int64_t>(m.to_index);
  out->dimension = PoseDimension(m.measured);
  SetMeasurement(PoseValues(m.measured), m.noise, out);
}

void ToLcm(const LandmarkMeasurement& m, slamd::landmark_observation_t* out) {
  out->utime = m.utime;
  out->robot = m.robot;
  out->pose_index = static_cast<std::int64_t>(m.pose_index);
  out->landmark_id = static_cast<std::int64_t>(m.landmark_id);
  out->kind = static_cast<std::int8_t>(m.kind);
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

void ToLcm(const PriorMeasurement& m, slamd::prior_t* out) {
  out->utime = m.utime;
  out->robot = m.robot;
  out->pose_index = static_cast<std::int64_t>(m.pose_index);
  out->kind = static_cast<std::int8_t>(m.kind);
  SetMeasurement(std::visit([](const auto& v) { return ToValues(v); }, m.measured), m.noise, out);
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

void ToLcm(const QueryRequest& m, slamd::query_t* out) {
  out->utime = m.utime;
  out->client = m.client;
  out->request_id = m.request_id;
  out->keys.clear();
  for (const WireKey& key : m.keys) {
    slamd::key_t k;
    k.robot = key.robot;
    k.kind = static_cast<std::int8_t>(key.kind);
    k.index = static_cast<std::int64_t>(key.index);
    out->keys.push_back(std::move(k));
  }
  out->num_keys = static_cast<std::int32_t>(out->keys.size());
  out->want_marginals = m.want_marginals;
  out->want_joint_marginal = m.want_joint_marginal;
  out->map_robot = m.map_robot;
}

}  // namespace slamd::server
