// RelativePointFactor<P, L>: a landmark's position measured in a pose's frame (x forward, y left;
// metres): (P, L) = (Pose2, Point2) or (Pose3, Point3). This is iSAM's LANDMARK measurement and
// g2o's EDGE_SE2_XY. Error: e = pose.TransformTo(landmark) − measured.
#pragma once

#include "core/factors/factor.h"

namespace slamd::core {

template <typename P, typename L>
class RelativePointFactor
    : public BinaryFactor<RelativePointFactor<P, L>, VariableTraits<L>::kDim, P, L> {
  using Base = BinaryFactor<RelativePointFactor<P, L>, VariableTraits<L>::kDim, P, L>;

 public:
  RelativePointFactor(Key pose, Key landmark, const L& measured, NoiseModel noise,
                      RobustKernel robust = {})
      : Base(pose, landmark, std::move(noise), robust), measured_(measured) {}

  const char* Name() const override;
  const L& measured() const { return measured_; }

  typename Base::ErrorVector Evaluate(const P& pose, const L& landmark, typename Base::Jacobian1* H1,
                                      typename Base::Jacobian2* H2) const {
    return pose.TransformTo(landmark, H1, H2) - measured_;
  }

 private:
  L measured_;
};

template <> inline const char* RelativePointFactor<Pose2, Point2>::Name() const { return "RelativePoint2"; }
template <> inline const char* RelativePointFactor<Pose3, Point3>::Name() const { return "RelativePoint3"; }

}  // namespace slamd::core
