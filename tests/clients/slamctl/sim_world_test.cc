// The synthetic worlds: determinism, read-back through core/io, ground truth consistent with the
// noiseless measurements, plausible noise statistics, outliers, multi-robot files, and a batch
// solve of a noise-free world that recovers the truth.
#include "clients/slamctl/sim_world.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

#include "core/batch/batch_solver.h"
#include "core/factors/between_factor.h"
#include "core/io/dataset.h"
#include "tests/testing/files.h"
#include "tests/testing/read_dataset.h"

namespace slamd::clients::sim {
namespace {

namespace fs = std::filesystem;
using core::Dataset;
using core::MakeKey;
using core::Pose2;
using core::Pose3;

using testing::MustReadDataset;
using testing::ReadFileBytes;
using testing::TempDir;

SimWorld MustGenerate(const SimParams& params) {
  core::Result<SimWorld> world = Generate(params);
  EXPECT_TRUE(world.ok()) << world.status().ToString();
  return std::move(world).value();
}

std::vector<std::string> MustWrite(const SimWorld& world, const TempDir& dir) {
  std::vector<std::string> written;
  const core::Status status = WriteWorld(world, dir.path(), &written);
  EXPECT_TRUE(status.ok()) << status.ToString();
  return written;
}

// The ground truth as read back from the *_groundtruth.g2o file.
core::Values TruthFromFile(const std::string& path) { return MustReadDataset(path).initial; }

SimParams Small(WorldKind kind) {
  SimParams p;
  p.world = kind;
  p.steps = kind == WorldKind::kSphere ? 144 : 150;
  p.seed = 7;
  return p;
}

const WorldKind kAllWorlds[] = {WorldKind::kManhattan, WorldKind::kLandmarks, WorldKind::kSphere,
                                WorldKind::kHelix};

TEST(SimWorld, SameSeedSameBytesOtherSeedOtherBytes) {
  for (const WorldKind kind : kAllWorlds) {
    SimParams p = Small(kind);
    p.outliers = 0.1;
    TempDir a, b, c;
    const std::vector<std::string> files = MustWrite(MustGenerate(p), a);
    MustWrite(MustGenerate(p), b);
    p.seed = 8;
    MustWrite(MustGenerate(p), c);
    ASSERT_GE(files.size(), 3u);
    for (const std::string& f : files) {
      EXPECT_EQ(ReadFileBytes(a.File(f)), ReadFileBytes(b.File(f)))
          << WorldKindName(kind) << " " << f;
      EXPECT_FALSE(ReadFileBytes(a.File(f)).empty()) << f;
    }
    EXPECT_NE(ReadFileBytes(a.File("world.g2o")), ReadFileBytes(c.File("world.g2o")))
        << WorldKindName(kind);
  }
}

TEST(SimWorld, ReadsBackWithTheExpectedCounts) {
  for (const WorldKind kind : kAllWorlds) {
    const SimWorld w = MustGenerate(Small(kind));
    TempDir dir;
    MustWrite(w, dir);
    std::size_t loops = 0;
    for (const SimEdge& e : w.edges) loops += e.kind == SimEdge::Kind::kLoop;
    const Dataset d = MustReadDataset(dir.File("world.g2o"));
    SCOPED_TRACE(WorldKindName(kind));
    EXPECT_EQ(d.is_3d, kind == WorldKind::kSphere || kind == WorldKind::kHelix);
    EXPECT_EQ(d.poses.size(), static_cast<std::size_t>(w.params.steps));
    EXPECT_EQ(d.num_pose_edges, w.edges.size());
    EXPECT_EQ(d.num_pose_edges, w.params.steps - 1 + loops);
    EXPECT_GT(loops, 5u);
    EXPECT_EQ(d.landmarks.size(), w.landmarks.size());
    EXPECT_EQ(d.num_landmark_observations, w.observations.size());
    // The initial guess is the odometry composition, not the truth.
    const core::Values truth = TruthFromFile(dir.File("world_groundtruth.g2o"));
    ASSERT_EQ(truth.size(), d.initial.size());
    const core::Key last = d.poses.back();
    if (d.is_3d) {
      EXPECT_TRUE(truth.At<Pose3>(d.poses[0]).Equals(Pose3(), 1e-12));
      EXPECT_FALSE(truth.At<Pose3>(last).Equals(d.initial.At<Pose3>(last), 1e-3));
    } else {
      EXPECT_TRUE(truth.At<Pose2>(d.poses[0]).Equals(Pose2(), 1e-12));
      EXPECT_FALSE(truth.At<Pose2>(last).Equals(d.initial.At<Pose2>(last), 1e-3));
    }
    if (kind == WorldKind::kLandmarks) {
      EXPECT_GT(w.landmarks.size(), 10u);
      const Dataset isam = MustReadDataset(dir.File("world.isam"));
      EXPECT_EQ(isam.format, core::DatasetFormat::kIsam);
      EXPECT_EQ(isam.graph.size(), d.graph.size());
      EXPECT_EQ(isam.landmarks, d.landmarks);
      // Same measurements and noise (the iSAM file has no vertices, so only the factors).
      for (std::size_t i = 0; i < d.graph.size(); ++i) {
        EXPECT_NEAR(isam.graph[i]->Chi2(truth), d.graph[i]->Chi2(truth),
                    1e-9 * (1 + d.graph[i]->Chi2(truth)))
            << i;
      }
    }
  }
}

// Every factor's (unwhitened) error at the ground truth is zero without noise.
void ExpectConsistent(const core::FactorGraph& graph, const core::Values& truth, double tol) {
  double worst = 0;
  for (const core::FactorPtr& f : graph)
    worst = std::max(worst, f->Error(truth).cwiseAbs().maxCoeff());
  EXPECT_LT(worst, tol);
}

TEST(SimWorld, NoiselessMeasurementsMatchTheGroundTruth) {
  for (const WorldKind kind : kAllWorlds) {
    for (const bool noise_free_flag : {true, false}) {
      SimParams p = Small(kind);
      if (noise_free_flag) {
        p.noise_free = true;
      } else {  // zero sigmas: also exact
        p.sigma_translation = p.sigma_rotation = p.sigma_bearing = p.sigma_range = 0;
      }
      const SimWorld w = MustGenerate(p);
      TempDir dir;
      MustWrite(w, dir);
      SCOPED_TRACE(std::string(WorldKindName(kind)) + (noise_free_flag ? " noise-free" : " zero"));
      const core::Values truth = TruthFromFile(dir.File("world_groundtruth.g2o"));
      ExpectConsistent(MustReadDataset(dir.File("world.g2o")).graph, truth, 1e-9);
      if (kind == WorldKind::kLandmarks) {
        ExpectConsistent(MustReadDataset(dir.File("world.isam")).graph, truth, 1e-9);
      }
    }
  }
  // The relative-point observation model too.
  SimParams p = Small(WorldKind::kLandmarks);
  p.observation = ObservationKind::kRelativePoint;
  p.noise_free = true;
  const SimWorld w = MustGenerate(p);
  ExpectConsistent(RobotDataset(w, 0).graph, RobotTruth(w, 0), 1e-9);
}

TEST(SimWorld, NoiseFreeWorldSharesEverythingButTheNoise) {
  SimParams p = Small(WorldKind::kLandmarks);
  const SimWorld noisy = MustGenerate(p);
  p.noise_free = true;
  const SimWorld exact = MustGenerate(p);
  ASSERT_EQ(noisy.edges.size(), exact.edges.size());
  ASSERT_EQ(noisy.observations.size(), exact.observations.size());
  for (std::size_t i = 0; i < noisy.truth[0].size(); ++i) {
    EXPECT_TRUE(std::get<Pose2>(noisy.truth[0][i]).Equals(std::get<Pose2>(exact.truth[0][i]), 0));
  }
}

// Chi2 per degree of freedom of the whitened residuals at the truth: about 1 with noise.
double Chi2PerDof(const SimWorld& w) {
  const Dataset d = RobotDataset(w, 0);
  const core::Values truth = RobotTruth(w, 0);
  double chi2 = 0;
  std::size_t dof = 0;
  for (const core::FactorPtr& f : d.graph) {
    chi2 += f->Chi2(truth);
    dof += f->dim();
  }
  return chi2 / dof;
}

TEST(SimWorld, WhitenedResidualsAtTheTruthHaveUnitVariance) {
  for (const WorldKind kind : kAllWorlds) {
    SimParams p;
    p.world = kind;
    p.steps = 3000;
    p.seed = 11;
    p.sigma_translation = 0.1;
    p.sigma_rotation = 0.05;
    const double c = Chi2PerDof(MustGenerate(p));
    RecordProperty(std::string("chi2_per_dof_") + WorldKindName(kind), std::to_string(c));
    EXPECT_GT(c, 0.9) << WorldKindName(kind);
    EXPECT_LT(c, 1.1) << WorldKindName(kind);
  }
  SimParams p;
  p.world = WorldKind::kLandmarks;
  p.steps = 1500;
  p.observation = ObservationKind::kRelativePoint;
  p.sigma_point = 0.2;
  const double c = Chi2PerDof(MustGenerate(p));
  RecordProperty("chi2_per_dof_relative_point", std::to_string(c));
  EXPECT_GT(c, 0.9);
  EXPECT_LT(c, 1.1);
}

struct OutlierLine {
  std::string file;
  int factor;
};

std::vector<OutlierLine> ReadOutliers(const std::string& path) {
  std::ifstream in(path);
  std::vector<OutlierLine> lines;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    OutlierLine o;
    s >> o.file >> o.factor;
    lines.push_back(o);
  }
  return lines;
}

TEST(SimWorld, OutliersFileListsTheWrongLoopClosures) {
  for (const WorldKind kind : {WorldKind::kManhattan, WorldKind::kSphere}) {
    SimParams p = Small(kind);
    p.steps = 400;
    p.outliers = 0.3;
    const SimWorld w = MustGenerate(p);
    TempDir dir;
    MustWrite(w, dir);
    std::size_t loops = 0;
    for (const SimEdge& e : w.edges) loops += e.kind != SimEdge::Kind::kOdometry;
    const std::vector<OutlierLine> listed = ReadOutliers(dir.File("outliers.txt"));
    SCOPED_TRACE(WorldKindName(kind));
    EXPECT_EQ(listed.size(), static_cast<std::size_t>(std::llround(0.3 * loops)));
    EXPECT_GT(listed.size(), 20u);
    const Dataset d = MustReadDataset(dir.File("world.g2o"));
    const core::Values truth = TruthFromFile(dir.File("world_groundtruth.g2o"));
    std::set<int> outliers;
    for (const OutlierLine& o : listed) {
      EXPECT_EQ(o.file, "world.g2o");
      outliers.insert(o.factor);
    }
    EXPECT_EQ(outliers.size(), listed.size());
    // Listed edges are far off at the truth; every other edge fits it (chi2 of 6 dof > 60 has
    // probability ~1e-10).
    for (std::size_t i = 0; i < d.graph.size(); ++i) {
      const double chi2 = d.graph[i]->Chi2(truth);
      if (outliers.count(static_cast<int>(i))) {
        EXPECT_GT(chi2, 1000) << "factor " << i;
      } else {
        EXPECT_LT(chi2, 60) << "factor " << i;
      }
    }
  }
}

TEST(SimWorld, SeveralRobotsWriteOneFilePerRobotAndInterRobotClosures) {
  for (const WorldKind kind : {WorldKind::kLandmarks, WorldKind::kHelix}) {
    SimParams p = Small(kind);
    p.robots = 3;
    p.noise_free = true;
    p.outliers = 0.2;
    const SimWorld w = MustGenerate(p);
    TempDir dir;
    MustWrite(w, dir);
    SCOPED_TRACE(WorldKindName(kind));
    std::vector<core::Values> truth;
    for (int k = 0; k < 3; ++k) {
      const std::string name = "robot" + std::to_string(k);
      const Dataset d = MustReadDataset(dir.File(name + ".g2o"));
      EXPECT_EQ(d.poses.size(), static_cast<std::size_t>(p.steps));
      truth.push_back(TruthFromFile(dir.File(name + "_groundtruth.g2o")));
      if (kind == WorldKind::kLandmarks) {
        EXPECT_TRUE(fs::exists(dir.File(name + ".isam")));
      }
    }
    // Outlier-free inter-robot closures agree with the ground truth of both robots.
    std::set<int> outlier_lines;
    for (const OutlierLine& o : ReadOutliers(dir.File("outliers.txt"))) {
      if (o.file == "inter_robot.txt") outlier_lines.insert(o.factor);
    }
    std::ifstream in(dir.File("inter_robot.txt"));
    int lines = 0, checked = 0;
    for (std::string line; std::getline(in, line);) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream s(line);
      std::string tag, ra, rb;
      int ia, ib;
      s >> tag >> ra >> ia >> rb >> ib;
      const int a = ra.back() - '0', b = rb.back() - '0';
      const bool outlier = outlier_lines.count(lines++) > 0;
      if (kind == WorldKind::kLandmarks) {
        ASSERT_EQ(tag, "INTER_SE2");
        double x, y, th, info[6];
        s >> x >> y >> th;
        for (double& v : info) s >> v;
        ASSERT_FALSE(s.fail()) << line;
        const Pose2 expected =
            truth[a].At<Pose2>(MakeKey('x', ia)).Between(truth[b].At<Pose2>(MakeKey('x', ib)));
        EXPECT_EQ(expected.Equals(Pose2(x, y, th), 1e-9), !outlier) << line;
        EXPECT_NEAR(info[0], 1 / (0.05 * 0.05), 1e-6);
      } else {
        ASSERT_EQ(tag, "INTER_SE3");
        double t[3], q[4], info[21];
        for (double& v : t) s >> v;
        for (double& v : q) s >> v;
        for (double& v : info) s >> v;
        ASSERT_FALSE(s.fail()) << line;
        const Pose3 measured(core::Rot3::FromQuaternion(q[3], q[0], q[1], q[2]),
                             core::Point3(t[0], t[1], t[2]));
        const Pose3 expected =
            truth[a].At<Pose3>(MakeKey('x', ia)).Between(truth[b].At<Pose3>(MakeKey('x', ib)));
        EXPECT_EQ(expected.Equals(measured, 1e-9), !outlier) << line;
      }
      checked += !outlier;
    }
    std::size_t inter = 0;
    for (const SimEdge& e : w.edges) inter += e.kind == SimEdge::Kind::kInterRobot;
    EXPECT_EQ(lines, static_cast<int>(inter));
    EXPECT_GT(checked, 3);
  }
}

