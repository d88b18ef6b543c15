// The live server's map as a PlotScene (see plot_live.h).
#include "clients/slamctl/plot_live.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <utility>

#include "clients/slamctl/query_client.h"
#include "core/geometry/rot3.h"
#include "server/messages/inbound.h"
#include "slamd/query_t.hpp"

namespace slamd::clients::plot {
namespace {

// "robot intel", or "robot a of shard east" (a sharded slamd's page).
std::string RobotName(const std::string& shard, const std::string& robot) {
  return "robot " + robot + (shard.empty() ? "" : " of shard " + shard);
}

// "page 2 of 4" or "pages 0, 2, 3 of 4": the indices in [0, count) not in `have` (a subset of
// [0, count)), at most 8 listed; "" when none. Stops after the 8th, so a huge count is cheap.
std::string MissingPages(const std::set<std::int32_t>& have, std::int32_t count) {
  constexpr int kShown = 8;
  const std::int64_t missing =
      static_cast<std::int64_t>(count) - static_cast<std::int64_t>(have.size());
  if (missing <= 0) return "";
  std::string list;
  int shown = 0;
  for (std::int32_t i = 0; i < count && shown < kShown; ++i) {
    if (!have.contains(i)) list += (shown++ ? ", " : "") + std::to_string(i);
  }
  if (missing > shown) list += ", ... (" + std::to_string(missing) + " in all)";
  return (missing == 1 ? "page " : "pages ") + list + " of " + std::to_string(count);
}

std::string Plural(std::int64_t n, const std::string& word) {
  return std::to_string(n) + " " + word + (n == 1 ? "" : "s");
}

// The world-frame value of a map entry (layouts in map_entry_t.lcm).
core::Result<core::Variable> EntryValue(const slamd::map_entry_t& e, bool is3d, bool pose,
                                        const std::string& what) {
  const std::size_t expected = pose ? (is3d ? 7 : 3) : (is3d ? 3 : 2);
  if (e.values.size() != expected || e.num_values != static_cast<std::int32_t>(expected)) {
    return core::InvalidArgument(what + ": " + std::to_string(e.values.size()) +
                                 " values, expected " + std::to_string(expected) + " for a " +
                                 (is3d ? "3D" : "2D") + " map");
  }
  for (const double v : e.values) {
    if (!std::isfinite(v)) return core::InvalidArgument(what + ": non-finite value");
  }
  const std::vector<double>& v = e.values;
  if (!pose) {
    if (is3d) return core::Variable(core::Point3(v[0], v[1], v[2]));
    return core::Variable(core::Point2(v[0], v[1]));
  }
  if (!is3d) return core::Variable(core::Pose2(v[0], v[1], v[2]));
  if (v[3] == 0.0 && v[4] == 0.0 && v[5] == 0.0 && v[6] == 0.0) {
    return core::InvalidArgument(what + ": zero quaternion");
  }
  return core::Variable(core::Pose3(core::Rot3::FromQuaternion(v[3], v[4], v[5], v[6]),
                                    core::Point3(v[0], v[1], v[2])));
}

// The entry's tangent covariance as a matrix; empty when the entry carries none.
core::Result<Eigen::MatrixXd> EntryCovariance(const slamd::map_entry_t& e, int dim,
                                              const std::string& what) {
  if (e.covariance.empty()) return Eigen::MatrixXd();
  if (e.covariance.size() != static_cast<std::size_t>(dim * dim)) {
    return core::InvalidArgument(what + ": covariance has " + std::to_string(e.covariance.size()) +
                                 " numbers, expected " + std::to_string(dim * dim));
  }
  for (const double c : e.covariance) {
    if (!std::isfinite(c)) return core::InvalidArgument(what + ": non-finite covariance");
  }
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  return Eigen::MatrixXd(Eigen::Map<const RowMajor>(e.covariance.data(), dim, dim));
}

// One robot's complete set of pages, checked for consistency.
struct RobotPages {
  std::int32_t page_count = 0;
  std::int64_t update_sequence = 0;
  std::int8_t dimension = 0;
  std::map<std::int32_t, const slamd::map_t*> pages;  // by page_index; first copy wins
};

core::Status CheckPage(const slamd::map_t& page, RobotPages* robot) {
  const std::string what =
      RobotName(page.shard, page.robot) + " page " + std::to_string(page.page_index);
  if (page.page_count < 1 || page.page_index < 0 || page.page_index >= page.page_count) {
    return core::InvalidArgument(what + ": page_index out of range for page_count " +
                                 std::to_string(page.page_count));
  }
  if (page.dimension != slamd::map_t::DIMENSION_2D &&
      page.dimension != slamd::map_t::DIMENSION_3D) {
    return core::InvalidArgument(what + ": dimension " + std::to_string(page.dimension) +
                                 " (expected 2 or 3)");
  }
  if (robot->pages.empty()) {
    robot->page_count = page.page_count;
    robot->update_sequence = page.update_sequence;
    robot->dimension = page.dimension;
  } else if (page.page_count != robot->page_count ||
             page.update_sequence != robot->update_sequence || page.dimension != robot->dimension) {
    return core::InvalidArgument(what +
                                 ": page_count, update_sequence or dimension differs from "
                                 "the robot's other pages");
  }
  robot->pages.emplace(page.page_index, &page);
  return core::Status::Ok();
}

struct Entry {
  std::int64_t index;
  const slamd::map_entry_t* entry;
};

// Entries of all pages, sorted by index; a repeated index is an error. `robot`: RobotName.
core::Result<std::vector<Entry>> SortedEntries(const RobotPages& pages, bool poses,
                                               const std::string& robot) {
  std::vector<Entry> out;
  for (const auto& [index, page] : pages.pages) {
    for (const slamd::map_entry_t& e : poses ? page->poses : page->landmarks) {
      out.push_back({e.index, &e});
    }
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const Entry& a, const Entry& b) { return a.index < b.index; });
  for (std::size_t i = 1; i < out.size(); ++i) {
    if (out[i].index == out[i - 1].index) {
      return core::InvalidArgument(robot + ": " + (poses ? "pose x" : "landmark l") +
                                   std::to_string(out[i].index) + " appears twice");
    }
  }
  return out;
}

}  // namespace

