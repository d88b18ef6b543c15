// ShardReplies: the replies of the shards that answer one query, merged.
#include "clients/slamctl/shard_replies.h"

#include <gtest/gtest.h>

namespace slamd::clients {
namespace {

slamd::query_reply_t Reply(const std::string& shard, int answering, int pages, int results = 0) {
  slamd::query_reply_t r{};
  r.request_id = 7;
  r.client = "c";
  r.shard = shard;
  r.shards_answering = answering;
  r.map_pages = pages;
  r.num_results = results;
  r.results.resize(static_cast<size_t>(results));
  return r;
}

// An unsharded slamd's one reply (shard "", shards_answering 1, or 0 from an older server).
TEST(ShardRepliesTest, OneReplyIsTheAnswer) {
  ShardReplies replies(7, "c");
  EXPECT_FALSE(replies.complete());
  EXPECT_EQ(replies.Missing(), "query_reply_t for request 7");
  slamd::query_reply_t other = Reply("", 0, 3);
  other.client = "d";  // another client's
  EXPECT_FALSE(replies.Add(other));
  other.client = "c";
  other.request_id = 8;
  EXPECT_FALSE(replies.Add(other));
  EXPECT_TRUE(replies.Add(Reply("", 0, 3, 1)));
  EXPECT_TRUE(replies.complete());
  EXPECT_EQ(replies.Missing(), "");
  EXPECT_EQ(replies.merged().map_pages, 3);
  EXPECT_EQ(replies.merged().num_results, 1);
}

// Three shards: the keys' results from the reply that has them (wherever it comes), the pages
// summed, the worst status with each shard's error, each shard counted once.
TEST(ShardRepliesTest, EveryShardsReplyMerged) {
  ShardReplies replies(7, "");
  EXPECT_TRUE(replies.Add(Reply("a", 3, 2)));
  EXPECT_FALSE(replies.Add(Reply("a", 3, 2)));
  EXPECT_EQ(replies.Missing(), "query_reply_t from 2 more of 3 shards (heard: a)");
  slamd::query_reply_t b = Reply("b", 3, 4, 2);
  b.status = slamd::query_reply_t::STATUS_PARTIAL;
  b.error = "map marginals not ready";
  EXPECT_TRUE(replies.Add(b));
  slamd::query_reply_t c = Reply("c", 3, 0);
  c.status = slamd::query_reply_t::STATUS_REJECTED;
  c.error = "unreachable";
  EXPECT_FALSE(replies.complete());
  EXPECT_TRUE(replies.Add(c));
  ASSERT_TRUE(replies.complete());
  const slamd::query_reply_t& m = replies.merged();
  EXPECT_EQ(m.map_pages, 6);
  EXPECT_EQ(m.num_results, 2);
  EXPECT_EQ(m.results.size(), 2u);
  EXPECT_EQ(m.status, slamd::query_reply_t::STATUS_REJECTED);
  EXPECT_EQ(m.error, "shard b: map marginals not ready; shard c: unreachable");
}

}  // namespace
}  // namespace slamd::clients