TEST(SimWorld, BatchSolveOfANoiseFreeWorldRecoversTheTruth) {
  for (const WorldKind kind : kAllWorlds) {
    SimParams p = Small(kind);
    p.steps = 100;
    p.noise_free = true;
    const SimWorld w = MustGenerate(p);
    Dataset d = RobotDataset(w, 0);
    const core::Values truth = RobotTruth(w, 0);
    // Start away from the truth (the noise-free odometry guess would be the truth itself).
    SimParams noisy = p;
    noisy.noise_free = false;
    const Dataset start = RobotDataset(MustGenerate(noisy), 0);
    ASSERT_TRUE(core::AddGaugePrior(truth, d.poses[0], 1e-6, &d.graph).ok());
    const core::BatchResult r = core::Optimize(d.graph, start.initial);
    SCOPED_TRACE(WorldKindName(kind));
    ASSERT_TRUE(r.status.ok()) << r.status.ToString();
    EXPECT_LT(r.summary.final_chi2, 1e-12);
    for (const core::Key key : d.poses) {
      if (d.is_3d) {
        EXPECT_TRUE(r.values.At<Pose3>(key).Equals(truth.At<Pose3>(key), 1e-6));
      } else {
        EXPECT_TRUE(r.values.At<Pose2>(key).Equals(truth.At<Pose2>(key), 1e-6));
      }
    }
    for (const core::Key key : d.landmarks) {
      EXPECT_LT((r.values.At<core::Point2>(key) - truth.At<core::Point2>(key)).norm(), 1e-6);
    }
  }
}

