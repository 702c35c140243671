#pragma once
// Safe, intersection-free upsampling of a level's solution to the next finer level (PSQ 4.4,
// Algorithms 2, 3 and 5): the warm start of every refinement. The prolongation P_{l+1}^l(x_l) is the
// shape we want, but it is oblivious to contact and strain limits; this finds an intersection-free
// state close to it with level l+1's topology.
//
// Algorithm, per vertex-split batch (split_batches.h; patches within a batch are vertex-disjoint):
//  1. g_i = the smallest contact gap of the pairs of each kept vertex i in the current mesh
//     (safe_advance.h's rule, capped at the level's mean rest edge length so that a contact-free
//     scene still has a scale).
//  2. Topology: every collapse of the batch is undone (faces_after -> faces_before); the restored
//     vertex starts on its kept vertex.
//  3. Safe perturbation (Algorithm 5): the restored vertex moves by eps = 0.01 g_i, first toward its
//     target, else along pseudo-random directions, until its patch is valid: no two patch primitives
//     without a common vertex closer than 1e-6 eps, no edge through a patch triangle, and each new
//     sliver triangle (kept, restored, a) facing the same side as its neighbours at a. The restored vertex starts
//     as a copy of i, so its pairs with the rest of the mesh start at least g_i apart, and moving
//     by 0.01 g_i cannot bring them into contact. (PSQ takes one g for the whole mesh; a single
//     tight spot then shrinks every perturbation of the batch.)
//  4. Additive advancement of ALL present vertices toward their targets (safe_advance.h): for the
//     intermediate connectivity between batches, the intermediate rest shape carried into the
//     deformed shape (see the .cpp); after the last batch, the prolongation itself.
//  4b. Splits the advancement left unopened (restored vertex nearer its kept vertex than half the
//     distance between their aims: both in tight contact, their straight paths blocked) get their
//     patch and one-ring pulled toward the aims by a Newton solve with membrane and barrier
//     (patch_relaxation.h, relax_toward), which slides them along the contact. Not in PSQ, whose
//     advancement stops such vertices too; without it a cloth draped over a sharp box and two
//     stacked sheets failed (a later split beside an unopened one found no valid perturbation).
//  5. Pairs left closer than the minimum gap (d - offset < min_gap_fraction * g_level, g_level the
//     gap of the coarse solution) and badly shaped new triangles get a local relaxation of their
//     patch (patch_relaxation.h: Newton on membrane + barrier with rising stiffness).
// After the last batch:
//  6. Vertices farther than short_fraction of an edge from their target are pulled toward it as in
//     4b (e.g. where the advancement stopped them beside a collider).
//  7. If any face has a strain limit: first the strain projection (strain_projection.h) of every
//     vertex that is not fixed, followed with CCD when it met every limit; what it leaves, the
//     reweighted membrane relaxation of the new vertices (those not on level l; PSQ 4.4.5, level-l
//     vertices fixed), then of every vertex that is not fixed, for up to 24 rounds (measured: with
//     the level-l vertices fixed a self-fold stayed at 1.18 for a 1.05 limit; the second pass
//     reaches 1.01). On the flag's 200 frames (levels 26 / 104 / 416 vertices) the projection alone
//     met the limit at all 19 seams of level 1 -> 2 in 3-66 iterations (2-11 ms) and at 7 of 19 of
//     level 0 -> 1; the relaxation the other 12 (0.12-0.37 s). Before the projection, with 8
//     rounds, every one of them was refused.
//
// Every relaxation runs on a submesh around its free vertices, with the ground, and its result is
// brought into the whole mesh by following its path of Newton iterates, each segment capped by CCD
// against the whole mesh and the ground (so geometry outside the submesh is respected too).
// Contact offsets: a pair beyond the offset is kept beyond it; a pair within it (only freshly split
// edges start there) is kept intersection-free with thickness 0 until relaxation pushes it out.
//
// Fixed vertices (pins, obstacles) advance toward their targets like all others but are never moved
// by relaxation.
//
// Deterministic: the pseudo-random directions come from a seeded mt19937_64 mapped to the sphere by
// hand (std distributions are implementation-defined), one stream per collapse.
//
// Conventions: positions (n, 3) rows in metres; ids 0-based; level l+1's global vertex ids.
#include <cstdint>
#include <optional>
#include <vector>
#include "geometry/mesh.h"
#include "hierarchy/safe_advance.h"
#include "hierarchy/scene_hierarchy.h"

