#include "physics/contact/broad_phase.h"

// Method. All boxes of one query live on one uniform grid of cubic cells of side h. The targets
// (faces for point-triangle, edges for edge-edge) are inserted into every cell their box covers, in a
// hash table over the cells' integer coordinates (CellTable). Each query primitive (vertex, edge)
// then visits the cells its own box covers and tests the targets found there.
//
// Each pair is produced exactly once, without a global sort or a "seen" set: a pair is only accepted
// in its lowest common cell, the cell whose coordinates are the componentwise max of the two boxes'
// lowest cells (it lies in both cell ranges whenever the boxes overlap). The pairs of one query
// primitive are sorted (a short list), and query primitives run in index order, so the output comes
// out globally sorted. Nothing depends on hash collisions, memory addresses or iteration order of
// anything but indices, so the result is deterministic.
//
// Exactness. Cell coordinates are floor((x - origin) / h) (computed as a product with 1 / h), which is
// monotone in x also in floating point, so two boxes that overlap in floating point always have
// overlapping cell ranges: the grid never misses a pair that the box test (the contract) accepts.
//
// Cell size h = mean edge length + r (+ mean vertex displacement for swept queries). The targets are
// edges and faces, whose boxes are about one edge length plus r wide (plus the motion, when swept).
// A cell at least that wide means a box covers at most 2 cells per axis, so insertion is O(1) per
// primitive; a cell not much wider keeps O(1) primitives per cell on a cloth-like surface (about
// (h / edge)^2 per sheet layer through the cell), so the tests done in a cell stay proportional to
// the true candidates. Smaller cells multiply insertions ((box / h)^3 cells per box); larger ones fill
// cells with primitives whose boxes do not overlap.
//
// Complexity per query: O(n + m + E) to build boxes and the table, O(K) for K candidate pairs plus
// the non-overlapping primitives met in shared cells (O(1) per primitive for bounded density), and
// O(k log k) to sort each query primitive's k pairs. Boxes covering more than kMaxCellsPerBox cells
// (a coarse ground plane next to fine cloth, a vertex moving far in one step) are not inserted; pairs
// involving them are box-tested directly against every primitive of the other kind, O(L * (n + m))
// or O(L * E) for L such boxes, which bounds the table's memory whatever the size mix.
//
// Memory: about 100 bytes per primitive (box, cell range, table entries) plus 8 per candidate pair.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace pd {
namespace {

constexpr int kCoordBits = 21;  // cell coordinates are clamped to [0, 2^21): no int overflow
constexpr double kMaxCoord = static_cast<double>((1 << kCoordBits) - 1);
constexpr long kMaxCellsPerBox = 64;  // above this, a box is handled by direct tests (see top)

struct Box {
  double lo[3], hi[3];
};

// Closed overlap: touching boxes overlap.
bool overlap(const Box& a, const Box& b) {
  for (int k = 0; k < 3; ++k)
    if (a.lo[k] > b.hi[k] || b.lo[k] > a.hi[k]) return false;
  return true;
}

// Positions of a query: V0 alone (static) or the motion V0 -> V1 (swept).
struct Motion {
  const Positions& V0;
  const Positions* V1;  // nullptr for a static query
};

// Box of the vertices `vs` (at both ends of the motion if swept), grown by r/2: the contract's formula.
template <std::size_t N>
Box box_of(const Motion& x, const std::array<int, N>& vs, double r) {
  Box b;
  for (int k = 0; k < 3; ++k) {
    b.lo[k] = std::numeric_limits<double>::infinity();
    b.hi[k] = -std::numeric_limits<double>::infinity();
  }
  for (int v : vs)
    for (int k = 0; k < 3; ++k) {
      b.lo[k] = std::min(b.lo[k], x.V0(v, k));
      b.hi[k] = std::max(b.hi[k], x.V0(v, k));
      if (x.V1) {
        b.lo[k] = std::min(b.lo[k], (*x.V1)(v, k));
        b.hi[k] = std::max(b.hi[k], (*x.V1)(v, k));
      }
    }
  for (int k = 0; k < 3; ++k) {
    b.lo[k] -= 0.5 * r;
    b.hi[k] += 0.5 * r;
  }
  return b;
}

// Inclusive range of integer cell coordinates covered by a box.
struct CellRange {
  int lo[3], hi[3];
  long count() const {
    return static_cast<long>(hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1);
  }
};

template <class Visit>
void for_each_cell(const CellRange& c, Visit visit) {
  for (int z = c.lo[2]; z <= c.hi[2]; ++z)
    for (int y = c.lo[1]; y <= c.hi[1]; ++y)
      for (int x = c.lo[0]; x <= c.hi[0]; ++x) visit(x, y, z);
}

struct Grid {
  double origin[3];  // lowest corner of all boxes, metres
  double inv_h;      // 1 / cell size, 1/metres

