// Factor: one measurement's term in the nonlinear least-squares problem.
//
// A factor on variables x₁..x_k with error function e(x) (dimension m ≤ 6) and noise model R
// contributes ρ(|R·e(x)|²) to the objective (ρ = identity without a robust kernel). Solvers call
// Linearize() to get the whitened residual b = R·e and the whitened Jacobian blocks
// A_i = R·∂e/∂δ_i (δ_i the right perturbation of x_i, see variable.h), scaled by √ρ'(s) when a
// robust kernel is set (iteratively reweighted least squares). The linear sub-problem is then
// min Σ |Σ_i A_i δ_i + b|².
//
// Factors are immutable after construction and shared between graphs and threads
// (std::shared_ptr<const Factor>); Linearize allocates nothing.
#pragma once

#include <array>
#include <memory>

#include "core/base/key.h"
#include "core/factors/noise_model.h"
#include "core/factors/robust_kernel.h"
#include "core/factors/values.h"

namespace slamd::core {

// The most variables a factor touches (unary priors, binary between/landmark factors).
inline constexpr int kMaxFactorKeys = 2;

// Linearisation output with a fixed capacity: no heap allocation.
struct LinearizedFactor {
  using Block = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor,
                              kMaxResidualDim, kMaxVariableDim>;
  int rows = 0;                                     // residual dimension m
  int num_keys = 0;                                 // how many blocks of A are used
  NoiseModel::Vector b;                             // whitened (reweighted) residual, m entries
  std::array<Block, kMaxFactorKeys> A;              // A[i]: m x dim(keys[i]), column-major
};

class Factor {
 public:
  Factor(KeyVector keys, NoiseModel noise, RobustKernel robust)
      : keys_(std::move(keys)), noise_(std::move(noise)), robust_(robust) {}
  virtual ~Factor() = default;
  Factor(const Factor&) = delete;
  Factor& operator=(const Factor&) = delete;

  const KeyVector& keys() const { return keys_; }
  int dim() const { return noise_.dim(); }
  const NoiseModel& noise_model() const { return noise_; }
  const RobustKernel& robust_kernel() const { return robust_; }

  // A short type name for messages and files, e.g. "BetweenPose2".
  virtual const char* Name() const = 0;
  // The variable type keys()[i] must have.
  virtual VariableType KeyType(int i) const = 0;

  // The unwhitened error e(x). The variables must exist with the right types (see
  // FactorGraph::CheckAgainst); this is checked only in debug builds.
  virtual NoiseModel::Vector Error(const Values& values) const = 0;
  // Whitened residual and Jacobians at `values` (see the file comment).
  virtual void Linearize(const Values& values, LinearizedFactor* out) const = 0;

  // |R·e(x)|²: this factor's share of chi2.
  double Chi2(const Values& values) const;
  // ρ(|R·e(x)|²): this factor's share of the (robust) objective; equals Chi2 without a kernel.
  double Cost(const Values& values) const { return robust_.Cost(Chi2(values)); }

 private:
  KeyVector keys_;
  NoiseModel noise_;
  RobustKernel robust_;
};

using FactorPtr = std::shared_ptr<const Factor>;

namespace internal {

// Applies whitening and the robust weight to a fixed-size residual and its Jacobians, and
// copies them into `out`. Shared by the typed factor templates below.
template <int M, int... Ds>
void FinishLinearization(const NoiseModel& noise, const RobustKernel& robust,
                         Eigen::Matrix<double, M, 1>& e, LinearizedFactor* out,
                         Eigen::Matrix<double, M, Ds>&... H) {
  noise.WhitenInPlace(&e);
  (noise.WhitenInPlace(&H), ...);
  if (!robust.is_none()) {
    const double sqrt_w = std::sqrt(robust.Weight(e.squaredNorm()));
    e *= sqrt_w;
    ((H *= sqrt_w), ...);
  }
  out->rows = M;
  out->num_keys = sizeof...(Ds);
  out->b = e;
  int i = 0;
  ((out->A[i++] = H), ...);
}

}  // namespace internal

// A factor on one variable of type V with an M-dimensional error. Derived provides
//   Eigen::Matrix<double, M, 1> Evaluate(const V& x, Eigen::Matrix<double, M, Dim(V)>* H) const;
// (H may be null), plus Name().
template <typename Derived, int M, typename V>
class UnaryFactor : public Factor {
 public:
  static constexpr int kDim = VariableTraits<V>::kDim;
  using Jacobian = Eigen::Matrix<double, M, kDim>;
  using ErrorVector = Eigen::Matrix<double, M, 1>;

  UnaryFactor(Key key, NoiseModel noise, RobustKernel robust)
      : Factor({key}, std::move(noise), robust) {
    SLAMD_CHECK(noise_model().dim() == M) << "noise dimension " << noise_model().dim()
                                          << " != error dimension " << M;
  }
  VariableType KeyType(int) const final { return VariableTraits<V>::kType; }
  NoiseModel::Vector Error(const Values& values) const final {
    return self().Evaluate(values.At<V>(keys()[0]), nullptr);
  }
  void Linearize(const Values& values, LinearizedFactor* out) const final {
    Jacobian H;
    ErrorVector e = self().Evaluate(values.At<V>(keys()[0]), &H);
    internal::FinishLinearization<M>(noise_model(), robust_kernel(), e, out, H);
  }

 private:
  const Derived& self() const { return static_cast<const Derived&>(*this); }
};

// A factor on two variables of types V1, V2 with an M-dimensional error. Derived provides
//   Eigen::Matrix<double, M, 1> Evaluate(const V1&, const V2&, Eigen::Matrix<double, M, D1>* H1,
//                                        Eigen::Matrix<double, M, D2>* H2) const;
template <typename Derived, int M, typename V1, typename V2>
class BinaryFactor : public Factor {
 public:
  static constexpr int kDim1 = VariableTraits<V1>::kDim;
  static constexpr int kDim2 = VariableTraits<V2>::kDim;
  using Jacobian1 = Eigen::Matrix<double, M, kDim1>;
  using Jacobian2 = Eigen::Matrix<double, M, kDim2>;
  using ErrorVector = Eigen::Matrix<double, M, 1>;

  BinaryFactor(Key key1, Key key2, NoiseModel noise, RobustKernel robust)
      : Factor({key1, key2}, std::move(noise), robust) {
    SLAMD_CHECK(noise_model().dim() == M) << "noise dimension " << noise_model().dim()
                                          << " != error dimension " << M;
  }
  VariableType KeyType(int i) const final {
    return i == 0 ? VariableTraits<V1>::kType : VariableTraits<V2>::kType;
  }
  NoiseModel::Vector Error(const Values& values) const final {
    return self().Evaluate(values.At<V1>(keys()[0]), values.At<V2>(keys()[1]), nullptr, nullptr);
  }
  void Linearize(const Values& values, LinearizedFactor* out) const final {
    Jacobian1 H1;
    Jacobian2 H2;
    ErrorVector e = self().Evaluate(values.At<V1>(keys()[0]), values.At<V2>(keys()[1]), &H1, &H2);
    internal::FinishLinearization<M>(noise_model(), robust_kernel(), e, out, H1, H2);
  }

 private:
  const Derived& self() const { return static_cast<const Derived&>(*this); }
};

}  // namespace slamd::core
