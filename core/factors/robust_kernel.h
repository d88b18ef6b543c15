// RobustKernel: an optional M-estimator wrapped around a factor's whitened residual, to limit the
// pull of outliers (wrong loop closures). With s = |R·e|² (the squared whitened residual):
//
//   kind            cost ρ(s)                         weight w = ρ'(s)
//   kNone           s                                 1
//   kHuber(k)       s            if s ≤ k²            1
//                   2k√s − k²    otherwise            k/√s
//   kCauchy(k)      k² ln(1 + s/k²)                   1 / (1 + s/k²)
//   kGemanMcClure(k) k² s / (k² + s)                  k⁴ / (k² + s)²
//   kDcs(Φ)         s            if s ≤ Φ             1
//   (Agarwal 2013)  Φ(3s − Φ)/(Φ + s) otherwise       4Φ² / (Φ + s)²
//
// Every ρ is scaled so that ρ(s) ≈ s for small s: a robust cost is in the same units as chi2 (GTSAM's
// loss functions are half of these). Solvers use iteratively reweighted least squares: at
// linearisation the whitened residual and Jacobian are scaled by √w.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "core/base/status.h"

namespace slamd::core {

class RobustKernel {
 public:
  enum class Kind { kNone, kHuber, kCauchy, kGemanMcClure, kDcs };

  RobustKernel() = default;  // kNone
  // `parameter` is k (Huber, Cauchy, Geman-McClure: a whitened-residual norm, e.g. 1.345) or Φ
  // (DCS: a squared whitened norm); it must be positive and finite.
  static Result<RobustKernel> Create(Kind kind, double parameter);
  // Parses "none", "huber", "cauchy", "gemanmcclure" / "geman-mcclure", "dcs".
  static Result<Kind> ParseKind(std::string_view name);
  static const char* KindName(Kind kind);

  Kind kind() const { return kind_; }
  double parameter() const { return parameter_; }
  bool is_none() const { return kind_ == Kind::kNone; }

  double Cost(double squared_norm) const;    // ρ(s)
  double Weight(double squared_norm) const;  // ρ'(s)

 private:
  RobustKernel(Kind kind, double parameter) : kind_(kind), parameter_(parameter) {}
  Kind kind_ = Kind::kNone;
  double parameter_ = 0.0;
};

}  // namespace slamd::core
