#include "core/factors/factor.h"

#include <algorithm>

namespace slamd::core {

Eigen::VectorXd Factor::Error(const Values& values) const {
  Eigen::VectorXd e(dim());
  EvaluateError(values, e.data());
  return e;
}

std::optional<Variable> MeasuredRelativePose(const Factor& factor) {
  if (factor.keys().size() != 2 || factor.KeyType(0) != factor.KeyType(1)) return std::nullopt;
  std::optional<Variable> z = factor.Measured();
  if (!z || TypeOf(*z) != factor.KeyType(0)) return std::nullopt;
  const std::span<const EntryKind> kinds = EntryKinds(TypeOf(*z));
  if (std::find(kinds.begin(), kinds.end(), EntryKind::kRotation) == kinds.end()) {
    return std::nullopt;  // two points: not a pose
  }
  return z;
}

double Factor::Chi2(const Values& values) const {
  if (dim() <= kMaxResidualDim) {  // the common case: no heap
    double e[kMaxResidualDim];
    EvaluateError(values, e);
    return noise_.SquaredMahalanobis(Eigen::Map<const Eigen::VectorXd>(e, dim()));
  }
  return noise_.SquaredMahalanobis(Error(values));
}

DynamicFactor::DynamicFactor(KeyVector keys, std::vector<VariableType> types, NoiseModel noise,
                             RobustKernel robust)
    : Factor(std::move(keys), std::move(noise), robust), types_(std::move(types)) {
  SLAMD_CHECK(types_.size() == this->keys().size())
      << types_.size() << " key types for " << this->keys().size() << " keys";
}

std::vector<const Variable*> DynamicFactor::Gather(const Values& values) const {
  std::vector<const Variable*> x(keys().size());
  for (std::size_t k = 0; k < x.size(); ++k) {
    x[k] = &values.Get(keys()[k]);
    SLAMD_DCHECK(TypeOf(*x[k]) == types_[k]) << Name() << ": key " << k << " has the wrong type";
  }
  return x;
}

void DynamicFactor::EvaluateError(const Values& values, double* e) const {
  const Eigen::VectorXd error = Evaluate(Gather(values), nullptr);
  SLAMD_CHECK(error.size() == dim()) << Name() << ": error of " << error.size() << " entries";
  Eigen::Map<Eigen::VectorXd>(e, dim()) = error;
}

void DynamicFactor::Linearize(const Values& values, LinearizedFactor* out) const {
  std::vector<Eigen::MatrixXd> H(keys().size());
  Eigen::VectorXd e = Evaluate(Gather(values), &H);
  const int m = dim();
  SLAMD_CHECK(e.size() == m) << Name() << ": error of " << e.size() << " entries";
  Eigen::VectorXd w(m);
  noise_model().Whiten(e.data(), w.data());
  const double scale = RobustScale(w.squaredNorm());
  std::vector<int> dims(keys().size());
  for (std::size_t k = 0; k < dims.size(); ++k) dims[k] = TangentDim(types_[k]);
  out->Reset(m, dims);
  out->MutableRhs() = scale * w;
  for (std::size_t k = 0; k < dims.size(); ++k) {
    SLAMD_CHECK(H[k].rows() == m && H[k].cols() == dims[k])
        << Name() << ": Jacobian " << k << " is " << H[k].rows() << "x" << H[k].cols();
    Eigen::Map<Eigen::MatrixXd> block = out->MutableBlock(static_cast<int>(k));
    for (int j = 0; j < dims[k]; ++j) noise_model().Whiten(H[k].col(j).data(), block.col(j).data());
    block *= scale;
  }
}

}  // namespace slamd::core
