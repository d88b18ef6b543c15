// The steps of Isam2::Update (isam2.cc).
#include <algorithm>
#include <thread>
#include <unordered_set>

#include "core/base/timing.h"
#include "core/inference/back_substitution.h"
#include "core/isam/isam2.h"
#include "core/linear/ordering.h"

namespace slamd::core {

Status Isam2::CheckInput(const FactorGraph& new_factors, const Values& new_values,
                         const Isam2UpdateOptions& options) const {
  for (Key key : new_values.keys()) {
    if (theta_.Contains(key)) {
      return AlreadyExists("variable " + KeyToString(key) + " already exists in the solver");
    }
  }
  std::unordered_set<Key> used;
  for (std::size_t f = 0; f < new_factors.size(); ++f) {
    const Factor& factor = *new_factors[f];
    for (int i = 0; i < static_cast<int>(factor.keys().size()); ++i) {
      const Key key = factor.keys()[i];
      used.insert(key);
      int slot = theta_.SlotOf(key);
      const Values* owner = &theta_;
      if (slot < 0) {
        slot = new_values.SlotOf(key);
        owner = &new_values;
      }
      if (slot < 0) {
        return NotFound("new factor " + std::to_string(f) + " (" + factor.Name() +
                        ") refers to variable " + KeyToString(key) +
                        ", which is neither in the solver nor among the new values");
      }
      if (owner->TypeAt(slot) != factor.KeyType(i)) {
        return InvalidArgument("new factor " + std::to_string(f) + " (" + factor.Name() +
                               ") expects " + KeyToString(key) + " to be a " +
                               VariableTypeName(factor.KeyType(i)) + ", but it is a " +
                               VariableTypeName(owner->TypeAt(slot)));
      }
      for (int j = 0; j < i; ++j) {
        if (factor.keys()[j] == key) {
          return InvalidArgument("new factor " + std::to_string(f) + " (" + factor.Name() +
                                 ") lists variable " + KeyToString(key) + " twice");
        }
      }
    }
  }
  for (Key key : new_values.keys()) {
    if (!used.count(key)) {
      return InvalidArgument("new variable " + KeyToString(key) +
                             " is not constrained by any new factor");
    }
  }
  std::unordered_set<int> removing;
  for (int f : options.remove_factors) {
    if (f < 0 || f >= static_cast<int>(factors_.size()) || !factors_[f]) {
      return InvalidArgument("cannot remove factor " + std::to_string(f) +
                             ": no such factor (or already removed)");
    }
    if (!removing.insert(f).second) {
      return InvalidArgument("factor " + std::to_string(f) + " is listed twice for removal");
    }
  }
  for (const std::vector<Key>* keys : {&options.extra_reeliminate, &options.no_relinearize}) {
    for (Key key : *keys) {
      if (!theta_.Contains(key) && !new_values.Contains(key)) {
        return NotFound("update option names unknown variable " + KeyToString(key));
      }
    }
  }
  return Status::Ok();
}

void Isam2::AddVariables(const Values& new_values) {
  for (int s = 0; s < static_cast<int>(new_values.size()); ++s) {
    const Status inserted = theta_.Insert(new_values.KeyAt(s), new_values.VariableAt(s));
    SLAMD_CHECK(inserted.ok()) << inserted.ToString();  // CheckInput ruled out every failure
    dims_.push_back(new_values.DimAt(s));
    offsets_.push_back(offsets_.back() + dims_.back());
  }
  // δ grows geometrically (the back-substitution accepts a longer vector; the tail stays zero),
  // so adding a variable costs O(1) amortised rather than a copy of all of δ.
  if (offsets_.back() > delta_.size()) {
    const Eigen::Index old_size = delta_.size();
    delta_.conservativeResize(std::max<Eigen::Index>(2 * old_size, offsets_.back()));
    delta_.tail(delta_.size() - old_size).setZero();
  }
  mark_.resize(theta_.size(), 0);
  variable_index_.Reserve(static_cast<int>(theta_.size()));
}

Status Isam2::LinearizeFactor(int index) {
  LinearizedFactor lf;
  const Factor& factor = *factors_[index];
  factor.Linearize(theta_, &lf);
  int ids[kMaxFactorKeys];
  for (int k = 0; k < lf.num_keys; ++k) ids[k] = theta_.SlotOf(factor.keys()[k]);
  const Status s = linearized_[index].Assign(lf, std::span<const int>(ids, lf.num_keys));
  if (!s.ok()) {
    return NumericalFailure("factor " + std::to_string(index) + " (" + factor.Name() + ") on " +
                            KeyToString(factor.keys()[0]) + " does not linearise: " + s.message());
  }
  return Status::Ok();
}

Status Isam2::AddFactors(const FactorGraph& new_factors, std::vector<int>* indices) {
  for (const FactorPtr& f : new_factors) {
    const int index = static_cast<int>(factors_.size());
    factors_.push_back(f);
    linearized_.emplace_back();
    if (Status s = LinearizeFactor(index); !s.ok()) {
      // Not in the variable index yet: drop it here, so that Rollback removes from the index
      // only the factors that were added to it.
      factors_.pop_back();
      linearized_.pop_back();
      return s;
    }
    const Status added = variable_index_.AddFactor(index, linearized_[index].vars());
    SLAMD_CHECK(added.ok()) << added.ToString();
    indices->push_back(index);
  }
  return Status::Ok();
}

void Isam2::RemoveFactors(const std::vector<int>& indices, std::vector<int>* affected) {
  for (int f : indices) {
    const std::span<const int> vars = linearized_[f].vars();
    affected->insert(affected->end(), vars.begin(), vars.end());
    const Status removed = variable_index_.RemoveFactor(f, vars);
    SLAMD_CHECK(removed.ok()) << removed.ToString();
    undo_.removed_factors.emplace_back(f, std::move(factors_[f]));
    factors_[f] = nullptr;
  }
}

bool Isam2::SelectRelinearization(const Isam2UpdateOptions& options, bool all,
                                  const Isam2Params::Relinearization& thresholds,
                                  std::vector<int>* relin) const {
  const int n = static_cast<int>(theta_.size());
  std::unordered_set<int> frozen;
  for (Key key : options.no_relinearize) frozen.insert(theta_.SlotOf(key));
  const double rot = thresholds.rotation_threshold;
  const double trans = thresholds.translation_threshold;
  // Candidates with their largest |δ entry| / threshold; > 1 means over the threshold.
  std::vector<std::pair<double, int>> over;
  for (int v = 0; v < n; ++v) {
    if (frozen.count(v)) continue;
    const double* d = delta_.data() + offsets_[v];
    double ratio = 0.0;
    const VariableType type = theta_.TypeAt(v);
    for (int k = 0; k < dims_[v]; ++k) {
      const bool rotation =
          (type == VariableType::kPose2 && k == 2) || (type == VariableType::kPose3 && k >= 3);
      ratio = std::max(ratio, std::abs(d[k]) / (rotation ? rot : trans));
    }
    if (all || ratio > 1.0) over.emplace_back(ratio, v);
  }
  const int limit = thresholds.max_variables;
  bool capped = false;
  if (!all && limit > 0 && static_cast<int>(over.size()) > limit) {
    std::nth_element(over.begin(), over.begin() + limit, over.end(),
                     [](const auto& a, const auto& b) { return a.first > b.first; });
    over.resize(limit);
    capped = true;
  }
  for (const auto& [ratio, v] : over) relin->push_back(v);
  return capped;
}

Status Isam2::Relinearize(const std::vector<int>& relin, std::vector<int>* affected,
                          int* num_factors) {
  for (int v : relin) {
    Eigen::Map<Eigen::VectorXd> d(delta_.data() + offsets_[v], dims_[v]);
    undo_.theta.emplace_back(v, theta_.VariableAt(v));
    undo_.delta.insert(undo_.delta.end(), d.data(), d.data() + d.size());
    RetractInPlace(&theta_.MutableVariableAt(v), d.data());
    d.setZero();
  }
  std::vector<int> factors;
  variable_index_.CollectFactors(relin, &factors);
  *num_factors = static_cast<int>(factors.size());
  undo_.relinearized_factors.insert(undo_.relinearized_factors.end(), factors.begin(),
                                    factors.end());
  // Each factor's linearisation is independent (θ is only read, each writes its own cache), so a
  // large relinearisation — the slowest steps relinearise most of the graph — is split across
  // threads. Below kFactorsPerThread factors a thread costs more than it saves.
  constexpr int kFactorsPerThread = 512;
  const int n = static_cast<int>(factors.size());
  const int threads = std::max(1, std::min(params_.linearization_threads, n / kFactorsPerThread));
  std::vector<Status> status(threads);
  auto linearize_share = [&](int t) {
    for (int i = t * n / threads; i < (t + 1) * n / threads; ++i) {
      status[t] = LinearizeFactor(factors[i]);
      if (!status[t].ok()) return;
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(linearize_share, t);
  linearize_share(0);
  for (std::thread& th : pool) th.join();
  for (const Status& s : status) SLAMD_RETURN_IF_ERROR(s);
  for (int f : factors) {
    const std::span<const int> vars = linearized_[f].vars();
    affected->insert(affected->end(), vars.begin(), vars.end());
  }
  return Status::Ok();
}

Status Isam2::ReEliminate(const std::vector<int>& affected, const std::vector<int>& last,
                          std::vector<int>* new_cliques, Isam2Result* result) {
  Stopwatch phase;
  // 4. Detach the top: every clique holding an affected variable as a frontal, and ancestors.
  removed_frontals_.clear();
  orphans_.clear();
  tree_.RemoveTop(affected, &removed_frontals_, &orphans_);
  undo_.top_removed = true;
  // 5. The variables to eliminate: the removed frontals and the new variables (not in the tree).
  const int n = static_cast<int>(theta_.size());
  elim_vars_.clear();
  for (int v : removed_frontals_) {
    if (!mark_[v]) elim_vars_.push_back(v), mark_[v] = 1;
  }
  for (int v = undo_.num_vars; v < n; ++v) {
    if (!mark_[v]) elim_vars_.push_back(v), mark_[v] = 1;
  }
  for (int v : elim_vars_) mark_[v] = 0;  // mark_ is all zero between uses
  result->seconds.remove_top = phase.Lap();
  const Status s = EliminateTop(elim_vars_, last, new_cliques, result);
  result->reeliminated_variables = static_cast<int>(elim_vars_.size());
  return s;
}

Status Isam2::EliminateTop(const std::vector<int>& vars, const std::vector<int>& last,
                           std::vector<int>* new_cliques, Isam2Result* result) {
  Stopwatch phase;
  // Local numbering of the variables to eliminate (mark_ = 1 + local index), cleared on exit so
  // that marking costs O(|vars|), not O(all variables).
  for (int i = 0; i < static_cast<int>(vars.size()); ++i) mark_[vars[i]] = i + 1;
  struct ClearMarks {
    const std::vector<int>& vars;
    std::vector<int>& mark;
    ~ClearMarks() {
      for (int v : vars) mark[v] = 0;
    }
  } clear_marks{vars, mark_};
  // The factors entirely inside the eliminated set (the others are summarised by orphans).
  elim_factors_.clear();
  variable_index_.CollectFactors(vars, &elim_factors_);
  elim_factors_.erase(std::remove_if(elim_factors_.begin(), elim_factors_.end(),
                                     [&](int f) {
                                       for (int v : linearized_[f].vars()) {
                                         if (!mark_[v]) return true;
                                       }
                                       return false;
                                     }),
                      elim_factors_.end());
  elim_jacobians_.clear();
  FactorIncidence incidence;
  std::vector<int> local;
  for (int f : elim_factors_) {
    elim_jacobians_.push_back(&linearized_[f]);
    local.clear();
    for (int v : linearized_[f].vars()) local.push_back(mark_[v] - 1);
    incidence.AddFactor(local);
  }
  elim_hessians_.clear();
  for (int orphan : orphans_) {
    const HessianFactor& cached = tree_.clique(orphan).cached_factor();
    elim_hessians_.push_back(&cached);
    local.clear();
    for (int v : cached.vars()) local.push_back(mark_[v] - 1);
    incidence.AddFactor(local);
  }
  // 6. Constrained COLAMD: the variables of the new factors last (iSAM2 §V-A), so the next
  // update, which most likely touches them again, finds them near the root.
  std::vector<int> group(vars.size(), 0);
  for (int v : last) {
    if (mark_[v]) group[mark_[v] - 1] = 1;
  }
  Result<std::vector<int>> order =
      ConstrainedColamdOrdering(static_cast<int>(vars.size()), incidence, group);
  if (!order.ok()) return order.status();
  order_.clear();
  for (int i : *order) order_.push_back(vars[i]);
  result->seconds.order = phase.Lap();

  // 7. Eliminate into the tree and re-attach the orphans under the cliques that absorbed them.
  const EliminationProblem problem{.var_dims = dims_,
                                   .factors = elim_jacobians_,
                                   .hessians = elim_hessians_,
                                   .ordering = order_};
  EliminationResult eliminated;
  const Status s = eliminator_.Eliminate(problem, &tree_, &eliminated);
  if (!s.ok()) {
    if (eliminated.failed_variable >= 0) {
      return NumericalFailure("the linear system is indeterminate at variable " +
                              KeyToString(theta_.KeyAt(eliminated.failed_variable)) +
                              " (is it anchored or observed enough?): " + s.message());
    }
    return s;
  }
  for (std::size_t i = 0; i < orphans_.size(); ++i) {
    tree_.Attach(orphans_[i], eliminated.hessian_cliques[i]);
  }
  *new_cliques = std::move(eliminated.cliques);
  result->reeliminated_cliques = static_cast<int>(new_cliques->size());
  result->seconds.eliminate = phase.Lap();
  return Status::Ok();
}

int Isam2::BackSubstitute(const std::vector<int>& new_cliques, bool full,
                          double wildfire_threshold) {
  if (full) {
    core::BackSubstitute(tree_, offsets_, &delta_);
    return tree_.NumCliques();
  }
  return WildfireBackSubstitute(tree_, new_cliques, wildfire_threshold, offsets_, &delta_,
                                &wildfire_);
}

void Isam2::Rollback() {
  // θ back as it was, then the relinearised factors linearised there again (deterministic, so
  // identical to what they were; cheaper than keeping copies on every update).
  for (auto& [v, old] : undo_.theta) theta_.MutableVariableAt(v) = std::move(old);
  for (int f : undo_.relinearized_factors) {
    if (f < undo_.num_factors)
      SLAMD_CHECK(LinearizeFactor(f).ok()) << "re-linearising factor " << f;
  }
  std::size_t at = 0;
  for (const auto& [v, unused] : undo_.theta) {
    std::copy_n(undo_.delta.data() + at, dims_[v], delta_.data() + offsets_[v]);
    at += dims_[v];
  }
  for (int f = static_cast<int>(factors_.size()) - 1; f >= undo_.num_factors; --f) {
    const Status removed = variable_index_.RemoveFactor(f, linearized_[f].vars());
    SLAMD_CHECK(removed.ok()) << removed.ToString();
  }
  factors_.resize(undo_.num_factors);
  linearized_.resize(undo_.num_factors);
  for (auto& [f, factor] : undo_.removed_factors) {
    factors_[f] = std::move(factor);
    const Status added = variable_index_.AddFactor(f, linearized_[f].vars());
    SLAMD_CHECK(added.ok()) << added.ToString();
  }
  // New variables out (they are the last slots).
  while (static_cast<int>(theta_.size()) > undo_.num_vars) {
    const Status erased = theta_.Erase(theta_.KeyAt(static_cast<int>(theta_.size()) - 1));
    SLAMD_CHECK(erased.ok()) << erased.ToString();
  }
  delta_.segment(offsets_[undo_.num_vars], offsets_.back() - offsets_[undo_.num_vars]).setZero();
  dims_.resize(undo_.num_vars);
  offsets_.resize(undo_.num_vars + 1);
  // The tree: re-eliminate the detached top from the old factors, which succeeded before.
  if (undo_.top_removed) {
    std::vector<int> vars;
    for (int v : removed_frontals_) {
      if (v < undo_.num_vars) vars.push_back(v);
    }
    std::vector<int> cliques;
    Isam2Result ignored;
    const Status s = EliminateTop(vars, {}, &cliques, &ignored);
    SLAMD_CHECK(s.ok()) << "restoring the Bayes tree after a failed update: " << s.ToString();
  }
}

}  // namespace slamd::core
