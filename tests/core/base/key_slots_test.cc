#include "core/base/key_slots.h"

#include <gtest/gtest.h>

#include <random>
#include <unordered_map>
#include <vector>

namespace slamd::core {
namespace {

TEST(KeySlotsTest, EmptyFindsNothing) {
  KeySlots index;
  EXPECT_EQ(index.Find(MakeKey('x', 1)), -1);
  EXPECT_FALSE(index.Erase(MakeKey('x', 1)));
  EXPECT_EQ(index.size(), 0u);
}

// Random inserts, updates, erases and lookups against std::unordered_map, over keys of several
// symbols and robots (the bits the hash must mix), through many growths and long probe runs.
TEST(KeySlotsTest, MatchesUnorderedMapUnderRandomOperations) {
  std::mt19937_64 rng(11);
  KeySlots index;
  std::unordered_map<Key, int> reference;
  std::vector<Key> keys;
  for (unsigned char robot = 0; robot < 3; ++robot) {
    for (std::uint64_t i = 0; i < 3000; ++i) {
      keys.push_back(MakeKey(i % 2 ? 'x' : 'l', i, robot));
    }
  }
  for (int step = 0; step < 200000; ++step) {
    const Key key = keys[rng() % keys.size()];
    const int op = static_cast<int>(rng() % 4);
    const bool present = reference.count(key) != 0;
    if (op == 0 && !present) {
      const int value = static_cast<int>(rng() % 1000000);
      index.Insert(key, value);
      reference[key] = value;
    } else if (op == 1 && present) {
      const int value = static_cast<int>(rng() % 1000000);
      index.Set(key, value);
      reference[key] = value;
    } else if (op == 2) {
      ASSERT_EQ(index.Erase(key), present) << "step " << step;
      reference.erase(key);
    }
    ASSERT_EQ(index.size(), reference.size()) << "step " << step;
    const auto it = reference.find(key);
    ASSERT_EQ(index.Find(key), it == reference.end() ? -1 : it->second) << "step " << step;
  }
  for (Key key : keys) {
    const auto it = reference.find(key);
    ASSERT_EQ(index.Find(key), it == reference.end() ? -1 : it->second);
  }
  // A copy is independent of the original.
  KeySlots copy = index;
  const Key some = reference.begin()->first;
  copy.Set(some, 7);
  EXPECT_EQ(index.Find(some), reference.begin()->second);
  EXPECT_EQ(copy.Find(some), 7);
}

TEST(KeySlotsDeathTest, MisuseAbortsNamingTheKey) {
  KeySlots index;
  index.Insert(MakeKey('x', 3), 0);
  EXPECT_DEATH(index.Insert(MakeKey('x', 3), 1), "already present");
  EXPECT_DEATH(index.Set(MakeKey('x', 4), 1), "absent");
  EXPECT_DEATH(index.Insert(MakeKey('x', 5), -1), "< 0");
}

}  // namespace
}  // namespace slamd::core