  // floor((x - origin) / h), clamped to [0, kMaxCoord] (the clamp only guards against rounding at
  // the grid's edges). Truncation is floor here because the value is clamped non-negative first;
  // it avoids a libm floor() call, which this hot path would otherwise make on baseline x86-64.
  int coord(double x, int k) const {
    const double v = std::clamp((x - origin[k]) * inv_h, 0.0, kMaxCoord);
    return static_cast<int>(v);
  }
  CellRange range(const Box& b) const {
    CellRange c;
    for (int k = 0; k < 3; ++k) {
      c.lo[k] = coord(b.lo[k], k);
      c.hi[k] = coord(b.hi[k], k);
    }
    return c;
  }
};

// Grid over all boxes of the query with cells of side `cell`, widened if the scene would need more
// than 2^20 cells along an axis (only for absurd size ratios; correctness does not depend on h).
Grid make_grid(const std::vector<Box>& a, const std::vector<Box>& b, double cell) {
  double lo[3], hi[3];
  for (int k = 0; k < 3; ++k) {
    lo[k] = std::numeric_limits<double>::infinity();
    hi[k] = -std::numeric_limits<double>::infinity();
  }
  for (const std::vector<Box>* boxes : {&a, &b})
    for (const Box& box : *boxes)
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], box.lo[k]);
        hi[k] = std::max(hi[k], box.hi[k]);
      }
  Grid g;
  double extent = 0.0;
  for (int k = 0; k < 3; ++k) {
    g.origin[k] = std::isfinite(lo[k]) ? lo[k] : 0.0;  // no boxes at all: any origin
    if (hi[k] > lo[k]) extent = std::max(extent, hi[k] - lo[k]);
  }
  double h = std::max(cell, extent / static_cast<double>(1 << 20));
  if (!(h > 0.0) || !std::isfinite(h)) h = 1.0;  // everything at one point: any cell works
  g.inv_h = 1.0 / h;
  return g;
}

// Cell -> primitives table. Primitives are listed per bucket (a hash of the cell), once per bucket
// even if several of their cells share it, in index order. Buckets mix cells, so a lookup returns a
// superset of the cell's primitives; collect_pairs' lowest-common-cell and box tests sort them out.
// Memory is 4 bytes per bucket and per entry (ids only, no keys, filled in place by counting sort):
// on a 100K-vertex sheet, allocating and first touching memory is a large share of a query's time.
class CellTable {
 public:
  // Inserts every primitive i with inserted[i] into the cells of ranges[i].
  CellTable(const std::vector<CellRange>& ranges, const std::vector<char>& inserted) {
    std::size_t cells = 0;
    for (std::size_t i = 0; i < ranges.size(); ++i)
      if (inserted[i]) cells += static_cast<std::size_t>(ranges[i].count());
    if (cells >= std::numeric_limits<std::uint32_t>::max())
      throw std::length_error("broad phase: grid too large");
    std::size_t buckets = 16;
    while (buckets < cells) buckets *= 2;  // about one cell per bucket
    mask_ = buckets - 1;
    start_.assign(buckets + 1, 0);
    // Calls put(bucket, i) once per distinct bucket of each inserted primitive i, i increasing or not.
    std::vector<std::size_t> mine;
    auto for_each_entry = [&](bool reverse, auto put) {
      const std::size_t n = ranges.size();
      for (std::size_t j = 0; j < n; ++j) {
        const std::size_t i = reverse ? n - 1 - j : j;
        if (!inserted[i]) continue;
        mine.clear();  // at most kMaxCellsPerBox buckets, usually 1 to 8: a linear search is enough
        for_each_cell(ranges[i], [&](int x, int y, int z) {
          const std::size_t b = bucket(x, y, z);
          if (std::find(mine.begin(), mine.end(), b) == mine.end()) mine.push_back(b);
        });
        for (std::size_t b : mine) put(b, static_cast<int>(i));
      }
    };
    for_each_entry(false, [&](std::size_t b, int) { ++start_[b + 1]; });
    for (std::size_t b = 1; b < start_.size(); ++b) start_[b] += start_[b - 1];
    ids_.resize(start_.back());
    // Counting sort without a cursor array: bucket b is filled backwards from its end start_[b + 1],
    // primitives in decreasing order (so each bucket ends up increasing), which leaves start_[b + 1]
    // at the bucket's beginning; shifting start_ down one slot restores [begin, end) pairs.
    for_each_entry(true, [&](std::size_t b, int i) { ids_[--start_[b + 1]] = i; });
    for (std::size_t b = 0; b < buckets; ++b) start_[b] = start_[b + 1];
    start_[buckets] = static_cast<std::uint32_t>(ids_.size());
  }

