// Contact primitives of part of a mesh (hierarchy/contact_submesh.h).
#include "hierarchy/contact_submesh.h"

#include <gtest/gtest.h>

#include "geometry/shapes.h"
#include "geometry/topology.h"

namespace pd {
namespace {

TEST(ContactSubmesh, FacesEdgesAndObjectsOfASubsetMatchTheSubsetAsAMeshOfItsOwn) {
  const TriMesh sheet = make_rectangle(1.0, 1.0, 4, 4);  // 25 vertices, 32 faces
  std::vector<int> vertex_object(25, 0);
  for (int v = 10; v < 25; ++v) vertex_object[static_cast<std::size_t>(v)] = 1;
  // Every third face.
  Faces F(11, 3);
  for (int k = 0; k < 11; ++k) F.row(k) = sheet.F.row(3 * k);
  const ContactSubmesh s = contact_submesh(F, vertex_object, {1, 0});

  ASSERT_TRUE(std::is_sorted(s.vertices.begin(), s.vertices.end()));
  for (int f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(s.vertices[static_cast<std::size_t>(s.prims.faces(f, c))], F(f, c));
      EXPECT_EQ(s.local(F(f, c)), s.prims.faces(f, c));
    }
  TriMesh own;
  own.V = gather_rows(sheet.V, s.vertices);
  own.F = s.prims.faces;
  EXPECT_EQ(s.prims.edges, build_topology(own).edges);
  for (std::size_t k = 0; k < s.vertices.size(); ++k)
    EXPECT_EQ(s.prims.vertex_object[k], vertex_object[static_cast<std::size_t>(s.vertices[k])]);
  EXPECT_EQ(s.prims.object_self_contact, (std::vector<char>{1, 0}));

  // Without objects every vertex is object 0.
  const ContactSubmesh one = contact_submesh(F, {}, {1});
  EXPECT_EQ(one.prims.vertex_object, std::vector<int>(one.vertices.size(), 0));
}

TEST(ContactSubmesh, ScatterUndoesGather) {
  const TriMesh sheet = make_rectangle(1.0, 1.0, 3, 3);
  const std::vector<int> ids = {2, 7, 11, 5};
  const Positions rows = gather_rows(sheet.V, ids);
  ASSERT_EQ(rows.rows(), 4);
  Positions x = Positions::Zero(sheet.V.rows(), 3);
  scatter_rows(rows, ids, x);
  for (int i : ids) EXPECT_TRUE((x.row(i).array() == sheet.V.row(i).array()).all());
  EXPECT_TRUE(x.row(0).isZero(0.0));
}

}  // namespace
}  // namespace pd
