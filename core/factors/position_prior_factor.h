// PositionPriorFactor<P>: an absolute position measurement of a pose (e.g. GPS), ignoring its
// orientation; P = Pose2 (2D position) or Pose3 (3D position). Error: e = translation − measured,
// in the world frame (metres). Encoded as the position.
#pragma once

#include "core/factors/prior_factor.h"

namespace slamd::core {

template <typename P>
class PositionPriorFactor : public TypedFactor<PositionPriorFactor<P>, P::kDim == 3 ? 2 : 3, P> {
  static constexpr int kM = P::kDim == 3 ? 2 : 3;
  using Base = TypedFactor<PositionPriorFactor<P>, kM, P>;
  using Position = Eigen::Matrix<double, kM, 1>;  // Point2 or Point3

 public:
  static const char* TypeName() {
    return std::is_same_v<P, Pose2> ? "PositionPrior2" : "PositionPrior3";
  }

  PositionPriorFactor(Key key, const Position& measured, NoiseModel noise, RobustKernel robust = {})
      : Base({key}, std::move(noise), robust), measured_(measured) {}
  static Result<FactorPtr> Decode(const FactorRecord& r, NoiseModel noise) {
    return internal::DecodeWithMeasured<PositionPriorFactor, Position>(r, std::move(noise));
  }

  const Position& measured() const { return measured_; }
  void EncodeMeasured(std::vector<double>* out) const override {
    out->insert(out->end(), measured_.data(), measured_.data() + kM);
  }

  typename Base::ErrorVector Evaluate(const P& pose,
                                      typename Base::template JacobianAt<0>* H) const {
    // Under the right perturbation (translation first) t moves by R·δt and not with δθ.
    if (H) {
      H->setZero();
      H->template leftCols<kM>() = pose.rotation().matrix();
    }
    return pose.translation() - measured_;
  }

 private:
  Position measured_;
};

}  // namespace slamd::core
