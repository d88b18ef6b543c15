// The iSAM text format (Kaess' iSAM data/*.txt): ODOMETRY / EDGE2, LANDMARK, EDGE3: reading one
// line (ReadIsamLine) and writing a 2D Dataset (WriteIsam). Layouts and conventions: dataset.h.
#include <algorithm>
#include <cmath>
#include <string>

#include "core/factors/factor.h"
#include "core/io/reader_internal.h"

namespace slamd::core::internal {
namespace {

using IsamNoise = ReadOptions::IsamNoise;

// The noise of an n-dimensional measurement from the upper-triangular numbers of the line.
Result<NoiseModel> IsamNoiseModel(const SourceLine& line, const double* values, int n,
                                  IsamNoise kind) {
  if (kind == IsamNoise::kCovariance) {
    return NoiseFromCovariance(line, SymmetricFromUpperRowMajor(values, n));
  }
  return NoiseFromSqrtInformation(line, UpperTriangularFromRowMajor(values, n));
}

Status ReadOdometry(const SourceLine& line, IsamNoise kind, DatasetBuilder* builder) {
  std::uint64_t i, j;
  double v[9];
  SLAMD_RETURN_IF_ERROR(
      ReadEdgeFields(line, std::string(line.tag()) + " i j dx dy dθ s11 s12 s13 s22 s23 s33",
                     /*is_3d=*/false, 9, builder, &i, &j, v));
  Result<NoiseModel> noise = IsamNoiseModel(line, v + 3, 3, kind);
  if (!noise.ok()) return noise.status();
  return builder->AddPoseEdge(line, i, j, Pose2(v[0], v[1], v[2]), std::move(noise).value());
}

Status ReadLandmark(const SourceLine& line, IsamNoise kind, DatasetBuilder* builder) {
  std::uint64_t pose, landmark;
  double v[5];
  SLAMD_RETURN_IF_ERROR(ReadEdgeFields(line, "LANDMARK pose landmark dx dy s11 s12 s22",
                                       /*is_3d=*/false, 5, builder, &pose, &landmark, v));
  Result<NoiseModel> noise = IsamNoiseModel(line, v + 2, 2, kind);
  if (!noise.ok()) return noise.status();
  return builder->AddLandmarkObservation(line, pose, landmark, Point2(v[0], v[1]),
                                         std::move(noise).value());
}

// EDGE3 i j x y z roll pitch yaw [s11 .. s66]. iSAM's error is the difference of the vectors
// (x, y, z, yaw, pitch, roll) of the predicted and the measured pose, whitened by the sqrt-info
// S that iSAM's Loader builds from the 21 numbers (its rotation rows come in reverse order).
// slamd's BetweenFactor<Pose3> error is ξ = Log(m⁻¹·p) = (v, ω). With p = m·Exp(ξ), to first
// order the translation moves by R_m·v and the angles by E⁻¹·ω, where E maps angle rates to the
// body angular velocity of R = Rz(yaw)·Ry(pitch)·Rx(roll):
//   ω = E·(roll', pitch', yaw')ᵀ,  E = [1 0 −sin p; 0 cos r sin r cos p; 0 −sin r cos r cos p].
// So iSAM's whitened error is S·J·ξ with J = blockdiag(R_m, rows (yaw, pitch, roll) of E⁻¹),
// and slamd's sqrt-information is S·J.
Status ReadEdge3(const SourceLine& line, IsamNoise kind, DatasetBuilder* builder) {
  SLAMD_RETURN_IF_ERROR(line.ExpectValues(
      8, 29, "EDGE3 i j x y z roll pitch yaw [+ 21 square-root information values]"));
  if (kind != IsamNoise::kSqrtInformation) {
    return line.Problem("EDGE3 noise can only be read as square-root information");
  }
  std::uint64_t i, j;
  double v[27];
  SLAMD_RETURN_IF_ERROR(
      ParseEdgeFields(line, /*is_3d=*/true, line.num_values() - 2, builder, &i, &j, v));
  const double roll = v[3], pitch = v[4], yaw = v[5];
  const Pose3 measured(Rot3::FromRollPitchYaw(roll, pitch, yaw), Point3(v[0], v[1], v[2]));

  Matrix6 S = Matrix6::Identity();
  if (line.num_values() == 29) {
    const double* s = v + 6;  // s11 s12 .. s16 s22 .. s26 s33 .. s36 s44 s45 s46 s55 s56 s66
    S.setZero();
    S.topRows<3>() << s[0], s[1], s[2], s[3], s[4], s[5],  //
        0, s[6], s[7], s[8], s[9], s[10],                  //
        0, 0, s[11], s[12], s[13], s[14];
    S(3, 3) = s[20], S(3, 4) = s[19], S(3, 5) = s[17];
    S(4, 4) = s[18], S(4, 5) = s[16];
    S(5, 5) = s[15];
  }
  const double cp = std::cos(pitch), sp = std::sin(pitch);
  const double cr = std::cos(roll), sr = std::sin(roll);
  if (std::abs(cp) < 1e-6) {
    return line.Problem("EDGE3 pitch " + std::to_string(pitch) +
                        " is at gimbal lock (|pitch| = π/2): its Euler-angle noise has no "
                        "equivalent on SO(3)");
  }
  Matrix3 E;
  E << 1, 0, -sp,      //
      0, cr, sr * cp,  //
      0, -sr, cr * cp;
  const Matrix3 E_inv = E.inverse();  // rows: roll', pitch', yaw'
  Matrix6 J = Matrix6::Zero();
  J.topLeftCorner<3, 3>() = measured.rotation().matrix();
  J.row(3).tail<3>() = E_inv.row(2);  // yaw
  J.row(4).tail<3>() = E_inv.row(1);  // pitch
  J.row(5).tail<3>() = E_inv.row(0);  // roll
  Result<NoiseModel> noise = NoiseFromSqrtInformation(line, S * J);
  if (!noise.ok()) return noise.status();
  return builder->AddPoseEdge(line, i, j, measured, std::move(noise).value());
}

}  // namespace

Status ReadIsamLine(const SourceLine& line, IsamNoise noise, DatasetBuilder* builder) {
  const std::string_view tag = line.tag();
  if (tag == "ODOMETRY" || tag == "EDGE2") return ReadOdometry(line, noise, builder);
  if (tag == "LANDMARK") return ReadLandmark(line, noise, builder);
  if (tag == "EDGE3") return ReadEdge3(line, noise, builder);
  return line.Problem(
      "expected an iSAM tag (ODOMETRY, EDGE2, LANDMARK, EDGE3), got the unknown "
      "tag '" +
      std::string(tag) + "'");
}

}  // namespace slamd::core::internal

