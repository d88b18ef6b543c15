#include "server/estimator/estimator.h"

#include <chrono>
#include <cmath>
#include <numeric>
#include <utility>

#include "core/base/thread_name.h"
#include "core/factors/bearing_range_factor.h"
#include "core/factors/between_factor.h"
#include "core/factors/factor_registry.h"
#include "core/factors/position_prior_factor.h"
#include "core/factors/prior_factor.h"
#include "core/factors/relative_point_factor.h"
#include "server/estimator/estimator_state.h"

namespace slamd::server {
namespace {

using core::Key;
using core::MakeKey;
using core::Pose2;
using core::Pose3;
using core::Variable;

bool SameType(const Variable& v, const RelativePose& z) {
  return std::holds_alternative<Pose2>(z) ? std::holds_alternative<Pose2>(v)
                                          : std::holds_alternative<Pose3>(v);
}

// from ∘ z (inverse = false) or from ∘ z⁻¹; types checked by the caller.
Variable Compose(const Variable& from, const RelativePose& z, bool inverse) {
  if (const Pose2* z2 = std::get_if<Pose2>(&z)) {
    const Pose2& a = std::get<Pose2>(from);
    return inverse ? a * z2->Inverse() : a * *z2;
  }
  const Pose3& z3 = std::get<Pose3>(z);
  const Pose3& a = std::get<Pose3>(from);
  return inverse ? a * z3.Inverse() : a * z3;
}

core::FactorPtr MakeBetween(Key a, Key b, const RelativePose& z, const core::NoiseModel& noise,
                            const core::RobustKernel& robust = {}) {
  if (const Pose2* z2 = std::get_if<Pose2>(&z)) {
    return std::make_shared<core::BetweenFactor<Pose2>>(a, b, *z2, noise, robust);
  }
  return std::make_shared<core::BetweenFactor<Pose3>>(a, b, std::get<Pose3>(z), noise, robust);
}

// params_.loop_closure_kernel as a kernel (validated by EstimatorParams::Validate).
core::RobustKernel DefaultLoopKernel(const EstimatorParams& params) {
  const auto kind = core::RobustKernel::ParseKind(params.loop_closure_kernel).value();
  if (kind == core::RobustKernel::Kind::kNone) return {};
  return core::RobustKernel::Create(kind, params.loop_closure_kernel_parameter).value();
}

std::string PoseName(const std::string& robot, std::uint64_t index) {
  return "robot '" + robot + "' pose " + std::to_string(index);
}

}  // namespace

const char* MessageTypeName(const Inbound& in) {
  static constexpr const char* kNames[] = {"odometry_t", "landmark_observation_t", "loop_closure_t",
                                           "prior_t",    "remove_factor_t",        "query_t"};
  return kNames[in.measurement.index()];
}

const std::string& MessageRobot(const Inbound& in) {
  return std::visit(
      [](const auto& m) -> const std::string& {
        using M = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<M, LoopClosureMeasurement> ||
                      std::is_same_v<M, RemoveFactorRequest>) {
          return m.robot_a;
        } else if constexpr (std::is_same_v<M, QueryRequest>) {
          return m.client;
        } else {
          return m.robot;
        }
      },
      in.measurement);
}

std::int64_t MessageUtime(const Inbound& in) {
  return std::visit([](const auto& m) { return m.utime; }, in.measurement);
}

core::Result<std::unique_ptr<Estimator>> Estimator::Create(const EstimatorParams& params,
                                                           const core::Isam2Params& isam2) {
  SLAMD_RETURN_IF_ERROR(params.Validate());
  core::Result<std::unique_ptr<core::Isam2>> isam = core::Isam2::Create(isam2);
  if (!isam.ok()) return isam.status();
  return std::unique_ptr<Estimator>(new Estimator(params, std::move(isam).value()));
}

Estimator::Estimator(const EstimatorParams& params, std::unique_ptr<core::Isam2> isam)
    : params_(params),
      default_loop_kernel_(DefaultLoopKernel(params)),
      isam_(std::move(isam)),
      marginals_threads_(isam_->params().threads),
      marginals_(std::make_unique<core::Isam2Marginals>(
          isam_.get(), core::MarginalsParams{.threads = marginals_threads_})) {
  PublishSnapshot(false);
}

Estimator::~Estimator() {
  if (rebuild_ && rebuild_->thread.joinable()) rebuild_->thread.join();
  if (retire_thread_.joinable()) retire_thread_.join();
}

core::Isam2UpdateOptions Estimator::UpdateOptions() const {
  return {.defer_relinearization_above =
              rebuild_failed_ ? 0 : params_.background_relinearization_above,
          .skip_relinearization = rebuild_ != nullptr};
}

core::Isam2UpdateOptions Estimator::ProcessUpdateOptions() const {
  core::Isam2UpdateOptions options = UpdateOptions();
  if (finish_later_) options.solve_first = NewestPoses();
  return options;
}

