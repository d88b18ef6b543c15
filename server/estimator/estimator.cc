#include "server/estimator/estimator.h"

#include <chrono>
#include <cmath>
#include <utility>

#include "core/base/memory_usage.h"
#include "core/base/thread_name.h"
#include "core/factors/factor_registry.h"
#include "server/messages/frame_observations.h"
#include "server/snapshot/estimator_state.h"

namespace slamd::server {
namespace {

using core::Key;
using core::MakeKey;
using core::Variable;

// The policies measurements follow (params validated by EstimatorParams::Validate).
MeasurementPolicy Policy(const EstimatorParams& params) {
  MeasurementPolicy policy{
      .anchor_at_origin = params.new_robot_anchor == AnchorPolicy::kAnchorAtOrigin,
      .anchor_sigma = params.anchor_sigma,
      .loop_closure_kernel = {},
      .landmark_initialization = {.min_views = params.landmark_min_views,
                                  .min_parallax_deg = params.landmark_min_parallax_deg,
                                  .max_reprojection_px = params.landmark_max_reprojection_px,
                                  .min_disparity_px = params.landmark_min_disparity_px},
      .max_landmark_error_px = params.max_landmark_error_px,
      .shards = params.shards};
  const auto kind = core::RobustKernel::ParseKind(params.loop_closure_kernel).value();
  if (kind != core::RobustKernel::Kind::kNone) {
    policy.loop_closure_kernel =
        core::RobustKernel::Create(kind, params.loop_closure_kernel_parameter).value();
  }
  return policy;
}

}  // namespace

core::Result<std::unique_ptr<Estimator>> Estimator::Create(const EstimatorParams& params,
                                                           const core::Isam2Params& isam2) {
  SLAMD_RETURN_IF_ERROR(params.Validate());
  core::Result<std::unique_ptr<core::Isam2>> isam = core::Isam2::Create(isam2);
  if (!isam.ok()) return isam.status();
  return std::unique_ptr<Estimator>(new Estimator(params, std::move(isam).value()));
}

Estimator::Estimator(const EstimatorParams& params, std::unique_ptr<core::Isam2> isam)
    : params_(params),
      policy_(Policy(params)),
      isam_(std::move(isam)),
      marginals_threads_(isam_->params().threads),
      marginals_(std::make_unique<core::Isam2Marginals>(
          isam_.get(), core::MarginalsParams{.threads = marginals_threads_})) {
  PublishSnapshot(false);
}

Estimator::~Estimator() {
  rebuild_.reset();  // joins its helper
  if (retire_thread_.joinable()) retire_thread_.join();
}

core::Isam2UpdateOptions Estimator::UpdateOptions() const {
  return {.defer_relinearization_above =
              relinearize_inline_ ? 0 : params_.background_relinearization_above,
          .skip_relinearization = rebuild_ != nullptr};
}

core::Isam2UpdateOptions Estimator::ProcessUpdateOptions() const {
  core::Isam2UpdateOptions options = UpdateOptions();
  if (finish_later_) options.solve_first = NewestPoses();
  return options;
}

void Estimator::AfterUpdate(int relinearization_deferred) {
  // Not while the window is behind: it does not remove while a rebuild is in flight, and under
  // a sustained load the rebuild (on a graph the window no longer bounds) would not end. The
  // next update relinearises inline instead.
  if (relinearization_deferred > 0 && !rebuild_) {
    if (WindowBehind()) {
      relinearize_inline_ = true;
    } else {
      StartRebuild();
    }
  }
  if (relinearization_deferred == 0) relinearize_inline_ = false;
}

void Estimator::AfterUpdateOnceSolved(int relinearization_deferred) {
  if (isam_->back_substitution_pending()) {
    pending_deferred_ = relinearization_deferred;  // FinishUpdate's
  } else {
    AfterUpdate(relinearization_deferred);
  }
}

void Estimator::FinishUpdate() {
  if (!isam_->back_substitution_pending()) return;
  isam_->FinishBackSubstitution();
  PublishSnapshot(false);  // the chi2, when due, now that all of δ is solved
  AfterUpdate(pending_deferred_);
}

void Estimator::StartRebuild() {
  rebuild_ = BackgroundRebuild::Start(
      *isam_, {.order_last = NewestPoses(),
               .max_rounds = replaying_ ? 0 : params_.rebuild_catch_up_rounds,
               .with_chi2 = !replaying_ && params_.chi2_interval_s > 0.0,
               .start_sequence = sequence_});
}

void Estimator::LogForRebuild(const core::FactorGraph& factors, const core::Values& values,
                              const core::Isam2Result& update, std::span<const int> removed) {
  if (rebuild_) rebuild_->Log(factors, values, update, removed, sequence_);
}

std::vector<Key> Estimator::NewestPoses(const Staged* s) const {
  std::vector<Key> keys;
  const Staged none;
  for (std::uint8_t id : registry_.ids()) {
    if (!robots_[id].anchored) continue;
    const Key newest = MakeKey('x', robots_[id].newest, id);
    const PoseAlias* alias = FindAlias(newest, s != nullptr ? *s : none);
    keys.push_back(alias == nullptr ? newest : alias->anchor);
  }
  return keys;
}

core::Result<bool> Estimator::FinishRebuild(std::span<const int> replay_rounds) {
  FinishUpdate();
  if (!rebuild_) return false;
  core::Result<BackgroundRebuild::Swap> finished =
      rebuild_->Finish(replay_rounds, UpdateOptions(), *isam_);
  rebuild_.reset();
  if (!finished.ok()) {
    relinearize_inline_ = true;
    return finished.status();
  }
  BackgroundRebuild::Swap& r = finished.value();
  numbers_.Remap(r.position);  // each factor's slot in the new solver
  last_swap_rounds_ = r.rounds;
  // The old solver and its marginals are freed on a helper thread: thousands of blocks, up to
  // 3.5 ms on victoriaPark, which the next message would wait for. (The marginals first: they
  // point to the solver.) A stream that never lets the estimator rest never trims its memory
  // (Refine), so the helper gives back what the allocator keeps beyond the live heap.
  if (retire_thread_.joinable()) retire_thread_.join();
  retire_thread_ =
      std::thread([old = std::move(isam_), marginals = std::move(marginals_)]() mutable {
        core::NameThisThread("slamd-retire");
        marginals.reset();
        old.reset();
        core::TrimFreedMemoryBeyondUse();
      });
  isam_ = std::move(r.solver);
  marginals_ = std::make_unique<core::Isam2Marginals>(
      isam_.get(), core::MarginalsParams{.threads = marginals_threads_});
  ++counters_.rebuilds;
  settled_ = false;
  if (r.chi2 >= 0.0 && r.chi2_sequence > chi2_sequence_) {
    chi2_ = r.chi2;
    chi2_sequence_ = r.chi2_sequence;
    chi2_time_ = std::chrono::steady_clock::now();  // as if computed here: not due again yet
  }
  PublishSnapshot(true);
  AfterUpdate(r.update.relinearization_deferred);
  return true;
}

bool Estimator::Known(Key key, const Staged& s) const {
  return s.values.Contains(key) || isam_->linearization_point().Contains(key) ||
         (s.reduced.pending_pose && s.reduced.pending_pose->first == key) ||
         FindAlias(key, s) != nullptr;
}

Variable Estimator::Estimate(Key key, const Staged& s) const {
  if (s.values.Contains(key)) return s.values.Get(key);
  if (s.reduced.pending_pose && s.reduced.pending_pose->first == key)
    return s.reduced.pending_pose->second;
  if (const PoseAlias* alias = FindAlias(key, s)) return AliasEstimate(*alias, &s);
  return isam_->CalculateEstimate(key);
}

void Estimator::FirstTime(const MeasurementId& id, Staged* s) {
  s->pending_id = id;
  s->pending_existing = nullptr;
  s->pending_digest.reset();
  if (const auto it = applied_.find(id); it != applied_.end()) {
    s->pending_existing = isam_->factor_slots()[numbers_.slot(it->second)];
  } else if (const auto m = reduced_.merged.find(id); m != reduced_.merged.end()) {
    s->pending_digest = m->second;
  } else if (s->seen.count(id) != 0) {
    for (const auto& [position, staged_id, first] : s->ids) {
      if (staged_id == id) s->pending_existing = s->factors[position];
    }
    for (const auto& [merged_id, factor] : s->reduced.merged) {
      if (merged_id == id) s->pending_existing = factor;
    }
  }
  s->seen.insert(id);
}

Outcome Estimator::AddMeasured(core::FactorPtr factor, Key first, const char* what, Staged* s,
                               Verdict* v) {
  SLAMD_CHECK(s->pending_id.has_value()) << "AddMeasured without FirstTime";
  const MeasurementId id = *s->pending_id;
  s->pending_id.reset();
  const core::FactorPtr existing = std::move(s->pending_existing);
  const std::optional<std::uint64_t> digest = std::exchange(s->pending_digest, std::nullopt);
  if (existing || digest) {
    s->reduced.pending_pose.reset();  // the pose it would place is not added
    if (existing ? core::SameMeasurement(*existing, *factor)
                 : core::MeasurementDigest(*factor) == *digest) {
      return Outcome::kAlreadyHeld;
    }
    *v = {RejectReason::kDuplicate, std::string(what) + ": a different measurement between " +
                                        core::KeyToString(std::get<1>(id)) + " and " +
                                        core::KeyToString(std::get<2>(id)) +
                                        " was already applied"};
    return Outcome::kRejected;
  }
  if (s->reduced.pending_pose || std::any_of(factor->keys().begin(), factor->keys().end(),
                                             [&](Key k) { return FindAlias(k, *s) != nullptr; })) {
    return AddReduced(std::move(factor), first, id, s, v);
  }
  s->ids.emplace_back(s->factors.size(), id, first);
  s->factors.Add(std::move(factor));
  return Outcome::kApplied;
}

Outcome Estimator::AddReplacing(core::FactorPtr factor, Key first, Staged* s) {
  SLAMD_CHECK(s->pending_id.has_value()) << "AddReplacing without FirstTime";
  const MeasurementId id = *s->pending_id;
  s->pending_id.reset();
  s->pending_existing = nullptr;
  s->pending_digest.reset();
  for (auto& [position, staged_id, staged_first] : s->ids) {
    if (staged_id != id) continue;
    s->factors.Replace(position, std::move(factor));  // a newer one in the same batch
    staged_first = first;
    return Outcome::kApplied;
  }
  if (const auto it = applied_.find(id); it != applied_.end() && numbers_.slot(it->second) >= 0) {
    s->replaced.push_back(it->second);
  }
  s->ids.emplace_back(s->factors.size(), id, first);
  s->factors.Add(std::move(factor));
  return Outcome::kApplied;
}

RobotState& Estimator::Robot(std::uint8_t id, Staged* s) {
  for (const auto& [saved, state] : s->robots_before) {
    if (saved == id) return robots_[id];
  }
  s->robots_before.emplace_back(id, robots_[id]);
  return robots_[id];
}

void Estimator::AddPose(std::uint8_t robot, std::uint64_t index, const Variable& value,
                        const Inbound& in, Staged* s) {
  (void)s->values.Insert(MakeKey('x', index, robot), value);  // new key: checked by the caller
  RobotState& r = Robot(robot, s);
  if (!r.anchored || index > r.newest) r.newest = index;
  r.anchored = true;
  Touch(robot, in, s);
}

void Estimator::Touch(std::uint8_t robot, const Inbound& in, Staged* s) {
  RobotState& r = Robot(robot, s);
  r.measurement_utime = MessageUtime(in);
  r.received_us = in.received_us;
}

class Estimator::Builder final : public GraphBuilder {
 public:
  Builder(Estimator& e, Staged& s, const Inbound& in) : e_(e), s_(s), in_(in) {}

