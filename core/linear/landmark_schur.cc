#include "core/linear/landmark_schur.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <string>

namespace slamd::core {
namespace {

// The landmarks are 2- and 3-dimensional points; a fixed capacity keeps their blocks off the heap.
constexpr int kMaxLandmarkDim = 6;
using LandmarkMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor,
                                     kMaxLandmarkDim, kMaxLandmarkDim>;
using LandmarkVector =
    Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxLandmarkDim, 1>;

}  // namespace

Result<std::unique_ptr<LandmarkSchur>> LandmarkSchur::Create(const BlockSparseSystem& h,
                                                             int num_landmarks) {
  const int n = h.NumVariables();
  if (num_landmarks < 1 || num_landmarks >= n) {
    return InvalidArgument("landmark elimination: " + std::to_string(num_landmarks) +
                           " landmarks of " + std::to_string(n) + " variables");
  }
  const std::vector<int>& order = h.order();
  const std::vector<int>& col_ptr = h.col_ptr();
  const std::vector<int>& row_idx = h.row_idx();
  const int L = h.Offset(order[num_landmarks]);  // landmark scalars: [0, L)
  // A landmark column holds its own block's upper triangle and nothing else, or some factor
  // joins it to an earlier landmark.
  for (int l = 0; l < num_landmarks; ++l) {
    const int v = order[l];
    if (h.VarDim(v) > kMaxLandmarkDim) {
      return InvalidArgument("landmark elimination: variable " + std::to_string(v) + " has " +
                             std::to_string(h.VarDim(v)) + " dimensions (at most " +
                             std::to_string(kMaxLandmarkDim) + ")");
    }
    const int first = h.Offset(v);
    if (col_ptr[first + 1] - col_ptr[first] != 1) {
      return InvalidArgument("landmark elimination: variable " + std::to_string(v) +
                             " shares a factor with another landmark");
    }
  }

  // The reduced system's variables: h's remaining variables in h's order (identity order).
  const int rest = n - num_landmarks;
  std::vector<int> var_at_scalar(h.Dim());  // h's permuted scalar -> reduced variable (rest only)
  std::vector<int> dims(rest), identity(rest);
  for (int i = 0; i < rest; ++i) {
    const int v = order[num_landmarks + i];
    dims[i] = h.VarDim(v);
    identity[i] = i;
    std::fill_n(var_at_scalar.begin() + h.Offset(v), dims[i], i);
  }

  // Borders: for every reduced variable's first column, its rows in landmark blocks.
  std::vector<std::vector<Border>> borders(num_landmarks);
  std::vector<int> landmark_at_scalar(L);
  for (int l = 0; l < num_landmarks; ++l) {
    const int v = order[l];
    std::fill_n(landmark_at_scalar.begin() + h.Offset(v), h.VarDim(v), l);
  }
  FactorIncidence incidence;
  for (int i = 0; i < rest; ++i) {
    const int first = h.Offset(order[num_landmarks + i]);
    const int begin = col_ptr[first], end = col_ptr[first + 1];
    const int stride = end - begin - 1;  // rows above the diagonal block
    int last_var = -1;
    for (int p = begin; p < end - 1; ++p) {
      const int row = row_idx[p];
      if (row < L) {
        const int l = landmark_at_scalar[row];
        if (row == h.Offset(order[l])) borders[l].push_back({i, p, stride});
      } else if (var_at_scalar[row] != last_var) {  // a block of Hrr: a two-variable factor
        last_var = var_at_scalar[row];
        incidence.AddFactor({last_var, i});
      }
    }
  }
  // One "factor" per landmark with a border: the block pattern of its update GᵀG.
  std::vector<int> factor_of_landmark(num_landmarks, -1);
  std::vector<int> vars;
  for (int l = 0; l < num_landmarks; ++l) {
    vars.clear();
    for (const Border& b : borders[l]) vars.push_back(b.var);
    if (vars.empty()) continue;
    factor_of_landmark[l] = incidence.NumFactors();
    incidence.AddFactor(vars);
  }
  Result<BlockSparseSystem> reduced = BlockSparseSystem::Create(dims, identity, incidence);
  if (!reduced.ok()) return reduced.status();
  auto schur = std::unique_ptr<LandmarkSchur>(new LandmarkSchur(std::move(reduced).value()));
  LandmarkSchur& s = *schur;
  s.num_landmarks_ = num_landmarks;
  s.landmark_dim_ = L;
  s.factor_of_landmark_ = std::move(factor_of_landmark);
  s.cholesky_offsets_.assign(num_landmarks + 1, 0);
  for (int l = 0; l < num_landmarks; ++l) {
    const int d = h.VarDim(order[l]);
    s.cholesky_offsets_[l + 1] = s.cholesky_offsets_[l] + d * d;
    s.border_.insert(s.border_.end(), borders[l].begin(), borders[l].end());
    s.border_offsets_.push_back(static_cast<int>(s.border_.size()));
  }
  s.cholesky_.resize(s.cholesky_offsets_.back());

  // Hrr's entries into the reduced pattern (a superset of it), column by column.
  const std::vector<int>& s_col = s.s_.col_ptr();
  const std::vector<int>& s_row = s.s_.row_idx();
  for (int j = L; j < h.Dim(); ++j) {
    const auto s_begin = s_row.begin() + s_col[j - L], s_end = s_row.begin() + s_col[j - L + 1];
    for (int p = col_ptr[j]; p < col_ptr[j + 1]; ++p) {
      if (row_idx[p] < L) continue;
      const auto it = std::lower_bound(s_begin, s_end, row_idx[p] - L);
      SLAMD_CHECK(it != s_end && *it == row_idx[p] - L) << "reduced pattern misses H's entry";
      s.hrr_source_.push_back(p);
      s.hrr_target_.push_back(static_cast<int>(it - s_row.begin()));
    }
  }
  return schur;
}

Status LandmarkSchur::Reduce(const BlockSparseSystem& h, int* failed_variable) {
  const std::vector<double>& hv = h.values();
  const std::vector<int>& col_ptr = h.col_ptr();
  s_.SetZero();
  std::vector<double>& sv = s_.values();
  for (std::size_t k = 0; k < hrr_source_.size(); ++k) sv[hrr_target_[k]] = hv[hrr_source_[k]];
  s_.rhs() = h.rhs().tail(h.Dim() - landmark_dim_);

  for (int l = 0; l < num_landmarks_; ++l) {
    const int v = h.order()[l];
    const int a = h.Offset(v), d = h.VarDim(v);
    LandmarkMatrix block(d, d);
    for (int j = 0; j < d; ++j) {
      for (int i = 0; i <= j; ++i) block(i, j) = block(j, i) = hv[col_ptr[a + j] + i];
    }
    const Eigen::LLT<LandmarkMatrix> llt(block);
    if (llt.info() != Eigen::Success) {
      *failed_variable = v;
      return NumericalFailure("a landmark's block is not positive definite");
    }
    Eigen::Map<Eigen::MatrixXd> factor(cholesky_.data() + cholesky_offsets_[l], d, d);
    factor = llt.matrixL();
    if (factor_of_landmark_[l] < 0) continue;

    // G = L⁻¹ W, one d x dim block per border variable, and e = −L⁻¹ b_l: subtracting the
    // "factor" (G, e) from S gives S −= GᵀG = Wᵀ Hll⁻¹ W and s += Gᵀe = −Wᵀ Hll⁻¹ b_l.
    const int b_begin = border_offsets_[l], b_end = border_offsets_[l + 1];
    int cols = 0;
    for (int b = b_begin; b < b_end; ++b) cols += s_.VarDim(border_[b].var);
    g_.resize(static_cast<std::size_t>(d) * cols);
    g_blocks_.clear();
    double* g = g_.data();
    for (int b = b_begin; b < b_end; ++b) {
      const Border& border = border_[b];
      g_blocks_.push_back(g);
      for (int j = 0; j < s_.VarDim(border.var); ++j) {
        const double* column =
            hv.data() + border.base + BlockSparseSystem::ColumnStart(j, border.stride);
        for (int i = 0; i < d; ++i) *g++ = column[i];
      }
    }
    Eigen::Map<Eigen::MatrixXd> G(g_.data(), d, cols);
    llt.matrixL().solveInPlace(G);
    LandmarkVector e = -h.rhs().segment(a, d);
    llt.matrixL().solveInPlace(e);
    s_.SubtractFactor(factor_of_landmark_[l], g_blocks_.data(), e.data(), d);
  }
  return Status::Ok();
}

void LandmarkSchur::BackSubstitute(const BlockSparseSystem& h, const Eigen::VectorXd& delta_rest,
                                   Eigen::VectorXd* delta) const {
  const std::vector<double>& hv = h.values();
  delta->resize(h.Dim());
  delta->tail(h.Dim() - landmark_dim_) = delta_rest;
  for (int l = 0; l < num_landmarks_; ++l) {
    const int v = h.order()[l];
    const int a = h.Offset(v), d = h.VarDim(v);
    // r = b_l − W δ_r, then δ_l = Lᵀ⁻¹ L⁻¹ r.
    LandmarkVector r = h.rhs().segment(a, d);
    for (int b = border_offsets_[l]; b < border_offsets_[l + 1]; ++b) {
      const Border& border = border_[b];
      const int offset = s_.Offset(border.var);
      for (int j = 0; j < s_.VarDim(border.var); ++j) {
        const double* column =
            hv.data() + border.base + BlockSparseSystem::ColumnStart(j, border.stride);
        const double x = delta_rest[offset + j];
        for (int i = 0; i < d; ++i) r[i] -= column[i] * x;
      }
    }
    const Eigen::Map<const Eigen::MatrixXd> factor(cholesky_.data() + cholesky_offsets_[l], d, d);
    factor.triangularView<Eigen::Lower>().solveInPlace(r);
    factor.transpose().triangularView<Eigen::Upper>().solveInPlace(r);
    delta->segment(a, d) = r;
  }
}

}  // namespace slamd::core
