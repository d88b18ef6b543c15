// BlockSparseSystem: the Gauss-Newton normal equations H δ = b (H = Σ JᵀJ, b = -Σ Jᵀe) of a
// factor graph, assembled straight into the compressed-column (CSC) arrays a sparse Cholesky
// backend factorizes, in a given ELIMINATION ORDER.
//
// Layout. Variables are dense indices 0..n-1 with dimensions var_dims[v]. Scalars are numbered in
// two ways:
//   * original order: variables in index order, var v occupies [OriginalOffset(v), +dim);
//   * permuted order: variables in elimination order (order[0] first), var v occupies
//     [Offset(v), +dim). H's CSC arrays and rhs() use the permuted order, so the backend can
//     factorize them as they are (no reordering).
// Only the upper triangle (row <= column, scalar level, permuted order) is stored, with sorted
// row indices in every column. The pattern holds every diagonal block (even for a variable no
// factor touches, whose block stays zero until damping is added) and every off-diagonal block of
// two variables that share a factor.
//
// Why direct CSC and not dense blocks copied into CSC: every column of a block column has the
// same off-diagonal row structure, so entry (i, j) of the block (row var r, column var c) lives at
//     base(r, c) + j * R_c + j (j + 1) / 2 + i,
// where R_c is the number of scalar rows above c's diagonal block. Create() precomputes base and
// R_c for every pair of variables of every factor, so AddFactor() is a small dense product plus
// index arithmetic: no search, no allocation, and no second copy pass over H before each
// factorization (the copy would cost about as much as the assembly itself).
//
// LM usage: assemble once per linearization (SetZero + AddFactor for all factors), keep a copy of
// values() (plain std::vector assignment, no reallocation after the first), and for each damping
// value restore it and call AddToDiagonal / AddDiagonal before factorizing.
//
// Thread safety: const methods may run concurrently; AddFactor on one object must not (two
// factors can write the same entries).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/base/status.h"
#include "core/linear/ordering.h"

namespace slamd::core {

class BlockSparseSystem {
 public:
  // Builds the pattern. var_dims[v] >= 1 for every variable; order is a permutation of 0..n-1
  // (order[k] = variable eliminated k-th, as returned by ColamdOrdering); incidence lists, per
  // factor, the variables it touches, each at most once. The k-th variable of factor f in the
  // incidence is the k-th Jacobian block passed to AddFactor(f, ...).
  // Fails with kInvalidArgument on any inconsistency, or kOutOfRange if H would have more than
  // 2^31 - 1 stored entries. H and b start at zero. Cost: O(nnz(H) + Σ_f |f|² log deg).
  static Result<BlockSparseSystem> Create(const std::vector<int>& var_dims,
                                          const std::vector<int>& order,
                                          const FactorIncidence& incidence);

  // --- Sizes and index maps ---------------------------------------------------------------------
  int NumVariables() const { return static_cast<int>(var_dims_.size()); }
  int NumFactors() const { return static_cast<int>(factor_offsets_.size()) - 1; }
  int Dim() const { return dim_; }                     // number of scalar unknowns
  int NumNonZeros() const { return col_ptr_.back(); }  // stored entries (upper triangle)
  int VarDim(int var) const { return var_dims_[var]; }
  int Offset(int var) const { return offset_[var]; }                  // permuted scalar offset
  int OriginalOffset(int var) const { return original_offset_[var]; }  // original scalar offset
  const std::vector<int>& order() const { return order_; }

  // --- Numeric assembly ---------------------------------------------------------------------------
  // H = 0, b = 0 (the pattern is kept).
  void SetZero();

  // Adds factor f's contribution: H += JᵀJ, b -= Jᵀe. jacobians[k] points to a column-major
  // m x d_k block (leading dimension m) for the k-th variable of factor f; e has m entries
  // (whitened residual). Preconditions (SLAMD_DCHECK only): 0 <= f < NumFactors(), m >= 1.
  void AddFactor(int f, const double* const* jacobians, const double* e, int m);
  // The opposite: H −= JᵀJ, b += Jᵀe (a Schur complement's update, landmark_schur.h).
  void SubtractFactor(int f, const double* const* jacobians, const double* e, int m);

