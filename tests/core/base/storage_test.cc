// Reusing vector storage (core/base/storage.h): kept while at most 4x the need or 2 KiB, given
// back beyond that, whatever the size the vector once had.
#include "core/base/storage.h"

#include <gtest/gtest.h>

namespace slamd::core {
namespace {

TEST(StorageTest, KeepsModestSlackAndGivesBackTheRest) {
  UninitVector<double> v;
  ResizeReusingStorage(&v, 4096);  // 32 KiB
  ASSERT_EQ(v.size(), 4096u);
  const double* first = v.data();
  ResizeReusingStorage(&v, 1024);  // a quarter: kept
  EXPECT_EQ(v.data(), first);
  EXPECT_GE(v.capacity(), 4096u);
  ResizeReusingStorage(&v, 1023);  // beyond 4x: given back
  EXPECT_EQ(v.size(), 1023u);
  EXPECT_LT(v.capacity(), 4096u);
  // Small vectors: 2 KiB (256 doubles) are kept whatever the ratio.
  UninitVector<double> u;
  ResizeReusingStorage(&u, 256);
  ResizeReusingStorage(&u, 1);
  EXPECT_EQ(u.capacity(), 256u);
  ResizeReusingStorage(&u, 257);  // growing
  ResizeReusingStorage(&u, 1);    // 2 KiB + 8 bytes at 257x the need: given back
  EXPECT_EQ(u.capacity(), 1u);
  std::vector<double> w(300, 1.0);  // above 2 KiB and over 4x its need: given back
  AssignReusingStorage(&w, 10, 2.0);
  EXPECT_EQ(w, std::vector<double>(10, 2.0));
  EXPECT_LT(w.capacity(), 300u);
  AssignReusingStorage(&w, 40, 3.0);  // growing
  EXPECT_EQ(w, std::vector<double>(40, 3.0));
}

}  // namespace
}  // namespace slamd::core
