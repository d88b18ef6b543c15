// BearingRangeFactor: a landmark (Point2) seen from a Pose2 at a bearing (radians,
// counter-clockwise from the pose's x axis) and a range (metres), e.g. from a laser or a camera
// with depth. Error: e = (wrap(bearing(x) − measured_bearing), range(x) − measured_range).
// Encoded as (bearing, range).
#pragma once

#include "core/factors/factor.h"

namespace slamd::core {

class BearingRangeFactor : public TypedFactor<BearingRangeFactor, 2, Pose2, Point2> {
 public:
  static const char* TypeName() { return "BearingRange2"; }

  BearingRangeFactor(Key pose, Key landmark, double bearing, double range, NoiseModel noise,
                     RobustKernel robust = {})
      : TypedFactor({pose, landmark}, std::move(noise), robust), bearing_(bearing), range_(range) {}
  static Result<FactorPtr> Decode(const FactorRecord& r, NoiseModel noise);

  double bearing() const { return bearing_; }
  double range() const { return range_; }
  void EncodeMeasured(std::vector<double>* out) const override {
    out->push_back(bearing_);
    out->push_back(range_);
  }
  // The landmark keys()[1] from the pose (known = 0) only.
  std::optional<Variable> Predict(int known, const Variable& known_value) const override;

  // At zero range the bearing is undefined: the Jacobian is then set to zero (the factor gives
  // no information) rather than dividing by zero.
  ErrorVector Evaluate(const Pose2& pose, const Point2& landmark, JacobianAt<0>* H1,
                       JacobianAt<1>* H2) const;

 private:
  double bearing_;
  double range_;
};

}  // namespace slamd::core
