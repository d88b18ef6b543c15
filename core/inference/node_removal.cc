#include "core/inference/node_removal.h"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/base/key_slots.h"
#include "core/factors/linear_container_factor.h"
#include "core/factors/linearized_factor.h"
#include "core/inference/chow_liu.h"

namespace slamd::core {
namespace {

// A diagonal entry of R_MM this small relative to R's largest means the removed variables'
// columns are dependent: their factors do not determine them.
constexpr double kRankTolerance = 1e-10;

}  // namespace

Result<NodeRemoval> MarginalizeOut(std::span<const FactorPtr> factors, const Values& theta,
                                   std::span<const Key> removed, const NodeRemovalParams& params) {
  if (removed.empty()) return InvalidArgument("MarginalizeOut: no variable to remove");
  if (params.tree_parents < 1 || params.tree_parents > 2) {
    return InvalidArgument("MarginalizeOut: tree_parents = " + std::to_string(params.tree_parents) +
                           "; must be 1 or 2");
  }
  // Columns: the removed variables first (in the given order), then the blanket (marked
  // kBlanket while the factors are gathered, placed in the order below).
  constexpr int kBlanket = std::numeric_limits<int>::max();
  KeySlots column_of;  // key -> its position in `keys`
  KeyVector keys;
  std::vector<int> column{0};  // first column of keys[i]; column.back() = total
  const auto place = [&](Key k) {
    keys.push_back(k);
    column.push_back(column.back() + theta.DimAt(theta.SlotOf(k)));
  };
  for (Key k : removed) {
    if (!theta.Contains(k))
      return InvalidArgument("MarginalizeOut: unknown variable " + KeyToString(k));
    if (column_of.Find(k) >= 0) {
      return InvalidArgument("MarginalizeOut: " + KeyToString(k) + " listed twice");
    }
    column_of.Insert(k, static_cast<int>(keys.size()));
    place(k);
  }
  const int num_removed = static_cast<int>(keys.size());
  const int removed_dim = column.back();

  NodeRemoval out;
  int rows = 0;
  // Marks a variable of factor i as on the blanket.
  const auto add_blanket = [&](Key k, std::size_t i) -> Status {
    if (!theta.Contains(k)) {
      return InvalidArgument("MarginalizeOut: factor " + std::to_string(i) + " (" +
                             factors[i]->Name() + ") has no value for " + KeyToString(k));
    }
    column_of.Insert(k, kBlanket);
    return Status::Ok();
  };
  const auto on_blanket = [&](Key k) { return column_of.Find(k) >= num_removed; };
  for (std::size_t i = 0; i < factors.size(); ++i) {
    const FactorPtr& f = factors[i];
    if (!f) continue;
    const bool touches = std::any_of(f->keys().begin(), f->keys().end(), [&](Key k) {
      const int at = column_of.Find(k);
      return at >= 0 && at < num_removed;
    });
    if (!touches) continue;
    out.removed_factors.push_back(static_cast<int>(i));
    rows += f->dim();
    for (Key k : f->keys()) {
      if (column_of.Find(k) >= 0) continue;
      if (Status s = add_blanket(k, i); !s.ok()) return s;
    }
  }
  // A Chow-Liu summary also takes in the summaries already on its blanket (NodeRemovalParams):
  // a root-relative one whose other variables are all on it, its root added to the blanket if
  // need be, and then those that root completes. A factor touching M has a key off the blanket:
  // none is taken twice.
  if (params.form == NodeRemovalParams::Form::kChowLiu) {
    std::vector<int> containers;  // the summaries in `factors`, looked up once
    for (std::size_t i = 0; i < factors.size(); ++i) {
      if (dynamic_cast<const LinearContainerFactor*>(factors[i].get())) {
        containers.push_back(static_cast<int>(i));
      }
    }
    std::vector<char> taken(factors.size(), 0);
    for (bool grown = true; grown;) {
      grown = false;
      for (const int i : containers) {
        if (taken[i]) continue;
        const auto* c = static_cast<const LinearContainerFactor*>(factors[i].get());
        const std::span<const Key> fk = c->keys();
        const auto members = fk.end() - (c->root_relative() ? 1 : 0);
        const int root = column_of.Find(fk.back());
        if (root >= 0 && root < num_removed) continue;  // touches M: taken in above
        if (!std::all_of(fk.begin(), members, on_blanket)) continue;
        if (root < 0) {
          if (Status s = add_blanket(fk.back(), i); !s.ok()) return s;
          grown = true;
        }
        taken[i] = 1;
        out.removed_factors.push_back(i);
        rows += c->dim();
      }
    }
    std::sort(out.removed_factors.begin(), out.removed_factors.end());
  }
  // The order the summary is computed in: the factors by their keys, the blanket by first
  // appearance in them, not by where `factors` holds them. A recovery's solver need not hold
  // them where the live one did, and a tree's conditionals amplify round-off (and a choice made
  // on a tolerance may flip): the summary must not hang on that order to be repeated exactly.
  std::vector<int> order = out.removed_factors;
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    const std::span<const Key> ka = factors[a]->keys(), kb = factors[b]->keys();
    return std::lexicographical_compare(ka.begin(), ka.end(), kb.begin(), kb.end());
  });
  for (int f : order) {
    for (Key k : factors[f]->keys()) {
      if (column_of.Find(k) != kBlanket) continue;
      column_of.Set(k, static_cast<int>(keys.size()));
      place(k);
      out.blanket.push_back(k);
    }
  }
  for (int i = 0; i < num_removed; ++i) {
    if (std::none_of(out.removed_factors.begin(), out.removed_factors.end(), [&](int f) {
          const std::span<const Key> fk = factors[f]->keys();
          return std::find(fk.begin(), fk.end(), keys[i]) != fk.end();
        })) {
      return FailedPrecondition("MarginalizeOut: " + KeyToString(keys[i]) +
                                " has no factor: nothing determines it");
    }
  }

  // [J b], the factors stacked, in the columns above.
  const int cols = column.back();
  Eigen::MatrixXd jb = Eigen::MatrixXd::Zero(rows, cols + 1);
  LinearizedFactor lf;
  int row = 0;
  for (int i : order) {
    const Factor& f = *factors[i];
    f.Linearize(theta, &lf);
    for (int k = 0; k < lf.num_keys(); ++k) {
      const int at = column_of.Find(f.keys()[k]);
      jb.block(row, column[at], lf.rows(), lf.dim(k)) = lf.Block(k);
    }
    jb.block(row, cols, lf.rows(), 1) = lf.Rhs();
    row += lf.rows();
  }
  if (!jb.allFinite()) {
    return FailedPrecondition("MarginalizeOut: a factor's linearisation at θ is not finite");
  }

  // R of [J b] (Householder QR; R is the upper triangle of the first min(rows, cols + 1) rows).
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(jb);
  const int r_rows = std::min(rows, cols + 1);
  const Eigen::MatrixXd r =
      qr.matrixQR().topRows(r_rows).triangularView<Eigen::Upper>().toDenseMatrix();
  const double scale = r.diagonal().head(std::min(r_rows, cols)).cwiseAbs().maxCoeff();
  for (int i = 0; i < num_removed; ++i) {
    for (int c = column[i]; c < column[i + 1]; ++c) {
      if (c >= r_rows || std::abs(r(c, c)) <= kRankTolerance * scale) {
        return FailedPrecondition("MarginalizeOut: " + KeyToString(keys[i]) +
                                  " is not determined by its factors (entry " +
                                  std::to_string(c - column[i]) + " of its tangent)");
      }
    }
  }
  // Rows of R below R_MM: [R_BB c_B] (fewer rows than blanket columns when the factors have
  // fewer residuals than unknowns), then ρ when there is a row for it.
  const int blanket_dim = cols - removed_dim;
  const int marginal_rows = std::max(0, std::min(r_rows, cols) - removed_dim);
  if (r_rows == cols + 1) out.constant_chi2 = r(cols, cols) * r(cols, cols);
  if (blanket_dim > 0 && marginal_rows > 0) {
    std::vector<Variable> x0;
    for (Key k : out.blanket) x0.push_back(theta.Get(k));
    const Eigen::MatrixXd A = r.block(removed_dim, removed_dim, marginal_rows, blanket_dim);
    const Eigen::VectorXd b = r.col(cols).segment(removed_dim, marginal_rows);
    Result<FactorPtr> marginal = LinearContainerFactor::Create(out.blanket, x0, A, b);
    if (!marginal.ok()) return marginal.status();
    out.marginal = std::move(marginal).value();
    if (params.form == NodeRemovalParams::Form::kChowLiu && out.blanket.size() >= 3) {
      // A tree the numbers cannot be trusted for (chow_liu.h) leaves the exact summary.
      std::vector<char> preferred(out.blanket.size(), 0);
      for (std::size_t i = 0; params.prefer_root && i < out.blanket.size(); ++i) {
        preferred[i] = params.prefer_root(out.blanket[i]);
      }
      Result<std::vector<FactorPtr>> tree =
          ChowLiuTree(out.blanket, x0, A, b, preferred, params.edge_frame, params.tree_parents);
      out.summary = tree.ok() ? std::move(tree).value() : std::vector<FactorPtr>{out.marginal};
    } else {
      out.summary = {out.marginal};
    }
  }
  return out;
}

}  // namespace slamd::core
