// A reconstruction replayed camera by camera, as a robot's camera would send it to an
// incremental solver: step i brings image i and its observations. An image enters (its pose and
// calibration, values from the reconstruction) once it is registered: it sees at least
// `min_registration_points` points already in the graph (its pose, scale included, is then
// determined), or, before the first point fixes the scale, that many points that become
// determined with it. An image that is not yet registered is held, and enters at the first later
// step after which it is (a camera that shares points only with image 0, or turned on the spot,
// would otherwise bring a pose or a scale nothing determines). A point enters once it is
// determined: seen by at least `min_views` registered images (the initial pair's by its two)
// with at least `min_parallax_deg` between two of their rays (at the reconstruction's camera
// centres); its observations are held
// until then and enter with it, its initial value the reconstruction's. A point seen by fewer
// views, or along nearly parallel rays, would leave the incremental system indeterminate
// (GTSAM's "indeterminant linear system"). A point in the graph can be dropped (Drop: its later
// observations are left out, counted), e.g. by a caller that finds its rays nearly parallel at
// the estimate (it ran off along them) before its depth becomes indeterminate.
//
// Gauge: image 0's pose and (when refined) calibration have priors (sigma anchor_sigma); the scale
// is fixed by a prior on the first point that enters along its ray from image 0 only (information
// 1/anchor_sigma² along the ray, 1e-6 across: in effect its range, as GTSAM's driver fixes it).
// Keys as core/ba/reconstruction_graph.h: image i → 'x' i, point j → 'l' j, intrinsics k → 'k' k
// (a shared intrinsics enters with its first image).
#pragma once

#include <vector>

#include "core/ba/reconstruction_graph.h"
#include "core/base/status.h"
#include "core/factors/factor_graph.h"
#include "core/factors/robust_kernel.h"
#include "core/factors/values.h"
#include "core/sfm/reconstruction.h"

namespace slamd::core {

struct ReconstructionStreamParams {
  int min_views = 2;                // >= 2
  int min_registration_points = 5;  // >= 3 (a pose from points in the graph; 5: the first pair)
  bool refine_intrinsics = true;  // calibrations as variables, or held at the file's values
  double min_parallax_deg = 1.0;  // >= 0
  double anchor_sigma = 1e-3;     // > 0
  double pixel_sigma = 1.0;       // > 0
  RobustKernel robust = {};       // on every observation

  Status Validate() const;
};

struct ReconstructionStep {
  FactorGraph factors;  // this step's: priors, observations of points already in, entering ones
  Values values;        // the variables these factors introduce
  int points_entered = 0;
  int observations_entered = 0;  // projection factors in `factors`
  std::vector<int> images_entered;  // registered at this step (this step's image or held ones)
};

class ReconstructionStream {
 public:
  // kInvalidArgument for invalid params or reconstruction.
  static Result<ReconstructionStream> Create(const Reconstruction& reconstruction,
                                             const ReconstructionStreamParams& params = {});

  int num_steps() const { return static_cast<int>(r_.images.size()); }
  // Step `image`; steps must be taken in order 0, 1, ... (checked).
  ReconstructionStep Next();
  // Observations not (yet) in the graph: of points not yet determined and of images not yet
  // registered; after the last step, those never determined or registered.
  int held_observations() const;
  int held_images() const;  // images not (yet) registered
  int points_in() const { return points_in_; }
  // Takes `point` (in the graph) out of the replay: its later observations are dropped, not
  // added (the caller removes it from the solver). Not the point that fixes the scale.
  void Drop(int point);
  bool Droppable(int point) const { return point_in_[point] == 1 && point != scale_point_; }
  int dropped_points() const { return dropped_points_; }
  int dropped_observations() const { return dropped_observations_; }
  // Images in the graph that observe `point` (for a caller judging its geometry).
  std::vector<int> ImagesSeeing(int point) const;
  // The graph's keys (ReconstructionKeys), e.g. for UpdateReconstruction.
  const ReconstructionGraph& keys() const { return keys_; }

 private:
  ReconstructionStream(Reconstruction r, ReconstructionStreamParams params, NoiseModel pixel_noise);
  // Views a point needs to enter now: two until the scale is fixed, then min_views.
  int ViewsNeeded() const;
  // Whether `point`'s held observations, with observation `extra` (>= 0) too, are `views` views
  // with enough parallax.
  bool Determined(int point, int views, int extra = -1) const;
  // Whether `image` can be registered now (class comment).
  bool Registrable(int image) const;
  // Enters `image`: its pose, calibration, the observations of points in, and the points it
  // determines.
  void Register(int image, ReconstructionStep* step);

  Reconstruction r_;
  ReconstructionStreamParams params_;
  ReconstructionGraph keys_;  // keys only (graph and values empty)
  NoiseModel pixel_noise_;
  int next_ = 0;
  int points_in_ = 0;
  int dropped_points_ = 0, dropped_observations_ = 0;
  int scale_point_ = -1;
  bool scale_fixed_ = false;
  std::vector<std::vector<int>> observations_of_image_;  // indices into r_.observations
  std::vector<std::vector<int>> observations_of_point_;
  std::vector<std::vector<int>> held_;                   // per point, its held observations
  std::vector<char> point_in_, intrinsics_in_;           // point_in_: 1 in the graph, 2 dropped
  std::vector<char> image_in_;
  std::vector<int> held_images_;  // not yet registered, in order
};

}  // namespace slamd::core
