#pragma once
// Error measures between two runs of one scene, behind `pd compare` (docs/progressive.md, "Error
// measures"): what a preview resolution, a level count, a tolerance or K time subsets change.
//
// One shape for every function: (a, b, selection) -> measure, where `a` is the run being judged and
// `b` the reference (for symmetric measures the order does not matter). Positions are (n, 3) rows in
// metres (geometry/mesh.h); faces 0-based; a selection is one flag per vertex (1 = counted) or a
// face list. Results are in metres unless a signature says otherwise.
//
// Obstacles are left out by the callers through the selection (simulated_vertices/simulated_faces,
// flags as in consistency.h): they follow their scripts on every level and in every run.
#include <memory>
#include <vector>

#include "geometry/mesh.h"

namespace pd {

// ---- selections ------------------------------------------------------------------------------------

// One flag per vertex: 1 for the vertices of objects k with obstacle[k] == 0. object_offsets: the
// level's vertex offsets (num_objects + 1 entries, object k owns [off[k], off[k+1])); obstacle: one
// flag per object.
std::vector<char> simulated_vertices(const std::vector<int>& object_offsets, const std::vector<char>& obstacle);

// The rows of F whose vertices belong to simulated objects (a face lies in one object; its first
// vertex decides). Same offsets and flags as simulated_vertices.
Faces simulated_faces(const Faces& F, const std::vector<int>& object_offsets, const std::vector<char>& obstacle);

// ---- per-vertex distance on one mesh ----------------------------------------------------------------

// Summary of a set of distances (m). p95 is the nearest-rank 95th percentile: the smallest value
// that at least 95 % of the values do not exceed (sorted[ceil(0.95 n) - 1]). All NaN, count 0, for
// an empty set.
struct DistanceStats {
  double mean = 0.0;
  double p95 = 0.0;
  double max = 0.0;
  std::size_t count = 0;
};
DistanceStats distance_stats(std::vector<double> d);

// |a_i - b_i| (m) for every vertex i with mask[i] != 0, in vertex order. a, b: (n, 3) positions of the
// same mesh (m); mask: n flags. Throws std::invalid_argument when the sizes differ.
std::vector<double> vertex_distances(const Positions& a, const Positions& b, const std::vector<char>& mask);

// distance_stats(vertex_distances(a, b, mask)): one frame's mean, p95 and max (m).
DistanceStats vertex_distance(const Positions& a, const Positions& b, const std::vector<char>& mask);

// ---- Hausdorff distance between triangle surfaces -------------------------------------------------
//
// "Hausdorff" here is vertex-to-surface, both directions:
//   H(A, B) = max( max over vertices v of A of dist(v, B), max over vertices w of B of dist(w, A) )
// with dist(p, S) the exact Euclidean distance from p to the nearest point of any triangle of S
// (point-to-triangle, CGAL's AABB tree; not sampled on the triangles). Only vertices used by a face
// count. It can miss the true Hausdorff distance where the farthest point of a surface lies inside a
// triangle (e.g. a fold's crest between vertices): a lower bound, equal to it when the farthest
// points are vertices (cloth meshes fine enough to follow their folds).

// A triangle surface with a search tree, built once and queried many times.
class TriangleSurface {
 public:
  // V: positions (m), F: the triangles to use (rows index V; vertices no face uses are ignored).
  // Requires F non-empty (std::invalid_argument otherwise).
  TriangleSurface(const Positions& V, const Faces& F);
  TriangleSurface(TriangleSurface&&) noexcept;
  TriangleSurface& operator=(TriangleSurface&&) noexcept;
  ~TriangleSurface();

