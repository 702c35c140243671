#include "store/hierarchy_store.h"

#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <system_error>

#include <Eigen/SparseCore>

#include "store/frame_file_check.h"
#include "store/frame_store.h"
#include "store/h5_util.h"

namespace pd {
namespace {

using h5::File;
using h5::Handle;
using h5::Shape;

constexpr const char* kRoot = "/hierarchy";

std::string level_group(int l) { return std::string(kRoot) + "/" + std::to_string(l); }
std::string object_group(size_t k) { return std::string(kRoot) + "/objects/" + std::to_string(k); }
hsize_t hs(size_t n) { return static_cast<hsize_t>(n); }

// Opens `path` (which must be an existing HDF5 file) for reading or writing.
File open_file(const std::string& path, bool write) {
  h5::quiet_hdf5();
  File f;
  f.path = path;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) f.fail("", "no such file");
  check_global_heaps(f);  // before HDF5 parses anything (see frame_file_check.h)
  const htri_t is_hdf5 = H5Fis_hdf5(path.c_str());
  if (is_hdf5 == 0) f.fail("", "not an HDF5 file");
  if (is_hdf5 < 0) f.fail_h5("", "cannot read the file");
  f.id = f.checked(H5Fopen(path.c_str(), write ? H5F_ACC_RDWR : H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose, "",
                   "cannot open the HDF5 file (truncated, or locked by another process?)");
  return f;
}

// ---- typed whole-dataset writes (little-endian file types, as frame_store.cpp) -------------------

void put_ints(const File& f, const std::string& name, const int* data, size_t rows, size_t cols = 0) {
  const Shape dims = cols ? Shape{hs(rows), hs(cols)} : Shape{hs(rows)};
  f.write_whole(name, H5T_STD_I32LE, H5T_NATIVE_INT, dims, data);
}
void put_ints(const File& f, const std::string& name, const std::vector<int>& v) {
  put_ints(f, name, v.data(), v.size());
}
void put_int64s(const File& f, const std::string& name, const std::vector<long long>& v) {
  f.write_whole(name, H5T_STD_I64LE, H5T_NATIVE_LLONG, {hs(v.size())}, v.data());
}
void put_doubles(const File& f, const std::string& name, const double* data, size_t rows, size_t cols = 0) {
  const Shape dims = cols ? Shape{hs(rows), hs(cols)} : Shape{hs(rows)};
  f.write_whole(name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, dims, data);
}
void put_mesh(const File& f, const std::string& group, const char* vname, const TriMesh& m) {
  put_doubles(f, group + "/" + vname, m.V.data(), static_cast<size_t>(m.V.rows()), 3);
  put_ints(f, group + "/faces", m.F.data(), static_cast<size_t>(m.F.rows()), 3);
}
void put_strings(const File& f, const std::string& name, const std::vector<std::string>& s) {
  std::vector<const char*> ptrs;
  for (const std::string& x : s) ptrs.push_back(x.c_str());
  Handle str = h5::vlen_string_type();
  f.write_whole(name, str.get(), str.get(), {hs(s.size())}, ptrs.data());
}

// ---- typed whole-dataset reads; `n` = -1 accepts any length --------------------------------------

// elem_size: the stored element's size in bytes (int32 4, int64 8, float64 8).
template <class T>
std::vector<T> get_vec(const File& f, const std::string& name, hid_t mem, H5T_class_t cls, long long n,
                       long long cols = 0) {
  Shape d;
  Handle h = f.open(name, cls, cols ? std::vector<long long>{n, cols} : std::vector<long long>{n}, &d, sizeof(T));
  f.require_stored(h.get(), name, d);  // before the allocation below
  std::vector<T> v(static_cast<size_t>(d[0] * (cols ? cols : 1)));
  f.io(false, h.get(), name, mem, Shape(d.size(), 0), d, v.data());
  return v;
}
std::vector<int> get_ints(const File& f, const std::string& name, long long n = -1, long long cols = 0) {
  return get_vec<int>(f, name, H5T_NATIVE_INT, H5T_INTEGER, n, cols);
}
std::vector<double> get_doubles(const File& f, const std::string& name, long long n = -1, long long cols = 0) {
  return get_vec<double>(f, name, H5T_NATIVE_DOUBLE, H5T_FLOAT, n, cols);
}
std::vector<long long> get_int64s(const File& f, const std::string& name, long long n = -1) {
  return get_vec<long long>(f, name, H5T_NATIVE_LLONG, H5T_INTEGER, n);
}
Positions get_positions(const File& f, const std::string& name, long long n = -1) {
  const std::vector<double> v = get_doubles(f, name, n, 3);
  check_finite(f, name, v.data(), v.size(), 3, "vertex");
  return Eigen::Map<const Positions>(v.data(), static_cast<Eigen::Index>(v.size() / 3), 3);
}
Faces get_faces(const File& f, const std::string& name, int num_vertices, long long m = -1) {
  const std::vector<int> v = get_ints(f, name, m, 3);
  Faces F = Eigen::Map<const Faces>(v.data(), static_cast<Eigen::Index>(v.size() / 3), 3);
  check_index_range(f, name, v.data(), v.size(), 0, num_vertices, "vertex index");
  return F;
}

// ---- collapse records and batches ----------------------------------------------------------------

// Faces of every record flattened into (k, 3) rows; offsets (n_c + 1) int64: record c owns rows
// [off[c], off[c+1]).
void put_tri_lists(const File& f, const std::string& name, const std::vector<Collapse>& cs, bool before) {
  std::vector<int> flat;
  std::vector<long long> off{0};
  for (const Collapse& c : cs) {
    for (const Tri& t : before ? c.faces_before : c.faces_after) flat.insert(flat.end(), t.begin(), t.end());
    off.push_back(static_cast<long long>(flat.size() / 3));
  }
  put_ints(f, name, flat.data(), flat.size() / 3, 3);
  put_int64s(f, name + "_offsets", off);
}

void put_collapses(const File& f, const std::string& g, const std::vector<Collapse>& cs) {
  f.make_group(g);
  std::vector<int> removed, kept;
  std::vector<double> rp, kb, ka;
  for (const Collapse& c : cs) {
    removed.push_back(c.removed);
    kept.push_back(c.kept);
    rp.insert(rp.end(), c.removed_position.data(), c.removed_position.data() + 3);
    kb.insert(kb.end(), c.kept_position_before.data(), c.kept_position_before.data() + 3);
    ka.insert(ka.end(), c.kept_position_after.data(), c.kept_position_after.data() + 3);
  }
  put_ints(f, g + "/removed", removed);
  put_ints(f, g + "/kept", kept);
  put_doubles(f, g + "/removed_position", rp.data(), cs.size(), 3);
  put_doubles(f, g + "/kept_position_before", kb.data(), cs.size(), 3);
  put_doubles(f, g + "/kept_position_after", ka.data(), cs.size(), 3);
  put_tri_lists(f, g + "/faces_before", cs, true);
  put_tri_lists(f, g + "/faces_after", cs, false);
}

// The collapses of group g, whose vertex ids are those of the finer level (num_fine vertices).
std::vector<Collapse> get_collapses(const File& f, const std::string& g, int num_fine) {
  const std::vector<int> removed = get_ints(f, g + "/removed");
  const long long n = static_cast<long long>(removed.size());
  const std::vector<int> kept = get_ints(f, g + "/kept", n);
  check_index_range(f, g + "/removed", removed.data(), removed.size(), 0, num_fine, "vertex id");
  check_index_range(f, g + "/kept", kept.data(), kept.size(), 0, num_fine, "vertex id");
  const std::vector<double> rp = get_doubles(f, g + "/removed_position", n, 3);
  const std::vector<double> kb = get_doubles(f, g + "/kept_position_before", n, 3);
  const std::vector<double> ka = get_doubles(f, g + "/kept_position_after", n, 3);
  check_finite(f, g + "/removed_position", rp.data(), rp.size(), 3, "collapse");
  check_finite(f, g + "/kept_position_before", kb.data(), kb.size(), 3, "collapse");
  check_finite(f, g + "/kept_position_after", ka.data(), ka.size(), 3, "collapse");
  std::vector<Collapse> cs(static_cast<size_t>(n));
  for (size_t c = 0; c < cs.size(); ++c) {
    cs[c].removed = removed[c];
    cs[c].kept = kept[c];
    cs[c].removed_position = Vec3(rp[3 * c], rp[3 * c + 1], rp[3 * c + 2]);
    cs[c].kept_position_before = Vec3(kb[3 * c], kb[3 * c + 1], kb[3 * c + 2]);
    cs[c].kept_position_after = Vec3(ka[3 * c], ka[3 * c + 1], ka[3 * c + 2]);
  }
  for (bool before : {true, false}) {
    const std::string name = g + (before ? "/faces_before" : "/faces_after");
    const std::vector<int> flat = get_ints(f, name, -1, 3);
    check_index_range(f, name, flat.data(), flat.size(), 0, num_fine, "vertex id");
    const std::vector<long long> off = get_int64s(f, name + "_offsets", n + 1);
    check_offsets(f, name + "_offsets", off, static_cast<long long>(flat.size() / 3));
    for (size_t c = 0; c < cs.size(); ++c) {
      std::vector<Tri>& out = before ? cs[c].faces_before : cs[c].faces_after;
      for (long long r = off[c]; r < off[c + 1]; ++r) out.push_back({flat[3 * r], flat[3 * r + 1], flat[3 * r + 2]});
    }
  }
  return cs;
}

// batches: the indices of every batch concatenated; batch_offsets (#batches + 1) int64.
void put_batches(const File& f, const std::string& g, const std::vector<std::vector<int>>& batches) {
  std::vector<int> flat;
  std::vector<long long> off{0};
  for (const std::vector<int>& b : batches) {
    flat.insert(flat.end(), b.begin(), b.end());
    off.push_back(static_cast<long long>(flat.size()));
  }
  put_ints(f, g + "/batches", flat);
  put_int64s(f, g + "/batch_offsets", off);
}

// Batches of indices into the level's num_collapses collapses.
std::vector<std::vector<int>> get_batches(const File& f, const std::string& g, size_t num_collapses) {
  const std::vector<int> flat = get_ints(f, g + "/batches");
  check_index_range(f, g + "/batches", flat.data(), flat.size(), 0, static_cast<long long>(num_collapses),
                    "collapse index");
  const std::vector<long long> off = get_int64s(f, g + "/batch_offsets");
  check_offsets(f, g + "/batch_offsets", off, static_cast<long long>(flat.size()));
  std::vector<std::vector<int>> out;
  for (size_t b = 0; b + 1 < off.size(); ++b) out.emplace_back(flat.begin() + off[b], flat.begin() + off[b + 1]);
  return out;
}

// ---- prolongation operators ----------------------------------------------------------------------

// U in compressed sparse row form (the layout scipy.sparse.csr_matrix takes).
struct Csr {
  std::vector<long long> indptr;
  std::vector<int> indices;
  std::vector<double> data;
};
Csr to_csr(const Eigen::SparseMatrix<double>& U) {
  Eigen::SparseMatrix<double, Eigen::RowMajor, int> R(U);
  R.makeCompressed();
  Csr c;
  c.indptr.assign(R.outerIndexPtr(), R.outerIndexPtr() + R.rows() + 1);
  c.indices.assign(R.innerIndexPtr(), R.innerIndexPtr() + R.nonZeros());
  c.data.assign(R.valuePtr(), R.valuePtr() + R.nonZeros());
  return c;
}
std::vector<double> tangent_array(const ShellProlongation& P) {
  std::vector<double> t;
  for (const Eigen::Vector2d& v : P.tangent_offsets()) t.insert(t.end(), {v[0], v[1]});
  return t;
}

void put_prolongation(const File& f, const std::string& g, const ShellProlongation& P) {
  f.make_group(g);
  f.write_int_attr(g, "rows", P.num_fine());
  f.write_int_attr(g, "cols", P.num_coarse());
  const size_t nf = static_cast<size_t>(P.num_fine());
  std::vector<int> face;
  std::vector<double> bary;
  // The locations as the operator uses them (its weights, = the rows of U): the constructor leaves
  // weights that are already normalised as they are (shell_prolongation.cpp), so they rebuild the
  // same operator bit for bit; get_prolongation checks that on every read.
  for (size_t i = 0; i < nf; ++i) {
    const SurfaceLocation& loc = P.locations()[i];
    face.push_back(loc.face);
    bary.insert(bary.end(), loc.bary.data(), loc.bary.data() + 3);
  }
  put_ints(f, g + "/location_face", face);
  put_doubles(f, g + "/location_bary", bary.data(), nf, 3);
  const Csr U = to_csr(P.U());
  put_int64s(f, g + "/U_indptr", U.indptr);
  put_ints(f, g + "/U_indices", U.indices);
  put_doubles(f, g + "/U_data", U.data.data(), U.data.size());
  put_doubles(f, g + "/normal_offsets", P.normal_offsets().data(), nf);
  const std::vector<double> t = tangent_array(P);
  put_doubles(f, g + "/tangent_offsets", t.data(), nf, 2);
}

// First index where a and b differ bit for bit (-1 if none; -2 if the sizes differ).
template <class T>
long long first_difference(const std::vector<T>& a, const std::vector<T>& b) {
  if (a.size() != b.size()) return -2;
  for (size_t i = 0; i < a.size(); ++i)
    if (std::memcmp(&a[i], &b[i], sizeof(T)) != 0) return static_cast<long long>(i);
  return -1;
}

ShellProlongation get_prolongation(const File& f, const std::string& g, const TriMesh& coarse,
                                   const Positions& fine_rest) {
  const int rows = f.read_int_attr(g, "rows"), cols = f.read_int_attr(g, "cols");
  if (rows != fine_rest.rows() || cols != coarse.V.rows())
    f.fail(g, "operator is " + std::to_string(rows) + " x " + std::to_string(cols) + ", the levels need " +
                  std::to_string(fine_rest.rows()) + " x " + std::to_string(coarse.V.rows()));
  const std::vector<int> face = get_ints(f, g + "/location_face", rows);
  const std::vector<double> bary = get_doubles(f, g + "/location_bary", rows, 3);
  std::vector<SurfaceLocation> locs(static_cast<size_t>(rows));
  for (size_t i = 0; i < locs.size(); ++i) {
    locs[i].face = face[i];
    locs[i].bary = Eigen::Vector3d(bary[3 * i], bary[3 * i + 1], bary[3 * i + 2]);
  }
  std::optional<ShellProlongation> P;
  try {
    P.emplace(coarse.V, coarse.F, fine_rest, locs);
  } catch (const std::invalid_argument& e) {
    f.fail(g, std::string("cannot rebuild the operator from the stored locations: ") + e.what());
  }

  // Compare the rebuilt operator with the stored arrays, bit for bit.
  const Csr stored{get_int64s(f, g + "/U_indptr", rows + 1L), get_ints(f, g + "/U_indices"),
                   get_doubles(f, g + "/U_data")};
  const Csr rebuilt = to_csr(P->U());
  const std::pair<const char*, long long> checks[] = {
      {"U_indptr", first_difference(rebuilt.indptr, stored.indptr)},
      {"U_indices", first_difference(rebuilt.indices, stored.indices)},
      {"U_data", first_difference(rebuilt.data, stored.data)},
      {"normal_offsets", first_difference(P->normal_offsets(), get_doubles(f, g + "/normal_offsets", rows))},
      {"tangent_offsets", first_difference(tangent_array(*P), get_doubles(f, g + "/tangent_offsets", rows, 2))},
  };
  for (const auto& [what, at] : checks)
    if (at != -1)
      f.fail(g, std::string("stored operator differs from the rebuilt one (file corrupt or written by another "
                            "version): ") +
                    what + (at == -2 ? " has another length" : " differs at entry " + std::to_string(at)));
  return std::move(*P);
}

// ---- whole hierarchy ------------------------------------------------------------------------------

void put_object(const File& f, size_t k, const ObjectHierarchy& oh, const std::string& name) {
  const std::string g = object_group(k);
  f.make_group(g);
  f.write_string_attr(g, "name", name);
  f.write_int_attr(g, "batch_levels", static_cast<int>(oh.batches.size()));
  for (size_t l = 0; l < oh.levels.size(); ++l) {
    const Level& lv = oh.levels[l];
    const std::string gl = g + "/" + std::to_string(l);
    f.make_group(gl);
    put_mesh(f, gl, "positions", lv.mesh);
    put_ints(f, gl + "/to_finest", lv.to_finest);
    put_ints(f, gl + "/coarse_to_fine", lv.coarse_to_fine);
    put_ints(f, gl + "/fine_to_coarse", lv.fine_to_coarse);
    put_collapses(f, gl + "/collapses", lv.collapses);
    if (l < oh.batches.size()) put_batches(f, gl, oh.batches[l]);
  }
}

// Object k of a hierarchy whose scene levels are `levels`: each of its level meshes must have as many
// vertices and triangles as the object owns in that scene level (vertex and face offsets), and every
// map, collapse and batch must index existing vertices, collapses and faces.
ObjectHierarchy get_object(const File& f, size_t k, const std::vector<SceneLevel>& levels) {
  const int num_levels = static_cast<int>(levels.size());
  const std::string g = object_group(k);
  const int batch_levels = f.read_int_attr(g, "batch_levels");
  if (batch_levels < 0 || batch_levels > num_levels)
    f.fail(g + "/@batch_levels", "must be in [0, " + std::to_string(num_levels) + "]");
  ObjectHierarchy oh;
  oh.levels.resize(static_cast<size_t>(num_levels));
  for (int l = 0; l < num_levels; ++l) {  // meshes first: the maps below need every level's size
    Level& lv = oh.levels[static_cast<size_t>(l)];
    const SceneLevel& s = levels[static_cast<size_t>(l)];
    const std::string gl = g + "/" + std::to_string(l);
    const int n = s.vertex_offsets[k + 1] - s.vertex_offsets[k], m = s.face_offsets[k + 1] - s.face_offsets[k];
    lv.mesh.V = get_positions(f, gl + "/positions", n);
    lv.mesh.F = get_faces(f, gl + "/faces", n, m);
  }
  const long long n_finest = oh.levels.back().mesh.V.rows();
  for (int l = 0; l < num_levels; ++l) {
    Level& lv = oh.levels[static_cast<size_t>(l)];
    const std::string gl = g + "/" + std::to_string(l);
    const long long n = lv.mesh.V.rows();
    const bool finest = l + 1 == num_levels;
    const int n_next = finest ? 0 : static_cast<int>(oh.levels[static_cast<size_t>(l) + 1].mesh.V.rows());
    lv.to_finest = get_ints(f, gl + "/to_finest", n);
    check_index_range(f, gl + "/to_finest", lv.to_finest.data(), lv.to_finest.size(), 0, n_finest, "vertex id");
    lv.coarse_to_fine = get_ints(f, gl + "/coarse_to_fine", finest ? 0 : n);
    check_index_range(f, gl + "/coarse_to_fine", lv.coarse_to_fine.data(), lv.coarse_to_fine.size(), -1, n_next,
                      "vertex id");
    lv.fine_to_coarse = get_ints(f, gl + "/fine_to_coarse", n_next);
    check_index_range(f, gl + "/fine_to_coarse", lv.fine_to_coarse.data(), lv.fine_to_coarse.size(), -1, n,
                      "vertex id");
    lv.collapses = get_collapses(f, gl + "/collapses", n_next);
    if (l < batch_levels) oh.batches.push_back(get_batches(f, gl, lv.collapses.size()));
  }
  return oh;
}

}  // namespace

void write_hierarchy(const std::string& path, const SceneHierarchy& h, const std::vector<std::string>& object_names) {
  File f = open_file(path, true);
  if (!f.has_attr("/", "format_version")) f.fail("/@format_version", "missing attribute, not a frame file");
  const int L = h.num_levels();
  if (L < 1) f.fail(kRoot, "the hierarchy has no levels");
  if (object_names.size() != h.objects.size())
    f.fail(kRoot, std::to_string(object_names.size()) + " object names for " + std::to_string(h.objects.size()) +
                      " objects");
  if (f.exists(kRoot)) f.check(H5Ldelete(f.id.get(), kRoot, H5P_DEFAULT), kRoot, "cannot replace the group");
  f.make_group(kRoot);
  f.write_string_attr(kRoot, "hash", h.hash);
  f.write_int_attr(kRoot, "num_levels", L);
  f.write_int_attr(kRoot, "num_objects", static_cast<int>(h.objects.size()));
  f.write_int_attr(kRoot, "hierarchy_format_version", kHierarchyFormatVersion);
  for (int l = 0; l < L; ++l) {
    const SceneLevel& s = h.levels[static_cast<size_t>(l)];
    const std::string g = level_group(l);
    f.make_group(g);
    // The first four as FrameWriter::add_level writes them (it then finds and checks them).
    put_mesh(f, g, "rest_positions", s.rest);
    put_ints(f, g + "/object_offsets", s.vertex_offsets);
    put_strings(f, g + "/object_names", object_names);
    put_ints(f, g + "/face_offsets", s.face_offsets);
    put_ints(f, g + "/to_finest", s.to_finest);
    if (s.to_next) put_prolongation(f, g + "/to_next", *s.to_next);
    if (s.to_finest_prolongation) put_prolongation(f, g + "/to_finest_prolongation", *s.to_finest_prolongation);
  }
  f.make_group(std::string(kRoot) + "/objects");
  for (size_t k = 0; k < h.objects.size(); ++k) put_object(f, k, h.objects[k], object_names[k]);
  f.flush();
  f.check(f.id.reset(), "", "close failed");
}

std::optional<std::string> stored_hierarchy_hash(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec) || H5Fis_hdf5(path.c_str()) <= 0) return std::nullopt;
  File f = open_file(path, false);
  if (!f.has_attr(kRoot, "hash")) return std::nullopt;
  return f.read_string_attr(kRoot, "hash");
}

