// The leader lease against a real three-server NATS JetStream cluster (its own network
// namespace; ctest label ha): one holder at a time; a holder that stops renewing loses it to the
// other after the TTL (not before), and its next renewal says so; a release hands over at once.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>

#include "server/replication/leader_lease.h"
#include "tests/testing/nats_cluster.h"
#include "tests/testing/processes.h"

namespace slamd::server {
namespace {

using Clock = std::chrono::steady_clock;

// Each test has its own bucket on the suite's cluster.
class LeaderLeaseTest : public testing::SharedNatsClusterTest {
 protected:
  std::unique_ptr<LeaderLease> Open(const std::string& holder) {
    auto lease = LeaderLease::Open({.nats = {.servers = cluster_->UrlList()},
                                    .bucket = test_name(),
                                    .ttl_ms = 1000,
                                    .holder = holder});
    EXPECT_TRUE(lease.ok()) << lease.status().ToString();
    return lease.ok() ? std::move(lease).value() : nullptr;
  }
};

TEST_F(LeaderLeaseTest, OneHolderUntilItStopsRenewing) {
  std::unique_ptr<LeaderLease> a = Open("aaaa"), b = Open("bbbb");
  ASSERT_TRUE(a && b);
  ASSERT_TRUE(a->TryAcquire().value());
  EXPECT_EQ(a->Holder().value(), "aaaa");
  // Renewed every quarter TTL for three TTLs: b never gets it.
  for (int i = 0; i < 12; ++i) {
    EXPECT_FALSE(b->TryAcquire().value());
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
    ASSERT_TRUE(a->Renew().ok());
  }
  // a stops renewing (it died): b gets the lease after the TTL, not before.
  const Clock::time_point stopped = Clock::now();
  while (!b->TryAcquire().value()) {
    ASSERT_LT(Clock::now() - stopped, std::chrono::seconds(10)) << "the lease never lapsed";
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  const double waited = std::chrono::duration<double>(Clock::now() - stopped).count();
  std::printf("[ lease    ] taken over %.3f s after the last renewal (ttl 1 s)\n", waited);
  EXPECT_GE(waited, 0.9);
  EXPECT_EQ(b->Holder().value(), "bbbb");
  const core::Status lost = a->Renew();
  EXPECT_EQ(lost.code(), core::StatusCode::kFailedPrecondition) << lost.ToString();
  EXPECT_FALSE(a->held());
  EXPECT_FALSE(a->TryAcquire().value());
}

TEST_F(LeaderLeaseTest, ReleaseHandsOverAtOnce) {
  std::unique_ptr<LeaderLease> a = Open("aaaa"), b = Open("bbbb");
  ASSERT_TRUE(a && b);
  ASSERT_TRUE(a->TryAcquire().value());
  EXPECT_FALSE(b->TryAcquire().value());
  ASSERT_TRUE(a->Release().ok());
  EXPECT_TRUE(b->TryAcquire().value());
  EXPECT_EQ(b->Holder().value(), "bbbb");
}

}  // namespace
}  // namespace slamd::server
