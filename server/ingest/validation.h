// Stateless validation of inbound LCM messages (each type's Validate is in its spec,
// server/messages/<type>.h): what can be decided from the message alone
// (the server's state — unknown robots, duplicates, ordering — is checked by the estimator).
//
// Checks, in this order, stopping at the first failure:
//   utime >= 0; names (1..limit chars of [A-Za-z0-9_.-]); pose indices and landmark ids in
//   0 .. 2^48-1 (core::kMaxKeyIndex); dimension / kind / target fields known; every count field
//   equal to its vector's length and to what the kind needs; array sizes within limits; every
//   double finite; kind-specific rules (no self loops, unit quaternions, range >= 0, fields a
//   kind does not use left empty); covariance symmetric (relative asymmetry <= 1e-6; it is then
//   symmetrised), positive definite and with condition number <= limits.max_condition_number
//   (the noise model itself is built by core::NoiseModel::FromCovariance); robust kernel name
//   known (core::RobustKernel::ParseKind) with a valid parameter.
//
// A rejection carries a RejectReason (the reject_t wire code) and a message that names the field:
//   "odometry_t.covariance: not positive definite (smallest eigenvalue -0.2)"
//
// Thread-safe (no state). Cost: a few µs per message (one eigen-decomposition of at most 6x6 and
// one Cholesky); allocation only for the messages of rejections and the noise model.
#pragma once

#include <optional>
#include <string>

#include "core/factors/noise_model.h"
#include "core/factors/robust_kernel.h"
#include "server/ingest/reject_reason.h"

namespace slamd::server {

struct Limits {
  // Robot names (and query_t.map_robot), bytes; >= 1.
  int max_robot_name_length = 64;
  // query_t.client, bytes; >= 1.
  int max_client_name_length = 64;
  // loop_closure_t.robust_kernel, bytes; >= 1.
  int max_robust_kernel_name_length = 32;
  // query_t.keys: 100 keys with 3D marginals keep a reply under ~60 kB; >= 1.
  int max_query_keys = 100;
  // Keys in a joint-marginal query (the reply holds a (6n)^2 matrix: 10 keys = 29 kB); >= 1.
  int max_joint_marginal_keys = 10;
  // Largest accepted ratio of a covariance's largest to smallest eigenvalue; > 1 and at most
  // core::NoiseModel::kMaxConditionNumber (1e14).
  double max_condition_number = 1e12;
  // Accepted | |q| - 1 | for quaternions (they are normalised on conversion); in (0, 0.1].
  double quaternion_norm_tolerance = 1e-4;
  // Accepted max|C - Cᵀ| / max|C| for covariances; in [0, 1e-3].
  double symmetry_tolerance = 1e-6;
  // Largest accepted |value| of a measurement (metres, radians): beyond it a value is not a
  // physical measurement but garbage that would wreck the solver's conditioning; > 0.
  double max_abs_value = 1e7;
  // Smallest accepted covariance eigenvalue (a standard deviation of 1e-8 m or rad): beyond it
  // the information (1e16) swamps the double precision of the solver; > 0.
  double min_variance = 1e-16;

  core::Status Validate() const;
};

// The outcome of validating one message.
struct Verdict {
  RejectReason reason = RejectReason::kNone;
  // Empty when accepted; otherwise "<type>.<field>: <what is wrong>".
  std::string message;

  bool ok() const { return reason == RejectReason::kNone; }
};

}  // namespace slamd::server