// A fixed side keeps the robots in the same square however long they drive: a lifelong world
// they revisit again and again.
TEST(SimWorld, FixedSideKeepsEveryPoseInTheSquare) {
  const SimWorld w = MustGenerate(
      {.world = WorldKind::kLandmarks, .seed = 4, .steps = 3000, .robots = 2, .side = 20});
  for (const std::vector<core::Variable>& robot : w.truth) {
    for (const core::Variable& v : robot) {
      const core::Pose2& x = std::get<core::Pose2>(v);
      EXPECT_GE(x.x(), -10.0);
      EXPECT_LT(x.x(), 10.0);
      EXPECT_GE(x.y(), -10.0);
      EXPECT_LT(x.y(), 10.0);
    }
  }
  EXPECT_EQ(SimParams{.side = -1}.Validate().message(), "SimParams::side = -1; violates >= 0");
}

// A patrol: each robot walks `patrol` steps, goes back to its start, and then drives that
// closed route again and again, one metre per step and inside the square.
TEST(SimWorld, PatrolRepeatsOneClosedRoute) {
  constexpr int kPatrol = 60, kSteps = 700;
  const SimWorld w = MustGenerate({.world = WorldKind::kLandmarks,
                                   .seed = 9,
                                   .steps = kSteps,
                                   .robots = 3,
                                   .side = 30,
                                   .patrol = kPatrol});
  for (const std::vector<core::Variable>& robot : w.truth) {
    std::vector<core::Vector2> at;
    for (const core::Variable& v : robot) at.push_back(std::get<core::Pose2>(v).translation());
    for (int t = 1; t < kSteps; ++t) {
      EXPECT_NEAR((at[t] - at[t - 1]).norm(), 1.0, 1e-12) << t;
      EXPECT_LE(at[t].cwiseAbs().maxCoeff(), 15.0);
    }
    // The route's length: the first step after the walk that is back at the start.
    int length = kPatrol + 1;
    while (length < kSteps && at[length] != at[0]) ++length;
    ASSERT_LT(length, kPatrol + 2 * 30);  // at most the way back across the square
    for (int t = kPatrol + 1; t < kSteps; ++t) {
      EXPECT_EQ(at[t], at[t % length]) << t;
      if (t > length) {  // later laps: the same poses, heading included (but at the start,
                         // where it arrives from the way back)
        EXPECT_EQ(std::get<core::Pose2>(robot[t]).theta(),
                  std::get<core::Pose2>(robot[t - length]).theta())
            << t;
      }
    }
  }
  // Random walks never repeat like that.
  const SimWorld walk = MustGenerate(
      {.world = WorldKind::kLandmarks, .seed = 9, .steps = kSteps, .robots = 3, .side = 30});
  EXPECT_NE(std::get<core::Pose2>(walk.truth[0][kSteps - 1]).translation(),
            std::get<core::Pose2>(w.truth[0][kSteps - 1]).translation());
  EXPECT_EQ(SimParams{.patrol = -1}.Validate().message(), "SimParams::patrol = -1; violates >= 0");
}

