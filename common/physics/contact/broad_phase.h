#pragma once
// Broad phase for IPC contact: the point-triangle and edge-edge pairs that may come within the
// contact distance, found with a spatial hash on a uniform grid.
//
// Candidate rule (the contract; tests compare against a brute force over all pairs with exactly it):
//   Each primitive's axis-aligned box is the min/max of its vertices' coordinates (for swept queries:
//   of the vertices at the start AND the end of the step), grown on every side by r / 2:
//     lo_k = min_k - 0.5 * r,  hi_k = max_k + 0.5 * r        (metres, r = the inflation radius)
//   Two primitives are a candidate pair when their boxes overlap as closed boxes (touching counts),
//   so every pair within distance r of each other (anywhere along the straight-line motion, for swept
//   queries) is a candidate, up to floating-point rounding of the grown bounds.
//   Excluded: pairs that share a vertex (a vertex of its own face, edges with a common endpoint: IPC
//   leaves adjacent primitives to the elastic energies), and pairs within one object whose
//   self-contact flag is off. Pairs between different objects are always kept.
//
// Output: pairs sorted lexicographically and unique; the same input gives the same output on every
// run and machine (no pointer- or hash-iteration-dependent order reaches the result).
//
// Cell size and complexity: see broad_phase.cpp (in short: cell = mean edge length + r (+ mean
// displacement for swept queries), so a typical box covers at most 2 cells per axis and a cell holds
// O(1) primitives of a cloth-like surface; one query is O(n + m + E + K) time and memory for n
// vertices, m faces, E edges and K candidate pairs, plus O(L * (n + m + E)) for the L primitives
// whose box covers more than 64 cells (e.g. a coarse ground plane), which are tested against
// everything directly). Measured on a 317 x 317 vertex sheet (100,489 vertices, ~640K pairs at r = 1 mm, -O2,
// one core of a shared VM): 75-140 ms per query when the allocator reuses memory, 0.2-0.3 s when
// every query page-faults its ~60 MB of fresh working memory.
#include <array>
#include <vector>

#include "geometry/mesh.h"

namespace pd {

// The contact primitives of a whole scene, in global indices (objects stacked into one vertex array).
struct ContactPrimitives {
  Faces faces;                                // (m, 3) vertex indices: point-triangle targets
  std::vector<std::array<int, 2>> edges;      // unique undirected edges (e.g. Topology::edges, offset)
  std::vector<int> vertex_object;             // object id of each vertex, in [0, #objects)
  std::vector<char> object_self_contact;      // per object: 1 if its primitives may contact each other
};

struct CandidatePairs {
  std::vector<std::array<int, 2>> point_triangle;  // (vertex, face), sorted, unique
  std::vector<std::array<int, 2>> edge_edge;       // (edge a, edge b) with a < b, sorted, unique
  bool operator==(const CandidatePairs& o) const {
    return point_triangle == o.point_triangle && edge_edge == o.edge_edge;
  }
};

// Pairs whose boxes at positions V (n, 3) overlap; r = inflation radius in metres (dhat plus
// thickness), r >= 0. Throws std::invalid_argument on inconsistent input (sizes, indices out of
// range, a face or edge spanning two objects, non-finite positions or r).
CandidatePairs find_candidates(const ContactPrimitives& prims, const Positions& V, double r);

// Same for the motion V0 -> V1 (both (n, 3)), for continuous collision detection: boxes bound each
// primitive at the start and end of the step, hence along the whole linear motion.
CandidatePairs find_swept_candidates(const ContactPrimitives& prims, const Positions& V0,
                                     const Positions& V1, double r);

// Edge-triangle pairs (edge, face) whose boxes at positions V overlap, with the same box rule and
// radius r as above, for the start-state intersection check (start_check.h): an edge that pierces a
// triangle's interior far from its vertices and edges is close to no point-triangle or edge-edge
// pair, so it needs pairs of its own. Excluded: an edge sharing a vertex with the face (including an
// edge of the face itself), and pairs within one object whose self-contact flag is off. Output
// sorted lexicographically by (edge, face), unique, deterministic; input checks as find_candidates.
std::vector<std::array<int, 2>> find_edge_face_candidates(const ContactPrimitives& prims, const Positions& V,
                                                          double r);

}  // namespace pd
