// The TORO 2D format (*.graph): VERTEX2, EDGE2 with TORO's information order, EQUIV.
// Layouts and conventions: dataset.h.
#include "core/io/reader_internal.h"

namespace slamd::core::internal {
namespace {

Status ReadEdge2(const SourceLine& line, DatasetBuilder* builder) {
  std::uint64_t i, j;
  double v[9];
  SLAMD_RETURN_IF_ERROR(
      ReadEdgeFields(line, "EDGE2 i j dx dy dθ I_xx I_xy I_yy I_θθ I_xθ I_yθ (TORO order)",
                     /*is_3d=*/false, 9, builder, &i, &j, v));
  // TORO stores xx xy yy θθ xθ yθ: not the row-major upper triangle g2o uses.
  const double xx = v[3], xy = v[4], yy = v[5], tt = v[6], xt = v[7], yt = v[8];
  Eigen::MatrixXd information(3, 3);
  information << xx, xy, xt,  //
      xy, yy, yt,             //
      xt, yt, tt;
  Result<NoiseModel> noise = NoiseFromInformation(line, information);
  if (!noise.ok()) return noise.status();
  return builder->AddPoseEdge(line, i, j, Pose2(v[0], v[1], v[2]), std::move(noise).value());
}

// EQUIV i j: a soft equality x_i = x_j of unit information (see dataset.h for why).
Status ReadEquiv(const SourceLine& line, DatasetBuilder* builder) {
  std::uint64_t i, j;
  SLAMD_RETURN_IF_ERROR(
      ReadEdgeFields(line, "EQUIV i j", /*is_3d=*/false, 0, builder, &i, &j, nullptr));
  return builder->AddPoseEdge(line, i, j, Pose2(), NoiseModel::Unit(3), /*equivalence=*/true);
}

}  // namespace

Status ReadToroLine(const SourceLine& line, DatasetBuilder* builder) {
  const std::string_view tag = line.tag();
  if (tag == "VERTEX2") return ReadPose2Vertex(line, "VERTEX2 id x y θ", builder);
  if (tag == "EDGE2") return ReadEdge2(line, builder);
  if (tag == "EQUIV") return ReadEquiv(line, builder);
  if (tag == "VERTEX3" || tag == "EDGE3") {
    return line.Problem("TORO 3D (" + std::string(tag) + ") is not supported");
  }
  return line.Problem("expected a TORO 2D tag (VERTEX2, EDGE2, EQUIV), got the unknown tag '" +
                      std::string(tag) + "'");
}

}  // namespace slamd::core::internal
