#include "store/frame_store.h"

#include <sys/stat.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <system_error>
#include <utility>

#include "geometry/obj_io.h"
#include "store/frame_file_check.h"
#include "store/h5_util.h"

namespace pd {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
using h5::File;
using h5::Handle;
using h5::level_name;
using h5::quiet_hdf5;
using h5::Shape;
using h5::vlen_string_type;

void check_stat_name(const File& f, const std::string& name, int level) {
  if (!valid_stat_name(name)) f.fail(level_name("/levels", level, "stats"), "invalid statistic name '" + name + "'");
}

// add_level on a file whose /hierarchy/<l> was written by write_hierarchy: the stored rest mesh,
// offsets and names must equal the given ones bit for bit, else InputError naming the dataset.
void check_stored_level(const File& f, const std::string& where, const Positions& rest, const Faces& faces,
                        const std::vector<int>& object_offsets, const std::vector<std::string>& object_names) {
  auto differs = [&](const std::string& name, const std::string& what) {
    f.fail(name, "stored " + what + " differs from the one given to add_level (the level does not belong to "
                 "the stored hierarchy)");
  };
  auto rows_of = [&](const std::string& name, H5T_class_t cls, long long cols) {
    Shape d;
    f.open(name, cls, cols > 0 ? std::vector<long long>{-1, cols} : std::vector<long long>{-1}, &d);
    return static_cast<long long>(d[0]);
  };
  const std::string rp = where + "/rest_positions", fp = where + "/faces", op = where + "/object_offsets",
                    np = where + "/object_names";
  if (rows_of(rp, H5T_FLOAT, 3) != rest.rows()) differs(rp, "vertex count");
  Positions V(rest.rows(), 3);
  f.read_into(rp, H5T_NATIVE_DOUBLE, H5T_FLOAT, {V.rows(), 3}, V.data());
  if (std::memcmp(V.data(), rest.data(), sizeof(double) * static_cast<size_t>(V.size())) != 0)
    differs(rp, "rest positions");
  if (rows_of(fp, H5T_INTEGER, 3) != faces.rows()) differs(fp, "face count");
  Faces F(faces.rows(), 3);
  f.read_into(fp, H5T_NATIVE_INT, H5T_INTEGER, {F.rows(), 3}, F.data());
  if (F != faces) differs(fp, "faces");
  const long long k1 = static_cast<long long>(object_offsets.size());
  if (rows_of(op, H5T_INTEGER, 0) != k1) differs(op, "object count");
  std::vector<int> off(object_offsets.size());
  f.read_into(op, H5T_NATIVE_INT, H5T_INTEGER, {k1}, off.data());
  if (off != object_offsets) differs(op, "object offsets");
  Handle d = f.open(np, H5T_STRING, {k1 - 1});
  if (f.read_strings(d.get(), false, np, static_cast<hsize_t>(k1 - 1)) != object_names) differs(np, "object names");
}

// The names of the scalar statistics of `level` (the links of /levels/<level>/stats but
// center_of_mass), sorted.
std::vector<std::string> stat_names_of(const File& f, int level) {
  const std::string name = level_name("/levels", level, "stats");
  Handle g = f.checked(H5Gopen2(f.id.get(), name.c_str(), H5P_DEFAULT), H5Gclose, name, "missing group");
  std::vector<std::string> out;
  auto collect = [](hid_t, const char* link, const H5L_info_t*, void* names) -> herr_t {
    if (std::string(link) != "center_of_mass") static_cast<std::vector<std::string>*>(names)->push_back(link);
    return 0;
  };
  f.check(H5Literate(g.get(), H5_INDEX_NAME, H5_ITER_INC, nullptr, collect, &out), name, "cannot list group");
  return out;
}

// File access for writers: every object in the oldest format that can hold it, at most HDF5 1.8's, so
// the superblock stays version 0 (what H5P_DEFAULT gives today; pinned so that it stays so). A version
// 3 superblock (libver "latest", which SWMR needs) marks the file "open for write" in the file itself;
// a writer killed before closing leaves the mark and every later open fails until h5clear removes it
// (measured on HDF5 1.10.8). Version 0 has no such mark: the guard against a second writer is HDF5's
// file lock (flock), which the kernel drops when the holding process dies.
Handle writer_access(const File& f) {
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  f.check(H5Pset_libver_bounds(fapl.get(), H5F_LIBVER_EARLIEST, H5F_LIBVER_V18), "", "cannot set format bounds");
  return fapl;
}

// A writer killed inside H5Fflush can leave the file longer than the allocated end its superblock
// records (objects were written, the superblock not yet). Such a file may open and read correctly,
// but writing on allocates from the recorded end, over stored objects: in 720 kills measured with
// tests/store/frame_store_kill_test.cpp, 17 files opened and then failed a later write ("incorrect
// cache entry type", "addr overflow") or read back a frame wrong after write_frame had returned; all
// 17 were longer than recorded (as were 152 others), none of the 550 files of the recorded length
// was. A file HDF5 closed or flushed completely ends exactly there (HDF5 truncates it to it).
void check_closed_cleanly(const File& f) {
  haddr_t eoa = 0;
  f.check(H5Fget_eoa(f.id.get(), &eoa), "", "cannot get the allocated end of the file");
  struct stat st;
  if (fstat(f.descriptor(), &st) != 0) f.fail("", std::string("cannot stat: ") + std::strerror(errno));
  if (static_cast<haddr_t>(st.st_size) != eoa)
    f.fail("", "not closed cleanly by its last writer (killed while flushing?): the file has " +
                   std::to_string(st.st_size) + " bytes but HDF5 allocated " + std::to_string(eoa) +
                   "; writing on could overwrite stored data, so it must be rebuilt");
}

// Opens f.path (read-write if `write`) and checks what FrameReader promises: format_version, the scene
// attribute and, for every level, that its datasets exist with consistent shapes. Returns the counts
// per level; *num_frames gets N + 1 (from level 0's done). Throws InputError naming the object.
std::vector<LevelCounts> open_frame_file(File& f, bool write, int* format_version, int* num_frames) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(f.path, ec)) f.fail("", "no such file");
  check_global_heaps(f);  // before HDF5 parses anything (see frame_file_check.h)
  htri_t is_hdf5 = H5Fis_hdf5(f.path.c_str());
  if (is_hdf5 == 0) f.fail("", "not an HDF5 file");
  if (is_hdf5 < 0) f.fail_h5("", "cannot read the file");
  if (write) {
    Handle fapl = writer_access(f);
    f.id = f.checked(H5Fopen(f.path.c_str(), H5F_ACC_RDWR, fapl.get()), H5Fclose, "",
                     "cannot open the HDF5 file for writing (truncated, or locked by another process?)");
    f.close_on_exec();
    check_closed_cleanly(f);
  } else {
    f.id = f.checked(H5Fopen(f.path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose, "",
                     "cannot open the HDF5 file (truncated, or locked by a writer?)");
  }
  *format_version = kFrameFormatVersion;  // check_frame_file refuses any other
  return check_frame_file(f, num_frames);
}

}  // namespace