void Estimator::AfterUpdate(int relinearization_deferred) {
  if (relinearization_deferred > 0 && !rebuild_) StartRebuild();
  if (relinearization_deferred == 0) rebuild_failed_ = false;
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
  // The helper reads only what is copied here (the factors are immutable and shared).
  auto rebuild = std::make_unique<Rebuild>();
  const std::vector<core::FactorPtr>& slots = isam_->factor_slots();
  core::FactorGraph factors;
  rebuild->position.assign(slots.size(), -1);
  for (size_t i = 0; i < slots.size(); ++i) {
    if (!slots[i]) continue;
    rebuild->position[i] = static_cast<int>(factors.size());
    factors.Add(slots[i]);
  }
  Rebuild* r = rebuild.get();
  // One thread: the other core is the live solver's. (The rebuilt solver keeps it after the
  // swap; with background relinearisation the steps large enough for threads are the rebuilds.
  // A/B at 1 kHz: ingest-to-publish p99 victoriaPark 4.2-4.5 -> 3.3-4.1 ms, manhattan 2.5-2.7 ->
  // 1.6-2.3 ms.)
  core::Isam2Params params = isam_->params();
  params.threads = 1;
  rebuild->thread = std::thread(
      [r, params, factors = std::move(factors), estimate = isam_->CalculateEstimate(),
       newest = NewestPoses(), max_rounds = replaying_ ? 0 : params_.rebuild_catch_up_rounds,
       with_chi2 = !replaying_ && params_.chi2_interval_s > 0.0,
       start_sequence = sequence_]() mutable {
        core::NameThisThread("slamd-rebuild");
        core::Result<std::unique_ptr<core::Isam2>> made = core::Isam2::Create(params);
        if (made.ok()) {
          r->solver = std::move(made).value();
          r->status = r->solver->Update(factors, estimate, {.order_last = newest}).status;
          // A relinearisation check now: its first pass in a new solver evaluates every factor
          // (Relinearization::error_threshold; nothing is known of their curvature yet), 4-5 ms on
          // victoriaPark, which would otherwise fall on the first checking update after the swap.
          if (r->status.ok()) {
            r->status =
                r->solver->Update({}, {}, {.order_last = newest, .force_relinearize = true}).status;
          }
        } else {
          r->status = made.status();
        }
        // Freed now, not after `done` with the lambda: freeing a large map's copies (up to 30 ms in
        // the soak) would fall on the estimator thread, in FinishRebuild's join.
        factors = core::FactorGraph();
        estimate = core::Values();
        // Catch-up rounds: each takes what was logged while the last one ran, so the backlog
        // shrinks round by round; at most max_rounds, for input faster than them. The new variables
        // come at their initial guesses (the live estimate is the estimator thread's): each round
        // relinearises what moved past the thresholds. With `finish`, the check that finds nothing
        // waiting also marks the rebuild done, under the log's lock: every update the estimator
        // logged before it saw the rebuild not done is taken here, and the swap takes only what
        // came after (on manhattan.g2o at 1 kHz, leaving the last 2 and what came during the chi2
        // pass made swaps of up to 4 ms on the estimator thread).
        const auto catch_up = [&](bool finish) {
          for (;;) {
            size_t end = 0;
            {
              std::lock_guard lock(r->log_mutex);
              end = r->log.size();
              if (end == r->caught_up || !r->status.ok() ||
                  static_cast<int>(r->rounds.size()) >= max_rounds) {
                if (finish) r->done.store(true, std::memory_order_release);
                return;
              }
            }
            const int taken = static_cast<int>(end - r->caught_up);
            r->status = CatchUp(r, end, {.force_relinearize = true}, nullptr).status;
            r->rounds.push_back(taken);
          }
        };
        catch_up(false);
        // The status chi2 of the rebuilt map, here rather than on the estimator thread, where a
        // pass over every factor (50-350 ms at 250k variables) held up every message behind it.
        // It describes the updates taken so far; the swap hands it over.
        if (r->status.ok() && with_chi2) {
          r->chi2 = r->solver->Chi2();
          std::lock_guard lock(r->log_mutex);
          r->chi2_sequence = r->caught_up == 0 ? start_sequence : r->log[r->caught_up - 1].sequence;
        }
        catch_up(true);  // what came during the chi2 pass (2-4 ms on manhattan.g2o)
      });
  rebuild_ = std::move(rebuild);
}

core::Isam2Result Estimator::CatchUp(Rebuild* r, size_t end, core::Isam2UpdateOptions options,
                                     const core::Isam2* live) {
  core::FactorGraph added;
  std::vector<int> live_index;  // of each factor in `added`
  core::Values values;
  {
    std::lock_guard lock(r->log_mutex);
    SLAMD_CHECK(end <= r->log.size()) << "catch-up past the log";
    std::vector<std::pair<int, core::FactorPtr>> factors;
    for (size_t e = r->caught_up; e < end; ++e) {
      const LoggedUpdate& u = r->log[e];
      factors.insert(factors.end(), u.added.begin(), u.added.end());
      for (size_t v = 0; v < u.values.size(); ++v) {
        const Key key = u.values.KeyAt(static_cast<int>(v));
        const core::Status s = values.Insert(
            key, live ? live->CalculateEstimate(key) : u.values.VariableAt(static_cast<int>(v)));
        SLAMD_CHECK(s.ok()) << s.ToString();  // the live solver took it as new
      }
      for (int index : u.removed) {
        if (static_cast<size_t>(index) < r->position.size() && r->position[index] >= 0) {
          options.remove_factors.push_back(r->position[index]);
          r->position[index] = -1;
          continue;
        }
        // Added in this round: it never reaches the new solver.
        const auto it = std::find_if(factors.begin(), factors.end(),
                                     [&](const auto& f) { return f.first == index; });
        SLAMD_CHECK(it != factors.end()) << "removed live factor " << index << " is unknown";
        it->second = nullptr;
      }
    }
    for (auto& [index, factor] : factors) {
      if (!factor) continue;
      live_index.push_back(index);
      added.Add(std::move(factor));
    }
  }
  r->caught_up = end;
  if (added.size() == 0 && values.empty() && options.remove_factors.empty()) return {};
  core::Isam2Result update = r->solver->Update(added, values, options);
  if (!update.status.ok()) return update;
  for (size_t k = 0; k < live_index.size(); ++k) {
    const int i = live_index[k];
    if (static_cast<size_t>(i) >= r->position.size()) r->position.resize(i + 1, -1);
    r->position[i] = update.new_factor_indices[k];
  }
  return update;
}

