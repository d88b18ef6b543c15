// `slamctl plot --live`: the live server's map as a PlotScene (plot_scene.h).
//
// Two steps, kept apart so the conversion is testable without a bus:
//   1. FetchLiveMap: one query_t (map_robot "*", a random request_id, want_marginals for
//      covariances) and the answer: the query_reply_t (whose map_pages is the number of map_t
//      pages published for the request, all robots together) and the map_t pages with that
//      request_id (periodic maps, request_id 0, and other clients' answers are ignored).
//      MapPageCollector decides when the answer is complete: the reply has arrived (from every
//      shard of a sharded slamd, each answering with its own robots: shard_replies.h), every
//      robot seen has all its pages 0 .. page_count-1, and the number of distinct pages equals
//      the replies' map_pages (which catches a robot none of whose pages arrived).
//   2. BuildLiveScene: complete pages -> one PlotRobot per (shard, robot).
//
// Conventions of the conversion (msgs/lcm/map_t.lcm, map_entry_t.lcm):
//   * Robots in name order (stable colours, independent of page arrival order); pose entries in
//     pose-index order form the trajectory; landmarks in id order.
//   * Values are world frame: 2D poses (x, y, θ), 3D poses (x, y, z, qw, qx, qy, qz), landmarks
//     (x, y[, z]). 3D maps are projected top-down (z dropped), as 3D datasets are.
//   * Covariances are tangent space, translation first; poses in the body frame (right
//     perturbation), landmarks in the world frame, i.e. exactly slamd's charts, so
//     core::PlanarCovariance turns them into the world x-y covariance of the ellipse.
//   * Pose ellipses are subsampled as for datasets: poses 0, K, 2K, ... in pose order and the
//     last pose, K = ellipse_every (0: about 50 per robot); entries without a covariance (not
//     requested, or not ready in the server's query budget) get none.
//   * Loop closures are not in map_t, so PlotRobot::loop_closures stays empty.
//
// Thread safety: none needed (plain functions and one single-threaded collector).
#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "clients/slamctl/lcm_client.h"
#include "clients/slamctl/plot_scene.h"
#include "clients/slamctl/shard_replies.h"
#include "core/base/status.h"
#include "server/transport/channels.h"
#include "slamd/map_t.hpp"
#include "slamd/query_reply_t.hpp"

namespace slamd::clients::plot {

// Gathers the answer to one request. Pages of other requests and repeated pages are ignored.
class MapPageCollector {
 public:
  explicit MapPageCollector(std::int64_t request_id) : request_id_(request_id) {}

  // Keeps `page` when its request_id is ours, (shard, robot, page_index) is new, and page_index
  // and page_count are valid and agree with the robot's first kept page. True when kept.
  bool AddPage(const slamd::map_t& page);
  // Merges the first reply of each shard with our request_id (ShardReplies). True when kept.
  bool AddReply(const slamd::query_reply_t& reply) { return replies_.Add(reply); }

  bool has_reply() const { return replies_.any(); }
  const slamd::query_reply_t& reply() const { return replies_.merged(); }
  // Kept pages in arrival order.
  const std::vector<slamd::map_t>& pages() const { return pages_; }
  std::int64_t request_id() const { return request_id_; }

  // True when the reply and every page it announced are here (see the file comment).
  bool Complete() const { return Missing().empty(); }
  // What is still missing, "" when complete; e.g. "the query_reply_t (request 42)" or
  // "robot intel: pages 1, 3 of 4; 1 more page the reply announced (5 of 6 arrived)".
  std::string Missing() const;

 private:
  std::int64_t request_id_;
  ShardReplies replies_{request_id_, ""};
  std::vector<slamd::map_t> pages_;
  struct RobotSeen {
    std::int32_t page_count = 0;        // as the robot's first kept page says
    std::set<std::int32_t> pages = {};  // page indices kept
  };
  std::map<std::pair<std::string, std::string>, RobotSeen> seen_;  // by (shard, robot)
};

struct LiveSceneOptions {
  // Pose ellipses for every K-th pose of each robot (and its last); 0: about 50 per robot. >= 0.
  int ellipse_every = 0;
  // k of the k-sigma ellipses. > 0.
  double sigma = 3.0;
  // Landmark ellipses (for landmarks that carry a covariance).
  bool landmark_ellipses = true;
};

struct LiveScene {
  PlotScene scene;                       // robots only; title and subtitle are the caller's
  std::int64_t update_sequence = 0;  // the solver update the map comes from (the newest shard's)
  std::vector<int> ellipse_every;        // the K used per robot (same order as scene.robots)
  std::int64_t missing_covariances = 0;  // entries that should have had an ellipse and had none
};

// Pages (any order; duplicates allowed) -> scene. Errors (kInvalidArgument, naming the robot
// and entry): incomplete pages (a robot missing page i of n, or conflicting page_count /
// update_sequence / dimension between its pages), a values or covariance array of the wrong
// size for the map's dimension, non-finite values, invalid options.
core::Result<LiveScene> BuildLiveScene(const std::vector<slamd::map_t>& pages,
                                       const LiveSceneOptions& options);

// The LCM round trip: publishes one query_t on the query channel asking for every robot's map
// (with marginals when `covariances`) and handles messages on `client` until the collector is
// complete or timeout_s passes. Errors: kOutOfRange "timed out after S s waiting for <what is
// missing>"; kFailedPrecondition when the server rejects the query (its error); the bus's.
// A reply with STATUS_PARTIAL is not an error (some covariances are missing: see
// LiveScene::missing_covariances). Subscribes `client` for good (meant for one fetch).
core::Result<MapPageCollector> FetchLiveMap(LcmClient& client, const server::ChannelNames& channels,
                                            bool covariances, double timeout_s);

}  // namespace slamd::clients::plot
