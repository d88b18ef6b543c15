// slamctl sim: writes a synthetic world (dataset + ground truth) into a directory. The worlds and
// their measurement models are described in sim_world.h (pose graphs, landmarks) and
// sim_camera_world.h (structure from motion); this file is the command line.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "clients/slamctl/client_common.h"
#include "clients/slamctl/commands.h"
#include "clients/slamctl/sim_camera_world.h"
#include "clients/slamctl/sim_world.h"

namespace slamd::clients {
namespace {

struct SimOptions {
  std::string world;
  std::string output;
  std::string observation = "bearing-range";
  sim::SimParams params;
  // Camera worlds: their own params, and the options that fill the rest of them.
  sim::CameraSimParams camera;
  std::string image_size = "640x480";
  std::string camera_model = "pinhole";
  std::string format = "both";
};

[[noreturn]] void Fail(int code, const std::string& message) {
  std::fprintf(stderr, "slamctl sim: %s\n", message.c_str());
  throw CommandExit{code};
}

// The command-line option of the SimParams or CameraSimParams field a Validate() message names
// (CLI11's checks catch most bad values first; NaN gets through them).
std::string OptionOf(const std::string& message) {
  static const char* const kOptions[][2] = {{"sigma_translation", "--sigma-xy"},
                                            {"sigma_rotation", "--sigma-theta"},
                                            {"loop_probability", "--loop-probability"},
                                            {"outliers", "--outliers"},
                                            {"sensor_range", "--sensor-range"},
                                            {"sigma_bearing", "--sigma-bearing"},
                                            {"sigma_range", "--sigma-range"},
                                            {"sigma_point", "--sigma-point"},
                                            {"steps", "--steps"},
                                            {"robots", "--robots"},
                                            {"landmarks", "--landmarks"},
                                            {"side", "--side"},
                                            {"patrol", "--patrol"},
                                            {"cameras", "--cameras"},
                                            {"points", "--points"},
                                            {"width", "--image-size"},
                                            {"height", "--image-size"},
                                            {"focal", "--focal"},
                                            {"k1", "--k1"},
                                            {"k2", "--k2"},
                                            {"sigma_pixel", "--sigma-pixel"},
                                            {"init_sigma_camera", "--init-sigma-camera"},
                                            {"init_sigma_rotation", "--init-sigma-rotation"},
                                            {"init_sigma_point", "--init-sigma-point"},
                                            {"baseline", "--baseline"}};
  for (const auto& [field, option] : kOptions) {
    if (message.find(std::string("::") + field + " ") != std::string::npos) return option;
  }
  return "options";
}

constexpr const char* kFooter = R"(
Worlds:
  manhattan  2D pose graph on a unit grid (like Olson's M3500): random turns, a loop closure
             (with --loop-probability) to earlier poses in the cell the robot enters
  landmarks  the same robot path plus point landmarks seen within --sensor-range
             (--observation bearing-range: written as the point r(cos b, sin b) with its
             first-order covariance, plus the raw measurements in *_bearing_range.txt;
             relative-point: the noisy point in the pose frame)
  sphere     3D rings on a sphere, loop closures to the ring below
  helix      3D helix climbing 1 m per turn, loop closures to the turn below
  camera-city    structure from motion: a camera driving through a grid of city blocks,
                 looking forward and 50 degrees to either side at points on the facades
  camera-object  structure from motion: cameras on rings of a hemisphere around an object
                 (an ellipsoid), looking at points on its surface
Files written into DIR (one robot; with --robots N: robot<k>.* plus inter_robot.txt):
  world.g2o               VERTEX lines = odometry composed from the true start (the initial guess
                          a robot would have), then EDGE_SE2 / EDGE_SE2_XY / EDGE_SE3:QUAT in
                          generation order (information matrices, g2o order)
  world.isam              landmark worlds: the same graph in iSAM format (ODOMETRY, LANDMARK;
                          square-root information)
  world_groundtruth.g2o   the true poses and landmarks as VERTEX lines
  inter_robot.txt         inter-robot loop closures (format in its '#' header)
  outliers.txt            the loop closures replaced by --outliers (format in its '#' header)
Files written into DIR by the camera worlds (--format):
  problem.bal             BAL: the measured pixels, the initial guess (the true cameras and
                          points perturbed by --init-sigma-*), one Cal3Bundler camera per image
  groundtruth.bal         the same observations with the true cameras and points
  colmap/                 COLMAP text model of the problem (cameras.txt, images.txt,
                          points3D.txt): one PINHOLE or OPENCV camera, points in colour
  groundtruth_colmap/     the same with the true cameras and points
  outliers.txt            the observations replaced by --outliers (format in its '#' header)
  stereo.txt              with --stereo: (uL, uR, v) per observation (format in its '#' header)
Only observations in front of the camera and inside the image are kept; points seen by fewer
than 2 images are dropped (and images that see fewer than 8 points).
Every file is byte-for-byte the same for the same options and --seed.)";

[[noreturn]] void FailOption(const core::Status& invalid) {
  Fail(kExitUsage, OptionOf(invalid.message()) + ": " + invalid.message());
}

// -o: created if missing; an error if it exists and is not a directory.
void MakeOutputDirectory(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec)) {
    Fail(kExitUsage, "-o: '" + dir + "' exists and is not a directory");
  }
  fs::create_directories(dir, ec);
  if (ec) Fail(kExitFailure, "-o: cannot create '" + dir + "': " + ec.message());
}

