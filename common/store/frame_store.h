#pragma once
// The HDF5 frame file: one file per job holding the level hierarchy and, for every level, the
// positions and statistics of frames t = 0..N. docs/frame-format.md describes the layout.
//
// Conventions: positions in metres (see geometry/mesh.h), faces 0-based, levels 0 = coarsest.
// Levels are added in order 0, 1, 2, ... Every failure (missing or corrupt file, wrong format
// version, missing dataset, level or frame out of range, frame not done) throws InputError whose
// what() starts with the file path and names the HDF5 object, e.g.
//   "out/flag.h5: /levels/1/positions: frame 7 of level 1 is not done"
// Not thread-safe: use a file from one thread at a time (Debian's HDF5 is built without locks).
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "geometry/mesh.h"
#include "util/input_error.h"

namespace pd {

// The only layout this code writes and reads.
constexpr int kFrameFormatVersion = 1;

// Per-object centres of mass, one row per object (metres).
using ObjectPoints = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

// Statistics of one frame. Each scalar goes to /levels/<l>/stats/<name> (float64), e.g.
// newton_iterations, line_search_cuts, solve_seconds, kinetic_energy, energy_<term>,
// min_contact_distance. A name must be non-empty, contain no '/', differ from "center_of_mass" and
// appear once per frame. center_of_mass has one row per object of the level, or zero rows when it
// was not computed (the frame's entry then stays NaN).
struct FrameStats {
  std::vector<std::pair<std::string, double>> scalars;
  ObjectPoints center_of_mass;
};

// Whether `name` may name a scalar statistic (the rule above: non-empty, no '/', not "." nor
// "center_of_mass"). The farm's scheduler checks frames with it before it records them.
bool valid_stat_name(const std::string& name);

// Writes a frame file. A single writer (one process, one object) per file. Movable, not copyable
// (a moved-from writer may only be destroyed or assigned to).
class FrameWriter {
 public:
  // Creates `path` (truncating an existing file) with format_version and the scene JSON text, for
  // frames 0..last_frame (so last_frame + 1 frames per level). Requires last_frame >= 0.
  static FrameWriter create(const std::string& path, const std::string& scene_json, int last_frame);

  // Opens the existing frame file `path` read-write to go on writing it (the farm's scheduler resumes
  // its jobs after a restart): checks it as FrameReader does, then loads every level (vertex and
  // object counts, done flags, the statistics present) so that add_level, write_frame, read_frame,
  // read_stats, clear_frame and is_done work as on the file create() made. Only done = 1 counts as
  // stored. Throws InputError "<path>: ..." naming the object if the file is missing, not HDF5,
  // truncated, locked by a process that has it open (another writer or reader), has another
  // format_version, has no level (frame count unknown: a writer stopped before its first add_level),
  // lacks a dataset or has one of the wrong shape, or is longer than the end HDF5 recorded: a writer
  // killed while flushing leaves that, and writing on would overwrite stored data (FrameReader still
  // reads such a file; the caller rebuilds it).
  // A killed writer leaves no lock behind (the kernel drops HDF5's flock with the process) and no
  // "open for write" mark (the files this class writes have a version 0 superblock, which has none).
  // But a file it was writing can, rarely, hold a done frame that reads back wrong with no error
  // (HDF5 updates its index in place; tests/store/frame_store_kill_test.cpp measures it): after a
  // kill, compare the done frames with the authoritative copy before writing on.
  static FrameWriter open(const std::string& path);

  FrameWriter(FrameWriter&&) noexcept;
  FrameWriter& operator=(FrameWriter&&) noexcept;
  FrameWriter(const FrameWriter&) = delete;
  FrameWriter& operator=(const FrameWriter&) = delete;
  ~FrameWriter();

  // Adds level `level`, which must equal num_levels() (levels come in order 0, 1, ...): writes
  // /hierarchy/<level>/{rest_positions, faces, object_offsets, object_names} (or, when the file
  // already has them because write_hierarchy stored the hierarchy, checks that they equal the given
  // ones bit for bit and throws InputError naming the dataset that differs) and creates
  // /levels/<level>/{positions, done, stats/center_of_mass}. object_offsets has num_objects + 1
  // entries, starts at 0, does not decrease and ends at rest.rows(); object k owns the vertices
  // [offsets[k], offsets[k+1]). object_names has num_objects entries. Requires rest.rows() > 0,
  // num_objects >= 1 and faces indexing existing vertices. The file is flushed afterwards.
  void add_level(int level, const Positions& rest, const Faces& faces,
                 const std::vector<int>& object_offsets, const std::vector<std::string>& object_names);

