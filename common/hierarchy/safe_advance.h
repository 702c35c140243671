#pragma once
// Additive, CCD-filtered advancement of every vertex toward its own target (PSQ 4.4.2 and 4.4.4,
// Algorithms 3 and 4): the motion that carries a just-split mesh toward the prolonged shape without
// ever letting two primitives touch.
//
// Motion. Vertex i moves on the straight line x_i(s) = x0_i + s (target_i - x0_i), all vertices with
// one shared progress s in [0, 1], until it is stopped. A contact pair (point-triangle, edge-edge, or
// a vertex and the ground plane) certifies, by additive CCD (ACCD, ccd_additive.h), a progress s_p up
// to which its motion is safe. The smallest s_p over all pairs is the next event: every vertex moves
// to s = s_p, and the pair's stencil vertices change course (below). The others go on. It ends when
// no pair bounds the motion before s = 1 (every vertex still on its line reached the end of it).
//
// Sliding (our departure from PSQ, which stops the whole stencil: "cancel their remaining
// displacement"). Stopping is too harsh for cloth resting on a collider: its targets move it mostly
// along the surface, yet one small approaching component stopped the vertex for the rest of the
// batch and left a collapsed edge behind (on a drape over a box, most vertices at the box stopped).
// So the vertices that approach the other primitive (negative velocity along the pair's normal,
// from its second primitive toward its first) lose that component and keep sliding; each pair turns
// its vertices once (a pair that bounds the motion again stops them), each vertex at most
// max_redirects times, so a vertex can slide across many facets of a collider but never loops.
// The pair's kept gap is lowered when it turns them (halved for a far pair, by 1% for a close one)
// for the slack that a first-order projection does not cover. A pair that bounds the motion without
// any approaching vertex (rotation, sliding off an edge) stops its stencil as in PSQ. Every event
// turns or stops a vertex, so there are at most (max_redirects + 1) n events.
//
// Ratio bounds (Algorithm 4). Every pair keeps d1 >= r d0 of its gap d0 at the start of the
// advancement: r = close_ratio (0.999) for pairs already much closer than the reference gap g
// (d0 < close_fraction * g), so they can hardly come closer, and r = far_ratio (0.1) otherwise, so
// they make progress. The bound is on d0, not on the gap at each re-evaluation: re-evaluated pairs
// would otherwise lose another 90% each time one of their vertices stops. An evaluation at gap d
// asks ACCD (ccd_additive.h) for eta = 1 - r d0 / d; once that would be below ACCD's resolution
// (eta < 0.001) the pair stops where it is.
//
// Floor. No pair is let below F = close_fraction * far_ratio * g (0.01 g) unless it starts below
// F / close_ratio (split-patch pairs below have none): without it the ratios compound over the many advancements of an upsampling
// (every batch and every relaxation runs one), and a pair kept at 99.9% and then 99% per sliding
// step ended 1e-11 m apart after 60 batches (two stacked sheets), too close for the next split's
// perturbation to be resolved in floating point.
//
// Split patches. A pair whose four vertices all lie in one patch that was just split (given by
// vertex_patch) starts at an artificial, tiny distance (the restored vertex was placed 0.01 g from
// its kept vertex), and splitting means exactly that these pairs move apart; holding them to 99.9%
// would stop most new edges before they open (measured: on a flat sheet at rest, every advancement
// event came from such pairs). They get far_ratio whatever their distance.
//
// Thickness. A pair whose distance is above the contact offset xi keeps its gap measured from xi
// (d - xi > 0 throughout, as the solver's barrier needs). A pair already within xi (only freshly split
// patches have those: their new edge starts shorter than xi) is only kept intersection-free
// (thickness 0) and never lets its distance shrink below r d0; relaxation (patch_relaxation.h) later
// pushes it out past xi.
//
// Lazy re-evaluation. A pair's certified s_p stays valid while none of its four vertices changes
// course (its relative motion is unchanged), so only the pairs touching a vertex that just changed
// are asked again, from their current positions: O(pairs + events * pairs per vertex) ACCD queries
// instead of Algorithm 3's full re-query per event.
//
// ACCD queries here are capped at 200 iterations (ccd_additive.h's guard): a pair sliding along at a
// gap kept to 99.9% would otherwise take up to 10,000 tiny certified steps, and the capped answer is
// still a certified (shorter) time; the pair then simply bounds the motion a little earlier.
//
// Candidates come once from the swept broad phase (start -> target) with radius xi + g: a pair that
// is no candidate stays further than g from contact along the whole motion.
//
// Conventions: positions (n, 3) rows, metres, indices 0-based into the rows; every vertex is a contact
// point (no unreferenced vertices: compact the mesh first).
#include <array>
#include <optional>
#include <vector>
#include "geometry/mesh.h"
#include "physics/contact/broad_phase.h"

