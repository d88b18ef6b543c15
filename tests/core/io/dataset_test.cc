// ReadDataset: the development datasets load with their README counts; format detection; the
// initial guess; and every kind of malformed input gives a located error instead of a crash.
#include "core/io/dataset.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <random>

#include "core/factors/between_factor.h"
#include "core/factors/relative_point_factor.h"
#include "tests/testing/datasets.h"

namespace slamd::core {
namespace {

using slamd::testing::SharedDatasetPath;
using slamd::testing::TestDataPath;
using slamd::testing::WriteTempFile;
using ::testing::HasSubstr;
using ::testing::StartsWith;

// Each shared file is parsed once per test binary.
const Dataset& LoadShared(const std::string& name, const ReadOptions& options = {}) {
  static std::map<std::string, Dataset> cache;
  const std::string id = name + "|" + std::to_string(static_cast<int>(options.isam_noise)) +
                         std::to_string(options.compose_initial_from_odometry);
  auto it = cache.find(id);
  if (it == cache.end()) {
    Result<Dataset> d = ReadDataset(SharedDatasetPath(name), options);
    EXPECT_TRUE(d.ok()) << d.status().ToString();
    it = cache.emplace(id, d.ok() ? std::move(d).value() : Dataset{}).first;
  }
  return it->second;
}

Status ReadText(const std::string& name, const std::string& text, Dataset* out = nullptr,
                const ReadOptions& options = {}) {
  Result<Dataset> d = ReadDataset(WriteTempFile(name, text), options);
  if (d.ok() && out) *out = std::move(d).value();
  return d.ok() ? Status::Ok() : d.status();
}

// ---------------------------------------------------------------------------------------------
// The development datasets: counts from /work/shared/datasets/README.md.

struct SharedCase {
  const char* file;
  ReadOptions::IsamNoise noise;
  DatasetFormat format;
  bool is_3d;
  std::size_t poses, landmarks, observations, edges, loop_like, equivalences;
  std::uint64_t last_pose_id;
};

class SharedDatasetTest : public ::testing::TestWithParam<SharedCase> {};

TEST_P(SharedDatasetTest, LoadsWithReadmeCounts) {
  const SharedCase& c = GetParam();
  SLAMD_SKIP_IF_NO_SHARED_DATASET(SharedDatasetPath(c.file));
  const Dataset& d = LoadShared(c.file, ReadOptions{.isam_noise = c.noise});
  EXPECT_EQ(d.format, c.format);
  EXPECT_EQ(d.is_3d, c.is_3d);
  EXPECT_EQ(d.poses.size(), c.poses);
  EXPECT_EQ(d.landmarks.size(), c.landmarks);
  EXPECT_EQ(d.num_landmark_observations, c.observations);
  EXPECT_EQ(d.num_pose_edges, c.edges);
  EXPECT_EQ(d.num_loop_like, c.loop_like);
  EXPECT_EQ(d.num_equivalences, c.equivalences);
  EXPECT_EQ(d.graph.size(), c.edges + c.observations + c.equivalences);
  EXPECT_EQ(d.initial.size(), c.poses + c.landmarks);
  ASSERT_FALSE(d.poses.empty());
  EXPECT_EQ(KeyIndex(d.poses.front()), 0u);
  EXPECT_EQ(KeyIndex(d.poses.back()), c.last_pose_id);
  EXPECT_TRUE(std::is_sorted(d.poses.begin(), d.poses.end()));
  EXPECT_TRUE(d.graph.CheckAgainst(d.initial).ok());
  EXPECT_TRUE(std::isfinite(d.graph.Chi2(d.initial)));
}

using Noise = ReadOptions::IsamNoise;
constexpr Noise kSqrt = Noise::kSqrtInformation;
INSTANTIATE_TEST_SUITE_P(
    Readme, SharedDatasetTest,
    ::testing::Values(
        SharedCase{"manhattan.g2o", kSqrt, DatasetFormat::kG2o, false, 3500, 0, 0, 5453, 1954, 0,
                   3499},
        SharedCase{"input_M3500_g2o.g2o", kSqrt, DatasetFormat::kG2o, false, 3500, 0, 0, 5453, 1954,
                   0, 3499},
        SharedCase{"manhattanOlson3500.txt", kSqrt, DatasetFormat::kIsam, false, 3500, 0, 0, 5598,
                   2099, 0, 3499},
        SharedCase{"manhattanOlson3500_groundtruth.txt", kSqrt, DatasetFormat::kIsam, false, 3500,
                   0, 0, 5598, 2099, 0, 3499},
        SharedCase{"intel.g2o", kSqrt, DatasetFormat::kG2o, false, 1728, 0, 0, 2512, 785, 0, 1727},
        SharedCase{"input_INTEL_g2o.g2o", kSqrt, DatasetFormat::kG2o, false, 1228, 0, 0, 1483, 256,
                   0, 1227},
        SharedCase{"victoriaPark.txt", kSqrt, DatasetFormat::kIsam, false, 6969, 151, 3640, 6968,
                   151, 0, 7119},
        SharedCase{"victoria_park.txt", Noise::kCovariance, DatasetFormat::kIsam, false, 6969, 151,
                   3640, 6968, 151, 0, 7119},
        SharedCase{"parking-garage.g2o", kSqrt, DatasetFormat::kG2o, true, 1661, 0, 0, 6275, 4615,
                   0, 1660},
        SharedCase{"w100.graph", kSqrt, DatasetFormat::kToro, false, 100, 0, 0, 300, 201, 40, 99},
        SharedCase{"pose2example.txt", kSqrt, DatasetFormat::kG2o, false, 11, 0, 0, 12, 2, 0, 10},
        SharedCase{"pose3example.txt", kSqrt, DatasetFormat::kG2o, true, 5, 0, 0, 6, 2, 0, 4}),
    [](const auto& info) {
      std::string name = info.param.file;
      for (char& ch : name) {
        if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
      }
      return name;
    });

TEST(SharedDatasets, ManhattanInitialIsOdometryComposition) {
  SLAMD_SKIP_IF_NO_SHARED_DATASET(SharedDatasetPath("manhattan.g2o"));
  const Dataset& d = LoadShared("manhattan.g2o");
  // By hand, from the first three lines of the file.
  const Pose2 x1(1.030390, 0.011350, -0.012958);
  const Pose2 x2 = x1 * Pose2(1.013900, -0.058639, -0.013225);
  const Pose2 x3 = x2 * Pose2(1.027650, -0.007456, 0.004833);
  EXPECT_TRUE(d.initial.At<Pose2>(MakeKey('x', 0)).Equals(Pose2(), 0.0));
  EXPECT_TRUE(d.initial.At<Pose2>(MakeKey('x', 1)).Equals(x1, 1e-15));
  EXPECT_TRUE(d.initial.At<Pose2>(MakeKey('x', 2)).Equals(x2, 1e-15));
  EXPECT_TRUE(d.initial.At<Pose2>(MakeKey('x', 3)).Equals(x3, 1e-15));
  // Every pose: x_k = x_{k-1} ∘ z_{k-1,k}, with the first odometry factor into k.
  std::map<Key, const BetweenFactor<Pose2>*> odometry;
  for (const FactorPtr& f : d.graph) {
    const auto* b = dynamic_cast<const BetweenFactor<Pose2>*>(f.get());
    ASSERT_NE(b, nullptr);
    if (KeyIndex(b->keys()[1]) == KeyIndex(b->keys()[0]) + 1) odometry.emplace(b->keys()[1], b);
  }
  ASSERT_EQ(odometry.size(), 3499u);
  for (std::uint64_t k = 1; k < 3500; ++k) {
    const Pose2 expected =
        d.initial.At<Pose2>(MakeKey('x', k - 1)) * odometry.at(MakeKey('x', k))->measured();
    ASSERT_TRUE(d.initial.At<Pose2>(MakeKey('x', k)).Equals(expected, 1e-12)) << k;
  }
}

TEST(SharedDatasets, M3500VariantsHaveIdenticalMeasurements) {
  SLAMD_SKIP_IF_NO_SHARED_DATASET(SharedDatasetPath("manhattan.g2o"));
  const Dataset& a = LoadShared("manhattan.g2o");
  const Dataset& b = LoadShared("input_M3500_g2o.g2o");
  ASSERT_EQ(a.graph.size(), b.graph.size());
  int different_noise = 0;
  for (std::size_t i = 0; i < a.graph.size(); ++i) {
    const auto& fa = static_cast<const BetweenFactor<Pose2>&>(*a.graph[i]);
    const auto& fb = static_cast<const BetweenFactor<Pose2>&>(*b.graph[i]);
    ASSERT_EQ(ToKeyVector(fa.keys()), ToKeyVector(fb.keys())) << i;
    ASSERT_TRUE(fa.measured().Equals(fb.measured(), 0.0)) << i;
    different_noise += !fa.noise_model().Equals(fb.noise_model(), 1e-6);
  }
  EXPECT_GT(different_noise, 5000);  // README: same measurements, different information
  // Carlone's file reads 44.72136 as information; SE-Sync's first edge is anisotropic.
  EXPECT_NEAR(b.graph[0]->noise_model().Information()(0, 0), 44.721360, 1e-9);
  EXPECT_NEAR(a.graph[0]->noise_model().Information()(1, 1), 376.516380, 1e-9);
  EXPECT_NEAR(a.graph[0]->noise_model().Information()(0, 1), -7.962220, 1e-9);
}

TEST(SharedDatasets, ParkingGarageQuaternionHasWLast) {
  SLAMD_SKIP_IF_NO_SHARED_DATASET(SharedDatasetPath("parking-garage.g2o"));
  const Dataset& d = LoadShared("parking-garage.g2o");
  // VERTEX_SE3:QUAT 1 4.15448 -0.0665288 0.000389663 -0.0107791 0.00867285 -0.00190021 0.999902
  const Pose3& x1 = d.initial.At<Pose3>(MakeKey('x', 1));
  EXPECT_TRUE(x1.translation().isApprox(Point3(4.15448, -0.0665288, 0.000389663), 1e-15));
  const Eigen::Quaterniond q(0.999902, -0.0107791, 0.00867285, -0.00190021);  // (w, x, y, z)
  EXPECT_TRUE(x1.rotation().matrix().isApprox(q.normalized().toRotationMatrix(), 1e-12));
  const Eigen::Quaterniond back = x1.rotation().ToQuaternion();
  EXPECT_NEAR(back.w(), 0.999902, 1e-6);
  EXPECT_NEAR(back.x(), -0.0107791, 1e-6);
  // Translation information is I and rotation information about 4 I (README), in (t, R) order.
  const Eigen::MatrixXd info = d.graph[0]->noise_model().Information();
  EXPECT_NEAR(info(0, 0), 1.0, 1e-9);
  EXPECT_GT(info(3, 3), 2.0);
}

TEST(SharedDatasets, IsamSqrtInformationIsSquared) {
  SLAMD_SKIP_IF_NO_SHARED_DATASET(SharedDatasetPath("manhattanOlson3500.txt"));
  // 44.72135955 as sqrt-information: Ω = 44.72135955² I ≈ 2000 I (README oddity 1).
  const Eigen::MatrixXd info =
      LoadShared("manhattanOlson3500.txt").graph[0]->noise_model().Information();
  EXPECT_NEAR(info(0, 0), 44.72135955 * 44.72135955, 1e-9);
  EXPECT_NEAR(info(2, 2), 2000.0, 1e-6);
  EXPECT_NEAR(info(0, 1), 0.0, 1e-12);
}

TEST(SharedDatasets, VictoriaParkCovarianceCopyMatchesSqrtInformationOriginal) {
  SLAMD_SKIP_IF_NO_SHARED_DATASET(SharedDatasetPath("victoria_park.txt"));
  const Dataset& a = LoadShared("victoriaPark.txt");
  const Dataset& b = LoadShared("victoria_park.txt", ReadOptions{.isam_noise = Noise::kCovariance});
  ASSERT_EQ(a.graph.size(), b.graph.size());
  // Odometry sqrt-info (100, 500, 500) = covariance (1e-4, 4e-6, 4e-6); landmark 1.581139² ≈ 1/0.4.
  for (std::size_t i = 0; i < a.graph.size(); ++i) {
    ASSERT_EQ(ToKeyVector(a.graph[i]->keys()), ToKeyVector(b.graph[i]->keys()));
    const Eigen::MatrixXd ia = a.graph[i]->noise_model().Information();
    const Eigen::MatrixXd ib = b.graph[i]->noise_model().Information();
    ASSERT_TRUE(ia.isApprox(ib, 1e-6)) << i << "\n" << ia << "\n" << ib;
  }
  // The first landmark observation: LANDMARK 4 5 11.5387 -3.2007, first seen from x4.
  const auto& obs = dynamic_cast<const RelativePointFactor<Pose2, Point2>&>(*a.graph[4]);
  EXPECT_EQ(obs.keys()[0], MakeKey('x', 4));
  EXPECT_EQ(obs.keys()[1], MakeKey('l', 5));
  const Point2 expected =
      a.initial.At<Pose2>(MakeKey('x', 4)).TransformFrom(Point2(11.5387, -3.2007));
  EXPECT_TRUE(a.initial.At<Point2>(MakeKey('l', 5)).isApprox(expected, 1e-15));
  // Pose ids are not contiguous: 5 and 9 are landmark ids.
  EXPECT_FALSE(a.initial.Contains(MakeKey('x', 5)));
  EXPECT_TRUE(a.initial.Contains(MakeKey('x', 6)));
}

TEST(SharedDatasets, W100EquivalencesAreUnitIdentityBetweens) {
  SLAMD_SKIP_IF_NO_SHARED_DATASET(SharedDatasetPath("w100.graph"));
  const Dataset& d = LoadShared("w100.graph");
  // Lines 401..440 are EQUIV, after the 300 EDGE2 lines: "EQUIV 21 1" is factor 300.
  const auto& f = dynamic_cast<const BetweenFactor<Pose2>&>(*d.graph[300]);
  EXPECT_EQ(ToKeyVector(f.keys()), (KeyVector{MakeKey('x', 21), MakeKey('x', 1)}));
  EXPECT_TRUE(f.measured().Equals(Pose2(), 0.0));
  EXPECT_TRUE(f.noise_model().Information().isIdentity(0.0));
  // TORO "1 0 1 1 0 0" is the identity in TORO order.
  EXPECT_TRUE(d.graph[0]->noise_model().Information().isIdentity(0.0));
}

// ---------------------------------------------------------------------------------------------
// Format detection.

TEST(FormatDetection, ByTagAndExtension) {
  // Noise "2 0 3 4 0 1": TORO Ω = [2 0 0; 0 3 1; 0 1 4]; iSAM R = [2 0 3; 0 4 0; 0 0 1].
  const std::string edge2 = "EDGE2 0 1 1 0 0 2 0 3 4 0 1\n";
  Dataset d;
  ASSERT_TRUE(ReadText("only_edge2.graph", edge2, &d).ok());
  EXPECT_EQ(d.format, DatasetFormat::kToro);
  Eigen::Matrix3d toro;
  toro << 2, 0, 0, 0, 3, 1, 0, 1, 4;
  EXPECT_TRUE(d.graph[0]->noise_model().Information().isApprox(toro, 1e-14));
  ASSERT_TRUE(ReadText("only_edge2.txt", edge2, &d).ok());
  EXPECT_EQ(d.format, DatasetFormat::kIsam);
  Eigen::Matrix3d R;
  R << 2, 0, 3, 0, 4, 0, 0, 0, 1;
  EXPECT_TRUE(d.graph[0]->noise_model().Information().isApprox(R.transpose() * R, 1e-14));
  // A decisive tag later in the file wins over EDGE2 (TORO: VERTEX2 after EDGE2 in a .txt).
  ASSERT_TRUE(ReadText("toro.txt", "EDGE2 0 1 1 0 0 1 0 1 1 0 0\nVERTEX2 0 0 0 0\n", &d).ok());
  EXPECT_EQ(d.format, DatasetFormat::kToro);
  ASSERT_TRUE(ReadText("g2o.txt", "# comment\n\nVERTEX_SE2 0 0 0 0\n", &d).ok());
  EXPECT_EQ(d.format, DatasetFormat::kG2o);
  ASSERT_TRUE(ReadText("isam.graph", "ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\n", &d).ok());
  EXPECT_EQ(d.format, DatasetFormat::kIsam);
}

TEST(FormatDetection, ForcedFormatRejectsOtherTags) {
  const Status s = ReadText("forced.g2o", "VERTEX_SE2 0 0 0 0\n", nullptr,
                            ReadOptions{.format = DatasetFormat::kIsam});
  EXPECT_EQ(s.code(), StatusCode::kDataLoss);
  EXPECT_THAT(s.message(), HasSubstr(":1: expected an iSAM tag"));
  EXPECT_THAT(s.message(), HasSubstr("'VERTEX_SE2'"));
  Dataset d;
  ASSERT_TRUE(ReadText("forced.graph", "EDGE2 0 1 1 0 0 2 0 0 3 0 4\n", &d,
                       ReadOptions{.format = DatasetFormat::kIsam})
                  .ok());
  EXPECT_EQ(d.format, DatasetFormat::kIsam);
}

// ---------------------------------------------------------------------------------------------
// Initial guess.

TEST(InitialGuess, VerticesThenCompositionThenFirstObservation) {
  Result<Dataset> r = ReadDataset(TestDataPath("small_slam2d.g2o"));
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  const Dataset& d = *r;
  EXPECT_EQ(d.poses, (KeyVector{MakeKey('x', 0), MakeKey('x', 1), MakeKey('x', 2), MakeKey('x', 3),
                                MakeKey('x', 5)}));
  EXPECT_EQ(d.landmarks, (KeyVector{MakeKey('l', 0), MakeKey('l', 7)}));
  EXPECT_EQ(d.num_pose_edges, 5u);
  EXPECT_EQ(d.num_loop_like, 2u);
  EXPECT_EQ(d.num_landmark_observations, 3u);
  const Pose2 x2(2.1, 0.2, 0.1);
  EXPECT_TRUE(d.initial.At<Pose2>(MakeKey('x', 2)).Equals(x2, 0.0));  // vertex
  const Pose2 x3 = x2 * Pose2(0.9, -0.1, 0.02);                       // EDGE_SE2 2 3
  EXPECT_TRUE(d.initial.At<Pose2>(MakeKey('x', 3)).Equals(x3, 1e-15));
  const Pose2 x5 = x3 * Pose2(-1.0, 0.0, 0.0).Inverse();  // EDGE_SE2 5 3
  EXPECT_TRUE(d.initial.At<Pose2>(MakeKey('x', 5)).Equals(x5, 1e-15));
  EXPECT_TRUE(d.initial.At<Point2>(MakeKey('l', 0)).isApprox(Point2(1.5, 2.0), 0.0));  // vertex
  const Point2 l7 = x2.TransformFrom(Point2(1.0, -1.0));  // EDGE_SE2_XY 2 7
  EXPECT_TRUE(d.initial.At<Point2>(MakeKey('l', 7)).isApprox(l7, 1e-15));
  // g2o information, upper triangle (x, y, θ): 100 1 2 200 3 1000.
  Eigen::Matrix3d info;
  info << 100, 1, 2, 1, 200, 3, 2, 3, 1000;
  EXPECT_TRUE(d.graph[0]->noise_model().Information().isApprox(info, 1e-14));
  Eigen::Matrix2d info_xy;
  info_xy << 50, 5, 5, 60;
  EXPECT_TRUE(d.graph[2]->noise_model().Information().isApprox(info_xy, 1e-14));
}

TEST(InitialGuess, ComposeFromOdometryIgnoresVerticesButTheFirst) {
  ReadOptions options;
  options.compose_initial_from_odometry = true;
  Result<Dataset> r = ReadDataset(TestDataPath("small_slam2d.g2o"), options);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  const Pose2 x1 = Pose2() * Pose2(1.0, 0.1, 0.05);
  const Pose2 x2 = x1 * Pose2(1.1, 0.05, 0.05);
  EXPECT_TRUE(r->initial.At<Pose2>(MakeKey('x', 2)).Equals(x2, 1e-15));
  // Landmark 0's vertex is ignored: first observation from x0.
  EXPECT_TRUE(r->initial.At<Point2>(MakeKey('l', 0)).isApprox(Point2(1.4, 2.1), 1e-15));
}

// Repeated passes in file order, not a breadth-first search from the first pose: here pass 0
// sets x1 (line 2), x3 (line 3) and then x2 from x3 (line 4); a BFS would set x2 from x1 (line 1).
TEST(InitialGuess, FollowsRepeatedPassesInFileOrder) {
  const std::string text =
      "EDGE_SE2 1 2 5 0 0 1 0 0 1 0 1\n"
      "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n"
      "EDGE_SE2 0 3 0 1 0 1 0 0 1 0 1\n"
      "EDGE_SE2 3 2 0 7 0 1 0 0 1 0 1\n";
  Dataset d;
  ASSERT_TRUE(ReadText("passes.g2o", text, &d).ok());
  EXPECT_TRUE(d.initial.At<Pose2>(MakeKey('x', 2)).Equals(Pose2(0, 8, 0), 1e-15));
  // Needing a second pass: line 1 can only fire after line 2 set x1.
  const std::string two_passes =
      "EDGE_SE2 1 2 5 0 0 1 0 0 1 0 1\n"
      "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n";
  ASSERT_TRUE(ReadText("two_passes.g2o", two_passes, &d).ok());
  EXPECT_TRUE(d.initial.At<Pose2>(MakeKey('x', 2)).Equals(Pose2(6, 0, 0), 1e-15));
}

TEST(InitialGuess, UnreachablePoseIsAnError) {
  const Status s =
      ReadText("islands.g2o", "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nEDGE_SE2 7 8 1 0 0 1 0 0 1 0 1\n");
  EXPECT_EQ(s.code(), StatusCode::kDataLoss);
  EXPECT_THAT(s.message(), HasSubstr("cannot initialise pose x7"));
  // A vertex in the second island makes it reachable; the first starts at the identity.
  Dataset d;
  ASSERT_TRUE(ReadText("islands.g2o",
                       "VERTEX_SE2 8 5 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n"
                       "EDGE_SE2 7 8 1 0 0 1 0 0 1 0 1\n",
                       &d)
                  .ok());
  EXPECT_TRUE(d.initial.At<Pose2>(MakeKey('x', 1)).Equals(Pose2(1, 0, 0), 0.0));
  EXPECT_TRUE(d.initial.At<Pose2>(MakeKey('x', 7)).Equals(Pose2(4, 0, 0), 1e-15));
  // A vertex-less lowest pose connected to vertices is composed from them, not set to identity.
  ASSERT_TRUE(
      ReadText("first.g2o", "VERTEX_SE2 1 5 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n", &d).ok());
  EXPECT_TRUE(d.initial.At<Pose2>(MakeKey('x', 0)).Equals(Pose2(4, 0, 0), 1e-15));
}

TEST(InitialGuess, OverflowingCompositionIsAnError) {
  const Status s = ReadText("huge.g2o",
                            "EDGE_SE2 0 1 1e308 0 0 1 0 0 1 0 1\n"
                            "EDGE_SE2 1 2 1e308 0 0 1 0 0 1 0 1\n");
  EXPECT_EQ(s.code(), StatusCode::kDataLoss);
  EXPECT_THAT(s.message(), HasSubstr("x2 is not finite"));
}

// ---------------------------------------------------------------------------------------------
// Errors: located, never a crash.

struct BadCase {
  const char* name;
  const char* file;
  const char* text;
  int line;
  const char* phrase;
};

class MalformedTest : public ::testing::TestWithParam<BadCase> {};

TEST_P(MalformedTest, NamesFileAndLine) {
  const BadCase& c = GetParam();
  const std::string path = WriteTempFile(c.file, c.text);
  Result<Dataset> d = ReadDataset(path);
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.status().code(), StatusCode::kDataLoss);
  EXPECT_THAT(d.status().message(), StartsWith(path + ":" + std::to_string(c.line) + ": "));
  EXPECT_THAT(d.status().message(), HasSubstr(c.phrase));
}

INSTANTIATE_TEST_SUITE_P(
    Errors, MalformedTest,
    ::testing::Values(
        BadCase{"WrongCount", "a.g2o", "VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0\n", 2,
                "expected EDGE_SE2 i j dx dy dθ I11 I12 I13 I22 I23 I33 (11 values after the tag, "
                "not 10), got 'EDGE_SE2 0 1"},
        BadCase{"Truncated", "a.g2o", "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0", 2,
                "(4 values after the tag, not 2)"},
        BadCase{"NotANumber", "a.g2o", "VERTEX_SE2 0 0 0 0\n\nVERTEX_SE2 1 0 abc 0\n", 3,
                "expected a finite number as value 3 of VERTEX_SE2, got 'abc'"},
        BadCase{"NaN", "a.g2o", "VERTEX_SE2 0 0 nan 0\n", 1, "got 'nan'"},
        BadCase{"Infinity", "a.g2o", "VERTEX_SE2 0 0 -inf 0\n", 1, "got '-inf'"},
        BadCase{"Overflow", "a.g2o", "VERTEX_SE2 0 0 1e999 0\n", 1, "got '1e999'"},
        BadCase{"TrailingGarbage", "a.g2o", "VERTEX_SE2 0 0 1.5x 0\n", 1, "got '1.5x'"},
        BadCase{"NegativeId", "a.g2o", "VERTEX_SE2 -1 0 0 0\n", 1,
                "expected an id (an integer in 0..2^48-1) as value 1 of VERTEX_SE2, got '-1'"},
        BadCase{"HugeId", "a.g2o", "VERTEX_SE2 281474976710656 0 0 0\n", 1,
                "got '281474976710656'"},
        BadCase{"FractionalId", "a.g2o", "VERTEX_SE2 1.0 0 0 0\n", 1, "got '1.0'"},
        BadCase{"UnknownTagFirst", "a.g2o", "# c\nFOO 1 2\n", 2, "got the unknown tag 'FOO'"},
        BadCase{"UnknownTagLater", "a.g2o", "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nFOO 1 2\n", 3,
                "expected a g2o tag"},
        BadCase{"OtherFormatTag", "a.g2o", "VERTEX_SE2 0 0 0 0\nODOMETRY 0 1 1 0 0 1 0 0 1 0 1\n",
                2, "unknown tag 'ODOMETRY'"},
        BadCase{"SelfEdge", "a.g2o", "EDGE_SE2 3 3 1 0 0 1 0 0 1 0 1\n", 1,
                "expected an edge between two different poses"},
        BadCase{"DuplicateVertex", "a.g2o", "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 0 1 0 0\n", 2,
                "duplicate vertex for pose 0"},
        BadCase{"MixedDimensions", "a.g2o", "VERTEX_SE2 0 0 0 0\nVERTEX_SE3:QUAT 1 0 0 0 0 0 0 1\n",
                2, "expected a 2D line"},
        BadCase{"NotPositiveDefinite", "a.g2o", "EDGE_SE2 0 1 1 0 0 1 0 0 -1 0 1\n", 1,
                "invalid noise: information matrix is not positive definite"},
        BadCase{"ZeroInformation", "a.g2o", "EDGE_SE2 0 1 1 0 0 0 0 0 0 0 0\n", 1, "invalid noise"},
        BadCase{"IllConditioned", "a.g2o", "EDGE_SE2 0 1 1 0 0 1e20 0 0 1 0 1\n", 1,
                "ill-conditioned"},
        BadCase{"ZeroQuaternion", "a.g2o", "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 0\n", 1,
                "expected a quaternion qx qy qz qw of finite, non-zero norm"},
        BadCase{"SingularSqrtInfo", "a.txt", "ODOMETRY 0 1 1 0 0 1 0 0 0 0 1\n", 1,
                "invalid noise"},
        BadCase{"IsamWrongCount", "a.txt", "ODOMETRY 0 1 1 0 0\n", 1,
                "expected ODOMETRY i j dx dy dθ s11 s12 s13 s22 s23 s33 (11 values"},
        BadCase{"LandmarkWrongCount", "a.txt",
                "ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\nLANDMARK 0 1 1 2 3\n", 2,
                "expected LANDMARK pose landmark dx dy s11 s12 s22"},
        BadCase{"ToroWrongCount", "a.graph", "VERTEX2 0 0 0 0\nEQUIV 0\n", 2, "expected EQUIV i j"},
        BadCase{"FixUnknownPose", "a.g2o", "FIX 9\nVERTEX_SE2 0 0 0 0\n", 1, "FIX names pose 9"},
        BadCase{"Edge3WrongCount", "a.txt", "EDGE3 0 1 0 0 0 0 0 0 1\n", 1,
                "(8 or 29 values after the tag, not 9)"},
        BadCase{"Edge3GimbalLock", "a.txt", "EDGE3 0 1 0 0 0 0 1.5707963267948966 0\n", 1,
                "gimbal lock"},
        BadCase{"Toro3d", "a.graph", "VERTEX3 0 0 0 0 0 0 0\n", 1,
                "TORO 3D (VERTEX3) is not supported"}),
    [](const auto& info) { return std::string(info.param.name); });

TEST(Errors, MissingFileIsNotFound) {
  Result<Dataset> d = ReadDataset("/nonexistent/dir/file.g2o");
  EXPECT_EQ(d.status().code(), StatusCode::kNotFound);
  EXPECT_THAT(d.status().message(), HasSubstr("/nonexistent/dir/file.g2o"));
}

TEST(Errors, DirectoryAndEmptyFile) {
  EXPECT_EQ(ReadDataset(::testing::TempDir()).status().code(), StatusCode::kIoError);
  const Status empty = ReadText("empty.g2o", "# only a comment\n\n  \n");
  EXPECT_EQ(empty.code(), StatusCode::kDataLoss);
  EXPECT_THAT(empty.message(), HasSubstr("found none"));
  // Only landmarks: no pose.
  EXPECT_EQ(ReadText("points.g2o", "VERTEX_XY 0 1 2\n").code(), StatusCode::kDataLoss);
}

TEST(Errors, WhitespaceVariantsAreAccepted) {
  Dataset d;
  ASSERT_TRUE(ReadText("ws.g2o",
                       "VERTEX_SE2\t0  +1.5 0 0\r\n\r\n   \nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1   \r\n",
                       &d)
                  .ok());
  EXPECT_EQ(d.initial.At<Pose2>(MakeKey('x', 0)).x(), 1.5);
  EXPECT_EQ(d.poses.size(), 2u);
}

// Random garbage and random truncations of a valid file: any Status, never a crash.
TEST(Errors, GarbageNeverCrashes) {
  std::mt19937 rng(42);
  const std::vector<std::string> tags = {
      "VERTEX_SE2",    "EDGE_SE2", "VERTEX_XY", "EDGE_SE2_XY", "VERTEX_SE3:QUAT",
      "EDGE_SE3:QUAT", "FIX",      "VERTEX2",   "EDGE2",       "EQUIV",
      "ODOMETRY",      "LANDMARK", "EDGE3",     "#",           ""};
  const std::vector<std::string> tokens = {
      "0",   "1",   "2",      "-1", "3.5", "1e308", "-1e308",
      "nan", "inf", "1e-320", "x",  "",    "0.0",   "99999999999999999999",
      "1",   "1",   "0",      "0.5"};
  int ok = 0;
  for (int file = 0; file < 300; ++file) {
    std::string text;
    const int num_lines = 1 + static_cast<int>(rng() % 8);
    for (int l = 0; l < num_lines; ++l) {
      text += tags[rng() % tags.size()];
      const int n = static_cast<int>(rng() % 32);
      for (int k = 0; k < n; ++k) text += " " + tokens[rng() % tokens.size()];
      text += rng() % 5 == 0 ? "\r\n" : "\n";
    }
    const char* names[] = {"g.g2o", "g.graph", "g.txt"};
    Result<Dataset> d = ReadDataset(WriteTempFile(names[rng() % 3], text));
    if (d.ok()) {
      ++ok;
      EXPECT_TRUE(d->graph.CheckAgainst(d->initial).ok()) << text;
    } else {
      EXPECT_FALSE(d.status().message().empty());
    }
  }
  // Raw bytes, NUL included.
  for (int file = 0; file < 100; ++file) {
    std::string bytes(rng() % 400, '\0');
    for (char& b : bytes) b = static_cast<char>(rng() % 256);
    if (file % 2 == 0) bytes = "VERTEX_SE2 0 0 0 0\n" + bytes;
    Result<Dataset> d = ReadDataset(WriteTempFile("bytes.g2o", bytes));
    if (d.ok()) {
      EXPECT_TRUE(d->graph.CheckAgainst(d->initial).ok());
    }
  }
  // Truncations of a valid file at every third byte.
  std::ifstream in(TestDataPath("small_slam2d.g2o"));
  const std::string valid((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(valid.size(), 100u);
  for (std::size_t n = 0; n < valid.size(); n += 3) {
    Result<Dataset> d = ReadDataset(WriteTempFile("cut.g2o", valid.substr(0, n)));
    if (d.ok()) {
      EXPECT_TRUE(d->graph.CheckAgainst(d->initial).ok());
    }
  }
  EXPECT_GE(ok, 0);
}

}  // namespace
}  // namespace slamd::core
