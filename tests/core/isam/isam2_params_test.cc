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

// Each entry of each variable type has a threshold: its kind's, unless the type overrides it.
TEST(Isam2ParamsTest, ThresholdsByVariableTypeAndKindOfEntry) {
  const Isam2Params::Relinearization r{
      .rotation_threshold = 0.2,
      .translation_threshold = 0.3,
      .calibration_threshold = 4.0,
      .other_threshold = 0.5,
      .per_type = {{.type = "Pose3", .kind = EntryKind::kRotation, .threshold = 0.01},
                   {.type = "Cal3DS2", .kind = EntryKind::kCalibration, .threshold = 1e-3}}};
  EXPECT_EQ(r.ThresholdOf(kVariableType<Pose2>, EntryKind::kRotation), 0.2);
  EXPECT_EQ(r.ThresholdOf(kVariableType<Pose3>, EntryKind::kRotation), 0.01);
  EXPECT_EQ(r.ThresholdOf(kVariableType<Pose3>, EntryKind::kTranslation), 0.3);
  EXPECT_EQ(r.ThresholdOf(kVariableType<Point3>, EntryKind::kTranslation), 0.3);
  EXPECT_EQ(r.ThresholdOf(kVariableType<Cal3DS2>, EntryKind::kCalibration), 1e-3);
  EXPECT_EQ(r.ThresholdOf(kVariableType<Cal3_S2>, EntryKind::kCalibration), 4.0);
  EXPECT_EQ(r.ThresholdOf(kVariableType<Cal3_S2>, EntryKind::kOther), 0.5);
  // The defaults: 0.1 for every kind, as GTSAM's single relinearize threshold.
  const Isam2Params::Relinearization d;
  for (EntryKind k : {EntryKind::kTranslation, EntryKind::kRotation, EntryKind::kCalibration,
                      EntryKind::kOther}) {
    EXPECT_EQ(d.ThresholdOf(kVariableType<Pose2>, k), 0.1);
  }
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
      {{.relinearization = {.calibration_threshold = 0.0}},
       "relinearization.calibration_threshold"},
      {{.relinearization = {.other_threshold = -1.0}}, "relinearization.other_threshold"},
      {{.relinearization = {.per_type = {{.type = "Pose4"}}}},
       "per_type: unknown variable type 'Pose4'"},
      {{.relinearization = {.per_type = {{.type = "Cal3DS2", .threshold = 0.0}}}},
       "per_type[Cal3DS2].threshold"},
      {{.relinearization = {.error_threshold = -1.0}}, "relinearization.error_threshold"},
      {{.relinearization = {.skip = 0}}, "relinearization.skip"},
      {{.relinearization = {.max_variables = -1}}, "relinearization.max_variables"},
      {{.wildfire_threshold = -0.1}, "wildfire_threshold"},
      {{.refine_threshold = 0.0}, "refine_threshold"},
      {{.refine_max_variables = -1}, "refine_max_variables"},
      {{.batch_every = -2}, "batch_every"},
      {{.max_landmarks_last = -1}, "max_landmarks_last"},
      {{.trust_region = {.initial_radius = 0.0}}, "trust_region.initial_radius"},
      {{.trust_region = {.min_radius = -1.0}}, "trust_region.min_radius"},
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