bool MapPageCollector::AddPage(const slamd::map_t& page) {
  if (page.request_id != request_id_) return false;
  // Malformed, or at odds with the robot's first page: cannot be part of one answer.
  if (page.page_count < 1 || page.page_index < 0 || page.page_index >= page.page_count)
    return false;
  RobotSeen& robot =
      seen_.try_emplace({page.shard, page.robot}, RobotSeen{.page_count = page.page_count})
          .first->second;
  if (page.page_count != robot.page_count || !robot.pages.insert(page.page_index).second) {
    return false;
  }
  pages_.push_back(page);
  return true;
}

std::string MapPageCollector::Missing() const {
  std::vector<std::string> parts;
  if (!replies_.complete()) parts.push_back("the " + replies_.Missing());
  std::int64_t known = 0;  // pages of the robots heard from
  for (const auto& [who, seen] : seen_) {
    known += seen.page_count;
    const std::string missing = MissingPages(seen.pages, seen.page_count);
    if (!missing.empty()) parts.push_back(RobotName(who.first, who.second) + ": map_t " + missing);
  }
  const slamd::query_reply_t& reply = replies_.merged();
  if (replies_.complete() && reply.map_pages > known) {
    parts.push_back(Plural(reply.map_pages - known, "map_t page") +
                    " of robots not heard from (the reply announced " +
                    std::to_string(reply.map_pages) + ", " + std::to_string(pages_.size()) +
                    " arrived)");
  }
  std::string out;
  for (std::size_t i = 0; i < parts.size(); ++i) out += (i ? "; " : "") + parts[i];
  return out;
}

