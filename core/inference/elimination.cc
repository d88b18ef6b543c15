#include "core/inference/elimination.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "core/base/inlined_vector.h"
#include "core/base/param_check.h"
#include "core/linear/partial_cholesky.h"

namespace slamd::core {
namespace {

std::string Str(int v) { return std::to_string(v); }

// M += [A b]ᵀ[A b] scattered to the clique's offsets, lower triangle only (the diagonal blocks'
// lower halves included). Plain loops: the blocks are at most 6 wide; ScatterFactor
// instantiates this for the usual row counts so the dot products are fully unrolled.
template <int kRows>
void ScatterJacobian(const double* data, int rows, const internal::ScatterBlock* blocks, int p,
                     int ld, double* M, double* ref) {
  const int m = kRows > 0 ? kRows : rows;
  for (int a = 0; a <= p; ++a) {
    for (int b = 0; b <= a; ++b) {
      const internal::ScatterBlock* row = &blocks[a];
      const internal::ScatterBlock* col = &blocks[b];
      if (row->target < col->target) std::swap(row, col);
      for (int cc = 0; cc < col->dim; ++cc) {
        const double* y = data + static_cast<size_t>(col->source + cc) * m;
        double* dst = M + static_cast<size_t>(col->target + cc) * ld + row->target;
        for (int rr = (a == b ? cc : 0); rr < row->dim; ++rr) {
          const double* x = data + static_cast<size_t>(row->source + rr) * m;
          double s = 0.0;
          for (int i = 0; i < m; ++i) s += x[i] * y[i];
          dst[rr] += s;
        }
      }
    }
  }
  // The raw diagonal is the pivot reference of a Jacobian factor (squared column norms).
  for (int a = 0; a < p; ++a) {
    for (int c = 0; c < blocks[a].dim; ++c) {
      const double* x = data + static_cast<size_t>(blocks[a].source + c) * m;
      double s = 0.0;
      for (int i = 0; i < m; ++i) s += x[i] * x[i];
      ref[blocks[a].target + c] += s;
    }
  }
}

constexpr int kUniformMaxVars = 4;  // the most variables ScatterUniformJacobian takes

// ScatterJacobian for the usual shape, kRows rows on variables of kDim each (a between factor
// of poses): each pair of variables is one fixed-size product AₐᵀA_b that Eigen unrolls and
// vectorises, where the plain loops above were scalar dot products of length kRows. The
// transposes are copied first: a column of Aₐᵀ is then contiguous, which the vectorised
// product needs (on Aₐᵀ read in place it falls back to scalar code).
template <int kRows, int kDim>
void ScatterUniformJacobian(const double* data, const internal::ScatterBlock* blocks, int p, int ld,
                            double* M, double* ref) {
  using Target = Eigen::Map<Eigen::Matrix<double, kDim, kDim>, 0, Eigen::OuterStride<>>;
  const Eigen::Map<const Eigen::Matrix<double, kRows, 1>> b(data + p * kDim * kRows);
  const int n = blocks[p].target;  // the right-hand side's row and column
  Eigen::Matrix<double, kDim, kRows> At[kUniformMaxVars];
  for (int a = 0; a < p; ++a) {
    At[a] = Eigen::Map<const Eigen::Matrix<double, kRows, kDim>>(data + blocks[a].source * kRows)
                .transpose();
  }
  for (int a = 0; a < p; ++a) {
    const int ta = blocks[a].target;
    const Eigen::Map<const Eigen::Matrix<double, kRows, kDim>> A(data + blocks[a].source * kRows);
    // The diagonal block: its lower triangle only (M's upper triangle is never read).
    const Eigen::Matrix<double, kDim, kDim> gram = At[a] * A;
    Target(M + static_cast<size_t>(ta) * ld + ta, kDim, kDim, Eigen::OuterStride<>(ld))
        .template triangularView<Eigen::Lower>() += gram;
    for (int c = 0; c < a; ++c) {
      const Eigen::Map<const Eigen::Matrix<double, kRows, kDim>> C(data + blocks[c].source * kRows);
      const int tc = blocks[c].target;
      // Blocks do not overlap, so the one with the larger offset gives the rows.
      if (ta > tc) {
        Target(M + static_cast<size_t>(tc) * ld + ta, kDim, kDim, Eigen::OuterStride<>(ld))
            .noalias() += At[a] * C;
      } else {
        Target(M + static_cast<size_t>(ta) * ld + tc, kDim, kDim, Eigen::OuterStride<>(ld))
            .noalias() += At[c] * A;
      }
    }
    // The right-hand side's row (bᵀA, along M's last row) and the pivot references.
    Eigen::Map<Eigen::Matrix<double, 1, kDim>, 0, Eigen::InnerStride<>>(
        M + static_cast<size_t>(ta) * ld + n, 1, kDim, Eigen::InnerStride<>(ld))
        .noalias() += (At[a] * b).transpose();
    Eigen::Map<Eigen::Matrix<double, kDim, 1>>(ref + ta) += gram.diagonal();
  }
  M[static_cast<size_t>(n) * ld + n] += b.squaredNorm();
}

void ScatterFactor(const JacobianFactor& f, const int* offset, int n, double* M, double* ref) {
  const int p = f.num_vars();
  InlinedVector<internal::ScatterBlock, kUniformMaxVars + 1> blocks(p + 1);  // heap past 4 vars
  bool uniform = p <= kUniformMaxVars;  // every variable of dim f.dim(0)
  for (int k = 0; k < p; ++k) {
    blocks[k] = {offset[f.var(k)], f.dim(k), f.offset(k)};
    uniform = uniform && f.dim(k) == f.dim(0);
  }
  blocks[p] = {n, 1, f.Dim()};
  const int ld = n + 1;
  if (uniform && f.rows() == 6 && f.dim(0) == 6) {
    return ScatterUniformJacobian<6, 6>(f.data(), blocks.data(), p, ld, M, ref);
  }
  if (uniform && f.rows() == 3 && f.dim(0) == 3) {
    return ScatterUniformJacobian<3, 3>(f.data(), blocks.data(), p, ld, M, ref);
  }
  switch (f.rows()) {
    case 1:
      return ScatterJacobian<1>(f.data(), 1, blocks.data(), p, ld, M, ref);
    case 2:
      return ScatterJacobian<2>(f.data(), 2, blocks.data(), p, ld, M, ref);
    case 3:
      return ScatterJacobian<3>(f.data(), 3, blocks.data(), p, ld, M, ref);
    case 6:
      return ScatterJacobian<6>(f.data(), 6, blocks.data(), p, ld, M, ref);
    default:
      return ScatterJacobian<0>(f.data(), f.rows(), blocks.data(), p, ld, M, ref);
  }
}

// M += info scattered to the clique's offsets, lower triangle only.
void ScatterFactor(const HessianFactor& h, const int* offset, int n, double* M, double* ref,
                   std::vector<internal::ScatterBlock>* scatter_blocks) {
  const int p = h.num_vars();
  const int ld = n + 1;
  scatter_blocks->resize(p + 1);
  internal::ScatterBlock* blocks = scatter_blocks->data();
  for (int k = 0; k < p; ++k) blocks[k] = {offset[h.var(k)], h.dim(k), h.offset(k)};
  blocks[p] = {n, 1, h.Dim()};
  const double* reference = h.reference().data();
  for (int a = 0; a < p; ++a) {
    for (int c = 0; c < blocks[a].dim; ++c)
      ref[blocks[a].target + c] += reference[blocks[a].source + c];
  }
  // Merge runs of variables that are adjacent both in info and in M (a child's separator is
  // usually a contiguous range of its parent's variables): fewer, longer inner loops. Every
  // entry still receives exactly one addition.
  int q = 0;
  for (int k = 1; k <= p; ++k) {
    if (blocks[k].target == blocks[q].target + blocks[q].dim) {
      blocks[q].dim += blocks[k].dim;  // sources are contiguous by construction
    } else {
      blocks[++q] = blocks[k];
    }
  }
  // Pairs a >= b cover info's lower triangle once (blocks are in info's order). A block lands
  // in M's lower triangle as it is when the variables keep their order in M (a child's
  // separator does: it is ordered as its parent eliminates), else transposed (an orphan's cached
  // factor under a new order).
  for (int a = 0; a <= q; ++a) {
    for (int b = 0; b <= a; ++b) {
      const internal::ScatterBlock& row = blocks[a];
      const internal::ScatterBlock& col = blocks[b];
      if (row.target >= col.target) {
        for (int cc = 0; cc < col.dim; ++cc) {
          // info(row.source + rr, col.source + cc), rr >= cc on the diagonal block.
          const double* src = h.column(col.source + cc) + (row.source - col.source - cc);
          double* dst = M + static_cast<size_t>(col.target + cc) * ld + row.target;
          for (int rr = (a == b ? cc : 0); rr < row.dim; ++rr) dst[rr] += src[rr];
        }
      } else {  // a > b: M(col.target + j, row.target + i) += info(row.source + i, col.source + j)
        for (int j = 0; j < col.dim; ++j) {
          const double* src = h.column(col.source + j) + (row.source - col.source - j);
          for (int i = 0; i < row.dim; ++i) {
            M[static_cast<size_t>(row.target + i) * ld + col.target + j] += src[i];
          }
        }
      }
    }
  }
}

// Asks for the cache lines of data[0, size) to be loaded (a hint: no fault, no wait).
void Prefetch(const double* data, size_t size) {
  const char* bytes = reinterpret_cast<const char*>(data);
  for (size_t b = 0; b < size * sizeof(double); b += 64) __builtin_prefetch(bytes + b);
}

}  // namespace

Status EliminationParams::Validate() const {
  if (!(relative_pivot_tolerance >= 0.0 && relative_pivot_tolerance < 1.0)) {
    return InvalidArgument("EliminationParams::relative_pivot_tolerance = " +
                           std::to_string(relative_pivot_tolerance) + "; violates range [0, 1)");
  }
  SLAMD_PARAM_CHECK(EliminationParams, relaxed_new_variables, >=, 0);
  SLAMD_PARAM_CHECK(EliminationParams, relaxed_max_frontals, >=, 1);
  return Status::Ok();
}

Status Eliminate(const EliminationProblem& problem, BayesTree* tree, EliminationResult* result,
                 const EliminationParams& params) {
  Eliminator eliminator(params);
  return eliminator.Eliminate(problem, tree, result);
}

Eliminator::Eliminator(EliminationParams params, int threads)
    : params_(params),
      threads_(threads),
      workspaces_(std::max(threads, 1)),
      pool_(std::max(threads, 1) - 1) {
  SLAMD_CHECK(threads >= 1) << "Eliminator: threads = " << threads << "; must be >= 1";
}

Status Eliminator::Eliminate(const EliminationProblem& problem, BayesTree* tree,
                             EliminationResult* result) {
  result->cliques.clear();
  result->hessian_cliques.assign(problem.hessians.size(), BayesTree::kNone);
  result->failed_variable = -1;
  result->threads_used = 1;
  // 1. Positions, factor assignment, pivot references.
  Status status = Prepare(problem, *tree);
  if (!status.ok()) {
    ResetPositions(problem.ordering);
    return status;
  }
  // 2. Symbolic phase: separators and supernodes.
  const int k = static_cast<int>(problem.ordering.size());
  const internal::SupernodeRule rule{.merge = params_.merge_supernodes,
                                     .relaxed_new_variables = params_.relaxed_new_variables,
                                     .relaxed_max_frontals = params_.relaxed_max_frontals};
  internal::BuildSymbolicForest(k, structure_ptr_, structure_pos_, hes_ptr_, rule, &forest_,
                                &symbolic_workspace_);
  // 3. Numeric phase into cliques created up front (so that threads only fill them), children
  //    before parents; then the links, in creation order.
  const int num = forest_.NumCliques();
  CliqueDims(problem);
  tree_id_.resize(num);
  for (int c = 0; c < num; ++c) {
    tree_id_[c] = tree->NewClique(Clique::MatrixDoubles(clique_nf_[c], clique_ns_[c]));
  }
  const bool parallel = threads_ > 1 && EstimateWork() >= kParallelMinWork;
  if (parallel && EliminateParallel(problem, tree, result)) {
    result->threads_used = threads_;
  } else {
    status = EliminateSerial(problem, tree, result);
  }
  if (!status.ok()) {
    // Freed again: the tree's free list holds the same slots as before (their storage may have
    // grown).
    for (int c = num - 1; c >= 0; --c) tree->FreeClique(tree_id_[c]);
    std::fill(result->hessian_cliques.begin(), result->hessian_cliques.end(), BayesTree::kNone);
    ResetPositions(problem.ordering);
    return status;
  }
  result->cliques.reserve(num);
  for (int c = 0; c < num; ++c) {
    const int id = tree_id_[c];
    for (int child = forest_.first_child[c]; child != -1; child = forest_.next_sibling[child]) {
      tree->Attach(tree_id_[child], id);
    }
    for (int v : tree->clique(id).frontals()) tree->SetCliqueOf(v, id);
    result->cliques.push_back(id);
  }
  ResetPositions(problem.ordering);
  return Status::Ok();
}

Status Eliminator::Prepare(const EliminationProblem& problem, const BayesTree& tree) {
  SLAMD_RETURN_IF_ERROR(params_.Validate());
  const int n = static_cast<int>(problem.var_dims.size());
  if (static_cast<int>(pos_.size()) < n) pos_.resize(n, -1);
  for (Workspace& ws : workspaces_) {
    if (static_cast<int>(ws.offset.size()) < n) ws.offset.resize(n, 0);
  }
  // 1a. Number the variables by position.
  const int k = static_cast<int>(problem.ordering.size());
  for (int p = 0; p < k; ++p) {
    const int v = problem.ordering[p];
    if (v < 0 || v >= n) {
      return InvalidArgument("Eliminate: ordering[" + Str(p) + "] = " + Str(v) + " outside [0, " +
                             Str(n) + ")");
    }
    if (pos_[v] != -1) return InvalidArgument("Eliminate: variable " + Str(v) + " ordered twice");
    if (problem.var_dims[v] < 1) {
      return InvalidArgument("Eliminate: variable " + Str(v) + " has dim " +
                             Str(problem.var_dims[v]));
    }
    if (tree.CliqueOf(v) != BayesTree::kNone) {
      return InvalidArgument("Eliminate: variable " + Str(v) + " is already frontal in clique " +
                             Str(tree.CliqueOf(v)) + " (remove it from the tree first)");
    }
    pos_[v] = p;
  }
  // 1b. Assign each factor to its first-eliminated variable (counting sort into CSR lists) and
  //     collect the structure for step 2.
  auto check_var = [&](int v, int dim, const char* kind, size_t index) -> Status {
    if (v < 0 || v >= n || pos_[v] < 0) {
      return InvalidArgument(std::string("Eliminate: ") + kind + " " + std::to_string(index) +
                             " touches variable " + Str(v) + ", which is not in the ordering");
    }
    if (dim != problem.var_dims[v]) {
      return InvalidArgument(std::string("Eliminate: ") + kind + " " + std::to_string(index) +
                             " has dim " + Str(dim) + " for variable " + Str(v) + " of dim " +
                             Str(problem.var_dims[v]));
    }
    return Status::Ok();
  };
  jac_ptr_.assign(k + 1, 0);
  hes_ptr_.assign(k + 1, 0);
  structure_ptr_.assign(k + 1, 0);
  first_.resize(problem.factors.size() + problem.hessians.size());
  for (size_t f = 0; f < problem.factors.size(); ++f) {
    const JacobianFactor* factor = problem.factors[f];
    if (factor == nullptr || factor->num_vars() == 0) {
      return InvalidArgument("Eliminate: factor " + std::to_string(f) + " is null or empty");
    }
    int first = k;
    for (int i = 0; i < factor->num_vars(); ++i) {
      const int v = factor->var(i);
      SLAMD_RETURN_IF_ERROR(check_var(v, factor->dim(i), "factor", f));
      first = std::min(first, pos_[v]);
    }
    first_[f] = first;
    ++jac_ptr_[first + 1];
    structure_ptr_[first + 1] += factor->num_vars();
  }
  for (size_t h = 0; h < problem.hessians.size(); ++h) {
    const HessianFactor* factor = problem.hessians[h];
    if (factor == nullptr || factor->num_vars() == 0) {
      return InvalidArgument("Eliminate: hessian " + std::to_string(h) + " is null or empty");
    }
    int first = k;
    for (int i = 0; i < factor->num_vars(); ++i) {
      const int v = factor->var(i);
      SLAMD_RETURN_IF_ERROR(check_var(v, factor->dim(i), "hessian", h));
      first = std::min(first, pos_[v]);
    }
    first_[problem.factors.size() + h] = first;
    ++hes_ptr_[first + 1];
    structure_ptr_[first + 1] += factor->num_vars();
  }
  for (int p = 0; p < k; ++p) {
    jac_ptr_[p + 1] += jac_ptr_[p];
    hes_ptr_[p + 1] += hes_ptr_[p];
    structure_ptr_[p + 1] += structure_ptr_[p];
  }
  // Fill the lists in input order (deterministic summation order).
  jac_list_.resize(problem.factors.size());
  hes_list_.resize(problem.hessians.size());
  structure_pos_.resize(structure_ptr_[k]);
  cursor_.assign(jac_ptr_.begin(), jac_ptr_.end() - 1);
  structure_cursor_.assign(structure_ptr_.begin(), structure_ptr_.end() - 1);
  for (size_t f = 0; f < problem.factors.size(); ++f) {
    const int first = first_[f];
    jac_list_[cursor_[first]++] = static_cast<int>(f);
    for (int v : problem.factors[f]->vars()) structure_pos_[structure_cursor_[first]++] = pos_[v];
  }
  cursor_.assign(hes_ptr_.begin(), hes_ptr_.end() - 1);
  for (size_t h = 0; h < problem.hessians.size(); ++h) {
    const int first = first_[problem.factors.size() + h];
    hes_list_[cursor_[first]++] = static_cast<int>(h);
    for (int v : problem.hessians[h]->vars()) structure_pos_[structure_cursor_[first]++] = pos_[v];
  }
  return Status::Ok();
}

void Eliminator::ShapeClique(const EliminationProblem& problem, int sym, BayesTree* tree,
                             Workspace* ws) const {
  // 3a. The clique's variables: frontals in elimination order, then the separator.
  ws->frontal_ids.clear();
  ws->frontal_dims.clear();
  ws->sep_ids.clear();
  ws->sep_dims.clear();
  for (int p = forest_.first_frontal[sym]; p != -1; p = forest_.next_frontal[p]) {
    const int v = problem.ordering[p];
    ws->frontal_ids.push_back(v);
    ws->frontal_dims.push_back(problem.var_dims[v]);
  }
  for (int i = forest_.sep_begin[sym]; i < forest_.sep_end[sym]; ++i) {
    const int v = problem.ordering[forest_.sep_data[i]];
    ws->sep_ids.push_back(v);
    ws->sep_dims.push_back(problem.var_dims[v]);
  }
  // 3e and 3f overwrite the whole conditional and cached factor, so they are not zeroed here.
  tree->mutable_clique(tree_id_[sym])
      .ResetForElimination(ws->frontal_ids, ws->frontal_dims, ws->sep_ids, ws->sep_dims);
}

Status Eliminator::EliminateClique(const EliminationProblem& problem, int sym, BayesTree* tree,
                                   Workspace* ws, std::vector<int>* hessian_cliques,
                                   bool shaped) const {
  const internal::SymbolicForest& forest = forest_;
  const int id = tree_id_[sym];
  Clique& clique = tree->mutable_clique(id);
  if (!shaped) ShapeClique(problem, sym, tree, ws);
  // The factors' entries are scattered over the heap, and a large re-elimination reads more of
  // them than the caches hold: loading them now overlaps the misses with 3b, which took 12%
  // off re-eliminating all of parking-garage. (The orphans' cached factors made no difference
  // beyond the noise; the children's are loaded one ahead in 3c.)
  for (int p = forest.first_frontal[sym]; p != -1; p = forest.next_frontal[p]) {
    for (int i = jac_ptr_[p]; i < jac_ptr_[p + 1]; ++i) {
      const JacobianFactor& f = *problem.factors[jac_list_[i]];
      Prefetch(f.data(), static_cast<size_t>(f.rows()) * (f.Dim() + 1));
    }
  }
  // The clique's variables (3a; from the clique when it was shaped beforehand).
  const std::span<const int> frontal_ids = clique.frontals(), sep_ids = clique.separator();

  // 3b. Offsets of the clique's variables in the dense augmented matrix M (n + 1 square; the
  //     last row/column is the right-hand side).
  int* offset = ws->offset.data();
  int n = 0;
  for (size_t i = 0; i < frontal_ids.size(); ++i) {
    offset[frontal_ids[i]] = n;
    n += clique.frontal_dim(static_cast<int>(i));
  }
  const int nf = n;
  for (size_t i = 0; i < sep_ids.size(); ++i) {
    offset[sep_ids[i]] = n;
    n += clique.separator_dim(static_cast<int>(i));
  }
  const int ld = n + 1;
  // Only the lower triangle is ever read or written (partial_cholesky.h), so only it is zeroed.
  std::vector<double>& matrix = ws->matrix;
  if (matrix.size() < static_cast<size_t>(ld) * ld) matrix.resize(static_cast<size_t>(ld) * ld);
  double* M = matrix.data();
  for (int c = 0; c < ld; ++c) {
    std::fill(M + static_cast<size_t>(c) * ld + c, M + static_cast<size_t>(c + 1) * ld, 0.0);
  }
  // Pivot references (partial_cholesky.h): the raw information assembled here plus the
  // references the children's cached factors carry.
  std::vector<double>& ref = ws->ref;
  ref.assign(ld, 0.0);

  // 3c. Assemble: the factors assigned to the frontals, then the children's cached factors.
  for (int p = forest.first_frontal[sym]; p != -1; p = forest.next_frontal[p]) {
    for (int i = jac_ptr_[p]; i < jac_ptr_[p + 1]; ++i) {
      ScatterFactor(*problem.factors[jac_list_[i]], offset, n, M, ref.data());
    }
    for (int i = hes_ptr_[p]; i < hes_ptr_[p + 1]; ++i) {
      ScatterFactor(*problem.hessians[hes_list_[i]], offset, n, M, ref.data(), &ws->scatter_blocks);
      (*hessian_cliques)[hes_list_[i]] = id;
    }
  }
  // The children's cached factors, each loaded while the one before is assembled (loading all
  // first, a root under thousands of points passed over tens of MB before it used any).
  const auto cached_of = [&](int c) -> const HessianFactor& {
    return tree->clique(tree_id_[c]).cached_factor();
  };
  const auto prefetch = [&](int c) {
    if (c != -1) Prefetch(cached_of(c).data(), HessianFactor::DataDoubles(cached_of(c).Dim()));
  };
  prefetch(forest.first_child[sym]);
  for (int c = forest.first_child[sym]; c != -1; c = forest.next_sibling[c]) {
    prefetch(forest.next_sibling[c]);
    ScatterFactor(cached_of(c), offset, n, M, ref.data(), &ws->scatter_blocks);
  }

  // 3d. Partial Cholesky of the frontal block: M's first nf columns become [Rᵀ; Sᵀ; −dᵀ] and
  //     the trailing block the Schur complement on the separator (lower triangles).
  const double tol = params_.relative_pivot_tolerance;
  int failed = internal::PartialCholeskyLower(M, ld, ld, nf, ref.data(), tol);
  bool non_finite_rhs = false;
  if (failed < 0) {
    for (int c = 0; c < nf && failed < 0; ++c) {
      if (!std::isfinite(M[static_cast<size_t>(c) * ld + n])) {
        failed = c;
        non_finite_rhs = true;
      }
    }
  }
  if (failed >= 0) {
    int k = 0;
    while (clique.frontal_offset(k + 1) <= failed) ++k;
    const int var = frontal_ids[k];
    ws->failed_variable = var;
    std::ostringstream message;
    message << "Eliminate: ";
    if (non_finite_rhs) {
      message << "non-finite right-hand side at variable " << var;
    } else if (ref[failed] == 0.0) {
      message << "variable " << var << " has no information (no factor constrains scalar "
              << failed - clique.frontal_offset(k) << " of it)";
    } else {
      message << "indeterminate system at variable " << var << ": pivot of its scalar "
              << failed - clique.frontal_offset(k) << " is not above " << tol
              << " x the information that flowed into it (" << ref[failed]
              << "): missing prior or gauge constraint?";
    }
    return NumericalFailure(message.str());
  }

  // 3e. The conditional [R S d]: row r is column r of M from row r on (R = Lᵀ), with d = −(...).
  //     Every entry is written: ResetForElimination left them unspecified.
  auto conditional = clique.mutable_conditional();
  for (int r = 0; r < nf; ++r) {
    const double* col = M + static_cast<size_t>(r) * ld;
    for (int c = 0; c < r; ++c) conditional(r, c) = 0.0;
    for (int c = r; c < n; ++c) conditional(r, c) = col[c];
    conditional(r, n) = -col[n];
  }
  // 3f. The cached factor: the trailing (separator + rhs) block's lower triangle, packed, and
  //     the propagated pivot references of the separator scalars.
  HessianFactor& cached = clique.mutable_cached_factor();
  const int ns1 = n - nf + 1;
  for (int c = 0; c < ns1; ++c) {
    const double* col = M + static_cast<size_t>(nf + c) * ld + nf;
    std::copy(col + c, col + ns1, cached.mutable_column(c));
  }
  std::copy_n(&ref[nf], n - nf, cached.mutable_reference().data());
  return Status::Ok();
}

void Eliminator::ResetPositions(std::span<const int> ordering) {
  const int n = static_cast<int>(pos_.size());
  for (int v : ordering) {
    if (v >= 0 && v < n) pos_[v] = -1;
  }
}

}  // namespace slamd::core
