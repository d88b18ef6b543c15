// HessianFactor: a quadratic term in information (augmented Hessian) form on dense variable ids.
//
// For variables v_0..v_{p-1} (dims d_k, stacked update δ of dimension D = Σ d_k) it stands for
//     [δ; 1]ᵀ · info · [δ; 1]   with   info = [[ Σ AᵀA , Σ Aᵀb ],
//                                               [ (.)ᵀ  , Σ bᵀb ]],
// i.e. the same quadratic as Σ |A δ + b|² (the sign convention of JacobianFactor). This is the
// form of the Schur complement an eliminated clique passes to its parent (its "cached factor",
// which iSAM2 reuses for subtrees it does not re-eliminate), and what the elimination assembles
// into a clique's dense matrix.
//
// Storage: info's lower triangle (with the diagonal), packed by columns: column j holds rows
// j..D, one after the other (the upper triangle is its mirror and is not stored: a clique's
// cached factor is most of the Bayes tree's memory, and writing a mirror was a quarter of
// eliminating a bundle adjustment's points). Variable k occupies rows/columns
// [offset(k), offset(k+1)); the last row/column holds the linear term and the constant.
// Reset() reuses capacity.
//
// Pivot reference: next to info, each of the D scalars carries reference(i) >= info(i, i), a
// bound on the magnitude of the information that was summed (and cancelled by Schur complements)
// to produce that diagonal entry. Elimination compares pivots against it to tell an unconstrained
// direction (round-off of the reference) from a weakly constrained one. For a factor built from
// Jacobians it is just the diagonal; a clique's cached factor carries the propagated bound.
// Thread safety: const methods may run concurrently.
#pragma once

#include <Eigen/Core>
#include <span>
#include <vector>

#include "core/base/status.h"
#include "core/base/storage.h"

namespace slamd::core {

class JacobianFactor;

class HessianFactor {
 public:
  HessianFactor() = default;

  // Validating constructor: vars distinct and >= 0, dims >= 1 (dims.size() == vars.size()),
  // info (Σ dims + 1) square, finite and symmetric (to 1e-9 relative). kInvalidArgument otherwise.
  // An empty variable list is allowed (a constant term, info 1 x 1).
  static Result<HessianFactor> Create(std::span<const int> vars, std::span<const int> dims,
                                      const Eigen::MatrixXd& info);
  // info = [A b]ᵀ[A b] on the Jacobian factor's variables (same order).
  static HessianFactor FromJacobian(const JacobianFactor& jacobian);

  // Sets the variables and zeroes info and reference. Preconditions as Create (SLAMD_DCHECK only:
  // used on the elimination hot path with ids it already validated). Reuses capacity.
  void Reset(std::span<const int> vars, std::span<const int> dims);
  // As Reset but leaves info and reference unspecified: for callers that overwrite every entry
  // (elimination writes the whole cached factor), saving a pass over the storage.
  void Reshape(std::span<const int> vars, std::span<const int> dims);

  // Bytes allocated for it beyond the object, for memory reports.
  std::size_t StorageBytes() const {
    return index_.capacity() * sizeof(int) + data_.capacity() * sizeof(double);
  }
  // Doubles its storage holds without allocating, and the doubles a factor of dimension D needs.
  std::size_t DataCapacity() const { return data_.capacity(); }
  static std::size_t DataDoubles(int D) { return PackedDoubles(D + 1) + static_cast<size_t>(D); }
  // Doubles of an n x n lower triangle, and where its packed column j starts.
  static std::size_t PackedDoubles(int n) { return static_cast<std::size_t>(n) * (n + 1) / 2; }
  static std::size_t ColumnStart(int n, int j) {
    return static_cast<std::size_t>(j) * n - static_cast<std::size_t>(j) * (j - 1) / 2;
  }
  // Gives back the capacity beyond what it holds (Reset/Reshape keep up to 4x for reuse).
  void ShrinkStorage() {
    index_.shrink_to_fit();
    data_.shrink_to_fit();
  }
  // Renames variable v to new_id[v] (order and storage unchanged): a solver that drops
  // variables renumbers the rest. new_id[v] must be >= 0 for every variable here (checked).
  void RenumberVariables(std::span<const int> new_id);

  int num_vars() const { return num_vars_; }
  std::span<const int> vars() const { return {index_.data(), static_cast<size_t>(num_vars_)}; }
  int var(int k) const { return index_[k]; }
  // Offset of variable k in info; offset(num_vars()) == Dim().
  int offset(int k) const { return index_[num_vars_ + k]; }
  int dim(int k) const { return offset(k + 1) - offset(k); }
  // D = Σ dims (info is (D + 1) x (D + 1)).
  int Dim() const { return index_[2 * num_vars_]; }

  // info(j..D, j): packed column j of the lower triangle, Dim() + 1 - j entries.
  const double* column(int j) const { return data_.data() + ColumnStart(Dim() + 1, j); }
  double* mutable_column(int j) { return data_.data() + ColumnStart(Dim() + 1, j); }
  // The whole packed lower triangle (PackedDoubles(Dim() + 1) entries).
  std::span<const double> packed_info() const { return {data_.data(), PackedDoubles(Dim() + 1)}; }
  std::span<double> mutable_packed_info() { return {data_.data(), PackedDoubles(Dim() + 1)}; }
  // info, both triangles, as a dense matrix (for tests and checks, not the hot paths).
  Eigen::MatrixXd Info() const;
  // Start of the storage, for prefetching (DataDoubles(Dim()) doubles).
  const double* data() const { return data_.data(); }

  // Per-scalar pivot reference (see the file comment), Dim() entries.
  Eigen::Map<const Eigen::VectorXd> reference() const { return {ReferenceData(), Dim()}; }
  Eigen::Map<Eigen::VectorXd> mutable_reference() { return {ReferenceData(), Dim()}; }
  // Sets reference() to the diagonal of info.
  void SetReferenceToDiagonal();

  // [δ; 1]ᵀ info [δ; 1] for a stacked update: variable v occupies
  // delta[var_offsets[v], var_offsets[v] + dim). Used by tests and error checks.
  double Error(std::span<const int> var_offsets, const Eigen::VectorXd& delta) const;

 private:
  int num_vars_ = 0;
  const double* ReferenceData() const { return data_.data() + PackedDoubles(Dim() + 1); }
  double* ReferenceData() { return data_.data() + PackedDoubles(Dim() + 1); }
  // Stores the lower triangle of the (D + 1)-square `info`.
  void Pack(const Eigen::MatrixXd& info);

  std::vector<int> index_ = {0};      // [vars (p) | offsets (p + 1)]: one allocation for both
  UninitVector<double> data_ = {0.0};  // [info's lower triangle, packed | reference (D)]
};

}  // namespace slamd::core
