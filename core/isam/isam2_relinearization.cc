// The relinearisation steps of Isam2::Update (isam2.cc): which variables to relinearise (their δ
// over the thresholds, or a factor's linearisation error over error_threshold, screened by each
// factor's measured curvature), and relinearising them on the solver's threads.
#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_set>

#include "core/isam/isam2.h"

namespace slamd::core {

int Isam2::SelectRelinearization(const Isam2UpdateOptions& options, bool all,
                                 const Isam2Params::Relinearization& thresholds,
                                 std::vector<int>* relin, int* screened) {
  const int n = static_cast<int>(theta_.size());
  std::unordered_set<int> frozen;
  for (Key key : options.no_relinearize) frozen.insert(theta_.SlotOf(key));
  // Each entry's threshold by variable type (Relinearization::ThresholdOf).
  std::array<std::array<double, kMaxVariableDim>, kNumVariableTypes> threshold{};
  for (int t = 0; t < kNumVariableTypes; ++t) {
    const std::span<const EntryKind> kinds = EntryKinds(static_cast<VariableType>(t));
    for (std::size_t k = 0; k < kinds.size(); ++k) {
      threshold[t][k] = thresholds.ThresholdOf(static_cast<VariableType>(t), kinds[k]);
    }
  }
  // Each variable's largest |δ entry| / threshold; > 1 means over the threshold.
  const double error_threshold = all ? 0.0 : thresholds.error_threshold;
  const double budget_unit = kStaleScreen * error_threshold;
  ratio_.resize(n);
  step_norms_.resize(n);
  over_budget_.clear();
  for (int v = 0; v < n; ++v) {
    const double* d = delta_.data() + offsets_[v];
    double ratio = 0.0, norm2 = 0.0, rotation2 = 0.0;
    const int type = static_cast<int>(var_types_[v]);
    const int rotation_begin = rotation_begin_[type] >= 0 ? rotation_begin_[type] : dims_[v];
    const double* entry_threshold = threshold[type].data();
    for (int k = 0; k < dims_[v]; ++k) {
      const bool rotation = k >= rotation_begin;
      ratio = std::max(ratio, std::abs(d[k]) / entry_threshold[k]);
      norm2 += d[k] * d[k];
      rotation2 += rotation ? d[k] * d[k] : 0.0;
    }
    // A frozen variable is not relinearised for its δ (FindStaleLinearizations reads this).
    ratio_[v] = frozen.empty() || !frozen.count(v) ? ratio : 0.0;
    if (error_threshold > 0.0 && norm2 > budget_unit * budget_[v] && norm2 != screened_norm2_[v]) {
      over_budget_.push_back(v);
      step_norms_[v] = {norm2, rotation2};
    }
  }
  // Deferred by δ alone: the linearisation-error check would only add to what is deferred, and
  // costs evaluations of the factors of most variables when most of the map moves (up to 3 ms
  // per update on victoriaPark in slamd).
  const int defer_above = options.defer_relinearization_above;
  if (!all && defer_above > 0) {
    int due = 0;
    for (int v = 0; v < n; ++v) due += ratio_[v] > 1.0;  // a frozen variable's ratio_ is 0
    if (due > defer_above) return due;
  }
  // ... raised to linearisation error / error_threshold on the variables of stale factors.
  if (error_threshold > 0.0) FindStaleLinearizations(error_threshold);
  *screened = error_threshold > 0.0 ? static_cast<int>(over_budget_.size()) : 0;
  std::vector<std::pair<double, int>> over;
  for (int v = 0; v < n; ++v) {
    if ((all || ratio_[v] > 1.0) && !frozen.count(v)) over.emplace_back(ratio_[v], v);
  }
  const int due = static_cast<int>(over.size());
  const int limit = thresholds.max_variables;
  if (!all && limit > 0 && due > limit) {
    std::nth_element(over.begin(), over.begin() + limit, over.end(),
                     [](const auto& a, const auto& b) { return a.first > b.first; });
    over.resize(limit);
  }
  for (const auto& [ratio, v] : over) relin->push_back(v);
  return due;
}

// A variable within its budget costs nothing beyond the δ scan SelectRelinearization does
// anyway, and neither does one whose factors all passed at exactly its present δ
// (screened_norm2_). The budget is a sufficient condition, far tighter than the screen once loop
// closures have moved the map: without that second exemption a third of a 56k-pose map was
// walked at every check, and at ~127k variables in the soak each check took 15-25 ms.
// The prediction is a screen, not a bound: κ_f depends on the direction of δ_f (a rigid motion
// of a between factor's two poses costs no error at all), so a factor measured along one
// direction may be stale along another before it is evaluated again.
void Isam2::FindStaleLinearizations(double threshold) {
  // Candidates: the factors of the variables over budget, unless predicted well below the
  // threshold by their curvature. (Factors with a variable over the δ threshold are relinearised
  // anyway, but at that variable's new θ only: their other variables keep a δ whose
  // linearisation error still counts.)
  probe_factors_.clear();
  probe_sizes_.clear();
  screened_.clear();
  probe_mark_.resize(factors_.size(), 0);
  over_budget_mark_.resize(theta_.size(), 0);
  for (int v : over_budget_) over_budget_mark_[v] = 1;
  for (int v : over_budget_) {
    for (int f : variable_index_.FactorsOf(v)) {
      if (probe_mark_[f]) continue;
      probe_mark_[f] = 1;
      screened_.push_back(f);
      // Every variable of f over its δ threshold: f is relinearised at θ ⊕ δ in this update
      // (unless max_variables defers some, which are taken at the next), so its error there
      // would change nothing. The slowest steps relinearise most of the graph: this halves
      // their factor evaluations.
      bool all_over = true;
      for (int u : FactorVars(f)) {
        all_over = all_over && ratio_[u] > 1.0;
      }
      if (all_over) continue;
      const double size = StepSize(f);
      if (size == 0.0) continue;  // at θ itself the linearisation is exact
      if (curvature_[f] >= 0.0f && curvature_[f] * size <= kStaleScreen * threshold) continue;
      probe_factors_.push_back(f);
      probe_sizes_.push_back(size);
    }
  }
  for (int f : screened_) probe_mark_[f] = 0;  // all zero between uses
  for (int v : over_budget_) over_budget_mark_[v] = 0;
  if (!probe_factors_.empty()) ProbeLinearizations(threshold);
  for (int f : probe_factors_) probe_mark_[f] = 1;  // probed now (cleared below)
  // New budgets: with each of its k_f variables u at |δ_u|² ≤ unit x budget_u, a factor f has
  // κ_f·s_f ≤ κ_f·|δ_f|² ≤ unit (unit = kStaleScreen x threshold): it would pass the screen.
  // Unknown curvature: budget 0 (evaluate as soon as δ_v moves).
  for (int v : over_budget_) {
    double budget = std::numeric_limits<double>::infinity();
    bool screened = true;  // every factor of v passed the screen, none was probed
    for (int f : variable_index_.FactorsOf(v)) {
      const double kappa = curvature_[f];
      if (kappa < 0.0) {
        budget = 0.0;
        screened = false;
        break;
      }
      screened = screened && !probe_mark_[f];
      if (kappa > 0.0) budget = std::min(budget, 1.0 / (kappa * BudgetKeys(f)));
    }
    budget_[v] = budget;
    screened_norm2_[v] = screened ? step_norms_[v].first : -1.0;
  }
  for (int f : probe_factors_) probe_mark_[f] = 0;
  // A probe may have raised κ_f: the budgets of f's other variables (within their budgets, so
  // not renewed above) must shrink with it, or f could drift past the screen through them.
  for (int f : probe_factors_) {
    const double kappa = curvature_[f];
    if (kappa <= 0.0) continue;
    for (int u : FactorVars(f)) {
      budget_[u] = std::min(budget_[u], 1.0 / (kappa * BudgetKeys(f)));
    }
  }
}

double Isam2::StepSize(int f) const {
  // |δ_u|² and its rotation part for each variable u of f, from SelectRelinearization's scan
  // (step_norms_ holds them for the variables over budget; the others are read from δ).
  double all2 = 0.0, rotation2 = 0.0;
  bool poses_only = true;
  for (int u : FactorVars(f)) {
    const int rotation_begin = rotation_begin_[static_cast<int>(var_types_[u])];
    poses_only = poses_only && rotation_begin >= 0;
    if (over_budget_mark_[u]) {
      all2 += step_norms_[u].first;
      rotation2 += step_norms_[u].second;
      continue;
    }
    const double* d = delta_.data() + offsets_[u];
    for (int k = 0; k < dims_[u]; ++k) {
      all2 += d[k] * d[k];
      if (rotation_begin >= 0 && k >= rotation_begin) rotation2 += d[k] * d[k];
    }
  }
  return std::sqrt(all2 * (poses_only ? rotation2 : all2));
}

void Isam2::ProbeLinearizations(double threshold) {
  // A robust factor's cached linearisation is scaled by √w at θ (IRLS): the weight is taken
  // first, and the difference is measured unweighted, in sigmas as for any other factor (a
  // large residual has a small weight, but its linearisation error moves the cost as much).
  probe_weights_.assign(probe_factors_.size(), 1.0);
  for (std::size_t i = 0; i < probe_factors_.size(); ++i) {
    const Factor& factor = *factors_[probe_factors_[i]];
    if (factor.robust_kernel().is_none()) continue;
    probe_error_.resize(factor.dim());
    factor.EvaluateError(theta_, probe_error_.data());
    const double s = factor.noise_model().SquaredMahalanobis(
        Eigen::Map<const Eigen::VectorXd>(probe_error_.data(), factor.dim()));
    probe_weights_[i] = std::sqrt(factor.robust_kernel().Weight(s));
  }
  // Move θ to θ ⊕ δ on the probed variables (restored below; mark_ is all zero between uses).
  probe_vars_.clear();
  probe_saved_.clear();
  for (int f : probe_factors_) {
    for (int v : linearized_[f].vars()) {
      if (mark_[v]) continue;
      mark_[v] = 1;
      probe_vars_.push_back(v);
      probe_saved_.push_back(theta_.VariableAt(v));
      RetractInPlace(&theta_.MutableVariableAt(v), delta_.data() + offsets_[v]);
    }
  }
  for (std::size_t i = 0; i < probe_factors_.size(); ++i) {
    const JacobianFactor& linear = linearized_[probe_factors_[i]];
    const Factor& factor = *factors_[probe_factors_[i]];
    const int m = linear.rows();
    probe_error_.resize(2 * m);  // e, then d
    double* e = probe_error_.data();
    double* d = e + m;
    factor.EvaluateError(theta_, e);
    // d = √w·R·e − (b + A·δ), in plain loops: the blocks are a few rows, where Eigen's
    // dynamic-size kernels cost more in set-up than in arithmetic.
    factor.noise_model().Whiten(e, d);
    const double w = probe_weights_[i];
    const double* ab = linear.data();  // [A_0 ... A_{p-1} b], column-major, m rows
    for (int row = 0; row < m; ++row) {
      d[row] = w * d[row] - ab[static_cast<std::size_t>(linear.Dim()) * m + row];
    }
    for (int k = 0; k < linear.num_vars(); ++k) {
      const double* x = delta_.data() + offsets_[linear.var(k)];
      const double* a = ab + static_cast<std::size_t>(linear.offset(k)) * m;
      for (int col = 0; col < linear.dim(k); ++col, a += m) {
        for (int row = 0; row < m; ++row) d[row] -= a[row] * x[col];
      }
    }
    double norm2 = 0.0;
    for (int row = 0; row < m; ++row) norm2 += d[row] * d[row];
    // Weight 0 (a redescending kernel far out): the factor does not count at all.
    const double error = w > 0.0 ? std::sqrt(norm2) / w : 0.0;
    // κ from this evaluation; an error below the floor counts as the floor, so that a factor
    // found (nearly) exact is evaluated again once its step has grown
    // kStaleScreen / kErrorFloor-fold, whatever its direction.
    curvature_[probe_factors_[i]] =
        static_cast<float>(std::max(error, kErrorFloor * threshold) / probe_sizes_[i]);
    const double ratio = error / threshold;
    if (!(ratio > 1.0)) continue;
    for (int v : linear.vars()) ratio_[v] = std::max(ratio_[v], ratio);
  }
  for (std::size_t i = 0; i < probe_vars_.size(); ++i) {
    theta_.MutableVariableAt(probe_vars_[i]) = probe_saved_[i];
    mark_[probe_vars_[i]] = 0;
  }
}

void Isam2::Relinearize(const std::vector<int>& relin, std::vector<int>* affected,
                        int* num_factors) {
  // Sized once (grown by doubling, the record of a whole-graph relinearisation left holes in the
  // heap as large as itself), and θ in its exact encoding: 32 bytes a Pose2 where a Variable
  // takes 112.
  std::size_t theta_size = undo_.theta.size(), delta_size = undo_.delta.size();
  for (int v : relin) {
    theta_size += EncodedSize(var_types_[v]);
    delta_size += dims_[v];
  }
  undo_.relinearized.insert(undo_.relinearized.end(), relin.begin(), relin.end());
  undo_.theta.reserve(theta_size);
  undo_.delta.reserve(delta_size);
  for (int v : relin) {
    Eigen::Map<Eigen::VectorXd> d(delta_.data() + offsets_[v], dims_[v]);
    EncodeVariable(theta_.VariableAt(v), &undo_.theta);
    undo_.delta.insert(undo_.delta.end(), d.data(), d.data() + d.size());
    RetractInPlace(&theta_.MutableVariableAt(v), d.data());
    d.setZero();
  }
  variable_index_.CollectFactors(relin, &relin_factors_);
  *num_factors = static_cast<int>(relin_factors_.size());
  undo_.relinearized_factors.reserve(undo_.relinearized_factors.size() + relin_factors_.size());
  undo_.relinearized_factors.insert(undo_.relinearized_factors.end(), relin_factors_.begin(),
                                    relin_factors_.end());
  for (int f : relin_factors_) {
    for (int v : FactorVars(f)) {
      affected->push_back(v);
    }
  }
  // Each factor's linearisation is independent (θ is only read, each writes its own cache), so
  // a large relinearisation — the slowest steps relinearise most of the graph — is shared
  // between threads, which start now and overlap steps 4-6 on the calling thread. Below
  // kFactorsPerThread factors a thread costs more than it saves.
  constexpr int kFactorsPerThread = 512;
  const int n = static_cast<int>(relin_factors_.size());
  const int helpers = std::min(params_.threads, n / kFactorsPerThread) - 1;
  relin_next_.store(0, std::memory_order_relaxed);
  if (helpers > 0) {
    relin_pool_.Run(helpers, [this](int) { LinearizeChunks(); });
    relin_running_ = true;
  } else {
    LinearizeChunks();  // small: at once, on this thread
  }
}

void Isam2::LinearizeChunks() {
  constexpr int kChunk = 64;
  const int n = static_cast<int>(relin_factors_.size());
  for (;;) {
    const int begin = relin_next_.fetch_add(kChunk, std::memory_order_relaxed);
    if (begin >= n) return;
    for (int i = begin; i < std::min(n, begin + kChunk); ++i) {
      Status s = LinearizeFactor(relin_factors_[i]);
      if (!s.ok()) {
        const std::lock_guard<std::mutex> lock(relin_mutex_);
        if (relin_status_.ok()) relin_status_ = std::move(s);
        relin_next_.store(n, std::memory_order_relaxed);  // stop everyone
        return;
      }
    }
  }
}

Status Isam2::FinishRelinearization() {
  if (relin_running_) {
    LinearizeChunks();
    relin_pool_.Wait();
    relin_running_ = false;
  }
  Status s = std::move(relin_status_);
  relin_status_ = Status::Ok();
  return s;
}

}  // namespace slamd::core
