// BetweenFactor<T>: a relative pose measurement between two poses (T = Pose2 or Pose3), e.g.
// odometry or a loop closure. measured is x₂ expressed in the frame of x₁.
// Error: e = measured.LocalCoordinates(x₁⁻¹·x₂), i.e. (x, y, θ) of measured⁻¹·x₁⁻¹·x₂ in 2D (the
// chart GTSAM and g2o use, so chi2 values agree with theirs) and the SE(3) Log in 3D, translation
// first. Encoded as the measured pose (VariableTraits<T>::Encode).
#pragma once

#include "core/factors/prior_factor.h"

namespace slamd::core {

template <typename T>
class BetweenFactor : public TypedFactor<BetweenFactor<T>, T::kDim, T, T> {
  using Base = TypedFactor<BetweenFactor<T>, T::kDim, T, T>;
  using Jacobian = typename Base::template JacobianAt<0>;

 public:
  static const char* TypeName() {
    return std::is_same_v<T, Pose2> ? "BetweenPose2" : "BetweenPose3";
  }

  BetweenFactor(Key key1, Key key2, const T& measured, NoiseModel noise, RobustKernel robust = {})
      : Base({key1, key2}, std::move(noise), robust), measured_(measured) {}
  static Result<FactorPtr> Decode(const FactorRecord& r, NoiseModel noise) {
    return internal::DecodeWithMeasured<BetweenFactor, T>(r, std::move(noise));
  }

  const T& measured() const { return measured_; }
  void EncodeMeasured(std::vector<double>* out) const override { EncodeVariable(measured_, out); }
  std::optional<Variable> Measured() const override { return measured_; }
  // keys()[1] = x₀ ∘ z (known = 0), keys()[0] = x₁ ∘ z⁻¹ (known = 1).
  std::optional<Variable> Predict(int known, const Variable& known_value) const override {
    SLAMD_CHECK(std::holds_alternative<T>(known_value))
        << TypeName() << ": the known value has the wrong type";
    return std::get<T>(known_value).Compose(known == 0 ? measured_ : measured_.Inverse());
  }
  FactorFormats Formats() const override {
    if constexpr (std::is_same_v<T, Pose2>) {
      return {.g2o = "EDGE_SE2", .isam = "ODOMETRY"};
    } else {
      return {.g2o = "EDGE_SE3:QUAT"};
    }
  }

  typename Base::ErrorVector Evaluate(const T& x1, const T& x2, Jacobian* H1, Jacobian* H2) const {
    // Between's Jacobian in x2 is the identity (perturbations on the right: x1⁻¹·x2·Exp(ξ) =
    // (x1⁻¹·x2)·Exp(ξ)), so H2 is H_local itself, not a product by I on every linearisation.
    Jacobian Hb1;
    const T predicted = x1.Between(x2, H1 ? &Hb1 : nullptr, nullptr);
    Jacobian H_local;
    const typename Base::ErrorVector e =
        internal::LocalWithJacobian(measured_, predicted, (H1 || H2) ? &H_local : nullptr);
    if (H1) *H1 = H_local * Hb1;
    if (H2) *H2 = H_local;
    return e;
  }

 private:
  T measured_;
};

// Compiled once, in between_factor.cc (with the library's optimisation: code that includes this
// header, e.g. a test at -O0, calls that copy instead of making one of its own).
extern template class TypedFactor<BetweenFactor<Pose2>, Pose2::kDim, Pose2, Pose2>;
extern template class TypedFactor<BetweenFactor<Pose3>, Pose3::kDim, Pose3, Pose3>;
extern template class BetweenFactor<Pose2>;
extern template class BetweenFactor<Pose3>;

}  // namespace slamd::core
