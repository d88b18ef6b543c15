// Isam2::RemoveVariables: node removal in the Bayes tree (isam2.h).
#include <algorithm>

#include "core/base/timing.h"
#include "core/inference/node_removal.h"
#include "core/isam/isam2.h"

namespace slamd::core {

Isam2RemovalResult Isam2::RemoveVariables(std::span<const Key> keys,
                                          const NodeRemovalParams& params, const Values* at) {
  CheckNoPendingSolve("RemoveVariables");
  Stopwatch timer;
  Isam2RemovalResult out;
  if (at) {  // MarginalizeOut reads `at`: the keys must be variables here too, of its types
    for (Key key : keys) {
      if (!theta_.Contains(key)) {
        out.status = InvalidArgument("RemoveVariables: unknown variable " + KeyToString(key));
        return out;
      }
    }
    for (Key key : at->keys()) {
      const int slot = theta_.SlotOf(key);
      if (slot >= 0 && theta_.TypeAt(slot) != TypeOf(at->Get(key))) {
        out.status = InvalidArgument("RemoveVariables: " + KeyToString(key) +
                                     " has another type in the values to marginalise at");
        return out;
      }
    }
  }
  // MarginalizeOut validates the keys (unknown, repeated), the values and that the marginal
  // exists.
  const Values& point = at ? *at : theta_;
  Result<NodeRemoval> removal = MarginalizeOut(factors_, point, keys, params);
  if (!removal.ok()) {
    out.status = removal.status();
    return out;
  }
  for (Key key : keys) (void)out.marginalized_at.Insert(key, point.Get(key));
  for (Key key : removal->blanket) (void)out.marginalized_at.Insert(key, point.Get(key));
  for (int f : removal->removed_factors) out.removed_dimension += factors_[f]->dim();
  undo_.Clear(static_cast<int>(theta_.size()), static_cast<int>(factors_.size()));
  std::vector<int> affected, last;
  std::vector<int> container;
  FactorGraph summary;
  for (const FactorPtr& f : removal->summary) summary.Add(f);
  out.status = AddFactors(summary, &container);
  if (out.status.ok()) {
    RemoveFactors(removal->removed_factors, &affected);
    for (int f : container) {
      for (int v : linearized_[f].vars()) last.push_back(v);
    }
    removing_.clear();
    for (Key key : keys) removing_.push_back(theta_.SlotOf(key));
    Isam2Result step;
    std::vector<int> new_cliques;
    out.status = ReEliminate(affected, last, &new_cliques, &step);
    removing_.clear();
    out.reeliminated_variables = step.reeliminated_variables;
    if (out.status.ok()) {
      ReleaseRemoved();
      BackSubstitute(new_cliques, /*full=*/false, params_.wildfire_threshold, {});
    }
  }
  if (!out.status.ok()) {
    Rollback();
    out.seconds = timer.Seconds();
    return out;
  }
  std::vector<int> dead;
  for (Key key : keys) dead.push_back(theta_.SlotOf(key));
  DropVariables(dead);
  out.removed_factors = std::move(removal->removed_factors);
  out.summary_factors = std::move(container);
  out.blanket = std::move(removal->blanket);
  out.constant_chi2 = removal->constant_chi2;
  out.seconds = timer.Seconds();
  return out;
}

void Isam2::DropVariables(const std::vector<int>& dead) {
  const int n = static_cast<int>(theta_.size());
  std::vector<int> new_id(n, 0);
  for (int v : dead) new_id[v] = -1;
  int kept = 0;
  for (int v = 0; v < n; ++v) {
    if (new_id[v] == 0) new_id[v] = kept++;
  }
  Values theta;
  std::vector<int> dims, offsets{0};
  std::vector<VariableType> types;
  std::vector<double> budget, screened;
  for (int v = 0; v < n; ++v) {
    if (new_id[v] < 0) continue;
    const Status inserted = theta.Insert(theta_.KeyAt(v), theta_.VariableAt(v));
    SLAMD_CHECK(inserted.ok()) << inserted.ToString();
    dims.push_back(dims_[v]);
    types.push_back(var_types_[v]);
    budget.push_back(budget_[v]);
    screened.push_back(screened_norm2_[v]);
    offsets.push_back(offsets.back() + dims_[v]);
  }
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(offsets.back());
  for (int v = 0; v < n; ++v) {
    if (new_id[v] >= 0) {
      delta.segment(offsets[new_id[v]], dims_[v]) = delta_.segment(offsets_[v], dims_[v]);
    }
  }
  theta_ = std::move(theta);
  dims_ = std::move(dims);
  var_types_ = std::move(types);
  budget_ = std::move(budget);
  screened_norm2_ = std::move(screened);
  offsets_ = std::move(offsets);
  delta_ = std::move(delta);
  mark_.assign(kept, 0);
  ratio_.clear();
  step_norms_.clear();
  over_budget_mark_.clear();
  solved_first_.clear();
  wildfire_.changed.clear();
  for (int& v : factor_var_ids_) v = v >= 0 ? new_id[v] : -1;
  for (std::size_t f = 0; f < factors_.size(); ++f) {
    if (factors_[f]) {
      linearized_[f].RenumberVariables(new_id);
    } else {
      linearized_[f] = JacobianFactor();  // a removed factor's storage goes
    }
  }
  variable_index_.RenumberVariables(new_id, kept);
  tree_.RenumberVariables(new_id, kept);
  costs_.Clear();
}

}  // namespace slamd::core
