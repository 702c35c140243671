// pd export: frames of a frame file as files other tools read: OBJ frames, or PC2 point caches with
// their rest OBJ (pc2_writer.h), of one level as stored or prolonged to the finest mesh, whole or per
// scene object, for every stored frame or a --frames range. File names: client/README.md.
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "cli_text.h"
#include "commands.h"
#include "geometry/obj_io.h"
#include "frame_file_guard.h"
#include "output_files.h"
#include "geometry/pc2_writer.h"
#include "store/frame_store.h"
#include "store/hierarchy_store.h"
#include "util/input_error.h"

namespace pd::cli {
namespace {

// How --frames is written, for messages.
const char* const kFramesAllowed = "FIRST:LAST, frame numbers with FIRST <= LAST (both exported), e.g. 0:99";
// PC2 caches open at once with --per-object (one file descriptor each); more objects go in batches
// that each read the frames again.
constexpr std::size_t kOpenCaches = 64;

std::string in_dir(const std::string& dir, const std::string& name) {
  return (std::filesystem::path(dir) / name).string();
}

void make_dir(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw InputError(dir + ": cannot create directory: " + ec.message());
}

// --frames FIRST:LAST (inclusive frame numbers), checked for form here and against the file later.
struct FrameRange {
  bool given = false;
  int first = 0, last = 0;
  std::string text() const { return std::to_string(first) + ":" + std::to_string(last); }
};

FrameRange parse_frames(const std::string& text) {
  FrameRange r;
  if (text.empty()) return r;  // not given (main.cpp refuses an explicit empty value)
  const std::size_t colon = text.find(':');
  if (colon == std::string::npos || text.find(':', colon + 1) != std::string::npos)
    throw InputError("--frames: '" + echo(text) + "' is not FIRST:LAST; allowed: " + kFramesAllowed);
  const ParsedInteger a = parse_decimal_integer(text.substr(0, colon), 0, kMaxFrames, kFramesAllowed);
  if (!a.problem.empty()) throw InputError("--frames: FIRST of '" + echo(text) + "': " + a.problem);
  const ParsedInteger b = parse_decimal_integer(text.substr(colon + 1), 0, kMaxFrames, kFramesAllowed);
  if (!b.problem.empty()) throw InputError("--frames: LAST of '" + echo(text) + "': " + b.problem);
  if (a.value > b.value)
    throw InputError("--frames: '" + echo(text) + "' is reversed (FIRST after LAST); allowed: " + kFramesAllowed);
  r.given = true;
  r.first = static_cast<int>(a.value);
  r.last = static_cast<int>(b.value);
  return r;
}

// Options that do not apply together are errors naming both (README.md, "Command-line rules"); checked
// before any file is opened. (--level with --rest alone: main.cpp.)
void check_option_combinations(const ExportArgs& args) {
  if (!args.rest || args.prolong) return;
  const std::string tail = ": does not apply to --rest alone (it writes rest meshes, no frames); allowed: with "
                           "--prolong, or without --rest";
  if (!args.frames.empty()) throw InputError("--frames" + tail);
  if (args.per_object) throw InputError("--per-object" + tail);
  if (args.format == "pc2") throw InputError("--format pc2" + tail);
}

// The stored frames of a done array as runs, e.g. "0..4, 7, 9..12" ("none"); at most 6 runs shown.
std::string stored_text(const std::vector<uint8_t>& done) {
  std::string out;
  int runs = 0;
  for (int t = 0; t < static_cast<int>(done.size()); ++t) {
    if (done[t] != 1 || (t > 0 && done[t - 1] == 1)) continue;
    int end = t;
    while (end + 1 < static_cast<int>(done.size()) && done[end + 1] == 1) ++end;
    if (++runs > 6) return out + ", ...";
    out += (out.empty() ? "" : ", ") + std::to_string(t) + (end > t ? ".." + std::to_string(end) : "");
  }
  return out.empty() ? "none" : out;
}

// The frames to export, in order, and a note for stderr when stored frames were left out or frames
// are missing. With --frames every frame of the range must be stored (a job file still being written
// has gaps: refused, naming the first missing frame). Without it: OBJ writes every stored frame (one
// file each, named by its number, as before --frames existed) and notes the missing ones; a PC2 cache
// has one sample per frame, so it takes the contiguous run from the first stored frame and notes
// what it left out.
struct FrameSelection {
  std::vector<int> frames;
  std::string note;
};

FrameSelection select_frames(const FrameReader& reader, int level, const FrameRange& range, bool contiguous,
                             const std::string& file) {
  const std::vector<uint8_t> done = reader.done(level);
  const int n = static_cast<int>(done.size());
  const std::string lv = "level " + std::to_string(level);
  const std::string stored = "stored: " + stored_text(done);
  FrameSelection s;
  if (range.given) {
    if (range.last >= n)
      throw InputError(shown_path(file) + ": --frames " + range.text() + ": " + lv + " has frames 0.." +
                       std::to_string(n - 1) + " (" + stored + ")");
    for (int t = range.first; t <= range.last; ++t) {
      if (done[t] != 1)
        throw InputError(shown_path(file) + ": --frames " + range.text() + ": frame " + std::to_string(t) + " of " +
                         lv + " is not stored yet (" + stored +
                         "); fetch the job file again later or give a stored range");
      s.frames.push_back(t);
    }
    return s;
  }
  int first = 0;
  while (first < n && done[first] != 1) ++first;
  if (contiguous && first == n)
    throw InputError(shown_path(file) + ": " + lv + " has no stored frame (frames 0.." + std::to_string(n - 1) +
                     "); nothing to export");
  for (int t = first; t < n && (done[t] == 1 || !contiguous); ++t)
    if (done[t] == 1) s.frames.push_back(t);
  if (static_cast<int>(s.frames.size()) == n) return s;
  if (contiguous)
    s.note = lv + ": exported frames " + std::to_string(s.frames.front()) + ".." + std::to_string(s.frames.back()) +
             ", the contiguous stored run from the first stored frame, of 0.." + std::to_string(n - 1) + " (" +
             stored + "); give --frames FIRST:LAST to choose";
  else
    s.note = lv + ": " + std::to_string(n - static_cast<int>(s.frames.size())) + " of frames 0.." +
             std::to_string(n - 1) + " are not stored yet and were not written (" + stored + ")";
  return s;
}

// Where the exported positions come from: the frames of `level` as stored, or (--prolong) prolonged
// to the finest mesh with P^level. rest/faces/offsets describe the mesh they live on.
struct Source {
  const FrameReader* reader = nullptr;
  std::string file;
  int level = 0;
  std::optional<SceneHierarchy> hierarchy;  // --prolong only
  Positions rest;                           // metres
  Faces faces;
  std::vector<int> offsets;  // object k owns vertices [offsets[k], offsets[k+1])
  std::vector<std::string> names;

