// Tests of the camera worlds (sim_camera_world.h): what an observation must satisfy, the cost of
// the ground truth (zero without noise, sigma's rms with), outliers, stereo, the BAL conversion,
// the files read back, and bundle adjustment from the initial guess to the noise level.
#include "clients/slamctl/sim_camera_world.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <variant>

#include "core/ba/bundle_adjuster.h"
#include "core/geometry/camera.h"
#include "core/io/sfm_io.h"
#include "tests/testing/files.h"
#include "tests/testing/sfm_reconstructions.h"

namespace slamd::clients::sim {
namespace {

// Pixel errors |projection - measured| of every observation, with any calibration.
std::vector<double> CameraWorldErrors(const core::Reconstruction& r) {
  std::vector<double> errors;
  for (const core::SfmObservation& o : r.observations) {
    const core::SfmImage& image = r.images[o.image];
    const core::Projection p = std::visit(
        [&](const auto& K) { return core::Project(image.pose, K, r.points[o.point].position); },
        r.intrinsics[image.intrinsics].calibration);
    errors.push_back((p.uv - o.uv).norm());
  }
  return errors;
}

// √(Σ |e|² / (2·observations)): the rms error per pixel axis (sigma for Gaussian noise).
double CameraWorldRmsPerAxis(const core::Reconstruction& r) {
  double sum = 0.0;
  const std::vector<double> errors = CameraWorldErrors(r);
  for (double e : errors) sum += e * e;
  return std::sqrt(sum / (2.0 * std::max<std::size_t>(1, errors.size())));
}

CameraSimParams SmallWorld(CameraWorldKind kind) {
  return kind == CameraWorldKind::kCity
             ? CameraSimParams{.world = kind, .cameras = 30, .points = 1500}
             : CameraSimParams{.world = kind, .cameras = 16, .points = 400};
}

CameraWorld MakeCameraWorld(const CameraSimParams& params) {
  core::Result<CameraWorld> world = GenerateCameraWorld(params);
  EXPECT_TRUE(world.ok()) << world.status().ToString();
  return world.ok() ? std::move(world).value() : CameraWorld{};
}

class CameraWorldKindTest : public ::testing::TestWithParam<CameraWorldKind> {};

TEST_P(CameraWorldKindTest, ObservationsAreVisibleOrderedAndEnough) {
  CameraSimParams params = SmallWorld(GetParam());
  params.noise_free = true;
  const CameraWorld world = MakeCameraWorld(params);
  const core::Reconstruction& r = world.truth;
  ASSERT_TRUE(r.Validate().ok());
  EXPECT_GE(r.images.size(), params.cameras * 3 / 4);
  EXPECT_LE(r.images.size(), static_cast<std::size_t>(params.cameras));
  EXPECT_GT(r.points.size(), 100u);
  ASSERT_EQ(r.intrinsics.size(), 1u);
  EXPECT_EQ(r.intrinsics[0].model, "PINHOLE");
  EXPECT_EQ(r.intrinsics[0].width, 640);
  std::vector<int> views(r.points.size(), 0), seen(r.images.size(), 0);
  for (std::size_t k = 0; k < r.observations.size(); ++k) {
    const core::SfmObservation& o = r.observations[k];
    ++views[o.point];
    ++seen[o.image];
    EXPECT_GE(o.uv.x(), 0.0);
    EXPECT_LT(o.uv.x(), 640.0);
    EXPECT_GE(o.uv.y(), 0.0);
    EXPECT_LT(o.uv.y(), 480.0);
    EXPECT_GT(r.images[o.image].pose.TransformTo(r.points[o.point].position).z(), 0.0);
    if (k > 0) {  // image by image, points ascending
      const core::SfmObservation& prev = r.observations[k - 1];
      EXPECT_TRUE(prev.image < o.image || (prev.image == o.image && prev.point < o.point)) << k;
    }
  }
  for (int v : views) EXPECT_GE(v, 2);
  for (int s : seen) EXPECT_GE(s, kMinImageObservations);
  // Noise-free: the ground truth reprojects exactly; the initial guess does not.
  EXPECT_LT(CameraWorldRmsPerAxis(r), 1e-9);
  EXPECT_GT(CameraWorldRmsPerAxis(world.initial), 1.0);
  EXPECT_EQ(world.initial.observations.size(), r.observations.size());
}

TEST_P(CameraWorldKindTest, PixelNoiseAndOutliersAsAsked) {
  CameraSimParams params = SmallWorld(GetParam());
  params.sigma_pixel = 0.7;
  const CameraWorld noisy = MakeCameraWorld(params);
  EXPECT_NEAR(CameraWorldRmsPerAxis(noisy.truth), 0.7, 0.05);
  EXPECT_TRUE(noisy.outliers.empty());

  params.outliers = 0.1;
  const CameraWorld world = MakeCameraWorld(params);
  const std::size_t n = world.truth.observations.size();
  EXPECT_EQ(world.outliers.size(), static_cast<std::size_t>(std::llround(0.1 * n)));
  EXPECT_TRUE(std::is_sorted(world.outliers.begin(), world.outliers.end()));
  // The outliers are the observations far off (a random pixel); the others are noise.
  const std::vector<double> errors = CameraWorldErrors(world.truth);
  std::vector<bool> outlier(n, false);
  for (int k : world.outliers) outlier[k] = true;
  std::size_t far_outliers = 0;
  for (std::size_t k = 0; k < n; ++k) {
    if (outlier[k]) {
      far_outliers += errors[k] > 10.0;
    } else {
      EXPECT_LT(errors[k], 0.7 * 6) << k;
    }
  }
  EXPECT_GT(far_outliers, world.outliers.size() * 9 / 10);
}

TEST_P(CameraWorldKindTest, SameSeedSameWorld) {
  const CameraSimParams params = SmallWorld(GetParam());
  const CameraWorld a = MakeCameraWorld(params), b = MakeCameraWorld(params);
  testing::ExpectSameReconstruction(a.initial, b.initial, 0.0, 0.0);
  CameraSimParams other = params;
  other.seed = 2;
  EXPECT_NE(MakeCameraWorld(other).truth.observations.size(), a.truth.observations.size());
}

INSTANTIATE_TEST_SUITE_P(Worlds, CameraWorldKindTest,
                         ::testing::Values(CameraWorldKind::kCity, CameraWorldKind::kObject),
                         [](const auto& info) {
                           return info.param == CameraWorldKind::kCity ? "City" : "Object";
                         });

TEST(SimCameraWorldTest, StereoIsTheRectifiedPairsProjection) {
  CameraSimParams params = SmallWorld(CameraWorldKind::kObject);
  params.stereo = true;
  params.noise_free = true;
  params.baseline = 0.3;
  params.outliers = 0.05;
  const CameraWorld world = MakeCameraWorld(params);
  const core::Reconstruction& r = world.truth;
  ASSERT_GT(world.stereo.size(), r.observations.size() / 2);
  for (const StereoObservation& s : world.stereo) {
    EXPECT_FALSE(std::binary_search(world.outliers.begin(), world.outliers.end(), s.observation));
    const core::SfmObservation& o = r.observations[s.observation];
    const double depth = r.images[o.image].pose.TransformTo(r.points[o.point].position).z();
    // A pinhole camera without noise: the left pixel is the monocular one.
    EXPECT_NEAR(s.uuv.x(), o.uv.x(), 1e-9);
    EXPECT_NEAR(s.uuv.z(), o.uv.y(), 1e-9);
    EXPECT_NEAR(s.uuv.x() - s.uuv.y(), params.focal * 0.3 / depth, 1e-9);
    EXPECT_GE(s.uuv.y(), 0.0);
  }
  // Stereo comes last: the rest of the world does not change with it.
  params.stereo = false;
  testing::ExpectSameReconstruction(MakeCameraWorld(params).initial, world.initial, 0.0, 0.0);
}

TEST(SimCameraWorldTest, BalConversionKeepsTheReprojectionErrors) {
  CameraSimParams params = SmallWorld(CameraWorldKind::kObject);
  params.model = CameraModel::kOpenCv;
  params.k1 = -0.05;
  params.k2 = 0.01;
  const CameraWorld world = MakeCameraWorld(params);
  ASSERT_TRUE(std::holds_alternative<core::Cal3DS2>(world.truth.intrinsics[0].calibration));
  const core::Reconstruction bal = AsBal(world.initial);
  ASSERT_EQ(bal.intrinsics.size(), bal.images.size());
  const std::vector<double> a = CameraWorldErrors(world.initial), b = CameraWorldErrors(bal);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) EXPECT_NEAR(a[k], b[k], 1e-9) << k;
  // An independent formula for BAL's camera agrees.
  double cost = 0.0;
  for (double e : a) cost += 0.5 * e * e;
  EXPECT_NEAR(testing::BundlerReprojectionCost(bal), cost, 1e-9 * cost);
}

TEST(SimCameraWorldTest, WrittenFilesReadBack) {
  CameraSimParams params = SmallWorld(CameraWorldKind::kCity);
  params.stereo = true;
  params.outliers = 0.02;
  const CameraWorld world = MakeCameraWorld(params);
  testing::TempDir dir("slamd_camworld_");
  std::vector<std::string> written;
  ASSERT_TRUE(WriteCameraWorld(world, CameraFormat::kBoth, dir.path(), &written).ok());
  EXPECT_EQ(written,
            (std::vector<std::string>{"problem.bal", "groundtruth.bal", "colmap/",
                                      "groundtruth_colmap/", "outliers.txt", "stereo.txt"}));
  for (const auto& [file, model] :
       {std::pair{"problem.bal", &world.initial}, std::pair{"groundtruth.bal", &world.truth}}) {
    core::Result<core::Reconstruction> bal = core::ReadBal(dir.File(file));
    ASSERT_TRUE(bal.ok()) << bal.status().ToString();
    EXPECT_EQ(bal->images.size(), model->images.size()) << file;
    EXPECT_EQ(bal->points.size(), model->points.size()) << file;
    ASSERT_EQ(bal->observations.size(), model->observations.size()) << file;
    const std::vector<double> read = CameraWorldErrors(*bal), made = CameraWorldErrors(*model);
    for (std::size_t k = 0; k < read.size(); ++k) ASSERT_NEAR(read[k], made[k], 1e-6) << file;
  }
  for (const auto& [name, model] :
       {std::pair{"colmap", &world.initial}, std::pair{"groundtruth_colmap", &world.truth}}) {
    core::Result<core::Reconstruction> colmap = core::ReadColmapText(dir.File(name));
    ASSERT_TRUE(colmap.ok()) << colmap.status().ToString();
    testing::ExpectSameReconstruction(*colmap, *model, 1e-12, 0.0);
  }
  // outliers.txt and stereo.txt: a '#' header, then one line per outlier / measurement.
  const auto data_lines = [&](const std::string& file) {
    std::ifstream in(dir.File(file));
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);) {
      if (line.empty() || line[0] != '#') lines.push_back(line);
    }
    return lines;
  };
  const std::vector<std::string> outliers = data_lines("outliers.txt");
  ASSERT_EQ(outliers.size(), world.outliers.size());
  ASSERT_FALSE(outliers.empty());
  std::istringstream first(outliers.front());
  int k = -1, image = -1, point = -1;
  first >> k >> image >> point;
  EXPECT_EQ(k, world.outliers.front());
  EXPECT_EQ(image, world.truth.observations[k].image);
  EXPECT_EQ(point, world.truth.observations[k].point);
  const std::vector<std::string> stereo = data_lines("stereo.txt");
  ASSERT_EQ(stereo.size(), world.stereo.size() + 1);
  EXPECT_EQ(stereo.front(), "CALIBRATION 500 500 320 240 0.5 1");
  EXPECT_EQ(stereo[1].rfind("STEREO " + std::to_string(world.stereo[0].observation) + " ", 0), 0u);
  // ReadStereoFile gives back what was written.
  core::Result<StereoFile> read = ReadStereoFile(dir.File("stereo.txt"));
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ(read->baseline, 0.5);
  ASSERT_EQ(read->stereo.size(), world.stereo.size());
  for (std::size_t i = 0; i < world.stereo.size(); ++i) {
    EXPECT_EQ(read->stereo[i].observation, world.stereo[i].observation);
    EXPECT_LT((read->stereo[i].uuv - world.stereo[i].uuv).norm(), 1e-9);
  }
  // A line that does not parse is named.
  std::ofstream(dir.File("bad.txt")) << "CALIBRATION 500 500 320 240 0.5 1\nSTEREO 1 2 x\n";
  const core::Result<StereoFile> bad = ReadStereoFile(dir.File("bad.txt"));
  EXPECT_EQ(bad.status().code(), core::StatusCode::kInvalidArgument);
  EXPECT_NE(bad.status().message().find("bad.txt:2:"), std::string::npos) << bad.status().message();
  EXPECT_EQ(ReadStereoFile(dir.File("missing.txt")).status().code(), core::StatusCode::kNotFound);
}

