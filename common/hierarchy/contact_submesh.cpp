#include "hierarchy/contact_submesh.h"

#include <algorithm>

namespace pd {

int ContactSubmesh::local(int full_id) const {
  return static_cast<int>(std::lower_bound(vertices.begin(), vertices.end(), full_id) - vertices.begin());
}

ContactSubmesh contact_submesh(const Faces& faces, const std::vector<int>& vertex_object,
                               const std::vector<char>& object_self_contact) {
  ContactSubmesh s;
  s.vertices.assign(faces.data(), faces.data() + faces.size());
  std::sort(s.vertices.begin(), s.vertices.end());
  s.vertices.erase(std::unique(s.vertices.begin(), s.vertices.end()), s.vertices.end());
  s.prims.faces.resize(faces.rows(), 3);
  std::vector<std::array<int, 2>> edges;
  edges.reserve(3 * static_cast<std::size_t>(faces.rows()));
  for (int f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = s.local(faces(f, k)), b = s.local(faces(f, (k + 1) % 3));
      s.prims.faces(f, k) = a;
      edges.push_back({std::min(a, b), std::max(a, b)});
    }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  s.prims.edges = std::move(edges);
  s.prims.vertex_object.assign(s.vertices.size(), 0);
  if (!vertex_object.empty())
    for (std::size_t k = 0; k < s.vertices.size(); ++k)
      s.prims.vertex_object[k] = vertex_object[static_cast<std::size_t>(s.vertices[k])];
  s.prims.object_self_contact = object_self_contact;
  return s;
}

Positions gather_rows(const Positions& x, const std::vector<int>& ids) {
  Positions out(static_cast<Eigen::Index>(ids.size()), 3);
  for (std::size_t k = 0; k < ids.size(); ++k) out.row(static_cast<Eigen::Index>(k)) = x.row(ids[k]);
  return out;
}

void scatter_rows(const Positions& rows, const std::vector<int>& ids, Positions& x) {
  for (std::size_t k = 0; k < ids.size(); ++k) x.row(ids[k]) = rows.row(static_cast<Eigen::Index>(k));
}

}  // namespace pd
