// PriorFactor<T>: an absolute measurement of one variable (T = Pose2, Pose3, Point2, Point3).
// Error: the chart coordinates of the estimate relative to the measurement,
//   poses:  e = measured.LocalCoordinates(x)   (Pose2: (x, y, θ) of measured⁻¹·x; Pose3: Log)
//   points: e = x − measured
// so the noise model is expressed in the measurement's frame (translation first, see pose3.h).
#pragma once

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
inline Vector2 LocalWithJacobian(const Point2& a, const Point2& b, Matrix2* H) {
  if (H) H->setIdentity();
  return b - a;
}
inline Vector3 LocalWithJacobian(const Point3& a, const Point3& b, Matrix3* H) {
  if (H) H->setIdentity();
  return b - a;
}

}  // namespace internal

template <typename T>
class PriorFactor : public UnaryFactor<PriorFactor<T>, VariableTraits<T>::kDim, T> {
  using Base = UnaryFactor<PriorFactor<T>, VariableTraits<T>::kDim, T>;

 public:
  PriorFactor(Key key, const T& measured, NoiseModel noise, RobustKernel robust = {})
      : Base(key, std::move(noise), robust), measured_(measured) {}

  const char* Name() const override;
  const T& measured() const { return measured_; }

  typename Base::ErrorVector Evaluate(const T& x, typename Base::Jacobian* H) const {
    return internal::LocalWithJacobian(measured_, x, H);
  }

 private:
  T measured_;
};

template <> inline const char* PriorFactor<Pose2>::Name() const { return "PriorPose2"; }
template <> inline const char* PriorFactor<Pose3>::Name() const { return "PriorPose3"; }
template <> inline const char* PriorFactor<Point2>::Name() const { return "PriorPoint2"; }
template <> inline const char* PriorFactor<Point3>::Name() const { return "PriorPoint3"; }

}  // namespace slamd::core
