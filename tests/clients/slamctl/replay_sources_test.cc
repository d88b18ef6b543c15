// replay_sources: inter-robot file parsing, round-robin interleaving with closures sent once both
// poses were, LCM log detection by magic (not extension) and log reading with channel selection.
#include "clients/slamctl/replay_sources.h"

#include <gtest/gtest.h>

#include <lcm/lcm-cpp.hpp>

#include "server/messages/inbound.h"
#include "server/transport/typed_subscribe.h"
#include "tests/testing/datasets.h"

namespace slamd::clients {
namespace {

constexpr const char* kChain =
    "EDGE_SE2 0 1 1 0 0 10 0 0 10 0 10\n"
    "EDGE_SE2 1 2 1 0 0 10 0 0 10 0 10\n"
    "EDGE_SE2 2 3 1 0 0 10 0 0 10 0 10\n";

std::vector<StepMessages> Steps(const std::string& robot) {
  core::Result<core::Dataset> d = core::ReadDataset(testing::WriteTempFile("chain.g2o", kChain));
  EXPECT_TRUE(d.ok());
  return MakeDatasetMessages(*d, {.robot = robot}).value();
}

TEST(ReplaySourcesTest, ParsesInterRobotLines) {
  std::string se3 = "INTER_SE3 a 1 b 2 1 2 3 0 0 0 1";
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j) se3 += i == j ? " 4" : " 0";
  auto closures = ParseInterRobot(
      "# comment\n\nINTER_SE2 a 3 b 0 1.5 -0.5 0.25 100 0 0 100 0 400  # trailing\n" + se3 + "\n",
      "f");
  ASSERT_TRUE(closures.ok()) << closures.status().ToString();
  ASSERT_EQ(closures->size(), 2u);
  const slamd::loop_closure_t& m = (*closures)[0].message;
  EXPECT_EQ((*closures)[0].line, 3);
  EXPECT_EQ(m.robot_a, "a");
  EXPECT_EQ(m.pose_a, 3);
  EXPECT_EQ(m.robot_b, "b");
  EXPECT_EQ(m.pose_b, 0);
  EXPECT_EQ(m.values, (std::vector<double>{1.5, -0.5, 0.25}));
  EXPECT_NEAR(m.covariance[0], 0.01, 1e-15);
  EXPECT_NEAR(m.covariance[8], 0.0025, 1e-15);
  const slamd::loop_closure_t& m3 = (*closures)[1].message;
  EXPECT_EQ(m3.dimension, slamd::loop_closure_t::DIMENSION_3D);
  EXPECT_NEAR(m3.values[3], 1.0, 1e-15);  // qw first on the wire
  EXPECT_NEAR(m3.covariance[0], 0.25, 1e-15);
  EXPECT_TRUE(server::Convert(m).ok());
  EXPECT_TRUE(server::Convert(m3).ok());

