// The steps of Isam2::Update (isam2.cc): checking and adding the input, re-eliminating the top,
// back-substitution and rollback; the relinearisation steps are in isam2_relinearization.cc.
#include <algorithm>
#include <unordered_set>
#include <utility>

#include "core/base/storage.h"
#include "core/base/timing.h"
#include "core/inference/back_substitution.h"
#include "core/isam/isam2.h"
#include "core/linear/ordering.h"

namespace slamd::core {
namespace {

// The landmarks of a re-eliminated top go first when the poses left are tied at least this
// densely (IndependentFirstOrdering's min_density).
constexpr double kLandmarksFirstDensity = 0.5;

}  // namespace

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
  for (const std::vector<Key>* keys : {&options.extra_reeliminate, &options.no_relinearize,
                                       &options.order_last, &options.solve_first}) {
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
    budget_.push_back(0.0);
    screened_norm2_.push_back(-1.0);
    var_types_.push_back(new_values.TypeAt(s));
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
  const Factor& factor = *factors_[index];
  const Status s = linearized_[index].Linearize(factor, theta_, FactorVars(index));
  if (!s.ok()) {
    return NumericalFailure("factor " + std::to_string(index) + " (" + factor.Name() + ") on " +
                            KeyToString(factor.keys()[0]) + " does not linearise: " + s.message());
  }
  return Status::Ok();
}

Status Isam2::AddFactors(const FactorGraph& new_factors, std::vector<int>* indices) {
  for (const FactorPtr& f : new_factors) {
    const std::size_t arity = f->keys().size();
    const bool reuse = arity < free_slots_.size() && !free_slots_[arity].empty();
    int index;
    if (reuse) {
      index = free_slots_[arity].back();
      free_slots_[arity].pop_back();
      factors_[index] = f;
      costs_.Forget(index);
      curvature_[index] = -1.0f;
      int* ids = factor_var_ids_.data() + factor_var_begin_[index];
      for (Key key : f->keys()) *ids++ = theta_.SlotOf(key);
    } else {
      index = static_cast<int>(factors_.size());
      ReserveOneMore(&factors_);
      factors_.push_back(f);
      ReserveOneMore(&linearized_);
      linearized_.emplace_back();
      curvature_.push_back(-1.0f);
      for (Key key : f->keys()) factor_var_ids_.push_back(theta_.SlotOf(key));
      factor_var_begin_.push_back(static_cast<int>(factor_var_ids_.size()));
    }
    if (Status s = LinearizeFactor(index); !s.ok()) {
      // Not in the variable index yet: drop it here, so that Rollback removes from the index
      // only the factors that were added to it.
      if (reuse) {
        factors_[index] = nullptr;
        free_slots_[arity].push_back(index);
      } else {
        factors_.pop_back();
        linearized_.pop_back();
        curvature_.pop_back();
        factor_var_begin_.pop_back();
        factor_var_ids_.resize(factor_var_begin_.back());
      }
      return s;
    }
    const Status added = variable_index_.AddFactor(index, linearized_[index].vars());
    SLAMD_CHECK(added.ok()) << added.ToString();
    for (int v : linearized_[index].vars()) budget_[v] = 0.0;  // its curvature is unknown
    if (reuse) undo_.reused_slots.push_back(index);
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
    costs_.Forget(f);
  }
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
  // Variables being removed (RemoveVariables) are left out: no factor is on them any more.
  const int n = static_cast<int>(theta_.size());
  elim_vars_.clear();
  for (int v : removing_) mark_[v] = 1;
  for (int v : removed_frontals_) {
    if (!mark_[v]) elim_vars_.push_back(v), mark_[v] = 1;
  }
  for (int v = undo_.num_vars; v < n; ++v) {
    if (!mark_[v]) elim_vars_.push_back(v), mark_[v] = 1;
  }
  for (int v : elim_vars_) mark_[v] = 0;  // mark_ is all zero between uses
  for (int v : removing_) mark_[v] = 0;
  result->seconds.remove_top = phase.Lap();
  const Status s = EliminateTop(last, new_cliques, result);
  result->reeliminated_variables = static_cast<int>(elim_vars_.size());
  return s;
}

namespace {

// Numbers `vars` locally in `mark` (1 + index) for the scope, so that marking costs O(|vars|),
// not O(all variables); `mark` is all zero between uses.
class LocalNumbering {
 public:
  LocalNumbering(const std::vector<int>& vars, std::vector<int>& mark) : vars_(vars), mark_(mark) {
    for (int i = 0; i < static_cast<int>(vars.size()); ++i) mark_[vars[i]] = i + 1;
  }
  ~LocalNumbering() {
    for (int v : vars_) mark_[v] = 0;
  }
  LocalNumbering(const LocalNumbering&) = delete;
  LocalNumbering& operator=(const LocalNumbering&) = delete;

