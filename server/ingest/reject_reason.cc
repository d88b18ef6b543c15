#include "server/ingest/reject_reason.h"

#include "slamd/reject_t.hpp"

namespace slamd::server {

#define SLAMD_SAME_CODE(kEnum, WIRE) \
  static_assert(static_cast<std::int32_t>(RejectReason::kEnum) == ::slamd::reject_t::WIRE, #WIRE)
SLAMD_SAME_CODE(kDecodeError, REASON_DECODE_ERROR);
SLAMD_SAME_CODE(kNotFinite, REASON_NOT_FINITE);
SLAMD_SAME_CODE(kBadTimestamp, REASON_BAD_TIMESTAMP);
SLAMD_SAME_CODE(kBadName, REASON_BAD_NAME);
SLAMD_SAME_CODE(kStringTooLong, REASON_STRING_TOO_LONG);
SLAMD_SAME_CODE(kIndexOutOfRange, REASON_INDEX_OUT_OF_RANGE);
SLAMD_SAME_CODE(kBadKind, REASON_BAD_KIND);
SLAMD_SAME_CODE(kSizeMismatch, REASON_SIZE_MISMATCH);
SLAMD_SAME_CODE(kTooManyElements, REASON_TOO_MANY_ELEMENTS);
SLAMD_SAME_CODE(kSelfLoop, REASON_SELF_LOOP);
SLAMD_SAME_CODE(kCovarianceNotSymmetric, REASON_COVARIANCE_NOT_SYMMETRIC);
SLAMD_SAME_CODE(kCovarianceNotPositiveDefinite, REASON_COVARIANCE_NOT_POSITIVE_DEFINITE);
SLAMD_SAME_CODE(kCovarianceIllConditioned, REASON_COVARIANCE_ILL_CONDITIONED);
SLAMD_SAME_CODE(kQuaternionNotUnit, REASON_QUATERNION_NOT_UNIT);
SLAMD_SAME_CODE(kUnknownRobustKernel, REASON_UNKNOWN_ROBUST_KERNEL);
SLAMD_SAME_CODE(kBadRobustParameter, REASON_BAD_ROBUST_PARAMETER);
SLAMD_SAME_CODE(kBadMeasurement, REASON_BAD_MEASUREMENT);
SLAMD_SAME_CODE(kUnusedFieldSet, REASON_UNUSED_FIELD_SET);
SLAMD_SAME_CODE(kUnknownRobot, REASON_UNKNOWN_ROBOT);
SLAMD_SAME_CODE(kUnknownPose, REASON_UNKNOWN_POSE);
SLAMD_SAME_CODE(kUnknownFactor, REASON_UNKNOWN_FACTOR);
SLAMD_SAME_CODE(kDuplicate, REASON_DUPLICATE);
SLAMD_SAME_CODE(kOutOfOrderTimeout, REASON_OUT_OF_ORDER_TIMEOUT);
SLAMD_SAME_CODE(kQueueFull, REASON_QUEUE_FULL);
SLAMD_SAME_CODE(kWouldDisconnect, REASON_WOULD_DISCONNECT);
SLAMD_SAME_CODE(kStorageError, REASON_STORAGE_ERROR);
SLAMD_SAME_CODE(kReplicationUnavailable, REASON_REPLICATION_UNAVAILABLE);
SLAMD_SAME_CODE(kShardUnavailable, REASON_SHARD_UNAVAILABLE);
static_assert(kNumRejectReasonCodes == ::slamd::reject_t::REASON_SHARD_UNAVAILABLE + 1);
#undef SLAMD_SAME_CODE

const char* RejectReasonName(RejectReason reason) {
  switch (reason) {
    case RejectReason::kNone:
      return "none";
    case RejectReason::kDecodeError:
      return "decode_error";
    case RejectReason::kNotFinite:
      return "not_finite";
    case RejectReason::kBadTimestamp:
      return "bad_timestamp";
    case RejectReason::kBadName:
      return "bad_name";
    case RejectReason::kStringTooLong:
      return "string_too_long";
    case RejectReason::kIndexOutOfRange:
      return "index_out_of_range";
    case RejectReason::kBadKind:
      return "bad_kind";
    case RejectReason::kSizeMismatch:
      return "size_mismatch";
    case RejectReason::kTooManyElements:
      return "too_many_elements";
    case RejectReason::kSelfLoop:
      return "self_loop";
    case RejectReason::kCovarianceNotSymmetric:
      return "covariance_not_symmetric";
    case RejectReason::kCovarianceNotPositiveDefinite:
      return "covariance_not_positive_definite";
    case RejectReason::kCovarianceIllConditioned:
      return "covariance_ill_conditioned";
    case RejectReason::kQuaternionNotUnit:
      return "quaternion_not_unit";
    case RejectReason::kUnknownRobustKernel:
      return "unknown_robust_kernel";
    case RejectReason::kBadRobustParameter:
      return "bad_robust_parameter";
    case RejectReason::kBadMeasurement:
      return "bad_measurement";
    case RejectReason::kUnusedFieldSet:
      return "unused_field_set";
    case RejectReason::kUnknownRobot:
      return "unknown_robot";
    case RejectReason::kUnknownPose:
      return "unknown_pose";
    case RejectReason::kUnknownFactor:
      return "unknown_factor";
    case RejectReason::kDuplicate:
      return "duplicate";
    case RejectReason::kOutOfOrderTimeout:
      return "out_of_order_timeout";
    case RejectReason::kQueueFull:
      return "queue_full";
    case RejectReason::kWouldDisconnect:
      return "would_disconnect";
    case RejectReason::kStorageError:
      return "storage_error";
    case RejectReason::kReplicationUnavailable:
      return "replication_unavailable";
    case RejectReason::kShardUnavailable:
      return "shard_unavailable";
  }
  return "unknown";
}

}  // namespace slamd::server
