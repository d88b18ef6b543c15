#include "server/snapshot/state_codec.h"

#include <Eigen/Core>
#include <cmath>

#include "core/factors/bearing_range_factor.h"
#include "core/factors/between_factor.h"
#include "core/factors/position_prior_factor.h"
#include "core/factors/prior_factor.h"
#include "core/factors/relative_point_factor.h"
#include "server/estimator/inbound_codec.h"
#include "slamd_proto/snapshot.pb.h"

namespace slamd::server {
namespace {

namespace pb = slamd::snapshot;
using core::Point2;
using core::Point3;
using core::Pose2;
using core::Pose3;

template <typename Field>
void Append(const Pose2& p, Field* out) {
  for (double v : {p.x(), p.y(), p.rotation().c(), p.rotation().s()}) out->Add(v);
}
template <typename Field>
void Append(const Pose3& p, Field* out) {
  for (int i = 0; i < 3; ++i) out->Add(p.translation()[i]);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out->Add(p.rotation().matrix()(r, c));
  }
}
template <typename Field>
void Append(const Point2& p, Field* out) {
  out->Add(p.x());
  out->Add(p.y());
}
template <typename Field>
void Append(const Point3& p, Field* out) {
  for (int i = 0; i < 3; ++i) out->Add(p[i]);
}

constexpr int kValueCount[] = {4, 12, 2, 3};  // Pose2, Pose3, Point2, Point3
constexpr double kMaxSqrtInformation = 1e8;
constexpr double kMaxAbsValue = 1e7;

// Reads a value of `type` from v[0..kValueCount); the caller checked the count.
core::Variable ReadValue(core::VariableType type, const double* v) {
  switch (type) {
    case core::VariableType::kPose2:
      return Pose2(core::Rot2::FromCosSin(v[2], v[3]), Point2(v[0], v[1]));
    case core::VariableType::kPose3: {
      core::Matrix3 R;
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) R(r, c) = v[3 + 3 * r + c];
      }
      return Pose3(core::Rot3(R), Point3(v[0], v[1], v[2]));
    }
    case core::VariableType::kPoint2:
      return Point2(v[0], v[1]);
    case core::VariableType::kPoint3:
      return Point3(v[0], v[1], v[2]);
  }
  return Point2();
}

void WriteVariable(const core::Variable& value, pb::Variable* out) {
  out->set_type(static_cast<pb::Variable::Type>(value.index()));
  std::visit([&](const auto& v) { Append(v, out->mutable_values()); }, value);
}

// Values within what validated messages can produce (server/ingest Limits::max_abs_value).
bool Plausible(const double* v, int n) {
  for (int i = 0; i < n; ++i) {
    if (!(std::abs(v[i]) <= kMaxAbsValue)) return false;
  }
  return true;
}

core::Result<core::Variable> ReadVariable(const pb::Variable& in, const std::string& what) {
  const int type = static_cast<int>(in.type());
  if (type < 0 || type > 3 || in.values_size() != kValueCount[type]) {
    return core::DataLoss("snapshot: " + what + ": variable of type " + std::to_string(type) +
                          " with " + std::to_string(in.values_size()) + " values");
  }
  if (!Plausible(in.values().data(), in.values_size())) {
    return core::DataLoss("snapshot: " + what + ": a value is not finite or beyond 1e7");
  }
  return ReadValue(static_cast<core::VariableType>(type), in.values().data());
}

void WriteValues(const core::Values& values,
                 google::protobuf::RepeatedPtrField<pb::KeyedVariable>* out) {
  out->Reserve(static_cast<int>(values.size()));
  for (size_t i = 0; i < values.size(); ++i) {
    pb::KeyedVariable* kv = out->Add();
    kv->set_key(values.KeyAt(static_cast<int>(i)));
    WriteVariable(values.VariableAt(static_cast<int>(i)), kv->mutable_value());
  }
}

core::Status ReadValues(const google::protobuf::RepeatedPtrField<pb::KeyedVariable>& in,
                        const char* what, core::Values* out) {
  for (const pb::KeyedVariable& kv : in) {
    core::Result<core::Variable> v = ReadVariable(kv.value(), what);
    if (!v.ok()) return v.status();
    const core::Status s = out->Insert(kv.key(), v.value());
    if (!s.ok()) return core::DataLoss(std::string("snapshot: ") + what + ": " + s.message());
  }
  return core::Status::Ok();
}

