#pragma once
// Decimation of a fine triangle mesh into coarser levels by quadric-error edge collapse, recording
// every collapse so that it can be undone as a vertex split (PSQ section 4.1; the records feed the
// intrinsic prolongation, PSQ 4.2-4.3 / Liu et al. 2021, and safe upsampling, PSQ 4.4).
//
// Method. CGAL's Surface_mesh_simplification::edge_collapse (CGAL 5.5) with the Garland-Heckbert
// *probabilistic plane* quadrics of Trettner and Kobbelt 2020
// (GarlandHeckbert_probabilistic_plane_policies; CGAL 5.5 also has probabilistic triangle quadrics;
// the plane_and_line policies only appeared in 5.6). Cost: the quadric error at the placement;
// placement: the quadric's minimiser, or the fixed vertex's own position when one end of the edge is
// fixed (below). The normal and position variances are given in units of the mesh (see
// DecimationSettings), not CGAL's defaults, so the result does not depend on the unit of length.
// All levels come from ONE run of collapses: level l is the state after the collapses that brought
// the vertex count down to its target, so quadrics accumulate across levels (as in PSQ 4.1). The
// exception is prescribed vertex sets (LevelSettings::kept_vertices, e.g. sub-grids): there each
// level is its own run from the next finer one, collapsing free vertices into kept ones only
// (detail::CollapseRule::kOntoLocked), so no vertex of any level moves from its finest position.
//
// Rules every collapse obeys (the rest of the hierarchy may rely on them):
// - Locked vertices (pinned regions, given by the caller) are never removed and never moved.
// - Boundary vertices are never moved; with keep_boundary (the default) never removed either, so every
//   level has exactly the finest mesh's boundary polygon(s); without it, only vertices on straight
//   stretches of boundary may go (see DecimationSettings::keep_boundary), so the shape stays exact.
// - An edge with one immobile end (locked or boundary) collapses onto that end: the merged vertex
//   keeps that end's id and position. An edge with two immobile ends never collapses (except the
//   straight-boundary case).
// - The mesh stays an oriented 2-manifold (CGAL's link condition), faces keep the fine mesh's
//   orientation.
// - No surviving triangle turns its normal by more than max_normal_change_degrees in one collapse,
//   and none comes out with quality below min(min_triangle_quality, the worst quality among the
//   triangles around the edge before the collapse), nor with (near-)zero area
//   (area < 1e-10 * bbox_diagonal^2, 100x validate_mesh's threshold). Quality is 4 sqrt(3) area / (sum of
//   squared edge lengths): 1 for equilateral, 0 for degenerate.
// Deterministic: same mesh and settings -> the same records and meshes, bit for bit (no containers
// keyed by pointers; CGAL's queue works on Surface_mesh indices).
// Cost (measured, Release, one core): 90K-vertex sheet to 3 coarser levels 3.8 s, 41K-vertex sphere
// 0.9 s, 6.4K sheet 0.16 s.
//
// Ids. A collapse merges two vertices into one; the merged vertex carries one of the two ids (the
// "kept" id) and the other id ("removed") disappears. Vertices never get new ids: every id in a
// record is a vertex id of the mesh the decimation started from (for build_levels: of the next finer
// level, see Level).
#include <array>
#include <vector>

#include "geometry/mesh.h"

