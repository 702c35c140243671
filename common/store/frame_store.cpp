#include "store/frame_store.h"

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <system_error>
#include <utility>

#include "geometry/obj_io.h"
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
  if (name.empty() || name.find('/') != std::string::npos || name == "." || name == "center_of_mass")
    f.fail(level_name("/levels", level, "stats"), "invalid statistic name '" + name + "'");
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

}  // namespace

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

  void require_open() const {
    if (!file.id.valid()) file.fail("", "frame file already closed");
  }
};

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
  f.id = f.checked(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose, "",
                   "cannot create HDF5 file");
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
  lv.done = f.create(data + "/done", H5T_STD_U8LE, {frames}, {}, H5T_NATIVE_UINT8, &zero);
  lv.center_of_mass = f.create(data + "/stats/center_of_mass", H5T_IEEE_F64LE, {frames, uk, 3}, {1, uk, 3},
                               H5T_NATIVE_DOUBLE, &kNaN);
  impl_->levels.push_back(std::move(lv));
  f.flush();
}

void FrameWriter::write_frame(int level, int t, const Positions& x, const FrameStats& stats) {
  impl_->require_open();
  const File& f = impl_->file;
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
    f.flush();
    lv.is_done[t] = 0;
  }
  f.io(true, lv.positions.get(), data + "/positions", H5T_NATIVE_DOUBLE, {ut, 0, 0}, {1, n, 3},
       const_cast<double*>(x.data()));
  if (com_rows != 0)
    f.io(true, lv.center_of_mass.get(), data + "/stats/center_of_mass", H5T_NATIVE_DOUBLE, {ut, 0, 0},
         {1, static_cast<hsize_t>(com_rows), 3}, const_cast<double*>(stats.center_of_mass.data()));
  for (auto& [name, value] : scalars) {
    const std::string ds = data + "/stats/" + name;
    auto it = lv.scalars.find(name);
    if (it == lv.scalars.end()) {
      Handle h = f.create(ds, H5T_IEEE_F64LE, {static_cast<hsize_t>(impl_->num_frames)}, {}, H5T_NATIVE_DOUBLE, &kNaN);
      it = lv.scalars.emplace(name, std::move(h)).first;
    }
    f.io(true, it->second.get(), ds, H5T_NATIVE_DOUBLE, {ut}, {1}, &value);
  }
  f.flush();  // the frame's data is on disk before its done flag is set
  flag = 1;
  f.io(true, lv.done.get(), data + "/done", H5T_NATIVE_UINT8, {ut}, {1}, &flag);
  f.flush();
  lv.is_done[t] = 1;
}

Positions FrameWriter::read_frame(int level, int t) const {
  impl_->require_open();
  const File& f = impl_->file;
  const std::string data = level_name("/levels", level, "positions");
  if (level < 0 || level >= num_levels()) f.fail(data, "level out of range [0, " + std::to_string(num_levels()) + ")");
  const Impl::Level& lv = impl_->levels[level];
  const std::string what = "frame " + std::to_string(t) + " of level " + std::to_string(level);
  if (t < 0 || t >= impl_->num_frames)
    f.fail(data, what + " out of range [0, " + std::to_string(impl_->num_frames) + ")");
  if (!lv.is_done[t]) f.fail(data, what + " is not done");
  Positions x(lv.num_vertices, 3);
  f.io(false, lv.positions.get(), data, H5T_NATIVE_DOUBLE, {static_cast<hsize_t>(t), 0, 0},
       {1, static_cast<hsize_t>(lv.num_vertices), 3}, x.data());
  return x;
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
  struct Level { int num_vertices = 0, num_faces = 0, num_objects = 0; };
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
    if (done(l)[t] != 1) file.fail(level_name("/levels", l, "positions"), what + " is not done");
    return lv;
  }
  // Reads the (rows, 3) block of frame t from a (num_frames, rows, 3) dataset.
  void read_frame_block(const std::string& name, int t, long long rows, double* out) const {
    Handle d = file.open(name, H5T_FLOAT, {num_frames, rows, 3});
    file.io(false, d.get(), name, H5T_NATIVE_DOUBLE, {static_cast<hsize_t>(t), 0, 0},
            {1, static_cast<hsize_t>(rows), 3}, out);
  }
};

