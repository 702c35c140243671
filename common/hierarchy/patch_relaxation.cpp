#include "hierarchy/patch_relaxation.h"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

#include "physics/contact/barrier_potential.h"
#include "physics/contact/ground_barrier.h"
#include "physics/contact/distance.h"
#include "physics/inertia.h"
#include "physics/membrane_neo_hookean.h"
#include "physics/strain_limit.h"
#include "solver/incremental_potential.h"
#include "solver/newton.h"

namespace pd {

namespace {

// The normalised membrane (see the header): only E * thickness matters, and it is 1 N/m.
constexpr double kYoungs = 1.0;     // Pa
constexpr double kPoisson = 0.3;
constexpr double kThickness = 1.0;  // m
constexpr double kMembraneScale = kYoungs * kThickness;  // E t, N/m

// relax_gaps' barrier reaches 2 * min_gap beyond the offset (why: header, relax_gaps).
constexpr double kGapReachFactor = 2.0;
// relax_gaps stops its rounds when a round's Newton solve ran out of iterations and the smallest gap
// did not grow by this factor over the round before (header, "Stalls").
constexpr double kStallGrowth = 1.1;
// relax_gaps' first kappa, in units of (E t) / dhat_b^2 (why: header, "Starting kappa").
constexpr double kStartKappa = 1e-2;
// A rest triangle with |e1 x e2| <= this * (longest edge)^2 is degenerate (sin of its smallest angle
// ~ 1e-12: its rest metric's inverse would be dominated by round-off).
constexpr double kDegenerateRest = 1e-12;
// Newton stops when its step is below this fraction of the mean rest edge length (m): stretches are
// then resolved to ~1e-5, far below the 1e-3 slack of the strain goal.
constexpr double kStepToleranceFraction = 1e-5;
// ... and never looser than this fraction of the barrier's reach, so gaps are resolved too.
constexpr double kStepToleranceGapFraction = 1e-2;
// relax_strain stops when a round improves the worst stretch ratio by less than this (relative).
constexpr double kMinStrainProgress = 1e-6;

// ---- Input checks ---------------------------------------------------------------------------

int check_mesh(const RelaxationMesh& mesh, const Positions& x, const char* who) {
  const std::string w = who;
  if (mesh.primitives == nullptr || mesh.rest == nullptr)
    throw std::invalid_argument(w + ": mesh.primitives and mesh.rest must be set");
  const int n = static_cast<int>(mesh.rest->rows());
  if (static_cast<int>(mesh.primitives->vertex_object.size()) != n || x.rows() != n)
    throw std::invalid_argument(w + ": rest, x and primitives.vertex_object must have one row / entry per vertex");
  if (!(mesh.offset >= 0.0) || !std::isfinite(mesh.offset))
    throw std::invalid_argument(w + ": offset must be finite and >= 0 (m)");
  if (!x.allFinite() || !mesh.rest->allFinite())
    throw std::invalid_argument(w + ": positions must be finite");
  const Faces& F = mesh.primitives->faces;
  if (F.size() > 0 && (F.minCoeff() < 0 || F.maxCoeff() >= n))
    throw std::invalid_argument(w + ": a face indexes a missing vertex");
  if (const GroundPlane* g = mesh.ground) {
    if (static_cast<int>(g->vertex_collides.size()) != n)
      throw std::invalid_argument(w + ": ground.vertex_collides needs one entry per vertex");
    for (int v = 0; v < n; ++v)
      if (g->vertex_collides[static_cast<std::size_t>(v)] && !(g->normal.dot(x.row(v).transpose()) - g->height > mesh.offset))
        throw std::invalid_argument(w + ": vertex " + std::to_string(v) + " starts within the offset of the ground");
  }
  return n;
}

std::vector<char> free_mask_of(const std::vector<int>& free_vertices, int n, const char* who) {
  std::vector<char> mask(static_cast<std::size_t>(n), 0);
  for (int v : free_vertices) {
    if (v < 0 || v >= n)
      throw std::invalid_argument(std::string(who) + ": free vertex " + std::to_string(v) + " is out of range [0, " +
                                  std::to_string(n) + ")");
    mask[static_cast<std::size_t>(v)] = 1;
  }
  return mask;
}

void check_counts(int rounds, int iterations, double anchor, const char* who) {
  if (rounds < 1 || iterations < 1)
    throw std::invalid_argument(std::string(who) + ": round and Newton iteration counts must be >= 1");
  if (!(anchor >= 0.0) || !std::isfinite(anchor))
    throw std::invalid_argument(std::string(who) + ": anchor_stiffness must be finite and >= 0");
}

// ---- Geometry helpers -----------------------------------------------------------------------

Vec<9> gather_face(const Positions& V, const Faces& F, int f) {
  Vec<9> out;
  for (int k = 0; k < 3; ++k) out.segment<3>(3 * k) = V.row(F(f, k)).transpose();
  return out;
}

bool rest_degenerate(const Positions& rest, const Faces& F, int f) {
  const Vec3 a = rest.row(F(f, 0)), b = rest.row(F(f, 1)), c = rest.row(F(f, 2));
  const double longest2 = std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
  const double cross = (b - a).cross(c - a).norm();
  return !std::isfinite(cross) || !(cross > kDegenerateRest * longest2);
}

bool has_free_vertex(const Faces& F, int f, const std::vector<char>& mask) {
  for (int k = 0; k < 3; ++k)
    if (mask[static_cast<std::size_t>(F(f, k))]) return true;
  return false;
}

// ---- The relaxation problem -----------------------------------------------------------------

// Faces of the membrane (with a free vertex, usable rest and current triangles) and the common data
// of both solves.
struct Setup {
  const RelaxationMesh* mesh = nullptr;
  int n = 0;
  std::vector<char> free_mask;
  std::vector<int> membrane_faces;  // rows of primitives->faces
  int skipped_faces = 0;
  double mean_edge = 0.0;  // mean rest edge length over the membrane faces, m
  Eigen::VectorXd start;   // stacked start positions, m
};

Setup make_setup(const RelaxationMesh& mesh, int n, std::vector<char> mask, const Positions& x) {
  Setup s;
  s.mesh = &mesh;
  s.n = n;
  s.free_mask = std::move(mask);
  s.start = stacked(x);
  const Faces& F = mesh.primitives->faces;
  const MembraneMaterialParams params = MembraneMaterialParams::from(kYoungs, kPoisson, kThickness);
  double edge_sum = 0.0;
  for (int f = 0; f < F.rows(); ++f) {
    if (!has_free_vertex(F, f, s.free_mask)) continue;
    if (rest_degenerate(*mesh.rest, F, f)) {
      ++s.skipped_faces;
      continue;
    }
    const Vec<9> X = gather_face(*mesh.rest, F, f);
    const MembraneRest rest = membrane_rest(X.segment<3>(0), X.segment<3>(3), X.segment<3>(6));
    if (!std::isfinite(neo_hookean_membrane_energy(gather_face(x, F, f), rest, params))) {
      ++s.skipped_faces;  // collapsed at the start: infinite energy, no Newton step possible
      continue;
    }
    s.membrane_faces.push_back(f);
    for (int k = 0; k < 3; ++k) edge_sum += (X.segment<3>(3 * ((k + 1) % 3)) - X.segment<3>(3 * k)).norm();
  }
  if (!s.membrane_faces.empty()) s.mean_edge = edge_sum / (3.0 * static_cast<double>(s.membrane_faces.size()));
  return s;
}

// The potential: anchor + membrane (faces grouped by weight; `start_shaped` faces at weight 1 with
// the start positions as their reference instead of the rest shape) + barrier. The anchor pulls toward
// `anchor_at` (stacked, m). The barrier contacts at the mesh's offset, except for the pairs that
// start within it (a freshly split edge is shorter than the offset), which contact at distance 0
// (BarrierPotential::set_thin_pairs): the barrier is then finite at the start, and no pair that
// starts beyond the offset can be pressed into it. dhat: the activation distance from 0 (m, >
// offset), the same for both kinds of pair. Returns the barrier so the caller can change kappa.
BarrierPotential* build_potential(const Setup& s, const std::map<double, std::vector<int>>& weighted_faces,
                                  double dhat, double kappa, double anchor, const Eigen::VectorXd& anchor_at,
                                  IncrementalPotential& ip, const std::vector<int>& start_shaped = {}) {
  ip = IncrementalPotential();
  ip.add_term(std::make_unique<InertiaTerm>(Eigen::VectorXd::Constant(3 * s.n, anchor * kMembraneScale)));
  const auto add_membrane = [&](const std::vector<int>& faces, const Positions& reference, double weight) {
    if (faces.empty()) return;
    Faces F(static_cast<Eigen::Index>(faces.size()), 3);
    for (std::size_t i = 0; i < faces.size(); ++i) F.row(static_cast<Eigen::Index>(i)) = s.mesh->primitives->faces.row(faces[i]);
    ip.add_term(std::make_unique<NeoHookeanMembrane>(
        F, reference, MembraneMaterialParams::from(weight * kYoungs, kPoisson, kThickness)));
  };
  for (const auto& [weight, faces] : weighted_faces) add_membrane(faces, *s.mesh->rest, weight);
  add_membrane(start_shaped, as_rows(s.start), 1.0);
  ContactSettings cs;
  cs.dhat = dhat - s.mesh->offset;  // activation measured from the offset
  cs.offset = s.mesh->offset;
  cs.kappa = kappa;
  auto barrier = std::make_unique<BarrierPotential>(*s.mesh->primitives, *s.mesh->rest, cs);
  barrier->set_thin_pairs(barrier->pairs_within_offset(s.start));
  BarrierPotential* raw = barrier.get();
  ip.add_term(std::move(barrier));
  if (const GroundPlane* g = s.mesh->ground) {
    std::vector<int> colliding;
    for (int v = 0; v < s.n; ++v)
      if (g->vertex_collides[static_cast<std::size_t>(v)]) colliding.push_back(v);
    ip.add_term(std::make_unique<GroundBarrier>(std::move(colliding), g->normal, g->height, cs, 0.0));
  }

  std::vector<char> fixed(static_cast<std::size_t>(3 * s.n), 1);
  for (int v = 0; v < s.n; ++v)
    if (s.free_mask[static_cast<std::size_t>(v)]) fixed[3 * v] = fixed[3 * v + 1] = fixed[3 * v + 2] = 0;
  ip.set_fixed_dofs(std::move(fixed));

  // h = 1 s and zero velocity: x_hat = anchor_at, the anchor is (mass / 2) |x - anchor_at|^2.
  StepStart step;
  step.h = 1.0;
  step.x = &anchor_at;
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(s.start.size());
  step.v = &zero;
  ip.begin_step(step);  // InertiaTerm keeps its own copy of x_hat, so `zero` may go out of scope
  return raw;
}

NewtonSettings newton_settings(const Setup& s, double dhat, int iterations) {
  NewtonSettings ns;
  ns.h = 1.0;  // the stopping measure ||p||_inf / h is then a length, m
  double tol = kStepToleranceGapFraction * dhat;
  if (s.mean_edge > 0.0) tol = std::min(tol, kStepToleranceFraction * s.mean_edge);
  ns.step_tolerance = tol;
  ns.max_iterations = iterations;
  ns.projection = HessianProjection::Clamp;
  return ns;
}

double min_relative_quality(const Setup& s, const Positions& x) {
  const Faces& F = s.mesh->primitives->faces;
  const Positions& R = *s.mesh->rest;
  double q = s.membrane_faces.empty() ? 0.0 : std::numeric_limits<double>::infinity();
  for (int f : s.membrane_faces) {
    const double qr = triangle_quality(R.row(F(f, 0)), R.row(F(f, 1)), R.row(F(f, 2)));
    q = std::min(q, triangle_quality(x.row(F(f, 0)), x.row(F(f, 1)), x.row(F(f, 2))) / qr);
  }
  return q;
}

// Copies the free rows of the stacked solution into x (fixed rows are never written, so they stay
// bit-for-bit what the caller passed).
void write_free(const Setup& s, const Eigen::VectorXd& xs, Positions& x) {
  for (int v = 0; v < s.n; ++v)
    if (s.free_mask[static_cast<std::size_t>(v)]) x.row(v) = xs.segment<3>(3 * v).transpose();
}

// Records every accepted Newton iterate into `iterates` (whole positions: `x` with the free rows
// replaced), if given.
void record_iterates(const Setup& s, const Positions& x, std::vector<Positions>* iterates, NewtonSettings& ns) {
  if (!iterates) return;
  iterates->clear();
  ns.after_iteration = [&s, x, iterates](const Eigen::VectorXd& xs) {
    Positions step = x;
    write_free(s, xs, step);
    iterates->push_back(std::move(step));
    return false;
  };
}

// Refuses a start the barrier cannot evaluate: a pair (any, free or not) at d <= 0.
void check_start_contact(const ContactPrimitives& prims, const Positions& x, double reach, const char* who) {
  if (!(relaxation_min_gap(prims, x, 0.0, reach) > 0.0))
    throw std::invalid_argument(std::string(who) + ": the start has a touching or intersecting contact pair (d <= 0)");
}

// The start shared by relax_strain and relax_toward (a barrier of fixed reach contact_gap beyond
// the offset): checks the reach and the start, builds the setup, fills the "before" measures.
Setup begin_fixed_barrier_solve(const RelaxationMesh& mesh, int n, std::vector<char> mask, const Positions& x,
                                double contact_gap, const char* who, RelaxationReport& report) {
  if (!(contact_gap > 0.0) || !std::isfinite(contact_gap))
    throw std::invalid_argument(std::string(who) + ": contact_gap must be finite and > 0 (m)");
  check_start_contact(*mesh.primitives, x, mesh.offset + contact_gap, who);
  Setup s = make_setup(mesh, n, std::move(mask), x);
  report.skipped_faces = s.skipped_faces;
  report.min_gap_before = relaxation_min_gap(*mesh.primitives, x, mesh.offset, contact_gap, s.free_mask);
  report.min_relative_quality_before = min_relative_quality(s, x);
  return s;
}

}  // namespace

double triangle_quality(const Vec3& a, const Vec3& b, const Vec3& c) {
  const double sum2 = (b - a).squaredNorm() + (c - b).squaredNorm() + (a - c).squaredNorm();
  if (!(sum2 > 0.0)) return 0.0;
  return 2.0 * std::sqrt(3.0) * (b - a).cross(c - a).norm() / sum2;  // area = |cross| / 2
}

double relaxation_min_gap(const ContactPrimitives& primitives, const Positions& x, double offset, double reach,
                          const std::vector<char>& free_mask) {
  if (!(reach >= 0.0) || !(offset >= 0.0))
    throw std::invalid_argument("relaxation_min_gap: offset and reach must be >= 0 (m)");
  const double limit = offset + reach;
  const CandidatePairs pairs = find_candidates(primitives, x, limit);
  const auto counts = [&](std::initializer_list<int> verts) {
    if (free_mask.empty()) return true;
    for (int v : verts)
      if (free_mask[static_cast<std::size_t>(v)]) return true;
    return false;
  };
  const auto row = [&](int v) -> Vec3 { return x.row(v).transpose(); };
  double gap = std::numeric_limits<double>::infinity();
  for (const auto& [v, f] : pairs.point_triangle) {
    const int a = primitives.faces(f, 0), b = primitives.faces(f, 1), c = primitives.faces(f, 2);
    if (!counts({v, a, b, c})) continue;
    Vec<12> x12;
    x12 << row(v), row(a), row(b), row(c);
    const double d = std::sqrt(point_triangle_squared_distance(x12));
    if (d < limit) gap = std::min(gap, d - offset);
  }
  for (const auto& [ea, eb] : pairs.edge_edge) {
    const auto& A = primitives.edges[static_cast<std::size_t>(ea)];
    const auto& B = primitives.edges[static_cast<std::size_t>(eb)];
    if (!counts({A[0], A[1], B[0], B[1]})) continue;
    Vec<12> x12;
    x12 << row(A[0]), row(A[1]), row(B[0]), row(B[1]);
    const double d = std::sqrt(edge_edge_squared_distance(x12));
    if (d < limit) gap = std::min(gap, d - offset);
  }
  return gap;
}

RelaxationReport relax_gaps(const RelaxationMesh& mesh, const std::vector<int>& free_vertices,
                            const GapRelaxationSettings& settings, Positions& x, std::vector<Positions>* iterates) {
  const char* who = "relax_gaps";
  const int n = check_mesh(mesh, x, who);
  std::vector<char> mask = free_mask_of(free_vertices, n, who);
  if (!(settings.min_gap > 0.0) || !std::isfinite(settings.min_gap))
    throw std::invalid_argument("relax_gaps: min_gap must be finite and > 0 (m)");
  check_counts(settings.max_stiffness_rounds, settings.newton_iterations_per_round, settings.anchor_stiffness, who);
  if (std::isnan(settings.keep_start_shape_within))
    throw std::invalid_argument("relax_gaps: keep_start_shape_within must not be NaN");

  const ContactPrimitives& prims = *mesh.primitives;
  const double reach = kGapReachFactor * settings.min_gap;
  const double dhat = mesh.offset + reach;  // the barrier's activation distance (its offset is 0)
  check_start_contact(prims, x, dhat, who);

  RelaxationReport report;
  const Setup s = make_setup(mesh, n, std::move(mask), x);
  report.skipped_faces = s.skipped_faces;
  report.min_gap_before = relaxation_min_gap(prims, x, mesh.offset, reach, s.free_mask);
  report.min_relative_quality_before = min_relative_quality(s, x);
  if (free_vertices.empty()) {  // nothing can move
    report.min_gap_after = report.min_gap_before;
    report.min_relative_quality_after = report.min_relative_quality_before;
    report.satisfied = report.min_gap_before >= settings.min_gap;
    return report;
  }

  // The membrane's reference per face (header, GapRelaxationSettings::keep_start_shape_within).
  const Faces& F = prims.faces;
  std::vector<int> reshaped, start_shaped;
  for (int f : s.membrane_faces) {
    const Vec<9> X = gather_face(*mesh.rest, F, f);
    const Eigen::Vector2d sigma =
        principal_stretches(gather_face(x, F, f), strain_limit_rest(X.segment<3>(0), X.segment<3>(3), X.segment<3>(6)));
    const double k = settings.keep_start_shape_within;
    const bool keep = sigma[0] <= k && sigma[1] * k >= 1.0 && !rest_degenerate(x, F, f);
    (keep ? start_shaped : reshaped).push_back(f);
  }
  IncrementalPotential ip;
  const double reach_b = dhat - mesh.offset;
  double kappa = kStartKappa * kMembraneScale / (reach_b * reach_b);  // J/m^4 (header: "Starting kappa")
  BarrierPotential* barrier =
      build_potential(s, {{1.0, reshaped}}, dhat, kappa, settings.anchor_stiffness, s.start, ip, start_shaped);
  NewtonSettings ns = newton_settings(s, dhat, settings.newton_iterations_per_round);
  record_iterates(s, x, iterates, ns);
  HessianAssembly hessian;
  CholmodSolver solver;
  Eigen::VectorXd xs = s.start;
  double gap = report.min_gap_before;
  for (int round = 1; round <= settings.max_stiffness_rounds; ++round) {
    barrier->set_kappa(kappa);
    const NewtonReport nr = newton_minimize(ip, xs, ns, hessian, solver);
    report.rounds = round;
    report.newton_iterations += nr.iterations;
    write_free(s, xs, x);
    const double before = gap;
    gap = relaxation_min_gap(prims, x, mesh.offset, reach, s.free_mask);
    if (gap >= settings.min_gap) break;
    // A stalled solve (header, "Stalls"): a stiffer barrier does not help Newton steps that the
    // line search cuts to nothing.
    if (settings.stop_when_stalled && !nr.converged && !(gap > kStallGrowth * before)) {
      report.stalled = true;
      break;
    }
    kappa *= 2.0;
  }
  report.min_gap_after = gap;
  report.min_relative_quality_after = min_relative_quality(s, x);
  report.satisfied = gap >= settings.min_gap;
  return report;
}

RelaxationReport relax_strain(const RelaxationMesh& mesh, const std::vector<int>& free_vertices,
                              const std::vector<double>& face_limit, const StrainRelaxationSettings& settings,
                              Positions& x, std::vector<Positions>* iterates) {
  const char* who = "relax_strain";
  const int n = check_mesh(mesh, x, who);
  std::vector<char> mask = free_mask_of(free_vertices, n, who);
  const ContactPrimitives& prims = *mesh.primitives;
  const Faces& F = prims.faces;
  if (static_cast<Eigen::Index>(face_limit.size()) != F.rows())
    throw std::invalid_argument("relax_strain: face_limit needs one entry per face");
  for (double l : face_limit)
    if (!(l == 0.0 || (std::isfinite(l) && l > 1.0)))
      throw std::invalid_argument("relax_strain: a face limit must be 0 (none) or a finite value > 1");
  if (!(settings.target_fraction >= 0.0 && settings.target_fraction < 1.0))
    throw std::invalid_argument("relax_strain: target_fraction must lie in [0, 1)");
  check_counts(settings.max_rounds, settings.newton_iterations_per_round, settings.anchor_stiffness, who);
  const double dhat = mesh.offset + settings.contact_gap;
  RelaxationReport report;
  const Setup s = begin_fixed_barrier_solve(mesh, n, std::move(mask), x, settings.contact_gap, who, report);

  // Limited faces with a usable rest triangle; those with a degenerate rest have no stretch.
  struct Limited {
    int face;
    StrainLimitRest rest;
    double goal;   // limit * (1 - target_fraction)
    double limit;
    bool movable;  // has a free vertex
  };
  std::vector<Limited> limited;
  for (int f = 0; f < F.rows(); ++f) {
    const double l = face_limit[static_cast<std::size_t>(f)];
    if (l == 0.0) continue;
    const bool movable = has_free_vertex(F, f, s.free_mask);
    if (rest_degenerate(*mesh.rest, F, f)) {
      if (!movable) ++report.skipped_faces;  // movable ones are already counted by make_setup
      continue;
    }
    const Vec<9> X = gather_face(*mesh.rest, F, f);
    limited.push_back({f, strain_limit_rest(X.segment<3>(0), X.segment<3>(3), X.segment<3>(6)),
                       l * (1.0 - settings.target_fraction), l, movable});
  }
  // Worst stretch, worst ratio sigma / limit over movable faces, and the movable faces over their goal.
  const auto measure = [&](const Positions& V, double& max_stretch, double& max_ratio, bool& all_met,
                           std::vector<int>* violating) {
    max_stretch = 0.0;
    max_ratio = 0.0;
    all_met = true;
    for (const Limited& L : limited) {
      const double sigma = principal_stretches(gather_face(V, F, L.face), L.rest)[0];
      max_stretch = std::max(max_stretch, sigma);
      const bool met = sigma <= L.goal;
      all_met = all_met && met;
      if (!L.movable) continue;
      max_ratio = std::max(max_ratio, sigma / L.limit);
      if (!met && violating) violating->push_back(L.face);
    }
  };
  double ratio = 0.0;
  bool met = false;
  std::vector<int> violating;
  measure(x, report.max_stretch_before, ratio, met, &violating);
  report.max_stretch_after = report.max_stretch_before;
  report.min_gap_after = report.min_gap_before;
  report.min_relative_quality_after = report.min_relative_quality_before;
  report.satisfied = met;
  if (violating.empty()) return report;  // nothing the free vertices can fix: leave x untouched

  // Membrane weight per face (powers of two, so faces group into few terms).
  std::map<int, double> weight;
  for (int f : s.membrane_faces) weight[f] = 1.0;
  NewtonSettings ns = newton_settings(s, dhat, settings.newton_iterations_per_round);
  record_iterates(s, x, iterates, ns);
  HessianAssembly hessian;
  CholmodSolver solver;
  Eigen::VectorXd xs = s.start;
  const double kappa = kMembraneScale / (settings.contact_gap * settings.contact_gap);
  for (int round = 1; round <= settings.max_rounds; ++round) {
    std::map<double, std::vector<int>> groups;
    for (const auto& [f, w] : weight) groups[w].push_back(f);
    IncrementalPotential ip;
    build_potential(s, groups, dhat, kappa, settings.anchor_stiffness, s.start, ip);
    const NewtonReport nr = newton_minimize(ip, xs, ns, hessian, solver);
    report.rounds = round;
    report.newton_iterations += nr.iterations;
    write_free(s, xs, x);

    double new_ratio = 0.0;
    violating.clear();
    measure(x, report.max_stretch_after, new_ratio, met, &violating);
    if (violating.empty() || (settings.stop_without_progress && new_ratio > ratio * (1.0 - kMinStrainProgress)))
      break;
    ratio = new_ratio;
    for (int f : violating) {
      auto it = weight.find(f);
      if (it != weight.end()) it->second *= 2.0;  // faces skipped by the membrane have no weight
    }
  }
  report.satisfied = met;
  report.min_gap_after = relaxation_min_gap(prims, x, mesh.offset, settings.contact_gap, s.free_mask);
  report.min_relative_quality_after = min_relative_quality(s, x);
  return report;
}

RelaxationReport relax_toward(const RelaxationMesh& mesh, const std::vector<int>& free_vertices, const Positions& aim,
                              const TargetRelaxationSettings& settings, Positions& x, std::vector<Positions>* iterates) {
  const char* who = "relax_toward";
  const int n = check_mesh(mesh, x, who);
  std::vector<char> mask = free_mask_of(free_vertices, n, who);
  if (aim.rows() != n || aim.cols() != 3 || !aim.allFinite())
    throw std::invalid_argument("relax_toward: aim must be finite, one row per vertex");
  if (!(settings.target_stiffness > 0.0) || !std::isfinite(settings.target_stiffness))
    throw std::invalid_argument("relax_toward: target_stiffness must be finite and > 0");
  check_counts(1, settings.newton_iterations, 0.0, who);
  const ContactPrimitives& prims = *mesh.primitives;
  const double dhat = mesh.offset + settings.contact_gap;
  RelaxationReport report;
  const Setup s = begin_fixed_barrier_solve(mesh, n, std::move(mask), x, settings.contact_gap, who, report);
  const auto max_distance = [&](const Positions& V) {
    double d = 0.0;
    for (int v = 0; v < n; ++v)
      if (s.free_mask[static_cast<std::size_t>(v)]) d = std::max(d, (V.row(v) - aim.row(v)).norm());
    return d;
  };
  report.max_target_distance_before = max_distance(x);

  IncrementalPotential ip;
  const double kappa = kMembraneScale / (settings.contact_gap * settings.contact_gap);
  build_potential(s, {{1.0, s.membrane_faces}}, dhat, kappa, settings.target_stiffness, stacked(aim), ip);
  NewtonSettings ns = newton_settings(s, dhat, settings.newton_iterations);
  record_iterates(s, x, iterates, ns);
  HessianAssembly hessian;
  CholmodSolver solver;
  Eigen::VectorXd xs = s.start;
  const NewtonReport nr = newton_minimize(ip, xs, ns, hessian, solver);
  report.rounds = 1;
  report.newton_iterations = nr.iterations;
  write_free(s, xs, x);
  report.satisfied = nr.converged;
  report.min_gap_after = relaxation_min_gap(prims, x, mesh.offset, settings.contact_gap, s.free_mask);
  report.min_relative_quality_after = min_relative_quality(s, x);
  report.max_target_distance_after = max_distance(x);
  return report;
}

}  // namespace pd
