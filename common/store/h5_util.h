#pragma once
// Small helpers over the HDF5 C API shared by the frame store (frame_store.cpp) and the hierarchy
// store (hierarchy_store.cpp). Internal to common/store: not part of the library's public surface.
//
// Every failure becomes InputError "<path>: <object>: <what>", with the innermost message of HDF5's
// error stack appended when there is one, so a bad file is reported by name and object.
#include <hdf5.h>

#include <string>
#include <utility>
#include <vector>

#include "util/input_error.h"

namespace pd::h5 {

using Shape = std::vector<hsize_t>;

// Longest string read_strings accepts by default (object names, hashes), bytes. The scene text
// attribute has its own limit (frame_file_check.h).
constexpr size_t kMaxStringBytes = 65536;
// Largest whole-dataset read of compressed data (File::require_stored), bytes.
constexpr unsigned long long kMaxFilteredBytes = 1ull << 30;

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
void quiet_hdf5();
// The innermost message of the current HDF5 error stack ("" when empty).
std::string hdf5_detail();

Handle simple_space(const Shape& dims);
Handle vlen_string_type();  // variable-length UTF-8 strings
// "<root>/<level>[/<leaf>]", e.g. level_name("/levels", 1, "done") = "/levels/1/done".
std::string level_name(const char* root, int level, const char* leaf = nullptr);
std::string join(const std::vector<long long>& v);  // "(5, *, 3)"; -1 prints as *

// An HDF5 file and its path; every failure becomes InputError "<path>: <object>: <what>".
struct File {
  std::string path;
  Handle id;

  [[noreturn]] void fail(const std::string& object, const std::string& what) const;
  [[noreturn]] void fail_h5(const std::string& object, const std::string& what) const;
  void check(herr_t status, const std::string& object, const char* what) const {
    if (status < 0) fail_h5(object, what);
  }
  Handle checked(hid_t h, Handle::Closer closer, const std::string& object, const char* what) const {
    if (h < 0) fail_h5(object, what);
    return Handle(h, closer);
  }

  bool exists(const std::string& name) const;  // every link of the path exists (no error when not)
  void make_group(const std::string& name) const;
  // Creates dataset `name` with an optional fill value and, if chunk is non-empty, chunked layout.
  Handle create(const std::string& name, hid_t file_type, const Shape& dims, const Shape& chunk = {},
                hid_t fill_type = H5T_NATIVE_DOUBLE, const void* fill = nullptr) const;
  // A one-dimensional contiguous dataset of n elements, created without a link (give it one with
  // link()) and with its storage allocated and filled with `fill` now, not at its first write as
  // HDF5 does by default: a writer killed inside the flush after that first write can leave the
  // dataset's header and link in the file without the fill, which then reads 0 everywhere (measured
  // by tests/store/frame_store_kill_test.cpp). `name` is only used in error messages.
  Handle create_filled(const std::string& name, hid_t file_type, hsize_t n, hid_t fill_type, const void* fill) const;
  void link(const Handle& object, const std::string& name) const;  // a hard link `name` to `object`
  // Reads (write = false) or writes the block [start, start + count) of dataset `dset` called `name`.
  void io(bool write, hid_t dset, const std::string& name, hid_t mem_type, const Shape& start, const Shape& count,
          void* data) const;
  void write_whole(const std::string& name, hid_t file_type, hid_t mem_type, const Shape& dims,
                   const void* data) const;
  // Opens dataset `name`, checks its type class, element size in bytes and shape (-1 matches any
  // extent); dims gets the shape. elem_size 0: 8 for H5T_FLOAT (float64; float32 is refused), any
  // for the other classes. A dataspace that is not simple (scalar, null) is refused.
  Handle open(const std::string& name, H5T_class_t cls, const std::vector<long long>& shape,
              Shape* dims = nullptr, size_t elem_size = 0) const;
  // Refuses a whole read of dataset `dset` (shape dims) whose data the file cannot hold: more bytes
  // than its stored size (a hostile shape would otherwise size an allocation of gigabytes from a
  // few bytes of header), or, for filtered (compressed) data, more than kMaxFilteredBytes. Strings
  // are bounded by read_strings instead.
  void require_stored(hid_t dset, const std::string& name, const Shape& dims) const;
  // Reads all of dataset `name`, whose shape must be `shape` (and element size elem_size, as open), into out.
  void read_into(const std::string& name, hid_t mem_type, H5T_class_t cls, const std::vector<long long>& shape,
                 void* out, size_t elem_size = 0) const;
  // Reads `count` variable-length strings from an attribute (attr = true) or a dataset `obj`, which
  // must hold exactly `count` of them; each at most max_bytes long (else InputError naming `name`).
  std::vector<std::string> read_strings(hid_t obj, bool attr, const std::string& name, hsize_t count,
                                        size_t max_bytes = kMaxStringBytes) const;
  // Scalar attributes `attr` of the object at path `object` ("/" for the root group). The error
  // messages name them "<object>@<attr>". read_int_attr takes a scalar (or one-element) integer
  // attribute whose value fits an int, and refuses anything else (a float, a string, an array).
  void write_int_attr(const std::string& object, const char* attr, int value) const;
  void write_string_attr(const std::string& object, const char* attr, const std::string& value) const;
  int read_int_attr(const std::string& object, const char* attr) const;
  std::string read_string_attr(const std::string& object, const char* attr) const;
  bool has_attr(const std::string& object, const char* attr) const;
  // H5Fflush, then fsync, so that data flushed before a later write also reaches the disk first.
  void flush() const;
  int descriptor() const;  // the file descriptor (sec2 driver)
  // Marks the descriptor close-on-exec. HDF5 opens files without O_CLOEXEC, so a program this process
  // starts would inherit the descriptor and with it HDF5's file lock (flock), which would then outlive
  // a killed writer and keep the file locked for as long as that program runs.
  void close_on_exec() const;
};

}  // namespace pd::h5
