// pd compare: how far the levels of one or two frame files are from a reference level (PD figures
// 18-19, and the speed-against-error plots): per frame and level the centre-of-mass deviation,
// per-vertex distance on the reference mesh, Hausdorff distance between the simulated surfaces and
// kinetic energy; with --seams, each seam's pop (its jolt against the run's own motion around it; with
// OTHER against the K = 1 run FILE's pop) and the seam jitter of OTHER against FILE.
// Printed as a summary per level (or one JSON object with --json) and written in full as CSV.
// The measures are defined in progressive/error_measures.h and docs/progressive.md.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli_text.h"
#include "commands.h"
#include "frame_file_guard.h"
#include "output_files.h"
#include "progressive/consistency.h"
#include "progressive/error_measures.h"
#include "store/frame_store.h"
#include "store/hierarchy_store.h"
#include "util/input_error.h"

namespace pd::cli {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Two rest meshes are "the same mesh" when every vertex agrees to this (m): far below any mesh
// spacing, far above the round-off of building the same mesh twice.
constexpr double kSameRestTolerance = 1e-9;
// How the CSV's header starts: an existing --csv file that starts otherwise was not written by pd compare.
constexpr const char* kCsvHeadStart = "file,level,frame,";

// The scene's time step from the file's stored scene text (NaN when it cannot be read: the CSV's
// time column is then empty rather than wrong).
double time_step_of(const FrameReader& reader) {
  const nlohmann::json j = nlohmann::json::parse(reader.scene_json(), nullptr, /*allow_exceptions=*/false);
  if (j.is_object() && j.contains("time_step") && j["time_step"].is_number()) return j["time_step"].get<double>();
  return kNaN;
}

nlohmann::json num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

// One input file, open for the whole command.
struct Source {
  explicit Source(const std::string& path) : reader(path) {}
  FrameReader reader;
  double time_step = kNaN;
  std::optional<SceneHierarchy> hierarchy;  // read on first need
  bool hierarchy_read = false;
  const std::optional<SceneHierarchy>& stored_hierarchy() {
    if (!hierarchy_read) hierarchy = read_hierarchy(reader.path()), hierarchy_read = true;
    return hierarchy;
  }
};

// One level series and everything measured on it, per stored frame (NaN where not measured).
struct Measured {
  LevelSeries s;
  std::size_t source = 0;
  Faces surface;                       // the level's faces of simulated objects
  const ShellProlongation* P = nullptr;  // to the finest mesh; null: the series' own positions
  bool reaches_reference = false;      // vertex distance computable
  std::string vd_note;                 // why not (or which frames were skipped)
  std::vector<double> com, vd_mean, vd_p95, vd_max, hausdorff, accel_diff;
  std::vector<double> second_diff;     // m(t), m per frame^2, by frame number 0..N (empty without --seams)
  std::vector<double> pooled_vd;       // every (vertex, frame) distance, for the summary
};

// Whether two levels hold the same mesh: vertex count, object offsets and rest positions.
bool same_mesh(const FrameReader& a, int la, const FrameReader& b, int lb) {
  if (a.num_vertices(la) != b.num_vertices(lb) || a.object_offsets(la) != b.object_offsets(lb)) return false;
  return (a.rest_positions(la) - b.rest_positions(lb)).cwiseAbs().maxCoeff() <= kSameRestTolerance;
}

// Refuses OTHER when it does not hold a run of FILE's scene. Runs of one scene may differ in frame
// count, mode, hierarchy and solver settings, and their scene texts in OBJ paths (e.g. made absolute in
// a copy), so the scene text is not compared; what must agree is the finest level of each file (the
// scene's meshes as given): object names in order, vertices and triangles per object, rest positions.
void check_same_scene(const FrameReader& a, const FrameReader& b) {
  const int la = a.num_levels() - 1, lb = b.num_levels() - 1;
  const std::string head = shown_path(b.path()) + ": is not a run of the scene of " + shown_path(a.path()) + ": ";
  const std::string tail = " (pd compare compares runs of one scene)";
  const std::vector<std::string> na = a.object_names(la), nb = b.object_names(lb);
  if (na != nb) {
    const auto list = [](const std::vector<std::string>& v) {
      std::string out;
      for (const std::string& n : v) out += (out.empty() ? "" : ", ") + echo(n);
      return "[" + echo(out) + "]";
    };
    throw InputError(head + "its objects " + list(nb) + " differ from " + list(na) + tail);
  }
  const std::vector<int> oa = a.object_offsets(la), ob = b.object_offsets(lb);
  for (std::size_t k = 0; k + 1 < oa.size() && k + 1 < ob.size(); ++k)
    if (oa[k + 1] - oa[k] != ob[k + 1] - ob[k])
      throw InputError(head + "object " + echo(na[k]) + " has " + std::to_string(ob[k + 1] - ob[k]) +
                       " vertices on its finest level, not " + std::to_string(oa[k + 1] - oa[k]) + tail);
  if (oa != ob || a.faces(la).rows() != b.faces(lb).rows())
    throw InputError(head + "its finest mesh has " + std::to_string(b.faces(lb).rows()) + " triangles, not " +
                     std::to_string(a.faces(la).rows()) + tail);
  const double d = (a.rest_positions(la) - b.rest_positions(lb)).cwiseAbs().maxCoeff();
  if (!(d <= kSameRestTolerance))
    throw InputError(head + "its finest rest mesh differs (by up to " + std::to_string(d) + " m)" + tail);
}

// How series m reaches the reference mesh for the vertex distance: itself when its own mesh is the
// reference's (the reference itself, its file's finest level against a finest reference, or two
// previews of one scene against each other), else prolonged to its file's finest mesh with the file's
// stored hierarchy; sets the note when neither gives the reference's mesh.
void plan_vertex_distance(Measured& m, Source& src, const FrameReader& ref_reader, int ref_level, bool is_reference) {
  const FrameReader& r = src.reader;
  const int finest = r.num_levels() - 1;
  int mesh_level = m.s.level;
  if (!is_reference && m.s.level != finest && !same_mesh(r, m.s.level, ref_reader, ref_level)) {
    const std::optional<SceneHierarchy>& h = src.stored_hierarchy();
    if (!h || h->num_levels() != r.num_levels() ||
        h->levels[static_cast<std::size_t>(m.s.level)].rest.V.rows() != r.num_vertices(m.s.level) ||
        !h->levels[static_cast<std::size_t>(m.s.level)].to_finest_prolongation) {
      m.vd_note = "level " + std::to_string(m.s.level) + " is not its file's finest and the file has no matching "
                  "stored hierarchy to prolong it with";
      return;
    }
    m.P = &*h->levels[static_cast<std::size_t>(m.s.level)].to_finest_prolongation;
    mesh_level = finest;
  }
  if (!same_mesh(r, mesh_level, ref_reader, ref_level)) {
    const int nv = r.num_vertices(mesh_level), nref = ref_reader.num_vertices(ref_level);
    m.vd_note = (m.P ? "prolonged to the finest mesh (" : "its mesh (") + std::to_string(nv) +
                " vertices) is not the reference's mesh (" + std::to_string(nref) + " vertices" +
                (nv == nref ? ", other rest positions or objects" : "") + ")";
    m.P = nullptr;
    return;
  }
  m.reaches_reference = true;
}

// Hausdorff and vertex distance of frame i of m against the reference frame (rx, tree).
void measure_frame(Measured& m, std::size_t i, const Positions& x, const Positions& rx, const Faces& ref_faces,
                   const TriangleSurface& ref_tree, const std::vector<char>& ref_mask) {
  const TriangleSurface tree(x, m.surface);
  m.hausdorff[i] = hausdorff_distance(x, m.surface, tree, rx, ref_faces, ref_tree);
  if (!m.reaches_reference) return;
  Positions fine;
  try {
    fine = m.P ? m.P->apply(x) : x;
  } catch (const DegenerateProlongationTriangle& e) {
    m.vd_note += (m.vd_note.empty() ? "" : "; ") + std::string("frame ") + std::to_string(m.s.frames[i]) +
                 ": cannot prolong: " + e.what();
    return;
  }
  const std::vector<double> d = vertex_distances(fine, rx, ref_mask);
  const DistanceStats st = distance_stats(d);
  m.vd_mean[i] = st.mean, m.vd_p95[i] = st.p95, m.vd_max[i] = st.max;
  m.pooled_vd.insert(m.pooled_vd.end(), d.begin(), d.end());
}

// Every measure of every series against the reference series `ref`, frame by frame of the reference
// (its surface tree is built once per frame).
void measure_all(std::vector<Measured>& all, std::vector<Source>& sources, std::size_t ref) {
  const Measured& r = all[ref];
  const FrameReader& rr = sources[r.source].reader;
  const std::vector<char> ref_mask = simulated_vertices(rr.object_offsets(r.s.level), r.s.obstacle);
  const Faces ref_faces = r.surface;
  if (ref_faces.rows() == 0) throw InputError(rr.path() + ": the reference level has no face of a simulated object");
  for (std::size_t k = 0; k < all.size(); ++k) {
    Measured& m = all[k];
    const std::size_t n = m.s.frames.size();
    for (std::vector<double>* v : {&m.com, &m.vd_mean, &m.vd_p95, &m.vd_max, &m.hausdorff, &m.accel_diff})
      v->assign(n, kNaN);
    for (const auto& [t, d] : com_deviation(m.s, r.s)) {  // also rejects another object count
      const auto at = std::lower_bound(m.s.frames.begin(), m.s.frames.end(), t);
      m.com[static_cast<std::size_t>(at - m.s.frames.begin())] = d;
    }
    if (m.surface.rows() == 0)
      throw InputError(m.s.file + ": level " + std::to_string(m.s.level) + " has no face of a simulated object");
    plan_vertex_distance(m, sources[m.source], rr, r.s.level, k == ref);
  }
  for (const int t : all[ref].s.frames) {
    const Positions rx = rr.frame(all[ref].s.level, t);
    const TriangleSurface ref_tree(rx, ref_faces);
    for (Measured& m : all) {
      const auto it = std::lower_bound(m.s.frames.begin(), m.s.frames.end(), t);
      if (it == m.s.frames.end() || *it != t) continue;
      const Positions x = sources[m.source].reader.frame(m.s.level, t);
      measure_frame(m, static_cast<std::size_t>(it - m.s.frames.begin()), x, rx, ref_faces, ref_tree, ref_mask);
    }
  }
}

// --seams "0,25,50" -> {0, 25, 50}; each T must leave frame T + 1 (0 <= T <= last - 1). The jitter
// takes the seams >= 1 (see all_seams); the pop takes them all.
std::vector<int> parse_seams(const std::string& text, const std::string& file, int last_frame) {
  std::vector<int> out;
  std::size_t at = 0;
  while (at <= text.size()) {
    const std::size_t comma = std::min(text.find(',', at), text.size());
    const std::string item = text.substr(at, comma - at);
    std::size_t used = 0;
    int t = 0;
    try {
      t = std::stoi(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (item.empty() || used != item.size())
      throw InputError(file + ": --seams: '" + item + "' is not a frame number (expected T1,T2,...)");
    if (t < 0 || t > last_frame - 1)
      throw InputError(file + ": --seams: frame " + item + " is outside 0.." + std::to_string(last_frame - 1) +
                       " (a seam T needs frame T + 1)");
    out.push_back(t);
    at = comma + 1;
  }
  return out;
}

// Seam jitter of series k (OTHER) against series one (FILE, K = 1) on the same level and mesh; fills
// k.accel_diff for the CSV.
nlohmann::json seam_entry(Measured& k, const FrameReader& kr, const Measured& one, const FrameReader& onr,
                          const std::vector<int>& seams) {
  const int n = std::min(kr.num_frames(), onr.num_frames());
  const std::vector<uint8_t> dk = kr.done(k.s.level), d1 = onr.done(one.s.level);
  const std::vector<char> mask = simulated_vertices(kr.object_offsets(k.s.level), k.s.obstacle);
  std::vector<double> d(static_cast<std::size_t>(n), kNaN);
  const auto stored = [&](int t) { return dk[static_cast<std::size_t>(t)] && d1[static_cast<std::size_t>(t)]; };
  for (int t = 1; t + 1 < n; ++t) {
    if (!stored(t - 1) || !stored(t) || !stored(t + 1)) continue;
    const int l = k.s.level, l1 = one.s.level;
    d[static_cast<std::size_t>(t)] =
        acceleration_difference(kr.frame(l, t - 1), kr.frame(l, t), kr.frame(l, t + 1), onr.frame(l1, t - 1),
                                onr.frame(l1, t), onr.frame(l1, t + 1), mask);
  }
  for (std::size_t i = 0; i < k.s.frames.size(); ++i)
    if (k.s.frames[i] < n) k.accel_diff[i] = d[static_cast<std::size_t>(k.s.frames[i])];
  const SeamJitter j = seam_jitter(d, seams);
  nlohmann::json e = {{"level", k.s.level}, {"seams", j.seams}, {"seam_d_m", nlohmann::json::array()},
                      {"max_seam_d_m", num(j.max_seam_d)}, {"median_other_d_m", num(j.median_other)},
                      {"ratio", num(j.ratio)}, {"units", "m per frame^2 (no division by h^2)"}};
  for (const double v : j.seam_d) e["seam_d_m"].push_back(num(v));
  if (std::isinf(j.ratio))
    e["ratio_note"] = "infinite: the other frames' median d is 0 (the runs agree there) and a seam's d is not";
  else if (std::isnan(j.ratio))
    e["ratio_note"] = std::isnan(j.max_seam_d)     ? "undefined: d is not defined at any seam frame"
                      : std::isnan(j.median_other) ? "undefined: d is not defined at any frame other than the seams"
                                                   : "undefined: d is 0 at the seams and the other frames' median is 0";
  return e;
}

// The seam_jitter array: every level of OTHER against the same level of FILE when their meshes match;
// null with FILE alone. Seam 0 (the level's start) is left out: d(0) needs frame -1, and the first
// subset is the K = 1 run's own task, so a seam 0 would only pull its zero d into the background.
nlohmann::json all_seams(std::vector<Measured>& all, std::vector<Source>& sources, std::vector<int> seams,
                         std::vector<std::string>& notes) {
  if (sources.size() < 2) {
    notes.push_back("no OTHER: the jitter compares the run with subsets (OTHER) against FILE");
    return nullptr;
  }
  if (std::find(seams.begin(), seams.end(), 0) != seams.end()) {
    notes.push_back("seam 0 left out: the jitter takes seams 1..N-1 (d(0) is not defined)");
    seams.erase(std::remove(seams.begin(), seams.end(), 0), seams.end());
  }
  nlohmann::json out = nlohmann::json::array();
  if (seams.empty()) return out;
  for (Measured& k : all) {
    if (k.source != 1) continue;
    const auto one = std::find_if(all.begin(), all.end(), [&](const Measured& m) {
      return m.source == 0 && m.s.level == k.s.level;
    });
    const std::string level = "level " + std::to_string(k.s.level);
    if (one == all.end()) {
      notes.push_back(level + ": FILE has no frames on this level");
    } else if (!same_mesh(sources[1].reader, k.s.level, sources[0].reader, one->s.level)) {
      notes.push_back(level + ": the two files' meshes differ");
    } else {
      out.push_back(seam_entry(k, sources[1].reader, *one, sources[0].reader, seams));
    }
  }
  return out;
}

// m(t) (progressive/error_measures.h) of series s for t = 0..N, NaN where frames t - 1, t and t + 1
// are not all stored; each stored frame is read once.
std::vector<double> second_differences(const FrameReader& r, const LevelSeries& s) {
  const std::vector<uint8_t> done = r.done(s.level);
  const std::vector<char> mask = simulated_vertices(r.object_offsets(s.level), s.obstacle);
  std::vector<double> m(done.size(), kNaN);
  Positions x[3];  // frames t - 2, t - 1, t
  int in_a_row = 0;  // stored frames ending at t
  for (std::size_t t = 0; t < done.size(); ++t) {
    if (!done[t]) {
      in_a_row = 0;
      continue;
    }
    x[0] = std::move(x[1]), x[1] = std::move(x[2]), x[2] = r.frame(s.level, static_cast<int>(t));
    if (++in_a_row >= 3) m[t - 1] = max_second_difference(x[0], x[1], x[2], mask);
  }
  return m;
}

// "infinite: ..." / "undefined: ..." for a pop that is not finite (JSON null); empty for a number.
std::string pop_note(const SeamPop& p) {
  if (std::isinf(p.pop)) return "infinite: the background is 0 and the peak is not";
  if (!std::isnan(p.pop)) return "";
  return std::isnan(p.peak)         ? "undefined: m is not defined at s or s + 1"
         : std::isnan(p.background) ? "undefined: m is not defined at any background frame"
                                    : "undefined: the peak and the background are 0";
}

// The pops of series k at the seams; with `one` (FILE's same level, the K = 1 run) its pops as the
// baseline and whether each seam is visible (pop > 0.5 and > 1.5 times the baseline); one_missing:
// why there is no baseline although OTHER was given (empty with one file).
nlohmann::json pop_entry(const Measured& k, const Measured* one, const std::string& one_missing,
                         const std::vector<int>& seams) {
  const std::vector<SeamPop> pk = seam_pops(k.second_diff, seams);
  const std::vector<SeamPop> p1 = one ? seam_pops(one->second_diff, seams) : std::vector<SeamPop>();
  nlohmann::json e = {{"file", k.s.file}, {"level", k.s.level}, {"seams", nlohmann::json::array()},
                      {"units", "m per frame^2 (no division by h^2)"}};
  int visible = 0;
  for (std::size_t i = 0; i < pk.size(); ++i) {
    const SeamPop& p = pk[i];
    const double base = one ? p1[i].pop : kNaN;
    const bool vis = p.pop > 0.5 && p.pop > 1.5 * base;  // false with NaN on either side
    nlohmann::json j = {{"seam", p.seam}, {"peak_m", num(p.peak)}, {"background_m", num(p.background)},
                        {"background_frames", p.background_frames}, {"pop", num(p.pop)},
                        {"baseline_pop", num(base)}, {"visible", vis}};
    if (const std::string note = pop_note(p); !note.empty()) j["pop_note"] = note;
    if (const std::string note = one ? pop_note(p1[i]) : ""; !note.empty()) j["baseline_pop_note"] = note;
    if (std::isnan(p.pop))
      j["visible_note"] = "not judged: the pop is undefined";
    else if (one && std::isnan(base))
      j["visible_note"] = "not judged: the K = 1 pop is undefined";
    else if (!one_missing.empty())
      j["visible_note"] = "not judged: no K = 1 baseline: " + one_missing;
    visible += vis;
    e["seams"].push_back(std::move(j));
  }
  e["visible_seams"] = visible;
  return e;
}

// The seam_pop array: every level of OTHER with FILE's same level as the baseline when the meshes
// match (a note says why not otherwise); with FILE alone, FILE's levels without a baseline.
nlohmann::json all_pops(std::vector<Measured>& all, std::vector<Source>& sources, const std::vector<int>& seams,
                        std::vector<std::string>& notes) {
  const std::size_t judged = sources.size() - 1;  // the source whose pops are judged: OTHER, else FILE
  if (judged == 0) notes.push_back("no OTHER: no K = 1 baseline, so no seam is judged visible");
  for (Measured& m : all) m.second_diff = second_differences(sources[m.source].reader, m.s);
  nlohmann::json out = nlohmann::json::array();
  for (const Measured& k : all) {
    if (k.source != judged) continue;
    const Measured* one = nullptr;
    std::string missing;
    if (judged == 1) {
      const auto it = std::find_if(all.begin(), all.end(), [&](const Measured& m) {
        return m.source == 0 && m.s.level == k.s.level;
      });
      if (it == all.end())
        missing = "FILE has no frames on this level";
      else if (!same_mesh(sources[1].reader, k.s.level, sources[0].reader, it->s.level))
        missing = "the two files' meshes differ";
      else
        one = &*it;
    }
    if (!missing.empty()) notes.push_back("level " + std::to_string(k.s.level) + ": no K = 1 baseline: " + missing);
    out.push_back(pop_entry(k, one, missing, seams));
  }
  return out;
}

nlohmann::json summary(const std::vector<int>& frames, const std::vector<double>& v) {
  double sum = 0.0, max = kNaN;
  int count = 0, at = -1;
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (std::isnan(v[i])) continue;
    sum += v[i], ++count;
    if (at < 0 || v[i] > max) max = v[i], at = frames[i];
  }
  return {{"mean", count ? num(sum / count) : nlohmann::json(nullptr)}, {"max", num(max)},
          {"max_frame", at < 0 ? nlohmann::json(nullptr) : nlohmann::json(at)}};
}

nlohmann::json series_json(const Measured& m, const Source& src) {
  nlohmann::json j = {{"file", m.s.file}, {"level", m.s.level}, {"vertices", src.reader.num_vertices(m.s.level)},
                      {"frames", m.s.frames.size()}, {"time_step_s", num(src.time_step)}};
  j["com_deviation_m"] = summary(m.s.frames, m.com);
  const DistanceStats vd = distance_stats(m.pooled_vd);
  j["vertex_distance_m"] = m.pooled_vd.empty() ? nlohmann::json(nullptr)
                                               : nlohmann::json{{"mean", vd.mean}, {"p95", vd.p95}, {"max", vd.max}};
  if (m.pooled_vd.empty() && m.vd_note.empty()) j["vertex_distance_note"] = "no frame in common with the reference";
  if (!m.vd_note.empty()) j["vertex_distance_note"] = m.vd_note;
  j["hausdorff_m"] = summary(m.s.frames, m.hausdorff);
  double ke_max = kNaN;
  for (const double e : m.s.kinetic_energy)
    if (!std::isnan(e) && !(e <= ke_max)) ke_max = e;
  j["kinetic_energy_J"] = {{"first", num(m.s.kinetic_energy.front())}, {"max", num(ke_max)},
                           {"last", num(m.s.kinetic_energy.back())}};
  nlohmann::json pf = {{"frame", m.s.frames}};
  const auto column = [](const std::vector<double>& v) {
    nlohmann::json a = nlohmann::json::array();
    for (const double x : v) a.push_back(num(x));
    return a;
  };
  pf["com_deviation_m"] = column(m.com);
  pf["vertex_distance_mean_m"] = column(m.vd_mean);
  pf["vertex_distance_p95_m"] = column(m.vd_p95);
  pf["vertex_distance_max_m"] = column(m.vd_max);
  pf["hausdorff_m"] = column(m.hausdorff);
  pf["kinetic_energy_J"] = column(m.s.kinetic_energy);
  j["per_frame"] = std::move(pf);
  return j;
}

// The CSV: one row per series and stored frame; an empty cell where a measure is not defined.
void write_csv(const std::string& path, const std::string& shown, const std::vector<Measured>& all,
               const std::vector<Source>& sources,
               const std::vector<std::string>& object_names) {
  std::ofstream csv(path);
  if (!csv) throw InputError(shown + ": cannot write the CSV file");
  csv << kCsvHeadStart << "time_s,kinetic_energy_J,com_deviation_m";
  for (const std::string& name : object_names) csv << ",com_" << name << "_x,com_" << name << "_y,com_" << name << "_z";
  csv << ",vertex_distance_mean_m,vertex_distance_p95_m,vertex_distance_max_m,hausdorff_m,"
         "accel_difference_m_per_frame2,max_second_difference_m_per_frame2\n";
  csv.precision(17);
  const auto cell = [&csv](double v) {
    csv << ",";
    if (!std::isnan(v)) csv << v;
  };
  for (const Measured& m : all) {
    const double h = sources[m.source].time_step;
    for (std::size_t i = 0; i < m.s.frames.size(); ++i) {
      const int t = m.s.frames[i];
      csv << m.s.file << "," << m.s.level << "," << t << ",";
      if (std::isfinite(h)) csv << t * h;
      cell(m.s.kinetic_energy[i]);
      cell(m.com[i]);
      for (Eigen::Index o = 0; o < m.s.com[i].rows(); ++o)
        csv << "," << m.s.com[i](o, 0) << "," << m.s.com[i](o, 1) << "," << m.s.com[i](o, 2);
      const double m_t = m.second_diff.empty() ? kNaN : m.second_diff[static_cast<std::size_t>(t)];
      for (const double v : {m.vd_mean[i], m.vd_p95[i], m.vd_max[i], m.hausdorff[i], m.accel_diff[i], m_t}) cell(v);
      csv << "\n";
    }
  }
  csv.close();
  if (!csv) throw InputError(shown + ": writing the CSV file failed");
}

// A pop as the text shows it: 2 significant digits, "inf" or "n/a" (the JSON's null with its note).
std::string pop_text(const nlohmann::json& pop, const nlohmann::json& seam, const char* note_key) {
  if (pop.is_number()) {
    char text[32];
    std::snprintf(text, sizeof text, "%.2g", pop.get<double>());
    return text;
  }
  return seam.value(note_key, "").rfind("infinite", 0) == 0 ? "inf" : "n/a";
}

// One line per level: "seam pop level 2 (F): seam 100 pop 0.31 (K=1 0.22), ... VISIBLE; 1 of 2 visible".
void print_pops(const nlohmann::json& levels) {
  for (const nlohmann::json& l : levels) {
    std::string line;
    bool baseline = false;
    for (const nlohmann::json& s : l["seams"]) {
      line += (line.empty() ? ": " : ", ") + std::string("seam ") + std::to_string(s["seam"].get<int>()) + " pop " +
              pop_text(s["pop"], s, "pop_note");
      if (s.contains("baseline_pop_note") || s["baseline_pop"].is_number())
        line += " (K=1 " + pop_text(s["baseline_pop"], s, "baseline_pop_note") + ")", baseline = true;
      if (s["visible"].get<bool>()) line += " VISIBLE";
    }
    if (baseline)
      line += "; " + std::to_string(l["visible_seams"].get<int>()) + " of " + std::to_string(l["seams"].size()) +
              " visible";
    std::printf("seam pop level %d (%s)%s\n", l["level"].get<int>(), l["file"].get<std::string>().c_str(),
                line.c_str());
  }
}

void print_text(const nlohmann::json& j) {
  const auto f = [](const nlohmann::json& v) { return v.is_number() ? v.get<double>() : kNaN; };
  std::printf("reference: %s level %d (centre-of-mass deviation = sum over simulated objects of |c - c_ref|)\n",
              j["reference"]["file"].get<std::string>().c_str(), j["reference"]["level"].get<int>());
  std::printf("%-40s %5s %7s %22s %14s %14s %14s %14s\n", "file", "level", "frames", "max deviation m (frame)",
              "mean dev. m", "last KE J", "max vertex m", "max Hausdorff m");
  for (const nlohmann::json& l : j["levels"]) {
    const nlohmann::json& c = l["com_deviation_m"];
    const nlohmann::json& vd = l["vertex_distance_m"];
    // A vertex distance that could not be measured shows as "n/a", its reason below the table.
    char vd_max[32] = "n/a";
    if (!vd.is_null()) std::snprintf(vd_max, sizeof vd_max, "%.4g", f(vd["max"]));
    std::printf("%-40s %5d %7d %13.4g (%5d) %14.4g %14.4g %14s %14.4g\n", l["file"].get<std::string>().c_str(),
                l["level"].get<int>(), l["frames"].get<int>(), f(c["max"]),
                c["max_frame"].is_number() ? c["max_frame"].get<int>() : -1,
                f(c["mean"]), f(l["kinetic_energy_J"]["last"]), vd_max, f(l["hausdorff_m"]["max"]));
  }
  for (const nlohmann::json& l : j["levels"])
    if (l.contains("vertex_distance_note"))
      std::printf("%s level %d: vertex distance: %s\n", l["file"].get<std::string>().c_str(), l["level"].get<int>(),
                  l["vertex_distance_note"].get<std::string>().c_str());
  if (!j.contains("seam_jitter_notes")) return;  // no --seams
  for (const nlohmann::json& s : j["seam_jitter"])
    std::printf("seam jitter level %d: max seam d %.4g m/frame^2, median other d %.4g, ratio %s\n",
                s["level"].get<int>(), f(s["max_seam_d_m"]), f(s["median_other_d_m"]),
                s["ratio"].is_number() ? std::to_string(s["ratio"].get<double>()).c_str()
                                       : s["ratio_note"].get<std::string>().c_str());
  for (const nlohmann::json& n : j["seam_jitter_notes"])
    std::printf("seam jitter %s\n", n.get<std::string>().c_str());
  print_pops(j["seam_pop"]);
  for (const nlohmann::json& n : j["seam_pop_notes"]) std::printf("seam pop %s\n", n.get<std::string>().c_str());
}

}  // namespace

int compare(const CompareArgs& args) {
  check_input_file(args.file, "frame file");
  if (!args.other.empty()) check_input_file(args.other, "frame file");
  check_frame_file_in_child(args.file);
  if (!args.other.empty()) check_frame_file_in_child(args.other);
  const std::string csv_path = args.csv.empty() ? args.file + ".compare.csv" : args.csv;
  check_output_file(csv_path, "--csv", {args.file, args.other});
  check_replaceable(csv_path, "--csv", args.force, file_starts_with(csv_path, kCsvHeadStart), "a pd compare CSV");
  std::vector<Source> sources;
  sources.reserve(2);  // Measured::P points into a Source's hierarchy: no reallocation
  std::vector<Measured> all;
  for (const std::string& f : {args.file, args.other}) {
    if (f.empty()) continue;
    sources.emplace_back(f);
    Source& src = sources.back();
    src.time_step = time_step_of(src.reader);
    for (LevelSeries& s : read_level_series(src.reader)) {
      Measured m;
      m.source = sources.size() - 1;
      m.surface = simulated_faces(src.reader.faces(s.level), src.reader.object_offsets(s.level), s.obstacle);
      m.s = std::move(s);
      all.push_back(std::move(m));
    }
  }
  if (sources.size() == 2) check_same_scene(sources[0].reader, sources[1].reader);
  // The reference: the finest level of the first file that holds frames.
  std::size_t ref = all.size();
  for (std::size_t k = 0; k < all.size(); ++k)
    if (all[k].source == 0) ref = k;
  if (ref == all.size()) throw InputError(args.file + ": no level holds a frame");
  std::vector<int> seams;
  if (!args.seams.empty())
    seams = parse_seams(args.seams, args.other.empty() ? args.file : args.other,
                        std::min(sources.front().reader.num_frames(), sources.back().reader.num_frames()) - 1);

  measure_all(all, sources, ref);
  nlohmann::json out = {{"reference", {{"file", all[ref].s.file}, {"level", all[ref].s.level},
                                       {"vertices", sources[0].reader.num_vertices(all[ref].s.level)}}},
                        {"levels", nlohmann::json::array()}, {"seam_jitter", nullptr}, {"seam_pop", nullptr}};
  if (!seams.empty()) {
    std::vector<std::string> jitter_notes, pop_notes;
    out["seam_jitter"] = all_seams(all, sources, seams, jitter_notes);
    out["seam_jitter_notes"] = jitter_notes;
    out["seam_pop"] = all_pops(all, sources, seams, pop_notes);
    out["seam_pop_notes"] = pop_notes;
  }
  for (const Measured& m : all) out["levels"].push_back(series_json(m, sources[m.source]));

  {
    PartialOutput csv(csv_path, "--csv");  // CSV_PATH.partial, renamed when complete
    write_csv(csv.path(), shown_path(csv_path), all, sources, all[ref].s.object_names);
    csv.commit();
  }
  if (args.json) {
    std::printf("%s\n", out.dump().c_str());
    std::fflush(stdout);  // the whole object before the stderr line, also when both go to one pipe
    std::fprintf(stderr, "wrote %s\n", csv_path.c_str());
  } else {
    print_text(out);
    std::printf("wrote %s\n", csv_path.c_str());
  }
  return 0;
}

}  // namespace pd::cli
