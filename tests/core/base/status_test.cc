#include "core/base/status.h"

#include <gtest/gtest.h>

namespace slamd::core {
namespace {

Status FailsWhenNegative(int v) {
  if (v < 0) return InvalidArgument("v = " + std::to_string(v) + " is negative");
  return Status::Ok();
}

Status Chain(int v) {
  SLAMD_RETURN_IF_ERROR(FailsWhenNegative(v));
  return NotFound("reached the end");
}

Result<int> Half(int v) {
  if (v % 2) return InvalidArgument("odd");
  return v / 2;
}

TEST(StatusTest, OkAndErrors) {
  EXPECT_TRUE(Status::Ok().ok());
  const Status s = NumericalFailure("not positive definite near x3");
  EXPECT_FALSE(s.ok());
  EXPECT_EQ(s.code(), StatusCode::kNumericalFailure);
  EXPECT_EQ(s.ToString(), "NumericalFailure: not positive definite near x3");
}

TEST(StatusTest, ReturnIfErrorPropagates) {
  EXPECT_EQ(Chain(-1).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(Chain(1).code(), StatusCode::kNotFound);
}

TEST(ResultTest, ValueOrStatus) {
  const Result<int> a = Half(4);
  ASSERT_TRUE(a.ok());
  EXPECT_EQ(*a, 2);
  const Result<int> b = Half(3);
  EXPECT_FALSE(b.ok());
  EXPECT_EQ(b.status().message(), "odd");
}

TEST(ResultDeathTest, ValueOfFailedResultAborts) {
  const Result<int> b = Half(3);
  EXPECT_DEATH((void)b.value(), "odd");
}

}  // namespace
}  // namespace slamd::core
