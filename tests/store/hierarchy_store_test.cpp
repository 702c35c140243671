#include "store/hierarchy_store.h"

#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

// The tamper test edits a file with the HDF5 C API directly (tests/CMakeLists.txt puts HDF5's headers
// on the test target's include path).
#include <hdf5.h>

#include "scene/scene_file.h"
#include "store/frame_store.h"
#include "support/input_error_of.h"
#include "support/test_paths.h"
#include "util/input_error.h"

namespace pd {
namespace {

// A pinned 12 x 12 sheet above a small icosphere obstacle, 3 levels; `ratio` changes the hash.
Scene small_scene(double ratio = 4.0) {
  const std::string text = R"({"format_version": 1, "name": "store", "time_step": 0.01, "frames": 4,
    "hierarchy": {"levels": 3, "ratio": )" + std::to_string(ratio) + R"(},
    "contact": {"dhat": 1e-3},
    "objects": [
      {"name": "sheet", "mesh": {"type": "rectangle", "size": [1.0, 1.0], "cells": [12, 12]},
       "material": {"preset": "cotton"}, "pins": [{"indices": [0, 12]}]},
      {"name": "ball", "mesh": {"type": "icosphere", "radius": 0.2, "subdivisions": 2}, "obstacle": true,
       "transform": {"translation": [0, 0, -1]}}]})";
  return parse_scene(text, "store.json", "");
}

using test::input_error_of;

bool same_bits(const double* a, const double* b, Eigen::Index n) {
  return std::memcmp(a, b, sizeof(double) * static_cast<size_t>(n)) == 0;
}
bool same_positions(const Positions& a, const Positions& b) {
  return a.rows() == b.rows() && same_bits(a.data(), b.data(), a.size());
}

// Every entry of U (row, column, value) with ==, and the offsets and locations.
void expect_same_operator(const ShellProlongation& a, const ShellProlongation& b, const std::string& what) {
  SCOPED_TRACE(what);
  ASSERT_EQ(a.num_fine(), b.num_fine());
  ASSERT_EQ(a.num_coarse(), b.num_coarse());
  ASSERT_EQ(a.U().nonZeros(), b.U().nonZeros());
  for (int c = 0; c < a.U().outerSize(); ++c) {
    Eigen::SparseMatrix<double>::InnerIterator ia(a.U(), c), ib(b.U(), c);
    for (; ia && ib; ++ia, ++ib) {
      ASSERT_EQ(ia.row(), ib.row());
      ASSERT_EQ(ia.col(), ib.col());
      ASSERT_EQ(ia.value(), ib.value()) << "U(" << ia.row() << ", " << ia.col() << ")";
    }
    ASSERT_EQ(static_cast<bool>(ia), static_cast<bool>(ib));
  }
  EXPECT_EQ(a.normal_offsets(), b.normal_offsets());
  EXPECT_EQ(a.tangent_offsets(), b.tangent_offsets());
  for (int i = 0; i < a.num_fine(); ++i) {
    ASSERT_EQ(a.locations()[i].face, b.locations()[i].face) << i;
    ASSERT_EQ(a.locations()[i].bary, b.locations()[i].bary) << i;
  }
}

void expect_same_collapse(const Collapse& a, const Collapse& b) {
  EXPECT_EQ(a.removed, b.removed);
  EXPECT_EQ(a.kept, b.kept);
  EXPECT_EQ(a.removed_position, b.removed_position);
  EXPECT_EQ(a.kept_position_before, b.kept_position_before);
  EXPECT_EQ(a.kept_position_after, b.kept_position_after);
  EXPECT_EQ(a.faces_before, b.faces_before);
  EXPECT_EQ(a.faces_after, b.faces_after);
}

