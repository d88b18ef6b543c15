#include "core/isam/isam2_params.h"

#include <gtest/gtest.h>

namespace slamd::core {
namespace {

// GTSAM's ISAM2 defaults, plus the linearisation-error check GTSAM does not have.
TEST(Isam2ParamsTest, DefaultsAreValidAndGtsamsPlusTheErrorCheck) {
  const Isam2Params p;
  EXPECT_TRUE(p.Validate().ok());
  EXPECT_EQ(p.relinearization.skip, 10);
  EXPECT_DOUBLE_EQ(p.relinearization.rotation_threshold, 0.1);
  EXPECT_DOUBLE_EQ(p.wildfire_threshold, 0.001);
  EXPECT_DOUBLE_EQ(p.relinearization.error_threshold, 0.1);  // on: GTSAM's ISAM2 has no such check
}

TEST(Isam2ParamsTest, EachViolationNamesTheField) {
  struct Case {
    Isam2Params params;
    const char* field;
  };
  const Case cases[] = {
      {{.relinearization = {.rotation_threshold = 0.0}}, "relinearization.rotation_threshold"},
      {{.relinearization = {.translation_threshold = -1.0}},
       "relinearization.translation_threshold"},
      {{.relinearization = {.error_threshold = -1.0}}, "relinearization.error_threshold"},
      {{.relinearization = {.skip = 0}}, "relinearization.skip"},
      {{.relinearization = {.max_variables = -1}}, "relinearization.max_variables"},
      {{.wildfire_threshold = -0.1}, "wildfire_threshold"},
      {{.refine_threshold = 0.0}, "refine_threshold"},
      {{.refine_max_variables = -1}, "refine_max_variables"},
      {{.batch_every = -2}, "batch_every"},
      {{.threads = 0}, "threads"},
      {{.elimination = {.relative_pivot_tolerance = 2.0}}, "relative_pivot_tolerance"},
  };
  for (const Case& c : cases) {
    const Status s = c.params.Validate();
    ASSERT_FALSE(s.ok()) << c.field;
    EXPECT_NE(s.message().find(c.field), std::string::npos) << s.message();
  }
}

}  // namespace
}  // namespace slamd::core
