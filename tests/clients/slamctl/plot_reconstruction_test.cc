// Tests of a reconstruction's picture (plot_reconstruction.h): telling its files from pose graphs,
// the view plane, one wedge per camera pointing where it looks, one dot per point in its colour,
// an extent that ignores a few far points, and the hook for camera ellipses.
#include "clients/slamctl/plot_reconstruction.h"

#include <gtest/gtest.h>

#include <cmath>

#include "clients/slamctl/plot_render.h"
#include "clients/slamctl/sim_camera_world.h"
#include "tests/testing/files.h"

namespace slamd::clients::plot {
namespace {

// Images at `centres`, each looking along world `view` (horizontal), image x horizontal.
core::Reconstruction CamerasAt(const std::vector<Eigen::Vector3d>& centres,
                               const Eigen::Vector3d& view = Eigen::Vector3d::UnitX()) {
  core::Reconstruction r;
  r.intrinsics.push_back({});
  const Eigen::Vector3d z = view.normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  Eigen::Matrix3d R;
  R << x, z.cross(x), z;
  for (const Eigen::Vector3d& c : centres) {
    r.images.push_back({.pose = core::Pose3(core::Rot3(R), c)});
  }
  return r;
}

TEST(PlotReconstructionTest, TellsReconstructionsFromPoseGraphs) {
  testing::TempDir dir("slamd_plotrec_");
  EXPECT_TRUE(IsReconstructionPath(dir.path()));  // a COLMAP model's directory
  const auto file = [&](const std::string& name, const std::string& text) {
    testing::WriteFileBytes(dir.File(name), text);
    return dir.File(name);
  };
  EXPECT_TRUE(IsReconstructionPath(file("a.bal", "2 3 4\n0 0 1.5 2.5\n")));
  EXPECT_TRUE(IsReconstructionPath(file("b.txt", "\n  # comment\n\t16 22106 83718\n")));
  EXPECT_FALSE(IsReconstructionPath(file("c.g2o", "VERTEX_SE2 0 0 0 0\n")));
  EXPECT_FALSE(IsReconstructionPath(file("d.txt", "# iSAM\nODOMETRY 0 1 1 0 0 1 0 0 1 0 1\n")));
  EXPECT_FALSE(IsReconstructionPath(file("e.txt", "-3 1 2\n")));
  EXPECT_FALSE(IsReconstructionPath(file("f.txt", "")));
  EXPECT_FALSE(IsReconstructionPath(dir.File("missing.bal")));
}

TEST(PlotReconstructionTest, ViewPlaneLeavesOutTheLeastSpreadAxis) {
  std::vector<Eigen::Vector3d> xy_ring, xz_ring, yz_ring;
  for (int k = 0; k < 8; ++k) {
    const double c = 3 * std::cos(k * 0.785), s = 3 * std::sin(k * 0.785);
    xy_ring.emplace_back(c, s, 0.1 * (k % 2));
    xz_ring.emplace_back(c, 0.1 * (k % 2), s);
    yz_ring.emplace_back(0.1 * (k % 2), c, s);
  }
  EXPECT_EQ(ChooseViewPlane(CamerasAt(xy_ring)), ViewPlane::kXY);
  EXPECT_EQ(ChooseViewPlane(CamerasAt(xz_ring)), ViewPlane::kXZ);
  EXPECT_EQ(ChooseViewPlane(CamerasAt(yz_ring)), ViewPlane::kYZ);
  // Ties leave out z, then y: a straight street at constant height is seen from above.
  EXPECT_EQ(ChooseViewPlane(CamerasAt({{0, 0, 1}, {0, 5, 1}})), ViewPlane::kXY);
  EXPECT_EQ(ChooseViewPlane(CamerasAt({{0, 0, 0}, {0, 0, 5}})), ViewPlane::kXZ);
  EXPECT_EQ(ChooseViewPlane(core::Reconstruction{}), ViewPlane::kXY);
  EXPECT_EQ(HorizontalLabel(ViewPlane::kYZ), "y [m]");
  EXPECT_EQ(VerticalLabel(ViewPlane::kXZ), "z [m]");
  for (ViewPlane plane : {ViewPlane::kXY, ViewPlane::kXZ, ViewPlane::kYZ}) {
    EXPECT_EQ(*ParseViewPlane(ViewPlaneName(plane)), plane);
  }
  EXPECT_FALSE(ParseViewPlane("zx").ok());
}

TEST(PlotReconstructionTest, WedgeOpensWhereTheCameraLooks) {
  // Looking along +x with z up: the image's left is +y.
  const PlotReconstruction seen = BuildReconstruction(CamerasAt({{1, 2, 3}}), ViewPlane::kXY);
  ASSERT_EQ(seen.cameras.size(), 1u);
  const PlotCamera& c = seen.cameras[0];
  EXPECT_EQ(c.center, Eigen::Vector2d(1, 2));
  const double n = std::hypot(1.0, kWedgeHalfWidth);
  EXPECT_TRUE(c.left_edge.isApprox(Eigen::Vector2d(1, kWedgeHalfWidth) / n, 1e-12));
  EXPECT_TRUE(c.right_edge.isApprox(Eigen::Vector2d(1, -kWedgeHalfWidth) / n, 1e-12));
  // Seen from the side (x-z plane) the same camera's wedge is a line along +x.
  const PlotReconstruction side = BuildReconstruction(CamerasAt({{1, 2, 3}}), ViewPlane::kXZ);
  ASSERT_EQ(side.cameras.size(), 1u);
  EXPECT_EQ(side.cameras[0].center, Eigen::Vector2d(1, 3));
  EXPECT_NEAR(side.cameras[0].left_edge.y(), 0.0, 1e-12);
  EXPECT_NEAR(side.cameras[0].left_edge.x(), 1 / n, 1e-12);
}

TEST(PlotReconstructionTest, OneWedgePerCameraOneDotPerPoint) {
  const core::Result<sim::CameraWorld> world = sim::GenerateCameraWorld(
      {.world = sim::CameraWorldKind::kObject, .cameras = 12, .points = 300});
  ASSERT_TRUE(world.ok()) << world.status().ToString();
  const core::Reconstruction& r = world->truth;
  const ViewPlane plane = ChooseViewPlane(r);
  EXPECT_EQ(plane, ViewPlane::kXY);  // rings around the object: spread in x and y
  const PlotReconstruction rec = BuildReconstruction(r, plane);
  ASSERT_EQ(rec.cameras.size(), r.images.size());
  ASSERT_EQ(rec.points.size(), r.points.size());
  EXPECT_TRUE(rec.camera_ellipses.empty());
  for (std::size_t j = 0; j < r.points.size(); ++j) {
    EXPECT_EQ(rec.points[j].position, r.points[j].position.head<2>());
    EXPECT_EQ(rec.points[j].color, r.points[j].color);
  }
  // Every camera looks at the object at the origin: its wedge opens towards it.
  for (const PlotCamera& c : rec.cameras) {
    EXPECT_GT((c.left_edge + c.right_edge).dot(-c.center), 0.0) << c.center.transpose();
  }
  PlotScene scene;
  scene.reconstruction = rec;
  const Box bounds = scene.Bounds();
  for (const PlotCamera& c : rec.cameras) {
    EXPECT_TRUE((c.center.array() >= bounds.min.array()).all() &&
                (c.center.array() <= bounds.max.array()).all());
  }
  EXPECT_EQ(scene.NumEllipses(), 0u);
}

TEST(PlotReconstructionTest, ExtentIgnoresAFewFarPoints) {
  core::Reconstruction r = CamerasAt({{0, 0, 0}, {1, 0, 0}});
  for (int j = 0; j < 1000; ++j) {
    r.points.push_back({.position = Eigen::Vector3d(j % 10, (j / 10) % 10, 0.5)});
  }
  for (int j = 0; j < 5; ++j) r.points.push_back({.position = Eigen::Vector3d(1e6, -1e6, 0)});
  const PlotReconstruction rec = BuildReconstruction(r, ViewPlane::kXY);
  EXPECT_EQ(rec.points.size(), 1005u);
  EXPECT_EQ(rec.extent.min, Eigen::Vector2d(0, 0));
  EXPECT_EQ(rec.extent.max, Eigen::Vector2d(9, 9));
}

// The hook for camera covariances: ellipses put in the scene are framed, counted and drawn.
TEST(PlotReconstructionTest, CameraEllipsesAreFramedAndCounted) {
  PlotScene scene;
  scene.reconstruction = BuildReconstruction(CamerasAt({{0, 0, 0}, {1, 0, 0}}), ViewPlane::kXY);
  scene.reconstruction.camera_ellipses.push_back(
      Ellipse{.center = {1, 0}, .semi_major = 4, .semi_minor = 1, .angle = 0});
  EXPECT_EQ(scene.NumEllipses(), 1u);
  EXPECT_EQ(scene.Bounds().max.x(), 5.0);
  EXPECT_EQ(scene.Bounds().min.x(), -3.0);
  testing::TempDir dir("slamd_plotrec_");
  EXPECT_TRUE(RenderScene(scene, dir.File("ellipses.png"), {.width = 400, .height = 300}).ok());
}

// A camera centre's ellipse is its translation covariance turned into the world (R Σ Rᵀ) and
// cut to the plane; the gauge camera (zero covariance) has none.
TEST(PlotReconstructionTest, CameraEllipsesFromTheCovariancesInTheWorld) {
  core::Reconstruction r;
  r.intrinsics.push_back({});
  r.images.push_back({.pose = core::Pose3(), .intrinsics = 0});
  // Camera 1 turned by 90° about z: its own x is the world's y.
  const core::Rot3 turn = core::Rot3::FromRollPitchYaw(0.0, 0.0, core::kPi / 2);
  r.images.push_back({.pose = core::Pose3(turn, core::Point3(4.0, 1.0, 0.0)), .intrinsics = 0});
  core::CameraCovariances cov{.block_dim = 6};
  cov.per_image.push_back(Eigen::MatrixXd::Zero(6, 6));
  Eigen::MatrixXd c = Eigen::MatrixXd::Zero(6, 6);
  c.diagonal() << 4.0, 1.0, 9.0, 1e-4, 1e-4, 1e-4;  // σx 2 m, σy 1 m in the camera's frame
  cov.per_image.push_back(c);
  const std::vector<Ellipse> e = CameraEllipses(r, cov, ViewPlane::kXY, 3.0);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0].center, Eigen::Vector2d(4.0, 1.0));
  EXPECT_NEAR(e[0].semi_major, 6.0, 1e-9);  // 3σ of 2 m, along the world's y
  EXPECT_NEAR(e[0].semi_minor, 3.0, 1e-9);
  EXPECT_NEAR(std::abs(e[0].angle), core::kPi / 2, 1e-9);
}

}  // namespace
}  // namespace slamd::clients::plot
