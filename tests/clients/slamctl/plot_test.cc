// Runs the slamctl binary: `slamctl plot` on small datasets (2D with landmarks, 3D, two robots)
// to PNG, SVG and PDF, and its argument errors (exit 2 with a message).
#include <cairo.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "server/estimator/estimator.h"
#include "server/journal/snapshot_file.h"
#include "server/snapshot/estimator_state.h"
#include "server/snapshot/state_codec.h"
#include "tests/clients/slamctl/slamctl_runner.h"
#include "tests/testing/datasets.h"
#include "tests/testing/files.h"

namespace slamd::clients {
namespace {

using testing::RunSlamctl;
using testing::SlamctlRun;

// Width and height of a PNG file as Cairo reads it (0, 0 if unreadable).
std::pair<int, int> PngSize(const std::string& path) {
  cairo_surface_t* s = cairo_image_surface_create_from_png(path.c_str());
  std::pair<int, int> size{0, 0};
  if (cairo_surface_status(s) == CAIRO_STATUS_SUCCESS) {
    size = {cairo_image_surface_get_width(s), cairo_image_surface_get_height(s)};
  }
  cairo_surface_destroy(s);
  return size;
}

// A 3D pose graph: a square loop of 4 poses with a loop closure, climbing in z.
std::string Write3dDataset() {
  std::string text;
  const double xy[4][2] = {{0, 0}, {2, 0}, {2, 2}, {0, 2}};
  for (int i = 0; i < 4; ++i) {
    text += "VERTEX_SE3:QUAT " + std::to_string(i) + " " + std::to_string(xy[i][0]) + " " +
            std::to_string(xy[i][1]) + " " + std::to_string(0.1 * i) + " 0 0 0 1\n";
  }
  const std::string info = " 100 0 0 0 0 0 100 0 0 0 0 100 0 0 0 400 0 0 400 0 400\n";
  text += "EDGE_SE3:QUAT 0 1 2 0 0.1 0 0 0 1" + info;
  text += "EDGE_SE3:QUAT 1 2 0 2 0.1 0 0 0 1" + info;
  text += "EDGE_SE3:QUAT 2 3 -2 0 0.1 0 0 0 1" + info;
  text += "EDGE_SE3:QUAT 3 0 0 -2 -0.3 0 0 0 1" + info;
  return testing::WriteTempFile("square3d.g2o", text);
}

TEST(PlotTest, PngOfSmallDatasetWithCovariances) {
  const std::string out = testing::WriteTempFile("small.png", "");
  const SlamctlRun r = RunSlamctl("plot " + testing::TestDataPath("small_slam2d.g2o") +
                                  " --optimize --covariances --ellipse-every 1 -o " + out);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("5 poses, 2 landmarks, 1 loop closures, 7 ellipses"), std::string::npos)
      << r.out;
  EXPECT_EQ(PngSize(out), std::make_pair(1200, 900));
}

TEST(PlotTest, SvgOfRequestedSize) {
  const std::string out = testing::WriteTempFile("small.svg", "");
  const SlamctlRun r =
      RunSlamctl("plot " + testing::TestDataPath("small_slam2d.g2o") + " --size 800x500 -o " + out);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const std::string svg = testing::ReadFileBytes(out);
  const std::size_t tag = svg.find("<svg");
  ASSERT_NE(tag, std::string::npos);
  const std::string head = svg.substr(tag, svg.find('>', tag) - tag);
  EXPECT_NE(head.find("width=\"800"), std::string::npos) << head;
  EXPECT_NE(head.find("height=\"500"), std::string::npos) << head;
}

TEST(PlotTest, ThreeDimensionalAndTwoRobotsToPdf) {
  const std::string data3d = Write3dDataset();
  const std::string out = testing::WriteTempFile("two.pdf", "");
  const SlamctlRun r = RunSlamctl("plot " + testing::TestDataPath("small_slam2d.g2o") + " " +
                                  data3d + " --optimize --covariances -o " + out);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("9 poses, 2 landmarks, 2 loop closures"), std::string::npos) << r.out;
  EXPECT_EQ(testing::ReadFileBytes(out).substr(0, 5), "%PDF-");
  // --format overrides the extension.
  const std::string forced = testing::WriteTempFile("forced.out", "");
  const SlamctlRun f = RunSlamctl("plot " + data3d + " --format png -o " + forced);
  ASSERT_EQ(f.exit_code, 0) << f.out;
  EXPECT_EQ(PngSize(forced), std::make_pair(1200, 900));
}