bool valid_stat_name(const std::string& name) {
  return !name.empty() && name.find('/') == std::string::npos && name != "." && name != "center_of_mass";
}

// ---------------------------------------------------------------------------------------------------
// FrameWriter

struct FrameWriter::Impl {
  struct Level {
    int num_vertices = 0, num_objects = 0;
    Handle positions, done, center_of_mass;
    std::map<std::string, Handle> scalars;
    std::vector<uint8_t> is_done;  // this writer's copy of `done`
  };
  File file;  // declared before `levels`, so the datasets are closed before the file
  int num_frames = 0;
  std::vector<Level> levels;
  bool flush_each_frame = true;  // write_frame's crash-safe order (see the header)

  void require_open() const {
    if (!file.id.valid()) file.fail("", "frame file already closed");
  }
  // The level of frame t after the range checks (and, if need_done, the check that the frame is done);
  // `leaf` names the dataset in the errors, e.g. "/levels/1/positions: frame 3 of level 1 is not done".
  Level& frame_level(int level, int t, const char* leaf, bool need_done) {
    require_open();
    const std::string object = level_name("/levels", level, leaf);
    if (level < 0 || level >= static_cast<int>(levels.size()))
      file.fail(object, "level out of range [0, " + std::to_string(levels.size()) + ")");
    const std::string what = "frame " + std::to_string(t) + " of level " + std::to_string(level);
    if (t < 0 || t >= num_frames) file.fail(object, what + " out of range [0, " + std::to_string(num_frames) + ")");
    if (need_done && !levels[level].is_done[t]) file.fail(object, what + " is not done");
    return levels[level];
  }
  // Opens the datasets of level l of an existing file (shapes checked by open_frame_file) and reads
  // its done flags and the names of its statistics.
  void load_level(int l, const LevelCounts& counts);
};

