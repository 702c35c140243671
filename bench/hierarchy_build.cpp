// Cost of the level hierarchy (hierarchy/scene_hierarchy.h, store/hierarchy_store.h) and of safe
// upsampling between its levels (hierarchy/safe_upsampling.h), for a cotton sheet and a closed
// cotton shell at about 6K, 25K and 90K finest vertices.
//
//   sheet   a 1 m square, make_rectangle with C x C cells (default 77, 157, 299: 6 084, 24 964,
//           90 000 vertices), pinned at its two top corners (as pd_bench_step_cost);
//   sphere  a closed sphere of radius 0.3 m made from make_box with C x C cells per side, every
//           vertex pushed radially onto the sphere (a "cube sphere"; default 32, 64, 122: 6 146,
//           24 578, 89 306 vertices). Icospheres only come at 10 242 and 40 962 vertices.
//
// One object per scene, cotton material (the cotton preset of scenes/drape-sphere.json), default
// hierarchy (4 levels, ratio 4), contact as drape-sphere.json (dhat 1 mm, offset 0.5 mm), self
// contact on, no ground.
//
// Per size: build_scene_hierarchy wall time, per-level vertex and triangle counts, build seconds
// and rest prolongation error (its report); write_hierarchy into a fresh frame file
// (FrameWriter::create + write_hierarchy, timed together) and read_hierarchy, both timed, and the
// file size. Then safe_upsample for every transition l -> l+1 from two coarse states:
//   rest    x_l = level l's rest positions;
//   bent    x_l = those positions bent analytically: the sheet gets a wave z = 0.05 sin(2 pi x / 0.5)
//           (a height field, so intersection-free), the sphere is squashed to (x, y, 0.6 z);
// target = to_next->apply(x_l) in both. Every UpsamplingReport field is printed.
//
// Time budget: a state (rest / bent) of a shape is skipped at a size when at the previous smaller
// size its upsampling (all transitions together) took more than --budget seconds (default 120), and
// the whole size is skipped when the previous hierarchy build took more than the budget.
//
//   pd_bench_hierarchy                          # sheet 77 157 299, sphere 32 64 122
//   pd_bench_hierarchy sheet 77 sphere 32       # a shape name, then its sizes (cells)
//   pd_bench_hierarchy --budget 300 sheet 299
//   --cap S       stop one safe_upsample call after S seconds (default 300; it runs in a forked
//                 child process for that) and skip the state at larger sizes
//   --max-fine N  skip the transitions to levels of more than N vertices
//   --states rest|bent|both   which coarse states (default both)
//   --file PATH   the HDF5 file for the write/read test (default /tmp/pd_bench_hierarchy.h5; removed)
//   --build-only  only build_scene_hierarchy (time and content hash): no HDF5, no safe upsampling
//   --threads N   threads for the hierarchy's location tasks and element loops (default every core)
//
// Every build prints a "content hash": FNV-1a over every array of the built hierarchy (per object
// level: mesh, maps, collapse records, batches; per scene level: mesh, offsets, both operators'
// locations, U, offsets). SceneHierarchy::hash only digests the inputs, so this is the check that a
// change to the build leaves its result bit-identical.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include "geometry/shapes.h"
#include "hierarchy/safe_upsampling.h"
#include "hierarchy/scene_hierarchy.h"
#include "store/frame_store.h"
#include "store/hierarchy_store.h"
#include "util/fnv1a.h"
#include "util/parallel.h"
#include "util/process_setup.h"
#include "upsampling_report.h"

using namespace pd;

