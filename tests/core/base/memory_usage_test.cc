// The process's memory figures (core/base/memory_usage.h).
#include "core/base/memory_usage.h"

#include <gtest/gtest.h>

#include <cstring>
#include <memory>

#include "tests/testing/glibc_malloc.h"

namespace slamd::core {
namespace {

#if SLAMD_GLIBC_MALLOC
// Once freed memory is kept for reuse, what the allocator holds is a high-water mark: a block
// freed again still counts, as it still would in the peak RSS.
TEST(MemoryUsageTest, AllocatorBytesKeepTheHighWaterMark) {
  KeepFreedMemoryForReuse();
  const std::int64_t before = AllocatorBytes();
  constexpr std::size_t kBlock = 24 << 20;  // below the 32 MiB served by mapping a block alone
  {
    std::unique_ptr<char[]> block(new char[kBlock]);
    std::memset(block.get(), 1, kBlock);
    EXPECT_GE(AllocatorBytes(), before + static_cast<std::int64_t>(kBlock));
  }
  EXPECT_GE(AllocatorBytes(), before + static_cast<std::int64_t>(kBlock));
  EXPECT_GT(ResidentBytes(), static_cast<std::int64_t>(kBlock));
}
#endif

}  // namespace
}  // namespace slamd::core