void Estimator::LogForRebuild(const core::FactorGraph& factors, const core::Values& values,
                              const core::Isam2Result& update, std::span<const int> removed) {
  if (!rebuild_) return;
  LoggedUpdate u;
  u.added.reserve(factors.size());
  for (size_t k = 0; k < factors.size(); ++k) {
    u.added.emplace_back(update.new_factor_indices[k], factors[k]);
  }
  u.values = values;
  u.removed.assign(removed.begin(), removed.end());
  u.sequence = sequence_;
  std::lock_guard lock(rebuild_->log_mutex);
  rebuild_->log.push_back(std::move(u));
}

std::vector<Key> Estimator::NewestPoses() const {
  std::vector<Key> keys;
  for (std::uint8_t id : registry_.ids()) {
    if (robots_[id].anchored) keys.push_back(MakeKey('x', robots_[id].newest, id));
  }
  return keys;
}

core::Result<bool> Estimator::FinishRebuild(std::span<const int> replay_rounds) {
  FinishUpdate();
  if (!rebuild_) return false;
  if (rebuild_->thread.joinable()) rebuild_->thread.join();
  SLAMD_CHECK(replay_rounds.empty() || rebuild_->rounds.empty())
      << "replayed catch-up rounds for a rebuild whose helper ran rounds (SetReplaying)";
  // Rounds recorded for another rebuild than this one cannot apply: recovery from a snapshot
  // taken while the journal's rebuild was in flight replays into a solver restored in a new
  // order, which may defer (and start its own rebuild) at other updates. Its swap then takes
  // everything in one update (a snapshot recovery is not bit for bit anyway).
  size_t named = 0;
  bool fits = true;
  for (int n : replay_rounds) {
    fits = fits && n > 0;
    named += static_cast<size_t>(std::max(n, 0));
  }
  if (!fits || rebuild_->caught_up + named > rebuild_->log.size()) replay_rounds = {};
  const std::unique_ptr<Rebuild> r = std::move(rebuild_);
  const auto failed = [this](const core::Status& s, const char* when) {
    rebuild_failed_ = true;
    return core::Status(s.code(), std::string("background rebuild: ") + when + s.message());
  };
  if (!r->status.ok()) return failed(r->status, "");
  for (int n : replay_rounds) {
    const core::Isam2Result round =
        CatchUp(r.get(), r->caught_up + n, {.force_relinearize = true}, nullptr);
    if (!round.status.ok()) return failed(round.status, "catching up: ");
    r->rounds.push_back(n);
  }
  // The rest in one update, its new variables at the live estimate, checked for relinearisation
  // as any update from messages.
  const core::Isam2Result update = CatchUp(r.get(), r->log.size(), UpdateOptions(), isam_.get());
  if (!update.status.ok()) return failed(update.status, "catching up: ");
  // Each factor's index in the new solver (a pass over a vector, not over applied_).
  for (int& index : solver_index_) {
    if (index < 0) continue;
    SLAMD_CHECK(static_cast<size_t>(index) < r->position.size() && r->position[index] >= 0)
        << "applied factor " << index << " is not in the rebuilt solver";
    index = r->position[index];
  }
  last_swap_rounds_ = r->rounds;
  // The old solver and its marginals are freed on a helper thread: thousands of blocks, up to
  // 3.5 ms on victoriaPark, which the next message would wait for. (The marginals first: they
  // point to the solver.)
  if (retire_thread_.joinable()) retire_thread_.join();
  retire_thread_ =
      std::thread([old = std::move(isam_), marginals = std::move(marginals_)]() mutable {
        core::NameThisThread("slamd-retire");
        marginals.reset();
        old.reset();
      });
  isam_ = std::move(r->solver);
  marginals_ = std::make_unique<core::Isam2Marginals>(
      isam_.get(), core::MarginalsParams{.threads = marginals_threads_});
  ++counters_.rebuilds;
  settled_ = false;
  if (r->chi2 >= 0.0 && r->chi2_sequence > chi2_sequence_) {
    chi2_ = r->chi2;
    chi2_sequence_ = r->chi2_sequence;
    chi2_time_ = std::chrono::steady_clock::now();  // as if computed here: not due again yet
  }
  PublishSnapshot(true);
  AfterUpdate(update.relinearization_deferred);
  return true;
}

