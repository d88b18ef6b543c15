// The kinds of variable a factor graph holds, written once. A Variable is one value of any of
// them; its VariableType is its position in this list (variable.h). To add a kind: its geometry
// file, its VariableTraits, and one entry here (appended, so that existing positions keep their
// meaning in memory; files store the kind's name, not its position).
#pragma once

#include <variant>

#include "core/variables/pose_traits.h"
#include "core/variables/vector_traits.h"

namespace slamd::core {

using Variable = std::variant<Pose2, Pose3, Point2, Point3, Cal3_S2, Cal3DS2, Cal3Bundler>;

}  // namespace slamd::core