// From the perturbed initial guess, bundle adjustment reaches the noise level: no worse than the
// truth, and the rms error per axis is what least squares leaves of the noise, σ·√((m − p)/m)
// for m residuals and p free parameters (6 per pose, 3 per point and per BAL calibration, less
// the 7 of the similarity gauge).
TEST(SimCameraWorldTest, BundleAdjustmentReachesTheNoiseLevel) {
  constexpr double kSigma = 0.5;
  for (CameraWorldKind kind : {CameraWorldKind::kObject, CameraWorldKind::kCity}) {
    CameraSimParams params = SmallWorld(kind);
    params.sigma_pixel = kSigma;
    const CameraWorld world = MakeCameraWorld(params);
    // BAL: one Cal3Bundler per image, refined with its pose; COLMAP: one fixed PINHOLE camera.
    for (const bool bal : {true, false}) {
      SCOPED_TRACE(std::string(CameraWorldKindName(kind)) + (bal ? " BAL" : " COLMAP"));
      core::Reconstruction r = bal ? AsBal(world.initial) : world.initial;
      core::Result<core::BundleAdjusterSummary> summary =
          core::BundleAdjust(core::BundleAdjusterParams{}, &r);
      ASSERT_TRUE(summary.ok()) << summary.status().ToString();
      const double m = 2.0 * r.observations.size();
      const double p = (bal ? 9.0 : 6.0) * r.images.size() + 3.0 * r.points.size() - 7.0;
      const double final_rms = CameraWorldRmsPerAxis(r);
      EXPECT_GT(summary->initial_cost, 10 * summary->final_cost);
      EXPECT_LE(final_rms, CameraWorldRmsPerAxis(world.truth) * (1 + 1e-6));
      EXPECT_NEAR(final_rms, kSigma * std::sqrt((m - p) / m), 0.05 * kSigma);
      EXPECT_NEAR(summary->rms_reprojection_px, std::sqrt(2.0) * final_rms, 1e-9);
    }
  }
}

