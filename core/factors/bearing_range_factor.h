// BearingRangeFactor: a landmark (Point2) seen from a Pose2 at a bearing (radians,
// counter-clockwise from the pose's x axis) and a range (metres), e.g. from a laser or a camera
// with depth. Error: e = (wrap(bearing(x) − measured_bearing), range(x) − measured_range).
#pragma once

#include "core/factors/factor.h"

namespace slamd::core {

class BearingRangeFactor : public BinaryFactor<BearingRangeFactor, 2, Pose2, Point2> {
 public:
  BearingRangeFactor(Key pose, Key landmark, double bearing, double range, NoiseModel noise,
                     RobustKernel robust = {})
      : BinaryFactor(pose, landmark, std::move(noise), robust), bearing_(bearing), range_(range) {}

  const char* Name() const override { return "BearingRange2"; }
  double bearing() const { return bearing_; }
  double range() const { return range_; }

  // At zero range the bearing is undefined: the Jacobian is then set to zero (the factor gives
  // no information) rather than dividing by zero.
  ErrorVector Evaluate(const Pose2& pose, const Point2& landmark, Jacobian1* H1, Jacobian2* H2) const;

 private:
  double bearing_;
  double range_;
};

}  // namespace slamd::core
