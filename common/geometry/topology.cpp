#include "geometry/topology.h"

#include <cstdio>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>

#include "util/input_error.h"

namespace pd {
namespace {

// The zero-area threshold of a mesh: 1e-12 of its bounding-box diagonal squared, so that the check
// means the same for a millimetre patch and a ten-metre sail.
double zero_area_threshold(const Positions& V) {
  const double diag2 = V.rows() > 0 ? (V.colwise().maxCoeff() - V.colwise().minCoeff()).squaredNorm() : 0.0;
  return 1e-12 * diag2;
}

struct ZeroAreaFace {
  int face;
  double area;  // m^2
};

// The first face of F whose area at positions X is below min_area, or exactly 0 (for when every
// vertex coincides and the threshold itself is 0).
std::optional<ZeroAreaFace> first_zero_area_face(const Positions& X, const Faces& F, double min_area) {
  for (int f = 0; f < F.rows(); ++f) {
    const Vec3 a = X.row(F(f, 0)).transpose(), b = X.row(F(f, 1)).transpose(), c = X.row(F(f, 2)).transpose();
    const double area = 0.5 * (b - a).cross(c - a).norm();
    if (!(area >= min_area) || area == 0.0) return ZeroAreaFace{f, area};
  }
  return std::nullopt;
}

// One side of an edge as seen from one face: the edge from F(face, k) to F(face, (k + 1) % 3).
// Sorting these by (undirected edge, face) groups each edge's faces together in O(m log m), with the
// lower-indexed face first; that is all the connectivity needs, and no hash map is involved, so the
// result is deterministic.
struct HalfEdge {
  std::uint64_t key;  // lo << 32 | hi, lo < hi the undirected edge's vertices
  int face;
  int k;              // local corner the edge starts at
  bool forward;       // true if the face runs lo -> hi
  int lo() const { return static_cast<int>(key >> 32); }
  int hi() const { return static_cast<int>(key & 0xffffffffu); }
};

// Requires every index to be in [0, n); callers check that first.
std::vector<HalfEdge> sorted_half_edges(const Faces& F) {
  std::vector<HalfEdge> half;
  half.reserve(3 * static_cast<std::size_t>(F.rows()));
  for (int f = 0; f < static_cast<int>(F.rows()); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      const auto lo = static_cast<std::uint64_t>(std::min(a, b)), hi = static_cast<std::uint64_t>(std::max(a, b));
      half.push_back({lo << 32 | hi, f, k, a < b});
    }
  std::sort(half.begin(), half.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return x.key != y.key ? x.key < y.key : (x.face != y.face ? x.face < y.face : x.k < y.k);
  });
  return half;
}

// Calls visit(begin, end) for each run of half-edges sharing one undirected edge.
template <class Visit>
void for_each_edge(const std::vector<HalfEdge>& half, Visit visit) {
  for (std::size_t i = 0; i < half.size();) {
    std::size_t j = i + 1;
    while (j < half.size() && half[j].key == half[i].key) ++j;
    visit(i, j);
    i = j;
  }
}

// Index of the first face corner outside [0, n), or -1.
long first_bad_corner(const TriMesh& mesh) {
  const int n = mesh.num_vertices();
  for (Eigen::Index c = 0; c < mesh.F.size(); ++c) {
    const int v = mesh.F.data()[c];
    if (v < 0 || v >= n) return static_cast<long>(c);
  }
  return -1;
}

std::string edge_name(const HalfEdge& h) {
  return "edge between vertices " + std::to_string(h.lo()) + " and " + std::to_string(h.hi());
}

}  // namespace

bool Topology::closed() const {
  return std::none_of(edge_face_count.begin(), edge_face_count.end(), [](int c) { return c == 1; });
}

