#include "server/ingest/validation.h"

#include <span>

#include "server/ingest/field_checks.h"
#include "slamd/landmark_observation_t.hpp"
#include "slamd/loop_closure_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "slamd/query_t.hpp"
#include "slamd/remove_factor_t.hpp"

namespace slamd::server {
namespace {

using internal::CheckCount;
using internal::CheckCovariance;
using internal::CheckFinite;
using internal::CheckIndex;
using internal::CheckMagnitude;
using internal::CheckName;
using internal::CheckRobustKernel;
using internal::CheckUnitQuaternion;
using internal::CheckUtime;
using internal::Reject;

// Full field names of a measurement's value/covariance arrays, as string literals (no
// formatting unless something is rejected).
struct MeasurementFields {
  const char* num_values;
  const char* values;
  const char* quaternion;
  const char* num_covariance;
  const char* covariance;
};
#define SLAMD_MEASUREMENT_FIELDS(type)                                                \
  MeasurementFields {                                                                 \
    type ".num_values", type ".values", type ".values[3..6]", type ".num_covariance", \
        type ".covariance"                                                            \
  }

// How a kind lays out its values: count, covariance dimension, whether values[3..6] is a
// quaternion, and the phrase used in size messages ("dimension 2", "kind 1 (bearing-range 2D)").
struct Layout {
  int num_values;
  int cov_dim;
  bool has_quaternion;
  const char* what;
};
constexpr Layout kPose2Layout{3, 3, false, "dimension 2 (x, y, theta)"};
constexpr Layout kPose3Layout{7, 6, true, "dimension 3 (x, y, z, qw, qx, qy, qz)"};

// Counts, finiteness, quaternion and covariance of one measurement; `extra` (checked after the
// values are known finite and before the covariance) holds kind-specific rules.
template <typename Msg, typename Extra>
Verdict CheckMeasurement(const Msg& msg, const MeasurementFields& f, const Layout& layout,
                         const Limits& limits, std::optional<core::NoiseModel>* noise,
                         Extra extra) {
  SLAMD_RETURN_IF_REJECTED(
      CheckCount(f.num_values, msg.num_values, msg.values.size(), layout.num_values, layout.what));
  SLAMD_RETURN_IF_REJECTED(CheckCount(f.num_covariance, msg.num_covariance, msg.covariance.size(),
                                      layout.cov_dim * layout.cov_dim, layout.what));
  SLAMD_RETURN_IF_REJECTED(CheckFinite(f.values, msg.values));
  SLAMD_RETURN_IF_REJECTED(CheckFinite(f.covariance, msg.covariance));
  SLAMD_RETURN_IF_REJECTED(CheckMagnitude(f.values, msg.values, limits.max_abs_value));
  SLAMD_RETURN_IF_REJECTED(extra());
  if (layout.has_quaternion) {
    const auto& v = msg.values;
    SLAMD_RETURN_IF_REJECTED(CheckUnitQuaternion(f.quaternion, v[3], v[4], v[5], v[6],
                                                 limits.quaternion_norm_tolerance));
  }
  return CheckCovariance(f.covariance, msg.covariance, layout.cov_dim, limits, noise);
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

constexpr const char* kLandmarkKinds =
    "1 (bearing-range 2D), 2 (relative point 2D), 3 (relative point 3D)";
constexpr const char* kPriorKinds = "1 (pose 2D), 2 (pose 3D), 3 (position 2D), 4 (position 3D)";

}  // namespace

core::Status Limits::Validate() const {
  auto violates = [](const char* field, const std::string& value, const char* constraint) {
    return core::InvalidArgument(std::string("Limits::") + field + " = " + value + "; violates " +
                                 constraint);
  };
  if (max_robot_name_length < 1)
    return violates("max_robot_name_length", std::to_string(max_robot_name_length), ">= 1");
  if (max_client_name_length < 1)
    return violates("max_client_name_length", std::to_string(max_client_name_length), ">= 1");
  if (max_robust_kernel_name_length < 1) {
    return violates("max_robust_kernel_name_length", std::to_string(max_robust_kernel_name_length),
                    ">= 1");
  }
  if (max_query_keys < 1) return violates("max_query_keys", std::to_string(max_query_keys), ">= 1");
  if (max_joint_marginal_keys < 1) {
    return violates("max_joint_marginal_keys", std::to_string(max_joint_marginal_keys), ">= 1");
  }
  if (!(max_condition_number > 1.0 &&
        max_condition_number <= core::NoiseModel::kMaxConditionNumber)) {
    return violates("max_condition_number", std::to_string(max_condition_number), "in (1, 1e14]");
  }
  if (!(quaternion_norm_tolerance > 0.0 && quaternion_norm_tolerance <= 0.1)) {
    return violates("quaternion_norm_tolerance", std::to_string(quaternion_norm_tolerance),
                    "in (0, 0.1]");
  }
  if (!(symmetry_tolerance >= 0.0 && symmetry_tolerance <= 1e-3)) {
    return violates("symmetry_tolerance", std::to_string(symmetry_tolerance), "in [0, 1e-3]");
  }
  if (!(min_variance > 0.0)) {
    return violates("min_variance", std::to_string(min_variance), "> 0");
  }
  if (!(max_abs_value > 0.0)) {
    return violates("max_abs_value", std::to_string(max_abs_value), "> 0");
  }
  return core::Status::Ok();
}

Verdict Validate(const slamd::odometry_t& msg, const Limits& limits,
                 std::optional<core::NoiseModel>* noise) {
  SLAMD_RETURN_IF_REJECTED(CheckUtime("odometry_t.utime", msg.utime));
  SLAMD_RETURN_IF_REJECTED(CheckName("odometry_t.robot", msg.robot, limits.max_robot_name_length));
  SLAMD_RETURN_IF_REJECTED(CheckIndex("odometry_t.from_index", msg.from_index));
  SLAMD_RETURN_IF_REJECTED(CheckIndex("odometry_t.to_index", msg.to_index));
  const Layout* layout = nullptr;
  SLAMD_RETURN_IF_REJECTED(CheckDimension("odometry_t.dimension", msg.dimension, &layout));
  return CheckMeasurement(
      msg, SLAMD_MEASUREMENT_FIELDS("odometry_t"), *layout, limits, noise, [&]() -> Verdict {
        if (msg.from_index == msg.to_index) {
          return Reject(RejectReason::kSelfLoop, "odometry_t.to_index",
                        "equals from_index (" + std::to_string(msg.from_index) + ")");
        }
        return {};
      });
}

Verdict Validate(const slamd::landmark_observation_t& msg, const Limits& limits,
                 std::optional<core::NoiseModel>* noise) {
  using M = slamd::landmark_observation_t;
  SLAMD_RETURN_IF_REJECTED(CheckUtime("landmark_observation_t.utime", msg.utime));
  SLAMD_RETURN_IF_REJECTED(
      CheckName("landmark_observation_t.robot", msg.robot, limits.max_robot_name_length));
  SLAMD_RETURN_IF_REJECTED(CheckIndex("landmark_observation_t.pose_index", msg.pose_index));
  SLAMD_RETURN_IF_REJECTED(CheckIndex("landmark_observation_t.landmark_id", msg.landmark_id));
  SLAMD_RETURN_IF_REJECTED(CheckKindRange("landmark_observation_t.kind", msg.kind,
                                          M::KIND_BEARING_RANGE_2D, M::KIND_RELATIVE_POINT_3D,
                                          kLandmarkKinds));
  static constexpr Layout kLayouts[] = {
      {2, 2, false, "kind 1 (bearing, range)"},
      {2, 2, false, "kind 2 (x, y)"},
      {3, 3, false, "kind 3 (x, y, z)"},
  };
  return CheckMeasurement(
      msg, SLAMD_MEASUREMENT_FIELDS("landmark_observation_t"), kLayouts[msg.kind - 1], limits,
      noise, [&]() -> Verdict {
        if (msg.kind == M::KIND_BEARING_RANGE_2D && msg.values[1] < 0.0) {
          return Reject(RejectReason::kBadMeasurement, "landmark_observation_t.values[1]",
                        "range " + internal::FormatNumber(msg.values[1]) + " m is negative");
        }
        return {};
      });
}

Verdict Validate(const slamd::loop_closure_t& msg, const Limits& limits,
                 std::optional<core::NoiseModel>* noise, core::RobustKernel* robust) {
  SLAMD_RETURN_IF_REJECTED(CheckUtime("loop_closure_t.utime", msg.utime));
  SLAMD_RETURN_IF_REJECTED(
      CheckName("loop_closure_t.robot_a", msg.robot_a, limits.max_robot_name_length));
  SLAMD_RETURN_IF_REJECTED(CheckIndex("loop_closure_t.pose_a", msg.pose_a));
  SLAMD_RETURN_IF_REJECTED(
      CheckName("loop_closure_t.robot_b", msg.robot_b, limits.max_robot_name_length));
  SLAMD_RETURN_IF_REJECTED(CheckIndex("loop_closure_t.pose_b", msg.pose_b));
  const Layout* layout = nullptr;
  SLAMD_RETURN_IF_REJECTED(CheckDimension("loop_closure_t.dimension", msg.dimension, &layout));
  SLAMD_RETURN_IF_REJECTED(CheckMeasurement(
      msg, SLAMD_MEASUREMENT_FIELDS("loop_closure_t"), *layout, limits, noise, [&]() -> Verdict {
        const double parameter = msg.robust_parameter;
        SLAMD_RETURN_IF_REJECTED(
            CheckFinite("loop_closure_t.robust_parameter", std::span(&parameter, 1)));
        if (msg.robot_a == msg.robot_b && msg.pose_a == msg.pose_b) {
          return Reject(RejectReason::kSelfLoop, "loop_closure_t.pose_b",
                        "(robot_b, pose_b) equals (robot_a, pose_a) = (" + msg.robot_a + ", " +
                            std::to_string(msg.pose_a) + ")");
        }
        return {};
      }));
  return CheckRobustKernel("loop_closure_t.robust_kernel", "loop_closure_t.robust_parameter",
                           msg.robust_kernel, msg.robust_parameter, limits, robust);
}

Verdict Validate(const slamd::prior_t& msg, const Limits& limits,
                 std::optional<core::NoiseModel>* noise) {
  using M = slamd::prior_t;
  SLAMD_RETURN_IF_REJECTED(CheckUtime("prior_t.utime", msg.utime));
  SLAMD_RETURN_IF_REJECTED(CheckName("prior_t.robot", msg.robot, limits.max_robot_name_length));
  SLAMD_RETURN_IF_REJECTED(CheckIndex("prior_t.pose_index", msg.pose_index));
  SLAMD_RETURN_IF_REJECTED(
      CheckKindRange("prior_t.kind", msg.kind, M::KIND_POSE_2D, M::KIND_POSITION_3D, kPriorKinds));
  static constexpr Layout kLayouts[] = {
      {3, 3, false, "kind 1 (x, y, theta)"},
      {7, 6, true, "kind 2 (x, y, z, qw, qx, qy, qz)"},
      {2, 2, false, "kind 3 (x, y)"},
      {3, 3, false, "kind 4 (x, y, z)"},
  };
  return CheckMeasurement(msg, SLAMD_MEASUREMENT_FIELDS("prior_t"), kLayouts[msg.kind - 1], limits,
                          noise, []() -> Verdict { return {}; });
}

Verdict Validate(const slamd::remove_factor_t& msg, const Limits& limits) {
  using M = slamd::remove_factor_t;
  SLAMD_RETURN_IF_REJECTED(CheckUtime("remove_factor_t.utime", msg.utime));
  SLAMD_RETURN_IF_REJECTED(
      CheckKindRange("remove_factor_t.target", msg.target, M::TARGET_ODOMETRY, M::TARGET_PRIOR,
                     "1 (odometry), 2 (landmark observation), 3 (loop closure), 4 (prior)"));
  SLAMD_RETURN_IF_REJECTED(
      CheckName("remove_factor_t.robot_a", msg.robot_a, limits.max_robot_name_length));
  SLAMD_RETURN_IF_REJECTED(CheckIndex("remove_factor_t.index_a", msg.index_a));
  switch (msg.target) {
    case M::TARGET_ODOMETRY:
      SLAMD_RETURN_IF_REJECTED(MustBeEmpty("remove_factor_t.robot_b", msg.robot_b, "odometry"));
      SLAMD_RETURN_IF_REJECTED(CheckIndex("remove_factor_t.index_b", msg.index_b));
      SLAMD_RETURN_IF_REJECTED(MustBeZero("remove_factor_t.kind", msg.kind, "odometry"));
      if (msg.index_a == msg.index_b) {
        return Reject(RejectReason::kSelfLoop, "remove_factor_t.index_b",
                      "equals index_a (" + std::to_string(msg.index_a) + ")");
      }
      return {};
    case M::TARGET_LANDMARK_OBSERVATION:
      SLAMD_RETURN_IF_REJECTED(
          MustBeEmpty("remove_factor_t.robot_b", msg.robot_b, "landmark observations"));
      SLAMD_RETURN_IF_REJECTED(CheckIndex("remove_factor_t.index_b", msg.index_b));
      return CheckKindRange("remove_factor_t.kind", msg.kind, 1, 3, kLandmarkKinds);
    case M::TARGET_LOOP_CLOSURE:
      SLAMD_RETURN_IF_REJECTED(
          CheckName("remove_factor_t.robot_b", msg.robot_b, limits.max_robot_name_length));
      SLAMD_RETURN_IF_REJECTED(CheckIndex("remove_factor_t.index_b", msg.index_b));
      SLAMD_RETURN_IF_REJECTED(MustBeZero("remove_factor_t.kind", msg.kind, "loop closures"));
      if (msg.robot_a == msg.robot_b && msg.index_a == msg.index_b) {
        return Reject(RejectReason::kSelfLoop, "remove_factor_t.index_b",
                      "(robot_b, index_b) equals (robot_a, index_a)");
      }
      return {};
    default:  // TARGET_PRIOR
      SLAMD_RETURN_IF_REJECTED(MustBeEmpty("remove_factor_t.robot_b", msg.robot_b, "priors"));
      SLAMD_RETURN_IF_REJECTED(MustBeZero("remove_factor_t.index_b", msg.index_b, "priors"));
      return CheckKindRange("remove_factor_t.kind", msg.kind, 1, 4, kPriorKinds);
  }
}

Verdict Validate(const slamd::query_t& msg, const Limits& limits) {
  SLAMD_RETURN_IF_REJECTED(CheckUtime("query_t.utime", msg.utime));
  SLAMD_RETURN_IF_REJECTED(
      CheckName("query_t.client", msg.client, limits.max_client_name_length, true));
  SLAMD_RETURN_IF_REJECTED(CheckCount("query_t.num_keys", msg.num_keys, msg.keys.size(), -1, ""));
  if (msg.num_keys > limits.max_query_keys) {
    return Reject(RejectReason::kTooManyElements, "query_t.keys",
                  std::to_string(msg.num_keys) + " keys, more than the limit of " +
                      std::to_string(limits.max_query_keys));
  }
  for (size_t i = 0; i < msg.keys.size(); ++i) {
    const slamd::key_t& key = msg.keys[i];
    const std::string field = "query_t.keys[" + std::to_string(i) + "]";
    SLAMD_RETURN_IF_REJECTED(CheckName(field + ".robot", key.robot, limits.max_robot_name_length));
    SLAMD_RETURN_IF_REJECTED(CheckKindRange((field + ".kind").c_str(), key.kind,
                                            slamd::key_t::KIND_POSE, slamd::key_t::KIND_LANDMARK,
                                            "1 (pose), 2 (landmark)"));
    SLAMD_RETURN_IF_REJECTED(CheckIndex(field + ".index", key.index));
  }
  if (msg.want_joint_marginal && msg.num_keys > limits.max_joint_marginal_keys) {
    return Reject(RejectReason::kTooManyElements, "query_t.keys",
                  std::to_string(msg.num_keys) +
                      " keys for a joint marginal, more than the limit of " +
                      std::to_string(limits.max_joint_marginal_keys));
  }
  if (msg.map_robot != "*") {
    SLAMD_RETURN_IF_REJECTED(
        CheckName("query_t.map_robot", msg.map_robot, limits.max_robot_name_length, true));
  }
  return {};
}

}  // namespace slamd::server