 private:
  const std::vector<int>& vars_;
  std::vector<int>& mark_;
};

}  // namespace

void Isam2::CollectTop(FactorIncidence* incidence) {
  // The factors entirely inside the eliminated set (the others are summarised by orphans).
  elim_factors_.clear();
  variable_index_.CollectFactors(elim_vars_, &elim_factors_);
  // The structure comes from FactorVars: relinearised factors may still be being written.
  elim_factors_.erase(std::remove_if(elim_factors_.begin(), elim_factors_.end(),
                                     [&](int f) {
                                       for (int v : FactorVars(f)) {
                                         if (!mark_[v]) return true;
                                       }
                                       return false;
                                     }),
                      elim_factors_.end());
  elim_jacobians_.clear();
  std::vector<int> local;
  for (int f : elim_factors_) {
    elim_jacobians_.push_back(&linearized_[f]);
    if (!incidence) continue;
    local.clear();
    for (int v : FactorVars(f)) local.push_back(mark_[v] - 1);
    incidence->AddFactor(local);
  }
  elim_hessians_.clear();
  for (int orphan : orphans_) {
    const HessianFactor& cached = tree_.clique(orphan).cached_factor();
    elim_hessians_.push_back(&cached);
    if (!incidence) continue;
    local.clear();
    for (int v : cached.vars()) local.push_back(mark_[v] - 1);
    incidence->AddFactor(local);
  }
}

Status Isam2::EliminateOrdered(std::vector<int>* new_cliques) {
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
  return Status::Ok();
}

void Isam2::RebuildReleasedTop() {
  elim_vars_ = released_order_;
  const LocalNumbering numbering(elim_vars_, mark_);
  CollectTop(nullptr);
  order_ = released_order_;
  std::vector<int> cliques;
  const Status s = EliminateOrdered(&cliques);
  // The same system in the order that eliminated it before: failing now is a broken invariant.
  SLAMD_CHECK(s.ok()) << "re-eliminating the top after a failed update: " << s.ToString();
}

Status Isam2::EliminateTop(const std::vector<int>& last, std::vector<int>* new_cliques,
                           Isam2Result* result) {
  Stopwatch phase;
  const std::vector<int>& vars = elim_vars_;
  const LocalNumbering numbering(vars, mark_);
  FactorIncidence incidence;
  CollectTop(&incidence);
  // 6. Constrained COLAMD: the variables of the new factors last (iSAM2 §V-A), so the next
  // update, which most likely touches them again, finds them near the root; their landmarks too
  // while they are few (Isam2Params::max_landmarks_last). But where landmarks are most of the
  // variables, and more than that, and the poses they leave are densely tied (bundle adjustment
  // of a compact scene), they all go first, as leaves under the poses they are seen from.
  const auto is_landmark = [&](int v) {
    const VariableType type = theta_.TypeAt(v);
    return type == kVariableType<Point2> || type == kVariableType<Point3>;
  };
  std::vector<char> landmark(vars.size(), 0);
  int num_landmarks = 0;
  for (std::size_t i = 0; i < vars.size(); ++i) {
    landmark[i] = is_landmark(vars[i]);
    num_landmarks += landmark[i];
  }
  const bool landmarks_first = num_landmarks > params_.max_landmarks_last &&
                               2 * num_landmarks > static_cast<int>(vars.size());
  const bool landmarks_last =
      !landmarks_first &&
      std::count_if(last.begin(), last.end(), is_landmark) <= params_.max_landmarks_last;
  std::vector<int> group(vars.size(), 0);
  for (int v : last) {
    if (mark_[v] && (landmarks_last || !is_landmark(v))) group[mark_[v] - 1] = 1;
  }
  const int num_vars = static_cast<int>(vars.size());
  Result<std::vector<int>> order =
      landmarks_first
          ? IndependentFirstOrdering(num_vars, incidence, landmark, group, kLandmarksFirstDensity)
          : ConstrainedColamdOrdering(num_vars, incidence, group);
  if (landmarks_first && order.status().code() == StatusCode::kFailedPrecondition) {
    // The poses left are too sparsely tied for the points-first order to fill in as little as
    // CCOLAMD's, or a factor ties two landmarks.
    order = ConstrainedColamdOrdering(num_vars, incidence, group);
  }
  if (!order.ok()) return order.status();
  order_.clear();
  for (int i : *order) order_.push_back(vars[i]);
  result->seconds.order = phase.Lap();

  // 7. Eliminate into the tree and re-attach the orphans under the cliques that absorbed them,
  // once the relinearised factors are all linearised (step 3's threads).
  SLAMD_RETURN_IF_ERROR(FinishRelinearization());
  result->seconds.relinearize += phase.Lap();
  // The detached top's storage goes to the new cliques (a large re-elimination otherwise faults
  // in fresh pages beside the old top); a rollback from here eliminates it again in its order.
  tree_.RemovedEliminationOrder(&released_order_);
  tree_.ReleaseRemoved();
  undo_.top_removed = false;
  undo_.top_released = true;
  SLAMD_RETURN_IF_ERROR(EliminateOrdered(new_cliques));
  result->reeliminated_cliques = static_cast<int>(new_cliques->size());
  result->seconds.eliminate = phase.Lap();
  return Status::Ok();
}

int Isam2::BackSubstitute(const std::vector<int>& new_cliques, bool full, double wildfire_threshold,
                          const std::vector<Key>& first) {
  if (full) {
    core::BackSubstitute(tree_, offsets_, &delta_);
    return tree_.NumCliques();
  }
  if (first.empty()) {
    return WildfireBackSubstitute(tree_, new_cliques, wildfire_threshold, offsets_, &delta_,
                                  &wildfire_);
  }
  solved_first_.clear();
  std::vector<int> first_cliques;
  for (Key key : first) {
    const int slot = theta_.SlotOf(key);
    solved_first_.push_back(slot);
    first_cliques.push_back(tree_.CliqueOf(slot));
  }
  return WildfireBegin(tree_, new_cliques, wildfire_threshold, first_cliques, offsets_, &delta_,
                       &wildfire_);
}

void Isam2::Rollback() {
  // Reused slots null and free again, in the order they were taken (a stack).
  for (auto it = undo_.reused_slots.rbegin(); it != undo_.reused_slots.rend(); ++it) {
    const Status removed = variable_index_.RemoveFactor(*it, linearized_[*it].vars());
    SLAMD_CHECK(removed.ok()) << removed.ToString();
    free_slots_[factors_[*it]->keys().size()].push_back(*it);
    factors_[*it] = nullptr;
  }
  // θ back as it was, then the relinearised factors linearised there again (deterministic, so
  // identical to what they were; cheaper than keeping copies on every update).
  std::size_t encoded = 0;
  for (int v : undo_.relinearized) {
    const int size = EncodedSize(var_types_[v]);
    Result<Variable> old = DecodeVariable(
        var_types_[v], {undo_.theta.data() + encoded, static_cast<std::size_t>(size)});
    SLAMD_CHECK(old.ok()) << "restoring variable " << v << ": " << old.status().ToString();
    theta_.MutableVariableAt(v) = *std::move(old);
    encoded += size;
  }
  for (int f : undo_.relinearized_factors) {
    if (f < undo_.num_factors && factors_[f])
      SLAMD_CHECK(LinearizeFactor(f).ok()) << "re-linearising factor " << f;
  }
  std::size_t at = 0;
  for (int v : undo_.relinearized) {
    std::copy_n(undo_.delta.data() + at, dims_[v], delta_.data() + offsets_[v]);
    at += dims_[v];
  }
  for (int f = static_cast<int>(factors_.size()) - 1; f >= undo_.num_factors; --f) {
    const Status removed = variable_index_.RemoveFactor(f, linearized_[f].vars());
    SLAMD_CHECK(removed.ok()) << removed.ToString();
  }
  factors_.resize(undo_.num_factors);
  linearized_.resize(undo_.num_factors);
  curvature_.resize(undo_.num_factors);
  factor_var_begin_.resize(undo_.num_factors + 1);
  factor_var_ids_.resize(factor_var_begin_.back());
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
  budget_.resize(undo_.num_vars);
  screened_norm2_.resize(undo_.num_vars);
  var_types_.resize(undo_.num_vars);
  offsets_.resize(undo_.num_vars + 1);
  // The tree: the detached top back as it was (the failed elimination freed what it made, and
  // the orphans are detached roots), or, once released, eliminated again in the order that
  // built it (not a new order: an ill-conditioned system that eliminated before could fail in
  // another). The estimate is restored exactly either way (θ and δ).
  if (undo_.top_removed) tree_.RestoreRemoved();
  if (undo_.top_released) RebuildReleasedTop();
}

void Isam2::Undo::Clear(int vars, int factors) {
  num_vars = vars;
  num_factors = factors;
  removed_factors.clear();
  reused_slots.clear();
  relinearized.clear();
  theta.clear();
  delta.clear();
  relinearized_factors.clear();
  top_removed = false;
  top_released = false;
}

// Lists of more than 64 KiB are given back: they come from the rare update that relinearises
// most of the graph (a long loop closed) and would otherwise stay allocated for good (input_M3500:
// 2,500 variables, ~0.17 MB by its sizes); a usual update's small record keeps its storage.
void Isam2::Undo::GiveBackLargeStorage() {
  constexpr std::size_t kKeepBytes = 64 << 10;
  const auto give_back = [](auto* list) {
    if (list->capacity() * sizeof((*list)[0]) > kKeepBytes) std::exchange(*list, {});
  };
  give_back(&removed_factors);
  give_back(&reused_slots);
  give_back(&relinearized);
  give_back(&theta);
  give_back(&delta);
  give_back(&relinearized_factors);
}

void Isam2::ReleaseRemoved() {
  tree_.ReleaseRemoved();
  for (const auto& [f, unused] : undo_.removed_factors) {
    const std::size_t arity = FactorVars(f).size();
    if (free_slots_.size() <= arity) free_slots_.resize(arity + 1);
    free_slots_[arity].push_back(f);
  }
  undo_.GiveBackLargeStorage();
}

}  // namespace slamd::core