namespace pd {

// The analytic ground: free space is n . p > height (+ offset).
struct GroundPlane {
  Vec3 normal = Vec3(0, 1, 0);          // unit
  double height = 0.0;                  // m
  std::vector<char> vertex_collides;    // per vertex: 1 if it collides with the ground
};

struct AdvanceSettings {
  double close_fraction = 0.1;  // d0 < close_fraction * g: "much closer than the gap"
  double close_ratio = 0.999;   // PSQ's r for close pairs (keep 99.9% of the gap)
  double far_ratio = 0.1;       // PSQ's r for the others
  // Times a vertex may have its approaching component removed (see "Sliding") before it stops.
  int max_redirects = 32;
};

struct AdvanceReport {
  int candidate_pairs = 0;      // point-triangle + edge-edge pairs from the broad phase
  int events = 0;               // times the motion was bounded by a pair, of which:
  int close_events = 0;         //   by a pair that started much closer than the gap (r = close_ratio)
  int ground_events = 0;        //   by a vertex and the ground
  int stopped_vertices = 0;     // vertices that stopped before their target
  int redirections = 0;         // approaching components removed (see "Sliding")
  int accd_queries = 0;
};

// The pairs within `radius` of contact at positions x: stencil (4 vertex ids; a ground vertex has -1
// in the last three), distance d (m; for a ground vertex its height above the plane) and gap: d -
// offset if d > offset, else d (the thickness rule above). Deterministic order. Pairs farther than
// radius are not looked at, so callers pass the largest gap they care about.
struct PairGap {
  std::array<int, 4> stencil;
  double distance = 0.0;
  double gap = 0.0;
};
std::vector<PairGap> pair_gaps(const ContactPrimitives& prims, const Positions& x, double offset, double radius,
                               const GroundPlane* ground = nullptr);

// The smallest gap of pair_gaps (+infinity without pairs).
double min_contact_gap(const ContactPrimitives& prims, const Positions& x, double offset, double radius,
                       const GroundPlane* ground = nullptr);

// The stencils of the pairs with d - offset < min_gap (for these the offset always counts, so a pair
// within the offset is listed whatever min_gap is). min_gap > 0, m.
std::vector<std::array<int, 4>> pairs_below_gap(const ContactPrimitives& prims, const Positions& x,
                                                double offset, double min_gap,
                                                const GroundPlane* ground = nullptr);

// Moves x toward target as described above; `gap` is the reference gap g (m, > 0). x must be
// intersection-free with every pair's distance > 0 and every ground vertex above the ground. Throws
// std::invalid_argument for size mismatches or a non-positive gap.
// vertex_patch (optional, size n): the split patch of each vertex (>= 0), -1 for none.
AdvanceReport advance_toward_targets(const ContactPrimitives& prims, double offset, double gap,
                                     const GroundPlane* ground, const Positions& target, Positions& x,
                                     const AdvanceSettings& settings = {},
                                     const std::vector<int>* vertex_patch = nullptr);

}  // namespace pd