namespace slamd::core {
namespace {

Status CheckIsamKey(Key key, unsigned char symbol, std::size_t index) {
  if (KeySymbol(key) == symbol && KeyRobot(key) == 0) return Status::Ok();
  return InvalidArgument("WriteIsam: factor " + std::to_string(index) + " has key " +
                         KeyToString(key) + ", not a '" +
                         std::string(1, static_cast<char>(symbol)) + "' key without a robot id");
}

// "<tag> i j <measurement> <upper triangle of R>".
Status WriteIsamFactor(const Factor& factor, std::size_t index, std::string* out) {
  const std::span<const Key> keys = factor.keys();
  const char* tag = factor.Formats().isam;
  const std::optional<Variable> measured = factor.Measured();
  if (tag == nullptr || !measured) {
    return InvalidArgument("WriteIsam: factor " + std::to_string(index) + " (" + factor.Name() +
                           ") has no iSAM form");
  }
  std::string line = tag;
  for (int k = 0; k < static_cast<int>(keys.size()); ++k) {
    // Poses (kinds with rotation entries) are iSAM's 'x' ids, landmarks its 'l' ones.
    const bool pose = std::ranges::count(EntryKinds(factor.KeyType(k)), EntryKind::kRotation) > 0;
    SLAMD_RETURN_IF_ERROR(CheckIsamKey(keys[k], pose ? 'x' : 'l', index));
    line.append(" ").append(std::to_string(KeyIndex(keys[k])));
  }
  // iSAM writes a Pose2 as x y θ and a Point2 as x y (the kinds its format has).
  if (const Pose2* p = std::get_if<Pose2>(&*measured)) {
    internal::AppendNumbers({p->x(), p->y(), p->theta()}, &line);
  } else {
    const Point2& q = std::get<Point2>(*measured);
    internal::AppendNumbers({q.x(), q.y()}, &line);
  }
  const Eigen::MatrixXd R = factor.noise_model().sqrt_information();
  for (int r = 0; r < R.rows(); ++r) {
    for (int c = r; c < R.cols(); ++c) internal::AppendNumbers({R(r, c)}, &line);
  }
  out->append(line).append("\n");
  return Status::Ok();
}

}  // namespace

Status WriteIsam(const Dataset& dataset, const std::string& path) {
  // Everything is formatted first, so that an unwritable dataset leaves no file.
  std::string out;
  for (std::size_t i = 0; i < dataset.graph.size(); ++i) {
    SLAMD_RETURN_IF_ERROR(WriteIsamFactor(*dataset.graph[i], i, &out));
  }
  return internal::WriteTextFile(path, out, "WriteIsam");
}

}  // namespace slamd::core
