#pragma once
// Edge and hinge connectivity of triangle meshes, and the validity checks every simulated mesh passes.
#include <array>
#include <string>
#include <vector>

#include "geometry/mesh.h"

namespace pd {

// An interior edge with its two triangles, as bending needs it:
//   v[0], v[1]: the edge's vertices; v[2]: the vertex opposite the edge in the triangle where the
//   edge runs v[0] -> v[1] (counter-clockwise); v[3]: the opposite vertex in the other triangle.
struct Hinge {
  std::array<int, 4> v;
};

struct Topology {
  std::vector<std::array<int, 2>> edges;      // unique undirected edges, v0 < v1, sorted
  std::vector<int> edge_face_count;           // faces per edge (1 = boundary, 2 = interior)
  std::vector<Hinge> hinges;                  // one per interior edge, in the order of `edges`
  std::vector<char> boundary_vertex;          // 1 if the vertex lies on a boundary edge
  bool closed() const;                        // no boundary edges
};

Topology build_topology(const TriMesh& mesh);

// Checks what the simulator relies on and throws InputError("<what>: <problem>") otherwise, with
// `what` naming the mesh (e.g. "scene.json: objects[1].mesh"):
//   faces index existing vertices; no triangle repeats a vertex; no triangle has (near-)zero area
//   (area < 1e-12 * bbox_diagonal^2); every edge has at most two faces (manifold); faces sharing an
//   edge traverse it in opposite directions (consistent orientation); no vertex is unused; all
//   coordinates finite.
void validate_mesh(const TriMesh& mesh, const std::string& what);

// A posed shape of a valid rest mesh (the same faces, other positions): every face keeps an area of
// at least 1e-12 times the rest mesh's bounding-box diagonal squared, the threshold validate_mesh
// applies to the rest shape, so that no start state crushes a triangle (its membrane energy would be
// infinite and the first step would fail). Throws InputError "<what>: face f has zero area in the
// posed shape ..." naming the first such face.
void validate_pose(const TriMesh& rest, const Positions& posed, const std::string& what);

}  // namespace pd
