// Tests of the Cairo renderer: the files are valid PNG/SVG/PDF of the requested size, the PNG has
// the trajectory's colour where the layout puts it and background in the margins, the layout
// keeps equal aspect and contains the scene, tick steps are 1/2/5 × 10^k.
#include "clients/slamctl/plot_render.h"

#include <cairo.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <string>

#include "tests/testing/datasets.h"
#include "tests/testing/files.h"

namespace slamd::clients::plot {
namespace {

// An L-shaped trajectory from (0, 0) to (100, 0) to (100, 50), a landmark and an ellipse.
PlotScene LScene() {
  PlotScene scene;
  scene.title = "test: 3 poses";
  scene.subtitle = "subtitle";
  PlotRobot r;
  r.name = "robot a";
  r.trajectory = {{0.0, 0.0}, {100.0, 0.0}, {100.0, 50.0}};
  r.landmarks = {{50.0, 30.0}};
  r.loop_closures = {{{0.0, 0.0}, {100.0, 50.0}}};
  r.pose_ellipses = {Ellipse{.center = {100.0, 0.0}, .semi_major = 5.0, .semi_minor = 2.0, .angle = 0.3}};
  scene.robots.push_back(r);
  return scene;
}

struct Image {
  int width = 0, height = 0;
  cairo_status_t status = CAIRO_STATUS_NULL_POINTER;
  std::vector<std::uint32_t> argb;  // premultiplied ARGB32, row-major
  std::uint32_t At(int x, int y) const { return argb[static_cast<std::size_t>(y) * width + x]; }
};

Image ReadPng(const std::string& path) {
  Image img;
  cairo_surface_t* s = cairo_image_surface_create_from_png(path.c_str());
  img.status = cairo_surface_status(s);
  if (img.status == CAIRO_STATUS_SUCCESS) {
    cairo_surface_flush(s);
    img.width = cairo_image_surface_get_width(s);
    img.height = cairo_image_surface_get_height(s);
    const int stride = cairo_image_surface_get_stride(s);
    const unsigned char* data = cairo_image_surface_get_data(s);
    for (int y = 0; y < img.height; ++y) {
      const auto* row = reinterpret_cast<const std::uint32_t*>(data + static_cast<std::size_t>(y) * stride);
      img.argb.insert(img.argb.end(), row, row + img.width);
    }
  }
  cairo_surface_destroy(s);
  return img;
}

bool IsWhite(std::uint32_t p) { return (p & 0xffffff) == 0xffffff; }
int Red(std::uint32_t p) { return (p >> 16) & 0xff; }
int Blue(std::uint32_t p) { return p & 0xff; }

TEST(NiceStepTest, OneTwoFiveTimesPowersOfTen) {
  EXPECT_DOUBLE_EQ(NiceStep(10.0, 5), 2.0);
  EXPECT_DOUBLE_EQ(NiceStep(100.0, 4), 20.0);  // 25: 20 is nearer than 50 in log scale
  EXPECT_DOUBLE_EQ(NiceStep(7.0, 7), 1.0);
  EXPECT_NEAR(NiceStep(0.3, 3), 0.1, 1e-15);
  EXPECT_DOUBLE_EQ(NiceStep(4000.0, 1), 5000.0);
  EXPECT_DOUBLE_EQ(NiceStep(80.0, 1), 100.0);
}

TEST(PlotFormatTest, FromPathAndName) {
  EXPECT_EQ(*PlotFormatFromPath("a/b.png"), PlotFormat::kPng);
  EXPECT_EQ(*PlotFormatFromPath("x.SVG"), PlotFormat::kSvg);
  EXPECT_EQ(*PlotFormatFromPath("x.pdf"), PlotFormat::kPdf);
  for (const char* bad : {"x.jpg", "x", "dir.png/x", "x."}) {
    const core::Result<PlotFormat> f = PlotFormatFromPath(bad);
    ASSERT_FALSE(f.ok()) << bad;
    EXPECT_NE(f.status().message().find(".png"), std::string::npos) << f.status().message();
  }
  EXPECT_EQ(*ParsePlotFormat("svg"), PlotFormat::kSvg);
  EXPECT_FALSE(ParsePlotFormat("gif").ok());
}

TEST(LayoutTest, EqualAspectAndSceneInsidePlotArea) {
  const PlotScene scene = LScene();
  const PlotLayout L = ComputeLayout(scene, 1200, 900);
  const Eigen::Vector2d o = L.ToPage({0.0, 0.0});
  EXPECT_NEAR((L.ToPage({1.0, 0.0}) - o).norm(), (L.ToPage({0.0, 1.0}) - o).norm(), 1e-12);
  EXPECT_LT(L.ToPage({0.0, 1.0}).y(), o.y());  // y up
  const Box b = scene.Bounds();
  for (const Eigen::Vector2d& corner : {b.min, b.max, Eigen::Vector2d(b.min.x(), b.max.y())}) {
    const Eigen::Vector2d p = L.ToPage(corner);
    EXPECT_GT(p.x(), L.area_x);
    EXPECT_LT(p.x(), L.area_x + L.area_w);
    EXPECT_GT(p.y(), L.area_y);
    EXPECT_LT(p.y(), L.area_y + L.area_h);
  }
  EXPECT_LT(L.area_x + L.area_w, L.legend_x);
}

TEST(RenderTest, PngHasRequestedSizeTrajectoryAndBackgroundMargins) {
  const PlotScene scene = LScene();
  for (const auto& [w, h] : {std::pair{1200, 900}, std::pair{640, 480}}) {
    const std::string path = testing::WriteTempFile("plot.png", "");
    ASSERT_TRUE(RenderScene(scene, path, {.width = w, .height = h}).ok());
    EXPECT_EQ(testing::ReadFileBytes(path).substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
    const Image img = ReadPng(path);
    ASSERT_EQ(img.status, CAIRO_STATUS_SUCCESS);
    EXPECT_EQ(img.width, w);
    EXPECT_EQ(img.height, h);
    const PlotLayout L = ComputeLayout(scene, w, h);
    // On the trajectory (mid-segments, away from the ellipse and the loop closure): robot 0's
    // colour (Okabe-Ito blue: more blue than red).
    // Lines are antialiased: take the most saturated pixel of the 3x3 window around the point.
    for (const Eigen::Vector2d& world : {Eigen::Vector2d(30.0, 0.0), Eigen::Vector2d(100.0, 30.0)}) {
      const Eigen::Vector2d p = L.ToPage(world);
      const int cx = static_cast<int>(std::floor(p.x())), cy = static_cast<int>(std::floor(p.y()));
      std::uint32_t px = 0xffffffff;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const std::uint32_t q = img.At(cx + dx, cy + dy);
          if (Blue(q) - Red(q) > Blue(px) - Red(px)) px = q;
        }
      }
      EXPECT_GT(Blue(px), Red(px) + 80) << w << " at " << world.transpose() << ": " << std::hex << px;
    }
    // ... and not elsewhere: 20 page units beside the trajectory there is no blue.
    for (const Eigen::Vector2d& world : {Eigen::Vector2d(30.0, 0.0), Eigen::Vector2d(100.0, 30.0)}) {
      const Eigen::Vector2d p = L.ToPage(world) + Eigen::Vector2d(-20.0, -20.0);
      const std::uint32_t q = img.At(static_cast<int>(p.x()), static_cast<int>(p.y()));
      EXPECT_LT(Blue(q) - Red(q), 20) << w << " near " << world.transpose() << ": " << std::hex << q;
    }
    // Background in the margins: the page corners.
    for (const auto& [x, y] : {std::pair{1, 1}, std::pair{w - 2, 1}, std::pair{1, h - 2}, std::pair{w - 2, h - 2}}) {
      EXPECT_TRUE(IsWhite(img.At(x, y))) << x << "," << y;
    }
  }
}

TEST(RenderTest, EmptySceneRenders) {
  const std::string path = testing::WriteTempFile("empty.png", "");
  EXPECT_TRUE(RenderScene(PlotScene{}, path, {}).ok());
  EXPECT_EQ(ReadPng(path).width, 1200);
}

TEST(RenderTest, SvgHasRequestedSize) {
  const std::string path = testing::WriteTempFile("plot.svg", "");
  ASSERT_TRUE(RenderScene(LScene(), path, {.width = 800, .height = 600, .format = PlotFormat::kSvg}).ok());
  const std::string svg = testing::ReadFileBytes(path);
  const std::size_t tag = svg.find("<svg");
  ASSERT_NE(tag, std::string::npos);
  const std::string head = svg.substr(tag, svg.find('>', tag) - tag);
  EXPECT_NE(head.find("width=\"800"), std::string::npos) << head;
  EXPECT_NE(head.find("height=\"600"), std::string::npos) << head;
}

TEST(RenderTest, PdfStartsWithSignature) {
  const std::string path = testing::WriteTempFile("plot.pdf", "");
  ASSERT_TRUE(RenderScene(LScene(), path, {.format = PlotFormat::kPdf}).ok());
  const std::string pdf = testing::ReadFileBytes(path);
  EXPECT_EQ(pdf.substr(0, 5), "%PDF-");
  EXPECT_NE(pdf.find("/MediaBox [ 0 0 1200 900 ]"), std::string::npos);
}

TEST(RenderTest, ErrorsAreStatuses) {
  for (PlotFormat f : {PlotFormat::kPng, PlotFormat::kSvg, PlotFormat::kPdf}) {
    const core::Status s = RenderScene(LScene(), "/nonexistent-dir/x", {.format = f});
    EXPECT_EQ(s.code(), core::StatusCode::kIoError) << s.ToString();
  }
  EXPECT_EQ(RenderScene(LScene(), "/tmp/x.png", {.width = 10}).code(), core::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace slamd::clients::plot
