// The g2o format: information order of the 2D and 3D edges, and WriteG2o → ReadDataset round
// trips (2D with landmarks, 3D, iSAM and TORO files converted to g2o).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "core/factors/between_factor.h"
#include "core/factors/prior_factor.h"
#include "core/factors/relative_point_factor.h"
#include "core/io/dataset.h"
#include "tests/testing/datasets.h"
#include "tests/testing/factor_examples.h"
#include "tests/testing/read_dataset.h"

namespace slamd::core {
namespace {

using slamd::testing::SharedDatasetPath;
using slamd::testing::TestDataPath;
using slamd::testing::WriteTempFile;
using ::testing::HasSubstr;

using testing::MustReadDataset;

// The measurement of a factor the writer supports, as a Variable.
Variable Measured(const Factor& f) {
  if (const auto* b = dynamic_cast<const BetweenFactor<Pose2>*>(&f)) return b->measured();
  if (const auto* b = dynamic_cast<const BetweenFactor<Pose3>*>(&f)) return b->measured();
  return dynamic_cast<const RelativePointFactor<Pose2, Point2>&>(f).measured();
}

// Same keys, values to `tol`, same factors with the same measurements (to `tol`) and information
// (to `tol` relative to its largest entry).
void ExpectSameDataset(const Dataset& a, const Dataset& b, double tol) {
  EXPECT_EQ(a.is_3d, b.is_3d);
  EXPECT_EQ(a.poses, b.poses);
  EXPECT_EQ(a.landmarks, b.landmarks);
  EXPECT_EQ(a.fixed, b.fixed);
  ASSERT_EQ(a.initial.keys(), b.initial.keys());
  for (const Key key : a.initial.keys()) {
    ASSERT_LE(LocalCoordinates(a.initial.Get(key), b.initial.Get(key)).norm(), tol)
        << KeyToString(key);
  }
  ASSERT_EQ(a.graph.size(), b.graph.size());
  for (std::size_t i = 0; i < a.graph.size(); ++i) {
    const Factor& fa = *a.graph[i];
    const Factor& fb = *b.graph[i];
    ASSERT_STREQ(fa.Name(), fb.Name()) << i;
    ASSERT_EQ(ToKeyVector(fa.keys()), ToKeyVector(fb.keys())) << i;
    ASSERT_LE(LocalCoordinates(Measured(fa), Measured(fb)).norm(), tol) << i;
    const Eigen::MatrixXd ia = fa.noise_model().Information();
    const Eigen::MatrixXd ib = fb.noise_model().Information();
    ASSERT_LE((ia - ib).cwiseAbs().maxCoeff(), tol * ia.cwiseAbs().maxCoeff()) << i;
  }
}

void ExpectRoundTrip(const Dataset& d) {
  const std::string path = WriteTempFile("round_trip.g2o", "");
  ASSERT_TRUE(WriteG2o(d, path).ok());
  const Dataset back = MustReadDataset(path);
  EXPECT_EQ(back.format, DatasetFormat::kG2o);
  ExpectSameDataset(d, back, 1e-12);
}

TEST(G2oRead, Information2dUpperTriangleRowMajor) {
  const Dataset d =
      MustReadDataset(WriteTempFile("info.g2o", "EDGE_SE2 0 1 1 2 0.5 110 1.2 1.3 220 2.3 330\n"));
  Eigen::Matrix3d omega;
  omega << 110, 1.2, 1.3, 1.2, 220, 2.3, 1.3, 2.3, 330;
  const Eigen::MatrixXd info = d.graph[0]->noise_model().Information();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(info(r, c), omega(r, c), 1e-12) << r << "," << c;
  }
  EXPECT_TRUE(dynamic_cast<const BetweenFactor<Pose2>&>(*d.graph[0])
                  .measured()
                  .Equals(Pose2(1, 2, 0.5), 1e-15));
}

TEST(G2oRead, Information3dInTranslationRotationOrder) {
  // A 6x6 information with distinct entries: diagonal 100 + 10 k, off-diagonal (r+1) + (c+1)/10.
  Eigen::Matrix<double, 6, 6> omega;
  std::string text = "EDGE_SE3:QUAT 0 1 1 2 3 0 0 0.6 0.8";
  for (int r = 0; r < 6; ++r) {
    for (int c = r; c < 6; ++c) {
      omega(r, c) = omega(c, r) = r == c ? 100.0 + 10 * r : (r + 1) + (c + 1) / 10.0;
      text += ' ';
      text += std::to_string(omega(r, c));
    }
  }
  const Dataset d = MustReadDataset(WriteTempFile("info3.g2o", text + "\n"));
  ASSERT_EQ(d.graph.size(), 1u);
  const Eigen::MatrixXd info = d.graph[0]->noise_model().Information();
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) EXPECT_NEAR(info(r, c), omega(r, c), 1e-12) << r << "," << c;
  }
  // qx qy qz qw = (0, 0, 0.6, 0.8): a rotation about z by 2·atan2(0.6, 0.8).
  const Pose3& z = dynamic_cast<const BetweenFactor<Pose3>&>(*d.graph[0]).measured();
  const Eigen::Matrix3d Rz =
      Eigen::AngleAxisd(2 * std::atan2(0.6, 0.8), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_TRUE(z.rotation().matrix().isApprox(Rz, 1e-15));
  EXPECT_TRUE(z.translation().isApprox(Point3(1, 2, 3), 0.0));
  EXPECT_TRUE(d.is_3d);
}

