#include "server/snapshot/state_codec.h"

#include <Eigen/Core>
#include <cmath>

#include "core/factors/factor_registry.h"
#include "server/messages/inbound_codec.h"
#include "slamd_proto/snapshot.pb.h"

namespace slamd::server {
namespace {

namespace pb = slamd::snapshot;
using core::Point2;
using core::Point3;
using core::Pose2;
using core::Pose3;

constexpr double kMaxSqrtInformation = 1e8;
constexpr double kMaxAbsValue = 1e7;

// The type names of snapshots written before they stored names (the proto enums' order).
constexpr const char* kLegacyVariableTypes[] = {"Pose2", "Pose3", "Point2", "Point3"};
constexpr const char* kLegacyFactorTypes[] = {"",
                                              "BetweenPose2",
                                              "BetweenPose3",
                                              "PriorPose2",
                                              "PriorPose3",
                                              "PositionPrior2",
                                              "PositionPrior3",
                                              "BearingRange2",
                                              "RelativePoint2",
                                              "RelativePoint3"};

void WriteVariable(const core::Variable& value, pb::Variable* out) {
  out->set_type_name(core::VariableTypeName(core::TypeOf(value)));
  std::vector<double> numbers;
  core::EncodeVariable(value, &numbers);
  out->mutable_values()->Add(numbers.begin(), numbers.end());
}

// Values within what validated messages can produce (server/ingest Limits::max_abs_value).
bool Plausible(const double* v, int n) {
  for (int i = 0; i < n; ++i) {
    if (!(std::abs(v[i]) <= kMaxAbsValue)) return false;
  }
  return true;
}

core::Result<core::Variable> ReadVariable(const pb::Variable& in, const std::string& what) {
  std::string name = in.type_name();
  if (name.empty()) {
    const int legacy = static_cast<int>(in.type());
    if (legacy < 0 || legacy >= static_cast<int>(std::size(kLegacyVariableTypes))) {
      return core::DataLoss("snapshot: " + what + ": unknown variable type " +
                            std::to_string(legacy));
    }
    name = kLegacyVariableTypes[legacy];
  }
  const std::optional<core::VariableType> type = core::VariableTypeFromName(name);
  if (!type) return core::DataLoss("snapshot: " + what + ": unknown variable type '" + name + "'");
  if (!Plausible(in.values().data(), in.values_size())) {
    return core::DataLoss("snapshot: " + what + ": a value is not finite or beyond 1e7");
  }
  core::Result<core::Variable> v =
      core::DecodeVariable(*type, {in.values().data(), static_cast<std::size_t>(in.values_size())});
  if (!v.ok()) return core::DataLoss("snapshot: " + what + ": " + v.status().message());
  return v;
}

// Any registered factor type, as its core::FactorRecord.
void WriteFactor(const core::Factor& f, pb::Factor* out) {
  const core::FactorRecord r = core::EncodeFactor(f);
  out->set_type_name(r.type);
  for (core::Key k : r.keys) out->add_keys(k);
  out->mutable_measured()->Add(r.measured.begin(), r.measured.end());
  for (int row = 0; row < r.sqrt_information.rows(); ++row) {
    for (int col = 0; col < r.sqrt_information.cols(); ++col) {
      out->add_sqrt_information(r.sqrt_information(row, col));
    }
  }
  out->set_robust_kind(static_cast<int>(r.robust.kind()));
  out->set_robust_parameter(r.robust.parameter());
  for (const core::Variable& v : r.values) WriteVariable(v, out->add_values());
}

core::Result<core::FactorPtr> ReadFactor(const pb::Factor& in, int index) {
  const std::string what = "factor " + std::to_string(index);
  core::FactorRecord r;
  r.type = in.type_name();
  if (r.type.empty()) {
    const int legacy = static_cast<int>(in.type());
    if (legacy <= 0 || legacy >= static_cast<int>(std::size(kLegacyFactorTypes))) {
      return core::DataLoss("snapshot: " + what + ": unknown type " + std::to_string(legacy));
    }
    r.type = kLegacyFactorTypes[legacy];
  }
  r.keys.assign(in.keys().begin(), in.keys().end());
  if (!Plausible(in.measured().data(), in.measured_size())) {
    return core::DataLoss("snapshot: " + what + ": a measured value is not finite or beyond 1e7");
  }
  r.measured.assign(in.measured().begin(), in.measured().end());
  const int dim = static_cast<int>(std::lround(std::sqrt(in.sqrt_information_size())));
  if (dim < 1 || dim * dim != in.sqrt_information_size()) {
    return core::DataLoss("snapshot: " + what + ": " + std::to_string(in.sqrt_information_size()) +
                          " square-root information entries are no square matrix");
  }
  r.sqrt_information.resize(dim, dim);
  for (int row = 0; row < dim; ++row) {
    for (int col = 0; col < dim; ++col) {
      r.sqrt_information(row, col) = in.sqrt_information(row * dim + col);
    }
  }
  // A square-root information entry beyond 1e8 (a standard deviation below 1e-8 m or rad) is
  // not something slamd writes from validated messages; a file that holds one is damaged, and
  // eliminating it would lose all precision.
  if (!(r.sqrt_information.cwiseAbs().maxCoeff() <= kMaxSqrtInformation)) {
    return core::DataLoss("snapshot: " + what + ": square-root information entry beyond 1e8");
  }
  if (in.robust_kind() != 0) {
    core::Result<core::RobustKernel> k = core::RobustKernel::Create(
        static_cast<core::RobustKernel::Kind>(in.robust_kind()), in.robust_parameter());
    if (!k.ok()) return core::DataLoss("snapshot: " + what + ": " + k.status().message());
    r.robust = k.value();
  }
  for (const pb::Variable& v : in.values()) {
    core::Result<core::Variable> value = ReadVariable(v, what);
    if (!value.ok()) return value.status();
    r.values.push_back(std::move(value).value());
  }
  core::Result<core::FactorPtr> f = core::DecodeFactor(r);
  if (!f.ok()) return core::DataLoss("snapshot: " + what + ": " + f.status().message());
  return f;
}

// A message re-encoded as its LCM type (held messages, cameras, track observations).
void WriteHeld(const Inbound& message, int waited, pb::HeldMessage* out) {
  std::string type;
  const std::vector<std::uint8_t> bytes = EncodeInbound(message, &type);
  out->set_message_type(type);
  out->set_lcm_payload(bytes.data(), bytes.size());
  out->set_waited(waited);
}

core::Result<Inbound> ReadHeld(const pb::HeldMessage& m, const char* what) {
  const auto* data = reinterpret_cast<const std::uint8_t*>(m.lcm_payload().data());
  core::Result<Inbound> msg = DecodeInbound(m.message_type(), {data, m.lcm_payload().size()});
  if (!msg.ok())
    return core::DataLoss(std::string("snapshot: ") + what + ": " + msg.status().message());
  return msg;
}

// Serialises a state's message in pieces: protobuf parses concatenated messages as one (each
// repeated field's elements in the order they come), so the large repeated fields go out a
// chunk at a time instead of as one message tree (for an 8.3 MB snapshot the encoding's peak
// memory was 28.9 MB as one tree, 12.3 MB in chunks).
class ChunkedWriter {
 public:
  pb::EstimatorState* message() { return &chunk_; }
  // Call after adding an element of a repeated field.
  void Added() {
    if (++pending_ == kChunk) Flush();
  }
  void Flush() {
    chunk_.AppendToString(&bytes_);
    chunk_.Clear();
    pending_ = 0;
  }
  std::string Finish() {
    Flush();
    return std::move(bytes_);
  }

