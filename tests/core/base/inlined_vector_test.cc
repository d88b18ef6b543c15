// InlinedVector (core/base/inlined_vector.h): entries inside the object up to N, on the heap
// beyond; the heap block is kept when the size shrinks; copies and moves keep the entries; the
// pointer shares the object's room with the inline entries.
#include "core/base/inlined_vector.h"

#include <gtest/gtest.h>

#include <numeric>
#include <vector>

namespace slamd::core {
namespace {

template <int N>
std::vector<int> Entries(const InlinedVector<int, N>& v) {
  return {v.begin(), v.end()};
}

std::vector<int> Iota(int n) {
  std::vector<int> v(n);
  std::iota(v.begin(), v.end(), 1);
  return v;
}

TEST(InlinedVectorTest, NoRoomBeyondTheEntriesAndTwoCounts) {
  EXPECT_EQ(sizeof(InlinedVector<int, 4>), 16 + 2 * sizeof(std::uint32_t));
  EXPECT_EQ(sizeof(InlinedVector<int, 1>), sizeof(int*) + 2 * sizeof(std::uint32_t));
}

TEST(InlinedVectorTest, InlineUpToNThenOnTheHeapWhichIsKept) {
  InlinedVector<int, 4> v;
  EXPECT_TRUE(v.empty());
  v.assign(Iota(4));
  EXPECT_EQ(Entries(v), Iota(4));
  EXPECT_EQ(v.HeapBytes(), 0u);
  const auto* object = reinterpret_cast<const char*>(&v);
  EXPECT_TRUE(reinterpret_cast<const char*>(v.data()) >= object &&
              reinterpret_cast<const char*>(v.data()) < object + sizeof(v));
  v.assign(Iota(7));
  EXPECT_EQ(Entries(v), Iota(7));
  EXPECT_EQ(v.HeapBytes(), 7 * sizeof(int));
  const int* heap = v.data();
  v.assign(Iota(2));  // smaller: the heap block stays
  EXPECT_EQ(Entries(v), Iota(2));
  EXPECT_EQ(v.data(), heap);
  v.assign(Iota(7));
  EXPECT_EQ(v.data(), heap);
  v.assign(Iota(9));  // larger than the block: a new one
  EXPECT_EQ(Entries(v), Iota(9));
  EXPECT_EQ(v.HeapBytes(), 9 * sizeof(int));
}

TEST(InlinedVectorTest, CopiesAndMovesKeepTheEntries) {
  for (int n : {0, 3, 4, 5, 12}) {
    SCOPED_TRACE(n);
    InlinedVector<int, 4> a;
    a.assign(Iota(n));
    InlinedVector<int, 4> b(a);
    EXPECT_EQ(Entries(b), Iota(n));
    InlinedVector<int, 4> c;
    c.assign(Iota(20));  // on the heap before it is assigned to
    c = b;
    EXPECT_EQ(Entries(c), Iota(n));
    InlinedVector<int, 4> d(std::move(b));
    EXPECT_EQ(Entries(d), Iota(n));
    EXPECT_TRUE(b.empty());  // NOLINT(bugprone-use-after-move): a moved-from vector is empty
    EXPECT_EQ(b.HeapBytes(), 0u);
    InlinedVector<int, 4> e;
    e.assign(Iota(6));
    e = std::move(d);
    EXPECT_EQ(Entries(e), Iota(n));
  }
}

}  // namespace
}  // namespace slamd::core