  // Stores frame t (0 <= t <= last_frame) of `level`: positions x (rest.rows() rows) and stats
  // (a new stat name creates its dataset, NaN in every frame and flushed before it gets its name, so
  // that frames already done read NaN there even after a crash), flushes, then sets done[t] = 1 and
  // flushes again, so a crash never leaves done = 1 without the frame's data.
  // Frames may come in any order; writing a frame again overwrites it (its done flag is cleared and
  // flushed first).
  void write_frame(int level, int t, const Positions& x, const FrameStats& stats);

  // Off: write_frame does not flush (the order above then holds only once flush() is called). For a
  // writer whose frames are kept durably elsewhere: the farm's scheduler records each frame in SQLite
  // and rebuilds the file from there after a crash, and two HDF5 flushes (each an fsync) per frame
  // were its bottleneck (docs/performance.md, "The farm under load"). Default on.
  void set_flush_each_frame(bool on);
  // Writes everything buffered to the file (HDF5's flush: metadata and data, then fsync).
  void flush();

  // Positions of a frame this writer stored (done), read back from the file: the farm's scheduler
  // feeds stored frames to workers from its open job file. Throws InputError like FrameReader::frame
  // for a level or frame out of range or not done.
  Positions read_frame(int level, int t) const;
  bool is_done(int level, int t) const;  // false outside the ranges

  // The statistics stored for frame t of `level` (done), read back from the file: the scalars sorted
  // by name, without those that read NaN (not stored for the frame), and center_of_mass (num_objects
  // rows, or zero rows when every entry is NaN, i.e. it was not computed). A frame written with these
  // stats gives them back bit for bit, in that order. Throws InputError like read_frame.
  FrameStats read_stats(int level, int t) const;

  // Withdraws frame t of `level`: sets done[t] = 0 and flushes (the positions and statistics stay in
  // the file until the frame is written again). Throws InputError for a level or frame out of range.
  void clear_frame(int level, int t);

  int num_levels() const;
  int num_frames() const;  // last_frame + 1
  const std::string& path() const;

  // Flushes and closes the file (throws InputError if that fails); add_level and write_frame throw
  // afterwards. Calling it again does nothing. The destructor closes without throwing.
  void close();

 private:
  struct Impl;
  explicit FrameWriter(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// Reads a frame file; the file stays open (read-only) while the reader lives. Shapes are checked
// when the file is opened.
class FrameReader {
 public:
  // Throws InputError "<path>: <object>: ..." if the file is missing, not HDF5, truncated, locked by a
  // writer, has another format_version, or fails any check of store/frame_file_check.h (a dataset
  // missing or of the wrong shape or type, an index or flag out of range, a non-finite rest position,
  // done frames that were never written, a count above the limits of docs/frame-format.md).
  explicit FrameReader(const std::string& path);
  FrameReader(FrameReader&&) noexcept;
  FrameReader& operator=(FrameReader&&) noexcept;
  FrameReader(const FrameReader&) = delete;
  FrameReader& operator=(const FrameReader&) = delete;
  ~FrameReader();

  const std::string& path() const;
  int format_version() const;
  int num_levels() const;
  int num_frames() const;  // N + 1, the same for every level
  std::string scene_json() const;

  // All the following throw InputError for a level outside [0, num_levels()).
  int num_vertices(int level) const;
  int num_objects(int level) const;
  Positions rest_positions(int level) const;
  Faces faces(int level) const;
  std::vector<int> object_offsets(int level) const;
  std::vector<std::string> object_names(int level) const;
  std::vector<uint8_t> done(int level) const;  // num_frames() entries, 1 where stored

  // Positions of frame t; throws InputError when t is outside [0, num_frames()), not done, its data
  // was never written, or a coordinate is not finite ("frame 7 of level 0: vertex 12 is not finite").
  Positions frame(int level, int t) const;
  // Centre of mass per object at frame t (NaN rows if not recorded); the range and done checks of
  // frame(), and InputError for an infinite entry.
  ObjectPoints center_of_mass(int level, int t) const;

  // Names of the scalar statistics of `level`, sorted (center_of_mass is not among them).
  std::vector<std::string> stat_names(int level) const;
  // num_frames() values, NaN where not stored. Throws InputError for an unknown name.
  std::vector<double> stat(int level, const std::string& name) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Writes one OBJ per done frame of `level` (faces of the level) to dir/frame_%05d.obj, numbered by
// frame t; creates dir. Returns the number of files written.
int export_obj_frames(const FrameReader& reader, int level, const std::string& dir);

}  // namespace pd