  const MeasurementPolicy& policy() const override { return e_.policy_; }
  std::optional<std::uint8_t> FindRobot(const std::string& name) const override {
    return e_.registry_.Find(name);
  }
  std::optional<std::uint8_t> FindOrAddRobot(const std::string& name) override {
    return e_.registry_.FindOrAdd(name);
  }
  bool Anchored(std::uint8_t robot) const override { return e_.robots_[robot].anchored; }
  bool Known(Key key) const override { return e_.Known(key, s_); }
  Variable Estimate(Key key) const override { return e_.Estimate(key, s_); }
  bool Ahead(Key pose) const override {
    const RobotState& r = e_.robots_[core::KeyRobot(pose)];
    return r.anchored && core::KeyIndex(pose) > r.newest;
  }
  void AddPose(std::uint8_t robot, std::uint64_t index, const Variable& value) override {
    if (e_.robots_[robot].anchored && e_.ReducedFor(robot) != nullptr && !s_.reduced.pending_pose) {
      // Node or alias: its factor (AddMeasured) decides.
      s_.reduced.pending_pose.emplace(MakeKey('x', index, robot), value);
      RobotState& r = e_.Robot(robot, &s_);
      if (index > r.newest) r.newest = index;
      e_.Touch(robot, in_, &s_);
      return;
    }
    e_.AddPose(robot, index, value, in_, &s_);
  }
  void AddVariable(Key key, const Variable& value) override {
    (void)s_.values.Insert(key, value);  // a new key: checked by the spec
  }
  void AddFactor(core::FactorPtr factor) override { s_.factors.Add(std::move(factor)); }
  void FirstTime(const MeasurementId& id) override { e_.FirstTime(id, &s_); }
  Outcome AddMeasured(core::FactorPtr factor, Key first, const char* what, Verdict* v) override {
    return e_.AddMeasured(std::move(factor), first, what, &s_, v);
  }
  Outcome AddReplacing(core::FactorPtr factor, Key first) override {
    return e_.AddReplacing(std::move(factor), first, &s_);
  }
  void Touch(std::uint8_t robot) override { e_.Touch(robot, in_, &s_); }
  CameraTable& cameras() override { return e_.cameras_; }
  LandmarkTracks& tracks() override { return e_.tracks_; }
  void RejectPart(Verdict verdict) override { s_.parts.push_back({in_, std::move(verdict)}); }
  void NoteShardLandmarks(const std::string& shard,
                          const std::vector<std::uint64_t>& landmarks) override {
    e_.shard_boundary_.NoteLandmarks(shard, landmarks);  // what it holds, whatever the update
  }

