#include "server/transport/bus.h"

#include <gtest/gtest.h>

#include <utility>

namespace slamd::server {
namespace {

TEST(Subscription, UnsubscribesExactlyOnce) {
  int calls = 0;
  {
    Subscription s([&] { ++calls; });
    EXPECT_TRUE(s.active());
    s.Unsubscribe();
    EXPECT_FALSE(s.active());
    s.Unsubscribe();
  }
  EXPECT_EQ(calls, 1);
}

TEST(Subscription, DestructorUnsubscribes) {
  int calls = 0;
  {
    Subscription s([&] { ++calls; });
  }
  EXPECT_EQ(calls, 1);
}

TEST(Subscription, MoveTransfersOwnership) {
  int a_calls = 0, b_calls = 0;
  Subscription a([&] { ++a_calls; });
  Subscription moved(std::move(a));
  EXPECT_FALSE(a.active());  // NOLINT(bugprone-use-after-move): moved-from is inactive by contract
  EXPECT_TRUE(moved.active());
  Subscription b([&] { ++b_calls; });
  b = std::move(moved);  // b's own subscription ends; it now holds a's
  EXPECT_EQ(b_calls, 1);
  EXPECT_EQ(a_calls, 0);
  b.Unsubscribe();
  EXPECT_EQ(a_calls, 1);
  Subscription empty;
  EXPECT_FALSE(empty.active());
}

TEST(CheckChannelName, Limits) {
  EXPECT_TRUE(CheckChannelName("SLAMD_ODOMETRY").ok());
  EXPECT_TRUE(CheckChannelName(std::string(63, 'c')).ok());
  EXPECT_FALSE(CheckChannelName(std::string(64, 'c')).ok());
  EXPECT_FALSE(CheckChannelName("").ok());
}

}  // namespace
}  // namespace slamd::server
