#include "core/linear/ordering.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <string>

#include "ccolamd.h"
#include "colamd.h"

namespace slamd::core {
namespace {

// The transpose of the incidence: for each variable (column of A) the factors (rows) touching it,
// without duplicates. Alen-sized so COLAMD can use the tail as workspace.
struct ColumnMatrix {
  std::vector<int> col_ptr;  // size num_vars + 1
  std::vector<int> rows;     // size >= recommended Alen
  int nnz = 0;
};

ColumnMatrix BuildColumns(int num_vars, const FactorIncidence& incidence) {
  const int num_factors = incidence.NumFactors();
  ColumnMatrix a;
  a.col_ptr.assign(num_vars + 1, 0);
  // last_factor[v] = last factor counted for v, so a variable listed twice in a factor counts once.
  std::vector<int> last_factor(num_vars, -1);
  for (int f = 0; f < num_factors; ++f) {
    for (int i = incidence.offsets[f]; i < incidence.offsets[f + 1]; ++i) {
      const int v = incidence.vars[i];
      if (last_factor[v] == f) continue;
      last_factor[v] = f;
      ++a.col_ptr[v + 1];
    }
  }
  std::partial_sum(a.col_ptr.begin(), a.col_ptr.end(), a.col_ptr.begin());
  a.nnz = a.col_ptr[num_vars];
  return a;
}

void FillRows(int num_vars, const FactorIncidence& incidence, size_t alen, ColumnMatrix* a) {
  a->rows.assign(std::max<size_t>(alen, a->nnz), 0);
  std::vector<int> next(a->col_ptr.begin(), a->col_ptr.end() - 1);
  std::vector<int> last_factor(num_vars, -1);
  for (int f = 0; f < incidence.NumFactors(); ++f) {
    for (int i = incidence.offsets[f]; i < incidence.offsets[f + 1]; ++i) {
      const int v = incidence.vars[i];
      if (last_factor[v] == f) continue;
      last_factor[v] = f;
      a->rows[next[v]++] = f;  // factors visited in increasing order: columns come out sorted
    }
  }
}

}  // namespace

Status ValidateIncidence(int num_vars, const FactorIncidence& incidence) {
  if (num_vars < 0) return InvalidArgument("num_vars = " + std::to_string(num_vars) + " < 0");
  if (incidence.offsets.empty() || incidence.offsets[0] != 0) {
    return InvalidArgument("FactorIncidence::offsets must start with 0");
  }
  for (size_t f = 0; f + 1 < incidence.offsets.size(); ++f) {
    if (incidence.offsets[f + 1] < incidence.offsets[f]) {
      return InvalidArgument("FactorIncidence::offsets decreases at factor " + std::to_string(f));
    }
  }
  if (static_cast<size_t>(incidence.offsets.back()) != incidence.vars.size()) {
    return InvalidArgument("FactorIncidence::offsets.back() = " +
                           std::to_string(incidence.offsets.back()) + " but vars has " +
                           std::to_string(incidence.vars.size()) + " entries");
  }
  for (size_t i = 0; i < incidence.vars.size(); ++i) {
    const int v = incidence.vars[i];
    if (v < 0 || v >= num_vars) {
      return InvalidArgument("FactorIncidence::vars[" + std::to_string(i) + "] = " +
                             std::to_string(v) + " outside [0, " + std::to_string(num_vars) + ")");
    }
  }
  return Status::Ok();
}

Result<std::vector<int>> ColamdOrdering(int num_vars, const FactorIncidence& incidence) {
  SLAMD_RETURN_IF_ERROR(ValidateIncidence(num_vars, incidence));
  std::vector<int> order(num_vars);
  ColumnMatrix a = BuildColumns(num_vars, incidence);
  if (a.nnz == 0) {  // nothing to order (also keeps COLAMD away from degenerate sizes)
    std::iota(order.begin(), order.end(), 0);
    return order;
  }
  const int num_factors = incidence.NumFactors();
  const size_t alen = colamd_recommended(a.nnz, num_factors, num_vars);
  if (alen == 0 || alen > static_cast<size_t>(std::numeric_limits<int>::max())) {
    return FailedPrecondition("COLAMD: problem too large (nnz = " + std::to_string(a.nnz) + ")");
  }
  FillRows(num_vars, incidence, alen, &a);
  double knobs[COLAMD_KNOBS];
  colamd_set_defaults(knobs);
  int stats[COLAMD_STATS];
  // COLAMD overwrites col_ptr with the column permutation (p[k] = column ordered k-th).
  std::vector<int> p = a.col_ptr;
  const int ok = colamd(num_factors, num_vars, static_cast<int>(alen), a.rows.data(), p.data(),
                        knobs, stats);
  if (!ok || stats[COLAMD_STATUS] < 0) {
    return FailedPrecondition("COLAMD failed with status " + std::to_string(stats[COLAMD_STATUS]));
  }
  std::copy(p.begin(), p.begin() + num_vars, order.begin());
  return order;
}

Result<std::vector<int>> ConstrainedColamdOrdering(int num_vars, const FactorIncidence& incidence,
                                                   const std::vector<int>& group) {
  SLAMD_RETURN_IF_ERROR(ValidateIncidence(num_vars, incidence));
  if (static_cast<int>(group.size()) != num_vars) {
    return InvalidArgument("group has " + std::to_string(group.size()) + " entries, expected " +
                           std::to_string(num_vars));
  }
  // CCOLAMD wants constraint sets numbered 0..n_col-1; map arbitrary ints to dense ranks.
  std::vector<int> distinct = group;
  std::sort(distinct.begin(), distinct.end());
  distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
  std::vector<int> cmember(num_vars);
  for (int v = 0; v < num_vars; ++v) {
    cmember[v] = static_cast<int>(std::lower_bound(distinct.begin(), distinct.end(), group[v]) -
                                  distinct.begin());
  }

  std::vector<int> order(num_vars);
  ColumnMatrix a = BuildColumns(num_vars, incidence);
  if (a.nnz == 0) {  // no structure: only the groups matter
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
                     [&](int x, int y) { return cmember[x] < cmember[y]; });
    return order;
  }
  const int num_factors = incidence.NumFactors();
  const size_t alen = ccolamd_recommended(a.nnz, num_factors, num_vars);
  if (alen == 0 || alen > static_cast<size_t>(std::numeric_limits<int>::max())) {
    return FailedPrecondition("CCOLAMD: problem too large (nnz = " + std::to_string(a.nnz) + ")");
  }
  FillRows(num_vars, incidence, alen, &a);
  double knobs[CCOLAMD_KNOBS];
  ccolamd_set_defaults(knobs);
  int stats[CCOLAMD_STATS];
  std::vector<int> p = a.col_ptr;
  const int ok = ccolamd(num_factors, num_vars, static_cast<int>(alen), a.rows.data(), p.data(),
                         knobs, stats, cmember.data());
  if (!ok || stats[CCOLAMD_STATUS] < 0) {
    return FailedPrecondition("CCOLAMD failed with status " +
                              std::to_string(stats[CCOLAMD_STATUS]));
  }
  std::copy(p.begin(), p.begin() + num_vars, order.begin());
  return order;
}