namespace pd {

// The fixed data of one level transition l -> l+1, scene-wide.
struct UpsamplingLevel {
  Faces coarse_faces;                     // level l faces, level l ids
  TriMesh fine;                           // level l+1 rest mesh
  SceneCollapses collapses;               // level l's collapses in level l+1 ids, batches, coarse_to_fine
  // P_{l+1}^l, for the rotations that carry intermediate rest shapes (see safe_upsampling.cpp);
  // null: no rotation (identity). Not owned: must outlive the calls.
  const ShellProlongation* to_next = nullptr;
  std::vector<int> vertex_object;         // per fine vertex, object id
  std::vector<char> object_self_contact;  // per object
  std::vector<char> vertex_fixed;         // per fine vertex: 1 = never moved by relaxation
  std::vector<double> face_strain_limit;  // per fine face (row of fine.F): sigma_max limit, 0 = none
  double offset = 0.0;                    // contact offset xi, m
  std::optional<GroundPlane> ground;      // vertex_collides per fine vertex
  // false: the scene has no contact at all, nothing can intersect, and the upsampled state is the
  // prolongation itself (then only strain limits are enforced).
  bool contact = true;
};

struct UpsamplingSettings {
  double perturbation_fraction = 0.01;    // eps = fraction * g (PSQ: 0.01)
  int max_perturbation_samples = 200;     // random directions tried per restored vertex
  double min_gap_fraction = 0.01;         // relax pairs below this fraction of the coarse solution's gap
  double min_quality = 0.05;              // relax new triangles below this quality (and half their rest quality)
  // A split is unopened when its restored vertex ends an advancement nearer its kept vertex than
  // this fraction of the distance between their aims; its patch is then pulled toward the aims.
  double unopened_fraction = 0.5;
  // After the last batch, vertices farther than this fraction of the mean edge from their target
  // are pulled toward it (with their one-ring).
  double short_fraction = 1e-3;
  std::uint64_t seed = 0x5eed;
  AdvanceSettings advance;
};

struct UpsamplingReport {
  int batches = 0;
  int splits = 0;
  int random_perturbations = 0;     // splits whose first (toward-target) perturbation was invalid
  int perturbation_samples = 0;     // random directions drawn in all
  int advance_events = 0;           // motions bounded by a pair, over all batches
  int close_events = 0;             //   of which by pairs that started much closer than the gap
  int stopped_vertices = 0;
  int redirections = 0;             // approaching components removed (safe_advance.h, "Sliding")
  int relaxed_patches = 0;          // batches that needed a gap/shape relaxation
  int unopened_splits = 0;          // splits the advancement left unopened (pulled toward their aims)
  int final_pull_vertices = 0;      // vertices short of their target after the last batch
  int pull_newton_iterations = 0;   // Newton iterations of all pulls
  int strain_passes = 0;            // strain relaxations run (new vertices, then all if needed)
  int strain_projection_iterations = 0;  // iterations of the strain projection (step 7a)
  int unresolved_gaps = 0;          // pairs still below the minimum gap at the end
  double coarse_gap = 0.0;          // g_level: smallest gap of the coarse solution (m)
  double final_gap = 0.0;           // smallest gap of the result (m, same rule)
  double max_target_distance = 0.0; // max_i |x_i - target_i|, m
  double rms_target_distance = 0.0; // m
  double max_stretch_before = 0.0;  // largest sigma_max over limited faces before / after the
  double max_stretch_after = 0.0;   // strain-limit relaxation (0 without limits)
  double seconds = 0.0;             // total wall time, s; split into:
  double perturb_seconds = 0.0;     // gap measurements, topology updates and safe perturbations
  double advance_seconds = 0.0;     // additive advancement
  double relax_seconds = 0.0;       // pulling unopened splits, finding too-close pairs and bad triangles, relaxing them
  double pull_seconds = 0.0;        // the final pull toward the targets
  double strain_seconds = 0.0;      // strain-limit relaxation
};

// Thrown when no valid perturbation is found for a split (PSQ Fig. 20: possible in contrived cases).
class UpsamplingFailed : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// x_coarse: level l's solution (n_l, 3), intersection-free; target: P_{l+1}^l(x_coarse) (n_{l+1}, 3).
// Returns level l+1 positions, intersection-free. Throws std::invalid_argument for inconsistent sizes,
// UpsamplingFailed as above.
Positions safe_upsample(const UpsamplingLevel& level, const Positions& x_coarse, const Positions& target,
                        const UpsamplingSettings& settings = {}, UpsamplingReport* report = nullptr);

// The transition l -> l+1 of a scene: contact offset, self-contact flags, ground, strain limits from
// the scene; pinned vertices and obstacles fixed. Throws std::invalid_argument for a level outside
// [0, L).
UpsamplingLevel upsampling_level(const Scene& scene, const SceneHierarchy& hierarchy, int level);

}  // namespace pd
