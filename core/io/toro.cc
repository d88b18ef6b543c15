// The TORO 2D format (*.graph): VERTEX2, EDGE2 with TORO's information order, EQUIV.
// Layouts and conventions: dataset.h.
#include "core/io/reader_internal.h"

namespace slamd::core::internal {
namespace {

Status ReadVertex2(const SourceLine& line, DatasetBuilder* builder) {
  SLAMD_RETURN_IF_ERROR(line.ExpectValues(4, "VERTEX2 id x y θ"));
  SLAMD_RETURN_IF_ERROR(builder->SetDimension(line, false));
  std::uint64_t id;
  double v[3];
  SLAMD_RETURN_IF_ERROR(line.Id(0, &id));
  SLAMD_RETURN_IF_ERROR(line.Numbers(1, 3, v));
  return builder->AddPoseVertex(line, id, Pose2(v[0], v[1], v[2]));
}

Status ReadEdge2(const SourceLine& line, DatasetBuilder* builder) {
  SLAMD_RETURN_IF_ERROR(
      line.ExpectValues(11, "EDGE2 i j dx dy dθ I_xx I_xy I_yy I_θθ I_xθ I_yθ (TORO order)"));
  SLAMD_RETURN_IF_ERROR(builder->SetDimension(line, false));
  std::uint64_t i, j;
  double v[9];
  SLAMD_RETURN_IF_ERROR(line.Id(0, &i));
  SLAMD_RETURN_IF_ERROR(line.Id(1, &j));
  SLAMD_RETURN_IF_ERROR(line.Numbers(2, 9, v));
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
  SLAMD_RETURN_IF_ERROR(line.ExpectValues(2, "EQUIV i j"));
  SLAMD_RETURN_IF_ERROR(builder->SetDimension(line, false));
  std::uint64_t i, j;
  SLAMD_RETURN_IF_ERROR(line.Id(0, &i));
  SLAMD_RETURN_IF_ERROR(line.Id(1, &j));
  return builder->AddPoseEdge(line, i, j, Pose2(), NoiseModel::Unit(3), /*equivalence=*/true);
}

}  // namespace

Status ReadToroLine(const SourceLine& line, DatasetBuilder* builder) {
  const std::string_view tag = line.tag();
  if (tag == "VERTEX2") return ReadVertex2(line, builder);
  if (tag == "EDGE2") return ReadEdge2(line, builder);
  if (tag == "EQUIV") return ReadEquiv(line, builder);
  if (tag == "VERTEX3" || tag == "EDGE3") {
    return line.Problem("TORO 3D (" + std::string(tag) + ") is not supported");
  }
  return line.Problem("expected a TORO 2D tag (VERTEX2, EDGE2, EQUIV), got the unknown tag '" +
                      std::string(tag) + "'");
}

}  // namespace slamd::core::internal
