// Clique: one node of the Bayes tree (Kaess et al., iSAM2, IJRR 2012, §III).
//
// A clique holds the Gaussian conditional density p(F | S) of its frontal variables F given its
// separator S, in square-root form
//     R · δ_F + S · δ_S = d,
// with R upper-triangular (FrontalDim() x FrontalDim(), positive diagonal), S FrontalDim() x
// SeparatorDim(), and d FrontalDim(). Notation after the paper (R, S, d).
//   * Frontals are listed in the order they were eliminated; the scalar rows of R follow it.
//   * The separator is listed in elimination order too (so separator()[0] is eliminated first
//     among them); S's column blocks follow it.
//   * The cached factor is the HessianFactor on the separator that eliminating this clique
//     produced (the Schur complement passed to the parent). iSAM2 re-eliminates only the top of
//     the tree and feeds the cached factors of the orphaned subtrees back in instead of their
//     original factors; its variables are the separator (separator() is cached_factor().vars()).
//
// Storage: [R S d] is one contiguous column-major FrontalDim() x (FrontalDim() + SeparatorDim()
// + 1) array (R's strictly lower part is zero). Cliques are owned by their BayesTree and
// addressed by int ids; parent/children links are ids, managed by the tree only.
//
// Generation stamp: generation() identifies the clique's current content (structure, [R S d],
// cached factor). Reset() and ResetForElimination() give it a new value, unique among all
// cliques of the process (a process-wide counter), so a reader that caches data derived from a
// clique (marginals.h) detects a change in O(1) by comparing stamps. Contract for writers: every
// (re)definition of the content starts with one of the two resets; writing through
// mutable_conditional() / mutable_cached_factor() without one is invisible to such caches. A
// copy keeps the stamp (same content).
// Thread safety: const methods may run concurrently; Reset()/ResetForElimination() of distinct
// cliques may run concurrently (the stamp counter is atomic).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <vector>

#include "core/inference/hessian_factor.h"

namespace slamd::core {

class Clique {
 public:
  static constexpr int kNone = -1;

  // --- Structure
  // ----------------------------------------------------------------------------------
  int num_frontals() const { return num_frontals_; }
  std::span<const int> frontals() const {
    return {index_.data(), static_cast<size_t>(num_frontals_)};
  }
  int frontal(int k) const { return index_[k]; }
  // Row offset of frontal k in R; frontal_offset(num_frontals()) == FrontalDim().
  int frontal_offset(int k) const { return index_[num_frontals_ + k]; }
  int frontal_dim(int k) const { return frontal_offset(k + 1) - frontal_offset(k); }
  int FrontalDim() const { return index_[2 * num_frontals_]; }

  std::span<const int> separator() const { return cached_.vars(); }
  int num_separator() const { return cached_.num_vars(); }
  // Column offset of separator variable k inside S (== its offset in the cached factor).
  int separator_offset(int k) const { return cached_.offset(k); }
  int separator_dim(int k) const { return cached_.dim(k); }
  int SeparatorDim() const { return cached_.Dim(); }

  int parent() const { return parent_; }
  const std::vector<int>& children() const { return children_; }

  // --- Conditional R δ_F + S δ_S = d
  // --------------------------------------------------------------- [R S d], FrontalDim() x
  // (FrontalDim() + SeparatorDim() + 1).
  Eigen::Map<const Eigen::MatrixXd> conditional() const {
    return {conditional_.data(), FrontalDim(), FrontalDim() + SeparatorDim() + 1};
  }
  Eigen::Map<Eigen::MatrixXd> mutable_conditional() {
    return {conditional_.data(), FrontalDim(), FrontalDim() + SeparatorDim() + 1};
  }
  // Contiguous column ranges of [R S d] (whole columns of a column-major array).
  Eigen::Map<const Eigen::MatrixXd> R() const {
    return {conditional_.data(), FrontalDim(), FrontalDim()};
  }
  Eigen::Map<const Eigen::MatrixXd> S() const {
    return {conditional_.data() + static_cast<size_t>(FrontalDim()) * FrontalDim(), FrontalDim(),
            SeparatorDim()};
  }
  Eigen::Map<const Eigen::VectorXd> d() const {
    return {
        conditional_.data() + static_cast<size_t>(FrontalDim()) * (FrontalDim() + SeparatorDim()),
        FrontalDim()};
  }

