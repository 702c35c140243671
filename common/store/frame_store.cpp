#include "store/frame_store.h"

#include <hdf5.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <system_error>
#include <utility>

#include "geometry/obj_io.h"

namespace pd {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
using Shape = std::vector<hsize_t>;

// Owns one hid_t and closes it with the matching H5?close function.
class Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  Handle() = default;
  Handle(hid_t id, Closer closer) : id_(id), closer_(closer) {}
  Handle(Handle&& o) noexcept : id_(std::exchange(o.id_, H5I_INVALID_HID)), closer_(o.closer_) {}
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = std::exchange(o.id_, H5I_INVALID_HID);
      closer_ = o.closer_;
    }
    return *this;
  }
  ~Handle() { reset(); }
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }
  herr_t reset() {  // closes the id now; returns the close function's status
    herr_t status = id_ >= 0 && closer_ ? closer_(id_) : 0;
    id_ = H5I_INVALID_HID;
    return status;
  }

 private:
  hid_t id_ = H5I_INVALID_HID;
  Closer closer_ = nullptr;
};

// Turns off HDF5's printing of its error stack; failures are reported as InputError instead.
void quiet_hdf5() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

// The innermost message of the current HDF5 error stack ("" when empty).
std::string hdf5_detail() {
  std::string detail;
  auto take_first = [](unsigned n, const H5E_error2_t* err, void* out) -> herr_t {
    if (n == 0 && err->desc != nullptr) *static_cast<std::string*>(out) = err->desc;
    return 0;
  };
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, take_first, &detail);
  return detail;
}

Handle simple_space(const Shape& dims) {
  return Handle(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose);
}
Handle vlen_string_type() {
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type.get(), H5T_VARIABLE);
  H5Tset_cset(type.get(), H5T_CSET_UTF8);
  return type;
}
std::string level_name(const char* root, int level, const char* leaf = nullptr) {
  std::string name = std::string(root) + "/" + std::to_string(level);
  return leaf ? name + "/" + leaf : name;
}
std::string join(const std::vector<long long>& v) {  // "(5, *, 3)"; -1 prints as *
  std::string s;
  for (long long x : v) s += (s.empty() ? "" : ", ") + (x < 0 ? std::string("*") : std::to_string(x));
  return "(" + s + ")";
}

// An HDF5 file and its path; every failure becomes InputError "<path>: <object>: <what>".
struct File {
  std::string path;
  Handle id;

  [[noreturn]] void fail(const std::string& object, const std::string& what) const {
    throw InputError(path + ": " + (object.empty() ? "" : object + ": ") + what);
  }
  [[noreturn]] void fail_h5(const std::string& object, const std::string& what) const {
    std::string detail = hdf5_detail();
    fail(object, detail.empty() ? what : what + " (HDF5: " + detail + ")");
  }
  void check(herr_t status, const std::string& object, const char* what) const {
    if (status < 0) fail_h5(object, what);
  }
  Handle checked(hid_t h, Handle::Closer closer, const std::string& object, const char* what) const {
    if (h < 0) fail_h5(object, what);
    return Handle(h, closer);
  }

