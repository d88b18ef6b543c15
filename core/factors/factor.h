// Factor: one measurement's term in the nonlinear least-squares problem.
//
// A factor on variables x₁..x_k with error function e(x) (dimension m) and noise model R
// contributes ρ(|R·e(x)|²) to the objective (ρ = identity without a robust kernel). Solvers call
// Linearize() to get the whitened residual b = R·e and the whitened Jacobian blocks
// A_i = R·∂e/∂δ_i (δ_i the right perturbation of x_i, see variables/variable.h), scaled by √ρ'(s)
// when a robust kernel is set (iteratively reweighted least squares). The linear sub-problem is
// then min Σ |Σ_i A_i δ_i + b|².
//
// Two bases implement Linearize for concrete factors:
//  - TypedFactor<Derived, M, V...>: an M-dimensional error on keys of the variable types V...,
//    with fixed-size Jacobians (no heap allocation per linearisation);
//  - DynamicFactor: sizes known only at run time (e.g. LinearContainerFactor).
// Each concrete factor's own files declare its type name, how its measurement is encoded
// (EncodeMeasured, read back by the registry, factor_registry.h), the formats that have it, and
// the initial guesses it gives (Predict).
//
// Factors are immutable after construction and shared between graphs and threads
// (std::shared_ptr<const Factor>).
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <span>
#include <tuple>
#include <vector>

#include "core/base/inlined_vector.h"
#include "core/base/key.h"
#include "core/factors/factor_record.h"
#include "core/factors/linearized_factor.h"
#include "core/factors/noise_model.h"
#include "core/factors/robust_kernel.h"
#include "core/factors/values.h"

namespace slamd::core {

// Where a factor type appears in text formats (nullptr: the format has no such record).
struct FactorFormats {
  const char* g2o = nullptr;   // g2o edge tag, e.g. "EDGE_SE2"
  const char* isam = nullptr;  // iSAM line tag, e.g. "ODOMETRY"
};

class Factor {
 public:
  Factor(const KeyVector& keys, NoiseModel noise, RobustKernel robust)
      : noise_(std::move(noise)), robust_(robust) {
    keys_.assign(keys);
  }
  virtual ~Factor() = default;
  Factor(const Factor&) = delete;
  Factor& operator=(const Factor&) = delete;

  std::span<const Key> keys() const { return {keys_.data(), keys_.size()}; }
  int dim() const { return noise_.dim(); }
  const NoiseModel& noise_model() const { return noise_; }
  const RobustKernel& robust_kernel() const { return robust_; }

  // The registered type name (factor_registry.h), e.g. "BetweenPose2".
  virtual const char* Name() const = 0;
  // The variable type keys()[i] must have.
  virtual VariableType KeyType(int i) const = 0;

  // The unwhitened error e(x), dim() entries written to `e`. The variables must exist with the
  // right types (see FactorGraph::CheckAgainst); this is checked only in debug builds.
  virtual void EvaluateError(const Values& values, double* e) const = 0;
  // Whitened residual and Jacobians at `values` (see the file comment).
  virtual void Linearize(const Values& values, LinearizedFactor* out) const = 0;

  // The measured quantity in the type's own layout of numbers (snapshots, exports); with the
  // keys, noise and kernel it rebuilds the factor (DecodeFactor, factor_registry.h).
  virtual void EncodeMeasured(std::vector<double>* out) const = 0;
  // Values the factor carries besides its measurement (LinearContainerFactor: its linearisation
  // point), for FactorRecord::values; none by default.
  virtual std::vector<Variable> CarriedValues() const { return {}; }
  // The measurement as a value, for factors whose error is the chart difference between it and a
  // prediction of the same kind from the keys: between factors (the relative pose), priors (the
  // value), relative points (the point in the pose's frame). Nothing for other factors.
  virtual std::optional<Variable> Measured() const { return std::nullopt; }
  // The value this factor puts the variable keys()[1 - known] at, given keys()[known] =
  // `known_value` (initial guesses); nothing when it cannot (the default, and e.g. a landmark
  // does not place its pose). `known_value` must have KeyType(known) (checked).
  virtual std::optional<Variable> Predict(int known, const Variable& known_value) const {
    (void)known;
    (void)known_value;
    return std::nullopt;
  }
  // The text formats that have this factor type.
  virtual FactorFormats Formats() const { return {}; }

  // e(x) as a vector (allocates: for tests and tools, not for solvers).
  Eigen::VectorXd Error(const Values& values) const;
  // |R·e(x)|²: this factor's share of chi2.
  double Chi2(const Values& values) const;
  // ρ(|R·e(x)|²): this factor's share of the (robust) objective; equals Chi2 without a kernel.
  double Cost(const Values& values) const { return robust_.Cost(Chi2(values)); }

 protected:
  // √ρ'(|R·e|²) for a whitened residual w, or 1 without a kernel.
  double RobustScale(double whitened2) const {
    return robust_.is_none() ? 1.0 : std::sqrt(robust_.Weight(whitened2));
  }