  for (const std::string bad :
       {"INTER_SE2 a 3 b 0 1 2 3 1 0 0 1 0", "INTER_SE2 a -3 b 0 1 2 3 1 0 0 1 0 1",
        "INTER_SE2 a 3 b 0 1 2 x 1 0 0 1 0 1", "INTER_SE2 a!x 3 b 0 1 2 3 1 0 0 1 0 1",
        "INTER_SE2 a 3 b 0 1 2 3 -1 0 0 1 0 1", "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1"}) {
    auto r = ParseInterRobot("\n" + bad + "\n", "f");
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_EQ(r.status().message().rfind("f:2:", 0), 0u) << r.status().message();
  }
}

TEST(ReplaySourcesTest, InterleavesRobotsAndSendsClosuresOnceBothPosesWereSent) {
  auto closures = ParseInterRobot(
      "INTER_SE2 a 3 b 1 1 0 0 1 0 0 1 0 1\n"
      "INTER_SE2 b 0 a 0 1 0 0 1 0 0 1 0 1\n",
      "f");
  ASSERT_TRUE(closures.ok());
  const std::vector<RobotDataset> robots = {{"a", Steps("a")}, {"b", Steps("b")}};
  auto items = InterleaveRobots(robots, *closures, server::ChannelNames{});
  ASSERT_TRUE(items.ok()) << items.status().ToString();
  // 2 robots x (prior + 3 odometry) + 2 closures.
  ASSERT_EQ(items->size(), 10u);
  std::vector<std::string> order;
  for (const ReplayItem& it : *items) {
    order.push_back(it.robot + ":" + it.channel.substr(6) + ":" + std::to_string(it.new_pose));
  }
  const std::vector<std::string> want = {
      "a:PRIOR:0",    "b:PRIOR:0",    "b:LOOP_CLOSURE:-1",  // b0-a0 once both were sent
      "a:ODOMETRY:1", "b:ODOMETRY:1", "a:ODOMETRY:2",
      "b:ODOMETRY:2", "a:ODOMETRY:3", "a:LOOP_CLOSURE:-1",  // a3-b1 right after a's step 3
      "b:ODOMETRY:3"};
  EXPECT_EQ(order, want);

  auto unknown = ParseInterRobot("INTER_SE2 a 3 c 1 1 0 0 1 0 0 1 0 1\n", "f");
  EXPECT_FALSE(InterleaveRobots(robots, *unknown, server::ChannelNames{}).ok());
  auto no_pose = ParseInterRobot("INTER_SE2 a 9 b 1 1 0 0 1 0 0 1 0 1\n", "f");
  EXPECT_FALSE(InterleaveRobots(robots, *no_pose, server::ChannelNames{}).ok());
}

TEST(ReplaySourcesTest, DetectsLcmLogsByMagicAndReadsTheSlamdChannels) {
  const std::string log_path = testing::WriteTempFile("recorded.g2o", "");  // misleading name
  const std::vector<RobotDataset> robots = {{"a", Steps("a")}};
  auto items = InterleaveRobots(robots, {}, server::ChannelNames{"P_"});
  ASSERT_TRUE(items.ok());
  {
    lcm::LogFile log(log_path, "w");
    ASSERT_TRUE(log.good());
    std::int64_t t = 1000000;
    for (const ReplayItem& it : *items) {
      lcm::LogEvent e{0, t, it.channel, static_cast<int32_t>(it.bytes.size()),
                      const_cast<std::uint8_t*>(it.bytes.data())};
      ASSERT_EQ(log.writeEvent(&e), 0);
      // Noise the replay must skip: an outbound channel and another application's channel.
      std::uint8_t junk[3] = {1, 2, 3};
      lcm::LogEvent o1{0, t, "P_ESTIMATE", 3, junk};
      lcm::LogEvent o2{0, t, "CAMERA", 3, junk};
      ASSERT_EQ(log.writeEvent(&o1), 0);
      ASSERT_EQ(log.writeEvent(&o2), 0);
      t += 10000;
    }
  }
  EXPECT_TRUE(IsLcmLog(log_path));
  EXPECT_FALSE(IsLcmLog(testing::WriteTempFile("x.lcm", kChain)));
  EXPECT_FALSE(IsLcmLog("/nonexistent/file"));

  auto read = ReadLcmLog(log_path, server::ChannelNames{"P_"}, "");
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  ASSERT_EQ(read->size(), items->size());
  for (size_t i = 0; i < items->size(); ++i) {
    EXPECT_EQ((*read)[i].channel, (*items)[i].channel);
    EXPECT_EQ((*read)[i].bytes, (*items)[i].bytes);
    EXPECT_EQ((*read)[i].robot, (*items)[i].robot);
    EXPECT_EQ((*read)[i].new_pose, (*items)[i].new_pose);
    EXPECT_EQ((*read)[i].log_utime, 1000000 + 10000 * static_cast<std::int64_t>(i));
  }
  auto with_camera = ReadLcmLog(log_path, server::ChannelNames{"P_"}, "CAM.*");
  ASSERT_TRUE(with_camera.ok());
  EXPECT_EQ(with_camera->size(), 2 * items->size());
  EXPECT_FALSE(ReadLcmLog(log_path, server::ChannelNames{"P_"}, "(").ok());
}

}  // namespace
}  // namespace slamd::clients