Topology build_topology(const TriMesh& mesh) {
  // Out-of-range indices would corrupt memory below; validate_mesh reports them properly to users,
  // here they are a programming error.
  if (first_bad_corner(mesh) >= 0) throw std::invalid_argument("build_topology: face index out of range");
  const Faces& F = mesh.F;
  const std::vector<HalfEdge> half = sorted_half_edges(F);

  Topology topo;
  topo.boundary_vertex.assign(static_cast<std::size_t>(mesh.num_vertices()), 0);
  topo.edges.reserve(half.size() / 2 + 1);
  topo.edge_face_count.reserve(half.size() / 2 + 1);
  for_each_edge(half, [&](std::size_t begin, std::size_t end) {
    const HalfEdge& first = half[begin];
    const int count = static_cast<int>(end - begin);
    topo.edges.push_back({first.lo(), first.hi()});
    topo.edge_face_count.push_back(count);
    if (count == 1) {
      topo.boundary_vertex[first.lo()] = 1;
      topo.boundary_vertex[first.hi()] = 1;
    } else if (count == 2) {
      // The lower-indexed face is the "first" triangle: the edge is taken in its counter-clockwise
      // direction there, so (v0, v1, v2) is that face up to rotation and, for a consistently
      // oriented mesh, (v1, v0, v3) is the other.
      const HalfEdge& second = half[begin + 1];
      Hinge h;
      h.v = {F(first.face, first.k), F(first.face, (first.k + 1) % 3), F(first.face, (first.k + 2) % 3),
             F(second.face, (second.k + 2) % 3)};
      topo.hinges.push_back(h);
    }
    // Edges with 3 or more faces (non-manifold) get no hinge; validate_mesh rejects such meshes.
  });
  return topo;
}

void validate_mesh(const TriMesh& mesh, const std::string& what) {
  auto fail = [&what](const std::string& problem) { throw InputError(what + ": " + problem); };
  const Positions& V = mesh.V;
  const Faces& F = mesh.F;
  const int n = mesh.num_vertices(), m = mesh.num_faces();
  if (m == 0) fail("mesh has no faces");

  // Finite coordinates first: the area test below would be meaningless with NaN or inf.
  for (int i = 0; i < n; ++i)
    if (!V.row(i).allFinite()) fail("vertex " + std::to_string(i) + " has a non-finite coordinate");

  const long bad = first_bad_corner(mesh);
  if (bad >= 0)
    fail("face " + std::to_string(bad / 3) + " references vertex " + std::to_string(F.data()[bad]) +
         ", which does not exist (the mesh has " + std::to_string(n) + " vertices)");

  for (int f = 0; f < m; ++f) {
    const int a = F(f, 0), b = F(f, 1), c = F(f, 2);
    if (a == b || a == c) fail("face " + std::to_string(f) + " repeats vertex " + std::to_string(a));
    if (b == c) fail("face " + std::to_string(f) + " repeats vertex " + std::to_string(b));
  }

  if (const std::optional<ZeroAreaFace> z = first_zero_area_face(V, F, zero_area_threshold(V)))
    fail("face " + std::to_string(z->face) + " has zero area");

  const std::vector<HalfEdge> half = sorted_half_edges(F);
  for_each_edge(half, [&](std::size_t begin, std::size_t end) {
    if (end - begin <= 2) return;
    std::string faces;
    for (std::size_t i = begin; i < end; ++i) faces += (i > begin ? ", " : "") + std::to_string(half[i].face);
    fail(edge_name(half[begin]) + " is shared by " + std::to_string(end - begin) + " faces (" + faces +
         "); a manifold edge has at most 2");
  });
  // Two faces on one edge agree in orientation exactly when they traverse it in opposite directions.
  for_each_edge(half, [&](std::size_t begin, std::size_t end) {
    if (end - begin == 2 && half[begin].forward == half[begin + 1].forward)
      fail("faces " + std::to_string(half[begin].face) + " and " + std::to_string(half[begin + 1].face) +
           " traverse the " + edge_name(half[begin]) + " in the same direction (inconsistent orientation)");
  });

  std::vector<char> used(static_cast<std::size_t>(n), 0);
  for (Eigen::Index c = 0; c < F.size(); ++c) used[F.data()[c]] = 1;
  for (int i = 0; i < n; ++i)
    if (!used[i]) fail("vertex " + std::to_string(i) + " is not used by any face");
}

void validate_pose(const TriMesh& rest, const Positions& posed, const std::string& what) {
  if (const std::optional<ZeroAreaFace> z = first_zero_area_face(posed, rest.F, zero_area_threshold(rest.V))) {
    char shown[64];
    std::snprintf(shown, sizeof shown, "%.3g", z->area);
    throw InputError(what + ": face " + std::to_string(z->face) + " has zero area in the posed shape (" + shown +
                     " m^2; the rest mesh needs at least 1e-12 of its bounding-box diagonal squared)");
  }
}

}  // namespace pd
