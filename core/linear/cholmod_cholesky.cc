// CHOLMOD backend of SparseCholesky. The only file that includes cholmod.h.
//
// Speed choices (each Gauss-Newton / LM step factorizes a matrix with an unchanged pattern):
//   * The caller's CSC arrays are wrapped in a stack cholmod_sparse header (no copy, no
//     allocation); CHOLMOD only reads them.
//   * cholmod_analyze runs once per pattern with the NATURAL ordering (the caller already ordered
//     the variables with COLAMD at block level); later calls only run cholmod_factorize on the
//     existing factor object, which CHOLMOD refactorizes in place.
//   * Solve uses cholmod_solve2 with persistent X/Y/E workspaces.
//   * The factor is always LLᵀ (Common.final_ll): CHOLMOD's simplicial LDLᵀ only stops at an exact
//     zero pivot, so it would silently accept an indefinite matrix.
//   * Simplicial runs in the caller's order exactly (an etree postorder made it ~10-25 % slower
//     on COLAMD-ordered pose graphs); supernodal gets the postorder, which it needs for large
//     supernodes. kAuto first analyses without postorder (the fill statistics CHOLMOD uses for
//     the choice do not depend on it) and re-analyses with it only when it picks supernodal.
//
// Measured (g++ 12 -O3, netlib reference BLAS, one core, median of repeated numeric
// refactorizations after block COLAMD; flops/nnz(L) in brackets):
//   M3500 (n = 10500, nnz(L) 189k) [36]      simplicial  3.0 ms   supernodal 11 ms
//   Intel (n = 3684) [12]                    simplicial  0.3 ms   supernodal  1.3 ms
//   parking-garage, 6x6 blocks [54]          simplicial  7.9 ms   supernodal 20 ms
//   grid 80x80, 6x6 blocks [286]             simplicial  292 ms   supernodal 376 ms
//   chain 3500 + 1000 random loops [549]     simplicial   83 ms   supernodal  84 ms
//   chain 3500 + 2000 random loops [1028]    simplicial  445 ms   supernodal 334 ms
#include "core/linear/cholmod_cholesky.h"

#include <cholmod.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "core/linear/blas_lock.h"

namespace slamd::core::internal {
namespace {

// CHOLMOD's error callback has no user pointer; the instance making the call points this at its
// message buffer for the duration of the call (one CHOLMOD call at a time per thread).
thread_local std::string* t_cholmod_message = nullptr;

void RecordCholmodError(int status, const char* file, int line, const char* message) {
  if (t_cholmod_message == nullptr) return;
  *t_cholmod_message = std::string("CHOLMOD ") + (status < 0 ? "error " : "warning ") +
                       std::to_string(status) + " (" + file + ":" + std::to_string(line) +
                       "): " + message;
}

class ScopedMessageSink {
 public:
  explicit ScopedMessageSink(std::string* sink) : previous_(t_cholmod_message) {
    t_cholmod_message = sink;
  }
  ~ScopedMessageSink() { t_cholmod_message = previous_; }
  ScopedMessageSink(const ScopedMessageSink&) = delete;
  ScopedMessageSink& operator=(const ScopedMessageSink&) = delete;

 private:
  std::string* previous_;
};

// RAII owner of cholmod_common (cholmod_start / cholmod_finish).
class CholmodCommon {
 public:
  CholmodCommon() { cholmod_start(&common_); }
  ~CholmodCommon() { cholmod_finish(&common_); }
  CholmodCommon(const CholmodCommon&) = delete;
  CholmodCommon& operator=(const CholmodCommon&) = delete;
  cholmod_common* get() { return &common_; }

 private:
  cholmod_common common_;
};

void SetMessage(std::string* message, std::string text) {
  if (message != nullptr) *message = std::move(text);
}

class CholmodCholesky final : public SparseCholesky {
 public:
  explicit CholmodCholesky(const Options& options) : options_(options) {
    cholmod_common* c = common_.get();
    c->print = 0;  // never print; errors come back through the return value
    c->error_handler = &RecordCholmodError;
    c->nmethods = 1;
    c->method[0].ordering = CHOLMOD_NATURAL;
    c->supernodal_switch = options.supernodal_switch;
    c->final_ll = 1;
    c->quick_return_if_not_posdef = 1;
  }

  ~CholmodCholesky() override {
    cholmod_common* c = common_.get();
    if (factor_ != nullptr) cholmod_free_factor(&factor_, c);
    if (x_ != nullptr) cholmod_free_dense(&x_, c);
    if (y_ != nullptr) cholmod_free_dense(&y_, c);
    if (e_ != nullptr) cholmod_free_dense(&e_, c);
  }

