// Estimator: turns validated measurements into factors and initial guesses for core::Isam2, each
// by its message spec's Apply (server/messages/<type>.h) over the batch it stages (the
// GraphBuilder, Estimator::Builder), with the stateful checks the stateless validation cannot
// make. The only owner of the solver; called on the estimator thread only, not thread-safe (its
// helpers: BackgroundRebuild's thread, and one that frees a replaced solver).
//
// Keys: pose i of robot r = MakeKey('x', i, id(r)), landmark j of robot r = MakeKey('l', j, id(r))
// or, of the map all robots share, MakeKey('m', j, 0) (ids from RobotRegistry). Initial
// guesses: a new pose = estimate(from) ∘ odometry (or estimate(to) ∘ odometry⁻¹ when only the
// to-pose is known: a robot connected mid-trajectory, or estimate(a) ∘ z for a loop closure that
// connects an unanchored robot); a new landmark is placed by its first observation from the
// observing pose's estimate; a pose prior places its pose.
//
// Process(batch) applies every message it can, in order, then runs ONE Isam2::Update for all of
// them (coalescing). Per message, one of:
//   applied   factors (and variables) added to the update;
//   held      it needs a pose that may still come: odometry neither of whose poses is known yet
//             (pose index ahead of the next expected, or a robot not anchored under
//             kHoldUntilConnected), a landmark observation or prior on an unknown pose, a loop
//             closure to a pose beyond its robot's newest (the other side known or ahead too). Held
//             messages are retried whenever a pose is added (in the same batch too); a message
//             held for more than max_hold_updates Process calls, or the oldest beyond
//             max_held_messages, is rejected with kOutOfOrderTimeout;
//   already held: the same measurement (type, variables, values, noise) as one applied before
//             (a robot re-sending after a restart): nothing changes; counted apart from rejections;
//             its robots listed so the daemon acknowledges it with their estimates;
//   rejected  with a Verdict: kDuplicate (a different measurement of the same type between the
//             same variables as one applied before), kUnknownRobot / kUnknownPose (loop closure to
//             a robot not in the graph or a pose at or before its robot's newest that is not,
//             unless it connects an unanchored robot),
//             kBadMeasurement (2D measurement on a 3D pose or vice versa; the solver refused the
//             update: then every message applied in this batch is rejected and the estimator's
//             state is unchanged), kTooManyElements (more than 255 robots).
// A RemoveFactorRequest splits the batch: the measurements before it go into one update, the
// removal into its own (so a removal the solver refuses, kWouldDisconnect, rejects nothing
// else), the rest into the next. It names an applied measurement by its identifying fields
// (msgs/lcm/remove_factor_t.lcm); none matching is kUnknownFactor. A removed measurement may be
// sent again. Origin anchors (kAnchorAtOrigin) cannot be removed.
//
// Background relinearisation swaps in a rebuilt solver (background_rebuild.h); the reduced pose
// graph holds new poses in a mapped area as aliases of nodes (reduced_graph.h), the lifelong
// window recently removed ones as aliases of keyframes (pose_window.h).
//
// Exactness: with refinement and background relinearisation off, each Process call is exactly one
// Isam2::Update of the factors in message order and the values in creation order, so feeding the
// messages of one dataset step per Process call reproduces an offline Isam2 run fed those steps
// (PrepareStep) bit for bit. Coalescing k odometry messages into one call equals k lock-step calls
// when none of the coalesced messages but the last closes a loop and relinearization.skip == 1 (the
// initial guesses then equal the lock-step estimates: a chain's update does not move its poses), up
// to rounding (tested to 1e-9).
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "core/isam/isam2.h"
#include "core/marginals/marginals.h"
#include "server/estimator/background_rebuild.h"
#include "server/estimator/estimator_params.h"
#include "server/estimator/factor_numbers.h"
#include "server/estimator/pose_window.h"
#include "server/estimator/process_result.h"
#include "server/estimator/reduced_graph.h"
#include "server/estimator/robot_registry.h"
#include "server/estimator/shard_boundary.h"
#include "server/messages/inbound.h"
#include "server/messages/landmark_tracks.h"
#include "server/snapshot/estimate_snapshot.h"
#include "server/snapshot/estimator_state.h"

namespace slamd::server {

class Estimator {
 public:
  // InvalidArgument when a params struct does not validate.
  static core::Result<std::unique_ptr<Estimator>> Create(const EstimatorParams& params,
                                                         const core::Isam2Params& isam2);

