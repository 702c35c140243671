// The IPC contact term: derivatives, the CCD cap on line-search steps, and a drape whose every frame
// the independent CGAL checker certifies intersection-free.
#include "physics/contact/barrier_potential.h"

#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Geometry>

#include "geometry/shapes.h"
#include "geometry/topology.h"
#include "physics/contact/barrier.h"
#include "progressive/test_scenes.h"
#include "support/intersection_checker.h"
#include "support/term_eval.h"
#include "support/contact_settings.h"
#include "support/two_squares.h"

namespace pd {
namespace {

using test::contact_settings;
using test::TwoSquares;

// Contact primitives of a scene system: every face and edge, objects as in the system, self-contact
// as `self_contact` says per object.
ContactPrimitives primitives_of(const SceneSystem& sys, std::vector<char> self_contact) {
  ContactPrimitives p;
  p.faces = sys.rest.F;
  p.edges = build_topology(sys.rest).edges;
  const int objects = static_cast<int>(sys.object_names.size());
  p.vertex_object.resize(sys.rest.num_vertices());
  for (int o = 0; o < objects; ++o)
    for (int v = sys.object_offsets[o]; v < sys.object_offsets[o + 1]; ++v) p.vertex_object[v] = o;
  p.object_self_contact = std::move(self_contact);
  return p;
}

TEST(BarrierPotential, GradientAndHessianMatchFiniteDifferencesWithActivePairs) {
  TwoSquares s;
  const BarrierPotential term(s.prims, s.rest, contact_settings(0.2, 0.01, 10.0));
  const ContactStats st = term.stats(s.x);
  ASSERT_GT(st.active_point_triangle, 0);
  ASSERT_GT(st.active_edge_edge, 0);
  ASSERT_GT(st.min_gap, 0.0);
  EXPECT_GT(term.value(s.x), 0.0);
  // FD steps (1e-4 .. 1e-7 m) stay far below the smallest gap, so no pair changes activity.
  test::expect_derivatives_match(test::check_term_derivatives(term, s.x), 1e-6, 1e-5);
}

TEST(BarrierPotential, ValueIsZeroWhenNoPairIsWithinTheActivationGap) {
  TwoSquares s;
  ContactSettings cs;
  cs.dhat = 1e-3;
  cs.kappa = 10.0;
  const BarrierPotential term(s.prims, s.rest, cs);
  EXPECT_EQ(term.value(s.x), 0.0);
  EXPECT_EQ(test::term_gradient(term, s.x).norm(), 0.0);
}

TEST(BarrierPotential, MaxStepStopsATriangleBeforeItPassesThroughAnother) {
  // The small square moves 0.5 m straight down through the big one: the step must be cut before
  // contact, and the state at the cut must be intersection-free and at least the offset apart.
  TwoSquares s;
  ContactSettings cs;
  cs.dhat = 1e-3;
  cs.offset = 2e-3;
  const BarrierPotential term(s.prims, s.rest, cs);
  Eigen::VectorXd dx = Eigen::VectorXd::Zero(s.x.size());
  for (int v = 9; v < 18; ++v) dx[3 * v + 2] = -0.13;
  ASSERT_FALSE(test::intersection_free(as_rows(Eigen::VectorXd(s.x + dx)), s.prims.faces));
  const double alpha = term.max_step(s.x, dx);
  EXPECT_GT(alpha, 0.0);
  EXPECT_LT(alpha, 1.0);
  const Eigen::VectorXd x1 = s.x + alpha * dx;
  EXPECT_TRUE(test::intersection_free(as_rows(x1), s.prims.faces));
  EXPECT_GT(term.stats(x1).min_gap, 0.0);
}

// The active pairs are kept while x is unchanged (value, gradient and Hessian of one Newton iterate
// share them): the same term evaluated at x, then at another state, then at x again, and a fresh
// term at each state, agree bit for bit; set_thin_pairs at an unchanged x is seen at once (a pair
// inside the offset: infinite before, finite after).
TEST(BarrierPotential, ActivePairsAreReusedOnlyWhileXAndTheThinPairsAreUnchanged) {
  TwoSquares s;
  const ContactSettings cs = contact_settings(0.1, 0.1, 10.0);
  Eigen::VectorXd far = s.x;
  for (int v = 9; v < 18; ++v) far[3 * v + 2] += 0.05;  // the upper square lifted 5 cm: none inside the offset, some active
  BarrierPotential term(s.prims, s.rest, cs);
  const BarrierPotential fresh_far(s.prims, s.rest, cs);
  ASSERT_TRUE(std::isfinite(fresh_far.value(far)));
  ASSERT_GT(fresh_far.value(far), 0.0);  // pairs active there too, other ones
  EXPECT_FALSE(std::isfinite(term.value(s.x)));
  EXPECT_EQ(term.value(far), fresh_far.value(far));
  const Eigen::VectorXd g_far = test::term_gradient(term, far);
  EXPECT_TRUE(g_far == test::term_gradient(fresh_far, far));
  EXPECT_FALSE(std::isfinite(term.value(s.x)));  // back at x: not the pairs of `far`

  term.set_thin_pairs(term.pairs_within_offset(s.x));  // same x: the cached pairs must not be used
  BarrierPotential fresh_thin(s.prims, s.rest, cs);
  fresh_thin.set_thin_pairs(fresh_thin.pairs_within_offset(s.x));
  ASSERT_TRUE(std::isfinite(fresh_thin.value(s.x)));
  EXPECT_EQ(term.value(s.x), fresh_thin.value(s.x));
  EXPECT_TRUE(test::term_hessian(term, s.x, HessianProjection::Clamp) ==
              test::term_hessian(fresh_thin, s.x, HessianProjection::Clamp));
}

// A finite-difference neighbour's gradient over the reference's broad-phase pairs equals the gradient
// computed from scratch, bit for bit, when no pair is near the candidate radius (here: the squares'
// pairs sit well inside or outside dhat + offset), and the active set of the reference is untouched.
TEST(BarrierPotential, GradientNearAReferenceUsesItsPairsAndEqualsTheGradientFromScratch) {
  TwoSquares s;
  const ContactSettings cs = contact_settings(0.2, 0.01, 10.0);
  const BarrierPotential term(s.prims, s.rest, cs), fresh(s.prims, s.rest, cs);
  Eigen::VectorXd v = Eigen::VectorXd::LinSpaced(s.x.size(), -1.0, 1.0);
  const Eigen::VectorXd near = s.x + 1e-7 * v;
  const Eigen::VectorXd g_ref = test::term_gradient(term, s.x);
  Eigen::VectorXd g_near = Eigen::VectorXd::Zero(s.x.size());
  term.add_gradient_near(s.x, near, g_near);
  const Eigen::VectorXd expected = test::term_gradient(fresh, near);
  ASSERT_GT(expected.norm(), 0.0);
  EXPECT_TRUE(g_near == expected);
  EXPECT_FALSE(g_near == g_ref) << "the neighbour's gradient is not the reference's";
  EXPECT_TRUE(test::term_gradient(term, s.x) == g_ref) << "the reference's cached pairs are unchanged";

  // The pairs are the reference's, not the neighbour's: from a reference with the upper square lifted
  // 1 m (no candidates at all), the gradient at s.x has no contact, although s.x has active pairs.
  Eigen::VectorXd lifted = s.x;
  for (int v = 9; v < 18; ++v) lifted[3 * v + 2] += 1.0;
  Eigen::VectorXd g_from_lifted = Eigen::VectorXd::Zero(s.x.size());
  term.add_gradient_near(lifted, s.x, g_from_lifted);
  EXPECT_EQ(g_from_lifted.norm(), 0.0);
  EXPECT_GT(g_ref.norm(), 0.0);
}

// Thin pairs (set_thin_pairs) contact at distance 0 instead of the offset. The squares' closest
// pairs are ~0.1 m apart, so an offset of 0.1 m puts some of them inside it and leaves others out.
TEST(BarrierPotential, ThinPairsContactAtDistanceZeroAndEveryOtherPairAtTheOffset) {
  TwoSquares s;
  ContactSettings with_offset;
  with_offset.dhat = 0.1;
  with_offset.offset = 0.1;
  with_offset.kappa = 10.0;

  BarrierPotential plain(s.prims, s.rest, with_offset);
  const CandidatePairs thin = plain.pairs_within_offset(s.x);
  ASSERT_FALSE(thin.point_triangle.empty() && thin.edge_edge.empty());
  EXPECT_FALSE(std::isfinite(plain.value(s.x)));  // a pair inside the offset: infinite barrier

  // Every candidate pair thin: the term is the offset-0 term with its own activation distance.
  BarrierPotential all_thin(s.prims, s.rest, with_offset);
  all_thin.set_thin_pairs(find_candidates(s.prims, as_rows(s.x), 1.0));
  ContactSettings zero = with_offset;
  zero.offset = 0.0;
  zero.dhat = with_offset.offset + with_offset.dhat;  // thin pairs are active as far out as the others
  const BarrierPotential offset_zero(s.prims, s.rest, zero);
  ASSERT_GT(offset_zero.value(s.x), 0.0);
  EXPECT_DOUBLE_EQ(all_thin.value(s.x), offset_zero.value(s.x));
  EXPECT_LT((test::term_gradient(all_thin, s.x) - test::term_gradient(offset_zero, s.x)).norm(),
            1e-12 * test::term_gradient(offset_zero, s.x).norm());

  // Only the pairs within the offset thin: finite, with derivatives that match finite differences
  // (steps of 1e-4 .. 1e-7 m, far below every gap, so no pair changes activity or offset).
  BarrierPotential mixed(s.prims, s.rest, with_offset);
  mixed.set_thin_pairs(thin);
  EXPECT_TRUE(std::isfinite(mixed.value(s.x)));
  EXPECT_GT(mixed.value(s.x), 0.0);
  EXPECT_NE(mixed.value(s.x), offset_zero.value(s.x));  // the other pairs keep their offset
  ASSERT_GT(mixed.stats(s.x).min_gap, 0.0);
  test::expect_derivatives_match(test::check_term_derivatives(mixed, s.x), 1e-6, 1e-5);

  // The step cap lets thin pairs come closer than the offset, never through each other.
  Eigen::VectorXd dx = Eigen::VectorXd::Zero(s.x.size());
  for (int v = 9; v < 18; ++v) dx[3 * v + 2] = -0.13;
  const double alpha = mixed.max_step(s.x, dx);
  EXPECT_GT(alpha, 0.0);
  EXPECT_LT(alpha, 1.0);
  const Eigen::VectorXd x1 = s.x + alpha * dx;
  EXPECT_TRUE(test::intersection_free(as_rows(x1), s.prims.faces));
  EXPECT_GT(mixed.stats(x1).min_gap, 0.0);
}

TEST(BarrierPotential, SheetDroppedOnASphereNeverIntersectsAndStaysOnTop) {
  // A 0.6 m cotton sheet dropped from 5 cm above a pinned sphere of radius 0.15 m.
  Scene scene;
  scene.name = "drape";
  scene.time_step = 0.01;
  scene.frames = 40;
  scene.gravity = Vec3(0, -9.81, 0);
  SceneObject sphere;
  sphere.name = "sphere";
  sphere.rest = make_icosphere(0.15, 2);
  sphere.initial = sphere.rest.V;
  sphere.material = {472.6, 0.8e6, 0.3, 3.2e-4, std::nullopt};
  PinGroup all;
  for (int v = 0; v < sphere.rest.num_vertices(); ++v) all.vertices.push_back(v);
  sphere.pins.push_back(all);
  SceneObject sheet;
  sheet.name = "sheet";
  sheet.rest = make_rectangle(0.6, 0.6, 12, 12);
  for (int i = 0; i < sheet.rest.num_vertices(); ++i)  // lay it flat (x-z plane) at y = 0.2
    sheet.rest.V.row(i) = Eigen::RowVector3d(sheet.rest.V(i, 0), 0.2, -sheet.rest.V(i, 1));
  sheet.initial = sheet.rest.V;
  sheet.material = sphere.material;
  scene.objects = {sphere, sheet};

  SceneSystem sys = build_scene_system(scene);
  ContactSettings cs;
  cs.dhat = 1e-3;
  cs.offset = 0.0;
  const double avg_mass = sys.masses.sum() / sys.masses.size();
  cs.kappa = barrier_stiffness_bounds(cs.dhat, cs.offset, sys.bbox_diagonal, avg_mass, scene.time_step).kappa_min;
  // The pinned sphere cannot touch itself; the sheet folds over the sphere and must not pass
  // through itself (with self-contact off it did, at frame 23).
  auto contact = std::make_unique<BarrierPotential>(primitives_of(sys, {0, 1}), sys.rest.V, cs);
  const BarrierPotential* term = contact.get();
  sys.ip.add_term(std::move(contact));

  int intersection_free_frames = 0;
  double min_gap = INFINITY;
  Eigen::VectorXd v;
  const Eigen::VectorXd x = test::run_scene(scene, sys, &v, [&](const FrameRecord& r) {
    const double gap = term->stats(r.x).min_gap;
    const test::IntersectionReport rep = test::find_intersections(as_rows(r.x), sys.rest.F);
    EXPECT_EQ(rep.intersecting_pairs, 0) << "frame " << r.frame << ": faces " << rep.face_pairs[0].first << ", "
                                         << rep.face_pairs[0].second << " (sphere has "
                                         << scene.objects[0].rest.num_faces() << " faces); min gap " << gap;
    intersection_free_frames += rep.intersecting_pairs == 0;
    min_gap = std::min(min_gap, gap);
  });
  EXPECT_EQ(intersection_free_frames, scene.frames);
  EXPECT_GT(min_gap, 0.0);
  // The sheet's centre vertex (index 84 of the sheet) rests on the sphere's top (y = 0.15).
  const int centre = sys.object_offsets[1] + 6 * 13 + 6;
  const double sphere_top = scene.objects[0].rest.V.col(1).maxCoeff();
  const ContactStats end = term->stats(x);
  std::printf("drape: min gap %.3g m, centre height %.5f m (sphere top %.5f), speed %.3g m/s, "
              "contact pairs at end %d PT / %d EE\n", min_gap, x[3 * centre + 1], sphere_top,
              v.segment<3>(3 * centre).norm(), end.active_point_triangle, end.active_edge_edge);
  EXPECT_GT(x[3 * centre + 1], sphere_top);
  EXPECT_LT(x[3 * centre + 1], sphere_top + 5e-3);
}


// The pair loops run on several threads (physics/element_loops.h): two 24 x 24 sheets 0.6 dhat
// apart, the upper one shifted and waved, have thousands of active pairs; value, gradient and
// assembled projected Hessian must be the same bytes for every thread count.
TEST(BarrierPotential, ValueGradientAndHessianAreBitIdenticalOnOneTwoAndThreeThreads) {
  const TriMesh lower = make_rectangle(1.0, 1.0, 24, 24);
  TriMesh upper = lower;
  for (int i = 0; i < upper.num_vertices(); ++i)
    upper.V.row(i) += Vec3(0.013, 0.007, 0.006 + 0.001 * std::sin(7.0 * upper.V(i, 0))).transpose();
  ContactPrimitives prims;
  const int n = lower.num_vertices();
  Positions rest(2 * n, 3);
  rest << lower.V, upper.V;
  prims.faces.resize(2 * lower.num_faces(), 3);
  prims.faces << lower.F, (lower.F.array() + n).matrix();
  for (auto e : build_topology(lower).edges) prims.edges.push_back(e);
  for (auto e : build_topology(lower).edges) prims.edges.push_back({e[0] + n, e[1] + n});
  prims.vertex_object.assign(2 * n, 0);
  for (int v = n; v < 2 * n; ++v) prims.vertex_object[v] = 1;
  prims.object_self_contact = {0, 0};
  ContactSettings cs;
  cs.dhat = 0.01;
  cs.kappa = 10.0;
  const BarrierPotential term(prims, rest, cs);
  const Eigen::VectorXd x = stacked(rest);
  const ContactStats st = term.stats(x);
  ASSERT_GT(st.active_point_triangle + st.active_edge_edge, 2000);  // the parallel path
  ASSERT_GT(st.min_gap, 0.0);
  const test::TermBits one = test::term_bits(term, x, HessianProjection::Clamp, 1);
  long compared = 0;
  for (int threads : {2, 3}) compared += test::expect_same_bits(one, test::term_bits(term, x, HessianProjection::Clamp, threads));
  EXPECT_GT(compared, 2 * 20000);
}

}  // namespace
}  // namespace pd