 private:
  InlinedVector<Key, 2> keys_;  // most factors have one or two keys: no heap block for them
  NoiseModel noise_;
  RobustKernel robust_;
};

using FactorPtr = std::shared_ptr<const Factor>;

// The relative pose a factor on two poses of one kind measures (between factors: odometry and
// loop closures): its Measured() when that is a pose of its keys' kind; nothing otherwise.
std::optional<Variable> MeasuredRelativePose(const Factor& factor);

// A factor on the variable types V... with an M-dimensional error. Derived provides
//   static const char* TypeName();  (the registered name)
//   Eigen::Matrix<double, M, 1> Evaluate(const V&... x, JacobianAt<i>*... H) const;
// (each H may be null: error only) and EncodeMeasured; Measured, Predict and Formats as it has
// them.
template <typename Derived, int M, typename... V>
class TypedFactor : public Factor {
 public:
  static_assert(M >= 1 && M <= kMaxResidualDim, "residual dimension out of range");
  static_assert(sizeof...(V) >= 1, "a factor has at least one key");
  static constexpr int kNumKeys = sizeof...(V);
  static constexpr int kResidualDim = M;
  using ErrorVector = Eigen::Matrix<double, M, 1>;
  template <int I>
  using JacobianAt =
      Eigen::Matrix<double, M, VariableTraits<std::tuple_element_t<I, std::tuple<V...>>>::kDim>;

  TypedFactor(KeyVector keys, NoiseModel noise, RobustKernel robust)
      : Factor(std::move(keys), std::move(noise), robust) {
    SLAMD_CHECK(static_cast<int>(this->keys().size()) == kNumKeys)
        << Derived::TypeName() << ": " << this->keys().size() << " keys, expected " << kNumKeys;
    SLAMD_CHECK(noise_model().dim() == M) << Derived::TypeName() << ": noise dimension "
                                          << noise_model().dim() << " != error dimension " << M;
  }

  const char* Name() const final { return Derived::TypeName(); }
  VariableType KeyType(int i) const final {
    static constexpr std::array<VariableType, kNumKeys> kTypes = {kVariableType<V>...};
    return kTypes[i];
  }
  void EvaluateError(const Values& values, double* e) const final {
    Eigen::Map<ErrorVector>{e} = Call(values, Indices{}, static_cast<JacobianOf<V>*>(nullptr)...);
  }
  void Linearize(const Values& values, LinearizedFactor* out) const final {
    std::tuple<JacobianOf<V>...> H;
    ErrorVector e = CallWith(values, &H, Indices{});
    noise_model().WhitenInPlace(&e);
    const double scale = RobustScale(e.squaredNorm());
    static constexpr std::array<int, kNumKeys> kDims = {VariableTraits<V>::kDim...};
    out->Reset(M, kDims);
    Eigen::Map<ErrorVector>{out->b()} = scale * e;
    Store(&H, scale, out, Indices{});
  }

 private:
  using Indices = std::index_sequence_for<V...>;
  template <typename T>
  using JacobianOf = Eigen::Matrix<double, M, VariableTraits<T>::kDim>;

  const Derived& self() const { return static_cast<const Derived&>(*this); }
  template <std::size_t... I, typename... H>
  ErrorVector Call(const Values& values, std::index_sequence<I...>, H*... jacobians) const {
    return self().Evaluate(values.At<V>(keys()[I])..., jacobians...);
  }
  template <std::size_t... I>
  ErrorVector CallWith(const Values& values, std::tuple<JacobianOf<V>...>* H,
                       std::index_sequence<I...>) const {
    return self().Evaluate(values.At<V>(keys()[I])..., &std::get<I>(*H)...);
  }
  template <std::size_t... I>
  void Store(std::tuple<JacobianOf<V>...>* H, double scale, LinearizedFactor* out,
             std::index_sequence<I...>) const {
    ((noise_model().WhitenInPlace(&std::get<I>(*H)),
      Eigen::Map<JacobianOf<V>>{out->A(static_cast<int>(I))} = scale * std::get<I>(*H)),
     ...);
  }
};

// A factor whose key count and residual size are known only at run time. Derived provides
//   Eigen::VectorXd Evaluate(std::span<const Variable* const> x,
//                            std::vector<Eigen::MatrixXd>* H) const;
// the unwhitened error at the keys' values x and, when H is not null, ∂e/∂δ_k in (*H)[k]
// (dim() x TangentDim(KeyType(k)); H comes sized to the number of keys). Linearising
// allocates.
class DynamicFactor : public Factor {
 public:
  DynamicFactor(KeyVector keys, std::vector<VariableType> types, NoiseModel noise,
                RobustKernel robust);

  VariableType KeyType(int i) const final { return types_[i]; }
  void EvaluateError(const Values& values, double* e) const final;
  void Linearize(const Values& values, LinearizedFactor* out) const final;

  virtual Eigen::VectorXd Evaluate(std::span<const Variable* const> x,
                                   std::vector<Eigen::MatrixXd>* H) const = 0;

 private:
  std::vector<const Variable*> Gather(const Values& values) const;

  std::vector<VariableType> types_;
};

}  // namespace slamd::core
