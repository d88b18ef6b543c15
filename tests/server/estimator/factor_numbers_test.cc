// FactorNumbers: released numbers go to the next measurements, a rebuild's remap moves the
// slots of the used ones only, a restore numbers the state's factors in order.
#include "server/estimator/factor_numbers.h"

#include <gtest/gtest.h>

#include <vector>

namespace slamd::server {
namespace {

FactorNumbers::Entry Entry(int i) {
  return {.id = {'o', core::MakeKey('x', i), core::MakeKey('x', i + 1), 0},
          .first = core::MakeKey('x', i),
          .dim = 3};
}

TEST(FactorNumbers, ReleasedNumbersAreReused) {
  FactorNumbers numbers;
  EXPECT_EQ(numbers.Add(Entry(0), 10), 0);
  EXPECT_EQ(numbers.Add(Entry(1), 11), 1);
  EXPECT_EQ(numbers.Add(Entry(2), 12), 2);
  numbers.Release(1);
  EXPECT_EQ(numbers.slot(1), -1);
  EXPECT_EQ(numbers.entry(1).dim, 0);
  EXPECT_EQ(numbers.Add(Entry(3), 13), 1);  // the released number, not a new one
  EXPECT_EQ(numbers.entry(1).id, Entry(3).id);
  EXPECT_EQ(numbers.slot(1), 13);
  EXPECT_EQ(numbers.size(), 3u);
  EXPECT_EQ(numbers.Add(Entry(4), 14), 3);  // none free: a new one
}

TEST(FactorNumbersDeathTest, RemapMovesTheUsedSlotsAndRestoreNumbersInOrder) {
  FactorNumbers numbers;
  numbers.Add(Entry(0), 2);
  numbers.Add(Entry(1), 0);
  numbers.Release(1);
  numbers.Remap(std::vector<int>{-1, -1, 5});
  EXPECT_EQ(numbers.slot(0), 5);
  EXPECT_EQ(numbers.slot(1), -1);
  EXPECT_DEATH(numbers.Remap(std::vector<int>{0, 1}), "not in the rebuilt solver");

  numbers.Restore({Entry(7), Entry(8), {}});
  EXPECT_EQ(numbers.size(), 3u);
  for (int n = 0; n < 3; ++n) EXPECT_EQ(numbers.slot(n), n);
  EXPECT_EQ(numbers.entry(1).id, Entry(8).id);
  EXPECT_EQ(numbers.Add(Entry(9), 3), 3);  // nothing free after a restore
}

}  // namespace
}  // namespace slamd::server
