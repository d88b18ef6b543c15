// Isam2Params: the per-instance options of the incremental solver (isam2.h), fixed at
// construction. Defaults follow GTSAM's ISAM2 defaults (Gauss-Newton steps, relinearize
// threshold 0.1, relinearize skip 10, wildfire 0.001) so results can be compared.
#pragma once

#include <string>
#include <vector>

#include "core/base/status.h"
#include "core/inference/elimination.h"
#include "core/variables/variable.h"

namespace slamd::core {

struct Isam2Params {
  struct Relinearization {
    // A variable is relinearised when a rotation entry of its update δ exceeds this (radians).
    // > 0.
    double rotation_threshold = 0.1;
    // ... or a translation entry (metres; points have translation entries only). > 0.
    double translation_threshold = 0.1;
    // ... or a calibration entry (in the calibration's units: pixels for focal lengths and
    // principal points, none for distortion terms). > 0.
    double calibration_threshold = 0.1;
    // ... or any other entry. > 0.
    double other_threshold = 0.1;
    // Thresholds of one kind of entry of one variable type, in place of the four above, e.g.
    // {.type = "Cal3DS2", .kind = EntryKind::kCalibration, .threshold = 1e-3}.
    struct TypeThreshold {
      std::string type;  // a variable type's name (VariableTypeName)
      EntryKind kind = EntryKind::kOther;
      double threshold = 0.1;  // > 0
    };
    std::vector<TypeThreshold> per_type = {};
    // ... or a factor on it has a stale linearisation: at the estimate θ ⊕ δ its whitened
    // residual differs from the linear model's prediction A·δ + b by more than this (in standard
    // deviations, |r(θ ⊕ δ) − (A·δ + b)|). The δ thresholds are in fixed units, blind to how
    // stiff the factors are: with information ~1e12 (input_INTEL_g2o), a rotation δ far below
    // 0.1 rad already leaves a linearisation error of thousands of sigmas, and the estimate
    // stays far from the optimum. Checked with the δ thresholds (every `skip` updates); only
    // factors whose error, predicted from their last evaluation, may be near this are
    // evaluated. 0 = off (δ thresholds only, as GTSAM's ISAM2). >= 0. A tenth of a sigma: the
    // linear model then misstates no factor by more than a small fraction of its noise (1 sigma
    // left M3500 and intel.g2o 0.004% above GTSAM's chi2; 0.1 costs up to ~10% more time).
    double error_threshold = 0.1;
    // The check runs every `skip` updates (1 = every update). >= 1.
    int skip = 10;
    // At most this many variables are relinearised in one update, those whose δ exceeds the
    // threshold by the largest factor first; the rest are checked again at the next update. This bounds the
    // worst step: after a large loop closure nearly every δ exceeds the threshold at once, and
    // relinearising them all re-eliminates the whole tree in one update. 0 = no limit. >= 0.
    int max_variables = 0;

    // The threshold of one entry kind of a variable type: its per_type entry, else the kind's.
    double ThresholdOf(VariableType type, EntryKind kind) const;
  };
  Relinearization relinearization = {};

  // Partial back-substitution ("wildfire"): below the re-eliminated top, a clique is re-solved
  // only when a separator variable's update changed by more than this (max abs entry). 0 solves
  // every clique below a change. >= 0.
  double wildfire_threshold = 0.001;

  // Refine() relinearises variables whose update exceeds this (both rotation and translation
  // entries). > 0.
  double refine_threshold = 1e-6;
  // ... at most this many per round, those whose update exceeds it by the largest factor first
  // (as Relinearization::max_variables). On a large map a round that relinearised every
  // variable still moving re-eliminated most of the tree (50-300 ms at 250k variables in slamd's
  // soak), and a message that came meanwhile waited for it. 0 = no limit. >= 0.
  int refine_max_variables = 2048;

  // Trust region: with `enabled`, every update ends with Powell's dog leg (core/isam/dogleg.h)
  // instead of the plain Gauss-Newton step: the step is cut back to the trust-region radius
  // along the dog-leg path until the cost (robust kernels applied) is below the cost where it
  // started, and the radius adapts to how well the linear model predicted the decrease. It
  // starts from the estimate before the update where the relinearisation check ran and left
  // nothing due (every update with skip 1), else from θ. Gauss-Newton
  // diverges where new variables are weakly determined (a camera's own calibration, a landmark
  // seen at little parallax); the dog leg does not, at the price of a full back-substitution,
  // the gradient and one or more cost evaluations per update: O(variables + factors), where
  // Gauss-Newton's update touches only the top of the tree. The radius is a Euclidean norm over
  // δ in the variables' own units.
  struct TrustRegion {
    bool enabled = false;
    double initial_radius = 1.0;  // > 0
    // Below this radius the update keeps the estimate it started from. > 0.
    double min_radius = 1e-9;
  };
  TrustRegion trust_region = {};

  // Threads for the slowest steps, which relinearise most of the graph and re-eliminate the
  // whole tree: they relinearise factors (when there are 512+ per thread) and eliminate
  // independent subtrees in parallel (Eliminator, when the work is large enough). Results do not
  // depend on it (each factor and clique is computed as by one thread). 1 = the calling thread
  // only. >= 1. (slamd also gives it to its marginals, MarginalsParams::threads.)
  int threads = 2;

  // The re-elimination orders the variables of the new factors last (iSAM2 §V-A: the next update,
  // which most likely touches them again, finds them near the root), landmarks (Point2, Point3)
  // among them only while there are at most this many. A camera frame sees hundreds of points:
  // ordered last, every older camera eliminated before them joined them into one dense root
  // clique (3 unknowns a point, O(n³)), where ordered freely they are eliminated before their
  // cameras (the Schur complement). A robot seeing a few landmarks keeps them at the root. When
  // more than this many landmarks are re-eliminated, they are most of what is, and the cameras
  // they leave are densely tied (half the pairs share a point), all of them go first, ahead of
  // the rest's COLAMD (Ladybug-49: COLAMD on the whole top cost as much as a third of the
  // elimination). >= 0.
  int max_landmarks_last = 8;

  // Every `batch_every` updates, relinearise every variable and re-eliminate the whole graph
  // with a fresh COLAMD ordering (the iSAM1-style batch step). 0 = never. >= 0.
  int batch_every = 0;

  // Dense clique elimination (pivot tolerance, supernodes). Isam2 accepts every positive pivot
  // (tolerance 0, like CHOLMOD in the batch solver) and reports only zero, negative or NaN ones.
  // A relative tolerance cannot tell round-off from a weakly constrained direction on real maps:
  // the round-off bound carried up the tree grows with lever arms and subtree size (1.6e15 on
  // manhattan.g2o where the true pivot is ~1e2), and parking-garage.g2o has rotation directions
  // with information 1.5e-9 next to ~4; any tolerance above ~1e-19 rejected valid updates on the
  // development data. Unanchored robots are kept out by the server, not detected here.
  EliminationParams elimination = {.relative_pivot_tolerance = 0.0};

  // Checks every field; the message names the field, its value and the constraint.
  Status Validate() const;
};

}  // namespace slamd::core
