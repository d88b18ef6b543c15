// JacobianFactor: one linearised factor in dense row-block form, on dense variable ids.
//
// It stands for the least-squares term |Σ_k A_k δ_{v_k} + b|², where δ_v is the tangent-space
// update of variable v (dimension dim(k)), A_k is rows() x dim(k) and b has rows() entries (the
// whitened residual, sign convention of LinearizedFactor: the minimiser solves AᵀA δ = -Aᵀb).
//
// Storage: one contiguous column-major rows x (Dim() + 1) array [A_0 | A_1 | ... | b], so every
// block and b are contiguous and Reset()/Assign() on an existing object allocate nothing once the
// capacity suffices (iSAM2 relinearises cached factors in place). At most kMaxVars variables.
//
// Variable ids are dense ints (the isam2 layer maps Keys to ids); a factor does not know the
// graph's dimension table, Eliminate() checks dim(k) against it.
// Thread safety: const methods may run concurrently.
#pragma once

#include <Eigen/Core>
#include <array>
#include <span>
#include <vector>

#include "core/base/status.h"
#include "core/factors/factor.h"

namespace slamd::core {

class JacobianFactor {
 public:
  // Enough for unary/binary factors and small multi-variable ones.
  static constexpr int kMaxVars = 4;

  JacobianFactor() = default;

  // Builds a factor from dense blocks: blocks[k] is rows x dim of variable vars[k], b has rows
  // entries. Fails (kInvalidArgument) on empty/mismatched sizes, duplicate or negative ids, more
  // than kMaxVars variables, or non-finite entries.
  static Result<JacobianFactor> Create(std::span<const int> vars,
                                       std::span<const Eigen::MatrixXd> blocks,
                                       const Eigen::VectorXd& b);

  // Sets the shape (rows >= 1; vars distinct, >= 0; dims >= 1) and zeroes every entry. Reuses the
  // storage: no allocation when rows * (Σ dims + 1) fits the current capacity.
  Status Reset(int rows, std::span<const int> vars, std::span<const int> dims);

  // Copies a linearised factor: ids[k] is the variable id of the factor's k-th key
  // (ids.size() == linearized.num_keys). Same failure modes and allocation behaviour as Reset(),
  // plus kInvalidArgument on non-finite entries.
  Status Assign(const LinearizedFactor& linearized, std::span<const int> ids);

  int rows() const { return rows_; }
  int num_vars() const { return num_vars_; }
  std::span<const int> vars() const { return {vars_.data(), static_cast<size_t>(num_vars_)}; }
  int var(int k) const { return vars_[k]; }
  int dim(int k) const { return offsets_[k + 1] - offsets_[k]; }
  // Column offset of block k inside Ab().
  int offset(int k) const { return offsets_[k]; }
  // Σ dims: the number of columns of A (b is column Dim() of Ab()).
  int Dim() const { return offsets_[num_vars_]; }

  // The whole augmented matrix [A_0 ... A_{p-1} b], rows() x (Dim() + 1), column-major.
  Eigen::Map<const Eigen::MatrixXd> Ab() const { return {data_.data(), rows_, Dim() + 1}; }
  Eigen::Map<Eigen::MatrixXd> mutable_Ab() { return {data_.data(), rows_, Dim() + 1}; }
  // Block k (rows() x dim(k)) and the right-hand side b (contiguous: whole columns).
  Eigen::Map<const Eigen::MatrixXd> A(int k) const {
    return {data_.data() + static_cast<size_t>(offsets_[k]) * rows_, rows_, dim(k)};
  }
  Eigen::Map<Eigen::MatrixXd> mutable_A(int k) {
    return {data_.data() + static_cast<size_t>(offsets_[k]) * rows_, rows_, dim(k)};
  }
  Eigen::Map<const Eigen::VectorXd> b() const {
    return {data_.data() + static_cast<size_t>(Dim()) * rows_, rows_};
  }
  Eigen::Map<Eigen::VectorXd> mutable_b() {
    return {data_.data() + static_cast<size_t>(Dim()) * rows_, rows_};
  }
  // Raw column-major storage (leading dimension rows()), for the elimination kernels.
  const double* data() const { return data_.data(); }

  // |Σ A_k δ_{v_k} + b|² for a stacked update δ: variable v occupies
  // delta[var_offsets[v], var_offsets[v] + dim). Used by tests and error checks.
  double Error(std::span<const int> var_offsets, const Eigen::VectorXd& delta) const;

 private:
  int rows_ = 0;
  int num_vars_ = 0;
  std::array<int, kMaxVars> vars_{};
  std::array<int, kMaxVars + 1> offsets_{};
  std::vector<double> data_;
};

}  // namespace slamd::core
