#include "core/ba/reduced_camera_matrix.h"

#include <Eigen/Cholesky>
#include <algorithm>

#include "core/base/check.h"
#include "core/linear/partial_cholesky.h"

namespace slamd::core::internal {

ReducedCameraMatrix::ReducedCameraMatrix(int block_dim, std::vector<std::vector<int>> neighbours)
    : d_(block_dim) {
  const int n = static_cast<int>(neighbours.size());
  row_start_.assign(n + 1, 0);
  for (int i = 0; i < n; ++i) {
    SLAMD_CHECK(!neighbours[i].empty() && neighbours[i].front() == i)
        << "camera row " << i << " must start with its diagonal block";
    row_start_[i + 1] = row_start_[i] + static_cast<long>(neighbours[i].size());
  }
  col_.reserve(row_start_[n]);
  for (const std::vector<int>& row : neighbours) col_.insert(col_.end(), row.begin(), row.end());
  values_.assign(static_cast<size_t>(row_start_[n]) * d_ * d_, 0.0);
}

void ReducedCameraMatrix::SetZero() { std::fill(values_.begin(), values_.end(), 0.0); }

long ReducedCameraMatrix::BlockIndex(int i, int k) const {
  const auto begin = col_.begin() + row_start_[i], end = col_.begin() + row_start_[i + 1];
  const auto it = std::lower_bound(begin, end, k);
  return it != end && *it == k ? it - col_.begin() : -1;
}

Eigen::MatrixXd ReducedCameraMatrix::ToDense() const {
  const int n = num_cameras();
  Eigen::MatrixXd S = Eigen::MatrixXd::Zero(dim(), dim());
  for (int i = 0; i < n; ++i) {
    for (long b = row_start_[i]; b < row_start_[i + 1]; ++b) {
      const int k = col_[b];
      const Eigen::Map<const Eigen::MatrixXd> block(Block(b), d_, d_);
      S.block(d_ * i, d_ * k, d_, d_) = block;
      if (k != i) S.block(d_ * k, d_ * i, d_, d_) = block.transpose();
    }
  }
  // The solvers read only the upper triangle of the diagonal blocks: mirror it.
  for (int i = 0; i < n; ++i) {
    auto diag = S.block(d_ * i, d_ * i, d_, d_);
    diag = diag.selfadjointView<Eigen::Upper>().toDenseMatrix();
  }
  return S;
}

Status ReducedCameraMatrix::SolveDense(const Eigen::VectorXd& b, Eigen::VectorXd* x) const {
  Eigen::MatrixXd solution;
  SLAMD_RETURN_IF_ERROR(SolveDense(Eigen::MatrixXd(b), &solution));
  *x = solution.col(0);
  return Status::Ok();
}

Status ReducedCameraMatrix::SolveDense(const Eigen::MatrixXd& b, Eigen::MatrixXd* x) const {
  const int n = num_cameras(), dim = d_ * n;
  // The lower triangle (what PartialCholeskyLower reads): block (k, i) = block (i, k)ᵀ, and the
  // diagonal blocks' lower triangles from their upper ones. Pairs that share no point: 0.
  Eigen::MatrixXd S = Eigen::MatrixXd::Zero(dim, dim);
  for (int i = 0; i < n; ++i) {
    for (long blk = row_start_[i]; blk < row_start_[i + 1]; ++blk) {
      S.block(d_ * col_[blk], d_ * i, d_, d_) =
          Eigen::Map<const Eigen::MatrixXd>(Block(blk), d_, d_).transpose();
    }
  }
  Eigen::VectorXd ref = S.diagonal().cwiseAbs();
  // LLᵀ, blocked, its wide rank updates in the BLAS (partial_cholesky.h); fails on a pivot <= 0.
  if (PartialCholeskyLower(S.data(), dim, dim, dim, ref.data(), 0.0) >= 0) {
    return NumericalFailure("reduced camera system not positive definite");
  }
  *x = b;
  S.triangularView<Eigen::Lower>().solveInPlace(*x);
  S.triangularView<Eigen::Lower>().adjoint().solveInPlace(*x);
  return Status::Ok();
}

void ReducedCameraMatrix::BuildCompressedColumns() {
  const int n = num_cameras();
  // Block columns: for column position k, the block rows i <= k and their block indices.
  std::vector<std::vector<std::pair<int, long>>> columns(n);
  for (int i = 0; i < n; ++i) {
    for (long blk = row_start_[i]; blk < row_start_[i + 1]; ++blk) {
      columns[col_[blk]].emplace_back(i, blk);
    }
  }
  col_ptr_.assign(dim() + 1, 0);
  row_idx_.clear();
  source_.clear();
  for (int k = 0; k < n; ++k) {
    for (int c = 0; c < d_; ++c) {
      const int column = d_ * k + c;
      for (const auto& [i, blk] : columns[k]) {
        const int rows = i == k ? c + 1 : d_;  // the diagonal block: its upper triangle
        for (int r = 0; r < rows; ++r) {
          row_idx_.push_back(d_ * i + r);
          source_.push_back(blk * d_ * d_ + static_cast<long>(c) * d_ + r);
        }
      }
      col_ptr_[column + 1] = static_cast<int>(row_idx_.size());
    }
  }
  csc_values_.resize(source_.size());
  cholesky_ = SparseCholesky::Create();
}

Status ReducedCameraMatrix::SolveSparse(const Eigen::VectorXd& b, Eigen::VectorXd* x) {
  SLAMD_RETURN_IF_ERROR(FactorSparse());
  return SolveFactored(b, x);
}

Status ReducedCameraMatrix::FactorSparse() {
  if (!cholesky_) BuildCompressedColumns();
  for (size_t t = 0; t < source_.size(); ++t) csc_values_[t] = values_[source_[t]];
  std::string message;
  int failed_column = -1;
  const LinearSolverTermination factorized = cholesky_->Factorize(
      dim(), col_ptr_.data(), row_idx_.data(), csc_values_.data(), &message, &failed_column);
  if (factorized != LinearSolverTermination::kSuccess) {
    return NumericalFailure("reduced camera system: " + message);
  }
  return Status::Ok();
}

Status ReducedCameraMatrix::SolveFactored(const Eigen::VectorXd& b, Eigen::VectorXd* x) {
  SLAMD_CHECK(cholesky_ != nullptr) << "SolveFactored before FactorSparse";
  std::string message;
  x->resize(dim());
  if (cholesky_->Solve(b.data(), x->data(), &message) != LinearSolverTermination::kSuccess) {
    return NumericalFailure("reduced camera system: " + message);
  }
  return Status::Ok();
}

void ReducedCameraMatrix::Pin(int k) {
  const int i = k / d_, r = k % d_;
  // Blocks are column-major: entry (row, col) at col·D + row.
  for (long blk = row_start_[i]; blk < row_start_[i + 1]; ++blk) {  // row r of blocks (i, ≥ i)
    for (int c = 0; c < d_; ++c) Block(blk)[c * d_ + r] = 0.0;
  }
  for (int above = 0; above <= i; ++above) {  // column r of blocks (≤ i, i)
    const long blk = BlockIndex(above, i);
    if (blk >= 0) std::fill_n(Block(blk) + r * d_, d_, 0.0);
  }
  Block(row_start_[i])[r * d_ + r] = 1.0;  // a row's first block is its diagonal one
}

double BlockCholeskyFlops(int block_dim, const std::vector<std::vector<int>>& neighbours) {
  const int n = static_cast<int>(neighbours.size());
  // from_children[j]: the patterns of the factor's columns whose elimination-tree parent is j
  // (concatenated; j's own column takes their union, less j, with its row of S).
  std::vector<std::vector<int>> from_children(n);
  std::vector<int> mark(n, -1), column;
  const double d3 = static_cast<double>(block_dim) * block_dim * block_dim;
  double flops = 0.0;
  for (int j = 0; j < n; ++j) {
    column.clear();
    const auto add = [&](int k) {
      if (k != j && mark[k] != j) {
        mark[k] = j;
        column.push_back(k);
      }
    };
    for (int k : neighbours[j]) add(k);
    for (int k : from_children[j]) add(k);
    std::vector<int>().swap(from_children[j]);
    const double c = static_cast<double>(column.size());
    flops += (c + 1.0) * (c + 1.0) * d3;
    if (column.empty()) continue;
    const int parent = *std::min_element(column.begin(), column.end());
    from_children[parent].insert(from_children[parent].end(), column.begin(), column.end());
  }
  return flops;
}

}  // namespace slamd::core::internal
