#pragma once
// Local relaxation solves used by safe upsampling (Progressive Shell Quasistatics, Zhang et al. 2023,
// sections 4.4.3 "Expansion-patch relaxation" and 4.4.5 "Strain limiting feasibility").
//
// Safe upsampling inserts vertices and advances them toward their prolonged targets with CCD. CCD is
// physics-oblivious: afterwards some contact pairs may sit closer than a wanted minimum gap, some
// triangles may be crushed, and some may be stretched beyond a strain limit. The two functions here
// move a given set of free vertices (every other vertex stays bit-for-bit where it is) to fix that,
// while every iterate stays intersection-free (every Newton line search is capped by the contact
// CCD of BarrierPotential::max_step).
//
// They work on a plain mesh: positions (n, 3) in metres, one row per vertex, 0-based indices, every
// vertex referenced by a face (mesh.h conventions). They know nothing about hierarchies.
//
// ---- Shared energy (both solves) ------------------------------------------------------------
// Minimised with projected Newton (solver/newton.h: newton_minimize, CHOLMOD), non-free dofs fixed:
//
//   E(x) = membrane(x) + anchor(x) + kappa * contact barrier(x)
//
//  * membrane: Neo-Hookean (physics/membrane_neo_hookean.h) on the faces with at least one free
//    vertex, rest shape = RelaxationMesh::rest, material E = 1 Pa, nu = 0.3, thickness 1 m. Why a
//    normalised material: no other elastic term competes with it; the anchor stiffness and the
//    barrier stiffness below are both set relative to E * thickness (N/m, the membrane's stiffness
//    per vertex, independent of the triangle size in 2D elasticity), so multiplying E * thickness by
//    any factor scales the whole energy and leaves the minimiser unchanged. The membrane pulls each
//    triangle toward its rest shape; its ln(J) term diverges as a triangle collapses, so it is also
//    what "expands the ill-shaped elements" (a crushed triangle is pushed open).
//    Faces skipped: a rest triangle that is degenerate (|e1 x e2| <= 1e-12 * longest edge^2, or
//    non-finite) has no usable rest metric (its inverse would be infinite or noise), and a face whose
//    *current* triangle has exactly zero area would make the start energy infinite (no Newton step is
//    possible from +infinity). Both are left out of the membrane (and counted in the report).
//  * anchor: InertiaTerm with h = 1 s, x_hat = the start positions and a uniform per-vertex "mass"
//    anchor_stiffness * E * thickness (so the term is anchor_stiffness * (E t) / 2 * |x - x_start|^2).
//    Needed because a flat membrane has no stiffness out of its plane (and a free vertex whose faces
//    are all rest-shaped has none at all): without it the Newton system is singular. Uniform (not
//    lumped by area) so that it stays commensurate with the size-independent membrane stiffness.
//    Weak (default 1e-2 of the membrane) so it only regularises.
//  * barrier: BarrierPotential over all of the mesh's contact primitives at the contact offset xi,
//    activation dhat_b (see each solve), plus the ground (RelaxationMesh::ground) with the same
//    offset, activation and stiffness. Pairs that START within the offset (a freshly split edge is
//    shorter than the shell thickness) contact at distance 0 instead (BarrierPotential thin pairs):
//    the barrier is then finite at every intersection-free start and pushes those pairs out through
//    the offset, while no pair that starts beyond the offset can be pressed into it (an earlier
//    version used offset 0 for the whole barrier whenever one pair started inside, and the membrane
//    then pressed pairs resting on a collider deep into the offset). CCD (ccd_ratio 0.9) keeps every
//    iterate intersection-free. Pairs are the broad phase's (pairs sharing a vertex excluded; pairs
//    within one object only with its self-contact flag on).
//
// Cost: the system has 3n dofs (fixed dofs are identity rows) and the broad phase / CCD run over the
// whole mesh, so each iteration is O(n); pass a submesh when n is large and the patch is small
// (contact with geometry left out of the submesh is then not seen).
//
// Pairs and faces whose vertices are all fixed cannot change; the success tests below only look at
// pairs (faces) with at least one free vertex.
//
// Path: each solve can return its accepted Newton iterates (`iterates`, whole positions, fixed rows
// as passed, in order; the last is the result). Each step between them was capped by the barrier's
// CCD, so a caller that solved on a submesh can follow the same piecewise-straight path in the
// whole mesh, checking each segment against what the submesh left out.
//
// Deterministic: no randomness; the same input gives the same output.
#include <limits>
#include <vector>

