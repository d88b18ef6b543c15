// plot_live: map_t pages -> PlotScene (pages in any order, missing pages, ellipses from known
// covariances in 2D and 3D), the page collector's completeness rule, and the query round trip
// against a fake server on an InProcessBus (a lost page and a rejected query are errors).
// Pages are made by the server's own pager (server::MapPages), as slamd sends them.
#include "clients/slamctl/plot_live.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include "core/geometry/rot3.h"
#include "server/messages/inbound.h"
#include "server/publish/replies.h"
#include "server/transport/in_process_bus.h"
#include "slamd/query_t.hpp"

namespace slamd::clients::plot {
namespace {

using std::numbers::pi;

// Pose i on a circle of radius 10, heading along it; covariance diag(0.01, 0.02, 0.001)·(1 + i)
// (body frame); `landmarks` points inside the circle with covariance diag(0.04, 0.09).
server::RobotMap CircleMap(const std::string& name, int poses, int landmarks) {
  server::RobotMap map{.robot = name};
  for (int i = 0; i < poses; ++i) {
    const double a = 2 * pi * i / poses;
    map.poses.push_back(
        {.index = static_cast<std::uint64_t>(i),
         .value = core::Pose2(10 * std::cos(a), 10 * std::sin(a), a + pi / 2),
         .covariance =
             (Eigen::Vector3d(0.01, 0.02, 0.001) * (1.0 + i)).asDiagonal().toDenseMatrix()});
  }
  for (int j = 0; j < landmarks; ++j) {
    map.landmarks.push_back(
        {.index = static_cast<std::uint64_t>(100 + j),
         .value = core::Point2(j, -j),
         .covariance = Eigen::Vector2d(0.04, 0.09).asDiagonal().toDenseMatrix()});
  }
  return map;
}

std::vector<slamd::map_t> Pages(const server::RobotMap& map, std::int64_t request_id = 42,
                                int max_bytes = server::kMaxMapPageBytes) {
  return server::MapPages(map, /*update_sequence=*/17, request_id, /*now_utime=*/0, max_bytes);
}

void ExpectSameScene(const PlotScene& a, const PlotScene& b) {
  ASSERT_EQ(a.robots.size(), b.robots.size());
  for (std::size_t r = 0; r < a.robots.size(); ++r) {
    const PlotRobot &x = a.robots[r], &y = b.robots[r];
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.trajectory, y.trajectory);
    EXPECT_EQ(x.landmarks, y.landmarks);
    ASSERT_EQ(x.pose_ellipses.size(), y.pose_ellipses.size());
    for (std::size_t i = 0; i < x.pose_ellipses.size(); ++i) {
      EXPECT_EQ(x.pose_ellipses[i].center, y.pose_ellipses[i].center);
      EXPECT_EQ(x.pose_ellipses[i].semi_major, y.pose_ellipses[i].semi_major);
    }
    EXPECT_EQ(x.landmark_ellipses.size(), y.landmark_ellipses.size());
  }
}

TEST(PlotLiveTest, AssemblesPagesInAnyOrder) {
  const server::RobotMap map = CircleMap("bot", 120, 5);
  // Small pages so the map spans many of them.
  const std::vector<slamd::map_t> pages = Pages(map, 42, 1500);
  ASSERT_GE(pages.size(), 5u);
  core::Result<LiveScene> ordered = BuildLiveScene(pages, {});
  ASSERT_TRUE(ordered.ok()) << ordered.status().ToString();
  EXPECT_EQ(ordered->update_sequence, 17);
  ASSERT_EQ(ordered->scene.robots.size(), 1u);
  const PlotRobot& robot = ordered->scene.robots[0];
  EXPECT_EQ(robot.name, "bot");
  ASSERT_EQ(robot.trajectory.size(), 120u);
  for (int i = 0; i < 120; ++i) {
    const double a = 2 * pi * i / 120;
    EXPECT_NEAR(robot.trajectory[i].x(), 10 * std::cos(a), 1e-12) << i;
    EXPECT_NEAR(robot.trajectory[i].y(), 10 * std::sin(a), 1e-12) << i;
  }
  ASSERT_EQ(robot.landmarks.size(), 5u);
  EXPECT_EQ(robot.landmarks[3], Eigen::Vector2d(3, -3));
  EXPECT_TRUE(robot.loop_closures.empty());  // not in map_t
  // As for datasets: about 50 ellipses, K = ceil(120 / 50) = 3: poses 0, 3, ..., 117 and 119.
  ASSERT_EQ(ordered->ellipse_every, std::vector<int>{3});
  ASSERT_EQ(robot.pose_ellipses.size(), 41u);
  EXPECT_EQ(robot.pose_ellipses[1].center, robot.trajectory[3]);
  EXPECT_EQ(robot.pose_ellipses.back().center, robot.trajectory[119]);
  EXPECT_EQ(robot.landmark_ellipses.size(), 5u);
  EXPECT_EQ(ordered->missing_covariances, 0);

  // Shuffled, with repeats: the same scene.
  std::vector<slamd::map_t> shuffled = pages;
  shuffled.push_back(pages[2]);
  shuffled.push_back(pages[0]);
  std::mt19937 rng(7);
  std::shuffle(shuffled.begin(), shuffled.end(), rng);
  core::Result<LiveScene> again = BuildLiveScene(shuffled, {});
  ASSERT_TRUE(again.ok()) << again.status().ToString();
  ExpectSameScene(ordered->scene, again->scene);

  // An explicit K, and no landmark ellipses.
  core::Result<LiveScene> every10 =
      BuildLiveScene(pages, {.ellipse_every = 10, .landmark_ellipses = false});
  ASSERT_TRUE(every10.ok());
  EXPECT_EQ(every10->scene.robots[0].pose_ellipses.size(), 13u);  // 0, 10, ..., 110, 119
  EXPECT_TRUE(every10->scene.robots[0].landmark_ellipses.empty());
}

TEST(PlotLiveTest, RobotsInNameOrderAndEntriesWithoutCovariance) {
  server::RobotMap b = CircleMap("bravo", 10, 0), a = CircleMap("alpha", 4, 2);
  for (server::MapEntry& e : a.poses) e.covariance.resize(0, 0);  // not ready in time
  std::vector<slamd::map_t> pages = Pages(b);
  for (const slamd::map_t& p : Pages(a)) pages.push_back(p);
  core::Result<LiveScene> live = BuildLiveScene(pages, {});
  ASSERT_TRUE(live.ok()) << live.status().ToString();
  ASSERT_EQ(live->scene.robots.size(), 2u);
  EXPECT_EQ(live->scene.robots[0].name, "alpha");
  EXPECT_EQ(live->scene.robots[1].name, "bravo");
  EXPECT_TRUE(live->scene.robots[0].pose_ellipses.empty());
  EXPECT_EQ(live->scene.robots[0].landmark_ellipses.size(), 2u);
  EXPECT_EQ(live->missing_covariances, 4);  // every alpha pose (K = 1)
  EXPECT_EQ(live->scene.robots[1].pose_ellipses.size(), 10u);

  // No pages at all (no robots yet): an empty scene.
  core::Result<LiveScene> empty = BuildLiveScene({}, {});
  ASSERT_TRUE(empty.ok());
  EXPECT_TRUE(empty->scene.robots.empty());
}

// The reference: a 2x2 covariance [[a, b], [b, c]] has eigenvalues (a + c)/2 ± √(((a − c)/2)² + b²)
// and its major axis at ½·atan2(2b, a − c).
TEST(PlotLiveTest, KnownCovarianceGivesTheEllipse2D) {
  server::RobotMap map{.robot = "r"};
  // Heading +y: body x is world y. Body translation covariance diag(4, 1) -> world diag(1, 4).
  Eigen::Matrix3d pose_cov;
  pose_cov << 4, 0, 0.05, 0, 1, 0, 0.05, 0, 0.1;
  map.poses.push_back({.index = 0, .value = core::Pose2(1, 2, pi / 2), .covariance = pose_cov});
  Eigen::Matrix2d lm_cov;
  lm_cov << 2, 0.5, 0.5, 1;  // world frame
  map.landmarks.push_back({.index = 9, .value = core::Point2(5, -1), .covariance = lm_cov});
  core::Result<LiveScene> live = BuildLiveScene(Pages(map), {.sigma = 3.0});
  ASSERT_TRUE(live.ok()) << live.status().ToString();
  const PlotRobot& robot = live->scene.robots.at(0);
  ASSERT_EQ(robot.pose_ellipses.size(), 1u);
  const Ellipse& e = robot.pose_ellipses[0];
  EXPECT_NEAR(e.center.x(), 1, 1e-12);
  EXPECT_NEAR(e.center.y(), 2, 1e-12);
  EXPECT_NEAR(e.semi_major, 3 * 2.0, 1e-9);
  EXPECT_NEAR(e.semi_minor, 3 * 1.0, 1e-9);
  EXPECT_NEAR(std::abs(e.angle), pi / 2, 1e-9);  // major axis along world y

  ASSERT_EQ(robot.landmark_ellipses.size(), 1u);
  const Ellipse& l = robot.landmark_ellipses[0];
  const double mid = 1.5, radius = std::sqrt(0.25 + 0.25);
  EXPECT_EQ(l.center, Eigen::Vector2d(5, -1));
  EXPECT_NEAR(l.semi_major, 3 * std::sqrt(mid + radius), 1e-9);
  EXPECT_NEAR(l.semi_minor, 3 * std::sqrt(mid - radius), 1e-9);
  EXPECT_NEAR(l.angle, 0.5 * std::atan2(1.0, 1.0), 1e-9);
}

TEST(PlotLiveTest, ThreeDMapsAreProjectedTopDown) {
  server::RobotMap map{.robot = "drone", .is3d = true};
  Eigen::Matrix<double, 6, 6> cov = Eigen::Matrix<double, 6, 6>::Zero();
  cov.diagonal() << 4, 1, 9, 0.1, 0.1, 0.1;  // body (v, ω)
  // Yawed 90°: body x -> world y: world x-y covariance diag(1, 4).
  map.poses.push_back(
      {.index = 0,
       .value = core::Pose3(core::Rot3::FromRollPitchYaw(0, 0, pi / 2), core::Point3(1, 2, 5)),
       .covariance = cov});
  // Rolled 90°: body y -> world z, body z -> world −y: world x-y covariance diag(4, 9).
  map.poses.push_back(
      {.index = 1,
       .value = core::Pose3(core::Rot3::FromRollPitchYaw(pi / 2, 0, 0), core::Point3(3, 4, -2)),
       .covariance = cov});
  map.landmarks.push_back({.index = 0,
                           .value = core::Point3(3, 4, 7),
                           .covariance = Eigen::Vector3d(1, 2, 3).asDiagonal().toDenseMatrix()});
  const std::vector<slamd::map_t> pages = Pages(map);
  ASSERT_EQ(pages.at(0).dimension, slamd::map_t::DIMENSION_3D);
  core::Result<LiveScene> live = BuildLiveScene(pages, {.sigma = 1.0});
  ASSERT_TRUE(live.ok()) << live.status().ToString();
  const PlotRobot& robot = live->scene.robots.at(0);
  ASSERT_EQ(robot.trajectory.size(), 2u);
  EXPECT_NEAR((robot.trajectory[0] - Eigen::Vector2d(1, 2)).norm(), 0, 1e-12);
  EXPECT_NEAR((robot.trajectory[1] - Eigen::Vector2d(3, 4)).norm(), 0, 1e-12);
  ASSERT_EQ(robot.pose_ellipses.size(), 2u);
  EXPECT_NEAR(robot.pose_ellipses[0].semi_major, 2.0, 1e-9);
  EXPECT_NEAR(robot.pose_ellipses[0].semi_minor, 1.0, 1e-9);
  EXPECT_NEAR(std::abs(robot.pose_ellipses[0].angle), pi / 2, 1e-9);
  EXPECT_NEAR(robot.pose_ellipses[1].semi_major, 3.0, 1e-9);
  EXPECT_NEAR(robot.pose_ellipses[1].semi_minor, 2.0, 1e-9);
  EXPECT_NEAR(std::abs(robot.pose_ellipses[1].angle), pi / 2, 1e-9);
  ASSERT_EQ(robot.landmarks.size(), 1u);
  EXPECT_EQ(robot.landmarks[0], Eigen::Vector2d(3, 4));
  ASSERT_EQ(robot.landmark_ellipses.size(), 1u);
  EXPECT_NEAR(robot.landmark_ellipses[0].semi_major, std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(robot.landmark_ellipses[0].semi_minor, 1.0, 1e-9);
}

TEST(PlotLiveTest, IncompleteOrMalformedPagesAreErrors) {
  const std::vector<slamd::map_t> pages = Pages(CircleMap("bot", 60, 0), 42, 1500);
  ASSERT_GE(pages.size(), 4u);
  const std::string count = std::to_string(pages.size());
  std::vector<slamd::map_t> missing = pages;
  missing.erase(missing.begin() + 2);
  core::Result<LiveScene> live = BuildLiveScene(missing, {});
  ASSERT_FALSE(live.ok());
  EXPECT_EQ(live.status().message(), "robot bot: map_t page 2 of " + count + " missing");
  missing.erase(missing.begin());
  EXPECT_EQ(BuildLiveScene(missing, {}).status().message(),
            "robot bot: map_t pages 0, 2 of " + count + " missing");

  std::vector<slamd::map_t> bad = pages;
  bad[1].page_count += 1;
  EXPECT_NE(BuildLiveScene(bad, {}).status().message().find("differs"), std::string::npos);
  bad = pages;
  bad[1].poses[0].values.pop_back();
  bad[1].poses[0].num_values -= 1;
  EXPECT_NE(BuildLiveScene(bad, {}).status().message().find("values, expected 3"),
            std::string::npos)
      << BuildLiveScene(bad, {}).status().message();
  bad = pages;
  bad[0].poses[0].covariance.resize(4);
  bad[0].poses[0].num_covariance = 4;
  EXPECT_NE(BuildLiveScene(bad, {}).status().message().find("pose x0: covariance has 4"),
            std::string::npos);
  bad = pages;
  bad[3].poses[0].values[0] = NAN;
  EXPECT_FALSE(BuildLiveScene(bad, {}).ok());
  EXPECT_FALSE(BuildLiveScene(pages, {.sigma = 0.0}).ok());
  EXPECT_FALSE(BuildLiveScene(pages, {.ellipse_every = -1}).ok());
}

// A sharded slamd's fleet-wide map: a reply and pages from each shard, each at its own update
// and with the shared map's landmarks it holds. Complete once every shard replied with every
// page it announced; one PlotRobot per (shard, robot).
TEST(PlotLiveTest, CollectorAndSceneTakeEveryShardsAnswer) {
  MapPageCollector collector(42);
  std::vector<slamd::map_t> east = Pages(CircleMap("a", 5, 0));
  std::vector<slamd::map_t> west = Pages(CircleMap("b", 4, 0));
  for (const slamd::map_t& p : Pages(CircleMap("", 0, 3))) east.push_back(p);
  for (const slamd::map_t& p : Pages(CircleMap("", 0, 2))) west.push_back(p);
  for (slamd::map_t& p : east) p.shard = "east";
  for (slamd::map_t& p : west) {
    p.shard = "west";
    p.update_sequence = 40;
  }
  const auto reply = [](const std::string& shard, std::size_t pages) {
    slamd::query_reply_t r{};
    r.request_id = 42;
    r.shard = shard;
    r.shards_answering = 2;
    r.map_pages = static_cast<std::int32_t>(pages);
    return r;
  };
  EXPECT_TRUE(collector.AddReply(reply("east", east.size())));
  EXPECT_FALSE(collector.AddReply(reply("east", east.size())));  // that shard's again
  for (const slamd::map_t& p : east) EXPECT_TRUE(collector.AddPage(p));
  EXPECT_EQ(collector.Missing(), "the query_reply_t from 1 more of 2 shards (heard: east)");
  for (const slamd::map_t& p : west) EXPECT_TRUE(collector.AddPage(p));  // "" of west is new
  EXPECT_FALSE(collector.Complete());
  EXPECT_TRUE(collector.AddReply(reply("west", west.size())));
  EXPECT_TRUE(collector.Complete()) << collector.Missing();
  EXPECT_EQ(collector.reply().map_pages, static_cast<std::int32_t>(east.size() + west.size()));

  core::Result<LiveScene> live = BuildLiveScene(collector.pages(), {});
  ASSERT_TRUE(live.ok()) << live.status().message();
  EXPECT_EQ(live->update_sequence, 40);  // the newest shard's
  std::vector<std::string> names;
  for (const PlotRobot& r : live->scene.robots) names.push_back(r.name);
  EXPECT_EQ(names, (std::vector<std::string>{"shared map (shard east)", "a",
                                             "shared map (shard west)", "b"}));
  // Within a shard, one update: a page of another is refused, naming the robot and shard.
  std::vector<slamd::map_t> mixed = collector.pages();
  mixed.back().update_sequence = 41;
  EXPECT_NE(BuildLiveScene(mixed, {}).status().message().find(
                "robot b of shard west: update_sequence 40 differs from 41"),
            std::string::npos)
      << BuildLiveScene(mixed, {}).status().message();
}

TEST(PlotLiveTest, CollectorKnowsWhenTheAnswerIsComplete) {
  MapPageCollector collector(42);
  EXPECT_EQ(collector.Missing(), "the query_reply_t for request 42");
  const std::vector<slamd::map_t> a = Pages(CircleMap("a", 60, 0), 42, 1500);
  const std::vector<slamd::map_t> b = Pages(CircleMap("b", 3, 0), 42);
  ASSERT_GE(a.size(), 3u);
  slamd::query_reply_t reply{};
  reply.request_id = 43;  // another client's
  reply.map_pages = static_cast<std::int32_t>(a.size() + b.size());
  EXPECT_FALSE(collector.AddReply(reply));
  EXPECT_FALSE(collector.AddPage(Pages(CircleMap("a", 3, 0), 0)[0]));  // a periodic map
  reply.request_id = 42;
  EXPECT_TRUE(collector.AddReply(reply));
  EXPECT_FALSE(collector.AddReply(reply));
  EXPECT_EQ(collector.Missing(), std::to_string(a.size() + 1) +
                                     " map_t pages of robots not heard from (the reply announced " +
                                     std::to_string(reply.map_pages) + ", 0 arrived)");
  EXPECT_TRUE(collector.AddPage(a[1]));
  EXPECT_FALSE(collector.AddPage(a[1]));  // repeated
  const std::string n = std::to_string(a.size());
  EXPECT_EQ(collector.Missing().rfind("robot a: map_t pages 0, 2, ", 0), 0u) << collector.Missing();
  for (const slamd::map_t& p : a) collector.AddPage(p);
  EXPECT_EQ(collector.Missing(), "1 map_t page of robots not heard from (the reply announced " +
                                     std::to_string(reply.map_pages) + ", " + n + " arrived)");
  EXPECT_FALSE(collector.Complete());
  collector.AddPage(b[0]);
  EXPECT_TRUE(collector.Complete()) << collector.Missing();
  EXPECT_EQ(collector.pages().size(), a.size() + 1);
  EXPECT_TRUE(BuildLiveScene(collector.pages(), {}).ok());
}

// Answers each query_t with every robot's pages (server::MapPages) and then the reply, as slamd
// does; `drop` skips one page; `reject` rejects the query.
class FakeServer {
 public:
  explicit FakeServer(server::Bus& bus) : bus_(bus) {
    sub_ = server::Subscribe<slamd::query_t>(
               bus, "SLAMD_QUERY", [this](std::string_view, const slamd::query_t& q) { Answer(q); },
               nullptr)
               .value();
  }
  int drop = -1;
  bool reject = false;
  slamd::query_t last;

 private:
  void Answer(const slamd::query_t& q) {
    last = q;
    slamd::query_reply_t r{};
    r.client = q.client;
    r.request_id = q.request_id;
    r.update_sequence = 17;
    if (reject) {
      r.status = slamd::query_reply_t::STATUS_REJECTED;
      r.error = "query_t.map_robot: bad";
    } else {
      std::vector<slamd::map_t> pages = Pages(CircleMap("a", 60, 2), q.request_id, 1500);
      for (const slamd::map_t& p : Pages(CircleMap("b", 5, 0), q.request_id)) pages.push_back(p);
      r.map_pages = static_cast<std::int32_t>(pages.size());
      for (const slamd::map_t& p : Pages(CircleMap("a", 7, 0), 0)) pages.push_back(p);  // periodic
      for (int i = 0; i < static_cast<int>(pages.size()); ++i) {
        if (i == drop) continue;
        ASSERT_TRUE(server::Publish(bus_, "SLAMD_MAP", pages[i]).ok());
      }
    }
    ASSERT_TRUE(server::Publish(bus_, "SLAMD_QUERY_REPLY", r).ok());
  }
  server::Bus& bus_;
  server::Subscription sub_;
};

TEST(PlotLiveTest, FetchesEveryRobotsMapOverTheBus) {
  LcmClient client(std::make_unique<server::InProcessBus>());
  FakeServer fake(client.bus());
  core::Result<MapPageCollector> answer = FetchLiveMap(client, {}, true, 2.0);
  ASSERT_TRUE(answer.ok()) << answer.status().ToString();
  EXPECT_EQ(fake.last.map_robot, "*");
  EXPECT_TRUE(fake.last.want_marginals);
  EXPECT_EQ(fake.last.request_id, answer->request_id());
  core::Result<LiveScene> live = BuildLiveScene(answer->pages(), {});
  ASSERT_TRUE(live.ok()) << live.status().ToString();
  ASSERT_EQ(live->scene.robots.size(), 2u);
  EXPECT_EQ(live->scene.robots[0].trajectory.size(), 60u);  // not the periodic map's 7
  EXPECT_EQ(live->scene.robots[1].trajectory.size(), 5u);
  EXPECT_EQ(live->scene.NumLandmarks(), 2u);
}

TEST(PlotLiveTest, LostPageOrRejectedQueryIsAnError) {
  {
    LcmClient client(std::make_unique<server::InProcessBus>());
    FakeServer fake(client.bus());
    fake.drop = 1;
    core::Result<MapPageCollector> answer = FetchLiveMap(client, {}, false, 0.3);
    ASSERT_FALSE(answer.ok());
    EXPECT_EQ(answer.status().code(), core::StatusCode::kOutOfRange);
    EXPECT_NE(answer.status().message().find("timed out after 0.3 s waiting for robot a: map_t "
                                             "page 1 of "),
              std::string::npos)
        << answer.status().message();
    EXPECT_FALSE(fake.last.want_marginals);
  }
  {
    LcmClient client(std::make_unique<server::InProcessBus>());
    FakeServer fake(client.bus());
    fake.reject = true;
    core::Result<MapPageCollector> answer = FetchLiveMap(client, {}, true, 2.0);
    ASSERT_FALSE(answer.ok());
    EXPECT_EQ(answer.status().message(), "slamd rejected the map query: query_t.map_robot: bad");
  }
  {
    LcmClient client(std::make_unique<server::InProcessBus>());  // nobody answers
    core::Result<MapPageCollector> answer = FetchLiveMap(client, {}, true, 0.2);
    ASSERT_FALSE(answer.ok());
    EXPECT_NE(answer.status().message().find("waiting for the query_reply_t for request"),
              std::string::npos)
        << answer.status().message();
  }
}

}  // namespace
}  // namespace slamd::clients::plot
