#include "core/factors/robust_kernel.h"

#include <cctype>
#include <cmath>

namespace slamd::core {

Result<RobustKernel> RobustKernel::Create(Kind kind, double parameter) {
  if (kind == Kind::kNone) return RobustKernel();
  if (!(parameter > 0.0) || !std::isfinite(parameter)) {
    return InvalidArgument(std::string("robust kernel ") + KindName(kind) + " parameter " +
                           std::to_string(parameter) + " must be positive and finite");
  }
  return RobustKernel(kind, parameter);
}

Result<RobustKernel::Kind> RobustKernel::ParseKind(std::string_view name) {
  std::string lower;
  for (char c : name) {
    if (c != '-' && c != '_') lower += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  }
  if (lower == "none") return Kind::kNone;
  if (lower == "huber") return Kind::kHuber;
  if (lower == "cauchy") return Kind::kCauchy;
  if (lower == "gemanmcclure") return Kind::kGemanMcClure;
  if (lower == "dcs") return Kind::kDcs;
  return InvalidArgument("unknown robust kernel '" + std::string(name) +
                         "' (expected none, huber, cauchy, geman-mcclure or dcs)");
}

const char* RobustKernel::KindName(Kind kind) {
  switch (kind) {
    case Kind::kNone: return "none";
    case Kind::kHuber: return "huber";
    case Kind::kCauchy: return "cauchy";
    case Kind::kGemanMcClure: return "geman-mcclure";
    case Kind::kDcs: return "dcs";
  }
  return "unknown";
}

double RobustKernel::Cost(double s) const {
  const double k = parameter_;
  switch (kind_) {
    case Kind::kNone: return s;
    case Kind::kHuber: return s <= k * k ? s : 2.0 * k * std::sqrt(s) - k * k;
    case Kind::kCauchy: return k * k * std::log1p(s / (k * k));
    case Kind::kGemanMcClure: return k * k * s / (k * k + s);
    case Kind::kDcs: return s <= k ? s : k * (3.0 * s - k) / (k + s);
  }
  return s;
}

double RobustKernel::Weight(double s) const {
  const double k = parameter_;
  switch (kind_) {
    case Kind::kNone: return 1.0;
    case Kind::kHuber: return s <= k * k ? 1.0 : k / std::sqrt(s);
    case Kind::kCauchy: return 1.0 / (1.0 + s / (k * k));
    case Kind::kGemanMcClure: {
      const double d = k * k + s;
      return k * k * k * k / (d * d);
    }
    case Kind::kDcs: {
      if (s <= k) return 1.0;
      const double d = k + s;
      return 4.0 * k * k / (d * d);
    }
  }
  return 1.0;
}

}  // namespace slamd::core