  LinearSolverTermination Factorize(int n, const int* col_ptr, const int* row_idx,
                                    const double* values, std::string* message,
                                    int* failed_column) override {
    if (failed_column != nullptr) *failed_column = -1;
    factorized_ = false;
    if (n < 0 || (n > 0 && (col_ptr == nullptr || row_idx == nullptr || values == nullptr))) {
      SetMessage(message, "Factorize: negative size or null array");
      return LinearSolverTermination::kFatal;
    }
    std::string cholmod_message;
    ScopedMessageSink sink(&cholmod_message);
    cholmod_common* c = common_.get();
    if (n == 0) {  // nothing to factorize; CHOLMOD is not needed
      if (factor_ != nullptr) cholmod_free_factor(&factor_, c);
      n_ = 0;
      factorized_ = true;
      return LinearSolverTermination::kSuccess;
    }

    // 1. (Re-)analyse when the pattern differs from the cached one.
    if (factor_ == nullptr || !SamePattern(n, col_ptr, row_idx)) {
      if (factor_ != nullptr) cholmod_free_factor(&factor_, c);
      n_ = -1;
      std::string error;
      if (!ValidPattern(n, col_ptr, row_idx, &error)) {
        SetMessage(message, "Factorize: " + error);
        return LinearSolverTermination::kFatal;
      }
      if (!Analyse(Wrap(n, col_ptr, row_idx, values))) {
        SetMessage(message, "cholmod_analyze failed: " + cholmod_message);
        return LinearSolverTermination::kFatal;
      }
      n_ = n;
      col_ptr_.assign(col_ptr, col_ptr + n + 1);
      row_idx_.assign(row_idx, row_idx + col_ptr[n]);
      ++num_analyses_;
    }

    // 2. Non-finite input: CHOLMOD's simplicial LLᵀ only tests pivot <= 0, which a NaN passes, so
    //    look for NaN/Inf first (O(nnz), a few percent of the factorization). Report the smaller
    //    index of the offending entry: the variable reached first in the caller's order.
    const int nnz = col_ptr[n];
    for (int p = 0; p < nnz; ++p) {
      if (!std::isfinite(values[p])) {
        const int column = row_idx[p];
        if (failed_column != nullptr) *failed_column = column;
        SetMessage(message, "matrix is not positive definite: non-finite entry in column " +
                                std::to_string(column));
        return LinearSolverTermination::kNumericalFailure;
      }
    }

    // 3. Numeric factorization into the existing factor object.
    cholmod_sparse a = Wrap(n, col_ptr, row_idx, values);
    int ok = 0;
    {
      const std::unique_lock<std::mutex> blas = LockBlas();  // supernodal: the BLAS and LAPACK
      ok = cholmod_factorize(&a, factor_, c);
    }
    if (c->status == CHOLMOD_NOT_POSDEF) {
      // L->minor is a column of the (postordered) factor; report it in the caller's numbering.
      const size_t minor = factor_->minor;
      const int* perm = static_cast<const int*>(factor_->Perm);
      const int column = (minor < static_cast<size_t>(n) && perm != nullptr)
                             ? perm[minor]
                             : static_cast<int>(minor);
      if (failed_column != nullptr) *failed_column = column;
      SetMessage(message, "matrix is not positive definite (pivot <= 0 or NaN at column " +
                              std::to_string(column) + ")");
      return LinearSolverTermination::kNumericalFailure;
    }
    if (!ok || c->status != CHOLMOD_OK) {
      SetMessage(message, "cholmod_factorize failed: " + cholmod_message);
      return LinearSolverTermination::kFatal;
    }
    factorized_ = true;
    return LinearSolverTermination::kSuccess;
  }

  LinearSolverTermination Solve(const double* b, double* x, std::string* message) override {
    if (!factorized_) {
      SetMessage(message, "Solve called without a successful Factorize");
      return LinearSolverTermination::kFatal;
    }
    if (n_ == 0) return LinearSolverTermination::kSuccess;
    std::string cholmod_message;
    ScopedMessageSink sink(&cholmod_message);
    cholmod_common* c = common_.get();
    cholmod_dense rhs{};
    rhs.nrow = n_;
    rhs.ncol = 1;
    rhs.nzmax = n_;
    rhs.d = n_;
    rhs.x = const_cast<double*>(b);  // CHOLMOD reads B only
    rhs.xtype = CHOLMOD_REAL;
    rhs.dtype = CHOLMOD_DOUBLE;
    int solved = 0;
    {
      const std::unique_lock<std::mutex> blas = LockBlas();  // supernodal: dtrsm/dgemm
      solved = cholmod_solve2(CHOLMOD_A, factor_, &rhs, nullptr, &x_, nullptr, &y_, &e_, c);
    }
    if (!solved || c->status != CHOLMOD_OK) {
      SetMessage(message, "cholmod_solve2 failed: " + cholmod_message);
      return LinearSolverTermination::kFatal;
    }
    std::memmove(x, x_->x, sizeof(double) * n_);
    return LinearSolverTermination::kSuccess;
  }