  bool prolonged() const { return hierarchy.has_value(); }
  std::string where(int t) const {
    return shown_path(file) + ": /levels/" + std::to_string(level) + "/positions: frame " + std::to_string(t) +
           (prolonged() ? " prolonged to the finest mesh" : "");
  }
  // "vertex 12 (object 'ball' vertex 3)" for a vertex of the exported mesh.
  std::string vertex(Eigen::Index v) const {
    std::string out = std::string(prolonged() ? "finest " : "") + "vertex " + std::to_string(v);
    for (std::size_t k = 0; k + 1 < offsets.size() && k < names.size(); ++k)
      if (v >= offsets[k] && v < offsets[k + 1])
        out += " (object '" + echo(names[k]) + "' vertex " + std::to_string(v - offsets[k]) + ")";
    return out;
  }
  Positions frame(int t) const;
};

Positions Source::frame(int t) const {
  const Positions x = reader->frame(level, t);  // refuses non-finite stored coordinates, naming the vertex
  if (!hierarchy) return x;
  const SceneLevel& s = hierarchy->levels[static_cast<size_t>(level)];
  Positions fine;
  try {
    fine = s.to_finest_prolongation ? s.to_finest_prolongation->apply(x) : x;
  } catch (const DegenerateProlongationTriangle& e) {
    throw InputError(where(t) + ": cannot prolong: " + e.what());
  }
  // Finite input can still prolong to inf (huge offsets); OBJ would print "inf", PC2 store it.
  for (Eigen::Index i = 0; i < fine.size(); ++i)
    if (!std::isfinite(fine.data()[i])) throw InputError(where(t) + ": " + vertex(i / 3) + " is not finite");
  return fine;
}

Source level_source(const FrameReader& reader, const std::string& file, int level) {
  Source s;
  s.reader = &reader;
  s.file = file;
  s.level = level;
  s.rest = reader.rest_positions(level);
  s.faces = reader.faces(level);
  s.offsets = reader.object_offsets(level);
  s.names = reader.object_names(level);
  return s;
}

// --prolong: the stored hierarchy's P^level, the finest mesh and its objects.
Source prolonged_source(const FrameReader& reader, const std::string& file, int level) {
  Source s = level_source(reader, file, level);
  s.hierarchy = read_hierarchy(file);
  if (!s.hierarchy)
    throw InputError(file + ": /hierarchy: the file has no stored level hierarchy (needed by --prolong); run `pd "
                            "hierarchy SCENE --out " + file + "` to make one");
  const SceneHierarchy& h = *s.hierarchy;
  if (level >= h.num_levels())
    throw InputError(file + ": --level " + std::to_string(level) + ": the hierarchy has levels 0.." +
                     std::to_string(h.num_levels() - 1));
  const SceneLevel& sl = h.levels[static_cast<size_t>(level)];
  if (reader.num_vertices(level) != sl.rest.V.rows())
    throw InputError(file + ": /levels/" + std::to_string(level) + "/positions: frames have " +
                     std::to_string(reader.num_vertices(level)) + " vertices, hierarchy level " +
                     std::to_string(level) + " has " + std::to_string(sl.rest.V.rows()));
  const SceneLevel& finest = h.levels.back();
  s.rest = finest.rest.V;
  s.faces = finest.rest.F;
  s.offsets = finest.vertex_offsets;
  if (s.offsets.size() != s.names.size() + 1)
    throw InputError(file + ": /hierarchy: the finest level has " +
                     std::to_string(static_cast<long>(s.offsets.size()) - 1) + " objects, /hierarchy/" +
                     std::to_string(level) + "/object_names " + std::to_string(s.names.size()));
  return s;
}

// A coordinate for a message: the shortest text that reads back as the same double (1e+39, not the
// 39 digits of %f nor %.17g's 9.9999999999999994e+38).
std::string number(double v) {
  char buf[32];
  return std::string(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
}

// What one output file covers: all of the mesh, or one object's vertices [first, first + count) and
// its faces (renumbered from 0).
struct Part {
  std::string stem;  // file name without extension
  Eigen::Index first = 0, count = 0;
  Faces faces;
};

// File-name stems of the objects: ASCII letters, digits, '-', '_', '.' kept, every other byte '_'
// (names come from the file); a name that is empty, starts with '.', or repeats another
// case-insensitively (a case-insensitive disk would merge them) gets "_<k>" or becomes "object_<k>".
std::vector<std::string> object_stems(const std::vector<std::string>& names) {
  std::vector<std::string> out;
  std::set<std::string> taken;
  for (std::size_t k = 0; k < names.size(); ++k) {
    std::string s;
    for (std::size_t i = 0; i < names[k].size() && s.size() < 64; ++i) {
      const unsigned char c = static_cast<unsigned char>(names[k][i]);
      s += (std::isalnum(c) && c < 128) || c == '-' || c == '_' || c == '.' ? static_cast<char>(c) : '_';
    }
    if (s.empty() || s[0] == '.') s = "object_" + std::to_string(k) + s;
    const auto lower = [](std::string t) {
      for (char& c : t) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      return t;
    };
    while (taken.count(lower(s))) s += "_" + std::to_string(k);
    taken.insert(lower(s));
    out.push_back(s);
  }
  return out;
}

// The parts to write: the whole mesh as `prefix`, or (per_object) each object as prefix + its stem.
std::vector<Part> make_parts(const Source& src, bool per_object, const std::string& prefix) {
  if (!per_object) return {Part{prefix, 0, src.rest.rows(), src.faces}};
  std::vector<Part> parts;
  const std::vector<std::string> stems = object_stems(src.names);
  for (std::size_t k = 0; k + 1 < src.offsets.size(); ++k) {
    Part p{prefix + stems[k], src.offsets[k], src.offsets[k + 1] - src.offsets[k], Faces()};
    std::vector<int> rows;  // faces of the object: all three corners in its range
    for (Eigen::Index f = 0; f < src.faces.rows(); ++f)
      if ((src.faces.row(f).array() >= p.first).all() && (src.faces.row(f).array() < p.first + p.count).all())
        rows.push_back(static_cast<int>(f));
    p.faces.resize(static_cast<Eigen::Index>(rows.size()), 3);
    for (std::size_t i = 0; i < rows.size(); ++i)
      p.faces.row(static_cast<Eigen::Index>(i)) = src.faces.row(rows[i]).array() - static_cast<int>(p.first);
    parts.push_back(std::move(p));
  }
  return parts;
}

// OBJ frames: frame_%05d.obj (whole mesh) or <object>_frame_%05d.obj (per object), numbered by frame.
int export_obj(const Source& src, const std::vector<int>& frames, bool per_object, const std::string& dir) {
  const std::vector<Part> parts = make_parts(src, per_object, "");
  make_dir(dir);
  for (const int t : frames) {
    const Positions x = src.frame(t);
    for (const Part& p : parts) {
      char name[32];
      std::snprintf(name, sizeof name, "frame_%05d.obj", t);
      write_obj(in_dir(dir, per_object ? p.stem + "_" + name : name), x.middleRows(p.first, p.count), p.faces);
    }
  }
  return static_cast<int>(frames.size() * parts.size());
}

// PC2: <prefix>.pc2 and its rest mesh <prefix>.obj (or <prefix>_<object>.pc2 / .obj per object);
// frames must be consecutive (one sample per frame, start frame = the first, sample rate 1).
// Returns the names of the files written.
std::vector<std::string> export_pc2(const Source& src, const std::vector<int>& frames, bool per_object,
                                    const std::string& prefix, const std::string& dir) {
  const std::vector<Part> parts = make_parts(src, per_object, per_object ? prefix + "_" : prefix);
  make_dir(dir);
  std::vector<std::string> names;
  for (const Part& p : parts) {
    write_obj(in_dir(dir, p.stem + ".obj"), src.rest.middleRows(p.first, p.count), p.faces);
    names.push_back(p.stem + ".pc2");
    names.push_back(p.stem + ".obj");
  }
  for (std::size_t b = 0; b < parts.size(); b += kOpenCaches) {
    const std::size_t end = std::min(parts.size(), b + kOpenCaches);
    std::vector<std::unique_ptr<Pc2Writer>> caches;
    for (std::size_t i = b; i < end; ++i)
      caches.push_back(std::make_unique<Pc2Writer>(in_dir(dir, parts[i].stem + ".pc2"),
                                                   static_cast<int>(parts[i].count),
                                                   static_cast<float>(frames.front()), /*sample_rate=*/1.0f,
                                                   static_cast<int>(frames.size())));
    for (const int t : frames) {
      const Positions x = src.frame(t);
      if (const Eigen::Index bad = first_non_float32(x, 0, x.rows()); bad >= 0)
        throw InputError(src.where(t) + ": " + src.vertex(bad / 3) + ": coordinate " + "xyz"[bad % 3] + " = " +
                         number(x.data()[bad]) + " m does not fit a float32 (PC2 stores float32, "
                         "|value| <= 3.4e38); not written");
      for (std::size_t i = b; i < end; ++i) caches[i - b]->add_sample(x, parts[i].first, "frame " + std::to_string(t));
    }
    for (const auto& c : caches) c->close();
  }
  return names;
}

// The files of --format pc2 for the message: all of them up to 4, else the first two and a count.
std::string listed(const std::vector<std::string>& names) {
  std::string out;
  for (std::size_t i = 0; i < names.size() && (i < 2 || names.size() <= 4); ++i) out += (i ? ", " : "") + names[i];
  if (names.size() > 4) out += " and " + std::to_string(names.size() - 2) + " more";
  return out;
}

// --rest: every level's rest mesh (from /hierarchy/<l>, which every frame file has) as level_<l>.obj.
int export_rest(const FrameReader& reader, const std::string& dir) {
  make_dir(dir);
  for (int l = 0; l < reader.num_levels(); ++l)
    write_obj(in_dir(dir, "level_" + std::to_string(l) + ".obj"), reader.rest_positions(l), reader.faces(l));
  return reader.num_levels();
}

// The frames of `level` (--prolong: prolonged) in args.format, into `dir`; returns the stdout line
// and sets `note` (stderr) when frames were left out.
std::string export_level_frames(const FrameReader& reader, const ExportArgs& args, int level, const FrameRange& range,
                                const std::string& dir, std::string& note) {
  const bool pc2 = args.format == "pc2";
  const Source src = args.prolong ? prolonged_source(reader, args.file, level) : level_source(reader, args.file, level);
  const FrameSelection sel = select_frames(reader, level, range, /*contiguous=*/pc2, args.file);
  note = sel.note;
  const std::string what = "level " + std::to_string(level) + (args.prolong ? " prolonged to the finest level" : "");
  const std::string shown = shown_path(args.out_dir);
  if (!pc2) {
    const int n = export_obj(src, sel.frames, args.per_object, dir);
    if (!args.per_object) return "wrote " + std::to_string(n) + " OBJ frames of " + what + " to " + shown;
    return "wrote " + std::to_string(n) + " OBJ files (" + std::to_string(sel.frames.size()) + " frames x " +
           std::to_string(src.names.size()) + " objects) of " + what + " to " + shown;
  }
  const std::string prefix = "level_" + std::to_string(level) + (args.prolong ? "_prolonged" : "");
  const std::vector<std::string> names = export_pc2(src, sel.frames, args.per_object, prefix, dir);
  return "wrote " + std::string(args.per_object ? std::to_string(names.size() / 2) + " PC2 caches" : "a PC2 cache") +
         " of frames " + std::to_string(sel.frames.front()) + ".." + std::to_string(sel.frames.back()) + " of " + what +
         " with " + (names.size() > 2 ? "their rest meshes" : "its rest mesh") + " to " + shown + ": " + listed(names);
}

}  // namespace

int export_frames(const ExportArgs& args) {
  check_option_combinations(args);
  const FrameRange range = parse_frames(args.frames);
  check_input_file(args.file, "frame file");
  check_frame_file_in_child(args.file);
  check_output_folder(args.out_dir, "--out", {args.file});
  const FrameReader reader(args.file);
  const int level = args.level < 0 ? 0 : args.level;
  if (level >= reader.num_levels())
    throw InputError(shown_path(args.file) + ": --level " + std::to_string(level) + ": the file has levels 0.." +
                     std::to_string(reader.num_levels() - 1));
  if (args.format != "obj" && args.format != "pc2")
    throw InputError("--format: '" + echo(args.format) + "' is not supported; allowed: obj, pc2");
  // Everything goes to a temporary folder first: an error leaves --out as it was (no partial export).
  PartialFolder out(args.out_dir, "--out");
  std::vector<std::string> lines;
  std::string note;
  if (args.rest) {
    const int n = export_rest(reader, out.path());
    lines.push_back("wrote the rest meshes of " + std::to_string(n) + " levels to " + shown_path(args.out_dir));
  }
  if (args.prolong || !args.rest) lines.push_back(export_level_frames(reader, args, level, range, out.path(), note));
  out.commit();
  for (const std::string& line : lines) std::printf("%s\n", line.c_str());
  if (!note.empty()) std::fprintf(stderr, "pd export: note: %s\n", one_line(note).c_str());
  return 0;
}

}  // namespace pd::cli
