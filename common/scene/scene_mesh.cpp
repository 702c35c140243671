#include "scene/scene_mesh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <vector>

#include "geometry/obj_io.h"
#include "scene/scene_file.h"
#include "util/input_error.h"
#include "util/message_text.h"

namespace pd {
namespace {

namespace fs = std::filesystem;
using scene_json::JsonNode;
namespace limits = scene_json::limits;

// Checked with the counts each generator documents, before it allocates anything.
void check_vertex_budget(const JsonNode& node, long long vertices, long long faces, const MeshBudget& budget) {
  if (vertices > kMaxSceneMeshVertices) {
    node.fail_got("gives " + std::to_string(vertices) + " vertices, more than the limit of " +
                  std::to_string(kMaxSceneMeshVertices) + " per object");
  }
  if (budget.vertices_before + vertices > kMaxSceneVertices) {
    node.fail_got("gives " + std::to_string(vertices) + " vertices, which brings the scene to " +
                  std::to_string(budget.vertices_before + vertices) + ", more than the limit of " +
                  std::to_string(kMaxSceneVertices) + " for all objects together");
  }
  if (faces > kMaxSceneMeshFaces) {
    node.fail_got("gives " + std::to_string(faces) + " faces, more than the limit of " +
                  std::to_string(kMaxSceneMeshFaces) + " per object");
  }
}


// Runs a mesh generator; anything it throws becomes an InputError at the mesh's key path.
template <class Make>
auto generate(const JsonNode& mesh, Make make) -> decltype(make()) {
  try {
    return make();
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    mesh.fail(std::string("could not build the mesh: ") + e.what());
  }
}

}  // namespace

std::string resolve_scene_path(const std::string& base_dir, const std::string& file) {
  fs::path p(file);
  if (p.is_relative() && !base_dir.empty()) p = fs::path(base_dir) / p;
  return p.lexically_normal().string();
}

TriMesh read_obj_at(const JsonNode& path_node, const std::string& base_dir) {
  std::string file = path_node.string(scene_json::kMaxPathBytes);
  if (file.empty()) path_node.fail_got("must be a path to an OBJ file");
  ObjLimits obj_limits;
  obj_limits.max_vertices = kMaxSceneMeshVertices;
  obj_limits.max_faces = kMaxSceneMeshFaces;
  try {
    return read_obj(resolve_scene_path(base_dir, file), obj_limits);
  } catch (const InputError& e) {
    path_node.fail(e.what());
  }
}

// The lattice of a generated rectangle or box (read_mesh has checked its keys), from its vertices
// before the object's transform; nothing for other mesh types.
std::optional<GridLattice> generated_lattice(const JsonNode& mesh_node, const TriMesh& mesh) {
  const std::string type = mesh_node.required("type").string(64);
  std::array<int, 3> cells{0, 0, 0};
  if (type == "rectangle") {
    const std::vector<JsonNode> c = mesh_node.required("cells").elements(2);
    cells = {static_cast<int>(c[0].integer(1, 100000)), static_cast<int>(c[1].integer(1, 100000)), 0};
  } else if (type == "box") {
    const int c = static_cast<int>(mesh_node.required("cells").integer(1, 10000));
    cells = {c, c, c};
  } else {
    return std::nullopt;
  }
  return generate(mesh_node, [&] { return lattice_of(mesh.V, cells); });
}

TriMesh read_mesh(const JsonNode& mesh, const std::string& base_dir, const MeshBudget& budget) {
  const std::string type = mesh.required("type").choice(
      {"rectangle", "rectangle_equilateral", "icosphere", "box", "cylinder", "cup", "gear", "obj"}, "mesh type");
  if (type == "rectangle") {
    mesh.expect_keys({"type", "size", "cells", "diagonals"});
    auto size = mesh.required("size").elements(2);
    JsonNode cells_node = mesh.required("cells");
    auto cells = cells_node.elements(2);
    double w = size[0].in_range(limits::kLength), h = size[1].in_range(limits::kLength);
    long long nx = cells[0].integer(1, 100000), ny = cells[1].integer(1, 100000);
    GridDiagonals diagonals = GridDiagonals::Checkerboard;
    if (auto d = mesh.optional("diagonals")) {
      const std::string name = d->choice({"checkerboard", "rows", "uniform"}, "diagonal pattern");
      diagonals = name == "rows" ? GridDiagonals::Rows
                  : name == "uniform" ? GridDiagonals::Uniform : GridDiagonals::Checkerboard;
    }
    check_vertex_budget(cells_node, (nx + 1) * (ny + 1), 2 * nx * ny, budget);
    return generate(mesh, [&] { return make_rectangle(w, h, static_cast<int>(nx), static_cast<int>(ny), diagonals); });
  }
  if (type == "rectangle_equilateral") {
    mesh.expect_keys({"type", "size", "cells_x"});
    auto size = mesh.required("size").elements(2);
    JsonNode cells_node = mesh.required("cells_x");
    double w = size[0].in_range(limits::kLength), h = size[1].in_range(limits::kLength);
    long long n = cells_node.integer(1, 100000);
    // Row count as make_rectangle_equilateral computes it, to bound the vertex count before building.
    double rows = std::max(1.0, std::round(h / (w / n * std::sqrt(3.0) / 2.0)));
    if (!(rows <= 1e7)) cells_node.fail_got("gives more than 10^7 rows of vertices for this size");
    const auto r = static_cast<long long>(rows);
    check_vertex_budget(cells_node, (r + 1) * (n + 2), r * (2 * n + 1), budget);
    return generate(mesh, [&] { return make_rectangle_equilateral(w, h, static_cast<int>(n)); });
  }
  if (type == "icosphere") {
    mesh.expect_keys({"type", "radius", "subdivisions"});
    double r = mesh.required("radius").in_range(limits::kLength);
    JsonNode s_node = mesh.required("subdivisions");
    long long s = s_node.integer(0, 8);
    check_vertex_budget(s_node, 10 * (1LL << (2 * s)) + 2, 20 * (1LL << (2 * s)), budget);
    return generate(mesh, [&] { return make_icosphere(r, static_cast<int>(s)); });
  }
  if (type == "box") {
    mesh.expect_keys({"type", "size", "cells"});
    Vec3 size = mesh.required("size").vec3_in(limits::kLength);
    JsonNode cells_node = mesh.required("cells");
    long long c = cells_node.integer(1, 10000);
    check_vertex_budget(cells_node, 6 * c * c + 2, 12 * c * c, budget);
    return generate(mesh, [&] { return make_box(size, static_cast<int>(c)); });
  }
  if (type == "cylinder") {
    mesh.expect_keys({"type", "radius", "height", "segments", "rings", "capped"});
    double r = mesh.required("radius").in_range(limits::kLength);
    double h = mesh.required("height").in_range(limits::kLength);
    long long segments = mesh.required("segments").integer(3, 100000);
    JsonNode rings_node = mesh.required("rings");
    long long rings = rings_node.integer(1, 100000);
    auto capped_node = mesh.optional("capped");
    bool capped = capped_node ? capped_node->boolean() : false;
    check_vertex_budget(rings_node, segments * (rings + 1) + (capped ? 2 : 0),
                        2 * segments * rings + (capped ? 2 * segments : 0), budget);
    return generate(mesh, [&] { return make_cylinder(r, h, static_cast<int>(segments), static_cast<int>(rings), capped); });
  }
  if (type == "cup") {
    mesh.expect_keys({"type", "radius", "height", "segments", "rings"});
    double r = mesh.required("radius").in_range(limits::kLength);
    double h = mesh.required("height").in_range(limits::kLength);
    long long segments = mesh.required("segments").integer(3, 100000);
    JsonNode rings_node = mesh.required("rings");
    long long rings = rings_node.integer(1, 100000);
    check_vertex_budget(rings_node, segments * (rings + 1) + 1, 2 * segments * rings + segments, budget);
    return generate(mesh, [&] { return make_cup(r, h, static_cast<int>(segments), static_cast<int>(rings)); });
  }
  if (type == "gear") {
    mesh.expect_keys({"type", "radius", "root_radius", "teeth", "thickness"});
    double r = mesh.required("radius").in_range(limits::kLength);
    JsonNode root_node = mesh.required("root_radius");
    double root = root_node.in_range(limits::kLength);
    // Checked here rather than left to make_gear so the message names the key.
    if (!(root < r)) root_node.fail_got("must be < radius (" + number_for_message(r) + ")");
    JsonNode teeth_node = mesh.required("teeth");
    long long teeth = teeth_node.integer(3, 100000);
    double thickness = mesh.required("thickness").in_range(limits::kLength);
    check_vertex_budget(teeth_node, 8 * teeth + 2, 16 * teeth, budget);
    return generate(mesh, [&] { return make_gear(r, root, static_cast<int>(teeth), thickness); });
  }
  mesh.expect_keys({"type", "path"});
  JsonNode path = mesh.required("path");
  TriMesh m = read_obj_at(path, base_dir);  // read_obj stops at the per-object vertex and face limits
  check_vertex_budget(path, m.num_vertices(), m.num_faces(), budget);
  return m;
}

}  // namespace pd