// The factor types a snapshot can hold: every factor the estimator creates.
void WriteFactor(const core::Factor& f, pb::Factor* out) {
  auto* m = out->mutable_measured();
  if (const auto* b2 = dynamic_cast<const core::BetweenFactor<Pose2>*>(&f)) {
    out->set_type(pb::Factor::BETWEEN_POSE2);
    Append(b2->measured(), m);
  } else if (const auto* b3 = dynamic_cast<const core::BetweenFactor<Pose3>*>(&f)) {
    out->set_type(pb::Factor::BETWEEN_POSE3);
    Append(b3->measured(), m);
  } else if (const auto* p2 = dynamic_cast<const core::PriorFactor<Pose2>*>(&f)) {
    out->set_type(pb::Factor::PRIOR_POSE2);
    Append(p2->measured(), m);
  } else if (const auto* p3 = dynamic_cast<const core::PriorFactor<Pose3>*>(&f)) {
    out->set_type(pb::Factor::PRIOR_POSE3);
    Append(p3->measured(), m);
  } else if (const auto* q2 = dynamic_cast<const core::PositionPriorFactor<Pose2>*>(&f)) {
    out->set_type(pb::Factor::POSITION_PRIOR_POSE2);
    Append(q2->measured(), m);
  } else if (const auto* q3 = dynamic_cast<const core::PositionPriorFactor<Pose3>*>(&f)) {
    out->set_type(pb::Factor::POSITION_PRIOR_POSE3);
    Append(q3->measured(), m);
  } else if (const auto* br = dynamic_cast<const core::BearingRangeFactor*>(&f)) {
    out->set_type(pb::Factor::BEARING_RANGE);
    m->Add(br->bearing());
    m->Add(br->range());
  } else if (const auto* r2 = dynamic_cast<const core::RelativePointFactor<Pose2, Point2>*>(&f)) {
    out->set_type(pb::Factor::RELATIVE_POINT_POSE2);
    Append(r2->measured(), m);
  } else if (const auto* r3 = dynamic_cast<const core::RelativePointFactor<Pose3, Point3>*>(&f)) {
    out->set_type(pb::Factor::RELATIVE_POINT_POSE3);
    Append(r3->measured(), m);
  } else {
    SLAMD_CHECK(false) << "snapshot: no encoding for factor " << f.Name();
  }
  for (core::Key k : f.keys()) out->add_keys(k);
  const auto& R = f.noise_model().sqrt_information();
  for (int r = 0; r < R.rows(); ++r) {
    for (int c = 0; c < R.cols(); ++c) out->add_sqrt_information(R(r, c));
  }
  out->set_robust_kind(static_cast<int>(f.robust_kernel().kind()));
  out->set_robust_parameter(f.robust_kernel().parameter());
}