void FrameWriter::Impl::load_level(int l, const LevelCounts& counts) {
  const File& f = file;
  const long long frames = num_frames;
  Level lv;
  lv.num_vertices = counts.num_vertices;
  lv.num_objects = counts.num_objects;
  lv.positions = f.open(level_name("/levels", l, "positions"), H5T_FLOAT, {frames, lv.num_vertices, 3});
  lv.center_of_mass = f.open(level_name("/levels", l, "stats/center_of_mass"), H5T_FLOAT, {frames, lv.num_objects, 3});
  const std::string done = level_name("/levels", l, "done");
  lv.done = f.open(done, H5T_INTEGER, {frames});
  lv.is_done.assign(num_frames, 0);
  f.io(false, lv.done.get(), done, H5T_NATIVE_UINT8, {0}, {static_cast<hsize_t>(frames)}, lv.is_done.data());
  for (uint8_t& d : lv.is_done) d = d == 1 ? 1 : 0;  // as FrameReader: only 1 means stored
  for (const std::string& name : stat_names_of(f, l)) {
    check_stat_name(f, name, l);
    lv.scalars.emplace(name, f.open(level_name("/levels", l, "stats/") + name, H5T_FLOAT, {frames}));
  }
  levels.push_back(std::move(lv));
}

FrameWriter::FrameWriter(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
FrameWriter::FrameWriter(FrameWriter&&) noexcept = default;
FrameWriter& FrameWriter::operator=(FrameWriter&&) noexcept = default;
FrameWriter::~FrameWriter() = default;

FrameWriter FrameWriter::create(const std::string& path, const std::string& scene_json, int last_frame) {
  quiet_hdf5();
  auto impl = std::make_unique<Impl>();
  File& f = impl->file;
  f.path = path;
  if (last_frame < 0) f.fail("", "last_frame must be >= 0, got " + std::to_string(last_frame));
  impl->num_frames = last_frame + 1;
  Handle fapl = writer_access(f);
  f.id = f.checked(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get()), H5Fclose, "",
                   "cannot create HDF5 file");
  f.close_on_exec();
  Handle scalar(H5Screate(H5S_SCALAR), H5Sclose);
  Handle version = f.checked(H5Acreate2(f.id.get(), "format_version", H5T_STD_I32LE, scalar.get(), H5P_DEFAULT,
                                        H5P_DEFAULT), H5Aclose, "/@format_version", "cannot create attribute");
  f.check(H5Awrite(version.get(), H5T_NATIVE_INT, &kFrameFormatVersion), "/@format_version", "write failed");
  Handle str = vlen_string_type();
  Handle scene = f.checked(H5Acreate2(f.id.get(), "scene", str.get(), scalar.get(), H5P_DEFAULT, H5P_DEFAULT),
                           H5Aclose, "/@scene", "cannot create attribute");
  const char* text = scene_json.c_str();
  f.check(H5Awrite(scene.get(), str.get(), &text), "/@scene", "write failed");
  f.make_group("/hierarchy");
  f.make_group("/levels");
  f.flush();
  return FrameWriter(std::move(impl));
}

FrameWriter FrameWriter::open(const std::string& path) {
  quiet_hdf5();
  auto impl = std::make_unique<Impl>();
  impl->file.path = path;
  int version = 0;
  const std::vector<LevelCounts> counts = open_frame_file(impl->file, true, &version, &impl->num_frames);
  for (int l = 0; l < static_cast<int>(counts.size()); ++l) impl->load_level(l, counts[l]);
  return FrameWriter(std::move(impl));
}