FrameReader::FrameReader(const std::string& path) : impl_(std::make_unique<Impl>()) {
  quiet_hdf5();
  Impl& r = *impl_;
  File& f = r.file;
  f.path = path;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) f.fail("", "no such file");
  htri_t is_hdf5 = H5Fis_hdf5(path.c_str());
  if (is_hdf5 == 0) f.fail("", "not an HDF5 file");
  if (is_hdf5 < 0) f.fail_h5("", "cannot read the file");
  f.id = f.checked(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose, "",
                   "cannot open the HDF5 file (truncated, or locked by a writer?)");
  Handle version = f.checked(H5Aopen(f.id.get(), "format_version", H5P_DEFAULT), H5Aclose, "/@format_version",
                             "missing attribute, not a frame file");
  f.check(H5Aread(version.get(), H5T_NATIVE_INT, &r.format_version), "/@format_version", "read failed");
  if (r.format_version != kFrameFormatVersion)
    f.fail("/@format_version", "format_version " + std::to_string(r.format_version) + " unsupported (expected " +
                                   std::to_string(kFrameFormatVersion) + ")");
  scene_json();  // checks that the attribute exists and is a string
  Handle levels = f.checked(H5Gopen2(f.id.get(), "/levels", H5P_DEFAULT), H5Gclose, "/levels", "missing group");
  H5G_info_t info;
  f.check(H5Gget_info(levels.get(), &info), "/levels", "cannot list group");
  if (info.nlinks == 0) f.fail("/levels", "the file has no levels");
  for (int l = 0; l < static_cast<int>(info.nlinks); ++l) {
    Shape d;
    Impl::Level lv;
    f.open(level_name("/hierarchy", l, "rest_positions"), H5T_FLOAT, {-1, 3}, &d);
    lv.num_vertices = static_cast<int>(d[0]);
    f.open(level_name("/hierarchy", l, "faces"), H5T_INTEGER, {-1, 3}, &d);
    lv.num_faces = static_cast<int>(d[0]);
    f.open(level_name("/hierarchy", l, "object_offsets"), H5T_INTEGER, {-1}, &d);
    if (d[0] < 2) f.fail(level_name("/hierarchy", l, "object_offsets"), "needs at least 2 entries");
    lv.num_objects = static_cast<int>(d[0]) - 1;
    const long long n = lv.num_vertices, k = lv.num_objects;
    f.open(level_name("/hierarchy", l, "object_names"), H5T_STRING, {k});
    f.open(level_name("/levels", l, "done"), H5T_INTEGER, {l == 0 ? -1 : r.num_frames}, &d);
    if (l == 0) r.num_frames = static_cast<int>(d[0]);
    f.open(level_name("/levels", l, "positions"), H5T_FLOAT, {r.num_frames, n, 3});
    f.open(level_name("/levels", l, "stats/center_of_mass"), H5T_FLOAT, {r.num_frames, k, 3});
    r.levels.push_back(lv);
  }
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
  return impl_->file.read_strings(a.get(), true, "/@scene", 1).front();
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
  impl_->read_frame_block(level_name("/levels", level, "positions"), t, X.rows(), X.data());
  return X;
}

ObjectPoints FrameReader::center_of_mass(int level, int t) const {
  ObjectPoints C(impl_->check_done(level, t).num_objects, 3);
  impl_->read_frame_block(level_name("/levels", level, "stats/center_of_mass"), t, C.rows(), C.data());
  return C;
}

std::vector<std::string> FrameReader::stat_names(int level) const {
  impl_->level(level);
  const File& f = impl_->file;
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