core::Result<core::FactorPtr> ReadFactor(const pb::Factor& in, int index) {
  const std::string what = "factor " + std::to_string(index);
  struct Shape {
    int keys, values, dim;
  };
  static constexpr Shape kShapes[] = {{0, 0, 0}, {2, 4, 3}, {2, 12, 6}, {1, 4, 3}, {1, 12, 6},
                                      {1, 2, 2}, {1, 3, 3}, {2, 2, 2},  {2, 2, 2}, {2, 3, 3}};
  const int type = static_cast<int>(in.type());
  if (type <= 0 || type >= static_cast<int>(std::size(kShapes))) {
    return core::DataLoss("snapshot: " + what + ": unknown type " + std::to_string(type));
  }
  const Shape shape = kShapes[type];
  if (in.keys_size() != shape.keys || in.measured_size() != shape.values ||
      in.sqrt_information_size() != shape.dim * shape.dim) {
    return core::DataLoss("snapshot: " + what + ": wrong number of keys, values or R entries");
  }
  if (!Plausible(in.measured().data(), in.measured_size())) {
    return core::DataLoss("snapshot: " + what + ": a measured value is not finite or beyond 1e7");
  }
  Eigen::MatrixXd R(shape.dim, shape.dim);
  for (int r = 0; r < shape.dim; ++r) {
    for (int c = 0; c < shape.dim; ++c) R(r, c) = in.sqrt_information(r * shape.dim + c);
  }
  // A square-root information entry beyond 1e8 (a standard deviation below 1e-8 m or rad) is
  // not something slamd writes from validated messages; a file that holds one is damaged, and
  // eliminating it would lose all precision.
  if (!(R.cwiseAbs().maxCoeff() <= kMaxSqrtInformation)) {
    return core::DataLoss("snapshot: " + what + ": square-root information entry beyond 1e8");
  }
  core::Result<core::NoiseModel> noise = core::NoiseModel::FromSqrtInformation(R);
  if (!noise.ok()) return core::DataLoss("snapshot: " + what + ": " + noise.status().message());
  core::RobustKernel robust;
  if (in.robust_kind() != 0) {
    core::Result<core::RobustKernel> k = core::RobustKernel::Create(
        static_cast<core::RobustKernel::Kind>(in.robust_kind()), in.robust_parameter());
    if (!k.ok()) return core::DataLoss("snapshot: " + what + ": " + k.status().message());
    robust = k.value();
  }
  const double* v = in.measured().data();
  const core::Key a = in.keys(0), b = shape.keys > 1 ? in.keys(1) : 0;
  const core::NoiseModel& n = noise.value();
  using VT = core::VariableType;
  switch (in.type()) {
    case pb::Factor::BETWEEN_POSE2:
      return core::FactorPtr(std::make_shared<core::BetweenFactor<Pose2>>(
          a, b, std::get<Pose2>(ReadValue(VT::kPose2, v)), n, robust));
    case pb::Factor::BETWEEN_POSE3:
      return core::FactorPtr(std::make_shared<core::BetweenFactor<Pose3>>(
          a, b, std::get<Pose3>(ReadValue(VT::kPose3, v)), n, robust));
    case pb::Factor::PRIOR_POSE2:
      return core::FactorPtr(std::make_shared<core::PriorFactor<Pose2>>(
          a, std::get<Pose2>(ReadValue(VT::kPose2, v)), n, robust));
    case pb::Factor::PRIOR_POSE3:
      return core::FactorPtr(std::make_shared<core::PriorFactor<Pose3>>(
          a, std::get<Pose3>(ReadValue(VT::kPose3, v)), n, robust));
    case pb::Factor::POSITION_PRIOR_POSE2:
      return core::FactorPtr(
          std::make_shared<core::PositionPriorFactor<Pose2>>(a, Point2(v[0], v[1]), n, robust));
    case pb::Factor::POSITION_PRIOR_POSE3:
      return core::FactorPtr(std::make_shared<core::PositionPriorFactor<Pose3>>(
          a, Point3(v[0], v[1], v[2]), n, robust));
    case pb::Factor::BEARING_RANGE:
      return core::FactorPtr(
          std::make_shared<core::BearingRangeFactor>(a, b, v[0], v[1], n, robust));
    case pb::Factor::RELATIVE_POINT_POSE2:
      return core::FactorPtr(std::make_shared<core::RelativePointFactor<Pose2, Point2>>(
          a, b, Point2(v[0], v[1]), n, robust));
    case pb::Factor::RELATIVE_POINT_POSE3:
      return core::FactorPtr(std::make_shared<core::RelativePointFactor<Pose3, Point3>>(
          a, b, Point3(v[0], v[1], v[2]), n, robust));
    default:
      break;
  }
  return core::DataLoss("snapshot: " + what + ": unknown type");
}

}  // namespace

