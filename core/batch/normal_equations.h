// NormalEquations: a factor graph's Gauss-Newton system H·δ = b (H = Σ AᵀA, b = −Σ Aᵀb_f over
// the whitened, robust-reweighted linearisations of every factor) on a fixed variable set, with
// a block-level ordering and a CHOLMOD factorisation whose symbolic analysis is reused across
// linearisations and damping values. The batch solver's linear engine.
//
// The ordering: COLAMD, or the landmarks first. Landmarks are the Point2/Point3 variables when no
// factor touches two of them (visual SLAM, bundle adjustment, range-bearing SLAM): H's landmark
// block is then block-diagonal, eliminating it first costs one small block per landmark and
// creates no fill among them, and what is left to factor is the Schur complement on the poses
// and calibrations (the reduced camera system of bundle adjustment, core/ba). CCOLAMD orders
// the rest. kAuto takes the landmarks first when they outnumber the other variables.
//
// Variables are the slots of the Values passed to Create(); δ is indexed by permuted scalar
// offsets (Offset(slot)), which is what RetractAll() consumes.
#pragma once

#include <memory>
#include <vector>

#include "core/batch/batch_params.h"
#include "core/factors/factor_graph.h"
#include "core/linear/block_sparse_system.h"
#include "core/linear/landmark_schur.h"
#include "core/linear/sparse_cholesky.h"

namespace slamd::core::internal {

class NormalEquations {
 public:
  // Checks the graph against the values (every key present with the right type, every variable
  // touched by some factor) and builds the ordering and the sparsity pattern.
  static Result<std::unique_ptr<NormalEquations>> Create(
      const FactorGraph& graph, const Values& values,
      BatchParams::Ordering ordering = BatchParams::Ordering::kAuto);

  // Linearises every factor at `values` into H and b (values must have the same keys and slots as
  // the ones given to Create).
  void Linearize(const Values& values);
  // Saves the undamped H so that damping can be added and removed repeatedly.
  void SaveUndamped() { undamped_ = system_.values(); }
  // H ← H_undamped + λ·D with D = I or D = clamp(diag(H_undamped)).
  void Damp(double lambda, bool diagonal);

  // Factorises H (or, landmarks first, eliminates them and factorises the Schur complement) and
  // solves H·δ = b. On failure the status names the variable nearest to the failing pivot.
  Status Solve(Eigen::VectorXd* delta);

  // out ← values ⊕ δ for every variable (out must have the same keys and slots).
  void RetractAll(const Values& values, const Eigen::VectorXd& delta, Values* out) const;

  // b (permuted order) of the last linearisation.
  const Eigen::VectorXd& rhs() const { return system_.rhs(); }
  // δᵀ·D·δ for the damping matrix D of the last Damp() call (the predicted-decrease term).
  double DampingNorm(const Eigen::VectorXd& delta, bool diagonal) const;

  double order_seconds() const { return order_s_; }  // the ordering in Create()
  // How many landmarks the ordering put first (0: plain COLAMD).
  int landmarks_first() const { return landmarks_first_; }
  double factorize_seconds() const { return factorize_s_; }
  double solve_seconds() const { return solve_s_; }
  const BlockSparseSystem& system() const { return system_; }

 private:
  NormalEquations(const FactorGraph& graph, const Values& values, BlockSparseSystem system);
  // The variable whose scalar block holds permuted column `column`.
  Key VariableAtColumn(int column) const;

  const FactorGraph& graph_;
  std::vector<Key> keys_;
  BlockSparseSystem system_;
  std::unique_ptr<LandmarkSchur> schur_;  // the landmarks first: solve through S (null: COLAMD)
  Eigen::VectorXd reduced_delta_;         // S's solution
  std::unique_ptr<SparseCholesky> cholesky_;
  std::vector<double> undamped_;
  Eigen::VectorXd damping_;            // D of the last Damp() (diagonal mode), original order
  double order_s_ = 0.0;
  int landmarks_first_ = 0;
  double factorize_s_ = 0.0;
  double solve_s_ = 0.0;
};

}  // namespace slamd::core::internal