  void make_group(const std::string& name) const {
    checked(H5Gcreate2(id.get(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, name,
            "cannot create group");
  }
  // Creates dataset `name` with an optional fill value and, if chunk is non-empty, chunked layout.
  Handle create(const std::string& name, hid_t file_type, const Shape& dims, const Shape& chunk = {},
                hid_t fill_type = H5T_NATIVE_DOUBLE, const void* fill = nullptr) const {
    Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
    if (!chunk.empty())
      check(H5Pset_chunk(dcpl.get(), static_cast<int>(chunk.size()), chunk.data()), name, "bad chunk shape");
    if (fill) check(H5Pset_fill_value(dcpl.get(), fill_type, fill), name, "bad fill value");
    Handle space = simple_space(dims);
    return checked(H5Dcreate2(id.get(), name.c_str(), file_type, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT),
                   H5Dclose, name, "cannot create dataset");
  }
  // Reads (write = false) or writes the block [start, start + count) of dataset `dset` called `name`.
  void io(bool write, hid_t dset, const std::string& name, hid_t mem_type, const Shape& start, const Shape& count,
          void* data) const {
    for (hsize_t c : count)
      if (c == 0) return;  // nothing to transfer
    Handle file_space = checked(H5Dget_space(dset), H5Sclose, name, "cannot get dataspace");
    check(H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr),
          name, "block outside the dataset");
    Handle mem_space = simple_space(count);
    check(write ? H5Dwrite(dset, mem_type, mem_space.get(), file_space.get(), H5P_DEFAULT, data)
                : H5Dread(dset, mem_type, mem_space.get(), file_space.get(), H5P_DEFAULT, data),
          name, write ? "write failed" : "read failed");
  }
  void write_whole(const std::string& name, hid_t file_type, hid_t mem_type, const Shape& dims,
                   const void* data) const {
    Handle d = create(name, file_type, dims);
    io(true, d.get(), name, mem_type, Shape(dims.size(), 0), dims, const_cast<void*>(data));
  }
  // Opens dataset `name`, checks its type class and shape (-1 matches any extent); dims gets the shape.
  Handle open(const std::string& name, H5T_class_t cls, const std::vector<long long>& shape,
              Shape* dims = nullptr) const {
    Handle d = checked(H5Dopen2(id.get(), name.c_str(), H5P_DEFAULT), H5Dclose, name, "missing dataset");
    Handle type(H5Dget_type(d.get()), H5Tclose);
    if (H5Tget_class(type.get()) != cls) fail(name, "dataset has the wrong element type");
    Handle space(H5Dget_space(d.get()), H5Sclose);
    int rank = H5Sget_simple_extent_ndims(space.get());
    Shape got(rank > 0 ? rank : 0);
    if (rank > 0) H5Sget_simple_extent_dims(space.get(), got.data(), nullptr);
    std::vector<long long> got_ll(got.begin(), got.end());
    bool ok = got.size() == shape.size();
    for (size_t i = 0; ok && i < got.size(); ++i) ok = shape[i] < 0 || got_ll[i] == shape[i];
    if (!ok) fail(name, "shape " + join(got_ll) + ", expected " + join(shape));
    if (dims) *dims = got;
    return d;
  }
  // Reads all of dataset `name`, whose shape must be `shape`, into out.
  void read_into(const std::string& name, hid_t mem_type, H5T_class_t cls, const std::vector<long long>& shape,
                 void* out) const {
    Shape dims;
    Handle d = open(name, cls, shape, &dims);
    io(false, d.get(), name, mem_type, Shape(dims.size(), 0), dims, out);
  }
  // H5Fflush, then fsync, so that data flushed before a later write also reaches the disk first.
  void flush() const {
    check(H5Fflush(id.get(), H5F_SCOPE_LOCAL), "", "flush failed");
    void* fd = nullptr;
    check(H5Fget_vfd_handle(id.get(), H5P_DEFAULT, &fd), "", "cannot get the file descriptor");
    if (fsync(*static_cast<int*>(fd)) != 0) fail("", "fsync failed");
  }
  void check_stat_name(const std::string& name, int level) const {
    if (name.empty() || name.find('/') != std::string::npos || name == "." || name == "center_of_mass")
      fail(level_name("/levels", level, "stats"), "invalid statistic name '" + name + "'");
  }
};

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
  for (const std::string& g : {where, data, data + "/stats"}) f.make_group(g);
  f.write_whole(where + "/rest_positions", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {un, 3}, rest.data());
  f.write_whole(where + "/faces", H5T_STD_I32LE, H5T_NATIVE_INT, {static_cast<hsize_t>(faces.rows()), 3},
                faces.data());
  f.write_whole(where + "/object_offsets", H5T_STD_I32LE, H5T_NATIVE_INT, {uk + 1}, object_offsets.data());
  std::vector<const char*> names;
  for (const std::string& s : object_names) names.push_back(s.c_str());
  Handle str = vlen_string_type();
  f.write_whole(where + "/object_names", str.get(), str.get(), {uk}, names.data());

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
    f.check_stat_name(name, level);
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
  // Reads `count` variable-length strings from an attribute (attr = true) or a dataset.
  std::vector<std::string> read_strings(hid_t obj, bool attr, const std::string& name, hsize_t count) const {
    Handle type(attr ? H5Aget_type(obj) : H5Dget_type(obj), H5Tclose);
    if (H5Tget_class(type.get()) != H5T_STRING || H5Tis_variable_str(type.get()) <= 0)
      file.fail(name, "expected variable-length strings");
    Handle mem = vlen_string_type();
    std::vector<char*> raw(count, nullptr);
    file.check(attr ? H5Aread(obj, mem.get(), raw.data())
                    : H5Dread(obj, mem.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, raw.data()),
               name, "read failed");
    std::vector<std::string> out;
    for (char* s : raw) {
      out.emplace_back(s ? s : "");
      H5free_memory(s);
    }
    return out;
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
  return impl_->read_strings(a.get(), true, "/@scene", 1).front();
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
  return impl_->read_strings(d.get(), false, name, static_cast<hsize_t>(k));
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
  f.check_stat_name(name, level);
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
