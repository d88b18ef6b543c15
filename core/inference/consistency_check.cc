#include "core/inference/consistency_check.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

namespace slamd::core {
namespace {

Status Fail(const std::string& message) {
  return FailedPrecondition("BayesTree inconsistent: " + message);
}

std::string C(int id) { return "clique " + std::to_string(id); }
std::string V(int var) { return "variable " + std::to_string(var); }

// Links: parents, children, roots, reachability.
Status CheckLinks(const BayesTree& tree) {
  for (int id = 0; id < tree.NumSlots(); ++id) {
    if (!tree.IsLive(id)) continue;
    const Clique& c = tree.clique(id);
    const int p = c.parent();
    if (p != BayesTree::kNone) {
      if (!tree.IsLive(p)) return Fail(C(id) + " has dead parent " + std::to_string(p));
      const auto& siblings = tree.clique(p).children();
      if (std::count(siblings.begin(), siblings.end(), id) != 1) {
        return Fail(C(id) + " is not listed exactly once among the children of its parent " +
                    std::to_string(p));
      }
    }
    for (int child : c.children()) {
      if (!tree.IsLive(child) || tree.clique(child).parent() != id) {
        return Fail(C(id) + " lists child " + std::to_string(child) + " which does not point back");
      }
    }
  }
  std::vector<char> seen(tree.NumSlots(), 0);
  for (int r : tree.roots()) {
    if (!tree.IsLive(r)) return Fail("root " + std::to_string(r) + " is not live");
    if (tree.clique(r).parent() != BayesTree::kNone) return Fail("root " + C(r) + " has a parent");
    if (seen[r]) return Fail("root " + C(r) + " listed twice");
    seen[r] = 1;
  }
  std::vector<int> order = tree.TopDownOrder();
  if (static_cast<int>(order.size()) != tree.NumCliques()) {
    return Fail(std::to_string(order.size()) + " cliques reachable from the roots, " +
                std::to_string(tree.NumCliques()) + " live (a cycle or a missing root)");
  }
  std::fill(seen.begin(), seen.end(), 0);
  for (int id : order) {
    if (seen[id]) return Fail(C(id) + " reached twice from the roots");
    seen[id] = 1;
  }
  return Status::Ok();
}

// Variables: each frontal exactly once, CliqueOf agrees, dims agree everywhere.
Status CheckVariables(const BayesTree& tree, std::vector<int>* dims) {
  std::vector<int> owner(tree.NumVariables(), BayesTree::kNone);
  dims->assign(tree.NumVariables(), 0);
  for (int id = 0; id < tree.NumSlots(); ++id) {
    if (!tree.IsLive(id)) continue;
    const Clique& c = tree.clique(id);
    if (c.num_frontals() == 0) return Fail(C(id) + " has no frontal variable");
    for (int k = 0; k < c.num_frontals(); ++k) {
      const int v = c.frontal(k);
      if (v < 0 || v >= tree.NumVariables()) return Fail(C(id) + " has unknown frontal " + V(v));
      if (owner[v] != BayesTree::kNone) {
        return Fail(V(v) + " is frontal in both " + C(owner[v]) + " and " + C(id));
      }
      owner[v] = id;
      (*dims)[v] = c.frontal_dim(k);
      if (c.frontal_dim(k) < 1) return Fail(V(v) + " has dim < 1 in " + C(id));
    }
  }
  for (int v = 0; v < tree.NumVariables(); ++v) {
    if (tree.CliqueOf(v) != owner[v]) {
      return Fail("CliqueOf(" + std::to_string(v) + ") = " + std::to_string(tree.CliqueOf(v)) +
                  " but it is frontal in " + std::to_string(owner[v]));
    }
  }
  for (int id = 0; id < tree.NumSlots(); ++id) {
    if (!tree.IsLive(id)) continue;
    const Clique& c = tree.clique(id);
    for (int k = 0; k < c.num_separator(); ++k) {
      const int v = c.separator()[k];
      if (v < 0 || v >= tree.NumVariables() || owner[v] == BayesTree::kNone) {
        return Fail(C(id) + " has separator " + V(v) + " which is frontal nowhere");
      }
      if (owner[v] == id) return Fail(V(v) + " is both frontal and separator in " + C(id));
      if (c.separator_dim(k) != (*dims)[v]) {
        return Fail(V(v) + " has dim " + std::to_string(c.separator_dim(k)) +
                    " in the separator of " + C(id) + " but " + std::to_string((*dims)[v]) +
                    " where it is frontal");
      }
      for (int j = 0; j < k; ++j) {
        if (c.separator()[j] == v) return Fail(V(v) + " twice in the separator of " + C(id));
      }
    }
  }
  return Status::Ok();
}

// Running intersection: separators flow into the parent.
Status CheckRunningIntersection(const BayesTree& tree) {
  for (int id = 0; id < tree.NumSlots(); ++id) {
    if (!tree.IsLive(id)) continue;
    const Clique& c = tree.clique(id);
    const int p = c.parent();
    if (p == BayesTree::kNone) {
      if (c.num_separator() != 0) {
        return Fail("root " + C(id) + " has a non-empty separator (an unattached orphan?)");
      }
      continue;
    }
    const Clique& parent = tree.clique(p);
    bool meets_frontals = c.num_separator() == 0;
    for (int v : c.separator()) {
      const bool in_frontals = tree.CliqueOf(v) == p;
      const auto& ps = parent.separator();
      const bool in_separator = std::find(ps.begin(), ps.end(), v) != ps.end();
      if (!in_frontals && !in_separator) {
        return Fail("separator " + V(v) + " of " + C(id) +
                    " is neither frontal nor separator in its parent " + std::to_string(p));
      }
      meets_frontals = meets_frontals || in_frontals;
    }
    if (!meets_frontals) {
      return Fail("the separator of " + C(id) + " does not meet the frontals of its parent " +
                  std::to_string(p));
    }
  }
  return Status::Ok();
}

// Matrix sizes and the shape of R.
Status CheckMatrices(const BayesTree& tree) {
  for (int id = 0; id < tree.NumSlots(); ++id) {
    if (!tree.IsLive(id)) continue;
    const Clique& c = tree.clique(id);
    const int nf = c.FrontalDim(), ns = c.SeparatorDim();
    int sum = 0;
    for (int k = 0; k < c.num_frontals(); ++k) sum += c.frontal_dim(k);
    if (sum != nf) return Fail(C(id) + ": frontal dims do not add up to FrontalDim()");
    sum = 0;
    for (int k = 0; k < c.num_separator(); ++k) sum += c.separator_dim(k);
    if (sum != ns) return Fail(C(id) + ": separator dims do not add up to SeparatorDim()");
    const auto cond = c.conditional();
    if (cond.rows() != nf || cond.cols() != nf + ns + 1)
      return Fail(C(id) + ": [R S d] has the wrong size");
    if (c.cached_factor().Dim() != ns) return Fail(C(id) + ": cached factor has the wrong size");
    if (!cond.allFinite()) return Fail(C(id) + ": [R S d] is not finite");
    for (int j = 0; j < nf; ++j) {
      if (!(cond(j, j) > 0.0)) return Fail(C(id) + ": R has a non-positive diagonal entry");
      for (int i = j + 1; i < nf; ++i) {
        if (cond(i, j) != 0.0) return Fail(C(id) + ": R is not upper-triangular");
      }
    }
  }
  return Status::Ok();
}

}  // namespace

Status CheckConsistency(const BayesTree& tree) {
  SLAMD_RETURN_IF_ERROR(CheckLinks(tree));
  std::vector<int> dims;
  SLAMD_RETURN_IF_ERROR(CheckVariables(tree, &dims));
  SLAMD_RETURN_IF_ERROR(CheckRunningIntersection(tree));
  return CheckMatrices(tree);
}

}  // namespace slamd::core
