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

// Which calibration parameters a model refines: a zero column is held; SIMPLE_PINHOLE ties fy to
// fx; the principal point only on request.
TEST(CalibrationBasisTest, FollowsTheModel) {
  const Cal3_S2 K(500.0, 500.0, 0.0, 320.0, 240.0);
  auto held = [](const Eigen::MatrixXd& basis) {
    std::vector<int> out;
    for (int c = 0; c < basis.cols(); ++c) {
      if (basis.col(c).isZero()) out.push_back(c);
    }
    return out;
  };
  using Held = std::vector<int>;
  EXPECT_EQ(held(CalibrationBasis({.calibration = K}, true)), Held{});
  EXPECT_EQ(held(CalibrationBasis({.calibration = K}, false)), (Held{3, 4}));
  EXPECT_EQ(held(CalibrationBasis({.calibration = K, .model = "PINHOLE"}, true)), Held{2});
  const Eigen::MatrixXd simple =
      CalibrationBasis({.calibration = K, .model = "SIMPLE_PINHOLE"}, false);
  EXPECT_EQ(held(simple), (Held{1, 2, 3, 4}));
  EXPECT_EQ(simple.col(0), (Eigen::VectorXd(5) << 1, 1, 0, 0, 0).finished());
  const Cal3DS2 opencv(K, 0.1, 0.01, 0.0, 0.0);
  EXPECT_EQ(held(CalibrationBasis({.calibration = opencv, .model = "OPENCV"}, false)),
            (Held{2, 3, 4}));
  const Cal3Bundler bundler(500.0, 0.1, 0.01);
  EXPECT_EQ(held(CalibrationBasis({.calibration = bundler, .model = "SIMPLE_RADIAL"}, false)),
            Held{2});
  EXPECT_EQ(held(CalibrationBasis({.calibration = bundler, .model = "RADIAL"}, false)), Held{});
  EXPECT_EQ(held(CalibrationBasis({.calibration = bundler}, false)), Held{});
}

}  // namespace
}  // namespace slamd::core
