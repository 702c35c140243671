// Cost of one implicit time step while contact is established, split into the contact term's
// pieces (broad phase, CCD, barrier assembly) and the solver's (assembly, factorization, solve),
// for two cotton scenes at about 6K and 25K cloth vertices:
//
//   sphere  a horizontal 0.8 m square dropped onto a fixed icosphere (r = 0.2 m, 4 subdivisions,
//           2562 vertices) above the ground, as scenes/drape-sphere.json, but starting 2 mm above
//           the sphere instead of 40 mm: at 25K vertices the contact steps take 1-3 minutes each,
//           and the free fall would only add steps before them;
//   fold    a 0.8 m square lying on the ground folded in half around a 10 mm loop, its upper layer
//           20 mm above the lower one: the upper layer falls onto the lower one (self-contact).
//
// Both use drape-sphere.json's contact: dhat 1 mm, offset 0.5 mm, friction 0.3 (mesh and ground),
// self-contact on, adaptive kappa, h = 10 ms, default solver settings.
//
// Each run steps from rest until the mesh barrier reports enough active pairs (warm-up, printed
// step by step), then measures K steps. How the split is measured, without touching the library:
// every term of the system's incremental potential is wrapped in a forwarding term that times its
// calls (value, add_gradient, add_hessian, max_step, begin_step), so per-term times are those of the
// real solve. What the wrapper cannot see is the inside of BarrierPotential's calls: its broad phase
// (find_candidates, run inside value/gradient/hessian whenever x differs from the last x it saw) and
// the swept broad phase inside max_step. For those the wrapper records the states the solve passed
// (every distinct x given to the mesh barrier, every (x, dx) given to its max_step) and after the
// step re-runs find_candidates / find_swept_candidates on exactly those states, once each, timed.
// Also after each step, at its final state: HessianAssembly::finish with a new and with an unchanged
// sparsity pattern, and one CHOLMOD analysis + factorization (see StepMeasure).
//
//   pd_bench_contact_step                     # both scenes at 77 and 157 cells per side
//   pd_bench_contact_step sphere 77           # one scene, given sizes (cells per side)
//   pd_bench_contact_step fold 157 --steps 5 --gap 0.01
//     --steps K   measured steps (default 3)
//     --gap g     sphere: start the cloth g metres above the sphere's top (default 0.002; the
//                 scene file has 0.04); fold: layers g apart, loop radius g / 2 (default 0.02)
//     --warmup N  at most N warm-up steps (default 60)
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "geometry/shapes.h"
#include "physics/contact/barrier_potential.h"
#include "physics/contact/broad_phase.h"
#include "physics/contact/ground_barrier.h"
#include "physics/hessian_assembly.h"
#include "progressive/contact_control.h"
#include "progressive/level_stepper.h"
#include "solver/cholmod_solver.h"
#include "util/process_setup.h"

using namespace pd;

namespace {

using Clock = std::chrono::steady_clock;
constexpr double kPi = 3.14159265358979323846;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

struct CallTimes {
  int calls = 0;
  double seconds = 0.0;
  void add(Clock::time_point t0) {
    seconds += since(t0);
    ++calls;
  }
};

struct TermTimes {
  CallTimes value, gradient, hessian, max_step, begin_step;
};

// Forwards every call to a term owned elsewhere and times it. When `record` is set (the mesh barrier
// during measured steps) it also keeps the states the broad phase ran on, for re-timing.
class TimedTerm final : public EnergyTerm {
 public:
  explicit TimedTerm(EnergyTerm* inner) : inner_(inner) {}

  std::string name() const override { return inner_->name(); }
  double value(const Eigen::VectorXd& x) const override {
    note_state(x);
    const auto t0 = Clock::now();
    const double e = inner_->value(x);
    times.value.add(t0);
    return e;
  }
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const override {
    note_state(x);
    const auto t0 = Clock::now();
    inner_->add_gradient(x, grad);
    times.gradient.add(t0);
  }
  void add_hessian(const Eigen::VectorXd& x, HessianProjection projection, HessianAssembly& h) const override {
    note_state(x);
    const auto t0 = Clock::now();
    inner_->add_hessian(x, projection, h);
    times.hessian.add(t0);
  }
  void begin_step(const StepStart& step) override {
    const auto t0 = Clock::now();
    inner_->begin_step(step);
    times.begin_step.add(t0);
  }
  double max_step(const Eigen::VectorXd& x, const Eigen::VectorXd& dx) const override {
    if (record) ccd_states.emplace_back(x, dx);
    const auto t0 = Clock::now();
    const double a = inner_->max_step(x, dx);
    times.max_step.add(t0);
    return a;
  }