namespace pd {

// A triangle as three vertex ids, counter-clockwise (the fine mesh's orientation), rotated so that the
// smallest id comes first. Two triangles are the same face exactly when their Tri are equal.
using Tri = std::array<int, 3>;

// One edge collapse, removed -> kept, and how to undo it.
//
// Before the collapse the mesh has vertices `removed` at removed_position and `kept` at
// kept_position_before, joined by an edge; after it, `removed` is gone and `kept` sits at
// kept_position_after. These are the positions at the moment of the collapse: a vertex moves only
// when it is the kept vertex of a collapse, so replaying the records from the start mesh reproduces
// every intermediate state exactly.
//
// faces_before: every face incident to `removed` or `kept` just before the collapse (the one-ring
//   patch of the edge; the one or two faces containing both are included). Sorted, no duplicates.
// faces_after: every face incident to `kept` just after it. Sorted.
//   Always: faces_after == faces_before without the faces containing both vertices, with `removed`
//   replaced by `kept` (re-rotated, sorted). The two patches have the same outer vertices (the ids in
//   faces_before other than `removed` and `kept`): for an interior edge they form one closed cycle
//   (the link of the edge) bounding both patches, which is what a joint flattening for successive
//   self-parameterization (Liu et al. 2021) needs; an edge with an end on the mesh boundary has an
//   open link and the patches also share boundary edges of the mesh.
// Undoing the collapse as a vertex split: in the mesh after it, replace faces_after by faces_before
// and put `removed` back (at removed_position, or wherever the split chooses); nothing else in the
// mesh changes. Undo the records of a decimation last-first to get back its start mesh exactly. Two
// consecutive splits whose faces_before use disjoint vertex sets commute (neither touches the
// other's faces or vertices); that is the freedom the colour batches of PSQ Algorithms 6-7 use.
// Positions: a level's rest positions are the state after its last collapse, so replaying a level's
// records backwards from its rest mesh also gives the finer level's rest positions bit for bit.
struct Collapse {
  int removed = -1;
  int kept = -1;
  Vec3 removed_position = Vec3::Zero();
  Vec3 kept_position_before = Vec3::Zero();
  Vec3 kept_position_after = Vec3::Zero();
  std::vector<Tri> faces_before;
  std::vector<Tri> faces_after;
};

struct DecimationSettings {
  // Boundary vertices never move. With keep_boundary they are never removed either, so every level
  // has the finest boundary polygon vertex for vertex. Without it, an unlocked boundary vertex may be
  // removed by collapsing one of its two boundary edges into the neighbour at the other end (which
  // stays put), only where the boundary is straight (the vertex collinear with its two boundary
  // neighbours within 1e-3 radians): the boundary keeps its exact shape (corners and curved stretches
  // stay) while straight edges coarsen. Sheets need that at the default ratio: their boundary grows
  // like sqrt(n), e.g. a 300x300 sheet has 1196 boundary vertices against a coarsest target of 1406.
  bool keep_boundary = true;
  // Largest change of a surviving triangle's normal in one collapse.
  double max_normal_change_degrees = 45.0;
  // See "Rules" above; 0 disables the quality test (the zero-area test stays).
  double min_triangle_quality = 0.2;
  // Probabilistic quadric variances (Trettner and Kobbelt 2020): normal_variance (dimensionless)
  // regularises each face plane so that flat regions prefer short moves (even triangles);
  // position_variance is in units of the finest mesh's mean edge length squared (it adds a constant
  // per accumulated face, so vertices that already stand for much area collapse later). Defaults from
  // a small sweep on sheets and spheres (normal 0.005-0.2, position 0-1), over which the worst and
  // mean triangle quality of the levels changed little. CGAL's own default (0.05 * mean edge length,
  // in the mesh's units) would make the result depend on the unit of length.
  double normal_variance = 0.05;
  double position_variance = 0.01;
  // A level whose target cannot be reached exactly (no valid collapse left) is accepted when it ends
  // within this fraction above the target; otherwise it is an InputError.
  double count_tolerance = 0.02;
};

// The result of decimating one mesh (the "fine" mesh) to a coarser one.
struct Decimation {
  TriMesh coarse;                     // vertices in increasing fine id; faces sorted as Tri
  std::vector<int> coarse_to_fine;    // coarse vertex id -> fine vertex id (increasing)
  std::vector<int> fine_to_coarse;    // fine vertex id -> coarse vertex id, -1 for removed vertices
  std::vector<Collapse> collapses;    // in the order performed; fine ids
};

// Decimates `fine` to `target_vertices` vertices, never removing or moving the vertices in `locked`
// (fine ids; duplicates allowed). Throws InputError naming the level ("level 1 (finest)" for the
// input mesh, "level 0 (coarsest)" for the target) and the counts when the mesh is invalid (validate_mesh's checks, plus non-manifold vertices), a locked id does not exist, or the
// target cannot be reached (see build_levels).
Decimation decimate(const TriMesh& fine, int target_vertices, const std::vector<int>& locked = {},
                    const DecimationSettings& settings = {});

struct LevelSettings {
  // Vertex counts of the coarser levels, from the finest's next (level L-1) down to the coarsest
  // (level 0), strictly decreasing and below the finest count, e.g. {2000, 500, 125}. When empty,
  // `coarser_levels` levels are made with ratio `ratio`: level l gets round(n_L / ratio^(L-l)).
  std::vector<int> target_vertex_counts;
  double ratio = 4.0;
  int coarser_levels = 3;
  // Finest-mesh vertex ids that no level may remove or move (pinned regions).
  std::vector<int> locked_vertices;
  // Prescribed vertex sets (e.g. grid_level_vertices, for meshes with a symmetry the quadric order
  // would break). When non-empty: one list per entry of target_vertex_counts (level L-1 first), finest
  // ids, each a subset of the previous list. Level l keeps exactly its list plus the fixed vertices
  // (locked; boundary per keep_boundary), which must number exactly its target; its listed vertices
  // never move while it is decimated from level l+1, in a run of its own (quadrics do not carry over
  // from the finer level's run, since the next level's free vertices would then be fixed too early).
  std::vector<std::vector<int>> kept_vertices;
  DecimationSettings decimation;
};

// One level of the hierarchy. Level l has its own compact vertex ids 0..n_l-1, in increasing order
// of the finest mesh's ids.
struct Level {
  TriMesh mesh;                        // rest mesh (positions from the decimation); faces sorted as Tri
                                       // (except at L, which is the input as given)
  std::vector<int> to_finest;          // level vertex id -> finest mesh vertex id (identity at L)
  // Relation to the next finer level l+1; all empty for the finest level L.
  std::vector<int> coarse_to_fine;     // this level's id -> level l+1's id
  std::vector<int> fine_to_coarse;     // level l+1's id -> this level's id, or -1 if removed
  std::vector<Collapse> collapses;     // from level l+1's mesh to this one, in order; level l+1 ids
};

// Which vertices of `mesh` no level may remove (by id): the `locked` ones, and the boundary vertices
// when keep_boundary, or only those where the boundary turns (corners, curved stretches) otherwise.
// Requires a mesh that passed validate_mesh and locked ids in range.
std::vector<char> fixed_vertices(const TriMesh& mesh, const std::vector<int>& locked, bool keep_boundary);

// levels[0] is the coarsest, levels[L] = levels.back() the finest (a copy of `finest` with its face
// order unchanged, identity to_finest, no collapses). Replaying level l's collapses backwards from level l's mesh gives level l+1's mesh
// (faces as sets of Tri, and positions) exactly.
// Throws InputError "level <l> ...: <problem>" (the caller prefixes the object's name) when the finest
// mesh is invalid, a setting is invalid, or a level's target cannot be reached: fewer than 4 vertices
// (3 for a mesh with boundary), fewer than the fixed (boundary and locked) vertices, or decimation
// stopping above target * (1 + count_tolerance) because no valid collapse is left.
std::vector<Level> build_levels(const TriMesh& finest, const LevelSettings& settings = {});

// Faces of a mesh as sorted Tri (each rotated smallest id first).
std::vector<Tri> sorted_tris(const Faces& F);
// Rotates (a, b, c) so that the smallest id comes first, keeping the orientation.
Tri canonical_tri(int a, int b, int c);

}  // namespace pd
