// slamctl sim: writes a synthetic world (dataset + ground truth) into a directory. The worlds and
// the measurement model are described in sim_world.h; this file is the command line.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "clients/slamctl/commands.h"
#include "clients/slamctl/sim_world.h"

namespace slamd::clients {
namespace {

struct SimOptions {
  std::string world;
  std::string output;
  std::string observation = "bearing-range";
  sim::SimParams params;
};

[[noreturn]] void Fail(int code, const std::string& message) {
  std::fprintf(stderr, "slamctl sim: %s\n", message.c_str());
  throw CommandExit{code};
}

// The command-line option of the SimParams field a Validate() message names (CLI11's checks
// catch most bad values first; NaN gets through them).
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
                                            {"landmarks", "--landmarks"}};
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
Files written into DIR (one robot; with --robots N: robot<k>.* plus inter_robot.txt):
  world.g2o               VERTEX lines = odometry composed from the true start (the initial guess
                          a robot would have), then EDGE_SE2 / EDGE_SE2_XY / EDGE_SE3:QUAT in
                          generation order (information matrices, g2o order)
  world.isam              landmark worlds: the same graph in iSAM format (ODOMETRY, LANDMARK;
                          square-root information)
  world_groundtruth.g2o   the true poses and landmarks as VERTEX lines
  inter_robot.txt         inter-robot loop closures (format in its '#' header)
  outliers.txt            the loop closures replaced by --outliers (format in its '#' header)
Every file is byte-for-byte the same for the same options and --seed.)";

}  // namespace

void RegisterSim(CLI::App& app) {
  auto opt = std::make_shared<SimOptions>();
  sim::SimParams& p = opt->params;
  CLI::App* cmd = app.add_subcommand(
      "sim", "Generate a synthetic world (dataset + ground truth) with a fixed seed");
  cmd->footer(kFooter);
  cmd->add_option("world", opt->world, "World: manhattan, landmarks, sphere or helix")->required();
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
                  "Fraction of loop closures replaced by random wrong ones, in [0, 1] "
                  "(listed in outliers.txt)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->add_flag("--noise-free", p.noise_free,
                "Add no noise (the files keep the information matrices of the sigmas)");
  cmd->add_option("--landmarks", p.landmarks,
                  "landmarks: landmarks placed (unobserved ones are dropped); default box area/4")
      ->check(CLI::NonNegativeNumber);
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
  cmd->callback([opt] {
    sim::SimParams& p = opt->params;
    if (!sim::ParseWorldKind(opt->world, &p.world)) {
      Fail(kExitUsage, "world: unknown world '" + opt->world +
                           "' (expected manhattan, landmarks, sphere or helix)");
    }
    if (p.steps == 1) Fail(kExitUsage, "--steps: must be at least 2 (got 1)");
    p.observation = opt->observation == "relative-point" ? sim::ObservationKind::kRelativePoint
                                                         : sim::ObservationKind::kBearingRange;
    const core::Status valid = p.Validate();
    if (!valid.ok()) Fail(kExitUsage, OptionOf(valid.message()) + ": " + valid.message());

    namespace fs = std::filesystem;
    std::error_code ec;
    if (fs::exists(opt->output, ec) && !fs::is_directory(opt->output, ec)) {
      Fail(kExitUsage, "-o: '" + opt->output + "' exists and is not a directory");
    }
    fs::create_directories(opt->output, ec);
    if (ec) Fail(kExitFailure, "-o: cannot create '" + opt->output + "': " + ec.message());

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