  // Rejects every held message (kOutOfOrderTimeout with `why`): at shutdown without a journal,
  // so that no message is left unanswered. Counted like other rejections.
  std::vector<Rejection> RejectHeld(const std::string& why);

  // An estimator rebuilt from a state exported by ExportState (a snapshot): the factors are
  // eliminated in one batch at the state's linearisation point, so the estimate is re-solved
  // there (equal to the exported one up to the partial back-substitution's tolerance). DataLoss
  // naming what is inconsistent (a factor index out of range, a robot id out of order, ...).
  static core::Result<std::unique_ptr<Estimator>> Restore(const EstimatorParams& params,
                                                          const core::Isam2Params& isam2,
                                                          const EstimatorState& state);
  const EstimatorParams& params() const { return params_; }
  // Everything needed to Restore this estimator; O(variables + factors), no solver work.
  EstimatorState ExportState() const;
  // Applies `batch` (see the file comment) with one Isam2::Update; publishes a new snapshot.
  // With `finish_later`, the update's back-substitution stops once every robot's newest pose
  // is solved (Isam2UpdateOptions::solve_first; a robot's newest pose is what estimate_t
  // carries): the snapshot then holds the new poses and Marginal() answers for them, and
  // FinishUpdate() must come before any other call.
  ProcessResult Process(std::vector<Inbound> batch, bool finish_later = false);
  // The rest of what Process(batch, true) left (the back-substitution of the rest of the map,
  // the snapshot's chi2 when due, starting a rebuild); no-op when nothing is left.
  void FinishUpdate();

  // Background relinearisation (file comment): in flight / done and waiting for FinishRebuild.
  bool Rebuilding() const { return rebuild_ != nullptr; }
  bool RebuildReady() const { return rebuild_ && rebuild_->Ready(); }
  // Waits for the rebuild in flight, brings it up to date and swaps it in (a new snapshot); false
  // when none was in flight. A failed rebuild leaves the live solver (the next update
  // relinearises) and the status says why. `replay_rounds`: a replay's journaled catch-up rounds
  // of this swap, run here (SetReplaying); ignored when they name more updates than were logged.
  core::Result<bool> FinishRebuild(std::span<const int> replay_rounds = {});
  // The catch-up rounds of the last swap (logged updates per round), for the journal.
  const std::vector<int>& last_swap_rounds() const { return last_swap_rounds_; }
  void SetReplaying(bool replaying) { replaying_ = replaying; }  // no catch-up rounds on helpers

  // Lifelong window (EstimatorParams::window, pose_window.cc): when due and no rebuild is in
  // flight, removes old poses but keyframes by RemoveVariables; what it removed, for the journal.
  NodeRemovalRecord ApplyPoseWindow();
  // The window fell behind (a robot has more than half of its poses one to two windows back):
  // no rebuild starts, one in flight is to be hurried and swapped in. A function of the graph.
  bool WindowBehind() const;
  void HurryRebuild() { rebuild_->Hurry(); }
  // Node removal (Isam2::RemoveVariables) of what.keys in chunks at what.at (empty: θ), summary
  // trees rooted at what.roots (sorted) where they can be, removed poses then held as
  // what.aliases; FailedPrecondition while a rebuild is in flight. A chunk that fails leaves
  // those before it removed (*done: what was, as a record).
  core::Status RemoveVariables(const NodeRemovalRecord& what, NodeRemovalRecord* done = nullptr);

  // Isam2::Refine(budget_s, max_rounds); a new snapshot when anything moved. (While a rebuild is
  // in flight, the swap discards what it did: the daemon refines only when none is.)
  core::Isam2::RefineResult Refine(double budget_s,
                                   int max_rounds = std::numeric_limits<int>::max());

  // Map shards (estimator_shards.cc): its own factors' marginal on its boundary (shard_boundary.h)
  // less the summaries it received, for every other shard; nullopt when it shares nothing yet.
  core::Result<std::optional<ShardSummaryMessage>> ShardSummary(std::int64_t utime);

  std::shared_ptr<const EstimateSnapshot> snapshot() const { return snapshot_; }  // never null

