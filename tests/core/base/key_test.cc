#include "core/base/key.h"

#include <gtest/gtest.h>

namespace slamd::core {
namespace {

TEST(KeyTest, PacksSymbolIndexAndRobot) {
  const Key k = MakeKey('x', 12);
  EXPECT_EQ(KeySymbol(k), 'x');
  EXPECT_EQ(KeyIndex(k), 12u);
  EXPECT_EQ(KeyRobot(k), 0);
  const Key r = MakeKey('l', kMaxKeyIndex, 'b');
  EXPECT_EQ(KeySymbol(r), 'l');
  EXPECT_EQ(KeyIndex(r), kMaxKeyIndex);
  EXPECT_EQ(KeyRobot(r), 'b');
}

TEST(KeyTest, SameIndexDifferentRobotsAreDifferentKeys) {
  EXPECT_NE(MakeKey('x', 5, 'a'), MakeKey('x', 5, 'b'));
  EXPECT_NE(MakeKey('x', 5), MakeKey('l', 5));
}

TEST(KeyTest, Prints) {
  EXPECT_EQ(KeyToString(MakeKey('x', 12)), "x12");
  EXPECT_EQ(KeyToString(MakeKey('x', 12, 'a')), "a:x12");
  EXPECT_EQ(KeyToString(MakeKey('l', 3, 200)), "r200:l3");
}

TEST(KeyDeathTest, IndexTooLargeAborts) {
  EXPECT_DEATH(MakeKey('x', kMaxKeyIndex + 1), "exceeds");
}

}  // namespace
}  // namespace slamd::core
