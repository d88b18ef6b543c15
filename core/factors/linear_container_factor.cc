#include "core/factors/linear_container_factor.h"

#include <string>
#include <unordered_set>

namespace slamd::core {

Result<FactorPtr> LinearContainerFactor::Create(KeyVector keys,
                                                std::vector<Variable> linearization_point,
                                                Eigen::MatrixXd A, Eigen::VectorXd b) {
  if (keys.empty()) return InvalidArgument("LinearContainerFactor: no keys");
  if (linearization_point.size() != keys.size()) {
    return InvalidArgument("LinearContainerFactor: " + std::to_string(keys.size()) + " keys but " +
                           std::to_string(linearization_point.size()) + " linearisation values");
  }
  std::unordered_set<Key> seen;
  std::vector<VariableType> types;
  int columns = 0;
  for (std::size_t k = 0; k < keys.size(); ++k) {
    if (!seen.insert(keys[k]).second) {
      return InvalidArgument("LinearContainerFactor: key " + KeyToString(keys[k]) +
                             " is listed twice");
    }
    if (!AllFinite(linearization_point[k])) {
      return InvalidArgument("LinearContainerFactor: the linearisation value of " +
                             KeyToString(keys[k]) + " is not finite");
    }
    types.push_back(TypeOf(linearization_point[k]));
    columns += TangentDim(types.back());
  }
  if (b.size() < 1 || A.rows() != b.size() || A.cols() != columns) {
    return InvalidArgument("LinearContainerFactor: A is " + std::to_string(A.rows()) + "x" +
                           std::to_string(A.cols()) + " and b has " + std::to_string(b.size()) +
                           " entries; expected m x " + std::to_string(columns) + " and m >= 1");
  }
  if (!A.allFinite() || !b.allFinite()) {
    return InvalidArgument("LinearContainerFactor: A or b has a NaN or infinite entry");
  }
  return FactorPtr(std::make_shared<const LinearContainerFactor>(std::move(keys), std::move(types),
                                                                 std::move(linearization_point),
                                                                 std::move(A), std::move(b)));
}

LinearContainerFactor::LinearContainerFactor(KeyVector keys, std::vector<VariableType> types,
                                             std::vector<Variable> linearization_point,
                                             Eigen::MatrixXd A, Eigen::VectorXd b)
    : DynamicFactor(std::move(keys), std::move(types), NoiseModel::Unit(static_cast<int>(b.size())),
                    RobustKernel()),
      x0_(std::move(linearization_point)),
      A_(std::move(A)),
      b_(std::move(b)) {
  offsets_.push_back(0);
  for (const Variable& v : x0_) offsets_.push_back(offsets_.back() + TangentDim(TypeOf(v)));
}

Result<FactorPtr> LinearContainerFactor::Decode(const FactorRecord& r, NoiseModel noise) {
  const int m = noise.dim();
  if (!noise.Equals(NoiseModel::Unit(m), 0.0) || !r.robust.is_none()) {
    return InvalidArgument("a linear container factor has the unit noise model and no kernel");
  }
  int columns = 0;
  for (const Variable& v : r.values) columns += TangentDim(TypeOf(v));
  const std::size_t expected = static_cast<std::size_t>(m) * (columns + 1);
  if (r.measured.size() != expected) {
    return InvalidArgument("measured: b and A are " + std::to_string(expected) + " numbers, not " +
                           std::to_string(r.measured.size()));
  }
  const Eigen::VectorXd b = Eigen::Map<const Eigen::VectorXd>(r.measured.data(), m);
  const Eigen::MatrixXd A = Eigen::Map<const Eigen::MatrixXd>(r.measured.data() + m, m, columns);
  return Create(r.keys, r.values, A, b);
}

void LinearContainerFactor::EncodeMeasured(std::vector<double>* out) const {
  out->insert(out->end(), b_.data(), b_.data() + b_.size());
  out->insert(out->end(), A_.data(), A_.data() + A_.size());
}

Eigen::VectorXd LinearContainerFactor::Evaluate(std::span<const Variable* const> x,
                                                std::vector<Eigen::MatrixXd>* H) const {
  Eigen::VectorXd e = b_;
  for (std::size_t k = 0; k < x0_.size(); ++k) {
    const int d = offsets_[k + 1] - offsets_[k];
    const Eigen::VectorXd delta = LocalCoordinates(x0_[k], *x[k]);
    e.noalias() += A_.middleCols(offsets_[k], d) * delta;
    if (!H) continue;
    // ∂δ/∂ε for x ⊕ ε is J⁻¹, J = ∂Local(x, x₀ ⊕ (δ + ε))/∂ε (the identity at x₀).
    const TangentMatrix J = EstimateTangentJacobian(TypeOf(x0_[k]), delta.data());
    (*H)[k] = A_.middleCols(offsets_[k], d) * J.inverse();
  }
  return e;
}

}  // namespace slamd::core