namespace {

using Clock = std::chrono::steady_clock;
constexpr double kPi = 3.14159265358979323846;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

SceneObject cotton(const std::string& name, TriMesh mesh) {
  SceneObject o;
  o.name = name;
  o.rest = std::move(mesh);
  o.initial = o.rest.V;
  o.material.density = 472.6;           // kg/m^3
  o.material.youngs_modulus = 8.21e5;   // Pa
  o.material.poisson_ratio = 0.243;
  o.material.thickness = 3.18e-4;       // m
  o.self_contact = true;
  return o;
}

Scene make_scene(const std::string& shape, int cells) {
  Scene scene;
  scene.name = shape;
  scene.source_path = "pd_bench_hierarchy(" + shape + " " + std::to_string(cells) + ")";
  scene.time_step = 0.01;
  scene.frames = 1;
  ContactConfig c;
  c.dhat = 1e-3;    // m
  c.offset = 5e-4;  // m
  scene.contact = c;
  if (shape == "sheet") {
    SceneObject sheet = cotton("sheet", make_rectangle(1.0, 1.0, cells, cells));
    PinGroup corners;
    corners.vertices = {cells * (cells + 1), (cells + 1) * (cells + 1) - 1};  // top corners
    sheet.pins.push_back(corners);
    scene.objects.push_back(sheet);
  } else {
    TriMesh box = make_box(Vec3(1, 1, 1), cells);
    for (int i = 0; i < box.V.rows(); ++i) box.V.row(i) *= 0.3 / box.V.row(i).norm();
    scene.objects.push_back(cotton("sphere", box));
  }
  return scene;
}

// The analytic deformation of the "bent" state.
Positions bend(const std::string& shape, const Positions& X) {
  Positions x = X;
  if (shape == "sheet") {
    for (int i = 0; i < x.rows(); ++i) x(i, 2) = 0.05 * std::sin(2 * kPi * X(i, 0) / 0.5);
  } else {
    x.col(2) *= 0.6;
  }
  return x;
}

struct Options {
  std::vector<std::pair<std::string, std::vector<int>>> runs;
  double budget = 120.0;
  double cap = 300.0;
  int max_fine = 0;            // > 0: skip transitions to a level with more vertices
  std::vector<int> states = {0, 1};  // 0 rest, 1 bent
  std::string file = "/tmp/pd_bench_hierarchy.h5";
  bool build_only = false;
};

// FNV-1a (util/fnv1a.h) over every array of a hierarchy, doubles bit for bit; sizes go first so that
// arrays that split differently hash apart.
class ContentHash {
 public:
  void bytes(const void* data, std::size_t size) { h_.bytes(data, size); }
  void i64(long long v) { h_.i64(v); }
  template <class T> void vec(const std::vector<T>& v) {
    i64(static_cast<long long>(v.size()));
    if (!v.empty()) bytes(v.data(), v.size() * sizeof(T));
  }
  template <class M> void mat(const M& m) {
    i64(m.rows());
    i64(m.cols());
    for (Eigen::Index i = 0; i < m.rows(); ++i)
      for (Eigen::Index j = 0; j < m.cols(); ++j) {
        const auto x = m(i, j);
        bytes(&x, sizeof x);
      }
  }
  void sparse(const Eigen::SparseMatrix<double>& m) {
    i64(m.rows());
    i64(m.cols());
    for (int k = 0; k < m.outerSize(); ++k)
      for (Eigen::SparseMatrix<double>::InnerIterator it(m, k); it; ++it) {
        i64(it.row());
        i64(it.col());
        const double v = it.value();
        bytes(&v, sizeof v);
      }
  }
  void prolongation(const std::optional<ShellProlongation>& p) {
    i64(p ? 1 : 0);
    if (!p) return;
    for (const SurfaceLocation& s : p->locations()) {
      i64(s.face);
      mat(s.bary);
    }
    sparse(p->U());
    vec(p->normal_offsets());
    for (const Eigen::Vector2d& t : p->tangent_offsets()) mat(t);
  }
  std::uint64_t value() const { return h_.value(); }

 private:
  Fnv1a h_;
};

std::uint64_t content_hash(const SceneHierarchy& h) {
  ContentHash c;
  for (const ObjectHierarchy& oh : h.objects) {
    for (const Level& lv : oh.levels) {
      c.mat(lv.mesh.V);
      c.mat(lv.mesh.F);
      c.vec(lv.to_finest);
      c.vec(lv.coarse_to_fine);
      c.vec(lv.fine_to_coarse);
      c.i64(static_cast<long long>(lv.collapses.size()));
      for (const Collapse& k : lv.collapses) {
        c.i64(k.removed);
        c.i64(k.kept);
        c.mat(k.removed_position);
        c.mat(k.kept_position_before);
        c.mat(k.kept_position_after);
        c.vec(k.faces_before);
        c.vec(k.faces_after);
      }
    }
    for (const auto& level_batches : oh.batches) {
      c.i64(static_cast<long long>(level_batches.size()));
      for (const std::vector<int>& b : level_batches) c.vec(b);
    }
  }
  for (const SceneLevel& s : h.levels) {
    c.mat(s.rest.V);
    c.mat(s.rest.F);
    c.vec(s.vertex_offsets);
    c.vec(s.face_offsets);
    c.vec(s.to_finest);
    c.prolongation(s.to_next);
    c.prolongation(s.to_finest_prolongation);
  }
  return c.value();
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--budget" && i + 1 < argc) {
      o.budget = std::atof(argv[++i]);
    } else if (a == "--max-fine" && i + 1 < argc) {
      o.max_fine = std::atoi(argv[++i]);
    } else if (a == "--states" && i + 1 < argc) {
      const std::string v = argv[++i];
      o.states = v == "rest" ? std::vector<int>{0} : v == "bent" ? std::vector<int>{1} : std::vector<int>{0, 1};
    } else if (a == "--cap" && i + 1 < argc) {
      o.cap = std::atof(argv[++i]);
    } else if (a == "--file" && i + 1 < argc) {
      o.file = argv[++i];
    } else if (a == "--build-only") {
      o.build_only = true;
    } else if (a == "--threads" && i + 1 < argc) {
      const int n = std::atoi(argv[++i]);
      if (n < 1) {
        std::fprintf(stderr, "pd_bench_hierarchy: --threads wants a count >= 1, got %s\n", argv[i]);
        std::exit(2);
      }
      pd::set_element_threads(n);
    } else if (a == "sheet" || a == "sphere") {
      o.runs.push_back({a, {}});
    } else if (!o.runs.empty() && std::atoi(a.c_str()) > 0) {
      o.runs.back().second.push_back(std::atoi(a.c_str()));
    } else {
      std::fprintf(stderr, "pd_bench_hierarchy: unknown argument %s\n", a.c_str());
      std::exit(2);
    }
  }
  if (o.runs.empty()) o.runs = {{"sheet", {77, 157, 299}}, {"sphere", {32, 64, 122}}};
  for (auto& r : o.runs)
    if (r.second.empty()) r.second = r.first == "sheet" ? std::vector<int>{77, 157, 299} : std::vector<int>{32, 64, 122};
  return o;
}