  // Calls visit(id) for every primitive in the bucket of cell (x, y, z): all primitives inserted
  // into that cell, each once, and maybe some of other cells.
  template <class Visit>
  void visit_bucket(int x, int y, int z, Visit&& visit) const {
    const std::size_t b = bucket(x, y, z);
    for (std::uint32_t e = start_[b]; e < start_[b + 1]; ++e) visit(ids_[e]);
  }
  // The same without the primitives whose ids lie in [skip.first, skip.second): a bucket lists its
  // ids in increasing order, so they are one run, stepped over by a binary search.
  template <class Visit>
  void visit_bucket(int x, int y, int z, std::pair<int, int> skip, Visit&& visit) const {
    if (skip.first == skip.second) return visit_bucket(x, y, z, visit);  // nothing to skip
    const std::size_t b = bucket(x, y, z);
    const int* e = ids_.data() + start_[b];
    const int* end = ids_.data() + start_[b + 1];
    for (; e != end && *e < skip.first; ++e) visit(*e);
    for (e = std::lower_bound(e, end, skip.second); e != end; ++e) visit(*e);
  }

 private:
  // Cells next to each other along x land in consecutive buckets: primitives are usually numbered
  // with spatial coherence (mesh rows), so consecutive queries then reuse cached buckets, which
  // measured 2-4x faster than a scattering hash on a 100K-vertex sheet. The large odd multipliers
  // scatter y and z, so no flat layer of the scene piles into a few buckets.
  std::size_t bucket(int x, int y, int z) const {
    const std::uint64_t h = static_cast<std::uint64_t>(x) + static_cast<std::uint64_t>(y) * 0x9E3779B1ull +
                            static_cast<std::uint64_t>(z) * 0x85EBCA77C2B2AE63ull;
    return static_cast<std::size_t>(h & mask_);
  }
  std::size_t mask_;
  std::vector<std::uint32_t> start_;  // bucket b lists ids_[start_[b], start_[b + 1])
  std::vector<int> ids_;
};

// The objects of a query's primitives and of its targets, and which objects self-collide: pairs
// within an object whose self-contact is off are never candidates, so a query primitive of such an
// object steps over its own object's targets instead of testing and rejecting them one by one (an
// obstacle's primitives next to each other: half of spin-sphere's broad phase). That needs each
// object's targets to be one run of ids (as the scene stacks them); otherwise nothing is skipped.
struct PairObjects {
  const std::vector<int>& query;
  const std::vector<int>& target;
  const std::vector<char>& self;
};

// Per object, the run [first, second) of target ids it owns when every object's targets are
// contiguous and its self-contact is off; {0, 0} (an empty run) otherwise.
std::vector<std::pair<int, int>> skipped_target_runs(const PairObjects& o) {
  const int objects = static_cast<int>(o.self.size());
  std::vector<std::pair<int, int>> run(static_cast<std::size_t>(objects), {-1, -1});
  const int n = static_cast<int>(o.target.size());
  for (int b = 0; b < n; ++b) {
    auto& r = run[static_cast<std::size_t>(o.target[b])];
    if (r.first < 0) {
      r = {b, b + 1};
    } else if (r.second == b) {
      r.second = b + 1;
    } else {
      return std::vector<std::pair<int, int>>(static_cast<std::size_t>(objects), {0, 0});  // not one run
    }
  }
  for (int k = 0; k < objects; ++k)
    if (run[static_cast<std::size_t>(k)].first < 0 || o.self[static_cast<std::size_t>(k)]) run[static_cast<std::size_t>(k)] = {0, 0};
  return run;
}

