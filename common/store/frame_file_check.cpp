#include "store/frame_file_check.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "store/frame_store.h"

namespace pd {
namespace {

using h5::File;
using h5::Handle;
using h5::level_name;
using h5::Shape;

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// Extent `d` of dataset `name` as an int within [lo, hi] (the limits above), else InputError.
int extent(const File& f, const std::string& name, hsize_t d, long long lo, long long hi, const char* what) {
  if (d < static_cast<hsize_t>(lo) || d > static_cast<hsize_t>(hi))
    f.fail(name, std::string(what) + " " + std::to_string(d) + " outside [" + std::to_string(lo) + ", " +
                     std::to_string(hi) + "]");
  return static_cast<int>(d);
}

// The levels of the file: the links under /levels must be exactly the groups "0" .. "L-1".
int count_levels(const File& f) {
  Handle levels = f.checked(H5Gopen2(f.id.get(), "/levels", H5P_DEFAULT), H5Gclose, "/levels", "missing group");
  H5G_info_t info;
  f.check(H5Gget_info(levels.get(), &info), "/levels", "cannot list group");
  if (info.nlinks == 0) f.fail("/levels", "the file has no levels");
  if (info.nlinks > static_cast<hsize_t>(kMaxFrameFileLevels))
    f.fail("/levels", "the file has " + std::to_string(info.nlinks) + " levels, more than the limit of " +
                          std::to_string(kMaxFrameFileLevels));
  const int L = static_cast<int>(info.nlinks);
  for (int l = 0; l < L; ++l)
    for (const char* root : {"/levels", "/hierarchy"}) {
      const std::string g = level_name(root, l);
      if (!f.exists(g))
        f.fail(g, "missing group (the levels of a file are 0.." + std::to_string(L - 1) + ")");
      H5O_info_t oi;
      if (H5Oget_info_by_name(f.id.get(), g.c_str(), &oi, H5P_DEFAULT) < 0 || oi.type != H5O_TYPE_GROUP)
        f.fail(g, "not a group");
    }
  return L;
}

// The storage layout of dataset dset; *chunk_frames gets the frames per chunk (chunked layout).
H5D_layout_t layout_of(const File& f, hid_t dset, const std::string& name, hsize_t* chunk_frames) {
  Handle dcpl = f.checked(H5Dget_create_plist(dset), H5Pclose, name, "cannot get the dataset's properties");
  const H5D_layout_t layout = H5Pget_layout(dcpl.get());
  if (layout == H5D_CHUNKED) {
    hsize_t chunk[3] = {0, 0, 0};
    if (H5Pget_chunk(dcpl.get(), 3, chunk) != 3 || chunk[0] == 0) f.fail(name, "unexpected chunk shape");
    *chunk_frames = chunk[0];
  } else if (layout != H5D_CONTIGUOUS && layout != H5D_COMPACT) {
    f.fail(name, "unsupported storage layout");
  }
  return layout;
}

// How many frames of the (frames, n, 3) dataset can have been written: frames per chunk times the
// chunks allocated (chunked), all or none (contiguous), all (compact).
long long stored_frames(const File& f, hid_t dset, const std::string& name, long long frames) {
  hsize_t chunk_frames = 1;
  const H5D_layout_t layout = layout_of(f, dset, name, &chunk_frames);
  if (layout == H5D_COMPACT) return frames;
  if (layout == H5D_CONTIGUOUS) return H5Dget_offset(dset) != HADDR_UNDEF ? frames : 0;
  Handle space = f.checked(H5Dget_space(dset), H5Sclose, name, "cannot get dataspace");
  hsize_t chunks = 0;
  f.check(H5Dget_num_chunks(dset, space.get(), &chunks), name, "cannot count the chunks");
  return static_cast<long long>(std::min<hsize_t>(chunks * chunk_frames, static_cast<hsize_t>(frames)));
}

// Reads and checks the rest mesh, offsets and names of level l; returns its counts.
LevelCounts check_level_mesh(const File& f, int l) {
  LevelCounts lv;
  Shape d;
  const std::string rp = level_name("/hierarchy", l, "rest_positions");
  f.require_stored(f.open(rp, H5T_FLOAT, {-1, 3}, &d).get(), rp, d);  // before allocating from d
  lv.num_vertices = extent(f, rp, d[0], 1, kMaxLevelVertices, "vertex count");
  std::vector<double> rest(3 * static_cast<size_t>(lv.num_vertices));
  f.read_into(rp, H5T_NATIVE_DOUBLE, H5T_FLOAT, {lv.num_vertices, 3}, rest.data());
  check_finite(f, rp, rest.data(), rest.size(), 3, "vertex");

  const std::string fp = level_name("/hierarchy", l, "faces");
  f.require_stored(f.open(fp, H5T_INTEGER, {-1, 3}, &d, 4).get(), fp, d);
  lv.num_faces = extent(f, fp, d[0], 0, kMaxLevelFaces, "face count");
  std::vector<int> faces(3 * static_cast<size_t>(lv.num_faces));
  f.read_into(fp, H5T_NATIVE_INT, H5T_INTEGER, {lv.num_faces, 3}, faces.data(), 4);
  check_index_range(f, fp, faces.data(), faces.size(), 0, lv.num_vertices, "vertex index");
  // A face that repeats a vertex is no triangle (what validate_mesh refuses in a scene's mesh): an
  // exported OBJ would carry it to the user's tools.
  for (long long k = 0; k < lv.num_faces; ++k) {
    const int a = faces[3 * k], b = faces[3 * k + 1], c = faces[3 * k + 2];
    if (a == b || a == c || b == c)
      f.fail(fp, "face " + std::to_string(k) + " repeats a vertex (" + std::to_string(a) + ", " + std::to_string(b) +
                     ", " + std::to_string(c) + ")");
  }

  const std::string op = level_name("/hierarchy", l, "object_offsets");
  f.require_stored(f.open(op, H5T_INTEGER, {-1}, &d, 4).get(), op, d);
  lv.num_objects = extent(f, op, d[0], 2, kMaxLevelObjects + 1, "entry count") - 1;
  std::vector<int> off(static_cast<size_t>(lv.num_objects) + 1);
  f.read_into(op, H5T_NATIVE_INT, H5T_INTEGER, {lv.num_objects + 1}, off.data(), 4);
  check_offsets(f, op, {off.begin(), off.end()}, lv.num_vertices);

  const std::string np = level_name("/hierarchy", l, "object_names");
  Handle names = f.open(np, H5T_STRING, {lv.num_objects});
  f.read_strings(names.get(), false, np, static_cast<hsize_t>(lv.num_objects));
  return lv;
}

// Checks the done flags, positions, center_of_mass and statistics of level l; *num_frames is taken
// from level 0's done and must match everywhere else.
void check_level_data(const File& f, int l, const LevelCounts& lv, int* num_frames) {
  Shape d;
  const std::string dp = level_name("/levels", l, "done");
  f.require_stored(f.open(dp, H5T_INTEGER, {l == 0 ? -1 : *num_frames}, &d, 1).get(), dp, d);
  if (l == 0) *num_frames = extent(f, dp, d[0], 1, kMaxFrameFileFrames, "frame count");
  std::vector<uint8_t> done(static_cast<size_t>(*num_frames));
  f.read_into(dp, H5T_NATIVE_UINT8, H5T_INTEGER, {*num_frames}, done.data(), 1);
  for (size_t t = 0; t < done.size(); ++t)
    if (done[t] > 1)
      f.fail(dp, "done[" + std::to_string(t) + "] = " + std::to_string(done[t]) + ", expected 0 or 1");
  const long long frames = *num_frames;
  const std::string pp = level_name("/levels", l, "positions");
  Handle positions = f.open(pp, H5T_FLOAT, {frames, lv.num_vertices, 3});
  // Every done frame has its positions written: a file cannot claim more done frames than it stores
  // (so reading all of them costs time in proportion to the file's size, not to its claims).
  long long num_done = 0;
  for (uint8_t flag : done) num_done += flag;
  const long long stored = stored_frames(f, positions.get(), pp, frames);
  if (num_done > stored)
    f.fail(pp, std::to_string(num_done) + " frames of level " + std::to_string(l) +
                   " are marked done but at most " + std::to_string(stored) + " were written");
  const std::string stats = level_name("/levels", l, "stats");
  f.open(stats + "/center_of_mass", H5T_FLOAT, {frames, lv.num_objects, 3});
  Handle g = f.checked(H5Gopen2(f.id.get(), stats.c_str(), H5P_DEFAULT), H5Gclose, stats, "missing group");
  std::vector<std::string> names;
  auto collect = [](hid_t, const char* link, const H5L_info_t*, void* out) -> herr_t {
    static_cast<std::vector<std::string>*>(out)->push_back(link);
    return 0;
  };
  f.check(H5Literate(g.get(), H5_INDEX_NAME, H5_ITER_INC, nullptr, collect, &names), stats, "cannot list group");
  for (const std::string& name : names) {
    if (name == "center_of_mass") continue;
    if (!valid_stat_name(name)) f.fail(stats, "invalid statistic name '" + name + "'");
    f.open(stats + "/" + name, H5T_FLOAT, {frames});
  }
}

// A read-only mapping of a whole file (empty when the file is empty or cannot be mapped).
class MappedFile {
 public:
  explicit MappedFile(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
    if (fd < 0) return;
    struct stat st;
    if (fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_size > 0) {
      void* p = mmap(nullptr, static_cast<size_t>(st.st_size), PROT_READ, MAP_PRIVATE, fd, 0);
      if (p != MAP_FAILED) data_ = static_cast<const unsigned char*>(p), size_ = static_cast<size_t>(st.st_size);
    }
    ::close(fd);
  }
  ~MappedFile() {
    if (data_) munmap(const_cast<unsigned char*>(data_), size_);
  }
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  const unsigned char* data() const { return data_; }
  size_t size() const { return size_; }

