#include "core/factors/between_factor.h"

namespace slamd::core {

template class TypedFactor<BetweenFactor<Pose2>, Pose2::kDim, Pose2, Pose2>;
template class TypedFactor<BetweenFactor<Pose3>, Pose3::kDim, Pose3, Pose3>;
template class BetweenFactor<Pose2>;
template class BetweenFactor<Pose3>;

}  // namespace slamd::core