// One line of the summary tables printed at the end (markdown).
std::vector<std::string> build_rows, upsample_rows;

std::string fmt(const char* f, ...) __attribute__((format(printf, 1, 2)));
std::string fmt(const char* f, ...) {
  char buf[1024];
  va_list ap;
  va_start(ap, f);
  std::vsnprintf(buf, sizeof buf, f, ap);
  va_end(ap);
  return buf;
}

// What a forked safe_upsample run sends back through its pipe.
struct Outcome {
  int status = 0;  // 0 done, 1 exception (message), 2 killed at the cap, 3 child lost
  double wall = 0.0;
  UpsamplingReport report;
  char message[512] = {};
};

// safe_upsample in a child process, so that a run longer than `cap` seconds can be stopped (the
// library call has no cancellation). The child works on a copy-on-write image of this process, so
// its timing is that of an ordinary call. OpenMP is limited to one thread
// (configure_numerical_libraries), so no thread pool is lost by fork.
Outcome upsample_forked(const UpsamplingLevel& level, const Positions& x, const Positions& target, double cap) {
  int fd[2];
  if (pipe(fd) != 0) {
    std::perror("pipe");
    std::exit(1);
  }
  std::fflush(stdout);
  const pid_t pid = fork();
  if (pid == 0) {
    close(fd[0]);
    Outcome o;
    const auto t0 = Clock::now();
    try {
      safe_upsample(level, x, target, {}, &o.report);
    } catch (const std::exception& e) {
      o.status = 1;
      std::snprintf(o.message, sizeof o.message, "%s", e.what());
    }
    o.wall = since(t0);
    const char* p = reinterpret_cast<const char*>(&o);
    std::size_t left = sizeof o;
    while (left > 0) {
      const ssize_t w = write(fd[1], p, left);
      if (w <= 0) break;
      p += w;
      left -= static_cast<std::size_t>(w);
    }
    _exit(0);
  }
  close(fd[1]);
  Outcome o;
  pollfd pfd{fd[0], POLLIN, 0};
  const int ready = poll(&pfd, 1, static_cast<int>(cap * 1000));
  if (ready <= 0) {
    kill(pid, SIGKILL);
    waitpid(pid, nullptr, 0);
    close(fd[0]);
    o.status = 2;
    o.wall = cap;
    return o;
  }
  char* p = reinterpret_cast<char*>(&o);
  std::size_t got = 0;
  while (got < sizeof o) {
    const ssize_t r = read(fd[0], p + got, sizeof o - got);
    if (r <= 0) break;
    got += static_cast<std::size_t>(r);
  }
  close(fd[0]);
  waitpid(pid, nullptr, 0);
  if (got < sizeof o) {
    Outcome lost;
    lost.status = 3;
    return lost;
  }
  return o;
}

