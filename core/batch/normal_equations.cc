#include "core/batch/normal_equations.h"

#include <algorithm>

#include "core/base/timing.h"

namespace slamd::core::internal {
namespace {

bool IsLandmark(VariableType type) {
  return type == kVariableType<Point2> || type == kVariableType<Point3>;
}

// group[v] = 0 for the landmarks, 1 for the rest; empty when some factor touches two landmarks
// (then they are not eliminated as independent blocks).
std::vector<int> LandmarkGroups(const Values& values, const FactorIncidence& incidence,
                                int* num_landmarks) {
  const int n = static_cast<int>(values.size());
  std::vector<int> group(n, 1);
  *num_landmarks = 0;
  for (int s = 0; s < n; ++s) {
    if (IsLandmark(values.TypeAt(s))) {
      group[s] = 0;
      ++*num_landmarks;
    }
  }
  for (int f = 0; f < incidence.NumFactors(); ++f) {
    int landmarks = 0;
    for (int i = incidence.offsets[f]; i < incidence.offsets[f + 1]; ++i) {
      landmarks += group[incidence.vars[i]] == 0;
    }
    if (landmarks > 1) return {};
  }
  return group;
}

Result<std::vector<int>> Order(const Values& values, const FactorIncidence& incidence,
                               BatchParams::Ordering ordering, int* landmarks_first) {
  const int n = static_cast<int>(values.size());
  *landmarks_first = 0;
  if (ordering != BatchParams::Ordering::kColamd) {
    int num_landmarks = 0;
    const std::vector<int> group = LandmarkGroups(values, incidence, &num_landmarks);
    const bool many = 2 * num_landmarks > n;
    if (!group.empty() && num_landmarks > 0 && num_landmarks < n &&
        (ordering == BatchParams::Ordering::kLandmarksFirst || many)) {
      *landmarks_first = num_landmarks;
      return ConstrainedColamdOrdering(n, incidence, group);
    }
  }
  return ColamdOrdering(n, incidence);
}

}  // namespace

Result<std::unique_ptr<NormalEquations>> NormalEquations::Create(const FactorGraph& graph,
                                                                 const Values& values,
                                                                 BatchParams::Ordering ordering) {
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
  int landmarks_first = 0;
  Result<std::vector<int>> order = Order(values, incidence, ordering, &landmarks_first);
  if (!order.ok()) return order.status();
  const double order_s = order_timer.Seconds();
  std::vector<int> dims(n);
  for (int s = 0; s < n; ++s) dims[s] = values.DimAt(s);
  Result<BlockSparseSystem> system = BlockSparseSystem::Create(dims, *order, incidence);
  if (!system.ok()) return system.status();
  auto equations = std::unique_ptr<NormalEquations>(
      new NormalEquations(graph, values, std::move(system).value()));
  equations->order_s_ = order_s;
  equations->landmarks_first_ = landmarks_first;
  if (landmarks_first > 0) {
    Result<std::unique_ptr<LandmarkSchur>> schur =
        LandmarkSchur::Create(equations->system_, landmarks_first);
    if (!schur.ok()) return schur.status();
    equations->schur_ = std::move(schur).value();
  }
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
  // Landmarks first: the Cholesky factor is the Schur complement's, whose scalars are H's from
  // LandmarkDim() on.
  int column_offset = 0;
  const BlockSparseSystem* factored = &system_;
  if (schur_ != nullptr) {
    int landmark = -1;
    const Status reduced = schur_->Reduce(system_, &landmark);
    if (!reduced.ok()) {
      factorize_s_ += timer.Lap();
      return NumericalFailure("the linear system is indeterminate at landmark " +
                              KeyToString(keys_[landmark]) + " (" + reduced.message() + ")");
    }
    column_offset = schur_->LandmarkDim();
    factored = &schur_->reduced();
  }
  std::string message;
  int failed_column = -1;
  const LinearSolverTermination t =
      cholesky_->Factorize(factored->Dim(), factored->col_ptr().data(), factored->row_idx().data(),
                           factored->values().data(), &message, &failed_column);
  factorize_s_ += timer.Lap();
  if (t != LinearSolverTermination::kSuccess) {
    if (t == LinearSolverTermination::kNumericalFailure && failed_column >= 0) {
      return NumericalFailure("the linear system is indeterminate near variable " +
                              KeyToString(VariableAtColumn(failed_column + column_offset)) + " (" +
                              message + ")");
    }
    return NumericalFailure("sparse Cholesky failed: " + message);
  }
  Eigen::VectorXd& x = schur_ != nullptr ? reduced_delta_ : *delta;
  x.resize(factored->Dim());
  const LinearSolverTermination s = cholesky_->Solve(factored->rhs().data(), x.data(), &message);
  if (s != LinearSolverTermination::kSuccess) {
    solve_s_ += timer.Lap();
    return NumericalFailure("sparse Cholesky solve failed: " + message);
  }
  if (schur_ != nullptr) schur_->BackSubstitute(system_, reduced_delta_, delta);
  solve_s_ += timer.Lap();
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