std::optional<SceneHierarchy> read_hierarchy(const std::string& path) {
  File f = open_file(path, false);
  if (!f.has_attr(kRoot, "hash")) return std::nullopt;
  const int version = f.read_int_attr(kRoot, "hierarchy_format_version");
  if (version != kHierarchyFormatVersion)
    f.fail(std::string(kRoot) + "/@hierarchy_format_version",
           "hierarchy_format_version " + std::to_string(version) + " unsupported (expected " +
               std::to_string(kHierarchyFormatVersion) + ")");
  SceneHierarchy h;
  h.hash = f.read_string_attr(kRoot, "hash");
  const int L = f.read_int_attr(kRoot, "num_levels");
  const int K = f.read_int_attr(kRoot, "num_objects");
  // Limits before anything is allocated from them (a hostile count would otherwise exhaust memory).
  if (L < 1 || L > kMaxFrameFileLevels)
    f.fail(std::string(kRoot) + "/@num_levels", "must be in [1, " + std::to_string(kMaxFrameFileLevels) + "], got " +
                                                    std::to_string(L));
  if (K < 1 || K > kMaxLevelObjects)
    f.fail(std::string(kRoot) + "/@num_objects", "must be in [1, " + std::to_string(kMaxLevelObjects) + "], got " +
                                                     std::to_string(K));
  h.levels.resize(static_cast<size_t>(L));
  for (int l = 0; l < L; ++l) {
    SceneLevel& s = h.levels[static_cast<size_t>(l)];
    const std::string g = level_group(l);
    s.rest.V = get_positions(f, g + "/rest_positions");
    const int n = static_cast<int>(s.rest.V.rows());
    if (n < 1) f.fail(g + "/rest_positions", "the level has no vertices");
    s.rest.F = get_faces(f, g + "/faces", n);
    s.vertex_offsets = get_ints(f, g + "/object_offsets", K + 1);
    check_offsets(f, g + "/object_offsets", {s.vertex_offsets.begin(), s.vertex_offsets.end()}, n);
    s.face_offsets = get_ints(f, g + "/face_offsets", K + 1);
    check_offsets(f, g + "/face_offsets", {s.face_offsets.begin(), s.face_offsets.end()}, s.rest.F.rows());
    s.to_finest = get_ints(f, g + "/to_finest", n);
  }
  const long long n_finest = h.levels.back().rest.V.rows();
  for (int l = 0; l < L; ++l) {
    const std::vector<int>& m = h.levels[static_cast<size_t>(l)].to_finest;
    check_index_range(f, level_group(l) + "/to_finest", m.data(), m.size(), 0, n_finest, "vertex id");
  }
  // Operators after all rest meshes are known (to_next needs level l + 1's).
  const Positions& finest_rest = h.levels.back().rest.V;
  for (int l = 0; l < L; ++l) {
    SceneLevel& s = h.levels[static_cast<size_t>(l)];
    const std::string g = level_group(l);
    if (f.exists(g + "/to_next")) {
      if (l + 1 == L) f.fail(g + "/to_next", "the finest level has no next level");
      s.to_next = get_prolongation(f, g + "/to_next", s.rest, h.levels[static_cast<size_t>(l) + 1].rest.V);
    }
    if (f.exists(g + "/to_finest_prolongation"))
      s.to_finest_prolongation = get_prolongation(f, g + "/to_finest_prolongation", s.rest, finest_rest);
  }
  for (int k = 0; k < K; ++k) h.objects.push_back(get_object(f, static_cast<size_t>(k), h.levels));
  return h;
}