std::string EncodeState(const EstimatorState& state, const JournalPosition& position) {
  pb::EstimatorState out;
  out.set_last_message_sequence(position.last_message_sequence);
  out.set_journal_offset(position.journal_offset);
  out.set_update_sequence(state.update_sequence);
  out.mutable_factors()->Reserve(static_cast<int>(state.factors.size()));
  for (const core::FactorPtr& f : state.factors) WriteFactor(*f, out.add_factors());
  WriteValues(state.linearization_point, out.mutable_linearization_point());
  for (const EstimatorState::Applied& a : state.applied) {
    pb::AppliedMeasurement* m = out.add_applied();
    m->set_type(a.type);
    m->set_key_a(a.a);
    m->set_key_b(a.b);
    m->set_kind(a.kind);
    m->set_factor(a.factor);
    m->set_first_key(a.first);
    m->set_dim(a.dim);
  }
  for (const EstimatorState::Robot& r : state.robots) {
    pb::RobotState* m = out.add_robots();
    m->set_name(r.name);
    m->set_id(r.id);
    m->set_anchored(r.anchored);
    m->set_newest(r.newest);
    m->set_measurement_utime(r.measurement_utime);
    WriteVariable(r.published, m->mutable_published());
    m->set_published_index(r.published_index);
    m->set_moved_sequence(r.moved_sequence);
  }
  for (const EstimatorState::HeldMessage& h : state.held) {
    pb::HeldMessage* m = out.add_held();
    std::string type;
    const std::vector<std::uint8_t> bytes = EncodeInbound(h.message, &type);
    m->set_message_type(type);
    m->set_lcm_payload(bytes.data(), bytes.size());
    m->set_waited(h.waited);
  }
  pb::Counters* c = out.mutable_counters();
  c->set_processed(state.counters.processed);
  c->set_applied(state.counters.applied);
  c->set_held(state.counters.held);
  c->set_rejected(state.counters.rejected);
  c->set_updates(state.counters.updates);
  c->set_refinements(state.counters.refinements);
  c->set_rebuilds(state.counters.rebuilds);
  for (std::int64_t n : state.counters.rejects_by_reason) c->add_rejects_by_reason(n);
  out.set_num_factors(state.num_factors);
  out.set_residual_dimension(state.residual_dimension);
  return out.SerializeAsString();
}

core::Result<EstimatorState> DecodeState(std::string_view bytes, JournalPosition* position) {
  pb::EstimatorState in;
  if (!in.ParseFromArray(bytes.data(), static_cast<int>(bytes.size()))) {
    return core::DataLoss("snapshot: the state does not parse (" + std::to_string(bytes.size()) +
                          " bytes)");
  }
  EstimatorState state;
  position->last_message_sequence = in.last_message_sequence();
  position->journal_offset = in.journal_offset();
  state.update_sequence = in.update_sequence();
  state.factors.reserve(static_cast<size_t>(in.factors_size()));
  for (int i = 0; i < in.factors_size(); ++i) {
    core::Result<core::FactorPtr> f = ReadFactor(in.factors(i), i);
    if (!f.ok()) return f.status();
    state.factors.push_back(std::move(f).value());
  }
  SLAMD_RETURN_IF_ERROR(
      ReadValues(in.linearization_point(), "linearization point", &state.linearization_point));
  for (const pb::AppliedMeasurement& m : in.applied()) {
    state.applied.push_back({static_cast<char>(m.type()), m.key_a(), m.key_b(), m.kind(),
                             m.factor(), m.first_key(), m.dim()});
  }
  for (const pb::RobotState& m : in.robots()) {
    if (m.id() == 0 || m.id() > 255) {
      return core::DataLoss("snapshot: robot '" + m.name() + "' has id " + std::to_string(m.id()));
    }
    core::Result<core::Variable> published =
        ReadVariable(m.published(), "robot '" + m.name() + "'");
    if (!published.ok()) return published.status();
    state.robots.push_back({m.name(), static_cast<std::uint8_t>(m.id()), m.anchored(), m.newest(),
                            m.measurement_utime(), published.value(), m.published_index(),
                            m.moved_sequence()});
  }
  for (const pb::HeldMessage& m : in.held()) {
    const auto* data = reinterpret_cast<const std::uint8_t*>(m.lcm_payload().data());
    core::Result<Inbound> msg = DecodeInbound(m.message_type(), {data, m.lcm_payload().size()});
    if (!msg.ok()) return core::DataLoss("snapshot: held message: " + msg.status().message());
    state.held.push_back({std::move(msg).value(), m.waited()});
  }
  const pb::Counters& c = in.counters();
  state.counters.processed = c.processed();
  state.counters.applied = c.applied();
  state.counters.held = c.held();
  state.counters.rejected = c.rejected();
  state.counters.updates = c.updates();
  state.counters.refinements = c.refinements();
  state.counters.rebuilds = c.rebuilds();
  for (int i = 0; i < c.rejects_by_reason_size() &&
                  i < static_cast<int>(state.counters.rejects_by_reason.size());
       ++i) {
    state.counters.rejects_by_reason[i] = c.rejects_by_reason(i);
  }
  state.num_factors = in.num_factors();
  state.residual_dimension = in.residual_dimension();
  return state;
}

}  // namespace slamd::server
