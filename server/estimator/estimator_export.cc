// Estimator::ExportState and Estimator::Restore: an estimator as values (EstimatorState, what
// snapshots store) and back.

#include "server/estimator/estimator.h"

namespace slamd::server {

using core::Key;
using core::MakeKey;

EstimatorState Estimator::ExportState() const {
  EstimatorState state;
  state.update_sequence = sequence_;
  std::vector<int> position(isam_->factor_slots().size(), -1);
  for (size_t i = 0; i < isam_->factor_slots().size(); ++i) {
    if (const core::FactorPtr& f = isam_->factor_slots()[i]) {
      position[i] = static_cast<int>(state.factors.size());
      state.factors.push_back(f);
    }
  }
  state.linearization_point = isam_->linearization_point();
  state.applied.reserve(applied_.size());
  for (int n = 0; n < static_cast<int>(numbers_.size()); ++n) {
    const FactorNumbers::Entry& f = numbers_.entry(n);
    const int slot = numbers_.slot(n);
    if (slot < 0 || f.dim == 0) continue;  // removed, or no measurement
    SLAMD_CHECK(position[slot] >= 0) << "applied measurement on a removed factor";
    const auto& [type, a, b, kind] = f.id;
    state.applied.push_back({type, a, b, kind, position[slot], f.first, f.dim});
  }
  for (std::uint8_t id : registry_.ids()) {
    const RobotState& r = robots_[id];
    state.robots.push_back({registry_.Name(id), id, r});
  }
  for (const Held& h : held_) state.held.push_back({h.message, h.waited});
  cameras_.ForEach(
      [&](std::uint8_t robot, int camera_id, std::uint64_t from, const CameraModel& camera) {
        state.cameras.push_back({.measurement = CameraInfo{.utime = 0,
                                                           .robot = registry_.Name(robot),
                                                           .camera_id = camera_id,
                                                           .from_pose_index = from,
                                                           .camera = camera}});
      });
  for (const auto& [landmark, track] : tracks_.tracks()) {
    for (const FrameObservations& o : track.observations) {
      state.track_observations.push_back({{.measurement = o}, track.waited});
    }
  }
  state.aliases.assign(reduced_.aliases.begin(), reduced_.aliases.end());
  for (const auto& [id, digest] : reduced_.merged) {
    const auto& [type, a, b, kind] = id;
    state.merged.push_back({type, a, b, kind, digest});
  }
  state.counters = counters_;
  state.num_factors = num_factors_;
  state.residual_dimension = residual_dimension_;
  state.shard_boundary.assign(shard_boundary_.keys().begin(), shard_boundary_.keys().end());
  return state;
}

core::Result<std::unique_ptr<Estimator>> Estimator::Restore(const EstimatorParams& params,
                                                            const core::Isam2Params& isam2,
                                                            const EstimatorState& state) {
  core::Result<std::unique_ptr<Estimator>> made = Create(params, isam2);
  if (!made.ok()) return made.status();
  std::unique_ptr<Estimator> e = std::move(made).value();
  for (const EstimatorState::Robot& r : state.robots) {
    const std::optional<std::uint8_t> id = e->registry_.FindOrAdd(r.name);
    if (!id || *id != r.id) {
      return core::DataLoss("snapshot: robot '" + r.name + "' has id " + std::to_string(r.id) +
                            ", registration order gives another");
    }
    e->robots_[*id] = r.state;
    e->robots_[*id].received_us = 0;
  }
  std::vector<FactorNumbers::Entry> numbers(state.factors.size());  // state factor i: number i
  for (const EstimatorState::Applied& a : state.applied) {
    if (a.factor < 0 || a.factor >= static_cast<int>(state.factors.size())) {
      return core::DataLoss("snapshot: applied measurement names factor " +
                            std::to_string(a.factor) + " of " +
                            std::to_string(state.factors.size()));
    }
    if (a.dim <= 0 || numbers[a.factor].dim != 0) {
      return core::DataLoss("snapshot: applied measurement on factor " + std::to_string(a.factor) +
                            " has dimension " + std::to_string(a.dim) +
                            " or is not the only one on it");
    }
    const MeasurementId id{a.type, a.a, a.b, a.kind};
    e->applied_[id] = a.factor;
    numbers[a.factor] = {id, a.first, a.dim};
  }
  for (const auto& [pose, alias] : state.aliases) {
    if (!state.linearization_point.Contains(alias.anchor) ||
        core::TypeOf(state.linearization_point.Get(alias.anchor)) != core::TypeOf(alias.offset) ||
        state.linearization_point.Contains(pose)) {
      return core::DataLoss("snapshot: pose alias " + core::KeyToString(pose) +
                            " is a node, or its anchor " + core::KeyToString(alias.anchor) +
                            " is not a pose of its kind in the graph");
    }
    e->reduced_.aliases[pose] = alias;
  }
  for (const EstimatorState::Merged& m : state.merged) {
    const MeasurementId id{m.type, m.a, m.b, m.kind};
    e->reduced_.merged_by_pose[e->reduced_.aliases.count(m.a) != 0 ? m.a : m.b].push_back(id);
    e->reduced_.merged[id] = m.digest;
  }
  // An anchored robot's newest pose is read after every update: it must be in the graph.
  for (const EstimatorState::Robot& r : state.robots) {
    if (!r.state.anchored) continue;
    if (r.state.newest > core::kMaxKeyIndex ||
        (!state.linearization_point.Contains(MakeKey('x', r.state.newest, r.id)) &&
         e->reduced_.aliases.count(MakeKey('x', r.state.newest, r.id)) == 0)) {
      return core::DataLoss("snapshot: robot '" + r.name + "' is anchored but its newest pose " +
                            std::to_string(r.state.newest) + " is not in the graph");
    }
  }
  if (!state.factors.empty() || !state.linearization_point.empty()) {
    core::FactorGraph graph;
    for (const core::FactorPtr& f : state.factors) graph.Add(f);
    // The newest poses at the root, as an incremental run keeps them (see order_last).
    const core::Isam2Result r =
        e->isam_->Update(graph, state.linearization_point, {.order_last = e->NewestPoses()});
    if (!r.status.ok()) return core::DataLoss("snapshot: " + r.status.ToString());
  }
  e->numbers_.Restore(std::move(numbers));  // the state's factor i is the solver's i
  for (const EstimatorState::HeldMessage& h : state.held) e->held_.push_back({h.message, h.waited});
  for (const Inbound& in : state.cameras) {
    const auto* c = std::get_if<CameraInfo>(&in.measurement);
    const std::optional<std::uint8_t> id = c ? e->registry_.Find(c->robot) : std::nullopt;
    if (!id || e->cameras_.FindExact(*id, c->camera_id, c->from_pose_index)) {
      return core::DataLoss(
          "snapshot: a camera is not a camera_info_t of a known robot, or "
          "appears twice");
    }
    e->cameras_.Add(*id, c->camera_id, c->from_pose_index, c->camera);
  }
  e->cameras_.Commit();
  for (const EstimatorState::HeldMessage& h : state.track_observations) {
    const auto* o = std::get_if<FrameObservations>(&h.message.measurement);
    const std::optional<std::uint8_t> id = o ? e->registry_.Find(o->robot) : std::nullopt;
    if (!id || o->features.size() != 1 || !e->cameras_.Find(*id, o->camera_id, o->pose_index)) {
      return core::DataLoss(
          "snapshot: a landmark track observation is not a one-feature "
          "frame_observations_t of a known robot and camera");
    }
    e->tracks_.Restore(LandmarkKey(o->landmark_namespace, o->features[0].landmark_id, *id), *o,
                       h.waited);
  }
  e->counters_ = state.counters;
  e->sequence_ = state.update_sequence;
  e->window_sequence_ = state.update_sequence;
  e->num_factors_ = state.num_factors;
  e->residual_dimension_ = state.residual_dimension;
  e->shard_boundary_.Insert(state.shard_boundary.begin(), state.shard_boundary.end());
  e->settled_ = false;
  e->snapshot_.reset();
  e->PublishSnapshot(false);
  return e;
}

}  // namespace slamd::server