// Appends to `out`, sorted, every (a, b) with query box a overlapping target box b that accept(a, b)
// keeps; with same_set (queries and targets are the same primitives) only pairs with a < b. accept
// must refuse pairs within an object whose self-contact is off (`objects`); they may be skipped
// before it is asked.
template <class Accept>
void collect_pairs(const std::vector<Box>& qbox, const std::vector<Box>& tbox, bool same_set,
                   double cell, const PairObjects& objects, Accept accept, std::vector<std::array<int, 2>>& out) {
  const std::vector<std::pair<int, int>> own_run = skipped_target_runs(objects);
  const Grid grid = make_grid(qbox, tbox, cell);
  const int nq = static_cast<int>(qbox.size()), nt = static_cast<int>(tbox.size());
  // Cell ranges, and whether a box is small enough for the table; targets share the queries' when
  // they are the same primitives.
  auto ranges_of = [&grid](const std::vector<Box>& boxes, std::vector<CellRange>& ranges,
                           std::vector<char>& small) {
    ranges.resize(boxes.size());
    small.resize(boxes.size());
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      ranges[i] = grid.range(boxes[i]);
      small[i] = ranges[i].count() <= kMaxCellsPerBox;
    }
  };
  std::vector<CellRange> qrange, trange_own;
  std::vector<char> qsmall, tsmall_own;
  ranges_of(qbox, qrange, qsmall);
  if (!same_set) ranges_of(tbox, trange_own, tsmall_own);
  const std::vector<CellRange>& trange = same_set ? qrange : trange_own;
  const std::vector<char>& tsmall = same_set ? qsmall : tsmall_own;
  std::vector<int> large_targets;
  for (int b = 0; b < nt; ++b)
    if (!tsmall[b]) large_targets.push_back(b);
  const CellTable table(trange, tsmall);

  std::vector<int> found;
  for (int a = 0; a < nq; ++a) {
    found.clear();
    const std::pair<int, int> skip = own_run[static_cast<std::size_t>(objects.query[a])];
    const auto skipped = [&skip](int b) { return b >= skip.first && b < skip.second; };
    auto consider = [&](int b) {
      if (overlap(qbox[a], tbox[b]) && accept(a, b)) found.push_back(b);
    };
    const CellRange& ra = qrange[a];
    if (qsmall[a]) {
      // Both small: through the table, in the lowest common cell only. If the boxes overlap, that
      // cell is in both ranges, so b is in its bucket; any other b met is rejected here or by the
      // box test. Each bucket lists b once, so the pair is found once.
      for_each_cell(ra, [&](int x, int y, int z) {
        table.visit_bucket(x, y, z, skip, [&](int b) {
          if (same_set && b <= a) return;
          const CellRange& rb = trange[b];
          if (x != std::max(ra.lo[0], rb.lo[0]) || y != std::max(ra.lo[1], rb.lo[1]) ||
              z != std::max(ra.lo[2], rb.lo[2]))
            return;
          consider(b);
        });
      });
      for (int b : large_targets)
        if ((!same_set || b > a) && !skipped(b)) consider(b);
    } else {
      for (int b = same_set ? a + 1 : 0; b < nt; ++b)
        if (!skipped(b)) consider(b);
    }
    std::sort(found.begin(), found.end());
    for (int b : found) out.push_back({a, b});
  }
}

[[noreturn]] void fail(const std::string& problem) {
  throw std::invalid_argument("broad phase: " + problem);
}

// Checks the input and returns the object of each face and each edge.
void check_input(const ContactPrimitives& p, const Motion& x, double r, std::vector<int>& face_object,
                 std::vector<int>& edge_object) {
  if (!(r >= 0.0) || !std::isfinite(r)) fail("inflation radius must be finite and >= 0");
  const int n = static_cast<int>(p.vertex_object.size());
  if (x.V0.rows() != n) fail("positions and vertex_object differ in size");
  if (x.V1 && x.V1->rows() != n) fail("start and end positions differ in size");
  if (!x.V0.allFinite() || (x.V1 && !x.V1->allFinite())) fail("non-finite position");
  const int objects = static_cast<int>(p.object_self_contact.size());
  for (int o : p.vertex_object)
    if (o < 0 || o >= objects) fail("vertex object id out of range");
  auto object_of = [&](const int* v, int count, const char* what, int index) {
    const std::string name = std::string(what) + " " + std::to_string(index);
    for (int k = 0; k < count; ++k)
      if (v[k] < 0 || v[k] >= n) fail(name + " index out of range");
    for (int k = 1; k < count; ++k)
      if (p.vertex_object[v[k]] != p.vertex_object[v[0]]) fail(name + " spans two objects");
    return p.vertex_object[v[0]];
  };
  face_object.resize(static_cast<std::size_t>(p.faces.rows()));
  for (int f = 0; f < static_cast<int>(p.faces.rows()); ++f) {
    const int v[3] = {p.faces(f, 0), p.faces(f, 1), p.faces(f, 2)};
    face_object[f] = object_of(v, 3, "face", f);
  }
  edge_object.resize(p.edges.size());
  for (std::size_t e = 0; e < p.edges.size(); ++e)
    edge_object[e] = object_of(p.edges[e].data(), 2, "edge", static_cast<int>(e));
}

