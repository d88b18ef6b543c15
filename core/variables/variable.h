// Generic operations on Variables: each is a std::visit over the list (variable_list.h) that
// calls the kind's VariableTraits, so nothing here changes when a kind is added.
//
// Poses move on the right: X ⊕ δ = X.Retract(δ) (see pose2.h and pose3.h for the tangent order,
// translation first). Points and calibrations move by plain addition.
#pragma once

#include <optional>
#include <span>
#include <string_view>
#include <utility>
#include <vector>

#include "core/base/status.h"
#include "core/variables/variable_list.h"

namespace slamd::core {

// A kind's position in the list. Only the list defines values; code names a kind by its C++
// type (kVariableType<Pose2>) or by its name (VariableTypeFromName).
enum class VariableType : unsigned char {};

inline constexpr int kNumVariableTypes = static_cast<int>(std::variant_size_v<Variable>);

namespace internal {
template <typename T, std::size_t... I>
constexpr int IndexInVariable(std::index_sequence<I...>) {
  int index = -1;
  ((std::is_same_v<T, std::variant_alternative_t<I, Variable>> ? (index = int(I)) : 0), ...);
  return index;
}
template <std::size_t... I>
constexpr int MaxDim(std::index_sequence<I...>) {
  int dim = 0;
  ((dim = std::max(dim, VariableTraits<std::variant_alternative_t<I, Variable>>::kDim)), ...);
  return dim;
}
using VariableIndices = std::make_index_sequence<std::variant_size_v<Variable>>;
}  // namespace internal

template <typename T>
inline constexpr VariableType kVariableType =
    static_cast<VariableType>(internal::IndexInVariable<T>(internal::VariableIndices{}));

// The largest tangent dimension of any kind (fixed-capacity buffers are sized by it).
inline constexpr int kMaxVariableDim = internal::MaxDim(internal::VariableIndices{});

inline VariableType TypeOf(const Variable& v) { return static_cast<VariableType>(v.index()); }
int TangentDim(VariableType type);
const char* VariableTypeName(VariableType type);
std::optional<VariableType> VariableTypeFromName(std::string_view name);
// What each tangent entry of the kind is (TangentDim(type) entries).
std::span<const EntryKind> EntryKinds(VariableType type);

// v ← v ⊕ delta, where delta points at TangentDim(TypeOf(v)) doubles.
void RetractInPlace(Variable* v, const double* delta);
// The tangent vector d with a ⊕ d = b (same type required; checked).
Eigen::VectorXd LocalCoordinates(const Variable& a, const Variable& b);
bool AllFinite(const Variable& v);

// The exact encoding (snapshots, map messages): EncodedSize(type) doubles appended to `out`.
int EncodedSize(VariableType type);
void EncodeVariable(const Variable& v, std::vector<double>* out);
// The inverse; InvalidArgument naming the kind on a wrong count or a value that is no valid one.
Result<Variable> DecodeVariable(VariableType type, std::span<const double> in);

// The layout in LCM messages (VariableTraits::EncodeMessage), appended to `out`.
void EncodeMessageValues(const Variable& v, std::vector<double>* out);

// A square matrix of at most kMaxVariableDim rows, stored inline (no heap).
using TangentMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor,
                                    kMaxVariableDim, kMaxVariableDim>;

// J such that Σ_E = J Σ_θ Jᵀ re-expresses a covariance in the tangent space at θ in the tangent
// space at the estimate E = θ ⊕ δ: ∂Local(E, θ⊕(δ+ε))/∂ε at 0 (VariableTraits::EstimateJacobian),
// d x d for the kind's d. It depends on δ only.
TangentMatrix EstimateTangentJacobian(VariableType type, const double* delta);

// How a top-down plot shows v: its world (x, y), or nothing for kinds that are not drawn.
std::optional<Vector2> PlanarPosition(const Variable& v);
// The world-frame (x, y) covariance of v from its tangent covariance (d x d; checked); only for
// kinds PlanarPosition draws.
Matrix2 PlanarCovariance(const Variable& v, const Eigen::MatrixXd& tangent_covariance);

}  // namespace slamd::core