 private:
  Estimator& e_;
  Staged& s_;
  const Inbound& in_;
};

Outcome Estimator::Apply(const Inbound& in, Staged* s, Verdict* v) {
  Builder builder(*this, *s, in);
  return VisitSpec(in, [&](auto spec, const auto& m) -> Outcome {
    using Spec = typename decltype(spec)::type;
    if constexpr (Spec::kRole == MessageRole::kMeasurement) {
      return Spec::Apply(m, builder, v);
    } else {
      SLAMD_CHECK(false) << Spec::kType << " reached Estimator::Apply";
      return Outcome::kRejected;
    }
  });
}

void Estimator::Reject(const Inbound& in, RejectReason reason, std::string message,
                       ProcessResult* result) {
  ++counters_.rejected;
  ++counters_.rejects_by_reason[static_cast<int>(reason)];
  result->rejections.push_back({in, Verdict{reason, std::move(message)}});
}

void Estimator::CommitCamerasAndTracks(ProcessResult* result) {
  cameras_.Commit();
  tracks_.Commit();
  for (auto& dropped :
       tracks_.Age(params_.landmark_max_wait_updates, params_.max_track_observations)) {
    LandmarkTracks::Track& track = dropped.second;
    ++counters_.landmarks_dropped;
    const bool full = track.waited <= params_.landmark_max_wait_updates;
    const FrameObservations& first = track.observations.front();
    const std::string name =
        LandmarkName(first.landmark_namespace, first.robot, first.features[0].landmark_id);
    Reject(Inbound{.measurement = std::move(track.observations.front())},
           RejectReason::kOutOfOrderTimeout,
           "frame_observations_t: " + name + " dropped with its " +
               std::to_string(track.observations.size()) + " observation(s): " +
               (full ? "the track buffer is full (estimator.max_track_observations = " +
                           std::to_string(params_.max_track_observations) + ")"
                     : "not determined within " +
                           std::to_string(params_.landmark_max_wait_updates) + " updates") +
               (track.why.empty() ? "" : "; " + track.why),
           result);
  }
}

ProcessResult Estimator::Process(std::vector<Inbound> batch, bool finish_later) {
  FinishUpdate();
  finish_later_ = finish_later;
  ProcessResult result;
  counters_.processed += static_cast<std::int64_t>(batch.size());
  std::vector<Inbound> segment;
  for (Inbound& in : batch) {
    const MessageRole role = MessageRoleOf(in);
    SLAMD_CHECK(role != MessageRole::kQuery)
        << "queries are answered by the daemon, not Estimator::Process";
    if (role == MessageRole::kRetraction) {
      if (!segment.empty()) ApplyBatch(std::move(segment), &result);
      segment.clear();
      Remove(in, &result);
    } else {
      segment.push_back(std::move(in));
    }
  }
  ApplyBatch(std::move(segment), &result);  // also ages held messages when empty
  finish_later_ = false;
  return result;
}

void Estimator::ApplyBatch(std::vector<Inbound> batch, ProcessResult* out) {
  ProcessResult& result = *out;
  std::vector<Held> pending(std::make_move_iterator(held_.begin()),
                            std::make_move_iterator(held_.end()));
  held_.clear();
  const size_t num_old = pending.size();
  for (Inbound& in : batch) pending.push_back({std::move(in), 0});

  // Apply in order; a pass that adds anything may release held messages, so repeat until none
  // is applied.
  Staged s;
  std::vector<char> done(pending.size(), 0);
  std::vector<size_t> applied;
  for (bool progress = true; progress;) {
    progress = false;
    for (size_t i = 0; i < pending.size(); ++i) {
      if (done[i]) continue;
      Verdict v;
      switch (Apply(pending[i].message, &s, &v)) {
        case Outcome::kApplied:
          done[i] = 1;
          applied.push_back(i);
          progress = true;
          break;
        case Outcome::kRejected:
          done[i] = 1;
          Reject(pending[i].message, v.reason, std::move(v.message), &result);
          break;
        case Outcome::kAlreadyHeld:
          done[i] = 1;
          ++counters_.already_held;
          VisitSpec(pending[i].message, [&](auto spec, const auto& m) {
            using Spec = typename decltype(spec)::type;
            result.already_held_robots.insert(Spec::Robot(m));
            if constexpr (requires { Spec::SecondRobot(m); }) {
              result.already_held_robots.insert(Spec::SecondRobot(m));
            }
          });
          break;
        case Outcome::kHeld:
          break;
      }
    }
  }

  // Still held: count, age, and reject beyond the bounds.
  for (size_t i = 0; i < pending.size(); ++i) {
    if (done[i]) continue;
    if (i >= num_old) ++counters_.held;
    Held& h = pending[i];
    if (++h.waited > params_.max_hold_updates) {
      Reject(h.message, RejectReason::kOutOfOrderTimeout,
             std::string(MessageTypeName(h.message)) +
                 ": the pose (or camera) it needs did not arrive within " +
                 std::to_string(params_.max_hold_updates) + " updates",
             &result);
    } else {
      held_.push_back(std::move(h));
    }
  }
  while (static_cast<int>(held_.size()) > params_.max_held_messages) {
    Reject(held_.front().message, RejectReason::kOutOfOrderTimeout,
           std::string(MessageTypeName(held_.front().message)) +
               ": hold buffer full (estimator.max_held_messages = " +
               std::to_string(params_.max_held_messages) + ")",
           &result);
    held_.pop_front();
  }

  for (Rejection& part : s.parts) {
    Reject(part.message, part.verdict.reason, std::move(part.verdict.message), &result);
  }
  if (s.factors.size() == 0 && s.values.empty()) {
    // Applied without factors (a camera_info_t, features that joined tracks, poses the reduced
    // graph held as aliases): nothing to undo.
    CommitCamerasAndTracks(&result);
    const bool aliases_moved = !s.reduced.aliases.empty();
    CommitReduced(&s);
    result.applied += static_cast<int>(applied.size());
    counters_.applied += static_cast<std::int64_t>(applied.size());
    PublishSnapshot(aliases_moved);  // a robot's newest pose, an alias, is a new estimate
    return;
  }
  FinishUpdate();  // a removal's update earlier in this Process
  core::Isam2UpdateOptions options = ProcessUpdateOptions();
  for (int n : s.replaced) options.remove_factors.push_back(numbers_.slot(n));
  if (finish_later_) options.solve_first = NewestPoses(&s);  // with this batch's aliases
  result.updates.push_back(isam_->Update(s.factors, s.values, options));
  const core::Isam2Result& update = result.updates.back();
  if (!update.status.ok()) {
    if (result.status.ok()) result.status = update.status;
    // The solver left its state unchanged: undo ours and reject what this batch applied.
    for (const auto& [id, state] : s.robots_before) robots_[id] = state;
    cameras_.Rollback();
    tracks_.Rollback();
    for (size_t i : applied) {
      Reject(pending[i].message, RejectReason::kBadMeasurement,
             std::string(MessageTypeName(pending[i].message)) +
                 ": the solver refused the update: " + update.status.ToString(),
             &result);
    }
    PublishSnapshot(false);
    return;
  }
  CommitCamerasAndTracks(&result);
  shard_boundary_.Grow(s.factors, s.ids);
  CommitReduced(&s);
  for (int n : s.replaced) {  // first: their numbers go to the new factors
    residual_dimension_ -= numbers_.entry(n).dim;
    numbers_.Release(n);
    --num_factors_;
  }
  for (const auto& [position, id, first] : s.ids) {
    applied_[id] =
        numbers_.Add({id, first, s.factors[position]->dim()}, update.new_factor_indices[position]);
  }
  num_factors_ += static_cast<std::int64_t>(s.factors.size());
  for (const core::FactorPtr& f : s.factors.factors()) residual_dimension_ += f->dim();
  result.applied += static_cast<int>(applied.size());
  for (size_t i : applied) result.applied_received_us.push_back(pending[i].message.received_us);
  counters_.applied += static_cast<std::int64_t>(applied.size());
  ++counters_.updates;
  settled_ = false;
  PublishSnapshot(true);
  LogForRebuild(s.factors, s.values, update, options.remove_factors);
  AfterUpdateOnceSolved(update.relinearization_deferred);
}

void Estimator::Remove(const Inbound& in, ProcessResult* result) {
  const auto& r = std::get<RemoveFactorRequest>(in.measurement);
  Key first = 0;
  std::string why;
  Staged none;
  const std::optional<MeasurementId> id =
      RemoveFactorSpec::Identity(r, Builder(*this, none, in), &first, &why);
  const auto it = id ? applied_.find(*id) : applied_.end();
  if (!id || it == applied_.end() || numbers_.entry(it->second).first != first) {
    if (id && reduced_.merged.count(*id) != 0) {
      why =
          "remove_factor_t: the measurement was composed onto other poses by the reduced pose "
          "graph (estimator.reduced) and cannot be removed";
    } else if (id) {
      why = "remove_factor_t: no such measurement was applied (from " +
            core::KeyToString(std::get<1>(*id)) +
            (std::get<2>(*id) != 0 ? " to " + core::KeyToString(std::get<2>(*id)) : "") +
            (it != applied_.end() ? "; the loop closure was sent the other way round)" : ")");
    }
    Reject(in, RejectReason::kUnknownFactor, std::move(why), result);
    return;
  }
  FinishUpdate();  // an earlier update of this Process
  core::Isam2UpdateOptions options = ProcessUpdateOptions();
  options.remove_factors = {numbers_.slot(it->second)};
  result->updates.push_back(isam_->Update({}, {}, options));
  const core::Isam2Result& update = result->updates.back();
  if (!update.status.ok()) {
    Reject(in, RejectReason::kWouldDisconnect,
           "remove_factor_t: the solver refused the removal: " + update.status.ToString(), result);
    PublishSnapshot(false);
    return;
  }
  --num_factors_;
  residual_dimension_ -= numbers_.entry(it->second).dim;
  numbers_.Release(it->second);
  applied_.erase(it);
  ++result->applied;
  result->applied_received_us.push_back(in.received_us);
  ++counters_.applied;
  ++counters_.updates;
  settled_ = false;
  PublishSnapshot(true);
  LogForRebuild({}, {}, update, options.remove_factors);
  AfterUpdateOnceSolved(update.relinearization_deferred);
}

std::vector<Rejection> Estimator::RejectHeld(const std::string& why) {
  ProcessResult result;
  for (const Held& h : held_) {
    Reject(h.message, RejectReason::kOutOfOrderTimeout,
           std::string(MessageTypeName(h.message)) + ": " + why, &result);
  }
  held_.clear();
  PublishSnapshot(false);
  return std::move(result.rejections);
}

core::Isam2::RefineResult Estimator::Refine(double budget_s, int max_rounds) {
  FinishUpdate();
  core::Isam2::RefineResult r = isam_->Refine(budget_s, max_rounds);
  ++counters_.refinements;
  settled_ = r.converged;
  if (settled_) isam_->TrimMemory();  // at rest: give back what updates keep for reuse
  PublishSnapshot(r.rounds > 0);
  return r;
}

}  // namespace slamd::server
