// PositionPriorFactor<P>: an absolute position measurement of a pose (e.g. GPS), ignoring its
// orientation; P = Pose2 (2D position) or Pose3 (3D position). Error: e = translation − measured,
// in the world frame (metres).
#pragma once

#include "core/factors/factor.h"

namespace slamd::core {

template <typename P>
class PositionPriorFactor
    : public UnaryFactor<PositionPriorFactor<P>, P::kDim == 3 ? 2 : 3, P> {
  static constexpr int kM = P::kDim == 3 ? 2 : 3;
  using Base = UnaryFactor<PositionPriorFactor<P>, kM, P>;
  using Position = Eigen::Matrix<double, kM, 1>;

 public:
  PositionPriorFactor(Key key, const Position& measured, NoiseModel noise, RobustKernel robust = {})
      : Base(key, std::move(noise), robust), measured_(measured) {}

  const char* Name() const override;
  const Position& measured() const { return measured_; }

  typename Base::ErrorVector Evaluate(const P& pose, typename Base::Jacobian* H) const {
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

template <> inline const char* PositionPriorFactor<Pose2>::Name() const { return "PositionPrior2"; }
template <> inline const char* PositionPriorFactor<Pose3>::Name() const { return "PositionPrior3"; }

}  // namespace slamd::core
