// The format-independent entry points of core/io/sfm_io.h: ReadReconstruction picks COLMAP for a
// directory and BAL for a file; WritePly writes points in their colour and camera centres in red,
// in a PLY header and body parsed back here.
#include "core/io/sfm_io.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "tests/testing/datasets.h"
#include "tests/testing/files.h"

namespace slamd::core {
namespace {

using slamd::testing::ReadFileBytes;
using slamd::testing::TempDir;
using slamd::testing::WriteFileBytes;
using slamd::testing::WriteTempFile;
using ::testing::HasSubstr;

TEST(ReadReconstructionTest, DirectoryIsColmapFileIsBal) {
  TempDir dir("slamd_sfm_io_");
  WriteFileBytes(dir.File("cameras.txt"), "1 PINHOLE 640 480 500 500 320 240\n");
  WriteFileBytes(dir.File("images.txt"), "7 1 0 0 0 0 0 0 1 a.png\n\n");
  WriteFileBytes(dir.File("points3D.txt"), "");
  Result<Reconstruction> colmap = ReadReconstruction(dir.path());
  ASSERT_TRUE(colmap.ok()) << colmap.status().ToString();
  ASSERT_EQ(colmap->images.size(), 1u);
  EXPECT_EQ(colmap->images[0].name, "a.png");

  const std::string bal = WriteTempFile("read_reconstruction.bal", "1 0 0 0 0 0 0 0 0 1 0 0\n");
  Result<Reconstruction> r = ReadReconstruction(bal);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_EQ(r->images.size(), 1u);
  EXPECT_EQ(r->intrinsics[0].model, "");

  EXPECT_EQ(ReadReconstruction(dir.File("nothing")).status().code(), StatusCode::kNotFound);
}

// Two coloured points and two cameras.
Reconstruction PlyExample() {
  Reconstruction r;
  r.intrinsics.resize(1);
  r.points.resize(2);
  r.points[0].position = Point3(0.5, -1.25, 2);
  r.points[0].color = {10, 20, 30};
  r.points[1].position = Point3(1e-3, 4, -7.75);
  r.points[1].color = {255, 255, 0};
  r.images.resize(2);
  r.images[0].pose = Pose3(Rot3::Exp(Vector3(0.1, 0.2, 0.3)), Point3(1, 2, 3));
  r.images[1].pose = Pose3(Rot3(), Point3(-4, 0, 0.125));
  return r;
}

TEST(WritePlyTest, PointsInTheirColourThenCameraCentresInRed) {
  const std::string path = WriteTempFile("cloud.ply", "");
  ASSERT_TRUE(WritePly(PlyExample(), path).ok());
  std::istringstream in(ReadFileBytes(path));
  std::vector<std::string> header;
  for (std::string line; std::getline(in, line) && line != "end_header";) header.push_back(line);
  ASSERT_GE(header.size(), 3u);
  EXPECT_EQ(header[0], "ply");
  EXPECT_EQ(header[1], "format ascii 1.0");
  const std::vector<std::string> properties(header.end() - 7, header.end());
  EXPECT_EQ(properties,
            (std::vector<std::string>{"element vertex 4", "property double x", "property double y",
                                      "property double z", "property uchar red",
                                      "property uchar green", "property uchar blue"}));
  struct Vertex {
    double x, y, z;
    int r, g, b;
  };
  std::vector<Vertex> vertices;
  for (Vertex v; in >> v.x >> v.y >> v.z >> v.r >> v.g >> v.b;) vertices.push_back(v);
  EXPECT_TRUE(in.eof());
  ASSERT_EQ(vertices.size(), 4u);
  EXPECT_EQ(vertices[0].x, 0.5);
  EXPECT_EQ(vertices[0].y, -1.25);
  EXPECT_EQ(vertices[0].z, 2.0);
  EXPECT_EQ((std::vector<int>{vertices[0].r, vertices[0].g, vertices[0].b}),
            (std::vector<int>{10, 20, 30}));
  EXPECT_EQ(vertices[1].x, 1e-3);
  EXPECT_EQ(vertices[1].b, 0);
  // The camera centres: the translations of T_wc.
  EXPECT_EQ(vertices[2].x, 1.0);
  EXPECT_EQ(vertices[2].z, 3.0);
  EXPECT_EQ(vertices[3].x, -4.0);
  EXPECT_EQ(vertices[3].z, 0.125);
  for (int k : {2, 3}) {
    EXPECT_EQ((std::vector<int>{vertices[k].r, vertices[k].g, vertices[k].b}),
              (std::vector<int>{255, 0, 0}));
  }
}

TEST(WritePlyTest, RefusesAnInvalidReconstruction) {
  Reconstruction r = PlyExample();
  r.points[1].position.x() = NAN;
  const std::string path = ::testing::TempDir() + "slamd_never_written.ply";
  const Status s = WritePly(r, path);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("point 1"));
  EXPECT_FALSE(std::filesystem::exists(path));
}

}  // namespace
}  // namespace slamd::core