void RunCameraSim(SimOptions* opt, sim::CameraWorldKind kind) {
  sim::CameraSimParams& c = opt->camera;
  c.world = kind;
  c.seed = opt->params.seed;
  c.outliers = opt->params.outliers;
  c.noise_free = opt->params.noise_free;
  c.model = opt->camera_model == "opencv" ? sim::CameraModel::kOpenCv : sim::CameraModel::kPinhole;
  if (!ParseSize(opt->image_size, &c.width, &c.height)) {
    Fail(kExitUsage, "--image-size '" + opt->image_size + "': expected WIDTHxHEIGHT, e.g. 640x480");
  }
  if (const core::Status valid = c.Validate(); !valid.ok()) FailOption(valid);
  // Generated first: too few points is a usage error, and creates no directory.
  core::Result<sim::CameraWorld> world = sim::GenerateCameraWorld(c);
  if (!world.ok()) Fail(kExitUsage, world.status().message());
  MakeOutputDirectory(opt->output);
  const sim::CameraFormat format = opt->format == "bal"      ? sim::CameraFormat::kBal
                                   : opt->format == "colmap" ? sim::CameraFormat::kColmap
                                                             : sim::CameraFormat::kBoth;
  std::vector<std::string> written;
  const core::Status status = sim::WriteCameraWorld(*world, format, opt->output, &written);
  if (!status.ok()) Fail(kExitFailure, status.ToString());
  const core::Reconstruction& truth = world->truth;
  std::printf("%s: %zu images, %zu points, %zu observations (%zu outliers)",
              sim::CameraWorldKindName(kind), truth.images.size(), truth.points.size(),
              truth.observations.size(), world->outliers.size());
  if (c.stereo) std::printf(", %zu stereo measurements", world->stereo.size());
  std::printf("\n");
  for (const std::string& file : written) {
    std::printf("  %s/%s\n", opt->output.c_str(), file.c_str());
  }
}

// The options of the camera worlds (--seed, --outliers and --noise-free are shared).
void AddCameraOptions(CLI::App* cmd, SimOptions* opt) {
  sim::CameraSimParams& c = opt->camera;
  cmd->add_option("--cameras", c.cameras,
                  "camera worlds: images asked for (>= 2); default 60 (camera-city), 36 "
                  "(camera-object)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--points", c.points,
                  "camera worlds: points placed (>= 1; unseen ones are dropped); default 6000 "
                  "(camera-city), 1500 (camera-object)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--image-size", opt->image_size, "camera worlds: WIDTHxHEIGHT in pixels")
      ->capture_default_str();
  cmd->add_option("--focal", c.focal, "camera worlds: focal length in pixels (> 0)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--camera-model", opt->camera_model,
                  "camera worlds: COLMAP camera model, pinhole (Cal3_S2) or opencv (Cal3DS2 with "
                  "radial distortion --k1, --k2); BAL files get one Cal3Bundler per image")
      ->check(CLI::IsMember({"pinhole", "opencv"}))
      ->capture_default_str();
  cmd->add_option("--k1", c.k1, "camera worlds (opencv): radial distortion k1")
      ->capture_default_str();
  cmd->add_option("--k2", c.k2, "camera worlds (opencv): radial distortion k2")
      ->capture_default_str();
  cmd->add_option("--sigma-pixel", c.sigma_pixel,
                  "camera worlds: pixel noise sigma per axis, pixels (>= 0)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--init-sigma-camera", c.init_sigma_camera,
                  "camera worlds: initial guess, camera position noise per axis, metres (>= 0)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--init-sigma-rotation", c.init_sigma_rotation,
                  "camera worlds: initial guess, camera rotation noise per axis, radians (>= 0)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--init-sigma-point", c.init_sigma_point,
                  "camera worlds: initial guess, point noise per axis, metres (>= 0)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  CLI::Option* stereo = cmd->add_flag(
      "--stereo", c.stereo,
      "camera worlds: also write stereo.txt, (uL, uR, v) of a rectified pair per image");
  cmd->add_option("--baseline", c.baseline,
                  "camera worlds (--stereo): stereo baseline, metres (> 0)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str()
      ->needs(stereo);
  cmd->add_option("--format", opt->format,
                  "camera worlds: bal (problem.bal, groundtruth.bal), colmap (colmap/, "
                  "groundtruth_colmap/) or both")
      ->check(CLI::IsMember({"bal", "colmap", "both"}))
      ->capture_default_str();
}

}  // namespace