bool Estimator::Known(Key key, const Staged& s) const {
  return s.values.Contains(key) || isam_->linearization_point().Contains(key);
}

Variable Estimator::Estimate(Key key, const Staged& s) const {
  if (s.values.Contains(key)) return s.values.Get(key);
  return isam_->CalculateEstimate(key);
}

void Estimator::FirstTime(char type, Key a, Key b, int kind, Staged* s) {
  const MeasurementId id = std::make_tuple(type, a, b, kind);
  s->pending_id = id;
  s->pending_existing = nullptr;
  if (const auto it = applied_.find(id); it != applied_.end()) {
    s->pending_existing = isam_->factor_slots()[solver_index_[it->second]];
  } else if (s->seen.count(id) != 0) {
    for (const auto& [position, staged_id, first] : s->ids) {
      if (staged_id == id) s->pending_existing = s->factors[position];
    }
  }
  s->seen.insert(id);
}

Estimator::Outcome Estimator::AddMeasured(core::FactorPtr factor, Key first, const char* what,
                                          Staged* s, Verdict* v) {
  SLAMD_CHECK(s->pending_id.has_value()) << "AddMeasured without FirstTime";
  const MeasurementId id = *s->pending_id;
  s->pending_id.reset();
  if (const core::FactorPtr existing = std::move(s->pending_existing)) {
    if (core::SameMeasurement(*existing, *factor)) return Outcome::kAlreadyHeld;
    *v = {RejectReason::kDuplicate, std::string(what) + ": a different measurement between " +
                                        core::KeyToString(std::get<1>(id)) + " and " +
                                        core::KeyToString(std::get<2>(id)) +
                                        " was already applied"};
    return Outcome::kRejected;
  }
  s->ids.emplace_back(s->factors.size(), id, first);
  s->factors.Add(std::move(factor));
  return Outcome::kApplied;
}

Estimator::RobotState& Estimator::Robot(std::uint8_t id, Staged* s) {
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

Estimator::Outcome Estimator::Apply(const Inbound& in, Staged* s, Verdict* v) {
  return std::visit(
      [&](const auto& m) -> Outcome {
        using M = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<M, OdometryMeasurement>) return ApplyOdometry(m, in, s, v);
        if constexpr (std::is_same_v<M, LandmarkMeasurement>) return ApplyLandmark(m, in, s, v);
        if constexpr (std::is_same_v<M, LoopClosureMeasurement>) {
          return ApplyLoopClosure(m, in, s, v);
        }
        if constexpr (std::is_same_v<M, PriorMeasurement>) return ApplyPrior(m, in, s, v);
        SLAMD_CHECK(false) << MessageTypeName(in) << " reached Estimator::Apply";
        return Outcome::kRejected;
      },
      in.measurement);
}

Estimator::Outcome Estimator::ApplyOdometry(const OdometryMeasurement& m, const Inbound& in,
                                            Staged* s, Verdict* v) {
  const auto id = registry_.FindOrAdd(m.robot);
  if (!id) {
    *v = {RejectReason::kTooManyElements, "odometry_t.robot: more than 255 robots"};
    return Outcome::kRejected;
  }
  const Key from = MakeKey('x', m.from_index, *id);
  const Key to = MakeKey('x', m.to_index, *id);
  // A robot connected in the middle of its trajectory (a loop closure placed pose k) gets its
  // earlier poses from the odometry into k, backwards.
  const bool backwards = !Known(from, *s) && Known(to, *s);
  const bool origin = !Known(from, *s) && !backwards && !robots_[*id].anchored &&
                      params_.new_robot_anchor == AnchorPolicy::kAnchorAtOrigin;
  if (!Known(from, *s) && !origin && !backwards) return Outcome::kHeld;  // ahead, or unanchored
  if (!origin && !backwards && !SameType(Estimate(from, *s), m.measured)) {
    *v = {RejectReason::kBadMeasurement,
          "odometry_t.dimension: does not match " + PoseName(m.robot, m.from_index)};
    return Outcome::kRejected;
  }
  if (Known(to, *s) && !SameType(Estimate(to, *s), m.measured)) {
    *v = {RejectReason::kBadMeasurement,
          "odometry_t.dimension: does not match " + PoseName(m.robot, m.to_index)};
    return Outcome::kRejected;
  }
  FirstTime('o', from, to, 0, s);
  if (origin) {
    const bool is2d = std::holds_alternative<Pose2>(m.measured);
    const core::NoiseModel anchor =
        core::NoiseModel::Isotropic(is2d ? 3 : 6, params_.anchor_sigma).value();
    AddPose(*id, m.from_index, is2d ? Variable(Pose2()) : Variable(Pose3()), in, s);
    if (is2d) {
      s->factors.Add(std::make_shared<core::PriorFactor<Pose2>>(from, Pose2(), anchor));
    } else {
      s->factors.Add(std::make_shared<core::PriorFactor<Pose3>>(from, Pose3(), anchor));
    }
  }
  if (backwards) {
    AddPose(*id, m.from_index, Compose(Estimate(to, *s), m.measured, true), in, s);
  } else if (!Known(to, *s)) {
    AddPose(*id, m.to_index, Compose(Estimate(from, *s), m.measured, false), in, s);
  }
  const Outcome outcome =
      AddMeasured(MakeBetween(from, to, m.measured, m.noise), from, "odometry_t", s, v);
  if (outcome == Outcome::kApplied) Touch(*id, in, s);
  return outcome;
}

