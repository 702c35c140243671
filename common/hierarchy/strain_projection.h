#pragma once
// Strain limits by projection: moves the free vertices of a mesh until every limited triangle's
// largest principal stretch is at or below its goal, by iterated per-triangle projections (in the
// manner of the isotropic strain limiting of Wang, O'Brien & Ramamoorthi 2010, "Multi-resolution
// isotropic strain limiting", swept Gauss-Seidel).
//
// Why: safe upsampling (safe_upsampling.h, step 7) must hand a refinement level a start state below
// its strain limits, since the level's strain-limit barrier is infinite beyond them. The prolonged
// fine state of a waving flag has stretches of 1.07-1.45 against a 1.05 limit. The reweighted
// membrane relaxation (patch_relaxation.h, relax_strain) reaches the limit only after 8-24 Newton
// solves, 0.4-2.3 s on the flag's 416-vertex level against a 0.06 s time step, and with its 8 rounds
// it often did not reach it at all (every vertical start of the flag was refused). A projection
// iteration costs a pass over the violating triangles.
//
// One iteration sweeps the limited triangles in order. A triangle f with sigma_max > goal_f has its
// deformation gradient F (3x2, see physics/strain_limit.h) clamped to F' = F V diag(s_i) V^T (V: the
// eigenvectors of F^T F, s_i = goal_f (1 - 1e-3) / sigma_i where sigma_i > goal_f, else 1: F's
// rotation with its larger singular values just below the goal), the clamped triangle
// F' (p_k - p_mean) (p_k: its rest vertices in the rest frame) is placed onto the current vertices by
// weighted Procrustes (a vertex that may not move weighs 1e6 times a free one, so the triangle is
// fitted onto its fixed vertices, rotation included), and its free vertices move there at once
// (Gauss-Seidel: later triangles see the move). Fixed vertices never move. Stops when every limited
// triangle meets its goal, when the worst stretch stops falling, or after max_iterations.
//
// Not an energy minimisation: the result is a nearby state below the limits, which the level's own
// solve then moves. Contact is not seen here: the caller follows the recorded iterates with CCD
// (submesh_relaxation.h, follow_path).
//
// Deterministic: one thread, fixed order. Conventions: positions (n, 3) rows in metres; faces
// 0-based; stretches dimensionless (1 = rest).
#include <vector>

#include "geometry/mesh.h"

namespace pd {

struct StrainProjectionSettings {
  double target_fraction = 1e-3;  // goal_f = limit_f * (1 - target_fraction), in [0, 1)
  int max_iterations = 2000;      // (>= 1)
  // Every this many iterations (>= 1) the worst stretch is checked; the projection stops when it
  // fell by less than a relative 1e-4 since the last check (a cycle it cannot leave).
  int progress_every = 50;
  int record_every = 10;          // iterates recorded every this many iterations (>= 1), and the last
};

struct StrainProjectionReport {
  int iterations = 0;               // projection iterations run
  double max_stretch_before = 0.0;  // max sigma_max over limited faces (0 when none)
  double max_stretch_after = 0.0;
  bool satisfied = false;           // every limited face meets its goal
};

// rest: (n, 3) rest positions; F: faces; face_limit: one per face, 0 = none, else the sigma_max limit
// (> 1); free_mask: one per vertex, 1 = may move. x: (n, 3), moved in place. iterates (optional):
// the positions every record_every iterations and at the end (not the start).
// A limited triangle whose rest shape has no area has no stretch and is skipped (as relax_strain does).
// Throws std::invalid_argument for inconsistent sizes, a limit that is not 0 and not a finite value
// > 1, or settings out of range.
StrainProjectionReport project_strain(const Positions& rest, const Faces& F, const std::vector<double>& face_limit,
                                      const std::vector<char>& free_mask, const StrainProjectionSettings& settings,
                                      Positions& x, std::vector<Positions>* iterates = nullptr);

}  // namespace pd