// Returns the build time, or a negative value when the build failed.
double run_size(const std::string& shape, int cells, const Options& opt, std::vector<double>& state_seconds) {
  const Scene scene = make_scene(shape, cells);
  const int n = scene.objects[0].rest.num_vertices();
  std::printf("\n== %s, %d cells: %d vertices, %d triangles\n", shape.c_str(), cells, n,
              static_cast<int>(scene.objects[0].rest.F.rows()));
  std::fflush(stdout);

  std::vector<HierarchyLevelReport> report;
  const auto t0 = Clock::now();
  SceneHierarchy h;
  try {
    h = build_scene_hierarchy(scene, &report);
  } catch (const std::exception& e) {
    std::printf("build failed: %s\n", e.what());
    build_rows.push_back(fmt("| %s | %d | build failed: %s |", shape.c_str(), n, e.what()));
    return -1.0;
  }
  const double build = since(t0);
  std::string counts, errors;
  for (std::size_t l = 0; l < report.size(); ++l) {
    const HierarchyLevelReport& r = report[l];
    std::printf("level %zu: %7d vertices %7d triangles  build %.3f s  rest prolongation error %.3g m\n", l, r.vertices,
                r.triangles, r.build_seconds, r.rest_prolongation_error);
    counts += fmt("%s%d", l ? " / " : "", r.vertices);
    if (l + 1 < report.size()) errors += fmt("%s%.1e", l ? " / " : "", r.rest_prolongation_error);
  }
  const std::uint64_t content = content_hash(h);
  std::printf("build %.3f s, content hash %016llx\n", build, static_cast<unsigned long long>(content));
  if (opt.build_only) {
    build_rows.push_back(fmt("| %s | %s | %.2f | %016llx | %s |", shape.c_str(), counts.c_str(), build,
                             static_cast<unsigned long long>(content), errors.c_str()));
    return build;
  }

  // HDF5: a fresh frame file, then the hierarchy into it; read back.
  std::filesystem::remove(opt.file);
  const auto t1 = Clock::now();
  {
    FrameWriter w = FrameWriter::create(opt.file, "{}", scene.frames);
    w.close();
  }
  write_hierarchy(opt.file, h, scene_object_names(scene));
  const double write = since(t1);
  const double mib = static_cast<double>(std::filesystem::file_size(opt.file)) / (1024.0 * 1024.0);
  const auto t2 = Clock::now();
  const std::optional<SceneHierarchy> back = read_hierarchy(opt.file);
  const double read = since(t2);
  std::filesystem::remove(opt.file);
  const bool same = back && back->hash == h.hash && back->num_levels() == h.num_levels();
  std::printf("build %.3f s; HDF5 write %.3f s, read %.3f s (%s), file %.2f MiB\n", build, write, read,
              same ? "same hash" : "DIFFERS", mib);
  build_rows.push_back(fmt("| %s | %s | %.2f | %.2f | %.2f | %.2f | %s |", shape.c_str(), counts.c_str(), build, write,
                           read, mib, errors.c_str()));

  const char* states[2] = {"rest", "bent"};
  for (int s : opt.states) {
    if (state_seconds[static_cast<std::size_t>(s)] > opt.budget) {
      std::printf("-- %s state skipped: at the previous size its upsampling took %.1f s > budget %.0f s\n", states[s],
                  state_seconds[static_cast<std::size_t>(s)], opt.budget);
      upsample_rows.push_back(fmt("| %s | %d | %s | all | skipped: previous size took %.0f s > %.0f s budget |",
                                  shape.c_str(), n, states[s], state_seconds[static_cast<std::size_t>(s)], opt.budget));
      continue;
    }
    double total = 0.0;
    for (int l = 0; l + 1 < h.num_levels(); ++l) {
      const SceneLevel& coarse = h.levels[static_cast<std::size_t>(l)];
      const int fine_n = static_cast<int>(h.levels[static_cast<std::size_t>(l + 1)].rest.V.rows());
      if (opt.max_fine > 0 && fine_n > opt.max_fine) {
        std::printf("%s %d -> %d: skipped (--max-fine %d < %d vertices)\n", states[s], l, l + 1, opt.max_fine, fine_n);
        upsample_rows.push_back(fmt("| %s | %d | %s | %d -> %d | skipped (time) |", shape.c_str(), n, states[s],
                                    static_cast<int>(coarse.rest.V.rows()), fine_n));
        continue;
      }
      const Positions x = s == 0 ? Positions(coarse.rest.V) : bend(shape, coarse.rest.V);
      const auto t3 = Clock::now();
      const UpsamplingLevel level = upsampling_level(scene, h, l);
      const double setup = since(t3);
      const Positions target = coarse.to_next->apply(x);
      const Outcome out = upsample_forked(level, x, target, opt.cap);
      const UpsamplingReport& r = out.report;
      if (out.status != 0) {
        total += setup + (out.status == 3 ? 0.0 : out.wall);
        if (out.status == 2) total = std::max(total, opt.budget + 1);  // larger sizes are skipped
        const std::string why = out.status == 1   ? fmt("failed after %.1f s: %s", out.wall, out.message)
                                : out.status == 2 ? fmt("stopped at the %.0f s cap", opt.cap)
                                                  : std::string("child process lost (crash?)");
        std::printf("%s %d -> %d: %s\n", states[s], l, l + 1, why.c_str());
        upsample_rows.push_back(fmt("| %s | %d | %s | %d -> %d | %s |", shape.c_str(), n, states[s],
                                    static_cast<int>(x.rows()), static_cast<int>(target.rows()), why.c_str()));
        continue;
      }
      const double wall = out.wall;
      total += setup + wall;
      std::printf("%s %d -> %d (%d -> %d vertices): setup %.3f s, wall %.3f s; %s\n", states[s], l, l + 1,
                  static_cast<int>(x.rows()), static_cast<int>(target.rows()), setup, wall,
                  bench::describe_upsampling(r).c_str());
      std::fflush(stdout);
      upsample_rows.push_back(fmt("| %s | %d | %s | %d -> %d | %d | %d | %d (%d) | %d | %d | %d / %d | %d | %.3g / %.3g | "
                                  "%.2g / %.2g | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f |",
                                  shape.c_str(), n, states[s], static_cast<int>(x.rows()),
                                  static_cast<int>(target.rows()), r.batches, r.splits, r.advance_events,
                                  r.close_events, r.stopped_vertices, r.relaxed_patches, r.unopened_splits,
                                  r.final_pull_vertices, r.unresolved_gaps, 1e3 * r.coarse_gap, 1e3 * r.final_gap,
                                  r.max_target_distance, r.rms_target_distance, r.seconds, r.perturb_seconds,
                                  r.advance_seconds, r.relax_seconds, r.pull_seconds, r.strain_seconds,
                                  r.seconds - r.perturb_seconds - r.advance_seconds - r.relax_seconds -
                                      r.pull_seconds - r.strain_seconds,
                                  setup,
                                  r.seconds / build));
    }
    std::printf("%s: upsampling all transitions %.2f s = %.2f x the build\n", states[s], total, total / build);
    state_seconds[static_cast<std::size_t>(s)] = total;
  }
  return build;
}

}  // namespace

