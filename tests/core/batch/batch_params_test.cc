#include "core/batch/batch_params.h"

#include <gtest/gtest.h>

namespace slamd::core {
namespace {

TEST(BatchParamsTest, DefaultsAreValid) { EXPECT_TRUE(BatchParams{}.Validate().ok()); }

TEST(BatchParamsTest, EachViolationNamesTheField) {
  struct Case {
    BatchParams params;
    const char* field;
  };
  const Case cases[] = {
      {{.max_iterations = 0}, "max_iterations"},
      {{.relative_tolerance = -1.0}, "relative_tolerance"},
      {{.absolute_tolerance = -1.0}, "absolute_tolerance"},
      {{.initial_lambda = -1.0}, "initial_lambda"},
      {{.lambda_floor = 0.0}, "lambda_floor"},
      {{.initial_lambda = 1.0, .max_lambda = 0.5}, "max_lambda"},
      {{.verbosity = -1}, "verbosity"},
  };
  for (const Case& c : cases) {
    const Status s = c.params.Validate();
    ASSERT_FALSE(s.ok()) << c.field;
    EXPECT_NE(s.message().find(std::string("BatchParams::") + c.field), std::string::npos) << s.message();
  }
}

}  // namespace
}  // namespace slamd::core
