// The TORO 2D format: VERTEX2, EDGE2 with TORO's information order, EQUIV.
#include <gtest/gtest.h>

#include "core/factors/between_factor.h"
#include "core/io/dataset.h"
#include "tests/testing/datasets.h"

namespace slamd::core {
namespace {

using slamd::testing::WriteTempFile;

TEST(Toro, InformationOrderIsXxXyYyTtXtYt) {
  // inf_xx=10 inf_xy=1 inf_yy=20 inf_θθ=30 inf_xθ=2 inf_yθ=3: every entry distinct.
  const std::string text =
      "VERTEX2 0 0 0 0\n"
      "VERTEX2 1 1 0.5 0.25\n"
      "EDGE2 0 1 1.0 0.4 0.2 10 1 20 30 2 3\n";
  Result<Dataset> d = ReadDataset(WriteTempFile("order.graph", text));
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  EXPECT_EQ(d->format, DatasetFormat::kToro);
  const Eigen::MatrixXd info = d->graph[0]->noise_model().Information();
  // Rows and columns in (x, y, θ) order.
  EXPECT_NEAR(info(0, 0), 10, 1e-12);
  EXPECT_NEAR(info(0, 1), 1, 1e-12);
  EXPECT_NEAR(info(1, 0), 1, 1e-12);
  EXPECT_NEAR(info(1, 1), 20, 1e-12);
  EXPECT_NEAR(info(2, 2), 30, 1e-12);
  EXPECT_NEAR(info(0, 2), 2, 1e-12);
  EXPECT_NEAR(info(2, 0), 2, 1e-12);
  EXPECT_NEAR(info(1, 2), 3, 1e-12);
  EXPECT_NEAR(info(2, 1), 3, 1e-12);
  const auto& f = dynamic_cast<const BetweenFactor<Pose2>&>(*d->graph[0]);
  EXPECT_TRUE(f.measured().Equals(Pose2(1.0, 0.4, 0.2), 1e-15));
  EXPECT_TRUE(d->initial.At<Pose2>(MakeKey('x', 1)).Equals(Pose2(1, 0.5, 0.25), 1e-15));
}

TEST(Toro, EquivIsAUnitIdentityBetweenCountedApart) {
  const std::string text =
      "VERTEX2 0 0 0 0\n"
      "VERTEX2 1 1 0 0\n"
      "VERTEX2 2 0.1 0 0\n"
      "EDGE2 1 0 -1 0 0 1 0 1 1 0 0\n"
      "EDGE2 2 1 -1 0 0 1 0 1 1 0 0\n"
      "EQUIV 2 0\n";
  Result<Dataset> d = ReadDataset(WriteTempFile("equiv.graph", text));
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  EXPECT_EQ(d->num_pose_edges, 2u);
  EXPECT_EQ(d->num_equivalences, 1u);
  EXPECT_EQ(d->num_loop_like, 0u);
  ASSERT_EQ(d->graph.size(), 3u);
  const auto& equiv = dynamic_cast<const BetweenFactor<Pose2>&>(*d->graph[2]);
  EXPECT_EQ(ToKeyVector(equiv.keys()), (KeyVector{MakeKey('x', 2), MakeKey('x', 0)}));
  EXPECT_TRUE(equiv.measured().Equals(Pose2(), 0.0));
  EXPECT_TRUE(equiv.noise_model().Information().isIdentity(0.0));
  // Its error is the offset between the two poses: 0.1 in x.
  EXPECT_NEAR(equiv.Chi2(d->initial), 0.01, 1e-15);
}

}  // namespace
}  // namespace slamd::core
