// `slamctl plot --live` against the real `slamd` over UDP multicast (udpm://, ttl=0), inside a
// private network namespace made by scripts/netns-run (ctest label netns; skipped with 77 where
// none can be made). The approach of server_replay_netns_test.cc: fork/exec the binaries
// (SLAMD_PATH, SLAMCTL_PATH), wait for slamd's first status_t, stop it with SIGTERM.
//  1. `slamctl replay intel.g2o --lockstep` into slamd, then `slamctl plot --live --covariances
//     -o x.png`: exit 0, every pose of intel plotted with ellipses, and the PNG has the requested
//     size and the robot's colour in it (read back with Cairo, loaded at run time: this test
//     links only slamd_server and core);
//  2. slamd stopped: `slamctl plot --live` exits 1 with a timeout message naming the reply;
//  3. argument errors (exit 2): datasets with --live, --lcm-url without --live.
#include <cairo/cairo.h>
#include <dlfcn.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "core/io/dataset.h"
#include "server/transport/lcm_bus.h"
#include "server/transport/typed_subscribe.h"
#include "slamd/status_t.hpp"
#include "tests/testing/datasets.h"
#include "tests/testing/processes.h"

namespace slamd::server {
namespace {

using testing::CommandRun;

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";

// A running slamd, listening once its first status_t is seen; stopped with SIGTERM (exit 0).
class Slamd {
 public:
  explicit Slamd(const std::string& config) {
    auto bus = LcmBus::Create(LcmBusParams{.url = kUrl});
    EXPECT_TRUE(bus.ok()) << bus.status().ToString();
    if (!bus.ok()) return;
    int statuses = 0;
    Subscription sub = Subscribe<slamd::status_t>(
                           **bus, "SLAMD_STATUS",
                           [&](std::string_view, const slamd::status_t&) { ++statuses; }, nullptr)
                           .value();
    pid_ = testing::Spawn({SLAMD_PATH, "--config", config, "--lcm-url", kUrl});
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (statuses == 0 && std::chrono::steady_clock::now() < deadline) {
      if (!(*bus)->HandleOnce(20).ok()) break;
    }
    listening = statuses > 0;
  }
  ~Slamd() {
    if (pid_ <= 0) return;
    kill(pid_, SIGTERM);
    EXPECT_EQ(testing::WaitExit(pid_), 0) << "slamd did not stop cleanly";
  }
  bool listening = false;

