// LandmarkSchur: solves normal equations whose first variables in elimination order are
// landmarks (variables no factor shares with another landmark: the points of visual SLAM and
// bundle adjustment) by eliminating the landmarks in closed form. With
//   H = [Hll Hlr; Hrl Hrr],  Hll block-diagonal (one small block per landmark),
//   S = Hrr − Hrl Hll⁻¹ Hlr,  s = b_r − Hrl Hll⁻¹ b_l,   S δ_r = s,   δ_l = Hll⁻¹ (b_l − Hlr δ_r).
// S, the Schur complement (bundle adjustment's reduced camera system), is a BlockSparseSystem of
// its own on the other variables, in H's order, for the sparse Cholesky to factor. A sparse
// Cholesky given H in the same order computes the same numbers, but pays its per-column
// bookkeeping on every landmark scalar and factors S column by column (simplicial) or through
// the reference BLAS (supernodal); here each landmark costs a few small dense products.
//
// Thread safety: one thread per object.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "core/base/status.h"
#include "core/linear/block_sparse_system.h"

namespace slamd::core {

class LandmarkSchur {
 public:
  // `h` (its pattern; Reduce reads its values): its first `num_landmarks` variables in
  // elimination order are the landmarks. kInvalidArgument when two of them share a block of H.
  static Result<std::unique_ptr<LandmarkSchur>> Create(const BlockSparseSystem& h,
                                                       int num_landmarks);

  // S and s from h's current values (damping included). kNumericalFailure when a landmark's
  // block is not positive definite; *failed_variable is then that landmark (h's index).
  Status Reduce(const BlockSparseSystem& h, int* failed_variable);
  // The reduced system: its variable i is h's variable order()[num_landmarks + i], its scalars
  // are h's permuted scalars from LandmarkDim() on.
  BlockSparseSystem& reduced() { return s_; }
  // Scalars of all landmarks (the offset of the reduced system's scalars in h).
  int LandmarkDim() const { return landmark_dim_; }

  // δ in h's permuted order from the reduced system's solution (after a successful Reduce, h
  // unchanged since).
  void BackSubstitute(const BlockSparseSystem& h, const Eigen::VectorXd& delta_rest,
                      Eigen::VectorXd* delta) const;

 private:
  // A variable of the reduced system sharing a block with a landmark: that block's entry (i, j)
  // (landmark row i, the variable's column j) is h.values()[base + j·stride + j(j+1)/2 + i].
  struct Border {
    int var;  // reduced-system variable
    int base;
    int stride;
  };
  explicit LandmarkSchur(BlockSparseSystem s) : s_(std::move(s)) {}

  int num_landmarks_ = 0;
  int landmark_dim_ = 0;
  std::vector<int> border_offsets_ = {0};  // landmark l's borders: [offsets[l], offsets[l+1])
  std::vector<Border> border_;
  std::vector<int> factor_of_landmark_;       // its factor in s_, or -1 (no border)
  std::vector<int> hrr_source_, hrr_target_;  // s_.values()[target] = h.values()[source]
  BlockSparseSystem s_;
  std::vector<double> cholesky_;       // per landmark its d x d factor L (column-major)
  std::vector<int> cholesky_offsets_;  // landmark l's factor at cholesky_[offsets[l]]
  std::vector<double> g_;              // L⁻¹·W of one landmark, reused
  std::vector<const double*> g_blocks_;
};

}  // namespace slamd::core
