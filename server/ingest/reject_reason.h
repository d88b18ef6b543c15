// RejectReason: why an inbound message was refused. The values are the wire codes of
// reject_t.REASON_* (static_asserts in reject_reason.cc keep the two in step).
//   1..31  stateless: found by Validate() from the message alone (the message specs,
//          server/messages/<type>.h)
//   32..   stateful: found by the server against its graph, queue or history
#pragma once

#include <cstdint>

namespace slamd::server {

enum class RejectReason : std::int32_t {
  kNone = 0,  // accepted
  kDecodeError = 1,
  kNotFinite = 2,
  kBadTimestamp = 3,
  kBadName = 4,
  kStringTooLong = 5,
  kIndexOutOfRange = 6,
  kBadKind = 7,
  kSizeMismatch = 8,
  kTooManyElements = 9,
  kSelfLoop = 10,
  kCovarianceNotSymmetric = 11,
  kCovarianceNotPositiveDefinite = 12,
  kCovarianceIllConditioned = 13,
  kQuaternionNotUnit = 14,
  kUnknownRobustKernel = 15,
  kBadRobustParameter = 16,
  kBadMeasurement = 17,
  kUnusedFieldSet = 18,
  kUnknownRobot = 32,
  kUnknownPose = 33,
  kUnknownFactor = 34,
  kDuplicate = 35,
  kOutOfOrderTimeout = 36,
  kQueueFull = 37,
  kWouldDisconnect = 38,
  kStorageError = 39,
  kReplicationUnavailable = 40,
  kShardUnavailable = 41,
};

// One past the largest code: the length of status_t.rejects_by_reason.
inline constexpr int kNumRejectReasonCodes = 42;

// "covariance_not_positive_definite", ... ("none" for kNone, "unknown" for other values).
const char* RejectReasonName(RejectReason reason);

}  // namespace slamd::server
