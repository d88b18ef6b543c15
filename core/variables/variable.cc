#include "core/variables/variable.h"

#include <array>

#include "core/base/check.h"

namespace slamd::core {
namespace {

// Per-kind facts in list order, built from the traits.
struct KindInfo {
  const char* name;
  int dim;
  int encoded_size;
  std::span<const EntryKind> entry_kinds;
};

template <std::size_t... I>
constexpr std::array<KindInfo, sizeof...(I)> MakeKinds(std::index_sequence<I...>) {
  return {KindInfo{VariableTraits<std::variant_alternative_t<I, Variable>>::kName,
                   VariableTraits<std::variant_alternative_t<I, Variable>>::kDim,
                   VariableTraits<std::variant_alternative_t<I, Variable>>::kEncodedSize,
                   VariableTraits<std::variant_alternative_t<I, Variable>>::kEntryKinds}...};
}
constexpr std::array<KindInfo, kNumVariableTypes> kKinds = MakeKinds(internal::VariableIndices{});

template <typename T>
using TraitsOf = VariableTraits<std::decay_t<T>>;

// Calls f(std::type_identity<T>{}) for the kind T at position `type` of the list.
template <typename F>
void VisitType(VariableType type, F&& f) {
  [&]<std::size_t... I>(std::index_sequence<I...>) {
    (void)((static_cast<int>(type) == static_cast<int>(I)
                ? (f(std::type_identity<std::variant_alternative_t<I, Variable>>{}), true)
                : false) ||
           ...);
  }
  (internal::VariableIndices{});
}

// Appends v's exact encoding, or its message layout.
template <bool kMessage>
void Append(const Variable& v, std::vector<double>* out) {
  std::visit(
      [out](const auto& x) {
        using Traits = TraitsOf<decltype(x)>;
        const std::size_t at = out->size();
        if constexpr (kMessage) {
          out->resize(at + Traits::kMessageSize);
          Traits::EncodeMessage(x, out->data() + at);
        } else {
          out->resize(at + Traits::kEncodedSize);
          Traits::Encode(x, out->data() + at);
        }
      },
      v);
}

}  // namespace

int TangentDim(VariableType type) { return kKinds[static_cast<int>(type)].dim; }

const char* VariableTypeName(VariableType type) {
  const int i = static_cast<int>(type);
  return i < kNumVariableTypes ? kKinds[i].name : "unknown";
}

std::optional<VariableType> VariableTypeFromName(std::string_view name) {
  for (int i = 0; i < kNumVariableTypes; ++i) {
    if (name == kKinds[i].name) return static_cast<VariableType>(i);
  }
  return std::nullopt;
}

std::span<const EntryKind> EntryKinds(VariableType type) {
  return kKinds[static_cast<int>(type)].entry_kinds;
}

void RetractInPlace(Variable* v, const double* delta) {
  std::visit([delta](auto& x) { x = TraitsOf<decltype(x)>::Retract(x, delta); }, *v);
}

Eigen::VectorXd LocalCoordinates(const Variable& a, const Variable& b) {
  SLAMD_CHECK(a.index() == b.index())
      << "LocalCoordinates between a " << VariableTypeName(TypeOf(a)) << " and a "
      << VariableTypeName(TypeOf(b));
  return std::visit(
      [&b](const auto& x) -> Eigen::VectorXd {
        using T = std::decay_t<decltype(x)>;
        return VariableTraits<T>::Local(x, std::get<T>(b));
      },
      a);
}

bool AllFinite(const Variable& v) {
  return std::visit([](const auto& x) { return TraitsOf<decltype(x)>::AllFinite(x); }, v);
}

int EncodedSize(VariableType type) { return kKinds[static_cast<int>(type)].encoded_size; }

void EncodeVariable(const Variable& v, std::vector<double>* out) { Append<false>(v, out); }

void EncodeMessageValues(const Variable& v, std::vector<double>* out) { Append<true>(v, out); }

Result<Variable> DecodeVariable(VariableType type, std::span<const double> in) {
  const int i = static_cast<int>(type);
  if (i >= kNumVariableTypes) return InvalidArgument("unknown variable type " + std::to_string(i));
  if (static_cast<int>(in.size()) != kKinds[i].encoded_size) {
    return InvalidArgument(std::string("a ") + kKinds[i].name + " is " +
                           std::to_string(kKinds[i].encoded_size) + " numbers, not " +
                           std::to_string(in.size()));
  }
  std::optional<Variable> v;
  VisitType(type, [&](auto kind) {
    using T = typename decltype(kind)::type;
    if (std::optional<T> x = VariableTraits<T>::Decode(in.data())) v = Variable(*x);
  });
  if (!v || !AllFinite(*v)) {
    return InvalidArgument(std::string("the numbers are no valid ") + kKinds[i].name);
  }
  return *v;
}

TangentMatrix EstimateTangentJacobian(VariableType type, const double* delta) {
  TangentMatrix J;
  VisitType(type, [&](auto kind) {
    J = VariableTraits<typename decltype(kind)::type>::EstimateJacobian(delta);
  });
  return J;
}

std::optional<Vector2> PlanarPosition(const Variable& v) {
  return std::visit(
      [](const auto& x) -> std::optional<Vector2> {
        using Traits = TraitsOf<decltype(x)>;
        if constexpr (Traits::kPlotted) {
          return Traits::PlanarPosition(x);
        } else {
          return std::nullopt;
        }
      },
      v);
}

Matrix2 PlanarCovariance(const Variable& v, const Eigen::MatrixXd& tangent_covariance) {
  const int dim = TangentDim(TypeOf(v));
  SLAMD_CHECK(tangent_covariance.rows() == dim && tangent_covariance.cols() == dim)
      << "covariance is " << tangent_covariance.rows() << "x" << tangent_covariance.cols()
      << ", expected " << dim;
  return std::visit(
      [&](const auto& x) -> Matrix2 {
        using Traits = TraitsOf<decltype(x)>;
        SLAMD_CHECK(Traits::kPlotted) << Traits::kName << " is not drawn in a plot";
        return Traits::PlanarCovariance(x, tangent_covariance);
      },
      v);
}

}  // namespace slamd::core
