// RelativePointFactor<P, L>: a landmark's position measured in a pose's frame (x forward, y left;
// metres): (P, L) = (Pose2, Point2) or (Pose3, Point3). This is iSAM's LANDMARK measurement and
// g2o's EDGE_SE2_XY. Error: e = pose.TransformTo(landmark) − measured. Encoded as the point.
#pragma once

#include "core/factors/prior_factor.h"

namespace slamd::core {

template <typename P, typename L>
class RelativePointFactor
    : public TypedFactor<RelativePointFactor<P, L>, VariableTraits<L>::kDim, P, L> {
  using Base = TypedFactor<RelativePointFactor<P, L>, VariableTraits<L>::kDim, P, L>;

 public:
  static const char* TypeName() {
    return std::is_same_v<P, Pose2> ? "RelativePoint2" : "RelativePoint3";
  }

  RelativePointFactor(Key pose, Key landmark, const L& measured, NoiseModel noise,
                      RobustKernel robust = {})
      : Base({pose, landmark}, std::move(noise), robust), measured_(measured) {}
  static Result<FactorPtr> Decode(const FactorRecord& r, NoiseModel noise) {
    return internal::DecodeWithMeasured<RelativePointFactor, L>(r, std::move(noise));
  }

  const L& measured() const { return measured_; }
  void EncodeMeasured(std::vector<double>* out) const override { EncodeVariable(measured_, out); }
  std::optional<Variable> Measured() const override { return measured_; }
  // The landmark keys()[1] from the pose (known = 0) only.
  std::optional<Variable> Predict(int known, const Variable& known_value) const override {
    if (known != 0) return std::nullopt;
    return std::get<P>(known_value).TransformFrom(measured_);
  }
  FactorFormats Formats() const override {
    if constexpr (std::is_same_v<P, Pose2>) {
      return {.g2o = "EDGE_SE2_XY", .isam = "LANDMARK"};
    } else {
      return {};
    }
  }

  typename Base::ErrorVector Evaluate(const P& pose, const L& landmark,
                                      typename Base::template JacobianAt<0>* H1,
                                      typename Base::template JacobianAt<1>* H2) const {
    return pose.TransformTo(landmark, H1, H2) - measured_;
  }

 private:
  L measured_;
};

}  // namespace slamd::core