TEST(G2oRead, FixLinesAreRecorded) {
  const Dataset d =
      MustReadDataset(WriteTempFile("fix.g2o", "FIX 0 1\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n"));
  EXPECT_EQ(d.fixed, (KeyVector{MakeKey('x', 0), MakeKey('x', 1)}));
  EXPECT_EQ(d.graph.size(), 1u);  // no factor for FIX
}

// Every registered factor type that declares a g2o form (Factor::Formats) is written and read
// back as the same measurement; the others are refused by name.
TEST(G2oWrite, EveryFactorTypeWithAG2oFormRoundTrips) {
  int written = 0;
  for (const testing::FactorExample& e : testing::EveryFactorTypeExample(21)) {
    SCOPED_TRACE(e.factor->Name());
    Dataset d;
    d.graph.Add(e.factor);
    d.initial = e.values;
    for (Key key : e.values.keys()) {
      // Kinds with rotation entries are g2o's poses, the others its landmarks.
      const bool pose =
          std::ranges::count(EntryKinds(TypeOf(e.values.Get(key))), EntryKind::kRotation) > 0;
      (pose ? d.poses : d.landmarks).push_back(key);
    }
    d.is_3d = std::holds_alternative<Pose3>(
        e.values.Get(d.poses.empty() ? e.values.KeyAt(0) : d.poses[0]));
    const std::string path = testing::WriteTempFile("every_factor.g2o", "");
    const Status written_status = WriteG2o(d, path);
    if (e.factor->Formats().g2o == nullptr) {
      EXPECT_FALSE(written_status.ok());
      continue;
    }
    ASSERT_TRUE(written_status.ok()) << written_status.ToString();
    Result<Dataset> back = ReadDataset(path);
    ASSERT_TRUE(back.ok()) << back.status().ToString();
    ASSERT_EQ(back->graph.size(), 1u);
    const Factor& f = *back->graph[0];
    EXPECT_STREQ(f.Name(), e.factor->Name());
    EXPECT_EQ(ToKeyVector(f.keys()), ToKeyVector(e.factor->keys()));
    // Text keeps 17 significant digits; a rotation goes through an angle or a quaternion.
    EXPECT_LT((f.Error(e.values) - e.factor->Error(e.values)).cwiseAbs().maxCoeff(), 1e-9);
    const Eigen::MatrixXd info = e.factor->noise_model().Information();
    EXPECT_LT((f.noise_model().Information() - info).cwiseAbs().maxCoeff(),
              1e-9 * info.cwiseAbs().maxCoeff());
    ++written;
  }
  EXPECT_EQ(written, 3);  // BetweenPose2, BetweenPose3, RelativePoint2
}

TEST(G2oWrite, RoundTrip2dWithLandmarks) {
  Dataset d = MustReadDataset(TestDataPath("small_slam2d.g2o"));
  d.fixed.push_back(MakeKey('x', 0));
  ExpectRoundTrip(d);
}

TEST(G2oWrite, RoundTrip3d) {
  SLAMD_SKIP_IF_NO_SHARED_DATASET(SharedDatasetPath("pose3example.txt"));
  ExpectRoundTrip(MustReadDataset(SharedDatasetPath("pose3example.txt")));
  // Near-singular rotation information (README oddity 3) survives too.
  ExpectRoundTrip(MustReadDataset(SharedDatasetPath("parking-garage.g2o")));
}

TEST(G2oWrite, RoundTripOfOtherFormats) {
  SLAMD_SKIP_IF_NO_SHARED_DATASET(SharedDatasetPath("victoriaPark.txt"));
  // Landmarks, non-contiguous pose ids, composed initial guess, iSAM sqrt-info.
  ExpectRoundTrip(MustReadDataset(SharedDatasetPath("victoriaPark.txt")));
  // TORO information order and EQUIV (written as identity EDGE_SE2 with unit information).
  const Dataset w100 = MustReadDataset(SharedDatasetPath("w100.graph"));
  ExpectRoundTrip(w100);
}

TEST(G2oWrite, FactorsWithoutG2oFormAreRejected) {
  Dataset d = MustReadDataset(TestDataPath("small_slam2d.g2o"));
  d.graph.Emplace<PriorFactor<Pose2>>(MakeKey('x', 0), Pose2(), NoiseModel::Unit(3));
  const std::string path = WriteTempFile("prior.g2o", "untouched");
  const Status s = WriteG2o(d, path);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("factor 8 (PriorPose2) has no g2o form"));
  std::ifstream in(path);
  std::string content;
  std::getline(in, content);
  EXPECT_EQ(content, "untouched");  // nothing written
}

TEST(G2oWrite, KeysAndPathsAreChecked) {
  Dataset d = MustReadDataset(TestDataPath("small_slam2d.g2o"));
  EXPECT_EQ(WriteG2o(d, "/nonexistent/dir/out.g2o").code(), StatusCode::kIoError);
  Dataset robot = d;
  const Key odd = MakeKey('x', 9, 'a');
  ASSERT_TRUE(robot.initial.Insert(odd, Pose2()).ok());
  robot.poses.push_back(odd);
  const Status s = WriteG2o(robot, WriteTempFile("robot.g2o", ""));
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("a:x9"));
  Dataset missing = d;
  missing.poses.push_back(MakeKey('x', 42));
  EXPECT_THAT(WriteG2o(missing, WriteTempFile("missing.g2o", "")).message(),
              HasSubstr("x42 has no value"));
}

}  // namespace
}  // namespace slamd::core
