// Initial guesses from measurements: where a factor puts one of its variables given the other.
// Shared by the dataset stream (new poses and landmarks), the batch solver's initial guesses and
// the server, so the rule lives in one place.
#pragma once

#include <optional>

#include "core/factors/factor.h"

namespace slamd::core {

// The value `factor` predicts for its variable other than keys()[known], given that variable's
// value `known_value`; nothing when the factor cannot predict it:
//   BetweenFactor<Pose2|Pose3>:  keys()[1] = x₀ ∘ z (known = 0), keys()[0] = x₁ ∘ z⁻¹ (known = 1);
//   RelativePointFactor, BearingRangeFactor: the landmark keys()[1] from the pose (known = 0) only.
// Any other factor predicts nothing. `known_value` must have the factor's type for that key
// (checked).
std::optional<Variable> PredictFromFactor(const Factor& factor, int known, const Variable& known_value);

}  // namespace slamd::core