TEST(SimWorld, ValidateNamesTheField) {
  SimParams p;
  p.sigma_translation = -1;
  EXPECT_NE(Generate(p).status().message().find("sigma_translation"), std::string::npos);
  p = SimParams{};
  p.outliers = 1.5;
  EXPECT_NE(Generate(p).status().message().find("outliers"), std::string::npos);
  p = SimParams{};  // a noise model beyond NoiseModel's condition limit
  p.sigma_translation = 1e5;
  EXPECT_NE(Generate(p).status().message().find("sigma_translation"), std::string::npos);
  p = SimParams{};
  p.world = WorldKind::kLandmarks;
  p.sigma_bearing = 1e-9;
  p.sigma_range = 10;
  EXPECT_NE(Generate(p).status().message().find("sigma_bearing"), std::string::npos);
  p.observation = ObservationKind::kRelativePoint;  // then the bearing sigma is unused
  p.steps = 20;
  EXPECT_TRUE(Generate(p).ok());
  p = SimParams{};
  p.steps = 1;
  EXPECT_FALSE(Generate(p).ok());
  WorldKind kind;
  EXPECT_FALSE(ParseWorldKind("moon", &kind));
  EXPECT_TRUE(ParseWorldKind("helix", &kind));
  EXPECT_EQ(kind, WorldKind::kHelix);
}

}  // namespace
}  // namespace slamd::clients::sim