#include "geometry/mesh.h"
#include "hierarchy/safe_advance.h"
#include "physics/contact/broad_phase.h"

namespace pd {

struct RelaxationMesh {
  const ContactPrimitives* primitives = nullptr;  // faces, edges, vertex_object, object_self_contact
  const Positions* rest = nullptr;  // rest positions of the same vertices (m): the membrane's rest shape
  double offset = 0.0;              // contact thickness xi (m, >= 0): contact happens at distance xi
  // Optional analytic ground (vertex_collides per vertex), with the same offset, activation and
  // stiffness as the mesh barrier (physics/contact/ground_barrier.h). Its colliding vertices must
  // start above height + offset.
  const GroundPlane* ground = nullptr;
};

struct GapRelaxationSettings {
  double min_gap = 0.0;                 // wanted: d - offset >= min_gap for every pair (m), > 0
  int max_stiffness_rounds = 16;        // kappa doubles each round (>= 1)
  int newton_iterations_per_round = 20; // (>= 1)
  double anchor_stiffness = 1e-2;       // anchor per vertex, in units of E * thickness (>= 0)
  bool stop_when_stalled = true;        // end the rounds when one stalls (relax_gaps, "Stalls")
  // The membrane's reference per face: a face whose principal stretches from its rest triangle
  // (sigma_max, sigma_min of relax_strain) start within [1 / keep_start_shape_within,
  // keep_start_shape_within] keeps its start shape as its reference (no stress at the start); any
  // other face (crushed, shrunk, or stretched past it) is pulled toward its rest shape, the membrane
  // "expanding ill-shaped elements". So the solve opens gaps and reshapes distorted triangles without
  // releasing the stress the patch starts with. 1 or less: every face toward its rest shape (an
  // undeformed face's start shape is its rest shape), PSQ 4.4.3 as written (relax_gaps, "Reference").
  double keep_start_shape_within = 2.0;
};

struct RelaxationReport {
  int rounds = 0;              // stiffness rounds (relax_gaps) / reweighting rounds (relax_strain)
  int newton_iterations = 0;   // Newton systems solved over all rounds
  // min over pairs with a free vertex and d < offset + gap_reach of (d - offset), m; +inf if none.
  // gap_reach = 2 * min_gap (relax_gaps) or the contact gap (relax_strain): values are exact below
  // it, and +inf means every such pair is at least that far.
  double min_gap_before = std::numeric_limits<double>::infinity();
  double min_gap_after = std::numeric_limits<double>::infinity();
  // relax_strain only: max over limited faces of sigma_max (largest principal stretch, 1 = rest).
  double max_stretch_before = 0.0, max_stretch_after = 0.0;
  // min over membrane faces of quality(x) / quality(rest), quality = 4 sqrt(3) area / sum |e|^2
  // (1 = same shape as at rest up to scale; -> 0 as a triangle is crushed).
  double min_relative_quality_before = 0.0, min_relative_quality_after = 0.0;
  // relax_toward only: max over free vertices of |x_v - aim_v| (m).
  double max_target_distance_before = 0.0, max_target_distance_after = 0.0;
  int skipped_faces = 0;       // faces with a free vertex left out of the membrane (see above)
  bool satisfied = false;      // the goal of the solve was met (see each function)
  bool stalled = false;        // relax_gaps only: the rounds ended on a stall (see relax_gaps)
};

// PSQ 4.4.3: relax the patch with Newton on E(x) above, barrier activation dhat_b = offset +
// 2 * min_gap, over rounds of increasing barrier stiffness kappa (doubled each round), until every
// pair with a free vertex has d - offset >= min_gap or the rounds run out.
//
// Why dhat_b = offset + 2 min_gap rather than offset + min_gap: a barrier only pushes while the pair
// is inside its activation distance, and it balances an opposing elastic / anchor force only at a
// distance where it is still active, i.e. strictly below dhat_b. With dhat_b = offset + min_gap the
// target would be reached only in the limit kappa -> infinity; with twice that, a finite kappa puts
// the equilibrium beyond offset + min_gap, and the barrier never pushes a pair beyond offset +
// 2 min_gap (no over-shoot beyond that).
//
// Reference: the membrane of E(x) is measured from each face's rest triangle only for the faces
// settings.keep_start_shape_within leaves out (the distorted ones); the others are measured from
// their start triangle. Why: with every face measured from its rest shape, a patch of a sheet that
// is stretched where it rests in contact (cube-trampoline-large, level 0 -> 1 at frame 50: the sheet
// under the cube) has its whole tension as a driving force, balanced at the start by contact and by
// the level's forces that E(x) leaves out (gravity, bending, the cube's weight). Newton then proposed
// steps of 1-6 cm pressing the patch into the contact it rests on, the CCD line search cut each to
// 1e-3..1e-1 of itself, and 20 iterations a round closed the smallest gap from 4.5e-7 to 3e-9 m
// instead of opening it. Measured with distorted = outside [1/2, 2] (pd_bench_upsample_frame, against
// every face toward its rest shape): there the upsampling 6.4 -> 0.6 s, its smallest gap 2e-8 ->
// 8.5e-7 m, pairs left under the wanted gap 10 -> 8; level 1 -> 2 at frame 50 4.8 -> 1.1 s, 1e-11 ->
// 1.6e-6 m, 10 -> 0; refused upsamplings of frames 30 / 50 / 70 over its three levels 5 -> 3 of 9,
// of cube-impact-sheet's level 0 at frames 26-36 5 -> 1 of 11 (docs/performance.md). Keeping only
// faces of nearly the rest quality (whatever their size) left restored vertices that had not opened
// up to 3 cm from their targets (a sheet on a sphere).
// Starting kappa: kappa_0 = 1e-2 (E t) / dhat_b^2 (J/m^4), then doubled per round. In a one-pair
// model against a resisting stiffness k (N/m), the barrier's push -kappa b'(s) 2 d at d = dhat_b / 2
// (the wanted distance offset + min_gap when offset = 0) is 4.33 kappa dhat_b^3, so it holds a
// pair there against a displacement of dhat_b / 2 when kappa = k / (8.66 dhat_b^2). kappa_0 thus
// wins against k = 0.087 E t: the default anchor (0.01 E t) is beaten in the first round (the first
// round does something), while pairs are not shoved all the way to the barrier's reach (the smallest
// kappa of the schedule that works disturbs the patch least, the point of a schedule that grows).
// Against the membrane itself (k ~ E t) a few doublings are needed; 16 rounds reach
// 655 (E t) / dhat_b^2, enough against k ~ 5700 E t.
// Each round runs Newton until its step is below min(1e-2 dhat_b, 1e-5 * mean rest edge) or
// newton_iterations_per_round, warm-started from the previous round.
// At least one round is always run, so the membrane also opens crushed triangles when the gaps are
// already fine. satisfied = every pair with a free vertex ends with d - offset >= min_gap.
// Stalls: with settings.stop_when_stalled, the rounds end early when a round's Newton solve used all
// its iterations and the smallest gap did not grow by 10 % over the round before: Newton steps of
// centimetres whose line search (CCD) lets them move nothing, round after round, at pairs left
// 1e-10 to 1e-8 m beyond the offset. Seen when safe upsampling opened a fine level in steady contact
// (cube-trampoline-large, level 0 -> 1 at frame 50): 55 patches, every one of them unsatisfied
// after all 8 rounds (160 iterations, 0.35-0.98 s each), 23.4 s of a 23.8 s upsampling for the
// same unresolved gaps; stopping at the stall ends each patch after one or two rounds.
// Throws std::invalid_argument for: missing pointers or inconsistent sizes (rest / x rows vs
// vertex_object), a free vertex out of [0, n) (duplicates are fine), min_gap <= 0 or not finite,
// offset < 0, non-positive round / iteration counts, a negative anchor stiffness, or a start with a
// pair at d <= 0 (touching / intersecting: the barrier is infinite there). Piercing without a close
// pair (an edge through a large triangle's interior) is not detected: the start must be
// intersection-free (physics/contact/start_check.h checks it).
RelaxationReport relax_gaps(const RelaxationMesh& mesh, const std::vector<int>& free_vertices,
                            const GapRelaxationSettings& settings, Positions& x,
                            std::vector<Positions>* iterates = nullptr);

struct StrainRelaxationSettings {
  double target_fraction = 1e-3;  // goal: sigma_max <= limit * (1 - target_fraction), in [0, 1)
  // Barrier activation gap (m, > 0): dhat_b = offset + contact_gap. Pairs closer than that are
  // pushed apart, and every iterate stays intersection-free. Default 1e-4 m, the low end of the gap
  // range PSQ keeps between primitives (1e-4 to 1e-3 m), so the barrier stays local.
  double contact_gap = 1e-4;
  int max_rounds = 8;                   // membrane reweighting rounds (>= 1)
  // Stop when a round improves the worst stretch ratio by less than a relative 1e-6. Off: the
  // rounds go on to max_rounds while any face is over its goal (reweighting is not monotone: on the
  // flag a round that raised the worst ratio was often followed by rounds that met every goal).
  bool stop_without_progress = true;
  int newton_iterations_per_round = 50; // (>= 1)
  double anchor_stiffness = 1e-2;       // as GapRelaxationSettings::anchor_stiffness
};

// PSQ 4.4.5 (PCS's strain-limit correction, with the old coarse vertices fixed and the new ones
// free): move the free vertices so that every limited face's largest principal stretch sigma_max is
// at most face_limit[f] * (1 - target_fraction).
//
// face_limit: one entry per face of mesh.primitives->faces, > 1 = limit on sigma_max (dimensionless),
// 0 = no limit for that face. The energy is E(x) above (barrier with dhat_b = offset + contact_gap
// and kappa = (E t) / contact_gap^2, fixed: the barrier's reach beyond the offset sets its scale).
// Round k minimises it with the membrane weight of each face multiplied by w_f, w_f starting at 1 and doubled every round in which face f (limited, with a free
// vertex) ends above its goal (iteratively reweighted membrane): the membrane alone spreads stretch
// over the free vertices, and the growing weights trade stretch away from the violating faces to
// their neighbours that are under their limits. Why not the StrainLimitTerm barrier: it is infinite
// at an over-limit start, which is exactly the state this solve starts from. Stops when every limited
// face with a free vertex meets its goal, when no violating face can change (all fixed), after
// max_rounds, or (with stop_without_progress) when a round improves the largest stretch ratio
// sigma_max / limit by less than 1e-6 (relative). Faces whose vertices are all fixed cannot be fixed here; they still count in
// max_stretch_* and make satisfied false if over their limit.
// satisfied = every limited face meets its goal.
// Throws std::invalid_argument as relax_gaps (minus min_gap), and for face_limit of the wrong size or
// an entry that is not 0 and not a finite value > 1, target_fraction outside [0, 1), contact_gap <= 0.
RelaxationReport relax_strain(const RelaxationMesh& mesh, const std::vector<int>& free_vertices,
                              const std::vector<double>& face_limit, const StrainRelaxationSettings& settings,
                              Positions& x, std::vector<Positions>* iterates = nullptr);

struct TargetRelaxationSettings {
  // Barrier activation gap beyond the offset (m, > 0), as StrainRelaxationSettings::contact_gap.
  double contact_gap = 1e-4;
  // Pull of each free vertex toward its aim, in units of E * thickness (> 0). 1: as stiff as the
  // membrane, so a vertex goes where its aim is unless contact or its triangles' shape hold it back.
  double target_stiffness = 1.0;
  int newton_iterations = 50;  // (>= 1)
};

// Moves the free vertices toward aim (one row per vertex, m) as far as contact allows, sliding
// along it: Newton on E(x) above with the anchor at `aim` (stiffness target_stiffness instead of
// anchor_stiffness), barrier with dhat_b = offset + contact_gap and kappa = (E t) / contact_gap^2.
// Why: the safe advancement (safe_advance.h) is physics-oblivious, and a vertex whose straight path
// runs into a collider stops there for good, even when its aim lies beside the collider or beyond
// one of its edges; here the barrier turns the pull into sliding, so cloth wraps around a sharp edge
// the way the level's own solve would move it. Every iterate is intersection-free (CCD-capped line
// search). satisfied = Newton converged (step below tolerance). Throws std::invalid_argument
// as relax_gaps, and for an aim of the wrong size or not finite, a non-positive contact_gap or
// target_stiffness.
RelaxationReport relax_toward(const RelaxationMesh& mesh, const std::vector<int>& free_vertices, const Positions& aim,
                              const TargetRelaxationSettings& settings, Positions& x,
                              std::vector<Positions>* iterates = nullptr);

// ---- Helpers (exposed for tests and callers' diagnostics) ------------------------------------

// min over point-triangle / edge-edge candidate pairs (broad phase rules) with at least one vertex
// in `free_mask` (size n, 1 = free; empty = every vertex counts) and distance < offset + reach, of
// (d - offset) in m; +inf if there is none. reach >= 0 (m).
double relaxation_min_gap(const ContactPrimitives& primitives, const Positions& x, double offset,
                          double reach, const std::vector<char>& free_mask = {});

// Shape quality of a triangle: 4 sqrt(3) * area / (sum of squared edge lengths), dimensionless,
// 1 for equilateral, 0 for degenerate.
double triangle_quality(const Vec3& a, const Vec3& b, const Vec3& c);

}  // namespace pd
