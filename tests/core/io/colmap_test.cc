// COLMAP's text model (core/io/sfm_io.h): a hand-written model with every supported camera
// model, keypoints without a 3-D point and an image without any is read with the conventions of
// sfm_io.h and round trips through WriteColmapText; malformed files name their line (both lines
// when a track disagrees with images.txt); what COLMAP cannot hold is refused; a BAL problem
// written as COLMAP reads back the same.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <filesystem>
#include <limits>
#include <string>

#include "core/io/sfm_io.h"
#include "tests/testing/datasets.h"
#include "tests/testing/files.h"
#include "tests/testing/sfm_reconstructions.h"

namespace slamd::core {
namespace {

using slamd::testing::BundlerReprojectionCost;
using slamd::testing::ExpectSameReconstruction;
using slamd::testing::ReadFileBytes;
using slamd::testing::SharedDatasetPath;
using slamd::testing::TempDir;
using slamd::testing::WriteFileBytes;
using ::testing::HasSubstr;

// The model's three files; the tests below refer to their line numbers.
constexpr const char* kColmapCameras =
    "# Camera list with one line of data per camera:\n"
    "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
    "1 SIMPLE_PINHOLE 640 480 500.5 320 240\n"                             // line 3
    "2 PINHOLE 640 480 510.25 505.75 319.5 239.5\n"                        // line 4
    "5 SIMPLE_RADIAL 1024 768 800.1 512.3 384.7 -0.013\n"                  // line 5
    "7 RADIAL 1024 768 790.2 511.9 383.1 -0.02 0.0031\n"                   // line 6
    "9 OPENCV 1280 720 900.5 901.5 640.2 360.3 -0.1 0.02 0.001 -0.002\n";  // line 7

constexpr const char* kColmapImages =
    "# Image list with two lines of data per image:\n"
    "10 0.9 0.1 -0.2 0.3 1.5 -2.25 3.125 1 img10.jpg\n"                      // line 2
    "100.5 200.25 3 300.5 -1 -1 400.125 50.5 4\n"                            // line 3
    "11 1 0 0 0 0 0 0 2 img11.jpg\n"                                         // line 4
    "1 2 3\n"                                                                // line 5
    "12 0.7071067811865476 0 0.7071067811865476 0 -1 0 2 5 sub/img12.png\n"  // line 6
    "10.1 20.2 4 30.3 40.4 -1 50.5 60.6 3\n"                                 // line 7
    "13 0.5 0.5 0.5 0.5 0.1 0.2 0.3 7 img13.jpg\n"                           // line 8
    "\n"                                                                     // line 9: no points
    "# a comment between images\n"                                           // line 10
    "14 0.99 -0.01 0.02 -0.03 4 5 6 9 img14.jpg\n"                           // line 11
    "700.7 300.3 4\n";                                                       // line 12

constexpr const char* kColmapPoints =
    "# 3D point list with one line of data per point:\n"
    "3 1.5 2.5 3.5 255 128 0 0.75 10 0 12 2 11 0\n"  // line 2
    "4 -1 -2 10.5 10 20 30 -1 10 2 12 0 14 0\n"      // line 3
    "5 0 0 0 1 2 3 0\n";                             // line 4

// A COLMAP model directory holding the three files, each optionally edited.
class ColmapModelDir {
 public:
  ColmapModelDir() {
    WriteFileBytes(cameras(), kColmapCameras);
    WriteFileBytes(images(), kColmapImages);
    WriteFileBytes(points(), kColmapPoints);
  }
  const std::string& path() const { return dir_.path(); }
  std::string cameras() const { return dir_.File("cameras.txt"); }
  std::string images() const { return dir_.File("images.txt"); }
  std::string points() const { return dir_.File("points3D.txt"); }

  // Replaces the first `from` in `file` by `to`.
  void Edit(const std::string& file, const std::string& from, const std::string& to) {
    std::string text = ReadFileBytes(file);
    const std::size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    WriteFileBytes(file, text.replace(at, from.size(), to));
  }