  // Distance (m) from point p (m) to the nearest point of the surface.
  double distance(const Vec3& p) const;
  // max over the vertices of V used by F of distance(V.row(i)) (m): the directed vertex-to-surface
  // distance from (V, F) to this surface; 0 when F is empty.
  double max_distance_from(const Positions& V, const Faces& F) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// H(A, B) above for A = (Va, Fa) and B = (Vb, Fb), both given with their search trees (ta built
// from (Va, Fa), tb from (Vb, Fb)), so that a reference surface is built once for many comparisons.
double hausdorff_distance(const Positions& Va, const Faces& Fa, const TriangleSurface& ta, const Positions& Vb,
                          const Faces& Fb, const TriangleSurface& tb);
// The same, building both trees.
double hausdorff_distance(const Positions& Va, const Faces& Fa, const Positions& Vb, const Faces& Fb);

// ---- seam jitter of time subsets ----------------------------------------------------------------------
//
// Per-vertex acceleration a(t) = x(t+1) - 2 x(t) + x(t-1), in metres per frame^2 (a second difference
// of positions, not divided by h^2: multiply by 1 / h^2 for m/s^2). Run `k` (K time subsets) against
// run `one` (K = 1) on the same level and mesh:
//   d(t) = max over selected vertices i of | a_k,i(t) - a_one,i(t) |      (m per frame^2)

// d(t) from the three frames t-1, t, t+1 of both runs (each (n, 3), m, same mesh); mask: n flags.
// 0 when no vertex is selected. Throws std::invalid_argument when the sizes differ.
double acceleration_difference(const Positions& k_prev, const Positions& k_now, const Positions& k_next,
                               const Positions& one_prev, const Positions& one_now, const Positions& one_next,
                               const std::vector<char>& mask);

// Seam jitter from d(t) (one entry per frame t = 0..N, NaN where d is not defined: frame 0 and N,
// or a frame either run lacks) and the seam frames T (a later subset (T, b] starts from frame T):
//   seams         T and T + 1 for every T, in increasing order, without repeats;
//   seam_d        d at each of them (m per frame^2; NaN where not defined);
//   max_seam_d    max over seam_d (NaN if none is defined);
//   median_other  the median of d over the other frames after the first seam where it is defined
//                 (mean of the two middle values for an even count; NaN if there is none). Frames
//                 before the first seam belong to the first subset, which is the K = 1 run's own
//                 task: d is 0 there by construction, so they are not the background;
//   ratio         max_seam_d / median_other: +inf when median_other is 0 and max_seam_d > 0, NaN when
//                 both are 0 or either is NaN (callers report the absolute values then).
// Throws std::invalid_argument for a seam outside [0, d.size()).
struct SeamJitter {
  std::vector<int> seams;
  std::vector<double> seam_d;
  double max_seam_d = 0.0;
  double median_other = 0.0;
  double ratio = 0.0;
};
SeamJitter seam_jitter(const std::vector<double>& d, const std::vector<int>& seam_starts);

// ---- seam pop: one run's own motion at a seam ---------------------------------------------------------
//
// Whether a seam shows as a jolt in one run, judged against that run's own motion around it (no
// second run needed; the K = 1 run's pop at the same seams is the baseline that tells a seam's jolt
// from the scene's own, e.g. an impact that happens to fall on a seam; pd compare calls a seam visible
// when its pop is > 0.5 and > 1.5 times the K = 1 run's, docs/progressive.md):
//   m(t) = max over selected vertices i of | x_i(t+1) - 2 x_i(t) + x_i(t-1) |     (m per frame^2)
// the per-frame maximum second difference of positions (Euclidean norm of the 3-vector, not divided
// by h^2: multiply by 1 / h^2 for m/s^2), defined where frames t-1, t and t+1 are all stored.

// m(t) from frames t-1, t, t+1 of one run (each (n, 3), m, same mesh); mask: n flags. 0 when no
// vertex is selected. Throws std::invalid_argument when the sizes differ.
double max_second_difference(const Positions& prev, const Positions& now, const Positions& next,
                             const std::vector<char>& mask);

// The pop of each seam s (a later subset (s, b] starts from frame s; s = 0 is the level's start, whose
// first solved frames are 1 and 2) from m (one entry per frame t = 0..N, NaN where m is not defined:
// always at 0 and N):
//   peak        max of m(t) over t in {s, s + 1} where defined (m per frame^2; NaN if neither is);
//   background  the nearest-rank 95th percentile (sorted[ceil(0.95 n) - 1], as distance_stats) of the
//               n = background_frames values m(t), t in [s - 20, s + 21] (20 frames either side of
//               the pair {s, s + 1}), where m is defined, leaving out t in {s', s' + 1} for every
//               seam s' of the list: no seam's own jolt is part of any seam's background (m per
//               frame^2; NaN when no frame is left). With 20 or more values one stray frame in the
//               window does not set the background alone; with fewer it is their max;
//   pop         peak / background: +inf when background is 0 and peak > 0, NaN when both are 0 or
//               either is NaN (callers report peak and background then).
// One entry per seam in increasing order, repeats merged. Throws std::invalid_argument for a seam
// outside [0, m.size() - 1) (s + 1 must be a frame).
struct SeamPop {
  int seam = 0;
  double peak = 0.0;
  double background = 0.0;
  double pop = 0.0;
  int background_frames = 0;
};
std::vector<SeamPop> seam_pops(const std::vector<double>& m, const std::vector<int>& seams);

}  // namespace pd
