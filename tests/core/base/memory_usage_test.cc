// The process's memory figures (core/base/memory_usage.h).
#include "core/base/memory_usage.h"

#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <vector>

#include "tests/testing/glibc_malloc.h"

namespace slamd::core {
namespace {

#if SLAMD_GLIBC_MALLOC
// Once freed memory is kept for reuse, what the allocator holds is a high-water mark: a block
// freed again still counts, as it still would in the peak RSS.
TEST(MemoryUsageTest, AllocatorBytesKeepTheHighWaterMark) {
  KeepFreedMemoryForReuse();
  constexpr std::size_t kBlock = 24 << 20;  // below the 32 MiB served by mapping a block alone
  std::int64_t held = 0;
  {
    std::unique_ptr<char[]> block(new char[kBlock]);
    std::memset(block.get(), 1, kBlock);
    // (Earlier tests in the same process may have left the heap room for it: not "before +".)
    held = AllocatorBytes();
    EXPECT_GE(held, static_cast<std::int64_t>(kBlock));
  }
  EXPECT_GE(AllocatorBytes(), held);
  EXPECT_GT(ResidentBytes(), static_cast<std::int64_t>(kBlock));
}

// The heap in use counts a block while it is held and not once it is freed, whatever the
// allocator keeps for reuse.
TEST(MemoryUsageTest, InUseFollowsTheLiveBlocks) {
  KeepFreedMemoryForReuse();
  constexpr std::size_t kBlock = 24 << 20;
  const std::int64_t before = AllocatorInUseBytes();
  std::int64_t with = 0;
  {
    std::unique_ptr<char[]> block(new char[kBlock]);
    std::memset(block.get(), 1, kBlock);
    with = AllocatorInUseBytes();
    EXPECT_GE(with - before, static_cast<std::int64_t>(kBlock));
  }
  EXPECT_LE(AllocatorInUseBytes(), with - static_cast<std::int64_t>(kBlock));
  EXPECT_LT(AllocatorInUseBytes(), ResidentBytes());
}

// What is kept for reuse goes back to the kernel once it outweighs what is in use, and only
// then: 160 MiB of blocks in use are left alone, and once freed their pages leave the resident
// set.
TEST(MemoryUsageTest, FreedMemoryBeyondUseGoesBack) {
  KeepFreedMemoryForReuse();
  constexpr std::size_t kBlock = 1 << 20, kBlocks = 160;
  constexpr std::int64_t kSlack = 16 << 20, kAll = kBlock * kBlocks;
  std::vector<std::unique_ptr<char[]>> blocks;
  for (std::size_t i = 0; i < kBlocks; ++i) {
    blocks.emplace_back(new char[kBlock]);
    std::memset(blocks.back().get(), 1, kBlock);
  }
  EXPECT_FALSE(TrimFreedMemoryBeyondUse(kSlack));
  blocks.clear();
  const std::int64_t held = ResidentBytes();
  EXPECT_TRUE(TrimFreedMemoryBeyondUse(kSlack));
  EXPECT_LT(ResidentBytes(), held - kAll / 2);
  EXPECT_FALSE(TrimFreedMemoryBeyondUse(kSlack));  // nothing left to give back
}
#endif

}  // namespace
}  // namespace slamd::core
