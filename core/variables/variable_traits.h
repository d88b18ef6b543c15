// VariableTraits<T>: everything the optimiser, the server and the plots need to know about one
// kind of variable, in one place. Each kind specialises it in its own <kind>_traits.h; the list of
// kinds is variable_list.h; generic code reaches the traits through variable.h (std::visit over
// the list), never through a switch over kinds.
//
// A specialisation provides:
//   kName              the type name in messages, files and snapshots ("Pose2")
//   kDim               tangent dimension (≤ kMaxVariableDim, see variable.h)
//   kEntryKinds        what each tangent entry is, for the relinearisation thresholds
//   Retract(x, d)      x ⊕ d for d = kDim doubles (the optimiser's chart)
//   Local(a, b)        the tangent vector d with a ⊕ d = b
//   AllFinite(x)
//   kEncodedSize, Encode(x, out), Decode(in)
//                      the exact encoding in snapshots and map messages: Decode(Encode(x)) == x
//                      bit for bit; Decode returns nothing for values that are no valid x
//   kMessageSize, EncodeMessage(x, out)
//                      the layout in LCM messages (msgs/lcm: Pose2 x, y, θ; Pose3 x, y, z, qw,
//                      qx, qy, qz with qw >= 0; points and calibrations their parameters)
//   EstimateJacobian(d)
//                      ∂Local(θ⊕d, θ⊕(d+ε))/∂ε at ε = 0: maps a covariance in the tangent space
//                      at θ to the tangent space at the estimate θ⊕d (marginals)
//   kPlotted, PlanarPosition(x), PlanarCovariance(x, cov)
//                      how a top-down plot shows it: its (x, y) in the world and the world-frame
//                      (x, y) covariance from a tangent covariance (kPlotted = false: not drawn)
#pragma once

namespace slamd::core {

// What one tangent entry of a variable moves: relinearisation compares |δ| per kind against its
// own threshold (Isam2Params::Relinearization).
enum class EntryKind : unsigned char { kTranslation, kRotation, kCalibration, kOther };
inline constexpr int kNumEntryKinds = 4;

template <typename T>
struct VariableTraits;

}  // namespace slamd::core
