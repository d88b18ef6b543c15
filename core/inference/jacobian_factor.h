// JacobianFactor: one linearised factor in dense row-block form, on dense variable ids.
//
// It stands for the least-squares term |Σ_k A_k δ_{v_k} + b|², where δ_v is the tangent-space
// update of variable v (dimension dim(k)), A_k is rows() x dim(k) and b has rows() entries (the
// whitened residual, sign convention of LinearizedFactor: the minimiser solves AᵀA δ = -Aᵀb).
//
// Storage: one contiguous column-major rows x (Dim() + 1) array [A_0 | A_1 | ... | b], so every
// block and b are contiguous and Reset()/Assign()/Linearize() on an existing object allocate
// nothing once the capacity suffices (iSAM2 relinearises cached factors in place). Any number of
// variables.
//
// Variable ids are dense ints (the isam2 layer maps Keys to ids); a factor does not know the
// graph's dimension table, Eliminate() checks dim(k) against it.
// Thread safety: const methods may run concurrently.
#pragma once

#include <Eigen/Core>
#include <span>
#include <vector>

#include "core/base/inlined_vector.h"
#include "core/base/status.h"
#include "core/factors/factor.h"

namespace slamd::core {

class JacobianFactor {
 public:
  JacobianFactor() = default;

  // Builds a factor from dense blocks: blocks[k] is rows x dim of variable vars[k], b has rows
  // entries. Fails (kInvalidArgument) on empty/mismatched sizes, duplicate or negative ids, or
  // non-finite entries.
  static Result<JacobianFactor> Create(std::span<const int> vars,
                                       std::span<const Eigen::MatrixXd> blocks,
                                       const Eigen::VectorXd& b);

  // Sets the shape (rows >= 1; vars distinct, >= 0; dims >= 1) and zeroes every entry. Reuses the
  // storage: no allocation when the shape fits the current capacity.
  Status Reset(int rows, std::span<const int> vars, std::span<const int> dims);

  // Copies a linearised factor: ids[k] is the variable id of the factor's k-th key
  // (ids.size() == linearized.num_keys()). Same failure modes and allocation behaviour as
  // Reset(), plus kInvalidArgument on non-finite entries.
  Status Assign(const LinearizedFactor& linearized, std::span<const int> ids);
  // Linearises `factor` at `values` in place (no copy); ids as for Assign.
  Status Linearize(const Factor& factor, const Values& values, std::span<const int> ids);
  // Bytes allocated for it beyond the object, for memory reports.
  std::size_t StorageBytes() const { return linear_.StorageBytes() + vars_.HeapBytes(); }
  // As HessianFactor::RenumberVariables.
  void RenumberVariables(std::span<const int> new_id);

  int rows() const { return linear_.rows(); }
  int num_vars() const { return static_cast<int>(vars_.size()); }
  std::span<const int> vars() const { return {vars_.data(), vars_.size()}; }
  int var(int k) const { return vars_[k]; }
  int dim(int k) const { return linear_.dim(k); }
  // Column offset of block k inside Ab().
  int offset(int k) const { return linear_.offset(k); }
  // Σ dims: the number of columns of A (b is column Dim() of Ab()).
  int Dim() const { return linear_.Dim(); }

  // The whole augmented matrix [A_0 ... A_{p-1} b], rows() x (Dim() + 1), column-major.
  Eigen::Map<const Eigen::MatrixXd> Ab() const { return linear_.Ab(); }
  Eigen::Map<Eigen::MatrixXd> mutable_Ab() { return linear_.MutableAb(); }
  // Block k (rows() x dim(k)) and the right-hand side b (contiguous: whole columns).
  Eigen::Map<const Eigen::MatrixXd> A(int k) const { return linear_.Block(k); }
  Eigen::Map<Eigen::MatrixXd> mutable_A(int k) { return linear_.MutableBlock(k); }
  Eigen::Map<const Eigen::VectorXd> b() const { return linear_.Rhs(); }
  Eigen::Map<Eigen::VectorXd> mutable_b() { return linear_.MutableRhs(); }
  // Raw column-major storage (leading dimension rows()), for the elimination kernels.
  const double* data() const { return linear_.data(); }

  // |Σ A_k δ_{v_k} + b|² for a stacked update δ: variable v occupies
  // delta[var_offsets[v], var_offsets[v] + dim). Used by tests and error checks.
  double Error(std::span<const int> var_offsets, const Eigen::VectorXd& delta) const;

 private:
  // Sets vars_ after checking them against the shape of linear_.
  Status SetVars(std::span<const int> ids);

  LinearizedFactor linear_;
  InlinedVector<int, 4> vars_;  // inline up to 4 variables
};

}  // namespace slamd::core
