// Query service: answers query_t requests and collects robot maps from the estimator's current
// state (estimates θ ⊕ δ and marginal covariances at the estimate). Runs on the estimator
// thread, between updates, so every answer reflects all messages queued before the query.
//
// Bounded time: marginals are computed until `budget_s` has passed; what is left gets no
// covariance and the answer is marked partial (query_reply_t.STATUS_PARTIAL). Estimates are
// always complete.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "core/variables/variable.h"
#include "server/estimator/estimator.h"
#include "server/messages/inbound.h"

namespace slamd::server {

struct VariableAnswer {
  WireKey key;
  bool found = false;
  core::Variable value;
  Eigen::MatrixXd covariance;  // empty: not requested or not ready in time
};

struct QueryAnswer {
  bool partial = false;                 // some requested covariance is missing (see error)
  std::string error;                    // why, when partial
  std::vector<VariableAnswer> results;  // one per queried key, in query order
  Eigen::MatrixXd joint;                // joint covariance of all keys, when requested and found
};

QueryAnswer AnswerQuery(Estimator& estimator, const QueryRequest& query, double budget_s);

struct MapEntry {
  std::uint64_t index = 0;          // pose index or landmark id
  core::Variable value;             // world frame
  Eigen::MatrixXd covariance = {};  // empty when not requested / not ready
};

struct RobotMap {
  std::string robot;
  bool is3d = false;
  std::vector<MapEntry> poses = {};      // by pose index
  std::vector<MapEntry> landmarks = {};  // by landmark id
};

// The maps of `robot` (a name) or of every robot ("*"), in registration order, then (for "*")
// the shared map's landmarks as the map of robot "" when there are any; an unknown robot gives
// none. With `marginals`, every variable's covariance (one pass over the Bayes tree); a
// budget overrun leaves the rest without and sets *partial.
std::vector<RobotMap> CollectMaps(Estimator& estimator, const std::string& robot, bool marginals,
                                  double budget_s, bool* partial);

}  // namespace slamd::server