 private:
  static constexpr int kChunk = 1024;
  pb::EstimatorState chunk_;
  std::string bytes_;
  int pending_ = 0;
};

void EncodeValue(core::Key key, const core::Variable& value, pb::KeyedVariable* out) {
  out->set_key(key);
  WriteVariable(value, out->mutable_value());
}

}  // namespace

void EncodeValues(const core::Values& values,
                  google::protobuf::RepeatedPtrField<snapshot::KeyedVariable>* out) {
  for (std::size_t i = 0; i < values.size(); ++i) {
    const int slot = static_cast<int>(i);
    EncodeValue(values.KeyAt(slot), values.VariableAt(slot), out->Add());
  }
}

core::Status DecodeValues(const google::protobuf::RepeatedPtrField<snapshot::KeyedVariable>& in,
                          const char* what, core::Values* out) {
  for (const pb::KeyedVariable& kv : in) {
    core::Result<core::Variable> v = ReadVariable(kv.value(), what);
    if (!v.ok()) return v.status();
    const core::Status s = out->Insert(kv.key(), v.value());
    if (!s.ok()) return core::DataLoss(std::string("snapshot: ") + what + ": " + s.message());
  }
  return core::Status::Ok();
}

void EncodeAlias(core::Key pose, const PoseAlias& alias, snapshot::PoseAlias* out) {
  out->set_pose(pose);
  out->set_anchor(alias.anchor);
  WriteVariable(alias.offset, out->mutable_offset());
  for (int row = 0; row < alias.covariance.rows(); ++row) {
    for (int col = 0; col < alias.covariance.cols(); ++col) {
      out->add_covariance(alias.covariance(row, col));
    }
  }
}

core::Result<PoseAlias> DecodeAlias(const snapshot::PoseAlias& in) {
  const std::string what = "pose alias " + core::KeyToString(in.pose());
  core::Result<core::Variable> offset = ReadVariable(in.offset(), what);
  if (!offset.ok()) return offset.status();
  const int n = core::TangentDim(core::TypeOf(offset.value()));
  if (in.covariance_size() != n * n || !Plausible(in.covariance().data(), n * n)) {
    return core::DataLoss("snapshot: " + what + ": covariance is not " + std::to_string(n) + "x" +
                          std::to_string(n) + " finite numbers");
  }
  Eigen::MatrixXd cov(n, n);
  for (int i = 0; i < n * n; ++i) cov(i / n, i % n) = in.covariance(i);
  return PoseAlias{in.anchor(), std::move(offset).value(), std::move(cov)};
}

std::string EncodeState(const EstimatorState& state, const JournalPosition& position) {
  ChunkedWriter writer;
  pb::EstimatorState& out = *writer.message();
  out.set_last_message_sequence(position.last_message_sequence);
  out.set_journal_offset(position.journal_offset);
  out.set_update_sequence(state.update_sequence);
  for (const core::FactorPtr& f : state.factors) {
    WriteFactor(*f, out.add_factors());
    writer.Added();
  }
  for (size_t i = 0; i < state.linearization_point.size(); ++i) {
    const int slot = static_cast<int>(i);
    EncodeValue(state.linearization_point.KeyAt(slot), state.linearization_point.VariableAt(slot),
                out.add_linearization_point());
    writer.Added();
  }
  for (const EstimatorState::Applied& a : state.applied) {
    pb::AppliedMeasurement* m = out.add_applied();
    m->set_type(a.type);
    m->set_key_a(a.a);
    m->set_key_b(a.b);
    m->set_kind(a.kind);
    m->set_factor(a.factor);
    m->set_first_key(a.first);
    m->set_dim(a.dim);
    writer.Added();
  }
  for (const EstimatorState::Robot& r : state.robots) {
    pb::RobotState* m = out.add_robots();
    m->set_name(r.name);
    m->set_id(r.id);
    m->set_anchored(r.state.anchored);
    m->set_newest(r.state.newest);
    m->set_measurement_utime(r.state.measurement_utime);
    WriteVariable(r.state.published, m->mutable_published());
    m->set_published_index(r.state.published_index);
    m->set_moved_sequence(r.state.moved_sequence);
  }
  for (const EstimatorState::HeldMessage& h : state.held) {
    WriteHeld(h.message, h.waited, out.add_held());
    writer.Added();
  }
  for (const Inbound& camera : state.cameras) WriteHeld(camera, 0, out.add_cameras());
  for (const EstimatorState::HeldMessage& h : state.track_observations) {
    WriteHeld(h.message, h.waited, out.add_track_observations());
    writer.Added();
  }
  for (const auto& [pose, alias] : state.aliases) {
    EncodeAlias(pose, alias, out.add_aliases());
    writer.Added();
  }
  for (const EstimatorState::Merged& merged : state.merged) {
    pb::MergedMeasurement* m = out.add_merged();
    m->set_type(merged.type);
    m->set_key_a(merged.a);
    m->set_key_b(merged.b);
    m->set_kind(merged.kind);
    m->set_digest(merged.digest);
    writer.Added();
  }
  pb::Counters* c = out.mutable_counters();
  c->set_processed(state.counters.processed);
  c->set_applied(state.counters.applied);
  c->set_held(state.counters.held);
  c->set_rejected(state.counters.rejected);
  c->set_already_held(state.counters.already_held);
  c->set_landmarks_dropped(state.counters.landmarks_dropped);
  c->set_removed_variables(state.counters.removed_variables);
  c->set_merged_poses(state.counters.merged_poses);
  c->set_reduced_left_out(state.counters.reduced_left_out);
  c->set_updates(state.counters.updates);
  c->set_refinements(state.counters.refinements);
  c->set_rebuilds(state.counters.rebuilds);
  for (std::int64_t n : state.counters.rejects_by_reason) c->add_rejects_by_reason(n);
  out.set_num_factors(state.num_factors);
  out.set_residual_dimension(state.residual_dimension);
  for (core::Key k : state.shard_boundary) out.add_shard_boundary(k);
  return writer.Finish();
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
      DecodeValues(in.linearization_point(), "linearization point", &state.linearization_point));
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
    state.robots.push_back({m.name(), static_cast<std::uint8_t>(m.id()),
                            RobotState{.anchored = m.anchored(),
                                       .newest = m.newest(),
                                       .measurement_utime = m.measurement_utime(),
                                       .received_us = 0,
                                       .published = published.value(),
                                       .published_index = m.published_index(),
                                       .moved_sequence = m.moved_sequence()}});
  }
  for (const pb::HeldMessage& m : in.held()) {
    core::Result<Inbound> msg = ReadHeld(m, "held message");
    if (!msg.ok()) return msg.status();
    state.held.push_back({std::move(msg).value(), m.waited()});
  }
  for (const pb::HeldMessage& m : in.cameras()) {
    core::Result<Inbound> msg = ReadHeld(m, "camera");
    if (!msg.ok()) return msg.status();
    state.cameras.push_back(std::move(msg).value());
  }
  for (const pb::HeldMessage& m : in.track_observations()) {
    core::Result<Inbound> msg = ReadHeld(m, "landmark track observation");
    if (!msg.ok()) return msg.status();
    state.track_observations.push_back({std::move(msg).value(), m.waited()});
  }
  for (const pb::PoseAlias& m : in.aliases()) {
    core::Result<PoseAlias> alias = DecodeAlias(m);
    if (!alias.ok()) return alias.status();
    state.aliases.push_back({m.pose(), std::move(alias).value()});
  }
  for (int i = 0; i < in.merged_size(); ++i) {
    const pb::MergedMeasurement& m = in.merged(i);
    std::uint64_t digest = m.digest();
    if (m.has_factor()) {  // written before merged measurements were kept as digests
      core::Result<core::FactorPtr> f = ReadFactor(m.factor(), i);
      if (!f.ok()) return f.status();
      digest = core::MeasurementDigest(*f.value());
    }
    state.merged.push_back({static_cast<char>(m.type()), m.key_a(), m.key_b(), m.kind(), digest});
  }
  const pb::Counters& c = in.counters();
  state.counters.processed = c.processed();
  state.counters.applied = c.applied();
  state.counters.held = c.held();
  state.counters.rejected = c.rejected();
  state.counters.already_held = c.already_held();
  state.counters.landmarks_dropped = c.landmarks_dropped();
  state.counters.removed_variables = c.removed_variables();
  state.counters.merged_poses = c.merged_poses();
  state.counters.reduced_left_out = c.reduced_left_out();
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
  state.shard_boundary.assign(in.shard_boundary().begin(), in.shard_boundary().end());
  return state;
}

}  // namespace slamd::server