void expect_same_hierarchy(const SceneHierarchy& a, const SceneHierarchy& b) {
  EXPECT_EQ(a.hash, b.hash);
  ASSERT_EQ(a.num_levels(), b.num_levels());
  for (int l = 0; l < a.num_levels(); ++l) {
    SCOPED_TRACE("level " + std::to_string(l));
    const SceneLevel &x = a.levels[l], &y = b.levels[l];
    EXPECT_TRUE(same_positions(x.rest.V, y.rest.V));
    EXPECT_EQ(x.rest.F, y.rest.F);
    EXPECT_EQ(x.vertex_offsets, y.vertex_offsets);
    EXPECT_EQ(x.face_offsets, y.face_offsets);
    EXPECT_EQ(x.to_finest, y.to_finest);
    ASSERT_EQ(x.to_next.has_value(), y.to_next.has_value());
    if (x.to_next) expect_same_operator(*x.to_next, *y.to_next, "to_next");
    ASSERT_EQ(x.to_finest_prolongation.has_value(), y.to_finest_prolongation.has_value());
    if (x.to_finest_prolongation)
      expect_same_operator(*x.to_finest_prolongation, *y.to_finest_prolongation, "to_finest_prolongation");
  }
  ASSERT_EQ(a.objects.size(), b.objects.size());
  for (size_t k = 0; k < a.objects.size(); ++k) {
    const ObjectHierarchy &p = a.objects[k], &q = b.objects[k];
    ASSERT_EQ(p.levels.size(), q.levels.size());
    EXPECT_EQ(p.batches, q.batches);
    for (size_t l = 0; l < p.levels.size(); ++l) {
      SCOPED_TRACE("object " + std::to_string(k) + " level " + std::to_string(l));
      const Level &u = p.levels[l], &v = q.levels[l];
      EXPECT_TRUE(same_positions(u.mesh.V, v.mesh.V));
      EXPECT_EQ(u.mesh.F, v.mesh.F);
      EXPECT_EQ(u.to_finest, v.to_finest);
      EXPECT_EQ(u.coarse_to_fine, v.coarse_to_fine);
      EXPECT_EQ(u.fine_to_coarse, v.fine_to_coarse);
      ASSERT_EQ(u.collapses.size(), v.collapses.size());
      for (size_t c = 0; c < u.collapses.size(); ++c) expect_same_collapse(u.collapses[c], v.collapses[c]);
    }
  }
}

// A frame file with the hierarchy of `scene` stored and its levels added (no frames).
std::string write_job_file(const std::string& dir, const Scene& scene, const SceneHierarchy& h) {
  const std::string path = dir + "/job.h5";
  FrameWriter w = FrameWriter::create(path, scene.json_text, scene.frames);
  write_hierarchy(path, h, scene_object_names(scene));
  add_hierarchy_levels(w, h, scene_object_names(scene));
  w.close();
  return path;
}

TEST(HierarchyStore, WriteThenReadGivesTheBuiltHierarchyBitForBit) {
  const Scene scene = small_scene();
  const SceneHierarchy built = build_scene_hierarchy(scene);
  ASSERT_EQ(built.num_levels(), 3);
  ASSERT_GT(built.levels[0].rest.V.rows(), 0);
  const std::string path = write_job_file(test::scratch_dir("hstore_roundtrip"), scene, built);
  const std::optional<SceneHierarchy> read = read_hierarchy(path);
  ASSERT_TRUE(read.has_value());
  expect_same_hierarchy(built, *read);
  EXPECT_EQ(stored_hierarchy_hash(path), built.hash);
  // Collapses exist on the coarser levels, so the records were really exercised.
  EXPECT_FALSE(read->objects[0].levels[0].collapses.empty());
  EXPECT_FALSE(read->objects[0].batches.empty());
}

TEST(HierarchyStore, FrameReaderReadsTheFileAndFramesGoToItsLevels) {
  const Scene scene = small_scene();
  const SceneHierarchy h = build_scene_hierarchy(scene);
  const std::string dir = test::scratch_dir("hstore_reader");
  const std::string path = dir + "/job.h5";
  FrameWriter w = FrameWriter::create(path, scene.json_text, scene.frames);
  write_hierarchy(path, h, scene_object_names(scene));
  add_hierarchy_levels(w, h, scene_object_names(scene));
  const Positions x0 = h.levels[0].rest.V.array() + 0.01;
  w.write_frame(0, 2, x0, FrameStats{});
  w.close();

  const FrameReader r(path);
  ASSERT_EQ(r.num_levels(), h.num_levels());
  EXPECT_EQ(r.num_frames(), scene.frames + 1);
  for (int l = 0; l < h.num_levels(); ++l) {
    EXPECT_TRUE(same_positions(r.rest_positions(l), h.levels[l].rest.V)) << l;
    EXPECT_EQ(r.faces(l), h.levels[l].rest.F) << l;
    EXPECT_EQ(r.object_offsets(l), h.levels[l].vertex_offsets) << l;
    EXPECT_EQ(r.object_names(l), (std::vector<std::string>{"sheet", "ball"})) << l;
  }
  EXPECT_TRUE(same_positions(r.frame(0, 2), x0));
  EXPECT_EQ(r.scene_json(), scene.json_text);
}