 private:
  const unsigned char* data_ = nullptr;
  size_t size_ = 0;
};

// Little-endian unsigned integer of `n` <= 8 bytes.
uint64_t decode(const unsigned char* p, int n) {
  uint64_t v = 0;
  for (int i = n - 1; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

// HDF5's "size of lengths" from the superblock (searched at 0, 512, 1024, ... as HDF5 does); 0 when
// there is none (the file is then no HDF5 file and H5Fopen refuses it).
int size_of_lengths(const MappedFile& m) {
  static const unsigned char kSignature[8] = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};
  for (size_t at = 0; at + 16 <= m.size(); at = at == 0 ? 512 : 2 * at) {
    if (std::memcmp(m.data() + at, kSignature, 8) != 0) continue;
    const unsigned version = m.data()[at + 8];
    return version <= 1 ? m.data()[at + 14] : m.data()[at + 10];
  }
  return 0;
}

}  // namespace

void check_global_heaps(const File& f) {
  const MappedFile m(f.path);
  const int L = size_of_lengths(m);
  if (L == 0) return;
  if (L != 2 && L != 4 && L != 8) f.fail("", "unsupported HDF5 superblock (size of lengths " + std::to_string(L) + ")");
  const unsigned char* const data = m.data();
  const size_t header = 8 + static_cast<size_t>(L), object_header = 8 + static_cast<size_t>(L);
  const unsigned char* at = data;
  while ((at = static_cast<const unsigned char*>(memmem(at, m.size() - static_cast<size_t>(at - data), "GCOL", 4)))) {
    const size_t start = static_cast<size_t>(at - data);
    ++at;
    if (start + header > m.size()) break;
    // HDF5 reads the collection only when it fits in the file; parse what it would.
    const uint64_t size = decode(data + start + 8, L);
    if (size < header || size > m.size() - start) continue;
    const size_t end = start + static_cast<size_t>(size);
    for (size_t p = start + header; p + object_header <= end;) {
      const uint64_t index = decode(data + p, 2), bytes = decode(data + p + 8, L);
      const uint64_t need = index > 0 ? object_header + ((bytes + 7) / 8) * 8 : bytes;
      if (need == 0 || bytes > end - p || need > end - p)
        f.fail("", "corrupt global heap collection at byte " + std::to_string(start) + " (object " +
                       std::to_string(index) + " at byte " + std::to_string(p) + " has size " + std::to_string(bytes) +
                       ")");
      p += static_cast<size_t>(need);
    }
  }
}

std::vector<LevelCounts> check_frame_file(const File& f, int* num_frames) {
  const int version = f.read_int_attr("/", "format_version");
  if (version != kFrameFormatVersion)
    f.fail("/@format_version", "format_version " + std::to_string(version) + " unsupported (expected " +
                                   std::to_string(kFrameFormatVersion) + ")");
  {
    Handle scene = f.checked(H5Aopen(f.id.get(), "scene", H5P_DEFAULT), H5Aclose, "/@scene", "missing attribute");
    f.read_strings(scene.get(), true, "/@scene", 1, kMaxSceneTextBytes);
  }
  const int L = count_levels(f);
  std::vector<LevelCounts> out;
  for (int l = 0; l < L; ++l) {
    out.push_back(check_level_mesh(f, l));
    check_level_data(f, l, out.back(), num_frames);
  }
  return out;
}

void check_finite(const File& f, const std::string& name, const double* v, size_t n, int per,
                  const std::string& what) {
  for (size_t i = 0; i < n; ++i)
    if (!std::isfinite(v[i]))
      f.fail(name, what + " " + std::to_string(i / static_cast<size_t>(per)) + " is not finite (" + number(v[i]) +
                       ")");
}

void check_index_range(const File& f, const std::string& name, const int* v, size_t n, long long lo, long long hi,
                       const std::string& what) {
  for (size_t i = 0; i < n; ++i)
    if (v[i] < lo || v[i] >= hi)
      f.fail(name, what + " " + std::to_string(v[i]) + " (entry " + std::to_string(i) + ") outside [" +
                       std::to_string(lo) + ", " + std::to_string(hi) + ")");
}

void check_offsets(const File& f, const std::string& name, const std::vector<long long>& off, long long total) {
  bool ok = !off.empty() && off.front() == 0 && off.back() == total;
  for (size_t i = 0; ok && i + 1 < off.size(); ++i) ok = off[i] <= off[i + 1];
  if (!ok) f.fail(name, "offsets must not decrease and run from 0 to " + std::to_string(total));
}

void check_frame_stored(const File& f, hid_t dset, const std::string& name, int level, int t) {
  hsize_t chunk_frames = 1;
  const H5D_layout_t layout = layout_of(f, dset, name, &chunk_frames);
  bool stored = true;
  if (layout == H5D_CHUNKED) {
    const hsize_t offset[3] = {static_cast<hsize_t>(t) - static_cast<hsize_t>(t) % chunk_frames, 0, 0};
    unsigned filter_mask = 0;
    haddr_t addr = HADDR_UNDEF;
    hsize_t size = 0;
    f.check(H5Dget_chunk_info_by_coord(dset, offset, &filter_mask, &addr, &size), name, "cannot find the chunk");
    stored = addr != HADDR_UNDEF && size > 0;
  } else if (layout == H5D_CONTIGUOUS) {
    stored = H5Dget_offset(dset) != HADDR_UNDEF;
  }
  if (!stored)
    f.fail(name, "frame " + std::to_string(t) + " of level " + std::to_string(level) +
                     " is marked done but was never written");
}

}  // namespace pd
