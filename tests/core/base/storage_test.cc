// Reusing vector storage (core/base/storage.h): kept while at most 2x the need or 512 bytes,
// given back beyond that, whatever the size the vector once had.
#include "core/base/storage.h"

#include <gtest/gtest.h>

namespace slamd::core {
namespace {

TEST(StorageTest, KeepsModestSlackAndGivesBackTheRest) {
  UninitVector<double> v;
  ResizeReusingStorage(&v, 4096);  // 32 KiB
  ASSERT_EQ(v.size(), 4096u);
  const double* first = v.data();
  ResizeReusingStorage(&v, 2048);  // a half: kept
  EXPECT_EQ(v.data(), first);
  EXPECT_GE(v.capacity(), 4096u);
  ResizeReusingStorage(&v, 2047);  // beyond 2x: given back
  EXPECT_EQ(v.size(), 2047u);
  EXPECT_LT(v.capacity(), 4096u);
  // Small vectors: 512 bytes (64 doubles) are kept whatever the ratio.
  UninitVector<double> u;
  ResizeReusingStorage(&u, 64);
  ResizeReusingStorage(&u, 1);
  EXPECT_EQ(u.capacity(), 64u);
  ResizeReusingStorage(&u, 65);  // growing
  ResizeReusingStorage(&u, 1);   // 520 bytes at 65x the need: given back
  EXPECT_EQ(u.capacity(), 1u);
  std::vector<double> w(300, 1.0);  // over 512 bytes and 2x its need: given back
  AssignReusingStorage(&w, 100, 2.0);
  EXPECT_EQ(w, std::vector<double>(100, 2.0));
  EXPECT_LT(w.capacity(), 300u);
  AssignReusingStorage(&w, 60, 3.0);  // within 2x: kept
  EXPECT_EQ(w, std::vector<double>(60, 3.0));
  EXPECT_EQ(w.capacity(), 100u);
}

}  // namespace
}  // namespace slamd::core