Estimator::Outcome Estimator::ApplyLandmark(const LandmarkMeasurement& m, const Inbound& in,
                                            Staged* s, Verdict* v) {
  const auto id = registry_.FindOrAdd(m.robot);
  if (!id) {
    *v = {RejectReason::kTooManyElements, "landmark_observation_t.robot: more than 255 robots"};
    return Outcome::kRejected;
  }
  const Key pose = MakeKey('x', m.pose_index, *id);
  if (!Known(pose, *s)) return Outcome::kHeld;
  const Key landmark = MakeKey('l', m.landmark_id, *id);
  const Variable x = Estimate(pose, *s);
  const bool needs3d = m.kind == LandmarkKind::kRelativePoint3;
  if (std::holds_alternative<Pose3>(x) != needs3d) {
    *v = {RejectReason::kBadMeasurement,
          "landmark_observation_t.kind: does not match " + PoseName(m.robot, m.pose_index)};
    return Outcome::kRejected;
  }
  const bool known = Known(landmark, *s);
  if (known && (std::holds_alternative<core::Point3>(Estimate(landmark, *s)) != needs3d)) {
    *v = {RejectReason::kBadMeasurement, "landmark_observation_t.kind: landmark " +
                                             std::to_string(m.landmark_id) +
                                             " has the other dimension"};
    return Outcome::kRejected;
  }
  FirstTime('l', pose, landmark, static_cast<int>(m.kind), s);
  core::FactorPtr factor;
  Variable guess;
  if (const BearingRange* br = std::get_if<BearingRange>(&m.measured)) {
    const Pose2& p = std::get<Pose2>(x);
    guess = p.TransformFrom(
        core::Point2(br->range * std::cos(br->bearing), br->range * std::sin(br->bearing)));
    factor =
        std::make_shared<core::BearingRangeFactor>(pose, landmark, br->bearing, br->range, m.noise);
  } else if (const core::Point2* p2 = std::get_if<core::Point2>(&m.measured)) {
    guess = std::get<Pose2>(x).TransformFrom(*p2);
    factor = std::make_shared<core::RelativePointFactor<Pose2, core::Point2>>(pose, landmark, *p2,
                                                                              m.noise);
  } else {
    const core::Point3& p3 = std::get<core::Point3>(m.measured);
    guess = std::get<Pose3>(x).TransformFrom(p3);
    factor = std::make_shared<core::RelativePointFactor<Pose3, core::Point3>>(pose, landmark, p3,
                                                                              m.noise);
  }
  const Outcome outcome = AddMeasured(std::move(factor), pose, "landmark_observation_t", s, v);
  if (outcome != Outcome::kApplied) return outcome;
  if (!known) (void)s->values.Insert(landmark, guess);
  Touch(*id, in, s);
  return outcome;
}

Estimator::Outcome Estimator::ApplyLoopClosure(const LoopClosureMeasurement& m, const Inbound& in,
                                               Staged* s, Verdict* v) {
  const auto ida = registry_.Find(m.robot_a);
  const auto idb = registry_.Find(m.robot_b);
  const bool known_a = ida && Known(MakeKey('x', m.pose_a, *ida), *s);
  const bool known_b = idb && Known(MakeKey('x', m.pose_b, *idb), *s);
  if (!known_a && !known_b) {
    if (!ida || !robots_[*ida].anchored) {
      *v = {RejectReason::kUnknownRobot,
            "loop_closure_t.robot_a: robot '" + m.robot_a + "' has no pose in the graph"};
    } else if (!idb || !robots_[*idb].anchored) {
      *v = {RejectReason::kUnknownRobot,
            "loop_closure_t.robot_b: robot '" + m.robot_b + "' has no pose in the graph"};
    } else {
      *v = {RejectReason::kUnknownPose,
            "loop_closure_t.pose_a: " + PoseName(m.robot_a, m.pose_a) + " is not in the graph"};
    }
    return Outcome::kRejected;
  }
  // Exactly one side known: it may connect (and anchor) a robot with no pose yet.
  if (known_a != known_b) {
    const std::string& robot = known_a ? m.robot_b : m.robot_a;
    const std::optional<std::uint8_t> id = known_a ? idb : ida;
    const std::uint64_t index = known_a ? m.pose_b : m.pose_a;
    if (id && robots_[*id].anchored) {
      *v = {RejectReason::kUnknownPose, std::string("loop_closure_t.") +
                                            (known_a ? "pose_b: " : "pose_a: ") +
                                            PoseName(robot, index) + " is not in the graph"};
      return Outcome::kRejected;
    }
  }
  const Key known_key = known_a ? MakeKey('x', m.pose_a, *ida) : MakeKey('x', m.pose_b, *idb);
  if (!SameType(Estimate(known_key, *s), m.measured) ||
      (known_a && known_b && !SameType(Estimate(MakeKey('x', m.pose_b, *idb), *s), m.measured))) {
    *v = {RejectReason::kBadMeasurement, "loop_closure_t.dimension: does not match the poses"};
    return Outcome::kRejected;
  }
  std::optional<std::uint8_t> a = ida, b = idb;
  if (!a) a = registry_.FindOrAdd(m.robot_a);
  if (!b) b = registry_.FindOrAdd(m.robot_b);
  if (!a || !b) {
    *v = {RejectReason::kTooManyElements, "loop_closure_t.robot_b: more than 255 robots"};
    return Outcome::kRejected;
  }
  const Key ka = MakeKey('x', m.pose_a, *a);
  const Key kb = MakeKey('x', m.pose_b, *b);
  FirstTime('c', std::min(ka, kb), std::max(ka, kb), 0, s);
  if (!known_b) AddPose(*b, m.pose_b, Compose(Estimate(ka, *s), m.measured, false), in, s);
  if (!known_a) AddPose(*a, m.pose_a, Compose(Estimate(kb, *s), m.measured, true), in, s);
  const Outcome outcome =
      AddMeasured(MakeBetween(ka, kb, m.measured, m.noise,
                              m.robust.is_none() ? default_loop_kernel_ : m.robust),
                  ka, "loop_closure_t", s, v);
  if (outcome == Outcome::kApplied) Touch(*a, in, s);
  return outcome;
}