TEST(HierarchyStore, AddLevelRejectsALevelThatDiffersFromTheStoredOne) {
  const Scene scene = small_scene();
  const SceneHierarchy h = build_scene_hierarchy(scene);
  const std::string path = test::scratch_dir("hstore_mismatch") + "/job.h5";
  const std::vector<std::string> names = scene_object_names(scene);
  FrameWriter w = FrameWriter::create(path, scene.json_text, scene.frames);
  write_hierarchy(path, h, names);
  w.add_level(0, h.levels[0].rest.V, h.levels[0].rest.F, h.levels[0].vertex_offsets, names);
  Positions moved = h.levels[1].rest.V;
  moved(3, 1) = std::nextafter(moved(3, 1), 1e9);  // one ulp
  const std::string msg = input_error_of(
      [&] { w.add_level(1, moved, h.levels[1].rest.F, h.levels[1].vertex_offsets, names); });
  EXPECT_EQ(msg.rfind(path + ": /hierarchy/1/rest_positions:", 0), 0u) << msg;
  const std::string msg2 = input_error_of(
      [&] { w.add_level(1, h.levels[1].rest.V, h.levels[1].rest.F, h.levels[1].vertex_offsets, {"sheet", "cube"}); });
  EXPECT_EQ(msg2.rfind(path + ": /hierarchy/1/object_names:", 0), 0u) << msg2;
  // The right level is still accepted.
  w.add_level(1, h.levels[1].rest.V, h.levels[1].rest.F, h.levels[1].vertex_offsets, names);
  EXPECT_EQ(w.num_levels(), 2);
}

TEST(HierarchyStore, LoadOrBuildReusesOnlyWhenTheHashMatches) {
  const std::string path = test::scratch_dir("hstore_reuse") + "/job.h5";
  const Scene scene = small_scene();
  bool reused = true;
  std::vector<HierarchyLevelReport> report;
  const SceneHierarchy first = load_or_build_hierarchy(scene, path, &reused, &report);
  EXPECT_FALSE(reused);
  EXPECT_EQ(report.size(), 3u);
  EXPECT_EQ(first.hash, hierarchy_hash(scene));

  const SceneHierarchy second = load_or_build_hierarchy(scene, path, &reused, &report);
  EXPECT_TRUE(reused);
  expect_same_hierarchy(first, second);
  EXPECT_EQ(FrameReader(path).num_levels(), 3);

  const Scene changed = small_scene(3.0);
  ASSERT_NE(hierarchy_hash(changed), hierarchy_hash(scene));
  const SceneHierarchy third = load_or_build_hierarchy(changed, path, &reused, &report);
  EXPECT_FALSE(reused);
  EXPECT_EQ(stored_hierarchy_hash(path), hierarchy_hash(changed));
  EXPECT_EQ(third.hash, hierarchy_hash(changed));
}

TEST(HierarchyStore, TamperedOperatorIsRejectedNamingTheDataset) {
  const Scene scene = small_scene();
  const SceneHierarchy h = build_scene_hierarchy(scene);
  const std::string path = write_job_file(test::scratch_dir("hstore_tamper"), scene, h);
  {
    const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(file, 0);
    const hid_t d = H5Dopen2(file, "/hierarchy/1/to_next/U_data", H5P_DEFAULT);
    ASSERT_GE(d, 0);
    std::vector<double> data(static_cast<size_t>(h.levels[1].to_next->U().nonZeros()));
    ASSERT_GE(H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data()), 0);
    data[5] = std::nextafter(data[5], 2.0);  // one ulp is enough
    ASSERT_GE(H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data()), 0);
    H5Dclose(d);
    H5Fclose(file);
  }
  const std::string msg = input_error_of([&] { read_hierarchy(path); });
  EXPECT_EQ(msg.rfind(path + ": /hierarchy/1/to_next: stored operator differs from the rebuilt one (file corrupt or "
                             "written by another version)", 0), 0u) << msg;
  EXPECT_NE(msg.find("U_data differs at entry 5"), std::string::npos) << msg;
}

TEST(HierarchyStore, PlainFrameFileHasNoHierarchyAndBadFilesNameThePath) {
  const std::string dir = test::scratch_dir("hstore_plain");
  const std::string path = dir + "/plain.h5";
  {
    FrameWriter w = FrameWriter::create(path, "{}", 1);
    Positions V(3, 3);
    V << 0, 0, 0, 1, 0, 0, 0, 1, 0;
    Faces F(1, 3);
    F << 0, 1, 2;
    w.add_level(0, V, F, {0, 3}, {"tri"});
    w.close();
  }
  EXPECT_FALSE(read_hierarchy(path).has_value());
  EXPECT_FALSE(stored_hierarchy_hash(path).has_value());
  EXPECT_FALSE(stored_hierarchy_hash(dir + "/missing.h5").has_value());
  const std::string missing = input_error_of([&] { read_hierarchy(dir + "/missing.h5"); });
  EXPECT_EQ(missing.rfind(dir + "/missing.h5: no such file", 0), 0u) << missing;

  // write_hierarchy only writes into frame files.
  const hid_t file = H5Fcreate((dir + "/other.h5").c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  H5Fclose(file);
  const Scene scene = small_scene();
  const SceneHierarchy h = build_scene_hierarchy(scene);
  const std::string msg = input_error_of([&] { write_hierarchy(dir + "/other.h5", h, scene_object_names(scene)); });
  EXPECT_EQ(msg.rfind(dir + "/other.h5: /@format_version:", 0), 0u) << msg;
}

}  // namespace
}  // namespace pd