  // H += lambda * I.
  void AddToDiagonal(double lambda);
  // H += diag(d), d in ORIGINAL scalar order (size Dim()), e.g. d = lambda * clamp(Diagonal()).
  void AddDiagonal(const Eigen::VectorXd& d);
  // diag(H) in ORIGINAL scalar order.
  Eigen::VectorXd Diagonal() const;

  // Where entry (i, j) of a block lies in values(): at base + ColumnStart(j, stride) + i, with
  // `base` the block's entry (0, 0) and `stride` the rows above its column variable's diagonal
  // block (see Layout).
  static int ColumnStart(int j, int stride) { return j * stride + (j * (j + 1)) / 2; }

  // --- Backend access (permuted order) ------------------------------------------------------------
  // CSC of the upper triangle of H: column j holds rows row_idx()[col_ptr()[j] .. col_ptr()[j+1]),
  // ascending; the diagonal entry is the last one of each column.
  const std::vector<int>& col_ptr() const { return col_ptr_; }
  const std::vector<int>& row_idx() const { return row_idx_; }
  // Mutable so LM can save and restore the undamped values; size NumNonZeros().
  std::vector<double>& values() { return values_; }
  const std::vector<double>& values() const { return values_; }
  // b = -Σ Jᵀe in permuted order.
  Eigen::VectorXd& rhs() { return rhs_; }
  const Eigen::VectorXd& rhs() const { return rhs_; }

  // y = H x with x, y in permuted order (uses the stored upper triangle symmetrically).
  void MultiplyPermuted(const Eigen::VectorXd& x, Eigen::VectorXd* y) const;

  // Scalar reordering between the permuted and the original numbering; sizes Dim(). `out` is
  // resized; it must not alias the input.
  void ToOriginalOrder(const Eigen::VectorXd& permuted, Eigen::VectorXd* original) const;
  void FromOriginalOrder(const Eigen::VectorXd& original, Eigen::VectorXd* permuted) const;

  // --- For tests and diagnostics ------------------------------------------------------------------
  Eigen::MatrixXd ToDense() const;         // full symmetric H, original order
  Eigen::VectorXd RhsOriginalOrder() const;  // b, original order

 private:
  // Where one block JₐᵀJ_b of a factor goes: entry (i, j) at values_[base + j*stride + j(j+1)/2 + i].
  // `row` and `col` are the factor-local indices of the row and column variable (row == col for
  // a diagonal block, of which only i <= j is stored).
  struct BlockSlot {
    int base;
    int stride;
    std::int16_t row;
    std::int16_t col;
  };

  BlockSparseSystem() = default;
  template <int Sign>
  void Accumulate(int f, const double* const* jacobians, const double* e, int m);

  std::vector<int> var_dims_;
  std::vector<int> order_;
  std::vector<int> offset_;           // permuted scalar offset per variable
  std::vector<int> original_offset_;  // original scalar offset per variable
  std::vector<int> permuted_of_original_;  // permuted scalar index of each original scalar
  std::vector<int> diag_index_;       // values_ index of H(s, s), s in ORIGINAL scalar order
  int dim_ = 0;

  std::vector<int> factor_offsets_;  // copy of the incidence's CSR (factor -> variables)
  std::vector<int> factor_vars_;
  std::vector<int> slot_offsets_;    // factor f's slots: slots_[slot_offsets_[f] .. [f+1])
  std::vector<BlockSlot> slots_;

  std::vector<int> col_ptr_ = {0};
  std::vector<int> row_idx_;
  std::vector<double> values_;
  Eigen::VectorXd rhs_;
};

}  // namespace slamd::core