void FrameWriter::add_level(int level, const Positions& rest, const Faces& faces,
                            const std::vector<int>& object_offsets, const std::vector<std::string>& object_names) {
  impl_->require_open();
  const File& f = impl_->file;
  const std::string where = level_name("/hierarchy", level), data = level_name("/levels", level);
  if (level != num_levels()) f.fail(where, "levels are added in order, expected level " + std::to_string(num_levels()));
  const int n = static_cast<int>(rest.rows()), k = static_cast<int>(object_names.size());
  if (n == 0) f.fail(where, "level has no vertices");
  if (k == 0 || object_offsets.size() != object_names.size() + 1)
    f.fail(where, "need num_objects >= 1 names and num_objects + 1 offsets, got " + std::to_string(k) + " and " +
                      std::to_string(object_offsets.size()));
  bool ok = object_offsets.front() == 0 && object_offsets.back() == n;
  for (int i = 0; ok && i < k; ++i) ok = object_offsets[i] <= object_offsets[i + 1];
  if (!ok) f.fail(where, "object_offsets must not decrease and run from 0 to " + std::to_string(n));
  if (faces.size() > 0 && (faces.minCoeff() < 0 || faces.maxCoeff() >= n))
    f.fail(where, "face index outside [0, " + std::to_string(n) + ")");

  const hsize_t un = static_cast<hsize_t>(n), uk = static_cast<hsize_t>(k);
  const hsize_t frames = static_cast<hsize_t>(impl_->num_frames);
  if (f.exists(where + "/rest_positions")) {
    // Written before by write_hierarchy (store/hierarchy_store.h): the level must be that one.
    check_stored_level(f, where, rest, faces, object_offsets, object_names);
    for (const std::string& g : {data, data + "/stats"}) f.make_group(g);
  } else {
    if (!f.exists(where)) f.make_group(where);
    for (const std::string& g : {data, data + "/stats"}) f.make_group(g);
    f.write_whole(where + "/rest_positions", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {un, 3}, rest.data());
    f.write_whole(where + "/faces", H5T_STD_I32LE, H5T_NATIVE_INT, {static_cast<hsize_t>(faces.rows()), 3},
                  faces.data());
    f.write_whole(where + "/object_offsets", H5T_STD_I32LE, H5T_NATIVE_INT, {uk + 1}, object_offsets.data());
    std::vector<const char*> names;
    for (const std::string& s : object_names) names.push_back(s.c_str());
    Handle str = vlen_string_type();
    f.write_whole(where + "/object_names", str.get(), str.get(), {uk}, names.data());
  }

  Impl::Level lv;
  lv.num_vertices = n;
  lv.num_objects = k;
  lv.is_done.assign(frames, 0);
  const uint8_t zero = 0;
  lv.positions = f.create(data + "/positions", H5T_IEEE_F64LE, {frames, un, 3}, {1, un, 3}, H5T_NATIVE_DOUBLE, &kNaN);
  // Allocated and filled now: see File::create_filled.
  lv.done = f.create_filled(data + "/done", H5T_STD_U8LE, frames, H5T_NATIVE_UINT8, &zero);
  f.link(lv.done, data + "/done");
  lv.center_of_mass = f.create(data + "/stats/center_of_mass", H5T_IEEE_F64LE, {frames, uk, 3}, {1, uk, 3},
                               H5T_NATIVE_DOUBLE, &kNaN);
  impl_->levels.push_back(std::move(lv));
  f.flush();
}

