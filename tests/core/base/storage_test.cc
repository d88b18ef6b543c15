// Reusing vector storage (core/base/storage.h): kept while at most 1.25x the need or 512 bytes,
// given back beyond that, whatever the size the vector once had; and growing by a quarter.
#include "core/base/storage.h"

#include <gtest/gtest.h>

namespace slamd::core {
namespace {

TEST(StorageTest, KeepsModestSlackAndGivesBackTheRest) {
  UninitVector<double> v;
  ResizeReusingStorage(&v, 4096);  // 32 KiB
  ASSERT_EQ(v.size(), 4096u);
  const double* first = v.data();
  ResizeReusingStorage(&v, 3277);  // 4096 <= 1.25 x 3277: kept
  EXPECT_EQ(v.data(), first);
  EXPECT_GE(v.capacity(), 4096u);
  ResizeReusingStorage(&v, 3276);  // beyond 1.25x: given back
  EXPECT_EQ(v.size(), 3276u);
  EXPECT_LT(v.capacity(), 4096u);
  // Small vectors: 512 bytes (64 doubles) are kept whatever the ratio.
  UninitVector<double> u;
  ResizeReusingStorage(&u, 64);
  ResizeReusingStorage(&u, 1);
  EXPECT_EQ(u.capacity(), 64u);
  ResizeReusingStorage(&u, 65);  // growing
  ResizeReusingStorage(&u, 1);   // 520 bytes at 65x the need: given back
  EXPECT_EQ(u.capacity(), 1u);
  std::vector<double> w(300, 1.0);  // over 512 bytes and 1.25x its need: given back
  AssignReusingStorage(&w, 200, 2.0);
  EXPECT_EQ(w, std::vector<double>(200, 2.0));
  EXPECT_LT(w.capacity(), 300u);
  AssignReusingStorage(&w, 160, 3.0);  // within 1.25x: kept
  EXPECT_EQ(w, std::vector<double>(160, 3.0));
  EXPECT_EQ(w.capacity(), 200u);
}

// One entry at a time, the capacity grows by a quarter (at least 16), so at most a fifth of a
// large array is unused (doubling: up to half); the entries are kept.
TEST(StorageTest, ReserveOneMoreGrowsByAQuarter) {
  std::vector<int> v;
  std::size_t grew = 0;
  for (int i = 0; i < 100000; ++i) {
    const std::size_t before = v.capacity();
    ReserveOneMore(&v);
    v.push_back(i);
    if (v.capacity() != before) {
      ++grew;
      EXPECT_LE(v.capacity(), std::max<std::size_t>(before + before / 4, before + 16)) << i;
    }
    if (v.size() > 64) ASSERT_GE(5 * v.size(), 4 * v.capacity()) << i;
  }
  EXPECT_LT(grew, 60u);  // geometric: amortised O(1) per entry
  for (int i = 0; i < 100000; ++i) ASSERT_EQ(v[i], i);
}

}  // namespace
}  // namespace slamd::core
