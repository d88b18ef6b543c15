// Writing a synthetic world: the dataset files (through core/io's WriteG2o / WriteIsam), the
// ground truth, inter_robot.txt, outliers.txt and the raw bearing-range measurements.
#include <string>
#include <vector>

#include "clients/slamctl/sim_text.h"
#include "clients/slamctl/sim_world.h"

namespace slamd::clients::sim {

namespace {

using core::Pose2;
using core::Pose3;

double SigmaWritten(double sigma) { return sigma > 0.0 ? sigma : kZeroSigmaFloor; }

std::string RobotName(int robot) { return "robot" + std::to_string(robot); }

std::string Header(const SimWorld& world) {
  const SimParams& p = world.params;
  return "# slamctl sim " + std::string(WorldKindName(p.world)) + " --seed " +
         std::to_string(p.seed) + " --steps " + std::to_string(p.steps) + " --robots " +
         std::to_string(p.robots) + " --outliers " + Num(p.outliers) + "\n";
}

std::string InterRobotText(const SimWorld& world, std::vector<int>* line_of_edge) {
  std::string out = Header(world);
  out +=
      "# Inter-robot loop closures, one per line, in generation order: pose idxB of robotB seen\n"
      "# from pose idxA of robotA (x_B = x_A * z), indices local to each robot's file.\n"
      "# INTER_SE2 robotA idxA robotB idxB dx dy dtheta I11 I12 I13 I22 I23 I33\n"
      "# INTER_SE3 robotA idxA robotB idxB x y z qx qy qz qw + 21 values\n"
      "# Information matrices: upper triangle, row-major, g2o order ((x, y, theta); (t, R)).\n";
  line_of_edge->assign(world.edges.size(), -1);
  int line = 0;
  for (std::size_t i = 0; i < world.edges.size(); ++i) {
    const SimEdge& e = world.edges[i];
    if (e.kind != SimEdge::Kind::kInterRobot) continue;
    (*line_of_edge)[i] = line++;
    out += world.is_3d ? "INTER_SE3" : "INTER_SE2";
    Append(&out, RobotName(e.robot_a));
    Append(&out, std::to_string(e.idx_a));
    Append(&out, RobotName(e.robot_b));
    Append(&out, std::to_string(e.idx_b));
    if (world.is_3d) {
      const Pose3& z = std::get<Pose3>(e.measured);
      const Eigen::Quaterniond q = z.rotation().ToQuaternion();
      for (double v : {z.translation().x(), z.translation().y(), z.translation().z(), q.x(), q.y(),
                       q.z(), q.w()}) {
        Append(&out, v);
      }
    } else {
      const Pose2& z = std::get<Pose2>(e.measured);
      for (double v : {z.x(), z.y(), z.theta()}) Append(&out, v);
    }
    const Eigen::MatrixXd info = e.noise.Information();
    for (int r = 0; r < info.rows(); ++r) {
      for (int c = r; c < info.cols(); ++c) Append(&out, info(r, c));
    }
    out += "\n";
  }
  return out;
}

std::string BearingRangeText(const SimWorld& world, int robot) {
  std::string out = Header(world);
  out +=
      "# The raw bearing-range measurements behind the dataset's landmark observations, in the\n"
      "# same order: BEARING_RANGE pose landmark bearing range sigma_bearing sigma_range\n"
      "# (bearing in radians from the pose's x axis, range in metres; independent noises).\n";
  const SimParams& p = world.params;
  for (const SimObservation& o : world.observations) {
    if (o.robot != robot) continue;
    out += "BEARING_RANGE";
    Append(&out, std::to_string(o.idx));
    Append(&out, std::to_string(o.landmark));
    for (double v :
         {o.bearing, o.range, SigmaWritten(p.sigma_bearing), SigmaWritten(p.sigma_range)}) {
      Append(&out, v);
    }
    out += "\n";
  }
  return out;
}

}  // namespace

core::Status WriteWorld(const SimWorld& world, const std::string& dir,
                        std::vector<std::string>* written) {
  const int robots = static_cast<int>(world.truth.size());
  const bool landmark_world = world.params.world == WorldKind::kLandmarks;
  std::string outliers =
      Header(world) +
      "# Loop closures replaced by random wrong ones (--outliers), one per line:\n"
      "# FILE FACTOR robotA idxA robotB idxB\n"
      "# FACTOR is the 0-based index of the edge in core::ReadDataset(FILE).graph\n"
      "# (the order of the edge lines); for inter_robot.txt, the 0-based index\n"
      "# among its INTER_ lines.\n";
  std::vector<std::vector<int>> factor_of_edge(robots);
  for (int k = 0; k < robots; ++k) {
    const std::string prefix = robots == 1 ? std::string("world") : RobotName(k);
    core::Dataset d = RobotDataset(world, k, &factor_of_edge[k]);
    SLAMD_RETURN_IF_ERROR(core::WriteG2o(d, dir + "/" + prefix + ".g2o"));
    written->push_back(prefix + ".g2o");
    if (landmark_world) {
      SLAMD_RETURN_IF_ERROR(core::WriteIsam(d, dir + "/" + prefix + ".isam"));
      written->push_back(prefix + ".isam");
      if (world.params.observation == ObservationKind::kBearingRange) {
        SLAMD_RETURN_IF_ERROR(
            WriteText(dir + "/" + prefix + "_bearing_range.txt", BearingRangeText(world, k)));
        written->push_back(prefix + "_bearing_range.txt");
      }
    }
    core::Dataset truth;
    truth.is_3d = world.is_3d;
    truth.poses = d.poses;
    truth.landmarks = d.landmarks;
    truth.initial = RobotTruth(world, k);
    SLAMD_RETURN_IF_ERROR(core::WriteG2o(truth, dir + "/" + prefix + "_groundtruth.g2o"));
    written->push_back(prefix + "_groundtruth.g2o");
  }
  std::vector<int> line_of_edge(world.edges.size(), -1);
  if (robots > 1) {
    SLAMD_RETURN_IF_ERROR(
        WriteText(dir + "/inter_robot.txt", InterRobotText(world, &line_of_edge)));
    written->push_back("inter_robot.txt");
  }
  for (std::size_t i = 0; i < world.edges.size(); ++i) {
    const SimEdge& e = world.edges[i];
    if (!e.outlier) continue;
    const bool inter = e.kind == SimEdge::Kind::kInterRobot;
    const std::string file = inter         ? "inter_robot.txt"
                             : robots == 1 ? "world.g2o"
                                           : RobotName(e.robot_a) + ".g2o";
    const int factor = inter ? line_of_edge[i] : factor_of_edge[e.robot_a][i];
    outliers += file;
    for (const std::string& word :
         {std::to_string(factor), RobotName(e.robot_a), std::to_string(e.idx_a),
          RobotName(e.robot_b), std::to_string(e.idx_b)}) {
      Append(&outliers, word);
    }
    outliers += "\n";
  }
  SLAMD_RETURN_IF_ERROR(WriteText(dir + "/outliers.txt", outliers));
  written->push_back("outliers.txt");
  return core::Status::Ok();
}

}  // namespace slamd::clients::sim