Estimator::Outcome Estimator::ApplyPrior(const PriorMeasurement& m, const Inbound& in, Staged* s,
                                         Verdict* v) {
  const auto id = registry_.FindOrAdd(m.robot);
  if (!id) {
    *v = {RejectReason::kTooManyElements, "prior_t.robot: more than 255 robots"};
    return Outcome::kRejected;
  }
  const Key key = MakeKey('x', m.pose_index, *id);
  const bool is_pose = m.kind == PriorKind::kPose2 || m.kind == PriorKind::kPose3;
  const bool needs3d = m.kind == PriorKind::kPose3 || m.kind == PriorKind::kPosition3;
  const bool known = Known(key, *s);
  if (!known && !(is_pose && !robots_[*id].anchored)) return Outcome::kHeld;
  if (known && std::holds_alternative<Pose3>(Estimate(key, *s)) != needs3d) {
    *v = {RejectReason::kBadMeasurement,
          "prior_t.kind: does not match " + PoseName(m.robot, m.pose_index)};
    return Outcome::kRejected;
  }
  FirstTime('p', key, 0, static_cast<int>(m.kind), s);
  core::FactorPtr factor;
  if (const Pose2* p2 = std::get_if<Pose2>(&m.measured)) {
    if (!known) AddPose(*id, m.pose_index, *p2, in, s);
    factor = std::make_shared<core::PriorFactor<Pose2>>(key, *p2, m.noise);
  } else if (const Pose3* p3 = std::get_if<Pose3>(&m.measured)) {
    if (!known) AddPose(*id, m.pose_index, *p3, in, s);
    factor = std::make_shared<core::PriorFactor<Pose3>>(key, *p3, m.noise);
  } else if (const core::Point2* t2 = std::get_if<core::Point2>(&m.measured)) {
    factor = std::make_shared<core::PositionPriorFactor<Pose2>>(key, *t2, m.noise);
  } else {
    factor = std::make_shared<core::PositionPriorFactor<Pose3>>(
        key, std::get<core::Point3>(m.measured), m.noise);
  }
  const Outcome outcome = AddMeasured(std::move(factor), key, "prior_t", s, v);
  if (outcome == Outcome::kApplied) Touch(*id, in, s);
  return outcome;
}

void Estimator::Reject(const Inbound& in, RejectReason reason, std::string message,
                       ProcessResult* result) {
  ++counters_.rejected;
  ++counters_.rejects_by_reason[static_cast<int>(reason)];
  result->rejections.push_back({in, Verdict{reason, std::move(message)}});
}

