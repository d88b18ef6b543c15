// Reconstruction::Validate: a consistent reconstruction passes; each kind of broken index and
// non-finite number is reported with the offending element.
#include "core/sfm/reconstruction.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace slamd::core {
namespace {

using ::testing::HasSubstr;

// Two images sharing one camera, two points, three observations.
Reconstruction SmallReconstruction() {
  Reconstruction r;
  r.intrinsics.resize(1);
  r.intrinsics[0].calibration = Cal3_S2(500, 500, 0, 320, 240);
  r.images.resize(2);
  r.images[1].pose = Pose3(Rot3(), Point3(1, 0, 0));
  r.points.resize(2);
  r.points[1].position = Point3(0, 0, 5);
  r.observations = {{.image = 0, .point = 0, .uv = Vector2(320, 240)},
                    {.image = 1, .point = 0, .uv = Vector2(220, 240)},
                    {.image = 1, .point = 1, .uv = Vector2(200, 240)}};
  return r;
}

void ExpectInvalid(const Reconstruction& r, const std::string& message) {
  const Status s = r.Validate();
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument) << message;
  EXPECT_THAT(s.message(), HasSubstr(message));
}

TEST(ReconstructionTest, ConsistentReconstructionIsValid) {
  EXPECT_TRUE(Reconstruction().Validate().ok());
  EXPECT_TRUE(SmallReconstruction().Validate().ok());
}

TEST(ReconstructionTest, IndicesOutOfRange) {
  Reconstruction r = SmallReconstruction();
  r.images[1].intrinsics = 1;
  ExpectInvalid(r, "image 1: intrinsics index 1 out of range [0, 1)");
  r = SmallReconstruction();
  r.observations[2].point = 2;
  ExpectInvalid(r, "observation 2: image 1 / point 2 out of range (2 images, 2 points)");
  r = SmallReconstruction();
  r.observations[0].image = -1;
  ExpectInvalid(r, "observation 0: image -1 / point 0 out of range");
}

TEST(ReconstructionTest, NonFiniteNumbers) {
  Reconstruction r = SmallReconstruction();
  r.intrinsics[0].calibration = Cal3Bundler(NAN, 0, 0);
  ExpectInvalid(r, "intrinsics 0: a parameter is not finite");
  r = SmallReconstruction();
  r.intrinsics[0].principal_point.x() = INFINITY;
  ExpectInvalid(r, "intrinsics 0: a parameter is not finite");
  r = SmallReconstruction();
  r.images[0].pose = Pose3(Rot3(), Point3(NAN, 0, 0));
  ExpectInvalid(r, "image 0: pose is not finite");
  r = SmallReconstruction();
  r.points[1].position.z() = NAN;
  ExpectInvalid(r, "point 1: position is not finite");
  r = SmallReconstruction();
  r.observations[1].uv.y() = -INFINITY;
  ExpectInvalid(r, "observation 1: pixel is not finite");
}

}  // namespace
}  // namespace slamd::core
