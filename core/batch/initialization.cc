#include "core/batch/initialization.h"

#include <Eigen/SparseCholesky>
#include <cmath>
#include <queue>
#include <vector>

#include "core/batch/batch_solver.h"
#include "core/factors/factor.h"
#include "core/factors/prior_factor.h"

namespace slamd::core {
namespace {

// One planar pose-pose measurement in slot numbering.
struct Edge {
  int i, j;  // x_j ≈ x_i ∘ z
  Pose2 z;
  Matrix3 info;  // information of the (x, y, θ) error
};

// One relative-point observation: landmark l ≈ x_i ∘ z.
struct Observation {
  int pose, landmark;
  Point2 z;
  Matrix2 info;
};

struct PlanarGraph {
  std::vector<Edge> edges;
  std::vector<Observation> observations;
  std::vector<std::vector<int>> edges_of;  // per slot: indices into edges
};

// The point a factor on (Pose2, Point2) measures in the pose's frame, if its error is that
// difference (relative point factors; not bearing-range ones).
std::optional<Point2> RelativePoint2Of(const Factor& f) {
  if (f.keys().size() != 2 || f.KeyType(0) != kVariableType<Pose2> ||
      f.KeyType(1) != kVariableType<Point2>) {
    return std::nullopt;
  }
  const std::optional<Variable> z = f.Measured();
  if (!z || !std::holds_alternative<Point2>(*z)) return std::nullopt;
  return std::get<Point2>(*z);
}

PlanarGraph Collect(const FactorGraph& graph, const Values& values) {
  PlanarGraph g;
  g.edges_of.resize(values.size());
  for (const FactorPtr& f : graph) {
    const std::optional<Variable> between = MeasuredRelativePose(*f);
    if (between && std::holds_alternative<Pose2>(*between)) {
      const int i = values.SlotOf(f->keys()[0]), j = values.SlotOf(f->keys()[1]);
      if (i < 0 || j < 0 || i == j) continue;
      g.edges_of[i].push_back(static_cast<int>(g.edges.size()));
      g.edges_of[j].push_back(static_cast<int>(g.edges.size()));
      g.edges.push_back({i, j, std::get<Pose2>(*between), f->noise_model().Information()});
    } else if (const std::optional<Point2> z = RelativePoint2Of(*f)) {
      const int i = values.SlotOf(f->keys()[0]), l = values.SlotOf(f->keys()[1]);
      if (i < 0 || l < 0) continue;
      g.observations.push_back({i, l, *z, f->noise_model().Information()});
    }
  }
  return g;
}

// Prim's algorithm from `root`: parent edge of every reached pose (-1 for the root and unreached).
std::vector<int> SpanningTreeParents(const PlanarGraph& g, int n, int root,
                                     std::vector<int>* order) {
  std::vector<int> parent(n, -1);
  std::vector<char> done(n, 0);
  using Item = std::pair<double, int>;  // (edge cost, edge index)
  std::priority_queue<Item, std::vector<Item>, std::greater<>> frontier;
  auto expand = [&](int v) {
    done[v] = 1;
    order->push_back(v);
    for (int e : g.edges_of[v]) {
      const Edge& edge = g.edges[e];
      if (!done[edge.i == v ? edge.j : edge.i]) frontier.emplace(edge.info.inverse().trace(), e);
    }
  };
  expand(root);
  while (!frontier.empty()) {
    const int e = frontier.top().second;
    frontier.pop();
    const Edge& edge = g.edges[e];
    const int next = done[edge.i] ? edge.j : edge.i;
    if (done[next]) continue;
    parent[next] = e;
    expand(next);
  }
  return parent;
}

// Composes poses along the tree (in the order they were reached).
void ComposeTree(const PlanarGraph& g, const std::vector<int>& parent,
                 const std::vector<int>& order, Values* values) {
  for (int v : order) {
    if (parent[v] < 0) continue;
    const Edge& e = g.edges[parent[v]];
    const Pose2 x = e.j == v ? values->At<Pose2>(values->KeyAt(e.i)).Compose(e.z)
                             : values->At<Pose2>(values->KeyAt(e.j)).Compose(e.z.Inverse());
    values->MutableVariableAt(v) = x;
  }
}

Status CheckReached(const Values& values, const std::vector<int>& parent, int root) {
  for (int s = 0; s < static_cast<int>(values.size()); ++s) {
    if (values.TypeAt(s) == kVariableType<Pose2> && s != root && parent[s] < 0) {
      return InvalidArgument("pose " + KeyToString(values.KeyAt(s)) +
                             " is not connected to the root by pose-pose measurements");
    }
  }
  return Status::Ok();
}

// Places each landmark (Point2) not yet placed from its first observation; relative-point
// observations take precedence over bearing-range ones (pass 0, then pass 1).
void PlaceLandmarksFromFirstObservation(const FactorGraph& graph, std::vector<char> done,
                                        Values* values) {
  for (int pass = 0; pass < 2; ++pass) {
    for (const FactorPtr& f : graph) {
      if (f->keys().size() != 2) continue;
      const bool relative = RelativePoint2Of(*f).has_value();
      if (relative != (pass == 0)) continue;
      const int p = values->SlotOf(f->keys()[0]), l = values->SlotOf(f->keys()[1]);
      if (p < 0 || l < 0 || done[l] || values->TypeAt(p) != kVariableType<Pose2> ||
          values->TypeAt(l) != kVariableType<Point2>) {
        continue;
      }
      if (const std::optional<Variable> v = f->Predict(0, values->VariableAt(p))) {
        values->MutableVariableAt(l) = *v;
        done[l] = 1;
      }
    }
  }
}

// Solves the SPD system assembled from triplets; unknowns of `fixed` rows were eliminated by the
// caller. Returns false when the system is singular.
bool SolveSparse(int n, const std::vector<Eigen::Triplet<double>>& triplets,
                 const Eigen::VectorXd& b, Eigen::VectorXd* x) {
  Eigen::SparseMatrix<double> A(n, n);
  A.setFromTriplets(triplets.begin(), triplets.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(A);
  if (ldlt.info() != Eigen::Success) return false;
  *x = ldlt.solve(b);
  return ldlt.info() == Eigen::Success && x->allFinite();
}

}  // namespace

Result<Values> InitializeSpanningTree(const FactorGraph& graph, const Values& initial, Key root) {
  const int r = initial.SlotOf(root);
  if (r < 0 || initial.TypeAt(r) != kVariableType<Pose2>) {
    return InvalidArgument("root " + KeyToString(root) + " is not a Pose2 variable of the values");
  }
  Values values = initial;
  const PlanarGraph g = Collect(graph, values);
  std::vector<int> order;
  const std::vector<int> parent =
      SpanningTreeParents(g, static_cast<int>(values.size()), r, &order);
  SLAMD_RETURN_IF_ERROR(CheckReached(values, parent, r));
  ComposeTree(g, parent, order, &values);
  PlaceLandmarksFromFirstObservation(graph, std::vector<char>(values.size(), 0), &values);
  return values;
}

Result<Values> InitializeLago(const FactorGraph& graph, const Values& initial, Key root) {
  Result<Values> tree = InitializeSpanningTree(graph, initial, root);
  if (!tree.ok()) return tree.status();
  Values values = std::move(tree).value();
  const PlanarGraph g = Collect(graph, values);
  const int n = static_cast<int>(values.size());
  const int r = values.SlotOf(root);

  // Unknown numbering: every pose but the root gets one angle and one position; every landmark
  // with a relative-point observation gets one position.
  std::vector<int> angle_index(n, -1), position_index(n, -1);
  int num_angles = 0, num_positions = 0;
  for (int s = 0; s < n; ++s) {
    if (s == r) continue;
    if (values.TypeAt(s) == kVariableType<Pose2>) {
      angle_index[s] = num_angles++;
      position_index[s] = num_positions++;
    }
  }
  std::vector<char> placed(n, 0);
  for (const Observation& o : g.observations) {
    if (position_index[o.landmark] < 0 && values.TypeAt(o.landmark) == kVariableType<Point2>) {
      position_index[o.landmark] = num_positions++;
      placed[o.landmark] = 1;
    }
  }

  // (2)+(3) Orientations: θ_j − θ_i = δθ_ij + 2πk_ij, k_ij from the tree's angles, weighted by the
  // marginal information of the angle (1 / Σ_θθ).
  std::vector<double> theta(n, 0.0);
  for (int s = 0; s < n; ++s) {
    if (values.TypeAt(s) == kVariableType<Pose2>)
      theta[s] = values.At<Pose2>(values.KeyAt(s)).theta();
  }
  {
    std::vector<Eigen::Triplet<double>> t;
    Eigen::VectorXd b = Eigen::VectorXd::Zero(num_angles);
    for (const Edge& e : g.edges) {
      const double w = 1.0 / e.info.inverse()(2, 2);
      const double dtheta = e.z.theta();
      const double k = std::round((theta[e.j] - theta[e.i] - dtheta) / (2.0 * M_PI));
      const double rel = dtheta + 2.0 * M_PI * k;  // wanted θ_j − θ_i
      const int a = angle_index[e.i], c = angle_index[e.j];
      // w (θ_j − θ_i − rel)², with the root's θ a constant.
      if (a >= 0) t.emplace_back(a, a, w);
      if (c >= 0) t.emplace_back(c, c, w);
      if (a >= 0 && c >= 0) {
        t.emplace_back(a, c, -w);
        t.emplace_back(c, a, -w);
      }
      if (c >= 0) b[c] += w * (rel + (a < 0 ? theta[e.i] : 0.0));
      if (a >= 0) b[a] -= w * (rel - (c < 0 ? theta[e.j] : 0.0));
    }
    Eigen::VectorXd x;
    if (num_angles > 0 && !SolveSparse(num_angles, t, b, &x)) {
      return NumericalFailure("LAGO orientation estimate: the angle system is singular");
    }
    for (int s = 0; s < n; ++s) {
      if (angle_index[s] >= 0) theta[s] = x[angle_index[s]];
    }
  }

  // (4) Positions with fixed orientations: t_j − t_i = R_i z_t (weight R_i Ω_tt R_iᵀ) and
  // l − t_i = R_i z (weight R_i Ω R_iᵀ).
  std::vector<Point2> position(n, Point2::Zero());
  for (int s = 0; s < n; ++s) {
    if (values.TypeAt(s) == kVariableType<Pose2>)
      position[s] = values.At<Pose2>(values.KeyAt(s)).translation();
  }
  {
    std::vector<Eigen::Triplet<double>> t;
    Eigen::VectorXd b = Eigen::VectorXd::Zero(2 * num_positions);
    auto add = [&](int i, int j, const Vector2& rel, const Matrix2& W) {
      // W-weighted (p_j − p_i − rel)², with the root's position a constant.
      const int a = position_index[i], c = position_index[j];
      for (int u = 0; u < 2; ++u) {
        for (int v = 0; v < 2; ++v) {
          if (a >= 0) t.emplace_back(2 * a + u, 2 * a + v, W(u, v));
          if (c >= 0) t.emplace_back(2 * c + u, 2 * c + v, W(u, v));
          if (a >= 0 && c >= 0) {
            t.emplace_back(2 * a + u, 2 * c + v, -W(u, v));
            t.emplace_back(2 * c + u, 2 * a + v, -W(u, v));
          }
        }
      }
      const Vector2 rhs_j = W * (rel + (a < 0 ? position[i] : Vector2::Zero()));
      const Vector2 rhs_i = W * (rel - (c < 0 ? position[j] : Vector2::Zero()));
      if (c >= 0) b.segment<2>(2 * c) += rhs_j;
      if (a >= 0) b.segment<2>(2 * a) -= rhs_i;
    };
    for (const Edge& e : g.edges) {
      const Matrix2 Ri = Rot2::FromAngle(theta[e.i]).matrix();
      // Rotating the error (x, y) of the measurement frame into the world: R_i R_z.
      const Matrix2 Rw = Ri * e.z.rotation().matrix();
      const Matrix2 W = Rw * e.info.topLeftCorner<2, 2>() * Rw.transpose();
      add(e.i, e.j, Ri * e.z.translation(), W);
    }
    for (const Observation& o : g.observations) {
      const Matrix2 Ri = Rot2::FromAngle(theta[o.pose]).matrix();
      add(o.pose, o.landmark, Ri * o.z, Ri * o.info * Ri.transpose());
    }
    Eigen::VectorXd x;
    if (num_positions > 0 && !SolveSparse(2 * num_positions, t, b, &x)) {
      return NumericalFailure("LAGO position estimate: the position system is singular");
    }
    for (int s = 0; s < n; ++s) {
      if (position_index[s] >= 0) position[s] = x.segment<2>(2 * position_index[s]);
    }
  }

  for (int s = 0; s < n; ++s) {
    if (s == r) continue;
    if (values.TypeAt(s) == kVariableType<Pose2>) {
      values.MutableVariableAt(s) = Pose2(Rot2::FromAngle(theta[s]), position[s]);
    } else if (placed[s]) {
      values.MutableVariableAt(s) = position[s];
    }
  }
  PlaceLandmarksFromFirstObservation(graph, placed, &values);
  return values;
}

}  // namespace slamd::core

namespace slamd::core {

Result<Values> InitializeIncremental(const FactorGraph& graph, const Values& initial,
                                     const std::vector<Key>& poses, int chunk) {
  if (chunk < 1)
    return InvalidArgument("incremental initialisation chunk " + std::to_string(chunk) + " < 1");
  if (poses.empty()) return initial;
  const int n = static_cast<int>(initial.size());
  // Step at which each variable becomes active: poses by their position in `poses`, landmarks
  // with their first observing pose; each factor is active from its latest variable's step.
  std::vector<int> step_of(n, -1);
  for (int k = 0; k < static_cast<int>(poses.size()); ++k) {
    const int s = initial.SlotOf(poses[k]);
    if (s < 0) return NotFound("pose " + KeyToString(poses[k]) + " has no initial value");
    step_of[s] = k;
  }
  std::vector<int> factor_step(graph.size(), -1);
  for (std::size_t f = 0; f < graph.size(); ++f) {
    int pose_step = -1;
    for (Key key : graph[f]->keys()) {
      const int s = initial.SlotOf(key);
      if (s >= 0 && step_of[s] >= 0) pose_step = std::max(pose_step, step_of[s]);
    }
    factor_step[f] = pose_step;
    // A landmark (any non-pose variable) is encoded as -2 - (step of its first observation).
    for (Key key : graph[f]->keys()) {
      const int s = initial.SlotOf(key);
      if (s < 0 || pose_step < 0 || step_of[s] >= 0) continue;
      if (step_of[s] == -1 || pose_step < -2 - step_of[s]) step_of[s] = -2 - pose_step;
    }
  }
  auto active_at = [&](int slot) {
    return step_of[slot] >= 0 ? step_of[slot] : -2 - step_of[slot];
  };

  Values estimate = initial;
  std::vector<char> placed(n, 0);
  placed[initial.SlotOf(poses[0])] = 1;
  std::vector<std::size_t> by_step(graph.size());
  for (std::size_t f = 0; f < graph.size(); ++f) by_step[f] = f;
  std::stable_sort(by_step.begin(), by_step.end(),
                   [&](std::size_t a, std::size_t b) { return factor_step[a] < factor_step[b]; });
  std::size_t next_factor = 0;
  FactorGraph active;
  BatchParams gn{.algorithm = BatchParams::Algorithm::kLevenbergMarquardt,
                 .max_iterations = 10,
                 .relative_tolerance = 1e-6,
                 .absolute_tolerance = 1e-6};
  const int num_poses = static_cast<int>(poses.size());
  for (int begin = 0; begin < num_poses; begin += chunk) {
    const int end = std::min(num_poses, begin + chunk);
    // Add the factors of this chunk, placing each new variable from the first factor that
    // connects it to a placed one.
    while (next_factor < by_step.size() && factor_step[by_step[next_factor]] < end) {
      const FactorPtr& f = graph[by_step[next_factor++]];
      if (factor_step[by_step[next_factor - 1]] < 0) continue;  // touches no pose
      active.Add(f);
      if (f->keys().size() != 2) continue;
      const int a = estimate.SlotOf(f->keys()[0]), b = estimate.SlotOf(f->keys()[1]);
      if (a < 0 || b < 0 || placed[a] == placed[b]) continue;
      const int known = placed[a] ? 0 : 1;
      const std::optional<Variable> v = f->Predict(known, estimate.VariableAt(placed[a] ? a : b));
      if (!v) continue;
      estimate.MutableVariableAt(placed[a] ? b : a) = *v;
      placed[a] = placed[b] = 1;
    }
    // Optimise the active part: the variables of active factors.
    Values sub;
    for (int s = 0; s < n; ++s) {
      if (active_at(s) < end && step_of[s] != -1)
        (void)sub.Insert(estimate.KeyAt(s), estimate.VariableAt(s));
    }
    FactorGraph anchored = active;
    anchored.Emplace<PriorFactor<Pose2>>(poses[0], initial.At<Pose2>(poses[0]),
                                         *NoiseModel::Isotropic(3, 1e-3));
    const BatchResult r = Optimize(anchored, sub, gn);
    if (!r.status.ok()) return r.status;
    for (Key key : r.values.keys())
      estimate.MutableVariableAt(estimate.SlotOf(key)) = r.values.Get(key);
  }
  return estimate;
}

}  // namespace slamd::core

namespace slamd::core {

Result<InitialGuess> ParseInitialGuess(std::string_view name) {
  if (name == "file") return InitialGuess::kAsGiven;
  if (name == "spanning-tree") return InitialGuess::kSpanningTree;
  if (name == "lago") return InitialGuess::kLago;
  if (name == "incremental") return InitialGuess::kIncremental;
  return InvalidArgument("unknown initial guess '" + std::string(name) +
                         "' (expected file, spanning-tree, lago or incremental)");
}

const char* InitialGuessName(InitialGuess method) {
  switch (method) {
    case InitialGuess::kAsGiven:
      return "file";
    case InitialGuess::kSpanningTree:
      return "spanning-tree";
    case InitialGuess::kLago:
      return "lago";
    case InitialGuess::kIncremental:
      return "incremental";
  }
  return "?";
}

Result<Values> MakeInitialGuess(InitialGuess method, const FactorGraph& graph,
                                const Values& initial, const std::vector<Key>& poses, int chunk) {
  if (method == InitialGuess::kAsGiven) return initial;
  if (poses.empty()) return InvalidArgument("an initial guess needs at least one pose");
  for (Key key : poses) {
    if (initial.Find<Pose2>(key) == nullptr) {
      return InvalidArgument("this initial guess supports planar (Pose2) graphs only; " +
                             KeyToString(key) + " is not a Pose2");
    }
  }
  switch (method) {
    case InitialGuess::kSpanningTree:
      return InitializeSpanningTree(graph, initial, poses.front());
    case InitialGuess::kLago:
      return InitializeLago(graph, initial, poses.front());
    case InitialGuess::kIncremental:
      return InitializeIncremental(graph, initial, poses, chunk);
    case InitialGuess::kAsGiven:
      break;
  }
  return initial;
}

}  // namespace slamd::core
