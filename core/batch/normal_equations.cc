#include "core/batch/normal_equations.h"

#include <algorithm>

#include "core/base/timing.h"

namespace slamd::core::internal {

Result<std::unique_ptr<NormalEquations>> NormalEquations::Create(const FactorGraph& graph,
                                                                 const Values& values) {
  SLAMD_RETURN_IF_ERROR(graph.CheckAgainst(values));
  const int n = static_cast<int>(values.size());
  FactorIncidence incidence;
  incidence.offsets.reserve(graph.size() + 1);
  incidence.vars.reserve(2 * graph.size());
  std::vector<char> touched(n, 0);
  for (const FactorPtr& f : graph) {
    for (Key key : f->keys()) {
      const int slot = values.SlotOf(key);
      incidence.vars.push_back(slot);
      touched[slot] = 1;
    }
    incidence.offsets.push_back(static_cast<int>(incidence.vars.size()));
  }
  for (int s = 0; s < n; ++s) {
    if (!touched[s]) {
      return InvalidArgument("variable " + KeyToString(values.KeyAt(s)) +
                             " is not constrained by any factor");
    }
  }
  Stopwatch order_timer;
  Result<std::vector<int>> order = ColamdOrdering(n, incidence);
  if (!order.ok()) return order.status();
  const double order_s = order_timer.Seconds();
  std::vector<int> dims(n);
  for (int s = 0; s < n; ++s) dims[s] = values.DimAt(s);
  Result<BlockSparseSystem> system = BlockSparseSystem::Create(dims, *order, incidence);
  if (!system.ok()) return system.status();
  auto equations = std::unique_ptr<NormalEquations>(
      new NormalEquations(graph, values, std::move(system).value()));
  equations->order_s_ = order_s;
  return equations;
}

NormalEquations::NormalEquations(const FactorGraph& graph, const Values& values,
                                 BlockSparseSystem system)
    : graph_(graph), keys_(values.keys()), system_(std::move(system)),
      cholesky_(SparseCholesky::Create()) {}

void NormalEquations::Linearize(const Values& values) {
  system_.SetZero();
  LinearizedFactor lf;  // reused: allocates only for the largest factor met
  std::vector<const double*> blocks;
  const int num_factors = static_cast<int>(graph_.size());
  for (int f = 0; f < num_factors; ++f) {
    graph_[f]->Linearize(values, &lf);
    blocks.resize(lf.num_keys());
    for (int k = 0; k < lf.num_keys(); ++k) blocks[k] = lf.A(k);
    system_.AddFactor(f, blocks.data(), lf.b(), lf.rows());
  }
}

void NormalEquations::Damp(double lambda, bool diagonal) {
  system_.values() = undamped_;
  if (!diagonal) {
    system_.AddToDiagonal(lambda);
    return;
  }
  // Marquardt: λ·diag(H), clamped so a variable with (nearly) no information still gets damped.
  damping_ = system_.Diagonal().cwiseMax(1e-6).cwiseMin(1e32);
  system_.AddDiagonal(lambda * damping_);
}

double NormalEquations::DampingNorm(const Eigen::VectorXd& delta, bool diagonal) const {
  if (!diagonal) return delta.squaredNorm();
  // δᵀ·D·δ with D in original order and δ in permuted order.
  Eigen::VectorXd d;
  system_.FromOriginalOrder(damping_, &d);
  return delta.dot(d.cwiseProduct(delta));
}

Status NormalEquations::Solve(Eigen::VectorXd* delta) {
  Stopwatch timer;
  std::string message;
  int failed_column = -1;
  const LinearSolverTermination t =
      cholesky_->Factorize(system_.Dim(), system_.col_ptr().data(), system_.row_idx().data(),
                           system_.values().data(), &message, &failed_column);
  factorize_s_ += timer.Lap();
  if (t != LinearSolverTermination::kSuccess) {
    if (t == LinearSolverTermination::kNumericalFailure && failed_column >= 0) {
      return NumericalFailure("the linear system is indeterminate near variable " +
                              KeyToString(VariableAtColumn(failed_column)) + " (" + message + ")");
    }
    return NumericalFailure("sparse Cholesky failed: " + message);
  }
  delta->resize(system_.Dim());
  const LinearSolverTermination s = cholesky_->Solve(system_.rhs().data(), delta->data(), &message);
  solve_s_ += timer.Lap();
  if (s != LinearSolverTermination::kSuccess) {
    return NumericalFailure("sparse Cholesky solve failed: " + message);
  }
  return Status::Ok();
}

void NormalEquations::RetractAll(const Values& values, const Eigen::VectorXd& delta,
                                 Values* out) const {
  const int n = static_cast<int>(values.size());
  for (int s = 0; s < n; ++s) {
    Variable& v = out->MutableVariableAt(s);
    v = values.VariableAt(s);
    RetractInPlace(&v, delta.data() + system_.Offset(s));
  }
}

Key NormalEquations::VariableAtColumn(int column) const {
  // Variables occupy consecutive permuted ranges in elimination order.
  const std::vector<int>& order = system_.order();
  const auto it = std::upper_bound(order.begin(), order.end(), column, [&](int col, int var) {
    return col < system_.Offset(var);
  });
  const int var = *(it - 1);
  return keys_[var];
}

}  // namespace slamd::core::internal