core::Result<LiveScene> BuildLiveScene(const std::vector<slamd::map_t>& pages,
                                       const LiveSceneOptions& options) {
  if (options.ellipse_every < 0 || !(options.sigma > 0.0)) {
    return core::InvalidArgument("LiveSceneOptions: ellipse_every must be >= 0 and sigma > 0");
  }
  // 1. Group by (shard, robot) (name order) and check each robot's pages are one complete set,
  // from one solver update per shard.
  std::map<std::pair<std::string, std::string>, RobotPages> robots;
  for (const slamd::map_t& page : pages) {
    SLAMD_RETURN_IF_ERROR(CheckPage(page, &robots[{page.shard, page.robot}]));
  }
  LiveScene live;
  live.scene.sigma = options.sigma;
  std::map<std::string, std::int64_t> shard_sequence;
  for (const auto& [who, robot] : robots) {
    std::set<std::int32_t> have;
    for (const auto& [index, page] : robot.pages) have.insert(index);
    const std::string missing = MissingPages(have, robot.page_count);
    const std::string name = RobotName(who.first, who.second);
    if (!missing.empty()) return core::InvalidArgument(name + ": map_t " + missing + " missing");
    const auto [it, first] = shard_sequence.try_emplace(who.first, robot.update_sequence);
    if (!first && robot.update_sequence != it->second) {
      return core::InvalidArgument(name + ": update_sequence " +
                                   std::to_string(robot.update_sequence) + " differs from " +
                                   std::to_string(it->second));
    }
    live.update_sequence = std::max(live.update_sequence, robot.update_sequence);
  }

  // 2. One PlotRobot per robot. (No structured binding: the lambda below captures the name,
  // which clang 14 does not allow for a binding.)
  for (const auto& named : robots) {
    const std::string& shard = named.first.first;
    const std::string& robot_name = named.first.second;
    const std::string name = RobotName(shard, robot_name);
    const auto& robot = named.second;
    const bool is3d = robot.dimension == slamd::map_t::DIMENSION_3D;
    core::Result<std::vector<Entry>> poses = SortedEntries(robot, true, name);
    if (!poses.ok()) return poses.status();
    core::Result<std::vector<Entry>> landmarks = SortedEntries(robot, false, name);
    if (!landmarks.ok()) return landmarks.status();
    const std::size_t n = poses->size();
    const int every = options.ellipse_every > 0 ? options.ellipse_every
                                                : std::max<int>(1, static_cast<int>((n + 49) / 50));

    PlotRobot out;
    out.name = robot_name.empty() ? "shared map" : robot_name;
    if (robot_name.empty() && !shard.empty()) out.name += " (shard " + shard + ")";
    out.trajectory.reserve(n);
    out.landmarks.reserve(landmarks->size());
    // Adds the entry's position (and its ellipse when wanted and its covariance is present).
    const auto add = [&](const Entry& e, bool pose, bool want_ellipse) -> core::Status {
      const std::string what = name + (pose ? " pose x" : " landmark l") + std::to_string(e.index);
      core::Result<core::Variable> value = EntryValue(*e.entry, is3d, pose, what);
      if (!value.ok()) return value.status();
      const Eigen::Vector2d position = *core::PlanarPosition(*value);  // a pose or a point
      (pose ? out.trajectory : out.landmarks).push_back(position);
      if (!want_ellipse) return core::Status::Ok();
      core::Result<Eigen::MatrixXd> cov =
          EntryCovariance(*e.entry, core::TangentDim(core::TypeOf(*value)), what);
      if (!cov.ok()) return cov.status();
      if (cov->size() == 0) {
        ++live.missing_covariances;
        return core::Status::Ok();
      }
      (pose ? out.pose_ellipses : out.landmark_ellipses)
          .push_back(
              CovarianceEllipse(position, core::PlanarCovariance(*value, *cov), options.sigma));
      return core::Status::Ok();
    };
    for (std::size_t i = 0; i < n; ++i) {
      const bool ellipse = i % every == 0 || i + 1 == n;  // every K-th and the last
      SLAMD_RETURN_IF_ERROR(add((*poses)[i], true, ellipse));
    }
    for (const Entry& e : *landmarks)
      SLAMD_RETURN_IF_ERROR(add(e, false, options.landmark_ellipses));
    live.scene.robots.push_back(std::move(out));
    live.ellipse_every.push_back(every);
  }
  return live;
}

core::Result<MapPageCollector> FetchLiveMap(LcmClient& client, const server::ChannelNames& channels,
                                            bool covariances, double timeout_s) {
  // Shared with the subscriptions, which outlive this call (they live as long as `client`).
  auto collector = std::make_shared<MapPageCollector>(RandomRequestId());
  SLAMD_RETURN_IF_ERROR(client.Subscribe<slamd::query_reply_t>(
      channels.QueryReply(),
      [collector](const slamd::query_reply_t& r) { collector->AddReply(r); }));
  SLAMD_RETURN_IF_ERROR(client.Subscribe<slamd::map_t>(
      channels.Map(), [collector](const slamd::map_t& m) { collector->AddPage(m); }));

  server::QueryRequest request;
  request.utime = std::chrono::duration_cast<std::chrono::microseconds>(
                      std::chrono::system_clock::now().time_since_epoch())
                      .count();
  request.client = "slamctl-plot";
  request.request_id = collector->request_id();
  request.want_marginals = covariances;
  request.map_robot = "*";
  slamd::query_t query;
  server::ToLcm(request, &query);
  SLAMD_RETURN_IF_ERROR(client.Publish(channels.Inbound<server::QuerySpec>(), query));

  core::Result<bool> done = client.HandleUntil([&] { return collector->Complete(); }, timeout_s);
  if (!done.ok()) return done.status();
  if (!*done) {
    char seconds[32];
    std::snprintf(seconds, sizeof seconds, "%g", timeout_s);
    return core::OutOfRange(std::string("timed out after ") + seconds + " s waiting for " +
                            collector->Missing() + " (query on " +
                            channels.Inbound<server::QuerySpec>() + ", replies on " +
                            channels.QueryReply() + " and " + channels.Map() + ")");
  }
  if (collector->reply().status == slamd::query_reply_t::STATUS_REJECTED) {
    return core::FailedPrecondition("slamd rejected the map query: " + collector->reply().error);
  }
  return *collector;
}

}  // namespace slamd::clients::plot