ProcessResult Estimator::Process(std::vector<Inbound> batch, bool finish_later) {
  FinishUpdate();
  finish_later_ = finish_later;
  ProcessResult result;
  counters_.processed += static_cast<std::int64_t>(batch.size());
  std::vector<Inbound> segment;
  for (Inbound& in : batch) {
    SLAMD_CHECK(!std::holds_alternative<QueryRequest>(in.measurement))
        << "queries are answered by the daemon, not Estimator::Process";
    if (std::holds_alternative<RemoveFactorRequest>(in.measurement)) {
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
          result.already_held_robots.insert(MessageRobot(pending[i].message));
          if (const auto* c =
                  std::get_if<LoopClosureMeasurement>(&pending[i].message.measurement)) {
            result.already_held_robots.insert(c->robot_b);
          }
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
                 ": the pose it needs did not arrive within " +
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

  if (s.factors.size() == 0 && s.values.empty()) {
    PublishSnapshot(false);
    return;
  }
  FinishUpdate();  // a removal's update earlier in this Process
  result.updates.push_back(isam_->Update(s.factors, s.values, ProcessUpdateOptions()));
  const core::Isam2Result& update = result.updates.back();
  if (!update.status.ok()) {
    if (result.status.ok()) result.status = update.status;
    // The solver left its state unchanged: undo ours and reject what this batch applied.
    for (const auto& [id, state] : s.robots_before) robots_[id] = state;
    for (size_t i : applied) {
      Reject(pending[i].message, RejectReason::kBadMeasurement,
             std::string(MessageTypeName(pending[i].message)) +
                 ": the solver refused the update: " + update.status.ToString(),
             &result);
    }
    PublishSnapshot(false);
    return;
  }
  for (const auto& [position, id, first] : s.ids) {
    applied_[id] = static_cast<int>(solver_index_.size());
    applied_factors_.push_back({id, first, s.factors[position]->dim()});
    solver_index_.push_back(update.new_factor_indices[position]);
  }
  num_factors_ += static_cast<std::int64_t>(s.factors.size());
  for (const core::FactorPtr& f : s.factors.factors()) residual_dimension_ += f->dim();
  result.applied += static_cast<int>(applied.size());
  for (size_t i : applied) result.applied_received_us.push_back(pending[i].message.received_us);
  counters_.applied += static_cast<std::int64_t>(applied.size());
  ++counters_.updates;
  settled_ = false;
  PublishSnapshot(true);
  LogForRebuild(s.factors, s.values, update, {});
  AfterUpdateOnceSolved(update.relinearization_deferred);
}

std::optional<Estimator::MeasurementId> Estimator::RemovalId(const RemoveFactorRequest& r,
                                                             Key* first, std::string* why) const {
  const auto a = registry_.Find(r.robot_a);
  if (!a) {
    *why = "remove_factor_t.robot_a: robot '" + r.robot_a + "' is not known";
    return std::nullopt;
  }
  const Key pose = MakeKey('x', r.index_a, *a);
  *first = pose;
  switch (r.target) {
    case RemoveTarget::kOdometry:
      return MeasurementId{'o', pose, MakeKey('x', r.index_b, *a), 0};
    case RemoveTarget::kLandmarkObservation:
      return MeasurementId{'l', pose, MakeKey('l', r.index_b, *a), r.kind};
    case RemoveTarget::kPrior:
      return MeasurementId{'p', pose, 0, r.kind};
    case RemoveTarget::kLoopClosure: {
      const auto b = registry_.Find(r.robot_b);
      if (!b) {
        *why = "remove_factor_t.robot_b: robot '" + r.robot_b + "' is not known";
        return std::nullopt;
      }
      const Key other = MakeKey('x', r.index_b, *b);
      return MeasurementId{'c', std::min(pose, other), std::max(pose, other), 0};
    }
  }
  *why = "remove_factor_t.target: unknown";
  return std::nullopt;
}

void Estimator::Remove(const Inbound& in, ProcessResult* result) {
  const auto& r = std::get<RemoveFactorRequest>(in.measurement);
  Key first = 0;
  std::string why;
  const std::optional<MeasurementId> id = RemovalId(r, &first, &why);
  const auto it = id ? applied_.find(*id) : applied_.end();
  if (!id || it == applied_.end() || applied_factors_[it->second].first != first) {
    if (id) {
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
  options.remove_factors = {solver_index_[it->second]};
  result->updates.push_back(isam_->Update({}, {}, options));
  const core::Isam2Result& update = result->updates.back();
  if (!update.status.ok()) {
    Reject(in, RejectReason::kWouldDisconnect,
           "remove_factor_t: the solver refused the removal: " + update.status.ToString(), result);
    PublishSnapshot(false);
    return;
  }
  --num_factors_;
  residual_dimension_ -= applied_factors_[it->second].dim;
  solver_index_[it->second] = -1;
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
  PublishSnapshot(r.rounds > 0);
  return r;
}

core::Result<Variable> Estimator::PoseEstimate(const std::string& robot,
                                               std::uint64_t index) const {
  const auto id = registry_.Find(robot);
  const Key key = id ? MakeKey('x', index, *id) : 0;
  if (!id || !isam_->linearization_point().Contains(key)) {
    return core::NotFound(PoseName(robot, index) + " is not in the graph");
  }
  return isam_->CalculateEstimate(key);
}

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
  for (size_t n = 0; n < applied_factors_.size(); ++n) {
    const AppliedFactor& f = applied_factors_[n];
    const int slot = solver_index_[n];
    if (slot < 0 || f.dim == 0) continue;  // removed, or no measurement
    SLAMD_CHECK(position[slot] >= 0) << "applied measurement on a removed factor";
    const auto& [type, a, b, kind] = f.id;
    state.applied.push_back({type, a, b, kind, position[slot], f.first, f.dim});
  }
  for (std::uint8_t id : registry_.ids()) {
    const RobotState& r = robots_[id];
    state.robots.push_back({registry_.Name(id), id, r.anchored, r.newest, r.measurement_utime,
                            r.published, r.published_index, r.moved_sequence});
  }
  for (const Held& h : held_) state.held.push_back({h.message, h.waited});
  state.counters = counters_;
  state.num_factors = num_factors_;
  state.residual_dimension = residual_dimension_;
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
    RobotState& s = e->robots_[*id];
    s.anchored = r.anchored;
    s.newest = r.newest;
    s.measurement_utime = r.measurement_utime;
    s.published = r.published;
    s.published_index = r.published_index;
    s.moved_sequence = r.moved_sequence;
  }
  e->applied_factors_.resize(state.factors.size());  // the state's factor i is number i
  for (const EstimatorState::Applied& a : state.applied) {
    if (a.factor < 0 || a.factor >= static_cast<int>(state.factors.size())) {
      return core::DataLoss("snapshot: applied measurement names factor " +
                            std::to_string(a.factor) + " of " +
                            std::to_string(state.factors.size()));
    }
    if (a.dim <= 0 || e->applied_factors_[a.factor].dim != 0) {
      return core::DataLoss("snapshot: applied measurement on factor " + std::to_string(a.factor) +
                            " has dimension " + std::to_string(a.dim) +
                            " or is not the only one on it");
    }
    const MeasurementId id{a.type, a.a, a.b, a.kind};
    e->applied_[id] = a.factor;
    e->applied_factors_[a.factor] = {id, a.first, a.dim};
  }
  // An anchored robot's newest pose is read after every update: it must be in the graph.
  for (const EstimatorState::Robot& r : state.robots) {
    if (!r.anchored) continue;
    if (r.newest > core::kMaxKeyIndex ||
        !state.linearization_point.Contains(MakeKey('x', r.newest, r.id))) {
      return core::DataLoss("snapshot: robot '" + r.name + "' is anchored but its newest pose " +
                            std::to_string(r.newest) + " is not in the graph");
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
  e->solver_index_.resize(state.factors.size());  // the state's factor i is the solver's i
  std::iota(e->solver_index_.begin(), e->solver_index_.end(), 0);
  for (const EstimatorState::HeldMessage& h : state.held) e->held_.push_back({h.message, h.waited});
  e->counters_ = state.counters;
  e->sequence_ = state.update_sequence;
  e->num_factors_ = state.num_factors;
  e->residual_dimension_ = state.residual_dimension;
  e->settled_ = false;
  e->snapshot_.reset();
  e->PublishSnapshot(false);
  return e;
}

std::optional<Key> Estimator::KeyOf(const WireKey& key) const {
  const auto id = registry_.Find(key.robot);
  if (!id || key.index > core::kMaxKeyIndex) return std::nullopt;
  const Key k = MakeKey(key.kind == KeyKind::kPose ? 'x' : 'l', key.index, *id);
  if (!isam_->linearization_point().Contains(k)) return std::nullopt;
  return k;
}

core::Status Estimator::Marginal(Key key, Eigen::MatrixXd* cov) {
  return marginals_->Marginal(key, core::Isam2Marginals::Frame::kEstimate, cov);
}

core::Status Estimator::JointMarginal(std::span<const Key> keys, Eigen::MatrixXd* cov) {
  return marginals_->JointMarginal(keys, core::Isam2Marginals::Frame::kEstimate, cov);
}

void Estimator::ComputeAllMarginals() { marginals_->ComputeAll(); }

core::Status Estimator::CachedMarginal(Key key, Eigen::MatrixXd* cov) const {
  return marginals_->CachedMarginal(key, core::Isam2Marginals::Frame::kEstimate, cov);
}

void Estimator::PublishSnapshot(bool bump) {
  if (bump) ++sequence_;
  auto snap = std::make_shared<EstimateSnapshot>();
  snap->update_sequence = sequence_;
  snap->num_variables = static_cast<std::int64_t>(isam_->linearization_point().size());
  snap->num_factors = num_factors_;
  snap->residual_dimension = residual_dimension_;
  snap->held_messages = static_cast<int>(held_.size());
  snap->settled = settled_;
  // chi2 is O(factors): after every update it would dominate a long run's update time. It is
  // recomputed at most every chi2_interval_s and at most 2% of the time, and whenever the
  // estimate settles; a swapped-in rebuild brings one computed on its helper thread.
  constexpr double kChi2MaxLoad = 0.02;
  const auto now = std::chrono::steady_clock::now();
  const double since = std::chrono::duration<double>(now - chi2_time_).count();
  const double interval = params_.chi2_interval_s;
  const bool due = since >= interval && (interval == 0.0 || since * kChi2MaxLoad >= chi2_cost_s_);
  const bool solved = !isam_->back_substitution_pending();  // chi2 needs all of δ
  if (solved && (chi2_sequence_ < 0 || (chi2_sequence_ != sequence_ && (due || settled_)))) {
    chi2_ = isam_->Chi2();
    chi2_sequence_ = sequence_;
    chi2_time_ = std::chrono::steady_clock::now();
    chi2_cost_s_ = std::chrono::duration<double>(chi2_time_ - now).count();
  }
  snap->chi2 = chi2_;
  snap->chi2_sequence = chi2_sequence_;
  for (std::uint8_t id : registry_.ids()) {
    RobotState& r = robots_[id];
    if (!r.anchored) continue;
    if (bump) {
      const Variable pose = isam_->CalculateEstimate(MakeKey('x', r.newest, id));
      const bool moved = r.moved_sequence == 0 || r.published_index != r.newest ||
                         pose.index() != r.published.index() ||
                         core::LocalCoordinates(r.published, pose).squaredNorm() > 0.0;
      if (moved) {
        r.published = pose;
        r.published_index = r.newest;
        r.moved_sequence = sequence_;
      }
    }
    if (r.moved_sequence == 0) continue;  // anchored by a batch that failed or not updated yet
    snap->robots.push_back({registry_.Name(id), id, r.published_index, r.published,
                            r.moved_sequence, r.measurement_utime, r.received_us});
  }
  snap->counters = counters_;
  snapshot_ = std::move(snap);
}

}  // namespace slamd::server