TEST(PlotTest, ArgumentErrorsExitTwoWithAMessage) {
  const std::string data = testing::TestDataPath("small_slam2d.g2o");
  struct Case {
    std::string args, message;
  };
  for (const Case& c :
       {Case{"plot " + data + " -o /tmp/slamd_plot_test.jpg", "*.png"},
        Case{"plot /nonexistent/file.g2o -o /tmp/slamd_plot_test.png", "/nonexistent/file.g2o"},
        Case{"plot " + data + " --bogus -o /tmp/slamd_plot_test.png", "--bogus"},
        Case{"plot " + data + " --size 12x -o /tmp/slamd_plot_test.png", "WIDTHxHEIGHT"},
        Case{"plot " + data + " --size 10x10 -o /tmp/slamd_plot_test.png", "out of range"},
        Case{"plot " + data + " --format gif -o /tmp/slamd_plot_test.png", "gif"},
        Case{"plot " + data + " -o /nonexistent-dir/x.png", "/nonexistent-dir does not exist"},
        Case{"plot " + data, "--output"}}) {
    const SlamctlRun r = RunSlamctl(c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.out;
    EXPECT_NE(r.out.find(c.message), std::string::npos) << c.args << "\n" << r.out;
  }
}

// A slamd snapshot (written as the daemon writes one) plots one robot per robot in it.
TEST(PlotTest, SnapshotFilePlotsEveryRobot) {
  auto estimator = server::Estimator::Create({}, {}).value();
  std::vector<server::Inbound> msgs;
  for (const char* robot : {"a", "b"}) {
    const core::NoiseModel noise = core::NoiseModel::Isotropic(3, 0.1).value();
    msgs.push_back({server::PriorMeasurement{1, robot, 0, server::PriorKind::kPose2,
                                             core::Pose2(robot[0] == 'a' ? 0 : 5, 0, 0), noise},
                    0});
    for (std::uint64_t i = 0; i < 8; ++i) {
      msgs.push_back(
          {server::OdometryMeasurement{2, robot, i, i + 1, core::Pose2(1, 0, 0.5), noise}, 0});
    }
  }
  ASSERT_TRUE(estimator->Process(msgs).status.ok());
  const std::string dir =
      std::filesystem::path(testing::WriteTempFile("snapshot_dir_marker", "")).parent_path() /
      "slamd_plot_snapshot";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const core::Result<std::string> file = server::WriteSnapshotFile(
      dir, 1, server::EncodeState(estimator->ExportState(), {.last_message_sequence = 19}));
  ASSERT_TRUE(file.ok()) << file.status().ToString();
  const std::string out = testing::WriteTempFile("snapshot.png", "");
  const SlamctlRun r = RunSlamctl("plot --snapshot " + *file + " --covariances -o " + out);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("18 poses, 0 landmarks"), std::string::npos) << r.out;
  EXPECT_EQ(PngSize(out), std::make_pair(1200, 900));
  const SlamctlRun both = RunSlamctl("plot --snapshot " + *file + " " +
                                     testing::TestDataPath("small_slam2d.g2o") + " -o " + out);
  EXPECT_EQ(both.exit_code, 2) << both.out;
  EXPECT_NE(both.out.find("--snapshot"), std::string::npos) << both.out;
  std::filesystem::remove_all(dir);
}

// A small simulated reconstruction, BAL and COLMAP, plotted as it is and bundle-adjusted.
TEST(PlotTest, ReconstructionsToPngAndSvg) {
  testing::TempDir dir("slamd_plot_sfm_");
  const SlamctlRun sim =
      RunSlamctl("sim camera-object --cameras 12 --points 300 -o " + dir.File("world"));
  ASSERT_EQ(sim.exit_code, 0) << sim.out;
  const SlamctlRun bal = RunSlamctl("plot " + dir.File("world/problem.bal") +
                                    " --ba --size 640x480 -o " + dir.File("bal.png"));
  ASSERT_EQ(bal.exit_code, 0) << bal.out;
  EXPECT_NE(bal.out.find("bundle adjustment: cost"), std::string::npos) << bal.out;
  EXPECT_NE(bal.out.find("12 cameras, "), std::string::npos) << bal.out;
  EXPECT_EQ(PngSize(dir.File("bal.png")), std::make_pair(640, 480));
  // A COLMAP directory (with a trailing slash), in a plane of our choice.
  const SlamctlRun colmap =
      RunSlamctl("plot " + dir.File("world/colmap/") + " --plane xz -o " + dir.File("colmap.svg"));
  ASSERT_EQ(colmap.exit_code, 0) << colmap.out;
  EXPECT_NE(colmap.out.find("xz plane"), std::string::npos) << colmap.out;
  const std::string svg = testing::ReadFileBytes(dir.File("colmap.svg"));
  EXPECT_NE(svg.find("<svg"), std::string::npos);
}

TEST(PlotTest, ReconstructionErrorsExitWithAMessage) {
  testing::TempDir dir("slamd_plot_sfm_");
  ASSERT_EQ(RunSlamctl("sim camera-object --cameras 8 --points 200 -o " + dir.path()).exit_code, 0);
  const std::string bal = dir.File("problem.bal"), g2o = testing::TestDataPath("small_slam2d.g2o");
  const std::string out = " -o " + dir.File("x.png");
  testing::WriteFileBytes(dir.File("bad.bal"), "2 1 1\n0 0 1.5 oops\n");
  std::filesystem::create_directories(dir.File("empty"));
  struct Case {
    std::string args, message;
    int code;
  };
  for (const Case& c : {
           Case{"plot " + g2o + " --ba" + out, "--ba bundle-adjusts a reconstruction", 2},
           Case{"plot " + bal + " --optimize" + out, "--ba", 2},
           Case{"plot " + bal + " --covariances" + out, "--covariances", 2},
           Case{"plot " + bal + " " + dir.File("colmap") + out, "plotted alone", 2},
           Case{"plot " + bal + " --plane zx" + out, "--plane", 2},
           Case{"plot " + g2o + " --plane xz" + out, "--plane is for reconstructions", 2},
           Case{"plot " + dir.File("bad.bal") + out, "bad.bal:2", 1},
           Case{"plot " + dir.File("empty") + out, "cameras.txt", 1},
       }) {
    const SlamctlRun r = RunSlamctl(c.args);
    EXPECT_EQ(r.exit_code, c.code) << c.args << "\n" << r.out;
    EXPECT_NE(r.out.find(c.message), std::string::npos) << c.args << "\n" << r.out;
  }
}

TEST(PlotTest, UnreadableDatasetFails) {
  const std::string bad = testing::WriteTempFile("bad.g2o", "VERTEX_SE2 0 zero 0 0\n");
  const SlamctlRun r = RunSlamctl("plot " + bad + " -o /tmp/slamd_plot_test_bad.png");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("bad.g2o"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace slamd::clients