void FrameWriter::write_frame(int level, int t, const Positions& x, const FrameStats& stats) {
  impl_->require_open();
  const File& f = impl_->file;
  const bool flush = impl_->flush_each_frame;
  const std::string data = level_name("/levels", level);
  if (level < 0 || level >= num_levels())
    f.fail(data, "level out of range [0, " + std::to_string(num_levels()) + ")");
  if (t < 0 || t >= impl_->num_frames)
    f.fail(data + "/positions",
           "frame " + std::to_string(t) + " out of range [0, " + std::to_string(impl_->num_frames) + ")");
  Impl::Level& lv = impl_->levels[level];
  if (x.rows() != lv.num_vertices)
    f.fail(data + "/positions", "got " + std::to_string(x.rows()) + " rows, need " + std::to_string(lv.num_vertices));
  const auto com_rows = stats.center_of_mass.rows();
  if (com_rows != 0 && com_rows != lv.num_objects)
    f.fail(data + "/stats/center_of_mass", "got " + std::to_string(com_rows) + " rows, need 0 or " +
                                               std::to_string(lv.num_objects));
  std::map<std::string, double> scalars;
  for (const auto& [name, value] : stats.scalars) {
    check_stat_name(f, name, level);
    if (!scalars.emplace(name, value).second) f.fail(data + "/stats/" + name, "statistic given twice");
  }

  const hsize_t ut = static_cast<hsize_t>(t), n = static_cast<hsize_t>(lv.num_vertices);
  uint8_t flag = 0;
  if (lv.is_done[t]) {  // rewriting a stored frame: withdraw its done flag first
    f.io(true, lv.done.get(), data + "/done", H5T_NATIVE_UINT8, {ut}, {1}, &flag);
    if (flush) f.flush();
    lv.is_done[t] = 0;
  }
  f.io(true, lv.positions.get(), data + "/positions", H5T_NATIVE_DOUBLE, {ut, 0, 0}, {1, n, 3},
       const_cast<double*>(x.data()));
  if (com_rows != 0)
    f.io(true, lv.center_of_mass.get(), data + "/stats/center_of_mass", H5T_NATIVE_DOUBLE, {ut, 0, 0},
         {1, static_cast<hsize_t>(com_rows), 3}, const_cast<double*>(stats.center_of_mass.data()));
  // A statistic new to the level: its dataset, NaN everywhere, is in the file (flushed) before a link
  // names it, so that no kill can show unfilled storage in the frames already done.
  std::vector<std::pair<std::string, Handle>> created;
  for (const auto& [name, value] : scalars)
    if (lv.scalars.count(name) == 0)
      created.emplace_back(name, f.create_filled(data + "/stats/" + name, H5T_IEEE_F64LE,
                                                 static_cast<hsize_t>(impl_->num_frames), H5T_NATIVE_DOUBLE, &kNaN));
  if (flush && !created.empty()) f.flush();
  for (auto& [name, dset] : created) {
    f.link(dset, data + "/stats/" + name);
    lv.scalars.emplace(name, std::move(dset));
  }
  for (auto& [name, value] : scalars)
    f.io(true, lv.scalars.at(name).get(), data + "/stats/" + name, H5T_NATIVE_DOUBLE, {ut}, {1}, &value);
  if (flush) f.flush();  // the frame's data is on disk before its done flag is set
  flag = 1;
  f.io(true, lv.done.get(), data + "/done", H5T_NATIVE_UINT8, {ut}, {1}, &flag);
  if (flush) f.flush();
  lv.is_done[t] = 1;
}

void FrameWriter::set_flush_each_frame(bool on) { impl_->flush_each_frame = on; }

void FrameWriter::flush() {
  impl_->require_open();
  impl_->file.flush();
}

Positions FrameWriter::read_frame(int level, int t) const {
  const Impl::Level& lv = impl_->frame_level(level, t, "positions", true);
  Positions x(lv.num_vertices, 3);
  impl_->file.io(false, lv.positions.get(), level_name("/levels", level, "positions"), H5T_NATIVE_DOUBLE,
                 {static_cast<hsize_t>(t), 0, 0}, {1, static_cast<hsize_t>(lv.num_vertices), 3}, x.data());
  return x;
}

FrameStats FrameWriter::read_stats(int level, int t) const {
  const Impl::Level& lv = impl_->frame_level(level, t, "stats", true);
  const File& f = impl_->file;
  const hsize_t ut = static_cast<hsize_t>(t);
  FrameStats out;
  for (const auto& [name, dset] : lv.scalars) {  // std::map: sorted by name
    double value = kNaN;
    f.io(false, dset.get(), level_name("/levels", level, "stats/") + name, H5T_NATIVE_DOUBLE, {ut}, {1}, &value);
    if (!std::isnan(value)) out.scalars.emplace_back(name, value);
  }
  out.center_of_mass.resize(lv.num_objects, 3);
  f.io(false, lv.center_of_mass.get(), level_name("/levels", level, "stats/center_of_mass"), H5T_NATIVE_DOUBLE,
       {ut, 0, 0}, {1, static_cast<hsize_t>(lv.num_objects), 3}, out.center_of_mass.data());
  if (out.center_of_mass.array().isNaN().all()) out.center_of_mass.resize(0, 3);  // not computed for the frame
  return out;
}

void FrameWriter::clear_frame(int level, int t) {
  Impl::Level& lv = impl_->frame_level(level, t, "done", false);
  uint8_t zero = 0;
  impl_->file.io(true, lv.done.get(), level_name("/levels", level, "done"), H5T_NATIVE_UINT8,
                 {static_cast<hsize_t>(t)}, {1}, &zero);
  impl_->file.flush();
  lv.is_done[t] = 0;
}