int main(int argc, char** argv) {
  configure_numerical_libraries(argv);
  const Options opt = parse(argc, argv);
  std::printf("budget %.0f s per state and size (skips larger sizes after a slower one), cap %.0f s per "
              "upsampling call\n", opt.budget, opt.cap);
  for (const auto& [shape, sizes] : opt.runs) {
    std::vector<double> state_seconds(2, 0.0);
    double build = 0.0;
    for (int cells : sizes) {
      if (build > opt.budget) {
        std::printf("\n== %s, %d cells: skipped, the previous build took %.1f s > budget %.0f s\n", shape.c_str(),
                    cells, build, opt.budget);
        build_rows.push_back(fmt("| %s | %d cells | skipped: previous build %.0f s |", shape.c_str(), cells, build));
        continue;
      }
      build = run_size(shape, cells, opt, state_seconds);
      if (build < 0) break;
    }
  }
  if (opt.build_only) {
    std::printf("\n| shape | vertices per level (0 = coarsest) | build s | content hash | rest prolongation error, "
                "levels 0 / 1 / 2 (m) |\n| --- | --- | ---: | --- | --- |\n");
    for (const std::string& r : build_rows) std::printf("%s\n", r.c_str());
    return 0;
  }
  std::printf("\n| shape | vertices per level (0 = coarsest) | build s | HDF5 write s | read s | file MiB | rest "
              "prolongation error, levels 0 / 1 / 2 (m) |\n| --- | --- | ---: | ---: | ---: | ---: | --- |\n");
  for (const std::string& r : build_rows) std::printf("%s\n", r.c_str());
  std::printf("\n| shape | finest vertices | state | vertices | batches | splits | advance events (close) | stopped | "
              "relaxed patches | unopened splits / short at end | unresolved | gap coarse / final (mm) | target distance max / rms "
              "(m) | s | perturb | advance | relax | pull | strain | other | setup s | s / build |\n| --- | ---: | --- | --- | ---: | "
              "---: | ---: | ---: | ---: | ---: | ---: | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n");
  for (const std::string& r : upsample_rows) std::printf("%s\n", r.c_str());
  return 0;
}