void RegisterSim(CLI::App& app) {
  auto opt = std::make_shared<SimOptions>();
  sim::SimParams& p = opt->params;
  CLI::App* cmd = app.add_subcommand(
      "sim", "Generate a synthetic world (dataset + ground truth) with a fixed seed");
  cmd->footer(kFooter);
  cmd->add_option("world", opt->world,
                  "World: manhattan, landmarks, sphere, helix, camera-city or camera-object")
      ->required();
  cmd->add_option("-o,--output", opt->output,
                  "Output directory (created; an error if it exists and is not a directory)")
      ->required();
  cmd->add_option("--seed", p.seed, "Seed of the random generator (std::mt19937_64)")
      ->capture_default_str();
  cmd->add_option("--steps", p.steps,
                  "Poses per robot (>= 2); default 1000 (manhattan, helix), 500 (landmarks), "
                  "1024 (sphere)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--robots", p.robots, "Robots in the same world (1..1000)")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->add_option("--sigma-xy,--sigma-translation", p.sigma_translation,
                  "Odometry/loop-closure translation noise sigma per axis, metres (>= 0; 0 = "
                  "exact, written with sigma 1e-4)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--sigma-theta,--sigma-rotation", p.sigma_rotation,
                  "Odometry/loop-closure rotation noise sigma (3D: per axis), radians (>= 0)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--loop-probability", p.loop_probability,
                  "Chance that each loop-closure candidate (an earlier pose at the same place) "
                  "becomes an edge, in [0, 1]")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->add_option("--outliers", p.outliers,
                  "Fraction of loop closures (camera worlds: observations) replaced by random "
                  "wrong ones, in [0, 1] (listed in outliers.txt)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->add_flag("--noise-free", p.noise_free,
                "Add no noise (the files keep the information matrices of the sigmas; camera "
                "worlds: no pixel noise, the initial guess is still perturbed)");
  cmd->add_option("--landmarks", p.landmarks,
                  "landmarks: landmarks placed (unobserved ones are dropped); default box area/4")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--side", p.side,
                  "manhattan, landmarks: side of the square world in metres (>= 4); default grows "
                  "with --steps so the robots cover it about twice")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--patrol", p.patrol,
                  "manhattan, landmarks: each robot random-walks this many steps, goes back to "
                  "its start, and then drives that closed route again and again; 0: random "
                  "walks throughout")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--sensor-range", p.sensor_range, "landmarks: sensor range, metres (> 0)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--observation", opt->observation, "landmarks: bearing-range or relative-point")
      ->check(CLI::IsMember({"bearing-range", "relative-point"}))
      ->capture_default_str();
  cmd->add_option("--sigma-bearing", p.sigma_bearing, "landmarks: bearing sigma, radians (>= 0)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--sigma-range", p.sigma_range, "landmarks: range sigma, metres (>= 0)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--sigma-point", p.sigma_point,
                  "landmarks (relative-point): sigma per axis, metres (>= 0)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  AddCameraOptions(cmd, opt.get());
  cmd->callback([opt] {
    sim::SimParams& p = opt->params;
    sim::CameraWorldKind camera_world;
    if (sim::ParseCameraWorldKind(opt->world, &camera_world)) {
      RunCameraSim(opt.get(), camera_world);
      return;
    }
    if (!sim::ParseWorldKind(opt->world, &p.world)) {
      Fail(kExitUsage, "world: unknown world '" + opt->world +
                           "' (expected manhattan, landmarks, sphere, helix, camera-city or "
                           "camera-object)");
    }
    if (p.steps == 1) Fail(kExitUsage, "--steps: must be at least 2 (got 1)");
    p.observation = opt->observation == "relative-point" ? sim::ObservationKind::kRelativePoint
                                                         : sim::ObservationKind::kBearingRange;
    if (const core::Status valid = p.Validate(); !valid.ok()) FailOption(valid);
    MakeOutputDirectory(opt->output);

    core::Result<sim::SimWorld> world = sim::Generate(p);
    if (!world.ok()) Fail(kExitUsage, world.status().message());
    std::vector<std::string> written;
    const core::Status status = sim::WriteWorld(world.value(), opt->output, &written);
    if (!status.ok()) Fail(kExitFailure, status.ToString());

    const sim::SimWorld& w = world.value();
    std::size_t loops = 0, inter = 0, outliers = 0;
    for (const sim::SimEdge& e : w.edges) {
      loops += e.kind == sim::SimEdge::Kind::kLoop;
      inter += e.kind == sim::SimEdge::Kind::kInterRobot;
      outliers += e.outlier;
    }
    std::printf(
        "%s: %d robot(s) x %d poses, %zu landmarks, %zu edges (%zu loop closures, %zu "
        "inter-robot, %zu outliers), %zu observations\n",
        sim::WorldKindName(p.world), w.params.robots, w.params.steps, w.landmarks.size(),
        w.edges.size(), loops, inter, outliers, w.observations.size());
    for (const std::string& file : written) {
      std::printf("  %s/%s\n", opt->output.c_str(), file.c_str());
    }
  });
}

}  // namespace slamd::clients