 private:
  TempDir dir_{"slamd_colmap_"};
};

Reconstruction MustReadColmap(const std::string& dir) {
  Result<Reconstruction> r = ReadColmapText(dir);
  EXPECT_TRUE(r.ok()) << r.status().ToString();
  return r.ok() ? std::move(r).value() : Reconstruction{};
}

TEST(ColmapTest, ReadsCamerasWithTheirModels) {
  ColmapModelDir dir;
  const Reconstruction r = MustReadColmap(dir.path());
  ASSERT_EQ(r.intrinsics.size(), 5u);
  const SfmIntrinsics& simple_pinhole = r.intrinsics[0];
  EXPECT_EQ(std::get<Cal3_S2>(simple_pinhole.calibration).vector(),
            Cal3_S2(500.5, 500.5, 0, 320, 240).vector());
  EXPECT_EQ(simple_pinhole.model, "SIMPLE_PINHOLE");
  EXPECT_EQ(simple_pinhole.width, 640);
  EXPECT_EQ(simple_pinhole.height, 480);
  EXPECT_EQ(simple_pinhole.id, 1u);
  EXPECT_EQ(std::get<Cal3_S2>(r.intrinsics[1].calibration).vector(),
            Cal3_S2(510.25, 505.75, 0, 319.5, 239.5).vector());
  const SfmIntrinsics& simple_radial = r.intrinsics[2];
  EXPECT_EQ(std::get<Cal3Bundler>(simple_radial.calibration).vector(),
            Cal3Bundler(800.1, -0.013, 0).vector());
  EXPECT_EQ(simple_radial.principal_point, Eigen::Vector2d(512.3, 384.7));
  EXPECT_EQ(simple_radial.model, "SIMPLE_RADIAL");
  EXPECT_EQ(std::get<Cal3Bundler>(r.intrinsics[3].calibration).vector(),
            Cal3Bundler(790.2, -0.02, 0.0031).vector());
  EXPECT_EQ(r.intrinsics[3].principal_point, Eigen::Vector2d(511.9, 383.1));
  EXPECT_EQ(std::get<Cal3DS2>(r.intrinsics[4].calibration).vector(),
            Cal3DS2(Cal3_S2(900.5, 901.5, 0, 640.2, 360.3), -0.1, 0.02, 0.001, -0.002).vector());
  EXPECT_EQ(r.intrinsics[4].id, 9u);
  EXPECT_EQ(r.intrinsics[4].width, 1280);
}

TEST(ColmapTest, ReadsWorldToCameraPosesAsTwc) {
  ColmapModelDir dir;
  const Reconstruction r = MustReadColmap(dir.path());
  ASSERT_EQ(r.images.size(), 5u);
  const SfmImage& image = r.images[0];
  EXPECT_EQ(image.id, 10u);
  EXPECT_EQ(image.name, "img10.jpg");
  EXPECT_EQ(image.intrinsics, 0);
  const Eigen::Matrix3d R_cw = Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3).normalized().matrix();
  const Pose3 T_cw = image.pose.Inverse();
  EXPECT_TRUE(T_cw.rotation().Equals(Rot3(R_cw), 1e-15));
  EXPECT_LE((T_cw.translation() - Point3(1.5, -2.25, 3.125)).norm(), 1e-14);
  // The camera centre is -R_cwᵀ t_cw.
  EXPECT_LE((image.pose.translation() + R_cw.transpose() * Point3(1.5, -2.25, 3.125)).norm(),
            1e-14);
  EXPECT_EQ(r.images[2].name, "sub/img12.png");
  EXPECT_EQ(r.images[2].intrinsics, 2);  // CAMERA_ID 5
  EXPECT_EQ(r.images[4].intrinsics, 4);  // CAMERA_ID 9
}

TEST(ColmapTest, ReadsObservationsInImageOrderAndPoints) {
  ColmapModelDir dir;
  const Reconstruction r = MustReadColmap(dir.path());
  struct Expected {
    int image, point;
    Eigen::Vector2d uv;
  };
  // The keypoints with POINT3D_ID -1 are dropped; image 13 has none; SIMPLE_RADIAL's pixels
  // (image 12) are relative to its principal point.
  const Expected expected[] = {
      {0, 0, {100.5, 200.25}},
      {0, 1, {400.125, 50.5}},
      {1, 0, {1, 2}},
      {2, 1, {10.1 - 512.3, 20.2 - 384.7}},
      {2, 0, {50.5 - 512.3, 60.6 - 384.7}},
      {4, 1, {700.7, 300.3}},
  };
  ASSERT_EQ(r.observations.size(), std::size(expected));
  for (std::size_t o = 0; o < r.observations.size(); ++o) {
    EXPECT_EQ(r.observations[o].image, expected[o].image) << o;
    EXPECT_EQ(r.observations[o].point, expected[o].point) << o;
    EXPECT_EQ(r.observations[o].uv, expected[o].uv) << o;
  }
  ASSERT_EQ(r.points.size(), 3u);
  EXPECT_EQ(r.points[0].id, 3u);
  EXPECT_EQ(r.points[0].position, Point3(1.5, 2.5, 3.5));
  EXPECT_EQ(r.points[0].color, (std::array<std::uint8_t, 3>{255, 128, 0}));
  EXPECT_EQ(r.points[0].error, 0.75);
  EXPECT_EQ(r.points[1].error, -1.0);
  EXPECT_EQ(r.points[2].id, 5u);  // a point with an empty track
  EXPECT_TRUE(r.Validate().ok());
}

TEST(ColmapTest, WriteReadRoundTrip) {
  ColmapModelDir dir;
  const Reconstruction r = MustReadColmap(dir.path());
  TempDir out("slamd_colmap_out_", /*create=*/false);
  ASSERT_TRUE(WriteColmapText(r, out.path()).ok());
  // Poses go through the quaternion and the inverse twice; the Cal3Bundler pixels through the
  // principal-point shift.
  ExpectSameReconstruction(r, MustReadColmap(out.path()), 1e-14, 1e-12);
  // Keypoints without a point are not written; an image without observations has an empty line.
  const std::string images = ReadFileBytes(out.File("images.txt"));
  EXPECT_THAT(images, HasSubstr("\n100.5 200.25 3 400.125 50.5 4\n"));
  EXPECT_THAT(images, HasSubstr(" 7 img13.jpg\n\n"));
  EXPECT_THAT(ReadFileBytes(out.File("points3D.txt")),
              HasSubstr("\n3 1.5 2.5 3.5 255 128 0 0.75 10 0 11 0 12 1\n"));
  EXPECT_THAT(ReadFileBytes(out.File("cameras.txt")),
              HasSubstr("\n5 SIMPLE_RADIAL 1024 768 800.1 512.3 384.7 -0.013\n"));
}

struct BadColmap {
  const char* file;  // "cameras", "images" or "points"
  const char* from;
  const char* to;
  int line;                     // where the message says the problem is
  const char* message;          // a part of the message after "FILE:LINE: "
  const char* other = nullptr;  // the other file a track mismatch names ("images" or "points")
  int other_line = 0;
};

TEST(ColmapTest, MalformedFilesNameTheLine) {
  const BadColmap cases[] = {
      {"cameras", "500.5 320 240", "500.5 320", 3,
       "expected CAMERA_ID SIMPLE_PINHOLE WIDTH HEIGHT f cx cy (7 fields, not 6)"},
      {"cameras", "OPENCV", "THIN_PRISM_FISHEYE", 7, "unknown camera model 'THIN_PRISM_FISHEYE'"},
      {"cameras", "2 PINHOLE", "1 PINHOLE", 4, "duplicate CAMERA_ID 1 (first at line 3)"},
      {"cameras", "640 480 510.25", "640 -480 510.25", 4, "expected HEIGHT (an integer in"},
      {"images", "-2.25 3.125", "-2.25 abc", 2, "expected TZ (a finite number), got 'abc'"},
      {"images", "100.5 200.25", "nan 200.25", 3,
       "expected X of 2D point 0 (a finite number), got 'nan'"},
      {"images", "300.5 -1 -1", "300.5 -1 -2", 3,
       "expected POINT3D_ID (or -1) of 2D point 1 (an integer in [0, 18446744073709551614]), "
       "got '-2'"},
      {"images", "0 0 2 img11", "0 0 3 img11", 4, "unknown CAMERA_ID 3"},
      {"images", "11 1 0", "10 1 0", 4, "duplicate IMAGE_ID 10 (first at line 2)"},
      {"images", "\n1 2 3\n", "\n1 2\n", 5, "(a multiple of 3 fields, not 2)"},
      {"images", "13 0.5 0.5 0.5 0.5", "13 0 0 0 0", 8,
       "expected a quaternion QW QX QY QZ of finite, non-zero norm"},
      {"images", "img14.jpg\n700.7 300.3 4\n", "img14.jpg\n", 11,
       "expected the image's 2D points (X Y POINT3D_ID ...) on the next line, got the end of "
       "the file"},
      {"images", "0 2 5 sub/img12.png", "0 2 5 sub/img 12.png", 6,
       "expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME (10 fields, or 9 without NAME, not "
       "11)"},
      {"points", "255 128 0", "256 128 0", 2, "expected R (an integer in [0, 255]), got '256'"},
      {"points", "14 0\n", "14\n", 3, "(8 + an even number of fields, not 13)"},
      {"points", "\n5 0 0", "\n4 0 0", 4, "duplicate POINT3D_ID 4 (first at line 3)"},
      {"points", "14 0\n", "15 0\n", 3,
       "track element 2 (IMAGE_ID 15, POINT2D_IDX 0): unknown IMAGE_ID"},
      {"points", "10 2 12 0", "10 5 12 0", 3,
       "track element 0 (IMAGE_ID 10, POINT2D_IDX 5): the image has 3 2D points", "images", 3},
      {"points", "10 0 12 2", "10 0 12 1", 2,
       "track element 1 (IMAGE_ID 12, POINT2D_IDX 1) of POINT3D_ID 3: ", "images", 7},
      {"points", "10 0 12 2 11 0", "10 0 12 2 12 2", 2,
       "track element 2 (IMAGE_ID 12, POINT2D_IDX 2) is listed twice"},
  };
  for (const BadColmap& c : cases) {
    ColmapModelDir dir;
    const std::string file = std::string(c.file) == "cameras"  ? dir.cameras()
                             : std::string(c.file) == "images" ? dir.images()
                                                               : dir.points();
    dir.Edit(file, c.from, c.to);
    const Result<Reconstruction> r = ReadColmapText(dir.path());
    ASSERT_FALSE(r.ok()) << c.from << " -> " << c.to;
    EXPECT_EQ(r.status().code(), StatusCode::kDataLoss) << r.status().message();
    EXPECT_THAT(r.status().message(),
                ::testing::StartsWith(file + ":" + std::to_string(c.line) + ": "));
    EXPECT_THAT(r.status().message(), HasSubstr(c.message));
    if (c.other != nullptr) {
      const std::string other = std::string(c.other) == "images" ? dir.images() : dir.points();
      EXPECT_THAT(r.status().message(), HasSubstr(other + ":" + std::to_string(c.other_line)));
    }
  }
}

TEST(ColmapTest, TwoDPointsMissingFromTracksNameBothLines) {
  {
    ColmapModelDir dir;
    dir.Edit(dir.points(), " 11 0\n", "\n");  // point 3's track no longer lists (11, 0)
    const Status s = ReadColmapText(dir.path()).status();
    EXPECT_EQ(s.message(), dir.images() +
                               ":5: 2D point 0 observes POINT3D_ID 3, but the point's track (" +
                               dir.points() + ":2) does not list (11, 0)");
  }
  {
    ColmapModelDir dir;
    dir.Edit(dir.points(), "4 -1 -2 10.5 10 20 30 -1 10 2 12 0 14 0\n", "");
    const Status s = ReadColmapText(dir.path()).status();
    EXPECT_EQ(s.message(), dir.images() + ":3: 2D point 2 observes POINT3D_ID 4, which is not in " +
                               dir.points());
  }
}

TEST(ColmapTest, MissingDirectoryOrFileIsNotFound) {
  EXPECT_EQ(ReadColmapText(::testing::TempDir() + "slamd_no_such_model").status().code(),
            StatusCode::kNotFound);
  ColmapModelDir dir;
  std::filesystem::remove(dir.points());
  const Status s = ReadColmapText(dir.path()).status();
  EXPECT_EQ(s.code(), StatusCode::kNotFound);
  EXPECT_THAT(s.message(), HasSubstr("points3D.txt"));
}

TEST(ColmapTest, WriteRefusesWhatColmapCannotHold) {
  ColmapModelDir dir;
  const Reconstruction good = MustReadColmap(dir.path());
  TempDir out("slamd_colmap_refused_", /*create=*/false);
  const auto expect_refused = [&](const Reconstruction& r, const std::string& message) {
    const Status s = WriteColmapText(r, out.path());
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument) << message;
    EXPECT_THAT(s.message(), HasSubstr(message));
    EXPECT_FALSE(std::filesystem::exists(out.path())) << message;
  };
  Reconstruction r = good;
  r.intrinsics[0].calibration = Cal3_S2(500, 501, 0, 320, 240);
  expect_refused(r, "intrinsics 0 (model 'SIMPLE_PINHOLE'): fx != fy");
  r = good;
  r.intrinsics[1].calibration = Cal3_S2(500, 500, 1, 320, 240);
  expect_refused(r, "intrinsics 1 (model 'PINHOLE'): COLMAP has no skew");
  r = good;
  r.intrinsics[2].calibration = Cal3Bundler(800, -0.01, 0.001);
  expect_refused(r, "intrinsics 2 (model 'SIMPLE_RADIAL'): k2 != 0");
  r = good;
  r.intrinsics[3].model = "FOV";
  expect_refused(r, "intrinsics 3 (model 'FOV'): not a model slamd writes");
  r = good;
  r.intrinsics[4].calibration = Cal3_S2(500, 500, 0, 320, 240);
  expect_refused(r, "intrinsics 4 (model 'OPENCV'): the model needs a Cal3DS2 calibration");
  r = good;
  r.images[1].name = "with blank.jpg";
  expect_refused(r, "image 1's name 'with blank.jpg' has a blank");
  r = good;
  r.images[3].id = 11;
  expect_refused(r, "images 1 and 3 have the same IMAGE_ID 11");
  r = good;
  r.points[2].id = std::numeric_limits<std::uint64_t>::max();
  expect_refused(r, "point 2 has id 2^64-1");
  r = good;
  r.observations[0].image = 7;
  expect_refused(r, "observation 0");
}

// A BAL problem has no model names: its Cal3Bundler cameras are written as RADIAL and read back
// with the same numbers, the observations grouped by image (BAL files group them by point).
TEST(ColmapTest, BalProblemAsColmapReadsBackTheSame) {
  const std::string path = SharedDatasetPath("bal/dubrovnik-3-7-pre.txt");
  SLAMD_SKIP_IF_NO_SHARED_DATASET(path);
  Result<Reconstruction> bal = ReadBal(path);
  ASSERT_TRUE(bal.ok()) << bal.status().ToString();
  TempDir out("slamd_colmap_bal_", /*create=*/false);
  ASSERT_TRUE(WriteColmapText(*bal, out.path()).ok());
  const Reconstruction colmap = MustReadColmap(out.path());
  const double cost = BundlerReprojectionCost(*bal);
  EXPECT_NEAR(BundlerReprojectionCost(colmap), cost, 1e-12 * cost);
  for (SfmIntrinsics& k : bal->intrinsics) k.model = "RADIAL";
  std::ranges::stable_sort(bal->observations, {}, &SfmObservation::image);
  ExpectSameReconstruction(*bal, colmap, 1e-12, 0.0);
}

}  // namespace
}  // namespace slamd::core
