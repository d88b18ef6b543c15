// Writing a camera world: the problem and the ground truth as BAL files and COLMAP text models
// (core/io/sfm_io.h), outliers.txt and stereo.txt; reading stereo.txt back.
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "clients/slamctl/sim_camera_world.h"
#include "clients/slamctl/sim_text.h"
#include "core/io/sfm_io.h"

namespace slamd::clients::sim {
namespace {

std::string CameraWorldHeader(const CameraWorld& world) {
  const CameraSimParams& p = world.params;
  return "# slamctl sim " + std::string(CameraWorldKindName(p.world)) + " --seed " +
         std::to_string(p.seed) + " --cameras " + std::to_string(p.cameras) + " --points " +
         std::to_string(p.points) + " --outliers " + Num(p.outliers) + "\n";
}

std::string OutlierObservationsText(const CameraWorld& world) {
  std::string out = CameraWorldHeader(world);
  out +=
      "# Observations whose pixel was replaced by a random one in the image (--outliers), one\n"
      "# per line: OBSERVATION IMAGE POINT, 0-based indices in the order of problem.bal (its\n"
      "# observation lines, cameras and points) and of the COLMAP model as ReadColmapText\n"
      "# returns it (images.txt and points3D.txt order; observations image by image).\n";
  for (const int k : world.outliers) {
    const core::SfmObservation& o = world.truth.observations[k];
    out += std::to_string(k);
    Append(&out, std::to_string(o.image));
    Append(&out, std::to_string(o.point));
    out += "\n";
  }
  return out;
}

std::string StereoText(const CameraWorld& world) {
  const CameraSimParams& p = world.params;
  std::string out = CameraWorldHeader(world);
  out +=
      "# Stereo measurements: each image is the left camera of a rectified pair whose right\n"
      "# camera sits BASELINE metres along the left one's +x axis; both have the pinhole\n"
      "# calibration below (no distortion: the images are rectified).\n"
      "# CALIBRATION fx fy cx cy BASELINE SIGMA   (pixels, metres; SIGMA: the noise of each of\n"
      "#                                          uL, uR and v, pixels)\n"
      "# STEREO OBSERVATION IMAGE POINT uL uR v   one per measurement, in observation order;\n"
      "#   0-based indices as in outliers.txt; pixels in COLMAP's frame (the image's top-left\n"
      "#   corner at (0, 0)), uR = uL - fx * BASELINE / depth. Outlier observations and points\n"
      "#   the right camera does not see have none.\n";
  out += "CALIBRATION";
  for (double v : {p.focal, p.focal, p.width / 2.0, p.height / 2.0, p.baseline,
                   p.noise_free ? 0.0 : p.sigma_pixel}) {
    Append(&out, v);
  }
  out += "\n";
  for (const StereoObservation& s : world.stereo) {
    const core::SfmObservation& o = world.truth.observations[s.observation];
    out += "STEREO";
    for (int index : {s.observation, o.image, o.point}) Append(&out, std::to_string(index));
    for (int k = 0; k < 3; ++k) Append(&out, s.uuv(k));
    out += "\n";
  }
  return out;
}

}  // namespace

core::Status WriteCameraWorld(const CameraWorld& world, CameraFormat format, const std::string& dir,
                              std::vector<std::string>* written) {
  if (format != CameraFormat::kColmap) {
    SLAMD_RETURN_IF_ERROR(core::WriteBal(AsBal(world.initial), dir + "/problem.bal"));
    written->push_back("problem.bal");
    SLAMD_RETURN_IF_ERROR(core::WriteBal(AsBal(world.truth), dir + "/groundtruth.bal"));
    written->push_back("groundtruth.bal");
  }
  if (format != CameraFormat::kBal) {
    SLAMD_RETURN_IF_ERROR(core::WriteColmapText(world.initial, dir + "/colmap"));
    written->push_back("colmap/");
    SLAMD_RETURN_IF_ERROR(core::WriteColmapText(world.truth, dir + "/groundtruth_colmap"));
    written->push_back("groundtruth_colmap/");
  }
  SLAMD_RETURN_IF_ERROR(WriteText(dir + "/outliers.txt", OutlierObservationsText(world)));
  written->push_back("outliers.txt");
  if (world.params.stereo) {
    SLAMD_RETURN_IF_ERROR(WriteText(dir + "/stereo.txt", StereoText(world)));
    written->push_back("stereo.txt");
  }
  return core::Status::Ok();
}

core::Result<StereoFile> ReadStereoFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) return core::NotFound(path + ": cannot open");
  StereoFile file;
  bool calibrated = false;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    std::istringstream words(line);
    std::string kind;
    if (!(words >> kind) || kind[0] == '#') continue;
    const std::string where = path + ":" + std::to_string(number) + ": ";
    if (kind == "CALIBRATION") {
      double fx, fy, cx, cy, sigma;
      if (!(words >> fx >> fy >> cx >> cy >> file.baseline >> sigma) || !(file.baseline > 0)) {
        return core::InvalidArgument(where + "expected CALIBRATION fx fy cx cy BASELINE SIGMA");
      }
      calibrated = true;
    } else if (kind == "STEREO") {
      StereoObservation s;
      int image, point;
      if (!(words >> s.observation >> image >> point >> s.uuv[0] >> s.uuv[1] >> s.uuv[2]) ||
          s.observation < 0 || !s.uuv.allFinite()) {
        return core::InvalidArgument(where + "expected STEREO OBSERVATION IMAGE POINT uL uR v");
      }
      file.stereo.push_back(s);
    } else {
      return core::InvalidArgument(where + "unknown line '" + kind + "'");
    }
  }
  if (!calibrated) return core::InvalidArgument(path + ": no CALIBRATION line");
  return file;
}

}  // namespace slamd::clients::sim