  // The current estimate of pose `index` of `robot`, a node or an alias (NotFound otherwise).
  core::Result<core::Variable> PoseEstimate(const std::string& robot, std::uint64_t index) const;
  // The solver key of a wire key; nullopt when that variable is not in the graph.
  std::optional<core::Key> KeyOf(const WireKey& key) const;
  // Marginal covariances at the current estimate (tangent at θ ⊕ δ, translation first), from
  // the Bayes tree with a cache kept across updates (core/marginals). NotFound for unknown keys.
  core::Status Marginal(core::Key key, Eigen::MatrixXd* cov);
  core::Status JointMarginal(std::span<const core::Key> keys, Eigen::MatrixXd* cov);
  // Every clique's marginal once: CachedMarginal is O(1) then, until the next update.
  void ComputeAllMarginals();
  core::Status CachedMarginal(core::Key key, Eigen::MatrixXd* cov) const;
  const RobotRegistry& registry() const { return registry_; }
  const core::Isam2& solver() const { return *isam_; }
  int held_messages() const { return static_cast<int>(held_.size()); }
  std::size_t factor_numbers() const { return numbers_.size(); }  // used + free: largest size
  const CameraTable& cameras() const { return cameras_; }         // camera_info_t
  const LandmarkTracks& tracks() const { return tracks_; }        // landmarks not determined yet

  ~Estimator();  // waits for a rebuild in flight

 private:
  Estimator(const EstimatorParams& params, std::unique_ptr<core::Isam2> isam);

  struct Held {  // a message waiting for a pose, and the Process calls it has waited through
    Inbound message;
    int waited = 0;
  };
  // What one batch adds; committed only when the update succeeds.
  struct Staged {
    core::FactorGraph factors;
    core::Values values;
    std::set<MeasurementId> seen;
    // (position in `factors`, id, first key) of each measured (removable) factor.
    std::vector<std::tuple<size_t, MeasurementId, core::Key>> ids;
    std::optional<MeasurementId> pending_id;  // set by FirstTime, taken by AddMeasured
    // Set by FirstTime when that identity is applied or staged already: the factor it has,
    // or the digest of the merged measurement it has (ReducedGraphState::merged).
    core::FactorPtr pending_existing;
    std::optional<std::uint64_t> pending_digest;
    std::vector<std::pair<std::uint8_t, RobotState>> robots_before;  // for rollback
    std::vector<Rejection> parts;  // rejected parts of messages (GraphBuilder::RejectPart)
    // Applied numbers of the factors it replaces (GraphBuilder::AddReplacing: a shard's
    // summary by its next one).
    std::vector<int> replaced;
    ReducedGraphStage reduced;
  };

  // The GraphBuilder a message's spec applies itself to: this estimator's state and batch `s`.
  class Builder;
  Outcome Apply(const Inbound& in, Staged* staged, Verdict* verdict);
  bool Known(core::Key key, const Staged& s) const;
  core::Variable Estimate(core::Key key, const Staged& s) const;
  // GraphBuilder's FirstTime, AddMeasured and AddReplacing (message_spec.h) on batch `s`.
  void FirstTime(const MeasurementId& id, Staged* s);
  Outcome AddMeasured(core::FactorPtr factor, core::Key first, const char* what, Staged* s,
                      Verdict* v);
  Outcome AddReplacing(core::FactorPtr factor, core::Key first, Staged* s);
  RobotState& Robot(std::uint8_t id, Staged* s);  // remembers its old state for rollback
  void ApplyBatch(std::vector<Inbound> batch, ProcessResult* result);
  void Remove(const Inbound& in, ProcessResult* result);
  void AddPose(std::uint8_t robot, std::uint64_t index, const core::Variable& value,
               const Inbound& in, Staged* s);
  void Touch(std::uint8_t robot, const Inbound& in, Staged* s);
  void Reject(const Inbound& in, RejectReason reason, std::string message, ProcessResult* result);
  // The batch stands: keeps its cameras and track changes, ages the landmark tracks by one
  // update and rejects those dropped (never determined).
  void CommitCamerasAndTracks(ProcessResult* result);
  void PublishSnapshot(bool bump);
  core::Isam2UpdateOptions UpdateOptions() const;  // of every update from messages (deferral)
  // After an update and its whole back-substitution: starts a rebuild for what it deferred.
  void AfterUpdate(int relinearization_deferred);
  // AfterUpdate now, or in FinishUpdate when the update left part of its back-substitution.
  void AfterUpdateOnceSolved(int relinearization_deferred);
  // Options for an update of Process: solve_first when it may finish later.
  core::Isam2UpdateOptions ProcessUpdateOptions() const;
  void StartRebuild();
  PoseWindowPlan WindowPlan() const;  // pose_window.h
  // The aliases of the plan's removed poses within keep_aliases (sorted; from the marginals).
  std::vector<std::pair<core::Key, PoseAlias>> WindowAliases(const PoseWindowPlan& plan);
  // RemoveVariables' steps; adds what it removed to *done (the roots a blanket held too).
  core::Status RemoveChunk(std::span<const core::Key> keys, const NodeRemovalRecord& what,
                           NodeRemovalRecord* done);
  void ForgetAliases(std::uint8_t robot, std::uint64_t before);  // and what was merged on them
  // Reduced pose graph (estimator_reduced.cc): a robot's policy (nullptr: off); a pose's alias
  // (staged or committed; nullptr for a node or unknown pose) and its estimate (anchor ∘ offset).
  const EstimatorParams::ReducedGraph* ReducedFor(std::uint8_t robot) const;
  const PoseAlias* FindAlias(core::Key pose, const Staged& s) const;
  core::Variable AliasEstimate(const PoseAlias& alias, const Staged* s = nullptr) const;
  // AddMeasured of a factor that places a pending pose or names an alias (reduced_graph.h).
  Outcome AddReduced(core::FactorPtr factor, core::Key first, const MeasurementId& id, Staged* s,
                     Verdict* v);
  // Stages a composed factor on (a, b) (kind 0: relative pose, 1: point in a's frame), unless
  // the pair has one of that kind (robust and Gaussian ones apart) or, with !link, b is a
  // landmark in the map: then the measurement is left out (counted). False when its covariance
  // is unusable.
  bool AddComposed(core::Key a, core::Key b, int kind, const ComposedMeasurement& m,
                   const core::RobustKernel& robust, Staged* s, bool link = true);
  bool Promote(core::Key pose, Staged* s);  // the robot's newest pose, an alias, made a node
  bool NearNode(const core::Variable& at, const EstimatorParams::ReducedGraph& policy,
                const Staged& s) const;
  // After a successful update: the batch's aliases and merged measurements; forgets aliases
  // beyond each robot's keep_aliases (and the merged measurements that named them).
  void CommitReduced(Staged* s);
  // The newest pose of every anchored robot (its anchor when an alias): what updates touch next.
  std::vector<core::Key> NewestPoses(const Staged* s = nullptr) const;
  // Logs a successful live update for the rebuild in flight (if any).
  void LogForRebuild(const core::FactorGraph& factors, const core::Values& values,
                     const core::Isam2Result& update, std::span<const int> removed);

