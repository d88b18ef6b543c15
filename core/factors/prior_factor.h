// PriorFactor<T>: an absolute measurement of one variable (any variable type).
// Error: the chart coordinates of the estimate relative to the measurement,
//   poses:  e = measured.LocalCoordinates(x)   (Pose2: (x, y, θ) of measured⁻¹·x; Pose3: Log)
//   points, calibrations: e = x − measured
// so the noise model is expressed in the measurement's frame (translation first, see pose3.h).
// Encoded as the measured value (VariableTraits<T>::Encode).
#pragma once

#include <string>

#include "core/factors/factor.h"

namespace slamd::core {

namespace internal {

// e = a.LocalCoordinates(b) with H = ∂e/∂δ_b for b ⊕ δ_b (a fixed).
// (a⁻¹·b's Jacobian in b is the identity, so H is the chart's Jacobian alone.)
inline Vector3 LocalWithJacobian(const Pose2& a, const Pose2& b, Matrix3* H) {
  return Pose2::ChartLocal(a.Between(b), H);
}
inline Vector6 LocalWithJacobian(const Pose3& a, const Pose3& b, Matrix6* H) {
  return Pose3::Log(a.Between(b), H);
}
// Variables that move by addition: e = b − a, H = I.
template <typename T, int D = VariableTraits<T>::kDim>
Eigen::Matrix<double, D, 1> LocalWithJacobian(const T& a, const T& b,
                                              Eigen::Matrix<double, D, D>* H) {
  if (H) H->setIdentity();
  return VariableTraits<T>::Local(a, b);
}

// Rebuilds a factor F(keys..., measured, noise, robust) whose measurement is a value of type T.
template <typename F, typename T>
Result<FactorPtr> DecodeWithMeasured(const FactorRecord& r, NoiseModel noise) {
  Result<Variable> measured = DecodeVariable(kVariableType<T>, r.measured);
  if (!measured.ok()) return InvalidArgument("measured: " + measured.status().message());
  const T& z = std::get<T>(*measured);
  if constexpr (F::kNumKeys == 1) {
    return FactorPtr(std::make_shared<const F>(r.keys[0], z, std::move(noise), r.robust));
  } else {
    return FactorPtr(
        std::make_shared<const F>(r.keys[0], r.keys[1], z, std::move(noise), r.robust));
  }
}

}  // namespace internal

template <typename T>
class PriorFactor : public TypedFactor<PriorFactor<T>, VariableTraits<T>::kDim, T> {
  using Base = TypedFactor<PriorFactor<T>, VariableTraits<T>::kDim, T>;

 public:
  // "Prior" + the variable type's name, e.g. "PriorPose2".
  static const char* TypeName() {
    static const std::string name = std::string("Prior") + VariableTraits<T>::kName;
    return name.c_str();
  }

  PriorFactor(Key key, const T& measured, NoiseModel noise, RobustKernel robust = {})
      : Base({key}, std::move(noise), robust), measured_(measured) {}
  static Result<FactorPtr> Decode(const FactorRecord& r, NoiseModel noise) {
    return internal::DecodeWithMeasured<PriorFactor, T>(r, std::move(noise));
  }

  const T& measured() const { return measured_; }
  void EncodeMeasured(std::vector<double>* out) const override { EncodeVariable(measured_, out); }
  std::optional<Variable> Measured() const override { return measured_; }

  typename Base::ErrorVector Evaluate(const T& x, typename Base::template JacobianAt<0>* H) const {
    return internal::LocalWithJacobian(measured_, x, H);
  }

 private:
  T measured_;
};

}  // namespace slamd::core
