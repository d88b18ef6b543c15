// BetweenFactor<T>: a relative pose measurement between two poses (T = Pose2 or Pose3), e.g.
// odometry or a loop closure. measured is x₂ expressed in the frame of x₁.
// Error: e = measured.LocalCoordinates(x₁⁻¹·x₂), i.e. (x, y, θ) of measured⁻¹·x₁⁻¹·x₂ in 2D (the
// chart GTSAM and g2o use, so chi2 values agree with theirs) and the SE(3) Log in 3D, translation
// first.
#pragma once

#include "core/factors/prior_factor.h"

namespace slamd::core {

template <typename T>
class BetweenFactor : public BinaryFactor<BetweenFactor<T>, T::kDim, T, T> {
  using Base = BinaryFactor<BetweenFactor<T>, T::kDim, T, T>;

 public:
  BetweenFactor(Key key1, Key key2, const T& measured, NoiseModel noise, RobustKernel robust = {})
      : Base(key1, key2, std::move(noise), robust), measured_(measured) {}

  const char* Name() const override;
  const T& measured() const { return measured_; }

  typename Base::ErrorVector Evaluate(const T& x1, const T& x2, typename Base::Jacobian1* H1,
                                      typename Base::Jacobian2* H2) const {
    // Between's Jacobian in x2 is the identity (perturbations on the right: x1⁻¹·x2·Exp(ξ) =
    // (x1⁻¹·x2)·Exp(ξ)), so H2 is H_local itself, not a product by I on every linearisation.
    typename Base::Jacobian1 Hb1;
    const T predicted = x1.Between(x2, H1 ? &Hb1 : nullptr, nullptr);
    typename Base::Jacobian2 H_local;
    const typename Base::ErrorVector e =
        internal::LocalWithJacobian(measured_, predicted, (H1 || H2) ? &H_local : nullptr);
    if (H1) *H1 = H_local * Hb1;
    if (H2) *H2 = H_local;
    return e;
  }

 private:
  T measured_;
};

template <> inline const char* BetweenFactor<Pose2>::Name() const { return "BetweenPose2"; }
template <> inline const char* BetweenFactor<Pose3>::Name() const { return "BetweenPose3"; }

}  // namespace slamd::core
