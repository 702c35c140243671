// project_strain (hierarchy/strain_projection.h): a stretched, bent sheet ends with every limited
// triangle at or below its goal, its fixed vertices where they were; a triangle no free vertex can
// fix is reported unsatisfied; bad input throws naming the field.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "geometry/shapes.h"
#include "hierarchy/strain_projection.h"
#include "physics/strain_limit.h"

namespace pd {
namespace {

// Largest sigma_max over the faces.
double worst_stretch(const Positions& rest, const Faces& F, const Positions& x) {
  double worst = 0.0;
  for (int f = 0; f < F.rows(); ++f) {
    Vec<9> xf;
    for (int k = 0; k < 3; ++k) xf.segment<3>(3 * k) = x.row(F(f, k)).transpose();
    const StrainLimitRest r = strain_limit_rest(rest.row(F(f, 0)), rest.row(F(f, 1)), rest.row(F(f, 2)));
    worst = std::max(worst, principal_stretches(xf, r)[0]);
  }
  return worst;
}

// A 0.5 m x 0.3 m sheet in the xy plane, then pulled 30 % along x (more at its free end) and bent out
// of its plane: the state a prolongation can hand a finer level.
struct StretchedSheet {
  TriMesh mesh = make_rectangle(0.5, 0.3, 10, 6);
  Positions x;
  std::vector<char> free;
  StretchedSheet() {
    x = mesh.V;
    free.assign(static_cast<std::size_t>(x.rows()), 1);
    const double left = mesh.V.col(0).minCoeff();
    for (Eigen::Index v = 0; v < x.rows(); ++v) {
      const double s = mesh.V(v, 0) - left;  // 0 at the pinned edge
      x(v, 0) = left + s * (1.0 + 0.6 * s);  // stretch growing toward the free end: 1.0 .. 1.6
      x(v, 2) = 0.05 * std::sin(6.0 * s) + 0.02 * mesh.V(v, 1);
      if (s < 1e-9) free[static_cast<std::size_t>(v)] = 0;  // the left edge is pinned where it is
    }
  }
};

TEST(StrainProjection, AStretchedBentSheetEndsBelowItsLimitWithItsPinnedEdgeUntouched) {
  StretchedSheet s;
  const std::vector<double> limit(static_cast<std::size_t>(s.mesh.F.rows()), 1.05);
  ASSERT_GT(worst_stretch(s.mesh.V, s.mesh.F, s.x), 1.3);
  const Positions start = s.x;
  std::vector<Positions> iterates;
  StrainProjectionSettings settings;
  const StrainProjectionReport r = project_strain(s.mesh.V, s.mesh.F, limit, s.free, settings, s.x, &iterates);
  EXPECT_TRUE(r.satisfied);
  EXPECT_GT(r.iterations, 1);
  EXPECT_LT(r.iterations, settings.max_iterations);
  EXPECT_GT(r.max_stretch_before, 1.3);
  EXPECT_LE(r.max_stretch_after, 1.05 * (1.0 - settings.target_fraction));
  EXPECT_DOUBLE_EQ(r.max_stretch_after, worst_stretch(s.mesh.V, s.mesh.F, s.x));
  int pinned = 0;
  for (Eigen::Index v = 0; v < s.x.rows(); ++v) {
    if (s.free[static_cast<std::size_t>(v)]) continue;
    ++pinned;
    EXPECT_EQ(s.x.row(v), start.row(v)) << "pinned vertex " << v << " moved";
  }
  EXPECT_EQ(pinned, 7);
  // Recorded every record_every iterations and at the end, which is the result.
  EXPECT_EQ(static_cast<int>(iterates.size()), (r.iterations + settings.record_every - 1) / settings.record_every);
  EXPECT_EQ(iterates.back(), s.x);
}

TEST(StrainProjection, ASheetBelowItsLimitIsLeftExactlyAsItWas) {
  StretchedSheet s;
  const std::vector<double> limit(static_cast<std::size_t>(s.mesh.F.rows()), 1.8);  // above the 1.6 stretch
  const Positions start = s.x;
  const StrainProjectionReport r = project_strain(s.mesh.V, s.mesh.F, limit, s.free, {}, s.x);
  EXPECT_TRUE(r.satisfied);
  EXPECT_EQ(r.iterations, 0);
  EXPECT_EQ(s.x, start);
}

TEST(StrainProjection, OnlyLimitedFacesAreProjectedAndAFaceWithoutAFreeVertexIsReportedUnsatisfied) {
  StretchedSheet s;
  std::vector<double> limit(static_cast<std::size_t>(s.mesh.F.rows()), 0.0);
  limit[0] = 1.05;  // a face of the pinned edge's column
  std::vector<char> none(s.free.size(), 0);
  const Positions start = s.x;
  const StrainProjectionReport stuck = project_strain(s.mesh.V, s.mesh.F, limit, none, {}, s.x);
  EXPECT_FALSE(stuck.satisfied);
  EXPECT_EQ(stuck.iterations, 0);
  EXPECT_EQ(s.x, start);
  const StrainProjectionReport r = project_strain(s.mesh.V, s.mesh.F, limit, s.free, {}, s.x);
  EXPECT_TRUE(r.satisfied);
  // Face 0 alone is limited: a vertex in no face with face 0 did not move.
  int untouched = 0;
  for (Eigen::Index v = 0; v < s.x.rows(); ++v) {
    bool near = false;
    for (int k = 0; k < 3; ++k) near = near || s.mesh.F(0, k) == v;
    if (near) continue;
    EXPECT_EQ(s.x.row(v), start.row(v)) << v;
    ++untouched;
  }
  EXPECT_EQ(untouched, static_cast<int>(s.x.rows()) - 3);
}

TEST(StrainProjection, BadInputThrowsNamingTheField) {
  StretchedSheet s;
  const std::vector<double> ok(static_cast<std::size_t>(s.mesh.F.rows()), 1.05);
  const auto message = [&](const std::vector<double>& limit, const std::vector<char>& free,
                           const StrainProjectionSettings& settings) -> std::string {
    Positions x = s.x;
    try {
      project_strain(s.mesh.V, s.mesh.F, limit, free, settings, x);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "no throw";
  };
  EXPECT_NE(message({1.05}, s.free, {}).find("face_limit"), std::string::npos);
  std::vector<double> bad = ok;
  bad[3] = 0.9;
  EXPECT_NE(message(bad, s.free, {}).find("face limit"), std::string::npos);
  EXPECT_NE(message(ok, {1, 0}, {}).find("free_mask"), std::string::npos);
  StrainProjectionSettings settings;
  settings.target_fraction = 1.0;
  EXPECT_NE(message(ok, s.free, settings).find("target_fraction"), std::string::npos);
  settings = {};
  settings.progress_every = 0;
  EXPECT_NE(message(ok, s.free, settings).find("progress_every"), std::string::npos);
}

}  // namespace
}  // namespace pd
