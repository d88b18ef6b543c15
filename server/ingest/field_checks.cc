#include "server/ingest/field_checks.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <sstream>

#include "core/base/key.h"

namespace slamd::server::internal {
namespace {

// Fixed capacity (at most 6x6): the eigen-decomposition below allocates nothing.
using SmallMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor,
                                  core::kMaxResidualDim, core::kMaxResidualDim>;

bool NameChar(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
         c == '.' || c == '-';
}

std::string Num(double v) { return FormatNumber(v); }

}  // namespace

std::string FormatNumber(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

Verdict Reject(RejectReason reason, std::string_view field, std::string_view detail) {
  Verdict v;
  v.reason = reason;
  v.message.reserve(field.size() + detail.size() + 2);
  v.message.append(field).append(": ").append(detail);
  return v;
}

Verdict CheckUtime(std::string_view field, std::int64_t utime) {
  if (utime < 0) {
    return Reject(RejectReason::kBadTimestamp, field,
                  std::to_string(utime) + " is negative (µs since the Unix epoch)");
  }
  return {};
}

Verdict CheckName(std::string_view field, const std::string& name, int max_length,
                  bool allow_empty) {
  if (name.empty()) {
    if (allow_empty) return {};
    return Reject(RejectReason::kBadName, field, "empty");
  }
  if (name.size() > static_cast<size_t>(max_length)) {
    return Reject(RejectReason::kStringTooLong, field,
                  std::to_string(name.size()) + " chars, more than the limit of " +
                      std::to_string(max_length));
  }
  for (size_t i = 0; i < name.size(); ++i) {
    if (!NameChar(name[i])) {
      std::ostringstream out;
      out << "character " << i << " (byte 0x" << std::hex
          << static_cast<int>(static_cast<unsigned char>(name[i]))
          << ") is not one of [A-Za-z0-9_.-]";
      return Reject(RejectReason::kBadName, field, out.str());
    }
  }
  return {};
}

Verdict CheckIndex(std::string_view field, std::int64_t index) {
  if (index < 0 || static_cast<std::uint64_t>(index) > core::kMaxKeyIndex) {
    return Reject(RejectReason::kIndexOutOfRange, field,
                  std::to_string(index) + " is outside 0 .. 2^48-1");
  }
  return {};
}

Verdict CheckCount(std::string_view count_field, std::int32_t count, size_t actual, int expected,
                   std::string_view what_needs_it) {
  if (count < 0 || static_cast<size_t>(count) != actual) {
    return Reject(
        RejectReason::kSizeMismatch, count_field,
        std::to_string(count) + " but the array holds " + std::to_string(actual) + " elements");
  }
  if (expected >= 0 && count != expected) {
    return Reject(RejectReason::kSizeMismatch, count_field,
                  std::to_string(count) + " elements, but " + std::string(what_needs_it) +
                      " needs " + std::to_string(expected));
  }
  return {};
}

Verdict CheckFinite(std::string_view field, std::span<const double> values) {
  for (size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) {
      return Reject(RejectReason::kNotFinite, std::string(field) + "[" + std::to_string(i) + "]",
                    "not finite (" + Num(values[i]) + ")");
    }
  }
  return {};
}

Verdict CheckMagnitude(std::string_view field, std::span<const double> values, double max_abs) {
  for (size_t i = 0; i < values.size(); ++i) {
    if (std::abs(values[i]) > max_abs) {
      return Reject(RejectReason::kBadMeasurement,
                    std::string(field) + "[" + std::to_string(i) + "]",
                    Num(values[i]) + " is beyond " + Num(max_abs) + " (Limits::max_abs_value)");
    }
  }
  return {};
}

Verdict CheckUnitQuaternion(std::string_view field, double w, double x, double y, double z,
                            double tolerance) {
  const double norm = std::sqrt(w * w + x * x + y * y + z * z);
  if (!(std::abs(norm - 1.0) <= tolerance)) {
    return Reject(
        RejectReason::kQuaternionNotUnit, field,
        "quaternion (w, x, y, z) has norm " + Num(norm) + ", not 1 within " + Num(tolerance));
  }
  return {};
}

Verdict CheckCovariance(std::string_view field, std::span<const double> row_major, int dim,
                        const Limits& limits, std::optional<core::NoiseModel>* noise) {
  SLAMD_CHECK(dim >= 1 && dim <= core::kMaxResidualDim && row_major.size() == size_t(dim * dim))
      << "CheckCovariance called before the size check";
  const Eigen::Map<const SmallMatrix> C(row_major.data(), dim, dim);

  // 1. Symmetric, relative to the largest entry (covariances in m² can be tiny).
  const double scale = C.cwiseAbs().maxCoeff();
  const double asymmetry = (C - C.transpose()).cwiseAbs().maxCoeff();
  if (asymmetry > limits.symmetry_tolerance * scale) {
    return Reject(RejectReason::kCovarianceNotSymmetric, field,
                  "not symmetric (largest |C - Cᵀ| entry " + Num(asymmetry) +
                      ", largest |C| entry " + Num(scale) + ")");
  }
  const SmallMatrix S = 0.5 * (C + C.transpose());

  // 2. Positive definite and well conditioned, from the eigenvalues.
  Eigen::SelfAdjointEigenSolver<SmallMatrix> eig(S, Eigen::EigenvaluesOnly);
  const double lo = eig.eigenvalues().minCoeff();
  const double hi = eig.eigenvalues().maxCoeff();
  if (!(lo > 0.0)) {
    return Reject(RejectReason::kCovarianceNotPositiveDefinite, field,
                  "not positive definite (smallest eigenvalue " + Num(lo) + ")");
  }
  if (hi / lo > limits.max_condition_number) {
    return Reject(RejectReason::kCovarianceIllConditioned, field,
                  "ill-conditioned (condition number " + Num(hi / lo) + " > " +
                      Num(limits.max_condition_number) + "; eigenvalues " + Num(lo) + " .. " +
                      Num(hi) + ")");
  }
  if (lo < limits.min_variance) {
    return Reject(RejectReason::kCovarianceIllConditioned, field,
                  "smallest eigenvalue " + Num(lo) + " below " + Num(limits.min_variance) +
                      " (Limits::min_variance: a standard deviation under 1e-8 m or rad)");
  }

  // 3. The noise model, built (and checked once more) by core.
  if (noise != nullptr) {
    core::Result<core::NoiseModel> model = core::NoiseModel::FromCovariance(Eigen::MatrixXd(S));
    if (!model.ok()) {
      return Reject(RejectReason::kCovarianceNotPositiveDefinite, field, model.status().message());
    }
    noise->emplace(std::move(model).value());
  }
  return {};
}

Verdict CheckRobustKernel(std::string_view name_field, std::string_view parameter_field,
                          const std::string& name, double parameter, const Limits& limits,
                          core::RobustKernel* robust) {
  if (name.size() > static_cast<size_t>(limits.max_robust_kernel_name_length)) {
    return Reject(RejectReason::kStringTooLong, name_field,
                  std::to_string(name.size()) + " chars, more than the limit of " +
                      std::to_string(limits.max_robust_kernel_name_length));
  }
  core::RobustKernel kernel;
  if (!name.empty()) {
    core::Result<core::RobustKernel::Kind> kind = core::RobustKernel::ParseKind(name);
    if (!kind.ok())
      return Reject(RejectReason::kUnknownRobustKernel, name_field, kind.status().message());
    if (*kind != core::RobustKernel::Kind::kNone) {
      core::Result<core::RobustKernel> created = core::RobustKernel::Create(*kind, parameter);
      if (!created.ok()) {
        return Reject(RejectReason::kBadRobustParameter, parameter_field,
                      Num(parameter) + " is not valid for " + core::RobustKernel::KindName(*kind) +
                          ": " + created.status().message());
      }
      kernel = *created;
    }
  }
  if (robust != nullptr) *robust = kernel;
  return {};
}

Verdict CheckDimension(const char* field, std::int8_t dimension, const Layout** layout) {
  if (dimension == 2) {
    *layout = &kPose2Layout;
  } else if (dimension == 3) {
    *layout = &kPose3Layout;
  } else {
    return Reject(RejectReason::kBadKind, field, std::to_string(dimension) + " is neither 2 nor 3");
  }
  return {};
}

Verdict MustBeEmpty(const char* field, const std::string& value, const char* target) {
  if (!value.empty()) {
    std::string detail =
        "'";  // appended step by step: GCC 12's -Wrestrict misfires on a + chain here
    detail.append(value, 0, 64).append("' must be empty for ").append(target);
    return Reject(RejectReason::kUnusedFieldSet, field, detail);
  }
  return {};
}

Verdict MustBeZero(const char* field, std::int64_t value, const char* target) {
  if (value != 0) {
    return Reject(RejectReason::kUnusedFieldSet, field,
                  std::to_string(value) + " must be 0 for " + target);
  }
  return {};
}

Verdict CheckKindRange(const char* field, std::int8_t kind, int lo, int hi, const char* names) {
  if (kind < lo || kind > hi) {
    return Reject(RejectReason::kBadKind, field, std::to_string(kind) + " is not one of " + names);
  }
  return {};
}

}  // namespace slamd::server::internal