  // Bytes allocated for its matrices and lists (capacity, not size), for memory reports.
  std::size_t StorageBytes() const {
    return index_.capacity() * sizeof(int) + conditional_.capacity() * sizeof(double) +
           cached_.StorageBytes() + children_.capacity() * sizeof(int);
  }
  // Doubles its matrices ([R S d] and the cached factor) can hold without allocating: what a
  // freed slot offers the next clique (BayesTree::NewClique).
  std::size_t MatrixCapacity() const { return conditional_.capacity() + cached_.DataCapacity(); }
  // The doubles ResetForElimination needs for these dims (nf frontal, ns separator scalars).
  static std::size_t MatrixDoubles(int nf, int ns) {
    return ConditionalDoubles(nf, ns) + HessianFactor::DataDoubles(ns);
  }
  // [R S d]: nf rows of nf + ns + 1 columns.
  static std::size_t ConditionalDoubles(int nf, int ns) {
    return static_cast<std::size_t>(nf) * (nf + ns + 1);
  }
  // Gives back the capacity beyond what it holds (a clique in use), or all of it (a freed one:
  // its next Reset allocates afresh).
  void ShrinkStorage();
  void ReleaseStorage();
  // Renames the frontal and separator variables (HessianFactor::RenumberVariables) and renews
  // generation(): a reader's cache keyed by variable ids must not take the old content for it.
  void RenumberVariables(std::span<const int> new_id);

  // Unique to this content of this clique across the process; renewed by Reset() and
  // ResetForElimination(), kept by a copy. Never 0.
  std::uint64_t generation() const { return generation_; }

  // The Schur complement on the separator left by eliminating this clique.
  const HessianFactor& cached_factor() const { return cached_; }
  HessianFactor& mutable_cached_factor() { return cached_; }

  // Sets frontals and separator (ids with their dims), zeroes [R S d] and the cached factor and
  // renews generation(). Reuses storage. Preconditions (SLAMD_DCHECK): non-empty frontals, dims >= 1, no id twice.
  // Does not touch the tree links.
  void Reset(std::span<const int> frontals, std::span<const int> frontal_dims,
             std::span<const int> separator, std::span<const int> separator_dims);
  // As Reset, but the entries of [R S d] and of the cached factor are left unspecified:
  // elimination overwrites all of them (R's strictly lower part included), and zeroing them
  // first was a memset of every re-eliminated clique on each update.
  void ResetForElimination(std::span<const int> frontals, std::span<const int> frontal_dims,
                           std::span<const int> separator, std::span<const int> separator_dims);

 private:
  friend class BayesTree;
  friend class BayesTreeTestPeer;  // tests corrupt links to exercise CheckConsistency

  void ResetImpl(std::span<const int> frontals, std::span<const int> frontal_dims,
                 std::span<const int> separator, std::span<const int> separator_dims, bool zero);

  // A fresh value of the process-wide stamp counter (relaxed atomic increment: only uniqueness
  // is needed; publishing the content to other threads is the caller's synchronisation).
  static std::uint64_t NewGeneration();

  std::uint64_t generation_ = NewGeneration();
  int num_frontals_ = 0;
  // Tree links, maintained by BayesTree (the small fields side by side: no padding between).
  int parent_ = kNone;
  int root_slot_ = kNone;  // position in BayesTree::roots_ while parent_ == kNone
  bool live_ = false;      // false while the slot is on the tree's free list
  bool marked_ = false;    // scratch flag for BayesTree::RemoveTop, false between calls
  std::vector<int> index_ = {0};      // [frontal ids (nf) | frontal offsets (nf + 1)]
  UninitVector<double> conditional_;  // [R S d], column-major
  HessianFactor cached_;              // on the separator
  std::vector<int> children_;         // tree link, maintained by BayesTree
};

}  // namespace slamd::core
