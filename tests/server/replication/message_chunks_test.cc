// Messages split into chunks for NATS and put back together: in order, from several senders at
// once, with copies and lost chunks, and malformed chunks refused.
#include "server/replication/message_chunks.h"

#include <gtest/gtest.h>

#include <numeric>
#include <vector>

#include "server/replication/relay_bus.h"

namespace slamd::server {
namespace {

std::vector<std::uint8_t> Bytes(std::size_t n, std::uint8_t first) {
  std::vector<std::uint8_t> v(n);
  std::iota(v.begin(), v.end(), first);
  return v;
}

TEST(MessageChunks, AMessageComesBackWholeFromItsChunks) {
  const std::vector<std::uint8_t> message = Bytes(2500, 7);
  const auto chunks = SplitIntoChunks("S0", 1, message, 1000);
  ASSERT_EQ(chunks.size(), 3u);
  ChunkAssembler assembler;
  for (std::size_t i = 0; i < chunks.size(); ++i) {
    const auto got = assembler.Add(chunks[i]);
    ASSERT_TRUE(got.ok()) << got.status().ToString();
    EXPECT_EQ(got.value().has_value(), i + 1 == chunks.size());
    if (got.value()) EXPECT_EQ(*got.value(), message);
  }
  // An empty message is one chunk.
  const auto empty = SplitIntoChunks("S0", 2, {}, 1000);
  ASSERT_EQ(empty.size(), 1u);
  const auto got = assembler.Add(empty[0]);
  ASSERT_TRUE(got.ok() && got.value().has_value());
  EXPECT_TRUE(got.value()->empty());
}

TEST(MessageChunks, SendersInterleaveCopiesAreIgnoredAndALostChunkDropsItsMessage) {
  const std::vector<std::uint8_t> a = Bytes(300, 1), b = Bytes(250, 100), c = Bytes(120, 50);
  const auto ca = SplitIntoChunks("S0", 4, a, 100);
  const auto cb = SplitIntoChunks("S1", 9, b, 100);
  ChunkAssembler assembler;
  std::vector<std::vector<std::uint8_t>> whole;
  const auto add = [&](const std::vector<std::uint8_t>& chunk) {
    const auto got = assembler.Add(chunk);
    ASSERT_TRUE(got.ok()) << got.status().ToString();
    if (got.value()) whole.push_back(*got.value());
  };
  add(ca[0]);
  add(cb[0]);
  add(ca[1]);
  add(ca[1]);  // a copy
  add(cb[1]);
  add(ca[2]);
  add(cb[2]);
  ASSERT_EQ(whole.size(), 2u);
  EXPECT_EQ(whole[0], a);
  EXPECT_EQ(whole[1], b);
  // S0's next message loses its first chunk; the one after it comes whole.
  const auto lost = SplitIntoChunks("S0", 5, a, 100);
  add(lost[1]);
  add(lost[2]);
  for (const auto& chunk : SplitIntoChunks("S0", 6, c, 100)) add(chunk);
  ASSERT_EQ(whole.size(), 3u);
  EXPECT_EQ(whole[2], c);
  EXPECT_EQ(assembler.dropped(), 1);
}

TEST(MessageChunks, WhatIsNotAChunkIsRefused) {
  ChunkAssembler assembler;
  const std::vector<std::uint8_t> body = Bytes(10, 0);
  for (const char* tag : {"S0", "S0/1/2", "S0/1/2/2", "S0/x/0/1", "/1/0/1", "S0/1/0/0", "S0/1/-1/2",
                          "S0/1/0/99999"}) {
    const auto got = assembler.Add(Frame(tag, body));
    ASSERT_FALSE(got.ok()) << tag;
    EXPECT_EQ(got.status().code(), core::StatusCode::kInvalidArgument) << tag;
    EXPECT_NE(got.status().message().find("not a message chunk"), std::string::npos);
  }
  EXPECT_FALSE(assembler.Add(std::vector<std::uint8_t>{}).ok());
}

}  // namespace
}  // namespace slamd::server
