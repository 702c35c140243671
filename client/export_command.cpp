// pd export: frames of a frame file as files other tools read.
#include <cstdio>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "commands.h"
#include "geometry/obj_io.h"
#include "output_files.h"
#include "store/frame_store.h"
#include "store/hierarchy_store.h"
#include "util/input_error.h"

namespace pd::cli {
namespace {

std::string in_dir(const std::string& dir, const std::string& name) {
  return (std::filesystem::path(dir) / name).string();
}

void make_dir(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw InputError(dir + ": cannot create directory: " + ec.message());
}

// --rest: every level's rest mesh (from /hierarchy/<l>, which every frame file has) as level_<l>.obj.
int export_rest(const FrameReader& reader, const std::string& dir) {
  make_dir(dir);
  for (int l = 0; l < reader.num_levels(); ++l)
    write_obj(in_dir(dir, "level_" + std::to_string(l) + ".obj"), reader.rest_positions(l), reader.faces(l));
  return reader.num_levels();
}

// --prolong: every done frame of `level`, prolonged to the finest mesh with P^level (the stored
// hierarchy's to_finest_prolongation), as frame_%05d.obj with the finest faces.
int export_prolonged(const FrameReader& reader, const std::string& file, int level, const std::string& dir) {
  const std::optional<SceneHierarchy> h = read_hierarchy(file);
  if (!h)
    throw InputError(file + ": /hierarchy: the file has no stored level hierarchy (needed by --prolong); run `pd "
                            "hierarchy SCENE --out " + file + "` to make one");
  if (level >= h->num_levels())
    throw InputError(file + ": --level " + std::to_string(level) + ": the hierarchy has levels 0.." +
                     std::to_string(h->num_levels() - 1));
  const SceneLevel& s = h->levels[static_cast<size_t>(level)];
  if (reader.num_vertices(level) != s.rest.V.rows())
    throw InputError(file + ": /levels/" + std::to_string(level) + "/positions: frames have " +
                     std::to_string(reader.num_vertices(level)) + " vertices, hierarchy level " +
                     std::to_string(level) + " has " + std::to_string(s.rest.V.rows()));
  const Faces& finest_faces = h->levels.back().rest.F;
  make_dir(dir);
  const std::vector<uint8_t> done = reader.done(level);
  int count = 0;
  for (int t = 0; t < static_cast<int>(done.size()); ++t) {
    if (done[t] != 1) continue;
    const Positions x = reader.frame(level, t);
    Positions fine;
    try {
      fine = s.to_finest_prolongation ? s.to_finest_prolongation->apply(x) : x;
    } catch (const DegenerateProlongationTriangle& e) {
      throw InputError(file + ": /levels/" + std::to_string(level) + "/positions: frame " + std::to_string(t) +
                       ": cannot prolong: " + e.what());
    }
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.obj", t);
    write_obj(in_dir(dir, name), fine, finest_faces);
    ++count;
  }
  return count;
}

}  // namespace

int export_frames(const ExportArgs& args) {
  check_input_file(args.file, "frame file");
  check_output_folder(args.out_dir, "--out", {args.file});
  const FrameReader reader(args.file);
  const int level = args.level < 0 ? 0 : args.level;
  if (level >= reader.num_levels())
    throw InputError(shown_path(args.file) + ": --level " + std::to_string(level) + ": the file has levels 0.." +
                     std::to_string(reader.num_levels() - 1));
  if (args.format != "obj") throw InputError("--format: '" + args.format + "' is not supported; allowed: obj");
  // Everything goes to a temporary folder first: an error leaves --out as it was (no partial export).
  PartialFolder out(args.out_dir, "--out");
  const std::string shown = shown_path(args.out_dir);
  std::vector<std::string> lines;
  if (args.rest) {
    const int n = export_rest(reader, out.path());
    lines.push_back("wrote the rest meshes of " + std::to_string(n) + " levels to " + shown);
  }
  if (args.prolong) {
    const int n = export_prolonged(reader, args.file, level, out.path());
    lines.push_back("wrote " + std::to_string(n) + " OBJ frames of level " + std::to_string(level) +
                    " prolonged to the finest level to " + shown);
  }
  if (!args.rest && !args.prolong) {
    const int n = export_obj_frames(reader, level, out.path());
    lines.push_back("wrote " + std::to_string(n) + " OBJ frames of level " + std::to_string(level) + " to " + shown);
  }
  out.commit();
  for (const std::string& line : lines) std::printf("%s\n", line.c_str());
  return 0;
}

}  // namespace pd::cli