  long FactorNonZeros() const override {
    if (factor_ == nullptr) return 0;
    if (factor_->is_super) return static_cast<long>(factor_->xsize);
    // Simplicial: entries of the packed columns (L->nzmax may include slack).
    const int* nz = static_cast<const int*>(factor_->nz);
    if (nz == nullptr) return 0;
    long total = 0;
    for (size_t j = 0; j < factor_->n; ++j) total += nz[j];
    return total;
  }

  bool IsSupernodal() const override { return factor_ != nullptr && factor_->is_super; }
  int NumAnalyses() const override { return num_analyses_; }

 private:
  // Symbolic analysis in the given order (see the notes at the top). On failure factor_ is null.
  bool Analyse(cholmod_sparse a) {
    cholmod_common* c = common_.get();
    const bool supernodal_only = options_.method == Method::kSupernodal;
    c->postorder = supernodal_only ? 1 : 0;
    c->supernodal = supernodal_only                            ? CHOLMOD_SUPERNODAL
                    : options_.method == Method::kSimplicial ? CHOLMOD_SIMPLICIAL
                                                               : CHOLMOD_AUTO;
    factor_ = cholmod_analyze(&a, c);
    if (factor_ != nullptr && c->status >= CHOLMOD_OK && options_.method == Method::kAuto &&
        factor_->is_super) {
      cholmod_free_factor(&factor_, c);
      c->postorder = 1;
      c->supernodal = CHOLMOD_SUPERNODAL;
      factor_ = cholmod_analyze(&a, c);
    }
    if (factor_ == nullptr || c->status < CHOLMOD_OK) {
      if (factor_ != nullptr) cholmod_free_factor(&factor_, c);
      return false;
    }
    return true;
  }

  static cholmod_sparse Wrap(int n, const int* col_ptr, const int* row_idx,
                             const double* values) {
    cholmod_sparse a{};
    a.nrow = n;
    a.ncol = n;
    a.nzmax = col_ptr[n];
    a.p = const_cast<int*>(col_ptr);  // CHOLMOD reads A only
    a.i = const_cast<int*>(row_idx);
    a.x = const_cast<double*>(values);
    a.stype = 1;  // upper triangle stored
    a.itype = CHOLMOD_INT;
    a.xtype = CHOLMOD_REAL;
    a.dtype = CHOLMOD_DOUBLE;
    a.sorted = 1;
    a.packed = 1;
    return a;
  }

  bool SamePattern(int n, const int* col_ptr, const int* row_idx) const {
    if (n != n_) return false;
    if (std::memcmp(col_ptr, col_ptr_.data(), sizeof(int) * (n + 1)) != 0) return false;
    return std::memcmp(row_idx, row_idx_.data(), sizeof(int) * col_ptr[n]) == 0;
  }

  // Checked once per new pattern: CHOLMOD trusts `sorted` and would read out of bounds otherwise.
  static bool ValidPattern(int n, const int* col_ptr, const int* row_idx, std::string* error) {
    if (n == 0) return true;
    if (col_ptr[0] != 0) {
      *error = "col_ptr[0] != 0";
      return false;
    }
    for (int j = 0; j < n; ++j) {
      if (col_ptr[j + 1] < col_ptr[j]) {
        *error = "col_ptr decreases at column " + std::to_string(j);
        return false;
      }
      for (int p = col_ptr[j]; p < col_ptr[j + 1]; ++p) {
        const int i = row_idx[p];
        if (i < 0 || i > j || (p > col_ptr[j] && row_idx[p - 1] >= i)) {
          *error = "row index " + std::to_string(i) + " in column " + std::to_string(j) +
                   " is not upper triangular, ascending and unique";
          return false;
        }
      }
    }
    return true;
  }

  Options options_;
  CholmodCommon common_;
  cholmod_factor* factor_ = nullptr;
  cholmod_dense* x_ = nullptr;  // cholmod_solve2 workspaces, reused across calls
  cholmod_dense* y_ = nullptr;
  cholmod_dense* e_ = nullptr;
  int n_ = -1;  // size of the analysed pattern; -1 = none
  std::vector<int> col_ptr_;
  std::vector<int> row_idx_;
  bool factorized_ = false;
  int num_analyses_ = 0;
};

}  // namespace

std::unique_ptr<SparseCholesky> CreateCholmodCholesky(const SparseCholesky::Options& options) {
  return std::make_unique<CholmodCholesky>(options);
}

}  // namespace slamd::core::internal
