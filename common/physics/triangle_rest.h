#pragma once
// Per-triangle rest data for the triangle energies (membrane, strain limit): one place that checks
// the faces against the rest positions and turns a zero-area rest triangle into a clear error.
#include <algorithm>
#include <array>
#include <stdexcept>
#include <string>
#include <vector>

#include "geometry/mesh.h"

namespace pd {

// For each face f (vertex indices into the rows of `rest`, metres): faces_out gets its vertices and
// rest_out gets make_rest(X0, X1, X2). Returns 3 * (largest vertex index + 1), the least length of
// a stacked x the term can read. Throws std::invalid_argument "<term>: face f ..." for an index
// outside `rest` or when make_rest throws std::invalid_argument (zero rest area).
template <class Rest, class MakeRest>
int build_triangle_rest(const char* term, const Faces& faces, const Positions& rest, MakeRest make_rest,
                        std::vector<std::array<int, 3>>& faces_out, std::vector<Rest>& rest_out) {
  const int n = static_cast<int>(faces.rows());
  faces_out.reserve(n);
  rest_out.reserve(n);
  int max_vertex = -1;
  for (int f = 0; f < n; ++f) {
    const std::array<int, 3> v{faces(f, 0), faces(f, 1), faces(f, 2)};
    for (int k = 0; k < 3; ++k) {
      if (v[k] < 0 || v[k] >= rest.rows())
        throw std::invalid_argument(std::string(term) + ": face " + std::to_string(f) +
                                    " has a vertex index outside the rest positions");
      max_vertex = std::max(max_vertex, v[k]);
    }
    try {
      rest_out.push_back(make_rest(rest.row(v[0]).transpose(), rest.row(v[1]).transpose(), rest.row(v[2]).transpose()));
    } catch (const std::invalid_argument&) {
      throw std::invalid_argument(std::string(term) + ": rest triangle of face " + std::to_string(f) + " has zero area");
    }
    faces_out.push_back(v);
  }
  return 3 * (max_vertex + 1);
}

}  // namespace pd