 private:
  pid_t pid_ = -1;
};

// Runs slamctl with `args`; stdout and stderr captured.
CommandRun Slamctl(std::vector<std::string> args, double timeout_s = 40) {
  args.insert(args.begin(), SLAMCTL_PATH);
  return testing::RunCommand(args, testing::Streams::kStdoutAndStderr, timeout_s);
}

// What the test reads from a PNG: its size and how many pixels are strongly coloured (the
// background, grid, axes and text are white, grey or black; robots, ellipses and landmarks are
// in the palette's colours). Cairo is opened at run time (see the file comment).
struct PngInfo {
  bool readable = false;
  int width = 0, height = 0;
  long coloured = 0;   // max − min channel > 60
  long non_white = 0;  // any channel < 250
};

PngInfo ReadPng(const std::string& path) {
  PngInfo info;
  void* lib = dlopen("libcairo.so.2", RTLD_NOW | RTLD_LOCAL);
  if (lib == nullptr) return info;
  const auto sym = [lib](const char* name) { return dlsym(lib, name); };
  auto create = reinterpret_cast<decltype(&cairo_image_surface_create_from_png)>(
      sym("cairo_image_surface_create_from_png"));
  auto status = reinterpret_cast<decltype(&cairo_surface_status)>(sym("cairo_surface_status"));
  auto width = reinterpret_cast<decltype(&cairo_image_surface_get_width)>(
      sym("cairo_image_surface_get_width"));
  auto height = reinterpret_cast<decltype(&cairo_image_surface_get_height)>(
      sym("cairo_image_surface_get_height"));
  auto stride = reinterpret_cast<decltype(&cairo_image_surface_get_stride)>(
      sym("cairo_image_surface_get_stride"));
  auto format = reinterpret_cast<decltype(&cairo_image_surface_get_format)>(
      sym("cairo_image_surface_get_format"));
  auto data = reinterpret_cast<decltype(&cairo_image_surface_get_data)>(
      sym("cairo_image_surface_get_data"));
  auto destroy = reinterpret_cast<decltype(&cairo_surface_destroy)>(sym("cairo_surface_destroy"));
  if (!create || !status || !width || !height || !stride || !format || !data || !destroy) {
    dlclose(lib);
    return info;
  }
  cairo_surface_t* s = create(path.c_str());
  const cairo_format_t f = format(s);
  if (status(s) == CAIRO_STATUS_SUCCESS && (f == CAIRO_FORMAT_ARGB32 || f == CAIRO_FORMAT_RGB24)) {
    info.readable = true;
    info.width = width(s);
    info.height = height(s);
    const unsigned char* pixels = data(s);
    for (int y = 0; y < info.height; ++y) {
      const auto* row = reinterpret_cast<const std::uint32_t*>(pixels + y * stride(s));
      for (int x = 0; x < info.width; ++x) {
        // Native-endian 0xAARRGGBB (premultiplied; a PNG plot is opaque).
        const int r = (row[x] >> 16) & 0xff, g = (row[x] >> 8) & 0xff, b = row[x] & 0xff;
        if (std::max({r, g, b}) - std::min({r, g, b}) > 60) ++info.coloured;
        if (std::min({r, g, b}) < 250) ++info.non_white;
      }
    }
  }
  destroy(s);
  dlclose(lib);
  return info;
}

TEST(ServerPlotNetnsTest, PlotsTheLiveMapOfAReplay) {
  ASSERT_TRUE(testing::OnlyLoopback()) << testing::kNotInNetns;
  const std::string config = testing::WriteTempFile(
      "slamd_plot.textproto", "publish { status_rate_hz: 20 }\nlog_level: \"warn\"\n");
  const std::string intel = std::string(SLAMD_TEST_DATA) + "/../../scripts/data/intel.g2o";
  core::Result<core::Dataset> dataset = core::ReadDataset(intel);
  ASSERT_TRUE(dataset.ok()) << dataset.status().ToString();
  const std::size_t poses = dataset->poses.size();
  const std::string png = testing::WriteTempFile("live_map.png", "");

  // 1. A replayed intel, plotted from the live server with its marginals.
  {
    Slamd slamd(config);
    ASSERT_TRUE(slamd.listening) << "no status_t from slamd";
    const CommandRun replay =
        Slamctl({"replay", intel, "--lockstep", "-q", "--lcm-url", kUrl, "--settle-timeout", "20"});
    ASSERT_EQ(replay.exit_code, 0) << replay.out;
    const CommandRun plot = Slamctl({"plot", "--live", "--covariances", "-o", png, "--size",
                                     "900x700", "--lcm-url", kUrl, "--timeout", "20"});
    ASSERT_EQ(plot.exit_code, 0) << plot.out;
    EXPECT_NE(plot.out.find("wrote " + png + " (900x700): 1 robots, " + std::to_string(poses) +
                            " poses, 0 landmarks, "),
              std::string::npos)
        << plot.out;
    // About 50 pose ellipses (every K-th pose and the last), all present (no "not ready").
    const std::size_t every = (poses + 49) / 50;
    const std::size_t ellipses = (poses + every - 1) / every + ((poses - 1) % every != 0);
    EXPECT_NE(plot.out.find(std::to_string(ellipses) + " ellipses"), std::string::npos)
        << plot.out << " (expected " << ellipses << " ellipses)";
    EXPECT_EQ(plot.out.find("warning"), std::string::npos) << plot.out;
    const PngInfo info = ReadPng(png);
    ASSERT_TRUE(info.readable) << png;
    EXPECT_EQ(info.width, 900);
    EXPECT_EQ(info.height, 700);
    EXPECT_GT(info.non_white, 20000) << "the picture is (nearly) blank";
    EXPECT_GT(info.coloured, 3000) << "no trajectory or ellipses in the robot's colour";
  }

  // 2. No server: a timeout (exit 1) that says what did not arrive.
  const CommandRun none =
      Slamctl({"plot", "--live", "-o", png, "--lcm-url", kUrl, "--timeout", "1"});
  EXPECT_EQ(none.exit_code, 1) << none.out;
  EXPECT_NE(none.out.find("timed out after 1 s waiting for the query_reply_t for request"),
            std::string::npos)
      << none.out;
  EXPECT_NE(none.out.find("is slamd running on"), std::string::npos) << none.out;

  // 3. Argument errors: exit 2 with a message, before any traffic.
  const CommandRun both = Slamctl({"plot", "--live", intel, "-o", png});
  EXPECT_EQ(both.exit_code, 2) << both.out;
  EXPECT_NE(both.out.find("--live"), std::string::npos) << both.out;
  const CommandRun url = Slamctl({"plot", intel, "--lcm-url", kUrl, "-o", png});
  EXPECT_EQ(url.exit_code, 2) << url.out;
  EXPECT_NE(url.out.find("--live"), std::string::npos) << url.out;
  const CommandRun optimize = Slamctl({"plot", "--live", "--optimize", "-o", png});
  EXPECT_EQ(optimize.exit_code, 2) << optimize.out;
}

}  // namespace
}  // namespace slamd::server
