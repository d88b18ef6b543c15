#include "core/linear/block_sparse_system.h"

#include <algorithm>
#include <limits>
#include <string>

namespace slamd::core {
namespace {

// Offset of column j inside a block column whose columns have `stride` rows above the diagonal
// block: column j holds stride + j + 1 entries (its part of the diagonal block is rows 0..j).

// values[base + ColumnStart(j) + i] += Σ_t A(t, i) B(t, j) for the block A ᵀB, with A (m x da)
// and B (m x db) column-major. For a diagonal block (A == B) only i <= j is stored.
template <int Sign, int M, int DA, int DB>
inline void AddProductFixed(const double* a, const double* b, bool diagonal, int stride,
                            double* out) {
  for (int j = 0; j < DB; ++j) {
    double* column = out + BlockSparseSystem::ColumnStart(j, stride);
    const double* bj = b + j * M;
    const int rows = diagonal ? j + 1 : DA;
    for (int i = 0; i < rows; ++i) {
      const double* ai = a + i * M;
      double s = 0.0;
      for (int t = 0; t < M; ++t) s += ai[t] * bj[t];
      column[i] += Sign * s;
    }
  }
}

template <int Sign>
inline void AddProductGeneric(const double* a, const double* b, int m, int da, int db,
                              bool diagonal, int stride, double* out) {
  for (int j = 0; j < db; ++j) {
    double* column = out + BlockSparseSystem::ColumnStart(j, stride);
    const double* bj = b + j * m;
    const int rows = diagonal ? j + 1 : da;
    for (int i = 0; i < rows; ++i) {
      const double* ai = a + i * m;
      double s = 0.0;
      for (int t = 0; t < m; ++t) s += ai[t] * bj[t];
      column[i] += Sign * s;
    }
  }
}

// Dispatches the common shapes to fully unrolled kernels: square whitened factors on 2D and 3D
// poses (m = d = 3 or 6) and on points (m = d = 2), and the blocks of projections and of the
// landmark Schur complement (m = 2 or 3 rows against 3- and 6-dimensional points, calibrations
// and poses); everything else takes the generic loop.
template <int Sign, int M>
inline bool AddProductSmall(const double* a, const double* b, int da, int db, bool diagonal,
                            int stride, double* out) {
  if (da == 3 && db == 3) {
    AddProductFixed<Sign, M, 3, 3>(a, b, diagonal, stride, out);
  } else if (da == 3 && db == 6) {
    AddProductFixed<Sign, M, 3, 6>(a, b, diagonal, stride, out);
  } else if (da == 6 && db == 3) {
    AddProductFixed<Sign, M, 6, 3>(a, b, diagonal, stride, out);
  } else if (da == 6 && db == 6) {
    AddProductFixed<Sign, M, 6, 6>(a, b, diagonal, stride, out);
  } else {
    return false;
  }
  return true;
}

template <int Sign>
inline void AddProduct(const double* a, const double* b, int m, int da, int db, bool diagonal,
                       int stride, double* out) {
  switch (m) {
    case 2:
      if (da == 2 && db == 2) return AddProductFixed<Sign, 2, 2, 2>(a, b, diagonal, stride, out);
      if (AddProductSmall<Sign, 2>(a, b, da, db, diagonal, stride, out)) return;
      break;
    case 3:
      if (AddProductSmall<Sign, 3>(a, b, da, db, diagonal, stride, out)) return;
      break;
    case 6:
      if (da == 6 && db == 6) return AddProductFixed<Sign, 6, 6, 6>(a, b, diagonal, stride, out);
      break;
    default:
      break;
  }
  AddProductGeneric<Sign>(a, b, m, da, db, diagonal, stride, out);
}

}  // namespace

Result<BlockSparseSystem> BlockSparseSystem::Create(const std::vector<int>& var_dims,
                                                    const std::vector<int>& order,
                                                    const FactorIncidence& incidence) {
  const int n = static_cast<int>(var_dims.size());
  // 1. Validate everything before building anything.
  for (int v = 0; v < n; ++v) {
    if (var_dims[v] < 1) {
      return InvalidArgument("var_dims[" + std::to_string(v) + "] = " +
                             std::to_string(var_dims[v]) + " < 1");
    }
  }
  if (static_cast<int>(order.size()) != n || !IsPermutation(order)) {
    return InvalidArgument("order is not a permutation of the " + std::to_string(n) +
                           " variables");
  }
  SLAMD_RETURN_IF_ERROR(ValidateIncidence(n, incidence));
  const int num_factors = incidence.NumFactors();
  {
    std::vector<int> seen(n, -1);
    for (int f = 0; f < num_factors; ++f) {
      const int size = incidence.offsets[f + 1] - incidence.offsets[f];
      if (size > std::numeric_limits<std::int16_t>::max()) {
        return InvalidArgument("factor " + std::to_string(f) + " touches " +
                               std::to_string(size) + " variables (limit 32767)");
      }
      for (int i = incidence.offsets[f]; i < incidence.offsets[f + 1]; ++i) {
        const int v = incidence.vars[i];
        if (seen[v] == f) {
          return InvalidArgument("factor " + std::to_string(f) + " lists variable " +
                                 std::to_string(v) + " twice");
        }
        seen[v] = f;
      }
    }
  }

  BlockSparseSystem s;
  s.var_dims_ = var_dims;
  s.order_ = order;
  s.factor_offsets_ = incidence.offsets;
  s.factor_vars_ = incidence.vars;
  const std::vector<int> pos = InversePermutation(order);

  // 2. Scalar offsets in both numberings (64-bit until checked).
  std::int64_t dim = 0;
  s.original_offset_.resize(n);
  for (int v = 0; v < n; ++v) {
    s.original_offset_[v] = static_cast<int>(std::min<std::int64_t>(dim, INT32_MAX));
    dim += var_dims[v];
  }
  if (dim > std::numeric_limits<int>::max()) return OutOfRange("H dimension exceeds 2^31 - 1");
  s.dim_ = static_cast<int>(dim);
  s.offset_.resize(n);
  for (int k = 0, off = 0; k < n; ++k) {
    s.offset_[order[k]] = off;
    off += var_dims[order[k]];
  }

  // 3. Block pattern: for every block column c, the variables r eliminated before c that share a
  //    factor with it (CSR by c, then sorted by position and deduplicated).
  std::vector<int> above_ptr(n + 1, 0);
  for (int f = 0; f < num_factors; ++f) {
    for (int i = incidence.offsets[f]; i < incidence.offsets[f + 1]; ++i) {
      for (int j = i + 1; j < incidence.offsets[f + 1]; ++j) {
        const int a = incidence.vars[i], b = incidence.vars[j];
        ++above_ptr[(pos[a] > pos[b] ? a : b) + 1];
      }
    }
  }
  for (int v = 0; v < n; ++v) above_ptr[v + 1] += above_ptr[v];
  std::vector<int> above(above_ptr[n]);
  {
    std::vector<int> next(above_ptr.begin(), above_ptr.end() - 1);
    for (int f = 0; f < num_factors; ++f) {
      for (int i = incidence.offsets[f]; i < incidence.offsets[f + 1]; ++i) {
        for (int j = i + 1; j < incidence.offsets[f + 1]; ++j) {
          int a = incidence.vars[i], b = incidence.vars[j];
          if (pos[a] > pos[b]) std::swap(a, b);  // a = row (earlier), b = column (later)
          above[next[b]++] = pos[a];             // store positions: sorting by them is the point
        }
      }
    }
  }
  // Deduplicate in place; above_count[c] = number of distinct row blocks of column c.
  std::vector<int> above_count(n);
  for (int c = 0; c < n; ++c) {
    auto begin = above.begin() + above_ptr[c], end = above.begin() + above_ptr[c + 1];
    std::sort(begin, end);
    above_count[c] = static_cast<int>(std::unique(begin, end) - begin);
  }

  // 4. Scalar CSC in elimination order. rel[above_ptr[c] + q] = scalar row offset of the q-th row
  //    block inside block column c; stride[c] = R_c; col_start[c] = first values_ index of c.
  std::vector<int> rel(above.size()), stride(n), col_start(n);
  std::int64_t nnz = 0;
  for (int k = 0; k < n; ++k) {
    const int c = order[k];
    int r_c = 0;
    for (int q = 0; q < above_count[c]; ++q) {
      rel[above_ptr[c] + q] = r_c;
      r_c += var_dims[order[above[above_ptr[c] + q]]];
    }
    stride[c] = r_c;
    col_start[c] = static_cast<int>(std::min<std::int64_t>(nnz, INT32_MAX));
    const std::int64_t d = var_dims[c];
    nnz += d * r_c + d * (d + 1) / 2;
    if (nnz > std::numeric_limits<int>::max()) {
      return OutOfRange("H has more than 2^31 - 1 stored entries");
    }
  }
  s.col_ptr_.assign(s.dim_ + 1, 0);
  s.row_idx_.resize(nnz);
  for (int k = 0; k < n; ++k) {
    const int c = order[k];
    const int d = var_dims[c];
    for (int j = 0; j < d; ++j) {
      const int start = col_start[c] + ColumnStart(j, stride[c]);
      s.col_ptr_[s.offset_[c] + j] = start;
      int* rows = s.row_idx_.data() + start;
      for (int q = 0; q < above_count[c]; ++q) {
        const int r = order[above[above_ptr[c] + q]];
        for (int i = 0; i < var_dims[r]; ++i) *rows++ = s.offset_[r] + i;
      }
      for (int i = 0; i <= j; ++i) *rows++ = s.offset_[c] + i;
    }
  }
  s.col_ptr_[s.dim_] = static_cast<int>(nnz);
  s.values_.assign(nnz, 0.0);
  s.rhs_ = Eigen::VectorXd::Zero(s.dim_);

  // 5. Scalar maps between the two numberings; the diagonal is the last entry of each column.
  s.permuted_of_original_.resize(s.dim_);
  s.diag_index_.resize(s.dim_);
  for (int v = 0; v < n; ++v) {
    for (int i = 0; i < var_dims[v]; ++i) {
      const int p = s.offset_[v] + i;
      s.permuted_of_original_[s.original_offset_[v] + i] = p;
      s.diag_index_[s.original_offset_[v] + i] = s.col_ptr_[p + 1] - 1;
    }
  }

  // 6. One slot per (k <= l) pair of every factor's variables, in the order AddFactor visits them.
  s.slot_offsets_.assign(num_factors + 1, 0);
  for (int f = 0; f < num_factors; ++f) {
    const int size = incidence.offsets[f + 1] - incidence.offsets[f];
    s.slot_offsets_[f + 1] = s.slot_offsets_[f] + size * (size + 1) / 2;
  }
  s.slots_.resize(s.slot_offsets_[num_factors]);
  BlockSlot* slot = s.slots_.data();
  for (int f = 0; f < num_factors; ++f) {
    const int* vars = incidence.vars.data() + incidence.offsets[f];
    const int size = incidence.offsets[f + 1] - incidence.offsets[f];
    for (int k = 0; k < size; ++k) {
      for (int l = k; l < size; ++l) {
        int row = k, col = l;
        if (pos[vars[row]] > pos[vars[col]]) std::swap(row, col);
        const int c = vars[col];
        int base = col_start[c];
        if (row == col) {
          base += stride[c];  // diagonal block: below all off-diagonal row blocks
        } else {
          auto begin = above.begin() + above_ptr[c];
          const int q = static_cast<int>(
              std::lower_bound(begin, begin + above_count[c], pos[vars[row]]) - begin);
          base += rel[above_ptr[c] + q];
        }
        *slot++ = BlockSlot{base, stride[c], static_cast<std::int16_t>(row),
                            static_cast<std::int16_t>(col)};
      }
    }
  }
  return s;
}

void BlockSparseSystem::SetZero() {
  std::fill(values_.begin(), values_.end(), 0.0);
  rhs_.setZero();
}

void BlockSparseSystem::AddFactor(int f, const double* const* jacobians, const double* e, int m) {
  Accumulate<1>(f, jacobians, e, m);
}

void BlockSparseSystem::SubtractFactor(int f, const double* const* jacobians, const double* e,
                                       int m) {
  Accumulate<-1>(f, jacobians, e, m);
}

template <int Sign>
void BlockSparseSystem::Accumulate(int f, const double* const* jacobians, const double* e, int m) {
  SLAMD_DCHECK(f >= 0 && f < NumFactors()) << "factor " << f << " out of range";
  SLAMD_DCHECK(m >= 1) << "residual dimension " << m;
  const int* vars = factor_vars_.data() + factor_offsets_[f];
  const int size = factor_offsets_[f + 1] - factor_offsets_[f];
  // b -= Sign·Jₖᵀ e for every variable k of the factor.
  for (int k = 0; k < size; ++k) {
    const int v = vars[k];
    const double* jk = jacobians[k];
    double* b = rhs_.data() + offset_[v];
    for (int i = 0; i < var_dims_[v]; ++i) {
      double s = 0.0;
      for (int t = 0; t < m; ++t) s += jk[i * m + t] * e[t];
      b[i] -= Sign * s;
    }
  }
  // H(row, col) += Sign·J_rowᵀ J_col for every pair, at the precomputed places.
  double* values = values_.data();
  for (int q = slot_offsets_[f]; q < slot_offsets_[f + 1]; ++q) {
    const BlockSlot& slot = slots_[q];
    AddProduct<Sign>(jacobians[slot.row], jacobians[slot.col], m, var_dims_[vars[slot.row]],
                     var_dims_[vars[slot.col]], slot.row == slot.col, slot.stride,
                     values + slot.base);
  }
}

void BlockSparseSystem::AddToDiagonal(double lambda) {
  for (int j = 0; j < dim_; ++j) values_[col_ptr_[j + 1] - 1] += lambda;
}

void BlockSparseSystem::AddDiagonal(const Eigen::VectorXd& d) {
  SLAMD_CHECK(d.size() == dim_) << "diagonal of size " << d.size() << ", expected " << dim_;
  for (int s = 0; s < dim_; ++s) values_[diag_index_[s]] += d[s];
}

Eigen::VectorXd BlockSparseSystem::Diagonal() const {
  Eigen::VectorXd d(dim_);
  for (int s = 0; s < dim_; ++s) d[s] = values_[diag_index_[s]];
  return d;
}

void BlockSparseSystem::MultiplyPermuted(const Eigen::VectorXd& x, Eigen::VectorXd* y) const {
  SLAMD_CHECK(x.size() == dim_) << "x of size " << x.size() << ", expected " << dim_;
  y->setZero(dim_);
  for (int j = 0; j < dim_; ++j) {
    double yj = 0.0;
    const int last = col_ptr_[j + 1] - 1;  // diagonal entry
    for (int p = col_ptr_[j]; p < last; ++p) {
      const int i = row_idx_[p];
      (*y)[i] += values_[p] * x[j];
      yj += values_[p] * x[i];
    }
    (*y)[j] += yj + values_[last] * x[j];
  }
}

void BlockSparseSystem::ToOriginalOrder(const Eigen::VectorXd& permuted,
                                        Eigen::VectorXd* original) const {
  SLAMD_CHECK(permuted.size() == dim_) << "size " << permuted.size() << ", expected " << dim_;
  original->resize(dim_);
  for (int s = 0; s < dim_; ++s) (*original)[s] = permuted[permuted_of_original_[s]];
}

void BlockSparseSystem::FromOriginalOrder(const Eigen::VectorXd& original,
                                          Eigen::VectorXd* permuted) const {
  SLAMD_CHECK(original.size() == dim_) << "size " << original.size() << ", expected " << dim_;
  permuted->resize(dim_);
  for (int s = 0; s < dim_; ++s) (*permuted)[permuted_of_original_[s]] = original[s];
}

Eigen::MatrixXd BlockSparseSystem::ToDense() const {
  std::vector<int> original_of_permuted(dim_);
  for (int s = 0; s < dim_; ++s) original_of_permuted[permuted_of_original_[s]] = s;
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(dim_, dim_);
  for (int j = 0; j < dim_; ++j) {
    for (int p = col_ptr_[j]; p < col_ptr_[j + 1]; ++p) {
      const int r = original_of_permuted[row_idx_[p]], c = original_of_permuted[j];
      h(r, c) = values_[p];
      h(c, r) = values_[p];
    }
  }
  return h;
}

Eigen::VectorXd BlockSparseSystem::RhsOriginalOrder() const {
  Eigen::VectorXd b;
  ToOriginalOrder(rhs_, &b);
  return b;
}

}  // namespace slamd::core