bool FrameWriter::is_done(int level, int t) const {
  if (level < 0 || level >= num_levels() || t < 0 || t >= impl_->num_frames) return false;
  return impl_->levels[level].is_done[t] != 0;
}

int FrameWriter::num_levels() const { return static_cast<int>(impl_->levels.size()); }
int FrameWriter::num_frames() const { return impl_->num_frames; }
const std::string& FrameWriter::path() const { return impl_->file.path; }

void FrameWriter::close() {
  File& f = impl_->file;
  if (!f.id.valid()) return;
  f.flush();
  impl_->levels.clear();
  f.check(f.id.reset(), "", "close failed");
}

// ---------------------------------------------------------------------------------------------------
// FrameReader

struct FrameReader::Impl {
  using Level = LevelCounts;
  File file;
  int format_version = 0;
  int num_frames = 0;
  std::vector<Level> levels;

  const Level& level(int l) const {
    if (l < 0 || l >= static_cast<int>(levels.size()))
      file.fail(level_name("/levels", l), "level out of range [0, " + std::to_string(levels.size()) + ")");
    return levels[l];
  }
  std::vector<uint8_t> done(int l) const {
    std::vector<uint8_t> out(num_frames);
    file.read_into(level_name("/levels", l, "done"), H5T_NATIVE_UINT8, H5T_INTEGER, {num_frames}, out.data());
    return out;
  }
  const Level& check_done(int l, int t) const {
    const Level& lv = level(l);
    const std::string what = "frame " + std::to_string(t) + " of level " + std::to_string(l);
    if (t < 0 || t >= num_frames)
      file.fail(level_name("/levels", l, "positions"), what + " out of range [0, " + std::to_string(num_frames) + ")");
    // One flag, not the whole dataset: reading every done frame stays linear in the frame count.
    const std::string dp = level_name("/levels", l, "done");
    Handle d = file.open(dp, H5T_INTEGER, {num_frames}, nullptr, 1);
    uint8_t flag = 0;
    file.io(false, d.get(), dp, H5T_NATIVE_UINT8, {static_cast<hsize_t>(t)}, {1}, &flag);
    if (flag != 1) file.fail(level_name("/levels", l, "positions"), what + " is not done");
    return lv;
  }
  // Reads the (rows, 3) block of frame t from a (num_frames, rows, 3) dataset; if need_stored, the
  // block must have been written (see check_frame_stored).
  void read_frame_block(const std::string& name, int l, int t, long long rows, double* out, bool need_stored) const {
    Handle d = file.open(name, H5T_FLOAT, {num_frames, rows, 3});
    if (need_stored) check_frame_stored(file, d.get(), name, l, t);
    file.io(false, d.get(), name, H5T_NATIVE_DOUBLE, {static_cast<hsize_t>(t), 0, 0},
            {1, static_cast<hsize_t>(rows), 3}, out);
  }
};

FrameReader::FrameReader(const std::string& path) : impl_(std::make_unique<Impl>()) {
  quiet_hdf5();
  impl_->file.path = path;
  impl_->levels = open_frame_file(impl_->file, false, &impl_->format_version, &impl_->num_frames);
}

FrameReader::FrameReader(FrameReader&&) noexcept = default;
FrameReader& FrameReader::operator=(FrameReader&&) noexcept = default;
FrameReader::~FrameReader() = default;

const std::string& FrameReader::path() const { return impl_->file.path; }
int FrameReader::format_version() const { return impl_->format_version; }
int FrameReader::num_levels() const { return static_cast<int>(impl_->levels.size()); }
int FrameReader::num_frames() const { return impl_->num_frames; }
int FrameReader::num_vertices(int level) const { return impl_->level(level).num_vertices; }
int FrameReader::num_objects(int level) const { return impl_->level(level).num_objects; }

std::string FrameReader::scene_json() const {
  const File& f = impl_->file;
  Handle a = f.checked(H5Aopen(f.id.get(), "scene", H5P_DEFAULT), H5Aclose, "/@scene", "missing attribute");
  return impl_->file.read_strings(a.get(), true, "/@scene", 1, kMaxSceneTextBytes).front();
}

Positions FrameReader::rest_positions(int level) const {
  Positions V(impl_->level(level).num_vertices, 3);
  impl_->file.read_into(level_name("/hierarchy", level, "rest_positions"), H5T_NATIVE_DOUBLE, H5T_FLOAT,
                        {V.rows(), 3}, V.data());
  return V;
}