  EstimatorParams params_;
  MeasurementPolicy policy_;  // from params_
  std::unique_ptr<core::Isam2> isam_;
  RobotRegistry registry_;
  RobotState robots_[256];
  // Applied (not removed) measurements -> their factor number in numbers_.
  std::map<MeasurementId, int> applied_;
  // Per factor number: the measurement and its solver slot. A table, so that a snapshot's
  // export walks it in one pass (walking the map took 75-140 ms at 375k factors in the soak).
  FactorNumbers numbers_;
  int marginals_threads_;  // Isam2Params::threads as configured (a rebuilt solver has 1)
  std::unique_ptr<core::Isam2Marginals> marginals_;
  std::unique_ptr<BackgroundRebuild> rebuild_;
  bool relinearize_inline_ = false;  // the last rebuild failed or none could start: inline
  std::thread retire_thread_;        // frees the solver a rebuild replaced
  std::vector<int> last_swap_rounds_;
  bool replaying_ = false;  // SetReplaying
  // Process(batch, true) is running (its updates may finish later); what the update left for
  // FinishUpdate reported as deferred relinearisation (AfterUpdate's argument).
  bool finish_later_ = false;
  int pending_deferred_ = 0;
  std::deque<Held> held_;
  CameraTable cameras_;
  LandmarkTracks tracks_;
  EstimatorCounters counters_;
  mutable ReducedGraphState reduced_;  // NearNode rebuilds its grid
  std::int64_t sequence_ = 0;
  std::int64_t window_sequence_ = 0;  // the update sequence the window last ran at
  // The last pass stopped at its bound with poses left: the next update runs a pass too.
  bool window_unfinished_ = false;
  ShardBoundary shard_boundary_{params_.shards, registry_};  // what ShardSummary is on
  std::int64_t num_factors_ = 0;
  std::int64_t residual_dimension_ = 0;
  bool settled_ = true;
  std::shared_ptr<const EstimateSnapshot> snapshot_;
  double chi2_ = 0.0;                // the latest status chi2, here or from a rebuild
  std::int64_t chi2_sequence_ = -1;  // its update sequence (-1: none yet)
  std::chrono::steady_clock::time_point chi2_time_;  // when chi2_ was last computed
  double chi2_cost_s_ = 0.0;                         // how long computing it here took [s]
};

}  // namespace slamd::server
