// LinearizedFactor: a factor's whitened Jacobian blocks and residual at one linearisation point,
// the output of Factor::Linearize.
//
// It stands for the least-squares term |Σ_k A_k δ_k + b|² in the right perturbations δ_k of the
// factor's keys (the minimiser solves AᵀA δ = -Aᵀb). Storage is one contiguous column-major
// rows x (Dim() + 1) array [A_0 | A_1 | ... | b], so each block and b are contiguous. Reset()
// keeps the storage: an object reused for linearisation after linearisation allocates only when
// it meets a larger factor than before (none in a solver's steady state).
#pragma once

#include <Eigen/Core>
#include <span>
#include <vector>

#include "core/base/inlined_vector.h"

namespace slamd::core {

class LinearizedFactor {
 public:
  // Sets the shape: `rows` residual entries and a block of rows x dims[k] per key. The entries
  // are left unset (Linearize overwrites every one).
  void Reset(int rows, std::span<const int> dims) {
    rows_ = rows;
    offsets_.resize(dims.size() + 1);
    offsets_[0] = 0;
    for (std::size_t k = 0; k < dims.size(); ++k) offsets_[k + 1] = offsets_[k] + dims[k];
    data_.resize(static_cast<std::size_t>(rows) * (Dim() + 1));
  }

  int rows() const { return rows_; }
  int num_keys() const { return offsets_.empty() ? 0 : static_cast<int>(offsets_.size()) - 1; }
  int dim(int k) const { return offsets_[k + 1] - offsets_[k]; }
  // Column of block k inside Ab().
  int offset(int k) const { return offsets_[k]; }
  // Σ dims: the columns of A (b is column Dim() of Ab()).
  int Dim() const { return offsets_.empty() ? 0 : offsets_.back(); }

  // Block k, rows() x dim(k), and b, column-major and contiguous.
  double* A(int k) { return data_.data() + static_cast<std::size_t>(offsets_[k]) * rows_; }
  const double* A(int k) const {
    return data_.data() + static_cast<std::size_t>(offsets_[k]) * rows_;
  }
  double* b() { return data_.data() + static_cast<std::size_t>(Dim()) * rows_; }
  const double* b() const { return data_.data() + static_cast<std::size_t>(Dim()) * rows_; }
  Eigen::Map<const Eigen::MatrixXd> Block(int k) const { return {A(k), rows_, dim(k)}; }
  Eigen::Map<Eigen::MatrixXd> MutableBlock(int k) { return {A(k), rows_, dim(k)}; }
  Eigen::Map<const Eigen::VectorXd> Rhs() const { return {b(), rows_}; }
  Eigen::Map<Eigen::VectorXd> MutableRhs() { return {b(), rows_}; }
  // Bytes allocated for it (capacity, not size), for memory reports.
  std::size_t StorageBytes() const {
    return data_.capacity() * sizeof(double) + offsets_.HeapBytes();
  }
  // [A_0 ... A_{k-1} b], rows() x (Dim() + 1).
  Eigen::Map<const Eigen::MatrixXd> Ab() const { return {data_.data(), rows_, Dim() + 1}; }
  Eigen::Map<Eigen::MatrixXd> MutableAb() { return {data_.data(), rows_, Dim() + 1}; }
  const double* data() const { return data_.data(); }

 private:
  int rows_ = 0;
  InlinedVector<int, 5> offsets_;  // num_keys() + 1 column offsets (inline up to 4 keys)
  std::vector<double> data_;
};

}  // namespace slamd::core