namespace {

// Whether the rows of `incidence` tie together at least `min_density` of the pairs of its
// num_vars variables (num_vars <= kMaxDensityVars; a bit per pair).
bool DenseEnough(int num_vars, const FactorIncidence& incidence, double min_density) {
  if (min_density <= 0.0 || num_vars < 2) return true;
  const double all = 0.5 * num_vars * (num_vars - 1.0);
  const long needed = static_cast<long>(std::ceil(min_density * all));
  std::vector<std::uint64_t> bits((static_cast<std::size_t>(num_vars) * num_vars + 63) / 64, 0);
  long pairs = 0;
  for (int f = 0; f < incidence.NumFactors(); ++f) {
    for (int i = incidence.offsets[f]; i < incidence.offsets[f + 1]; ++i) {
      for (int j = incidence.offsets[f]; j < i; ++j) {
        const int a = std::max(incidence.vars[i], incidence.vars[j]);
        const int b = std::min(incidence.vars[i], incidence.vars[j]);
        if (a == b) continue;
        const std::size_t bit = static_cast<std::size_t>(a) * num_vars + b;
        std::uint64_t& word = bits[bit / 64];
        const std::uint64_t mask = std::uint64_t{1} << (bit % 64);
        if (word & mask) continue;
        word |= mask;
        if (++pairs >= needed) return true;
      }
    }
  }
  return false;
}

}  // namespace