  mutable TermTimes times;
  bool track_states = false;  // mirror BarrierPotential's one-entry candidate cache
  bool record = false;        // keep the states (measured steps only)
  mutable std::vector<Eigen::VectorXd> broad_states;  // x at which the barrier ran find_candidates
  mutable std::vector<std::pair<Eigen::VectorXd, Eigen::VectorXd>> ccd_states;  // (x, dx) of max_step
  mutable Eigen::VectorXd last_x;  // the x the barrier's candidate cache holds (see note_state)

 private:
  // BarrierPotential re-runs its broad phase exactly when x differs bit for bit from the last x it
  // evaluated. Its other callers (ContactControl's stats / min_gap, friction lagging) only ask at
  // states the solve has just evaluated through this wrapper (the accepted iterate, the step's start
  // = the previous step's end), so comparing with the last x seen here finds the same cache misses.
  void note_state(const Eigen::VectorXd& x) const {
    if (!track_states) return;
    if (last_x.size() == x.size() && last_x == x) return;
    last_x = x;
    if (record) broad_states.push_back(x);
  }

  EnergyTerm* inner_;
};

struct Options {
  std::vector<std::string> scenes = {"sphere", "fold"};
  std::vector<int> sizes = {77, 157};
  int steps = 3;
  int max_warmup = 60;
  double gap = -1.0;  // scene default
};

// A 0.8 m cotton square (the "cotton" preset of drape-sphere.json), `cells` per side, in
// make_rectangle's x-y plane; the scenes pose it.
SceneObject cotton_square(int cells) {
  SceneObject cloth;
  cloth.name = "cloth";
  cloth.rest = make_rectangle(0.8, 0.8, cells, cells);
  cloth.material.density = 472.6;  // kg/m^3
  cloth.material.youngs_modulus = 8.21e5;  // Pa
  cloth.material.poisson_ratio = 0.243;
  cloth.material.thickness = 3.18e-4;  // m
  cloth.self_contact = true;
  return cloth;
}

Scene contact_scene(const std::string& name) {
  Scene scene;
  scene.name = name;
  scene.source_path = "pd_bench_contact_step(" + name + ")";
  scene.time_step = 0.01;  // s
  ContactConfig c;
  c.dhat = 1e-3;     // m
  c.offset = 5e-4;   // m
  c.friction = 0.3;
  scene.contact = c;
  Ground g;
  g.height = 0.0;
  g.friction = 0.3;
  scene.ground = g;
  return scene;
}

// drape-sphere.json at `cells` per side: sphere of radius 0.2 m centred 0.21 m up, cloth flat `gap`
// metres above its top (the scene file has 0.04 m).
Scene sphere_scene(int cells, double gap) {
  Scene scene = contact_scene("sphere");
  SceneObject cloth = cotton_square(cells);
  const double y = 0.41 + gap;
  Positions V(cloth.rest.V.rows(), 3);
  // make_rectangle's x-y plane laid horizontally (x-z) at height y.
  for (int i = 0; i < V.rows(); ++i) V.row(i) << cloth.rest.V(i, 0), y, -cloth.rest.V(i, 1);
  cloth.rest.V = V;
  cloth.initial = V;
  scene.objects.push_back(cloth);

  SceneObject sphere;
  sphere.name = "sphere";
  sphere.rest = make_icosphere(0.2, 4);
  sphere.rest.V.col(1).array() += 0.21;
  sphere.initial = sphere.rest.V;
  sphere.obstacle = true;
  scene.objects.push_back(sphere);
  return scene;
}

// The square folded in half about a line along x: the lower layer lies 1 mm above the ground
// (within dhat of it, as self-fold.json's sheet), a half-circle loop of radius R joins it to the
// upper layer 2 R higher. The rest shape is flat, so the loop pushes back with a bending moment D / R
// (about 2.3e-4 N m/m at R = 10 mm), some 500 times less than the upper layer's weight about the fold
// (0.12 N m/m): the upper layer comes down onto the lower one over nearly its whole area.
Scene fold_scene(int cells, double gap) {
  Scene scene = contact_scene("fold");
  SceneObject cloth = cotton_square(cells);
  const double R = 0.5 * gap, y0 = 1e-3;
  const double s_a = 0.4 - 0.5 * kPi * R, s_b = 0.4 + 0.5 * kPi * R;  // loop between arc lengths
  Positions V(cloth.rest.V.rows(), 3);
  for (int i = 0; i < V.rows(); ++i) {
    const double x = cloth.rest.V(i, 0), s = cloth.rest.V(i, 1) + 0.4;  // arc length across the fold, m
    if (s <= s_a) {
      V.row(i) << x, y0, s - s_a;
    } else if (s >= s_b) {
      V.row(i) << x, y0 + 2 * R, s_b - s;
    } else {
      const double phi = (s - s_a) / R;
      V.row(i) << x, y0 + R * (1 - std::cos(phi)), R * std::sin(phi);
    }
  }
  cloth.initial = V;
  scene.objects.push_back(cloth);
  return scene;
}

double stat(const FrameRecord& r, const char* key) {
  for (const auto& [k, v] : r.contact)
    if (k == key) return v;
  return 0.0;
}

struct StepMeasure {
  int iterations = 0, cuts = 0;
  double step = 0, assemble = 0, analyse = 0, factorize = 0, solve = 0, line_search = 0;
  std::map<std::string, TermTimes> terms;  // summed over the terms of each name
  int broad_calls = 0;
  double broad = 0;                        // re-timed find_candidates, s
  long broad_pairs = 0;                    // candidates found over those calls
  int swept_calls = 0;
  double swept = 0;                        // re-timed find_swept_candidates, s
  long swept_pairs = 0;
  int active_pt = 0, active_ee = 0, active_ground = 0;
  double min_gap = 0;
  // Re-timed at the step's final state: HessianAssembly::finish with a new pattern (sorting the
  // element entries into a fresh sparse structure) and with an unchanged one (scatter only), and
  // CHOLMOD's symbolic analysis and numeric factorization of that matrix, s.
  double finish_rebuild = 0, finish_reuse = 0, analyse_call = 0, factorize_call = 0;
};

void add(CallTimes& a, const CallTimes& b) {
  a.calls += b.calls;
  a.seconds += b.seconds;
}

void add(TermTimes& a, const TermTimes& b) {
  add(a.value, b.value);
  add(a.gradient, b.gradient);
  add(a.hessian, b.hessian);
  add(a.max_step, b.max_step);
  add(a.begin_step, b.begin_step);
}

double ms(double s) { return 1e3 * s; }

void run(const std::string& which, int cells, const Options& opt) {
  const double gap = opt.gap > 0 ? opt.gap : (which == "sphere" ? 0.002 : 0.02);
  const Scene scene = which == "sphere" ? sphere_scene(cells, gap) : fold_scene(cells, gap);
  SceneSystem sys = build_scene_system(scene);
  check_start_state(scene, sys);

  // Put a timing wrapper in front of every term. The original potential keeps owning the terms (so
  // ContactControl's and the pin target's pointers stay valid); the system's potential only forwards.
  IncrementalPotential owner = std::move(sys.ip);
  sys.ip = IncrementalPotential();
  std::vector<TimedTerm*> timed;
  TimedTerm* mesh_timer = nullptr;
  for (const auto& t : owner.terms()) {
    auto w = std::make_unique<TimedTerm>(t.get());
    if (t.get() == static_cast<EnergyTerm*>(sys.contact.mesh)) mesh_timer = w.get();
    timed.push_back(w.get());
    sys.ip.add_term(std::move(w));
  }
  sys.ip.set_fixed_dofs(owner.fixed_dofs());
  mesh_timer->track_states = true;
  const BarrierPotential& mesh = *sys.contact.mesh;
  const double r_broad = mesh.settings().dhat + mesh.settings().offset;

  const int cloth_vertices = scene.objects[0].rest.num_vertices();
  const int obstacle_vertices = sys.rest.num_vertices() - cloth_vertices;
  // Warm-up ends when the mesh barrier has this many active pairs. Proportional to the vertex count,
  // so that both resolutions are measured at about the same contact area: on the sphere a cap a few
  // cm across (the 6K cloth reaches it about 5 steps after first contact); in the fold the upper
  // layer has landed (about 3 pairs per upper-layer vertex).
  const int target_pairs = which == "sphere" ? cloth_vertices / 16 : cloth_vertices;
  std::printf("\n== %s, %d x %d cells: %d cloth vertices, %d obstacle vertices, %d faces; %s %.1f mm\n",
              which.c_str(), cells, cells, cloth_vertices, obstacle_vertices, sys.rest.num_faces(),
              which == "sphere" ? "cloth starts above the sphere's top by" : "layers start apart by", ms(gap));
  std::printf("warm-up until the mesh barrier has >= %d active pairs (at most %d steps)\n", target_pairs,
              opt.max_warmup);
  std::printf("%5s %4s %5s %8s %8s %8s %10s %9s\n", "step", "its", "cuts", "PT", "EE", "ground", "min gap mm", "step s");

  LevelStepper stepper(sys, scene.solver, scene.time_step);
  Eigen::VectorXd x = sys.x0, v = sys.v0;
  int frame = 0;
  const auto warm0 = Clock::now();
  auto print_row = [&](const FrameRecord& r) {
    const ContactStats mesh_stats = mesh.stats(x);
    const ContactStats gs = sys.contact.ground ? sys.contact.ground->stats(x) : ContactStats{};
    std::printf("%5d %4d %5d %8d %8d %8d %10.4f %9.2f  %s\n", r.frame, r.newton.iterations, r.newton.line_search_cuts,
                mesh_stats.active_point_triangle, mesh_stats.active_edge_edge, gs.active_point_triangle,
                ms(stat(r, "contact_min_gap")), r.seconds, r.newton.stop_reason.c_str());
    std::fflush(stdout);
    return mesh_stats.active_point_triangle + mesh_stats.active_edge_edge;
  };
  while (frame < opt.max_warmup) {
    const FrameRecord r = stepper.step(frame, x, v);
    ++frame;
    if (print_row(r) >= target_pairs) break;
  }
  const double warm_seconds = since(warm0);
  std::printf("warm-up: %d steps, %.1f s\n", frame, warm_seconds);

  std::vector<StepMeasure> measured;
  for (int k = 0; k < opt.steps; ++k) {
    for (TimedTerm* t : timed) t->times = TermTimes{};
    mesh_timer->record = true;
    const FrameRecord r = stepper.step(frame, x, v);
    ++frame;
    mesh_timer->record = false;
    print_row(r);

    StepMeasure m;
    m.iterations = r.newton.iterations;
    m.cuts = r.newton.line_search_cuts;
    m.step = r.seconds;
    m.assemble = r.newton.assemble_seconds;
    m.analyse = r.newton.analyse_seconds;
    m.factorize = r.newton.factorize_seconds;
    m.solve = r.newton.solve_seconds;
    m.line_search = r.newton.line_search_seconds;
    for (TimedTerm* t : timed) add(m.terms[t->name()], t->times);
    // Re-time the broad phases on the states this step ran them on (once each, outside the step).
    for (const auto& xs : mesh_timer->broad_states) {
      const auto t0 = Clock::now();
      const CandidatePairs p = find_candidates(mesh.primitives(), as_rows(xs), r_broad);
      m.broad += since(t0);
      m.broad_pairs += static_cast<long>(p.point_triangle.size() + p.edge_edge.size());
      ++m.broad_calls;
    }
    for (const auto& [xs, dx] : mesh_timer->ccd_states) {
      const Eigen::VectorXd x1 = xs + dx;
      const auto t0 = Clock::now();
      const CandidatePairs p = find_swept_candidates(mesh.primitives(), as_rows(xs), as_rows(x1), mesh.settings().offset);
      m.swept += since(t0);
      m.swept_pairs += static_cast<long>(p.point_triangle.size() + p.edge_edge.size());
      ++m.swept_calls;
    }
    mesh_timer->broad_states.clear();
    mesh_timer->ccd_states.clear();
    {
      // Through the unwrapped potential, so the per-term timings above stay those of the solve. The
      // barrier's candidate cache already holds x (the stepper's record() evaluated its stats there).
      HessianAssembly ha;
      bool changed = false;
      owner.hessian(x, scene.solver.projection, ha);
      auto t0 = Clock::now();
      ha.finish(&changed);
      m.finish_rebuild = since(t0);
      owner.hessian(x, scene.solver.projection, ha);
      t0 = Clock::now();
      const HessianAssembly::SparseMatrix& H = ha.finish(&changed);
      m.finish_reuse = since(t0);
      CholmodSolver cs;
      cs.factorize(H, true);
      m.analyse_call = cs.analyse_seconds();
      m.factorize_call = cs.factorize_seconds();
    }
    const ContactStats s = mesh.stats(x);
    m.active_pt = s.active_point_triangle;
    m.active_ee = s.active_edge_edge;
    m.active_ground = sys.contact.ground ? sys.contact.ground->stats(x).active_point_triangle : 0;
    m.min_gap = stat(r, "contact_min_gap");
    measured.push_back(std::move(m));
  }

  // Per step: where the wall time went (ms). Columns in the order of docs/performance.md.
  std::printf("\nper measured step, ms (its = Newton iterations, pairs = active mesh pairs PT+EE / ground vertices)\n");
  std::printf("%5s %4s %4s %15s | %7s | %8s %7s %7s %7s %7s | %7s %7s %6s | %8s %7s %7s %7s | %7s\n", "step",
              "its", "cuts", "pairs", "step", "assemble", "elastic", "barrier", "frict", "sparse", "analyse",
              "factor", "solve", "linesrch", "CCD", "swept", "broad", "other");
  for (std::size_t k = 0; k < measured.size(); ++k) {
    const StepMeasure& m = measured[k];
    auto gh = [&](const char* name) {
      const auto it = m.terms.find(name);
      return it == m.terms.end() ? 0.0 : it->second.gradient.seconds + it->second.hessian.seconds;
    };
    double all_gh = 0;
    for (const auto& [name, t] : m.terms) all_gh += t.gradient.seconds + t.hessian.seconds;
    const double other = m.step - m.assemble - m.analyse - m.factorize - m.solve - m.line_search;
    char pairs[32];
    std::snprintf(pairs, sizeof pairs, "%d/%d", m.active_pt + m.active_ee, m.active_ground);
    std::printf("%5d %4d %4d %15s | %7.0f | %8.0f %7.0f %7.0f %7.0f %7.0f | %7.0f %7.0f %6.0f | %8.0f %7.0f %7.0f %7.0f | %7.0f\n",
                frame - opt.steps + 1 + int(k), m.iterations, m.cuts, pairs, ms(m.step), ms(m.assemble),
                ms(gh("membrane") + gh("bending")), ms(gh("contact")), ms(gh("friction")), ms(m.assemble - all_gh),
                ms(m.analyse), ms(m.factorize), ms(m.solve), ms(m.line_search),
                ms(m.terms.at("contact").max_step.seconds), ms(m.swept), ms(m.broad), ms(other));
  }

  // Per call, over all measured steps.
  int its = 0;
  double assemble = 0, factorize = 0, analyse = 0, solve = 0, step = 0, broad = 0, swept = 0;
  double finish_rebuild = 0, finish_reuse = 0, analyse_call = 0, factorize_call = 0;
  int broad_calls = 0, swept_calls = 0;
  long broad_pairs = 0, swept_pairs = 0;
  std::map<std::string, TermTimes> terms;
  for (const StepMeasure& m : measured) {
    its += m.iterations;
    assemble += m.assemble;
    factorize += m.factorize;
    analyse += m.analyse;
    solve += m.solve;
    step += m.step;
    broad += m.broad;
    swept += m.swept;
    broad_calls += m.broad_calls;
    swept_calls += m.swept_calls;
    broad_pairs += m.broad_pairs;
    swept_pairs += m.swept_pairs;
    finish_rebuild += m.finish_rebuild;
    finish_reuse += m.finish_reuse;
    analyse_call += m.analyse_call;
    factorize_call += m.factorize_call;
    for (const auto& [name, t] : m.terms) add(terms[name], t);
  }
  const int K = static_cast<int>(measured.size());
  const TermTimes& c = terms.at("contact");
  auto per = [](double s, int n) { return n ? 1e3 * s / n : 0.0; };
  std::printf("\nmeans over %d steps: %.1f its/step, step %.0f ms; per iteration: assemble %.1f ms, factorize %.1f ms, "
              "solve %.2f ms; analyse %.1f ms/step\n",
              K, double(its) / K, per(step, K), per(assemble, its), per(factorize, its), per(solve, its),
              per(analyse, K));
  std::printf("broad phase (find_candidates, r = %.2g m, re-timed): %.2f calls/step, %.2f ms/call, %.0f candidates/call\n",
              r_broad, double(broad_calls) / K, per(broad, broad_calls),
              broad_calls ? double(broad_pairs) / broad_calls : 0.0);
  std::printf("CCD (mesh max_step, in situ): %.2f calls/step, %.2f ms/call; of which swept broad phase (re-timed) "
              "%.2f ms/call, %.0f candidates/call\n",
              double(c.max_step.calls) / K, per(c.max_step.seconds, c.max_step.calls), per(swept, swept_calls),
              swept_calls ? double(swept_pairs) / swept_calls : 0.0);
  std::printf("at the final states (re-timed): finish %.1f ms with a new pattern, %.1f ms reusing it; analyse %.1f ms, "
              "factorize %.1f ms per call => about %.1f analyses/step\n",
              per(finish_rebuild, K), per(finish_reuse, K), per(analyse_call, K), per(factorize_call, K),
              analyse_call > 0 ? analyse / analyse_call : 0.0);
  std::printf("%-10s %22s %22s %22s %22s %16s\n", "term", "value calls/step ms/c", "gradient calls/st ms/c",
              "hessian calls/st ms/c", "max_step calls/st ms/c", "begin_step ms/st");
  for (const auto& [name, t] : terms)
    std::printf("%-10s %10.1f %11.2f %10.1f %11.2f %10.1f %11.2f %10.1f %11.2f %16.2f\n", name.c_str(),
                double(t.value.calls) / K, per(t.value.seconds, t.value.calls), double(t.gradient.calls) / K,
                per(t.gradient.seconds, t.gradient.calls), double(t.hessian.calls) / K,
                per(t.hessian.seconds, t.hessian.calls), double(t.max_step.calls) / K,
                per(t.max_step.seconds, t.max_step.calls), per(t.begin_step.seconds, K));
  std::printf("check: mesh barrier value() in situ %.0f ms/step >= re-timed broad phase %.0f ms/step\n",
              per(c.value.seconds, K), per(broad, K));
}

}  // namespace

int main(int argc, char** argv) {
  configure_numerical_libraries(argv);
  Options opt;
  std::vector<std::string> scenes;
  std::vector<int> sizes;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--steps" && i + 1 < argc) {
      opt.steps = std::atoi(argv[++i]);
    } else if (a == "--gap" && i + 1 < argc) {
      opt.gap = std::atof(argv[++i]);
    } else if (a == "--warmup" && i + 1 < argc) {
      opt.max_warmup = std::atoi(argv[++i]);
    } else if (a == "sphere" || a == "fold") {
      scenes.push_back(a);
    } else if (std::atoi(a.c_str()) > 0) {
      sizes.push_back(std::atoi(a.c_str()));
    } else {
      std::fprintf(stderr, "usage: %s [sphere|fold]... [cells]... [--steps K] [--gap m] [--warmup N]\n", argv[0]);
      return 2;
    }
  }
  if (!scenes.empty()) opt.scenes = scenes;
  if (!sizes.empty()) opt.sizes = sizes;
  for (const std::string& s : opt.scenes)
    for (int cells : opt.sizes) run(s, cells, opt);
  return 0;
}