TEST(SimCameraWorldTest, InvalidParamsNameTheField) {
  const struct {
    CameraSimParams params;
    std::string field;
  } cases[] = {
      {{.cameras = 1}, "CameraSimParams::cameras = 1"},
      {{.points = -3}, "CameraSimParams::points"},
      {{.width = 8}, "CameraSimParams::width"},
      {{.focal = 0.0}, "CameraSimParams::focal"},
      {{.k1 = 0.1}, "CameraSimParams::k1 = 0.100000; violates == 0 for the PINHOLE model"},
      {{.sigma_pixel = NAN}, "CameraSimParams::sigma_pixel"},
      {{.outliers = 1.5}, "CameraSimParams::outliers"},
      {{.init_sigma_point = INFINITY}, "CameraSimParams::init_sigma_point"},
      {{.baseline = -1.0}, "CameraSimParams::baseline"},
  };
  for (const auto& c : cases) {
    const core::Result<CameraWorld> world = GenerateCameraWorld(c.params);
    ASSERT_FALSE(world.ok()) << c.field;
    EXPECT_EQ(world.status().code(), core::StatusCode::kInvalidArgument);
    EXPECT_NE(world.status().message().find(c.field), std::string::npos)
        << world.status().message();
  }
  // Too few points for any image to keep enough of them.
  const core::Result<CameraWorld> sparse = GenerateCameraWorld({.points = 3});
  ASSERT_FALSE(sparse.ok());
  EXPECT_NE(sparse.status().message().find("more points"), std::string::npos)
      << sparse.status().message();
}

}  // namespace
}  // namespace slamd::clients::sim
