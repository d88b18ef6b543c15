// Runs the slamctl binary: `slamctl sim` writes deterministic worlds, and its argument errors
// exit 2 with a message naming the option.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "core/io/dataset.h"
#include "core/io/sfm_io.h"
#include "tests/clients/slamctl/slamctl_runner.h"
#include "tests/testing/files.h"

namespace slamd::clients {
namespace {

namespace fs = std::filesystem;

using testing::ReadFileBytes;
using testing::RunSlamctl;
using testing::SlamctlRun;

// A path for a directory the command creates; removed at the end of the scope.
class SimOutputDir : public testing::TempDir {
 public:
  SimOutputDir() : testing::TempDir("slamd_simcli_", /*create=*/false) {}
};

TEST(SimTest, SameSeedSameFiles) {
  SimOutputDir a, b, c;
  const std::string args = "sim landmarks --steps 120 --outliers 0.2 --loop-probability 0.8";
  const SlamctlRun ra = RunSlamctl(args + " --seed 5 -o " + a.path());
  ASSERT_EQ(ra.exit_code, 0) << ra.out;
  EXPECT_NE(ra.out.find("landmarks: 1 robot(s) x 120 poses"), std::string::npos) << ra.out;
  ASSERT_EQ(RunSlamctl(args + " --seed 5 -o " + b.path()).exit_code, 0);
  ASSERT_EQ(RunSlamctl(args + " --seed 6 -o " + c.path()).exit_code, 0);
  for (const char* f : {"world.g2o", "world.isam", "world_groundtruth.g2o",
                        "world_bearing_range.txt", "outliers.txt"}) {
    ASSERT_TRUE(fs::exists(a.File(f))) << f;
    EXPECT_EQ(ReadFileBytes(a.File(f)), ReadFileBytes(b.File(f))) << f;
  }
  EXPECT_NE(ReadFileBytes(a.File("world.g2o")), ReadFileBytes(c.File("world.g2o")));
  core::Result<core::Dataset> d = core::ReadDataset(a.File("world.g2o"));
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  EXPECT_EQ(d.value().poses.size(), 120u);
}

TEST(SimTest, EveryWorldAndSeveralRobots) {
  for (const char* world : {"manhattan", "sphere", "helix"}) {
    SimOutputDir dir;
    const SlamctlRun r =
        RunSlamctl(std::string("sim ") + world + " --steps 64 --robots 2 -o " + dir.path());
    ASSERT_EQ(r.exit_code, 0) << r.out;
    for (const char* f : {"robot0.g2o", "robot1.g2o", "robot0_groundtruth.g2o",
                          "robot1_groundtruth.g2o", "inter_robot.txt", "outliers.txt"}) {
      EXPECT_TRUE(fs::exists(dir.File(f))) << world << " " << f;
    }
    EXPECT_EQ(ReadFileBytes(dir.File("inter_robot.txt")).rfind("# slamctl sim", 0), 0u);
  }
  // An existing directory is fine (files are overwritten).
  SimOutputDir dir;
  ASSERT_EQ(RunSlamctl("sim manhattan --steps 10 -o " + dir.path()).exit_code, 0);
  EXPECT_EQ(RunSlamctl("sim manhattan --steps 10 -o " + dir.path()).exit_code, 0);
}

TEST(SimTest, CameraWorldsWriteBalColmapAndStereo) {
  SimOutputDir both, bal;
  const std::string args = "sim camera-object --cameras 12 --points 300 --outliers 0.1 --stereo";
  const SlamctlRun r = RunSlamctl(args + " -o " + both.path());
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("camera-object: 12 images, "), std::string::npos) << r.out;
  for (const char* f :
       {"problem.bal", "groundtruth.bal", "colmap/cameras.txt", "colmap/images.txt",
        "colmap/points3D.txt", "groundtruth_colmap/points3D.txt", "outliers.txt", "stereo.txt"}) {
    EXPECT_TRUE(fs::exists(both.File(f))) << f;
  }
  // The same seed gives the same files; --format bal writes only the BAL pair of them.
  ASSERT_EQ(RunSlamctl(args + " --format bal -o " + bal.path()).exit_code, 0);
  EXPECT_EQ(ReadFileBytes(bal.File("problem.bal")), ReadFileBytes(both.File("problem.bal")));
  EXPECT_FALSE(fs::exists(bal.File("colmap")));
  const core::Result<core::Reconstruction> problem = core::ReadBal(bal.File("problem.bal"));
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  EXPECT_EQ(problem->images.size(), 12u);
  const core::Result<core::Reconstruction> colmap = core::ReadColmapText(both.File("colmap"));
  ASSERT_TRUE(colmap.ok()) << colmap.status().ToString();
  EXPECT_EQ(colmap->observations.size(), problem->observations.size());
  // An OPENCV camera with distortion, in a city.
  SimOutputDir city;
  const SlamctlRun c = RunSlamctl(
      "sim camera-city --cameras 20 --points 800 --camera-model opencv --k1 -0.02 --image-size "
      "800x600 --focal 600 --format colmap -o " +
      city.path());
  ASSERT_EQ(c.exit_code, 0) << c.out;
  EXPECT_NE(ReadFileBytes(city.File("colmap/cameras.txt")).find("OPENCV 800 600 600 600 400 300"),
            std::string::npos);
}

TEST(SimTest, BadArgumentsExit2NamingTheOption) {
  SimOutputDir dir;
  const struct {
    std::string args;
    std::string expected;
  } cases[] = {
      {"sim manhattan --sigma-xy -1", "--sigma-xy"},
      {"sim manhattan --sigma-theta -0.1", "--sigma-theta"},
      {"sim landmarks --sigma-range -2", "--sigma-range"},
      {"sim manhattan --outliers 1.5", "--outliers"},
      {"sim manhattan --loop-probability -0.5", "--loop-probability"},
      {"sim manhattan --robots 0", "--robots"},
      {"sim manhattan --steps 1", "--steps"},
      {"sim landmarks --observation sonar", "--observation"},
      {"sim moon", "unknown world 'moon'"},
      {"sim manhattan --sigma-xy nan", "--sigma-xy"},
      {"sim landmarks --sigma-point inf", "--sigma-point"},
      {"sim camera-city --cameras 1", "--cameras"},
      {"sim camera-city --points -4", "--points"},
      {"sim camera-object --image-size 640", "--image-size"},
      {"sim camera-object --image-size 8x8", "--image-size"},
      {"sim camera-object --focal nan", "--focal"},
      {"sim camera-object --k1 0.1", "--k1"},
      {"sim camera-object --camera-model fisheye", "--camera-model"},
      {"sim camera-object --sigma-pixel -1", "--sigma-pixel"},
      {"sim camera-object --init-sigma-rotation inf", "--init-sigma-rotation"},
      {"sim camera-object --baseline 0.3", "--stereo"},
      {"sim camera-object --format ply", "--format"},
      {"sim camera-object --points 3", "more points"},
  };
  for (const auto& c : cases) {
    const SlamctlRun r = RunSlamctl(c.args + " -o " + dir.path());
    EXPECT_EQ(r.exit_code, 2) << c.args << ": " << r.out;
    EXPECT_NE(r.out.find(c.expected), std::string::npos) << c.args << ": " << r.out;
  }
  EXPECT_FALSE(fs::exists(dir.path()));  // nothing created on bad arguments
  // -o naming a file.
  const std::string file = ::testing::TempDir() + "slamd_simcli_file_" + std::to_string(getpid());
  std::ofstream(file) << "x";
  const SlamctlRun r = RunSlamctl("sim manhattan -o " + file);
  EXPECT_EQ(r.exit_code, 2) << r.out;
  EXPECT_NE(r.out.find("not a directory"), std::string::npos) << r.out;
  fs::remove(file);
}

TEST(SimTest, HelpExplainsEveryOption) {
  const SlamctlRun r = RunSlamctl("sim --help");
  EXPECT_EQ(r.exit_code, 0) << r.out;
  for (const char* option : {"--seed",         "--steps",       "--robots",
                             "--sigma-xy",     "--sigma-theta", "--loop-probability",
                             "--outliers",     "--noise-free",  "--landmarks",
                             "--sensor-range", "--observation", "--sigma-bearing",
                             "--sigma-range",  "--sigma-point", "-o",
                             "manhattan",      "landmarks",     "sphere",
                             "helix",          "groundtruth",   "inter_robot.txt",
                             "outliers.txt"}) {
    EXPECT_NE(r.out.find(option), std::string::npos) << option << " missing from\n" << r.out;
  }
}

TEST(SimTest, HelpExplainsTheCameraWorlds) {
  const SlamctlRun r = RunSlamctl("sim --help");
  EXPECT_EQ(r.exit_code, 0) << r.out;
  std::istringstream words(
      "camera-city camera-object --cameras --points --image-size --focal --camera-model --k1 --k2 "
      "--sigma-pixel --init-sigma-camera --init-sigma-rotation --init-sigma-point --stereo "
      "--baseline --format problem.bal groundtruth.bal colmap/ groundtruth_colmap/ stereo.txt");
  for (std::string word; words >> word;) {
    EXPECT_NE(r.out.find(word), std::string::npos) << word << " missing from\n" << r.out;
  }
}

}  // namespace
}  // namespace slamd::clients
