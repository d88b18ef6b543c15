#include "server/estimator/robot_registry.h"

#include <gtest/gtest.h>

#include <set>

namespace slamd::server {
namespace {

TEST(RobotRegistryTest, PrintableLettersFirstThenEveryOtherNonZeroId) {
  RobotRegistry r;
  EXPECT_FALSE(r.Find("alpha"));
  EXPECT_EQ(*r.FindOrAdd("alpha"), 'a');
  EXPECT_EQ(*r.FindOrAdd("beta"), 'b');
  EXPECT_EQ(*r.FindOrAdd("alpha"), 'a');  // stable
  EXPECT_EQ(r.Name('b'), "beta");
  std::set<int> ids = {'a', 'b'};
  for (int i = 2; i < RobotRegistry::kMaxRobots; ++i) {
    std::string name = "r";
    name += std::to_string(i);  // (not "r" + ...: g++ 12 -Wrestrict false positive)
    const auto id = r.FindOrAdd(name);
    ASSERT_TRUE(id);
    if (i == 26) {
      EXPECT_EQ(*id, 'A');
    }
    if (i == 52) {
      EXPECT_EQ(*id, '0');
    }
    EXPECT_NE(*id, 0);
    EXPECT_TRUE(ids.insert(*id).second) << "id reused: " << int(*id);
  }
  EXPECT_EQ(r.size(), 255);
  EXPECT_FALSE(r.FindOrAdd("one too many"));
  EXPECT_EQ(*r.Find("r254"), *r.FindOrAdd("r254"));
}

}  // namespace
}  // namespace slamd::server
