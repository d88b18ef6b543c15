// ReducedCameraMatrix: the reduced camera system S = U − W V⁻¹ Wᵀ of bundle adjustment (the
// points eliminated), stored as its upper block triangle: one D x D block per pair of cameras
// that see a common point (co-visibility), in the cameras' elimination order ("positions").
// The bundle adjuster adds into it point by point (schur_elimination.h); then it is solved
// densely (Eigen's LLᵀ, for few cameras) or by CHOLMOD (sparse, cameras in a fill-reducing
// order). Internal to core/ba.
//
// Thread safety: blocks may be written concurrently by threads that do not share a block row
// (the adjuster locks rows); everything else: one thread.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/base/status.h"
#include "core/geometry/eigen_types.h"
#include "core/linear/sparse_cholesky.h"

namespace slamd::core::internal {

class ReducedCameraMatrix {
 public:
  // `neighbours[i]`: the positions k >= i of the cameras that share a point with the camera at
  // position i (i itself included), ascending. D: unknowns per camera.
  ReducedCameraMatrix(int block_dim, std::vector<std::vector<int>> neighbours);

  int block_dim() const { return d_; }
  int num_cameras() const { return static_cast<int>(row_start_.size()) - 1; }
  int dim() const { return d_ * num_cameras(); }
  long num_blocks() const { return static_cast<long>(col_.size()); }

  void SetZero();
  // The index of block (i, k), i <= k, both positions; -1 when the cameras share no point.
  long BlockIndex(int i, int k) const;
  // Column-major D x D storage of block `index`.
  double* Block(long index) { return values_.data() + index * d_ * d_; }
  const double* Block(long index) const { return values_.data() + index * d_ * d_; }
  // The first block index of row i and one past its last; column positions via Column(index).
  long RowBegin(int i) const { return row_start_[i]; }
  long RowEnd(int i) const { return row_start_[i + 1]; }
  int Column(long index) const { return col_[index]; }

  // Solves S x = b (b, x: dim() entries, positions order) by a dense LLᵀ. kNumericalFailure
  // when S is not numerically positive definite. The matrix form: one column per right-hand side.
  Status SolveDense(const Eigen::VectorXd& b, Eigen::VectorXd* x) const;
  Status SolveDense(const Eigen::MatrixXd& b, Eigen::MatrixXd* x) const;
  // The same by CHOLMOD; the symbolic analysis is kept between calls (the pattern never changes).
  Status SolveSparse(const Eigen::VectorXd& b, Eigen::VectorXd* x);
  // SolveSparse in two steps, to solve for many right-hand sides with one factorisation.
  Status FactorSparse();
  Status SolveFactored(const Eigen::VectorXd& b, Eigen::VectorXd* x);
  // Decouples unknown k (positions order, scalar): its row and column zero, its diagonal 1, so
  // that the solution's entry k is b's and the rest solve S without unknown k (a gauge).
  void Pin(int k);
  // Entries of the Cholesky factor of the last SolveSparse (0 before it).
  long FactorNonZeros() const { return cholesky_ ? cholesky_->FactorNonZeros() : 0; }

  // S as a dense symmetric matrix (tests, marginals of small problems).
  Eigen::MatrixXd ToDense() const;

 private:
  void BuildCompressedColumns();

  int d_;
  std::vector<long> row_start_;  // block rows: [row_start_[i], row_start_[i+1]) in col_/values_
  std::vector<int> col_;         // column position of each block
  std::vector<double> values_;
  // Compressed-column upper triangle for CHOLMOD, built on the first SolveSparse: entry t comes
  // from values_[source_[t]].
  std::vector<int> col_ptr_, row_idx_;
  std::vector<long> source_;
  std::vector<double> csc_values_;
  std::unique_ptr<SparseCholesky> cholesky_;
};

// Floating-point operations of the LLᵀ of a matrix of D x D blocks with the upper block pattern
// `neighbours` (as the constructor takes it), eliminated in that order: a symbolic factorisation
// of the block pattern, column j of the factor costing about (c_j + 1)² D³ for its c_j blocks
// below the diagonal. O(blocks of the factor).
double BlockCholeskyFlops(int block_dim, const std::vector<std::vector<int>>& neighbours);

}  // namespace slamd::core::internal
