#include "server/ingest/reject_reason.h"

#include <gtest/gtest.h>

#include <set>
#include <string>

#include "slamd/reject_t.hpp"

namespace slamd::server {
namespace {

TEST(RejectReason, CodesMatchTheWireConstants) {
  // Also static_asserted in reject_reason.cc; repeated here for the reasons a test names.
  EXPECT_EQ(static_cast<int>(RejectReason::kDecodeError), slamd::reject_t::REASON_DECODE_ERROR);
  EXPECT_EQ(static_cast<int>(RejectReason::kCovarianceNotPositiveDefinite),
            slamd::reject_t::REASON_COVARIANCE_NOT_POSITIVE_DEFINITE);
  EXPECT_EQ(static_cast<int>(RejectReason::kWouldDisconnect),
            slamd::reject_t::REASON_WOULD_DISCONNECT);
  EXPECT_EQ(static_cast<int>(RejectReason::kStorageError), slamd::reject_t::REASON_STORAGE_ERROR);
  EXPECT_EQ(static_cast<int>(RejectReason::kReplicationUnavailable),
            slamd::reject_t::REASON_REPLICATION_UNAVAILABLE);
  EXPECT_EQ(static_cast<int>(RejectReason::kShardUnavailable),
            slamd::reject_t::REASON_SHARD_UNAVAILABLE);
  EXPECT_EQ(kNumRejectReasonCodes, slamd::reject_t::REASON_SHARD_UNAVAILABLE + 1);
}

TEST(RejectReason, EveryCodeHasAUniqueName) {
  std::set<std::string> names;
  int named = 0;
  for (int code = 0; code < kNumRejectReasonCodes; ++code) {
    const std::string name = RejectReasonName(static_cast<RejectReason>(code));
    if (name == "unknown") continue;  // the gap 19..31
    ++named;
    EXPECT_TRUE(names.insert(name).second) << name;
  }
  EXPECT_EQ(named, 1 + 18 + 10);  // none, 18 stateless, 10 stateful
  EXPECT_STREQ(RejectReasonName(RejectReason::kNone), "none");
  EXPECT_STREQ(RejectReasonName(static_cast<RejectReason>(25)), "unknown");
}

}  // namespace
}  // namespace slamd::server