// Cell side in metres (see the top of the file). The mean edge length comes from the edge list, or
// from the faces' sides if there are no edges.
double cell_size(const ContactPrimitives& p, const Motion& x, double r) {
  double length = 0.0;
  for (const auto& e : p.edges) length += (x.V0.row(e[0]) - x.V0.row(e[1])).norm();
  if (!p.edges.empty()) {
    length /= static_cast<double>(p.edges.size());
  } else if (p.faces.rows() > 0) {
    for (Eigen::Index f = 0; f < p.faces.rows(); ++f)
      for (int k = 0; k < 3; ++k)
        length += (x.V0.row(p.faces(f, k)) - x.V0.row(p.faces(f, (k + 1) % 3))).norm();
    length /= 3.0 * static_cast<double>(p.faces.rows());
  }
  double motion = 0.0;
  if (x.V1 && x.V0.rows() > 0) motion = (*x.V1 - x.V0).rowwise().norm().mean();
  return length + r + motion;
}

CandidatePairs run(const ContactPrimitives& p, const Motion& x, double r) {
  std::vector<int> face_object, edge_object;
  check_input(p, x, r, face_object, edge_object);
  const double cell = cell_size(p, x, r);
  const std::vector<int>& vertex_object = p.vertex_object;
  const std::vector<char>& self = p.object_self_contact;
  const int n = static_cast<int>(vertex_object.size()), m = static_cast<int>(p.faces.rows());

  std::vector<Box> vertex_box(static_cast<std::size_t>(n)), face_box(static_cast<std::size_t>(m)),
      edge_box(p.edges.size());
  for (int v = 0; v < n; ++v) vertex_box[v] = box_of<1>(x, {v}, r);
  for (int f = 0; f < m; ++f) face_box[f] = box_of<3>(x, {p.faces(f, 0), p.faces(f, 1), p.faces(f, 2)}, r);
  for (std::size_t e = 0; e < p.edges.size(); ++e) edge_box[e] = box_of<2>(x, p.edges[e], r);

  CandidatePairs out;
  collect_pairs(vertex_box, face_box, false, cell, PairObjects{vertex_object, face_object, self}, [&](int v, int f) {
    if (v == p.faces(f, 0) || v == p.faces(f, 1) || v == p.faces(f, 2)) return false;
    return vertex_object[v] != face_object[f] || self[vertex_object[v]] != 0;
  }, out.point_triangle);
  collect_pairs(edge_box, edge_box, true, cell, PairObjects{edge_object, edge_object, self}, [&](int a, int b) {
    const auto& ea = p.edges[a];
    const auto& eb = p.edges[b];
    if (ea[0] == eb[0] || ea[0] == eb[1] || ea[1] == eb[0] || ea[1] == eb[1]) return false;
    return edge_object[a] != edge_object[b] || self[edge_object[a]] != 0;
  }, out.edge_edge);
  return out;
}

}  // namespace

CandidatePairs find_candidates(const ContactPrimitives& prims, const Positions& V, double r) {
  return run(prims, Motion{V, nullptr}, r);
}

CandidatePairs find_swept_candidates(const ContactPrimitives& prims, const Positions& V0,
                                     const Positions& V1, double r) {
  return run(prims, Motion{V0, &V1}, r);
}

std::vector<std::array<int, 2>> find_edge_face_candidates(const ContactPrimitives& prims, const Positions& V,
                                                          double r) {
  // The same machinery as run(): edges are the queries, faces the targets (as vertices against faces
  // there), so pairs come out sorted by edge, then face.
  const Motion x{V, nullptr};
  std::vector<int> face_object, edge_object;
  check_input(prims, x, r, face_object, edge_object);
  const double cell = cell_size(prims, x, r);
  const int m = static_cast<int>(prims.faces.rows());
  std::vector<Box> face_box(static_cast<std::size_t>(m)), edge_box(prims.edges.size());
  for (int f = 0; f < m; ++f) face_box[f] = box_of<3>(x, {prims.faces(f, 0), prims.faces(f, 1), prims.faces(f, 2)}, r);
  for (std::size_t e = 0; e < prims.edges.size(); ++e) edge_box[e] = box_of<2>(x, prims.edges[e], r);
  std::vector<std::array<int, 2>> out;
  collect_pairs(edge_box, face_box, false, cell, PairObjects{edge_object, face_object, prims.object_self_contact},
                [&](int e, int f) {
    const auto& ev = prims.edges[e];
    for (int k = 0; k < 3; ++k)
      if (prims.faces(f, k) == ev[0] || prims.faces(f, k) == ev[1]) return false;
    return edge_object[e] != face_object[f] || prims.object_self_contact[edge_object[e]] != 0;
  }, out);
  return out;
}

}  // namespace pd