Faces FrameReader::faces(int level) const {
  const Impl::Level& lv = impl_->level(level);
  const std::string name = level_name("/hierarchy", level, "faces");
  Faces F(lv.num_faces, 3);
  impl_->file.read_into(name, H5T_NATIVE_INT, H5T_INTEGER, {F.rows(), 3}, F.data());
  if (F.size() > 0 && (F.minCoeff() < 0 || F.maxCoeff() >= lv.num_vertices))
    impl_->file.fail(name, "face index outside [0, " + std::to_string(lv.num_vertices) + ")");
  return F;
}

std::vector<int> FrameReader::object_offsets(int level) const {
  const Impl::Level& lv = impl_->level(level);
  const std::string name = level_name("/hierarchy", level, "object_offsets");
  std::vector<int> off(lv.num_objects + 1);
  impl_->file.read_into(name, H5T_NATIVE_INT, H5T_INTEGER, {lv.num_objects + 1}, off.data());
  bool ok = off.front() == 0 && off.back() == lv.num_vertices;
  for (size_t i = 0; ok && i + 1 < off.size(); ++i) ok = off[i] <= off[i + 1];
  if (!ok) impl_->file.fail(name, "offsets must not decrease and run from 0 to " + std::to_string(lv.num_vertices));
  return off;
}

std::vector<std::string> FrameReader::object_names(int level) const {
  const std::string name = level_name("/hierarchy", level, "object_names");
  const int k = impl_->level(level).num_objects;
  Handle d = impl_->file.open(name, H5T_STRING, {k});
  return impl_->file.read_strings(d.get(), false, name, static_cast<hsize_t>(k));
}

std::vector<uint8_t> FrameReader::done(int level) const {
  impl_->level(level);
  return impl_->done(level);
}

Positions FrameReader::frame(int level, int t) const {
  Positions X(impl_->check_done(level, t).num_vertices, 3);
  const std::string name = level_name("/levels", level, "positions");
  impl_->read_frame_block(name, level, t, X.rows(), X.data(), true);
  check_finite(impl_->file, name, X.data(), static_cast<size_t>(X.size()), 3,
               "frame " + std::to_string(t) + " of level " + std::to_string(level) + ": vertex");
  return X;
}

ObjectPoints FrameReader::center_of_mass(int level, int t) const {
  ObjectPoints C(impl_->check_done(level, t).num_objects, 3);
  const std::string name = level_name("/levels", level, "stats/center_of_mass");
  impl_->read_frame_block(name, level, t, C.rows(), C.data(), false);
  // NaN means "not computed" (docs/frame-format.md); an infinite centre is corrupt.
  for (Eigen::Index i = 0; i < C.size(); ++i)
    if (std::isinf(C.data()[i]))
      impl_->file.fail(name, "frame " + std::to_string(t) + " of level " + std::to_string(level) + ": object " +
                                 std::to_string(i / 3) + " is not finite (inf)");
  return C;
}

std::vector<std::string> FrameReader::stat_names(int level) const {
  impl_->level(level);
  return stat_names_of(impl_->file, level);
}

std::vector<double> FrameReader::stat(int level, const std::string& name) const {
  impl_->level(level);
  const File& f = impl_->file;
  check_stat_name(f, name, level);
  const std::string ds = level_name("/levels", level, "stats/") + name;
  if (H5Lexists(f.id.get(), ds.c_str(), H5P_DEFAULT) <= 0) f.fail(ds, "no such statistic");
  std::vector<double> out(impl_->num_frames);
  f.read_into(ds, H5T_NATIVE_DOUBLE, H5T_FLOAT, {impl_->num_frames}, out.data());
  return out;
}

int export_obj_frames(const FrameReader& reader, int level, const std::string& dir) {
  const Faces F = reader.faces(level);
  const std::vector<uint8_t> done = reader.done(level);
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw InputError(dir + ": cannot create directory: " + ec.message());
  int count = 0;
  for (int t = 0; t < static_cast<int>(done.size()); ++t) {
    if (done[t] != 1) continue;
    char file[32];
    std::snprintf(file, sizeof file, "frame_%05d.obj", t);
    write_obj((std::filesystem::path(dir) / file).string(), reader.frame(level, t), F);
    ++count;
  }
  return count;
}

}  // namespace pd