std::vector<std::string> scene_object_names(const Scene& scene) {
  std::vector<std::string> names;
  for (const SceneObject& o : scene.objects) names.push_back(o.name);
  return names;
}

void add_hierarchy_levels(FrameWriter& writer, const SceneHierarchy& h, const std::vector<std::string>& object_names) {
  for (int l = 0; l < h.num_levels(); ++l) {
    const SceneLevel& s = h.levels[static_cast<size_t>(l)];
    writer.add_level(l, s.rest.V, s.rest.F, s.vertex_offsets, object_names);
  }
}

SceneHierarchy load_or_build_hierarchy(const Scene& scene, const std::string& path, bool* reused,
                                       std::vector<HierarchyLevelReport>* report) {
  if (reused) *reused = false;
  const std::optional<std::string> stored = stored_hierarchy_hash(path);
  if (stored && *stored == hierarchy_hash(scene)) {
    if (std::optional<SceneHierarchy> h = read_hierarchy(path)) {
      if (reused) *reused = true;
      if (report) report->clear();
      return std::move(*h);
    }
  }
  SceneHierarchy h = build_scene_hierarchy(scene, report);
  const std::vector<std::string> names = scene_object_names(scene);
  FrameWriter writer = FrameWriter::create(path, scene.json_text, scene.frames);
  write_hierarchy(path, h, names);
  add_hierarchy_levels(writer, h, names);
  writer.close();
  return h;
}

}  // namespace pd
