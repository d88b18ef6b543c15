#include "core/factors/values.h"

#include <gtest/gtest.h>

namespace slamd::core {
namespace {

TEST(ValuesTest, InsertAtUpdateErase) {
  Values v;
  const Key x0 = MakeKey('x', 0), l3 = MakeKey('l', 3), y = MakeKey('y', 1);
  ASSERT_TRUE(v.Insert(x0, Pose2(1, 2, 0.3)).ok());
  ASSERT_TRUE(v.Insert(l3, Point2(4, 5)).ok());
  ASSERT_TRUE(v.Insert(y, Pose3()).ok());
  EXPECT_EQ(v.size(), 3u);
  EXPECT_EQ(v.TotalDim(), 3 + 2 + 6);
  EXPECT_EQ(v.SlotOf(l3), 1);
  EXPECT_EQ(v.DimAt(2), 6);
  EXPECT_DOUBLE_EQ(v.At<Pose2>(x0).theta(), 0.3);
  EXPECT_EQ(v.Find<Pose3>(x0), nullptr);  // wrong type
  EXPECT_EQ(v.Insert(x0, Pose2()).code(), StatusCode::kAlreadyExists);
  EXPECT_EQ(v.Update(x0, Point2(0, 0)).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(v.Update(MakeKey('x', 9), Pose2()).code(), StatusCode::kNotFound);
  ASSERT_TRUE(v.Update(x0, Pose2(0, 0, 1)).ok());
  EXPECT_DOUBLE_EQ(v.At<Pose2>(x0).theta(), 1.0);
  ASSERT_TRUE(v.Erase(l3).ok());
  EXPECT_FALSE(v.Contains(l3));
  EXPECT_EQ(v.SlotOf(y), 1);
  EXPECT_EQ(v.KeyAt(1), y);
}

TEST(ValuesTest, RejectsNonFiniteValues) {
  Values v;
  const Status s = v.Insert(MakeKey('x', 1), Point2(std::nan(""), 0));
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("x1"), std::string::npos);
  EXPECT_TRUE(v.empty());
}

TEST(ValuesTest, RetractAndLocalCoordinatesAreInverse) {
  Eigen::VectorXd d(6);
  d << 0.1, -0.2, 0.3, 0.05, -0.1, 0.2;
  for (Variable v : {Variable(Pose2(1, 2, 3)), Variable(Pose3()), Variable(Point2(1, 1)),
                     Variable(Point3(1, 2, 3))}) {
    Variable moved = v;
    RetractInPlace(&moved, d.data());
    const int dim = TangentDim(TypeOf(v));
    EXPECT_TRUE(LocalCoordinates(v, moved).isApprox(d.head(dim), 1e-10)) << VariableTypeName(TypeOf(v));
  }
}

TEST(ValuesDeathTest, TypedAccessToMissingKeyAborts) {
  Values v;
  EXPECT_DEATH((void)v.At<Pose2>(MakeKey('x', 4)), "x4");
}

}  // namespace
}  // namespace slamd::core
