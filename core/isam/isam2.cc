// Isam2::Update as numbered steps after Kaess et al. (IJRR 2012), Alg. 2-7; the helpers are in
// isam2_steps.cc.
#include "core/isam/isam2.h"

#include <algorithm>
#include <cmath>

#include "core/base/timing.h"
#include "core/isam/dogleg.h"

namespace slamd::core {

Result<std::unique_ptr<Isam2>> Isam2::Create(const Isam2Params& params) {
  SLAMD_RETURN_IF_ERROR(params.Validate());
  return std::unique_ptr<Isam2>(new Isam2(params));
}

Isam2::Isam2(const Isam2Params& params)
    : params_(params),
      offsets_{0},
      radius_(params.trust_region.initial_radius),
      eliminator_(params.elimination, params.threads),
      relin_pool_(params.threads - 1) {
  for (int t = 0; t < kNumVariableTypes; ++t) {
    const std::span<const EntryKind> kinds = EntryKinds(static_cast<VariableType>(t));
    int begin = static_cast<int>(kinds.size());
    while (begin > 0 && kinds[begin - 1] == EntryKind::kRotation) --begin;
    for (int k = 0; k < begin; ++k) {
      SLAMD_CHECK(kinds[k] != EntryKind::kRotation)
          << VariableTypeName(static_cast<VariableType>(t)) << ": rotation entries must be last";
    }
    rotation_begin_[t] = begin < static_cast<int>(kinds.size()) ? begin : -1;
  }
}

Isam2Result Isam2::Update(const FactorGraph& new_factors, const Values& new_values,
                          const Isam2UpdateOptions& options) {
  return UpdateWith(new_factors, new_values, options, params_.relinearization,
                    params_.wildfire_threshold);
}

Isam2::RefineResult Isam2::Refine(double budget_s, int max_rounds) {
  Stopwatch timer;
  RefineResult out;
  const Isam2Params::Relinearization fine{
      .rotation_threshold = params_.refine_threshold,
      .translation_threshold = params_.refine_threshold,
      .calibration_threshold = params_.refine_threshold,
      .other_threshold = params_.refine_threshold,
      .error_threshold = params_.relinearization.error_threshold,
      .skip = 1,
      .max_variables = params_.refine_max_variables};
  while (out.rounds < max_rounds && timer.Seconds() < budget_s) {
    const Isam2Result r = UpdateWith({}, {}, {.force_relinearize = true}, fine,
                                     kRefineWildfire * params_.refine_threshold);
    --num_updates_;  // refinement rounds are not updates (the skip and batch counters ignore them)
    ++out.rounds;
    out.status = r.status;
    out.relinearized_variables += r.relinearized_variables;
    if (!r.status.ok()) break;
    if (r.relinearized_variables == 0) {
      out.converged = true;
      break;
    }
  }
  out.seconds = timer.Seconds();
  return out;
}

Isam2Result Isam2::UpdateWith(const FactorGraph& new_factors, const Values& new_values,
                              const Isam2UpdateOptions& options,
                              const Isam2Params::Relinearization& relinearization,
                              double wildfire_threshold) {
  CheckNoPendingSolve("Update");
  Stopwatch total, phase;
  Isam2Result result;
  // 0. Validate everything before changing anything.
  result.status = CheckInput(new_factors, new_values, options);
  if (!result.status.ok()) return result;
  undo_.Clear(static_cast<int>(theta_.size()), static_cast<int>(factors_.size()));

  // 1. Add the new variables (θ = the initial guess, δ = 0).
  AddVariables(new_values);
  result.new_variables = static_cast<int>(new_values.size());
  // 2. Add the new factors, linearised at θ; their variables are affected, and are ordered last.
  std::vector<int> affected, last;
  result.status = AddFactors(new_factors, &result.new_factor_indices);
  for (int f : result.new_factor_indices) {
    for (int v : linearized_[f].vars()) last.push_back(v);
  }
  affected = last;
  if (!options.order_last.empty()) {
    last.clear();
    for (Key key : options.order_last) last.push_back(theta_.SlotOf(key));
  }
  // Removed factors: their variables are affected (their cliques hold the factor).
  RemoveFactors(options.remove_factors, &affected);
  for (Key key : options.extra_reeliminate) affected.push_back(theta_.SlotOf(key));
  result.seconds.add = phase.Lap();

  // 3. Fluid relinearisation (Alg. 6): every `skip` updates, relinearise the variables whose δ
  // exceeds the threshold, and every factor on them; the batch step relinearises everything.
  ++num_updates_;
  const bool batch =
      options.force_full || (params_.batch_every > 0 && num_updates_ % params_.batch_every == 0);
  result.batch_step = batch;
  const bool check = !options.skip_relinearization &&
                     (options.force_relinearize || relinearization_backlog_ ||
                      num_updates_ % relinearization.skip == 0);
  if (result.status.ok() && (batch || check)) {
    std::vector<int> relin;
    // Capped by max_variables or deferred: what is left is checked at the next update, not
    // `skip` later.
    const int due =
        SelectRelinearization(options, batch, relinearization, &relin, &result.screened_variables);
    if (!batch && options.defer_relinearization_above > 0 &&
        due > options.defer_relinearization_above) {
      result.relinearization_deferred = due;
      relin.clear();
    }
    relinearization_backlog_ = due > static_cast<int>(relin.size());
    result.relinearized_variables = static_cast<int>(relin.size());
    Relinearize(relin, &affected, &result.relinearized_factors);
  }
  if (batch) {
    affected.resize(theta_.size());
    for (int v = 0; v < static_cast<int>(theta_.size()); ++v) affected[v] = v;
    last.clear();  // a fresh, unconstrained ordering
  }
  result.seconds.relinearize = phase.Lap();

  // 4-7. Remove the top of the tree touched by the affected variables (Alg. 4/5), re-eliminate it
  // with the orphans' cached factors in a constrained order (newest last) and re-attach the
  // orphans (Alg. 3).
  std::vector<int> new_cliques;
  if (result.status.ok()) result.status = ReEliminate(affected, last, &new_cliques, &result);
  phase.Lap();  // ReEliminate timed its own steps
  // A failure before step 7 leaves step 3's threads running: they must stop before Rollback.
  const Status relinearized = FinishRelinearization();
  if (result.status.ok()) result.status = relinearized;
  if (!result.status.ok()) {
    Rollback();
    --num_updates_;
    result.new_factor_indices.clear();
    result.seconds.total = total.Seconds();
    return result;
  }
  ReleaseRemoved();

  // 8. Partial back-substitution (Alg. 7, "wildfire") from the new cliques down; all of it for
  // the trust region, whose step is measured on the whole of δ.
  const bool trust_region = params_.trust_region.enabled;
  // The dog leg's start: the estimate before this update, where every δ is within its threshold
  // (the check ran and left nothing due), so that the model linearised at θ holds there too.
  if (trust_region && check && !relinearization_backlog_) {
    start_ = delta_.head(offsets_.back());
  } else {
    start_.resize(0);
  }
  result.solved_cliques =
      BackSubstitute(new_cliques, options.force_full_solve || batch || trust_region,
                     wildfire_threshold, trust_region ? std::vector<Key>{} : options.solve_first);
  result.seconds.solve = phase.Lap();
  // 9. Trust region: the dog leg in place of the Gauss-Newton step.
  if (trust_region) {
    result.trust_region = TrustRegionStep();
    result.seconds.trust_region = phase.Lap();
  }
  result.seconds.total = total.Seconds();
  return result;
}

int Isam2::FinishBackSubstitution() {
  if (!wildfire_.in_pass) return 0;
  solved_first_.clear();
  return WildfireFinish(tree_, offsets_, &delta_, &wildfire_);
}

void Isam2::CheckSolvedFirst(int slot) const {
  SLAMD_CHECK(std::find(solved_first_.begin(), solved_first_.end(), slot) != solved_first_.end())
      << "Isam2: δ of " << KeyToString(theta_.KeyAt(slot))
      << " read before FinishBackSubstitution (only the solve_first keys are solved)";
}

void Isam2::CheckNoPendingSolve(const char* what) const {
  SLAMD_CHECK(!wildfire_.in_pass) << "Isam2::" << what
                                  << " while a back-substitution is pending (solve_first): "
                                     "call FinishBackSubstitution first";
}

Values Isam2::CalculateEstimate() const {
  CheckNoPendingSolve("CalculateEstimate");
  return RetractedBy(delta_);
}

Values Isam2::RetractedBy(const Eigen::VectorXd& step) const {
  Values out = theta_;
  for (int v = 0; v < static_cast<int>(out.size()); ++v) {
    RetractInPlace(&out.MutableVariableAt(v), step.data() + offsets_[v]);
  }
  return out;
}

Variable Isam2::CalculateEstimate(Key key) const {
  const int v = theta_.SlotOf(key);
  SLAMD_CHECK(v >= 0) << "no variable named " << KeyToString(key);
  Variable x = theta_.VariableAt(v);
  RetractInPlace(&x, Delta(v));
  return x;
}

FactorGraph Isam2::Factors() const {
  FactorGraph graph;
  for (const FactorPtr& f : factors_) {
    if (f) graph.Add(f);
  }
  return graph;
}

double Isam2::Chi2() const {
  CheckNoPendingSolve("Chi2");
  // No copy of the factor graph: one pass over the live factors.
  const Values at = RetractedBy(delta_);
  double chi2 = 0.0;
  for (const FactorPtr& f : factors_) {
    if (f) chi2 += f->Chi2(at);
  }
  return chi2;
}

double Isam2::CostAt(const Eigen::VectorXd* step) {
  Values retracted;
  const Values& at = step != nullptr ? (retracted = RetractedBy(*step)) : theta_;
  return costs_.Sum(
      at, factors_, [this](int f) { return FactorVars(f); }, &relin_pool_);
}

Isam2Result::TrustRegion Isam2::TrustRegionStep() {
  Isam2Result::TrustRegion out;
  const int n = offsets_.back();
  const TopDownCliques cliques(tree_);  // for every sum over cliques below
  const Isam2Params::TrustRegion& p = params_.trust_region;
  // The dog leg from θ ⊕ start (start in δ's layout, or null for θ itself), judged against the
  // cost there; false when it found no step down. δ holds the Gauss-Newton step until a step is
  // taken.
  const auto search = [&](const Eigen::VectorXd* start) {
    gauss_newton_ = delta_.head(n);
    if (start != nullptr) gauss_newton_ -= *start;
    const Eigen::VectorXd& gauss_newton = gauss_newton_;
    TreeGradient(cliques, offsets_, start, &gradient_, &dogleg_scratch_);
    const double g2 = gradient_.squaredNorm();
    // Every step below is α δ_gn + β g: one pass gives the model's terms of all of them.
    const TreeModelPair model =
        ModelTermsOfPair(cliques, offsets_, start, gauss_newton, gradient_, &dogleg_scratch_);
    const double rg2 = model.bb;
    const double gain = model.Of(1.0, 0.0).Decrease();
    const double cost_start = CostAt(start);
    // The start at the model's minimum (g = 0), or nothing to gain beyond round-off: the
    // Gauss-Newton step, unjudged, since round-off would decide the comparison and shrink the
    // radius for nothing.
    if (!(g2 > 0.0) || !(rg2 > 0.0) || !(gain > kNegligibleDecrease * (1.0 + cost_start))) {
      out.gauss_newton = true;
      return true;
    }
    const double to_cauchy = g2 / rg2;
    cauchy_ = to_cauchy * gradient_;
    while (true) {
      const DoglegWeights w = DoglegPoint(gauss_newton, cauchy_, radius_, &step_);
      ++out.attempts;
      const double predicted = model.Of(w.on_gauss_newton, w.on_cauchy * to_cauchy).Decrease();
      const double step_norm = step_.norm();
      if (start != nullptr) step_ += *start;
      const double actual = cost_start - CostAt(&step_);
      const double rho = predicted > 0.0 ? actual / predicted : -1.0;
      // Powell's rule (Nocedal & Wright, Alg. 4.1): grow on a good prediction at the boundary,
      // shrink on a poor one (a NaN ratio too, so that the loop ends).
      if (rho > 0.75 && step_norm >= 0.99 * radius_) {
        radius_ *= 2.0;
      } else if (!(rho >= 0.25)) {
        radius_ = 0.25 * std::min(radius_, step_norm);
      }
      if (std::isfinite(actual) && actual > 0.0 && rho > 0.0) {
        out.gauss_newton = step_norm == gauss_newton.norm();
        delta_.head(n) = step_;
        return true;
      }
      if (radius_ < p.min_radius) {  // no decrease found: afresh next time
        radius_ = p.initial_radius;
        return false;
      }
    }
  };
  // From the estimate before the update where UpdateWith gave one (start_), so that the update
  // does not end above it: the variables within their relinearisation thresholds keep a δ that θ
  // lacks, and θ's cost can be far above the estimate's (Ladybug replayed camera by camera,
  // calibrations refined: 10-100x), so that a step judged against θ's cost can leave the estimate
  // far above where it was. Where the model finds no step down there, from θ, where it is exact;
  // failing that too, the start (or θ) stays.
  const bool from_start = start_.size() == n && start_.squaredNorm() > 0.0;
  if (!(from_start && search(&start_)) && !search(nullptr)) {
    if (from_start) {
      delta_.head(n) = start_;
    } else {
      delta_.head(n).setZero();
    }
  }
  out.radius = radius_;
  return out;
}

}  // namespace slamd::core
