#include "store/h5_util.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <limits>

namespace pd::h5 {

void quiet_hdf5() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

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

std::string level_name(const char* root, int level, const char* leaf) {
  std::string name = std::string(root) + "/" + std::to_string(level);
  return leaf ? name + "/" + leaf : name;
}

std::string join(const std::vector<long long>& v) {
  std::string s;
  for (long long x : v) s += (s.empty() ? "" : ", ") + (x < 0 ? std::string("*") : std::to_string(x));
  return "(" + s + ")";
}

void File::fail(const std::string& object, const std::string& what) const {
  throw InputError(path + ": " + (object.empty() ? "" : object + ": ") + what);
}

void File::fail_h5(const std::string& object, const std::string& what) const {
  std::string detail = hdf5_detail();
  fail(object, detail.empty() ? what : what + " (HDF5: " + detail + ")");
}

bool File::exists(const std::string& name) const {
  // H5Lexists fails (rather than returning 0) when an intermediate group is missing: walk the path.
  std::string prefix;
  size_t pos = 0;
  while (pos < name.size()) {
    size_t next = name.find('/', pos + 1);
    if (next == std::string::npos) next = name.size();
    prefix = name.substr(0, next);
    if (prefix != "/" && H5Lexists(id.get(), prefix.c_str(), H5P_DEFAULT) <= 0) return false;
    pos = next;
  }
  return true;
}

void File::make_group(const std::string& name) const {
  checked(H5Gcreate2(id.get(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, name,
          "cannot create group");
}

Handle File::create(const std::string& name, hid_t file_type, const Shape& dims, const Shape& chunk,
                    hid_t fill_type, const void* fill) const {
  Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  if (!chunk.empty())
    check(H5Pset_chunk(dcpl.get(), static_cast<int>(chunk.size()), chunk.data()), name, "bad chunk shape");
  if (fill) check(H5Pset_fill_value(dcpl.get(), fill_type, fill), name, "bad fill value");
  Handle space = simple_space(dims);
  return checked(H5Dcreate2(id.get(), name.c_str(), file_type, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT),
                 H5Dclose, name, "cannot create dataset");
}

Handle File::create_filled(const std::string& name, hid_t file_type, hsize_t n, hid_t fill_type,
                           const void* fill) const {
  Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  check(H5Pset_alloc_time(dcpl.get(), H5D_ALLOC_TIME_EARLY), name, "bad allocation time");
  check(H5Pset_fill_time(dcpl.get(), H5D_FILL_TIME_ALLOC), name, "bad fill time");
  check(H5Pset_fill_value(dcpl.get(), fill_type, fill), name, "bad fill value");
  Handle space = simple_space({n});
  return checked(H5Dcreate_anon(id.get(), file_type, space.get(), dcpl.get(), H5P_DEFAULT), H5Dclose, name,
                 "cannot create dataset");
}

void File::link(const Handle& object, const std::string& name) const {
  check(H5Olink(object.get(), id.get(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT), name, "cannot link object");
}

void File::io(bool write, hid_t dset, const std::string& name, hid_t mem_type, const Shape& start,
              const Shape& count, void* data) const {
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

void File::write_whole(const std::string& name, hid_t file_type, hid_t mem_type, const Shape& dims,
                       const void* data) const {
  Handle d = create(name, file_type, dims);
  io(true, d.get(), name, mem_type, Shape(dims.size(), 0), dims, const_cast<void*>(data));
}

namespace {
std::string type_label(hid_t type) {
  const H5T_class_t cls = H5Tget_class(type);
  const std::string bits = std::to_string(8 * H5Tget_size(type));
  if (cls == H5T_FLOAT) return "float" + bits;
  if (cls == H5T_INTEGER) return (H5Tget_sign(type) == H5T_SGN_NONE ? "uint" : "int") + bits;
  if (cls == H5T_STRING) return "string";
  return "an HDF5 type of class " + std::to_string(static_cast<int>(cls));
}
std::string class_label(H5T_class_t cls, size_t size) {
  const std::string bits = size ? std::to_string(8 * size) : "";
  if (cls == H5T_FLOAT) return "float" + (bits.empty() ? "64" : bits);
  if (cls == H5T_INTEGER) return bits.empty() ? "an integer" : (size == 1 ? "uint8" : "int" + bits);
  if (cls == H5T_STRING) return "strings";
  return "class " + std::to_string(static_cast<int>(cls));
}
}  // namespace

Handle File::open(const std::string& name, H5T_class_t cls, const std::vector<long long>& shape, Shape* dims,
                  size_t elem_size) const {
  Handle d = checked(H5Dopen2(id.get(), name.c_str(), H5P_DEFAULT), H5Dclose, name, "missing dataset");
  Handle type = checked(H5Dget_type(d.get()), H5Tclose, name, "cannot get the element type");
  if (elem_size == 0 && cls == H5T_FLOAT) elem_size = 8;
  if (H5Tget_class(type.get()) != cls || (elem_size != 0 && H5Tget_size(type.get()) != elem_size))
    fail(name, "element type " + type_label(type.get()) + ", expected " + class_label(cls, elem_size));
  // Virtual datasets and external storage read other files, which a hostile file could point at a
  // FIFO or a device (a read that never ends): only data inside the file is read.
  Handle dcpl = checked(H5Dget_create_plist(d.get()), H5Pclose, name, "cannot get the dataset's properties");
  const H5D_layout_t layout = H5Pget_layout(dcpl.get());
  if (layout != H5D_CHUNKED && layout != H5D_CONTIGUOUS && layout != H5D_COMPACT)
    fail(name, "unsupported storage layout (only chunked, contiguous or compact data in the file itself)");
  if (H5Pget_external_count(dcpl.get()) != 0) fail(name, "data in external files are not read");
  Handle space = checked(H5Dget_space(d.get()), H5Sclose, name, "cannot get dataspace");
  if (H5Sget_simple_extent_type(space.get()) != H5S_SIMPLE)
    fail(name, "not an array (scalar or empty dataspace), expected shape " + join(shape));
  int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 0) fail_h5(name, "cannot get the shape");
  Shape got(static_cast<size_t>(rank));
  if (rank > 0 && H5Sget_simple_extent_dims(space.get(), got.data(), nullptr) < 0) fail_h5(name, "cannot get the shape");
  std::vector<long long> got_ll(got.begin(), got.end());
  bool ok = got.size() == shape.size();
  for (size_t i = 0; ok && i < got.size(); ++i) ok = shape[i] < 0 || got_ll[i] == shape[i];
  if (!ok) fail(name, "shape " + join(got_ll) + ", expected " + join(shape));
  if (dims) *dims = got;
  return d;
}

void File::require_stored(hid_t dset, const std::string& name, const Shape& dims) const {
  Handle type = checked(H5Dget_type(dset), H5Tclose, name, "cannot get the element type");
  if (H5Tget_class(type.get()) == H5T_STRING) return;
  const unsigned long long limit = std::numeric_limits<unsigned long long>::max();
  unsigned long long need = H5Tget_size(type.get());
  for (hsize_t d : dims) need = d != 0 && need > limit / d ? limit : need * d;
  Handle dcpl = checked(H5Dget_create_plist(dset), H5Pclose, name, "cannot get the dataset's properties");
  const bool filtered = H5Pget_nfilters(dcpl.get()) > 0;
  const unsigned long long stored = H5Dget_storage_size(dset);
  if (filtered ? need > kMaxFilteredBytes : need > stored)
    fail(name, "the shape needs " + std::to_string(need) + " bytes of data but the file stores " +
                   std::to_string(stored) + (filtered ? " (compressed; at most " + std::to_string(kMaxFilteredBytes) +
                                                           " bytes are read)"
                                                     : ""));
}

void File::read_into(const std::string& name, hid_t mem_type, H5T_class_t cls, const std::vector<long long>& shape,
                     void* out, size_t elem_size) const {
  Shape dims;
  Handle d = open(name, cls, shape, &dims, elem_size);
  require_stored(d.get(), name, dims);
  io(false, d.get(), name, mem_type, Shape(dims.size(), 0), dims, out);
}

std::vector<std::string> File::read_strings(hid_t obj, bool attr, const std::string& name, hsize_t count,
                                            size_t max_bytes) const {
  Handle type(attr ? H5Aget_type(obj) : H5Dget_type(obj), H5Tclose);
  if (H5Tget_class(type.get()) != H5T_STRING || H5Tis_variable_str(type.get()) <= 0)
    fail(name, "expected variable-length strings");
  // The element count must be `count`: H5Aread / H5Dread fill as many pointers as the object holds.
  Handle space(attr ? H5Aget_space(obj) : H5Dget_space(obj), H5Sclose);
  const hssize_t n = H5Sget_simple_extent_npoints(space.get());
  if (n < 0) fail_h5(name, "cannot get dataspace");
  if (static_cast<hsize_t>(n) != count)
    fail(name, "holds " + std::to_string(n) + " strings, expected " + std::to_string(count));
  Handle mem = vlen_string_type();
  std::vector<char*> raw(count, nullptr);
  const herr_t status =
      attr ? H5Aread(obj, mem.get(), raw.data()) : H5Dread(obj, mem.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, raw.data());
  std::vector<std::string> out;
  size_t too_long = count;  // index of the first string over max_bytes
  for (size_t i = 0; i < raw.size(); ++i) {
    if (status >= 0) {
      out.emplace_back(raw[i] ? raw[i] : "");
      if (too_long == count && out.back().size() > max_bytes) too_long = i;
    }
    H5free_memory(raw[i]);
  }
  check(status, name, "read failed");
  if (too_long != count)
    fail(name, "string " + std::to_string(too_long) + " has " + std::to_string(out[too_long].size()) +
                   " bytes, more than the limit of " + std::to_string(max_bytes));
  return out;
}

namespace {
std::string attr_label(const std::string& object, const char* attr) {
  return (object == "/" ? std::string("/") : object + "/") + "@" + attr;
}
}  // namespace

void File::write_int_attr(const std::string& object, const char* attr, int value) const {
  const std::string label = attr_label(object, attr);
  if (H5Aexists_by_name(id.get(), object.c_str(), attr, H5P_DEFAULT) > 0)
    check(H5Adelete_by_name(id.get(), object.c_str(), attr, H5P_DEFAULT), label, "cannot replace attribute");
  Handle scalar(H5Screate(H5S_SCALAR), H5Sclose);
  Handle a = checked(H5Acreate_by_name(id.get(), object.c_str(), attr, H5T_STD_I32LE, scalar.get(), H5P_DEFAULT,
                                       H5P_DEFAULT, H5P_DEFAULT),
                     H5Aclose, label, "cannot create attribute");
  check(H5Awrite(a.get(), H5T_NATIVE_INT, &value), label, "write failed");
}

void File::write_string_attr(const std::string& object, const char* attr, const std::string& value) const {
  const std::string label = attr_label(object, attr);
  if (H5Aexists_by_name(id.get(), object.c_str(), attr, H5P_DEFAULT) > 0)
    check(H5Adelete_by_name(id.get(), object.c_str(), attr, H5P_DEFAULT), label, "cannot replace attribute");
  Handle scalar(H5Screate(H5S_SCALAR), H5Sclose);
  Handle str = vlen_string_type();
  Handle a = checked(H5Acreate_by_name(id.get(), object.c_str(), attr, str.get(), scalar.get(), H5P_DEFAULT,
                                       H5P_DEFAULT, H5P_DEFAULT),
                     H5Aclose, label, "cannot create attribute");
  const char* text = value.c_str();
  check(H5Awrite(a.get(), str.get(), &text), label, "write failed");
}

int File::read_int_attr(const std::string& object, const char* attr) const {
  const std::string label = attr_label(object, attr);
  Handle a = checked(H5Aopen_by_name(id.get(), object.c_str(), attr, H5P_DEFAULT, H5P_DEFAULT), H5Aclose, label,
                     "missing attribute");
  Handle type(H5Aget_type(a.get()), H5Tclose);
  if (H5Tget_class(type.get()) != H5T_INTEGER || H5Tget_size(type.get()) > 8)
    fail(label, "attribute is " + type_label(type.get()) + ", expected an integer");
  Handle space(H5Aget_space(a.get()), H5Sclose);
  if (H5Sget_simple_extent_npoints(space.get()) != 1) fail(label, "attribute is not a single value");
  // Read as 64 bits so that a wider stored value is range-checked here, not clipped by HDF5.
  long long value = 0;
  check(H5Aread(a.get(), H5T_NATIVE_LLONG, &value), label, "read failed");
  if (value < std::numeric_limits<int>::min() || value > std::numeric_limits<int>::max())
    fail(label, "value " + std::to_string(value) + " out of range");
  return static_cast<int>(value);
}

std::string File::read_string_attr(const std::string& object, const char* attr) const {
  const std::string label = attr_label(object, attr);
  Handle a = checked(H5Aopen_by_name(id.get(), object.c_str(), attr, H5P_DEFAULT, H5P_DEFAULT), H5Aclose, label,
                     "missing attribute");
  return read_strings(a.get(), true, label, 1).front();
}

bool File::has_attr(const std::string& object, const char* attr) const {
  return exists(object) && H5Aexists_by_name(id.get(), object.c_str(), attr, H5P_DEFAULT) > 0;
}

void File::flush() const {
  check(H5Fflush(id.get(), H5F_SCOPE_LOCAL), "", "flush failed");
  if (fsync(descriptor()) != 0) fail("", "fsync failed");
}

int File::descriptor() const {
  void* fd = nullptr;
  check(H5Fget_vfd_handle(id.get(), H5P_DEFAULT, &fd), "", "cannot get the file descriptor");
  return *static_cast<int*>(fd);
}

void File::close_on_exec() const {
  const int fd = descriptor(), flags = fcntl(fd, F_GETFD);
  if (flags < 0 || fcntl(fd, F_SETFD, flags | FD_CLOEXEC) < 0)
    fail("", std::string("cannot set close-on-exec: ") + std::strerror(errno));
}

}  // namespace pd::h5