Result<std::vector<int>> IndependentFirstOrdering(int num_vars, const FactorIncidence& incidence,
                                                  const std::vector<char>& independent,
                                                  const std::vector<int>& group,
                                                  double min_density) {
  SLAMD_RETURN_IF_ERROR(ValidateIncidence(num_vars, incidence));
  if (static_cast<int>(independent.size()) != num_vars ||
      static_cast<int>(group.size()) != num_vars) {
    return InvalidArgument("independent and group need " + std::to_string(num_vars) +
                           " entries, have " + std::to_string(independent.size()) + " and " +
                           std::to_string(group.size()));
  }
  // The unmarked variables, numbered densely for the reduced system.
  std::vector<int> order;
  std::vector<int> rest_id(num_vars, -1), rest_var, rest_group;
  for (int v = 0; v < num_vars; ++v) {
    if (independent[v]) {
      order.push_back(v);
    } else {
      rest_id[v] = static_cast<int>(rest_var.size());
      rest_var.push_back(v);
      rest_group.push_back(group[v]);
    }
  }
  // Each marked variable's neighbours (factors in CSR by marked variable), and the factors
  // without a marked variable as they are.
  const int num_factors = incidence.NumFactors();
  std::vector<int> owner(num_factors, -1);
  FactorIncidence reduced;
  for (int f = 0; f < num_factors; ++f) {
    for (int i = incidence.offsets[f]; i < incidence.offsets[f + 1]; ++i) {
      const int v = incidence.vars[i];
      if (!independent[v] || v == owner[f]) continue;
      if (owner[f] >= 0) {
        return FailedPrecondition("factor " + std::to_string(f) + " touches variables " +
                                  std::to_string(owner[f]) + " and " + std::to_string(v) +
                                  ", both marked independent");
      }
      owner[f] = v;
    }
    if (owner[f] < 0) {
      for (int i = incidence.offsets[f]; i < incidence.offsets[f + 1]; ++i) {
        reduced.vars.push_back(rest_id[incidence.vars[i]]);
      }
      reduced.offsets.push_back(static_cast<int>(reduced.vars.size()));
    }
  }
  std::vector<int> ptr(num_vars + 1, 0);
  for (int f = 0; f < num_factors; ++f) {
    if (owner[f] >= 0) ++ptr[owner[f] + 1];
  }
  std::partial_sum(ptr.begin(), ptr.end(), ptr.begin());
  std::vector<int> by_owner(ptr[num_vars]), cursor(ptr.begin(), ptr.end() - 1);
  for (int f = 0; f < num_factors; ++f) {
    if (owner[f] >= 0) by_owner[cursor[owner[f]]++] = f;
  }
  std::vector<int> seen(rest_var.size(), -1);
  std::vector<int> row_of(num_vars, -1);  // a marked variable's row in `reduced` (-1: none)
  for (int v : order) {
    for (int k = ptr[v]; k < ptr[v + 1]; ++k) {
      const int f = by_owner[k];
      for (int i = incidence.offsets[f]; i < incidence.offsets[f + 1]; ++i) {
        const int r = rest_id[incidence.vars[i]];
        if (r >= 0 && seen[r] != v) {
          seen[r] = v;
          reduced.vars.push_back(r);
        }
      }
    }
    if (reduced.vars.size() > static_cast<size_t>(reduced.offsets.back())) {
      row_of[v] = reduced.NumFactors();
      reduced.offsets.push_back(static_cast<int>(reduced.vars.size()));
    }
  }
  const int num_rest = static_cast<int>(rest_var.size());
  if (min_density > 0.0 &&
      (num_rest > kMaxDensityVars || !DenseEnough(num_rest, reduced, min_density))) {
    return FailedPrecondition("the system left after the independent variables is sparser than " +
                              std::to_string(min_density));
  }
  Result<std::vector<int>> rest = ConstrainedColamdOrdering(num_rest, reduced, rest_group);
  if (!rest.ok()) return rest.status();
  // The marked variables sorted by where their neighbours are eliminated (the first, then the
  // last): those seen from the same poses come together, so the parents' assembly of their
  // updates stays in the same part of the parents' matrices (in index order, eliminating
  // Ladybug-49's top took 1.5x as long).
  std::vector<int> rest_pos(rest_var.size());
  for (int k = 0; k < static_cast<int>(rest->size()); ++k) rest_pos[(*rest)[k]] = k;
  std::vector<std::pair<int, int>> span(num_vars, {std::numeric_limits<int>::max(), -1});
  for (int v : order) {
    if (row_of[v] < 0) continue;  // no neighbours: last
    for (int i = reduced.offsets[row_of[v]]; i < reduced.offsets[row_of[v] + 1]; ++i) {
      span[v].first = std::min(span[v].first, rest_pos[reduced.vars[i]]);
      span[v].second = std::max(span[v].second, rest_pos[reduced.vars[i]]);
    }
  }
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return span[a] < span[b]; });
  for (int r : *rest) order.push_back(rest_var[r]);
  return order;
}

std::vector<int> InversePermutation(const std::vector<int>& perm) {
  SLAMD_DCHECK(IsPermutation(perm)) << "not a permutation";
  std::vector<int> inverse(perm.size());
  for (size_t k = 0; k < perm.size(); ++k) inverse[perm[k]] = static_cast<int>(k);
  return inverse;
}

bool IsPermutation(const std::vector<int>& perm) {
  const int n = static_cast<int>(perm.size());
  std::vector<char> seen(n, 0);
  for (int v : perm) {
    if (v < 0 || v >= n || seen[v]) return false;
    seen[v] = 1;
  }
  return true;
}

}  // namespace slamd::core
