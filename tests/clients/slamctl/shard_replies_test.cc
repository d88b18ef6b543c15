// ShardReplies: the replies of the shards that answer one query, merged.
#include "clients/slamctl/shard_replies.h"

#include <gtest/gtest.h>

#include <set>
#include <vector>

namespace slamd::clients {
namespace {

// A reply of `shard` to a query of `results` keys, those in `found` found (value: the index).
slamd::query_reply_t Reply(const std::string& shard, int answering, int pages, int results = 0,
                           std::set<int> found = {}) {
  slamd::query_reply_t r{};
  r.request_id = 7;
  r.client = "c";
  r.shard = shard;
  r.shards_answering = answering;
  r.map_pages = pages;
  r.num_results = results;
  r.results.resize(static_cast<size_t>(results));
  for (int i : found) {
    r.results[i].found = true;
    r.results[i].values = {double(i)};
    r.results[i].num_values = 1;
  }
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

// Three shards: each key's result from the reply that found it (its owner's, whichever comes
// first), the pages summed, the worst status with each shard's error, each shard counted once.
TEST(ShardRepliesTest, EveryShardsReplyMerged) {
  ShardReplies replies(7, "");
  EXPECT_TRUE(replies.Add(Reply("a", 3, 2, 3, {1})));
  EXPECT_FALSE(replies.Add(Reply("a", 3, 2, 3, {0, 1, 2})));  // that shard's again
  EXPECT_EQ(replies.Missing(), "query_reply_t from 2 more of 3 shards (heard: a)");
  slamd::query_reply_t b = Reply("b", 3, 4, 3, {0});
  b.status = slamd::query_reply_t::STATUS_PARTIAL;
  b.error = "map marginals not ready";
  EXPECT_TRUE(replies.Add(b));
  slamd::query_reply_t c = Reply("c", 3, 0, 3);
  c.status = slamd::query_reply_t::STATUS_REJECTED;
  c.error = "unreachable";
  EXPECT_FALSE(replies.complete());
  EXPECT_TRUE(replies.Add(c));
  ASSERT_TRUE(replies.complete());
  const slamd::query_reply_t& m = replies.merged();
  EXPECT_EQ(m.map_pages, 6);
  ASSERT_EQ(m.results.size(), 3u);
  for (int i : {0, 1}) {
    EXPECT_TRUE(m.results[i].found);
    EXPECT_EQ(m.results[i].values, std::vector<double>{double(i)});
  }
  EXPECT_FALSE(m.results[2].found);  // no shard found it
  EXPECT_EQ(m.status, slamd::query_reply_t::STATUS_REJECTED);
  EXPECT_EQ(m.error, "shard b: map marginals not ready; shard c: unreachable");
}

}  // namespace
}  // namespace slamd::clients
