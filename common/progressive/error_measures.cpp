#include "progressive/error_measures.h"

// CGAL 5.5 calls used (header-only): AABB_tree over AABB_triangle_primitive of
// Simple_cartesian<double> triangles, accelerate_distance_queries() and squared_distance(point),
// which is the exact point-to-triangle distance (projection onto each candidate triangle, onto a
// segment for a degenerate one) in double arithmetic. The kernel has no interval arithmetic, so this
// file needs neither CGAL's -frounding-math nor its GMP fallback (see common/CMakeLists.txt for why
// the rest of pd_common is kept free of that flag).
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

namespace pd {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using Triangle = Kernel::Triangle_3;
using TriangleIterator = std::vector<Triangle>::const_iterator;
using Primitive = CGAL::AABB_triangle_primitive<Kernel, TriangleIterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;

Point to_point(const Positions& V, int i) { return Point(V(i, 0), V(i, 1), V(i, 2)); }

void require_same_shape(const Positions& a, const Positions& b, std::size_t mask, const char* what) {
  if (a.rows() != b.rows() || mask != static_cast<std::size_t>(a.rows()))
    throw std::invalid_argument(std::string(what) + ": positions with " + std::to_string(a.rows()) + " and " +
                                std::to_string(b.rows()) + " rows, mask of " + std::to_string(mask));
}

// The object that owns vertex v: the k with off[k] <= v < off[k+1] (-1 outside every object).
int owner(const std::vector<int>& off, int v) {
  const auto it = std::upper_bound(off.begin(), off.end(), v);
  if (it == off.begin() || it == off.end()) return -1;
  return static_cast<int>(it - off.begin()) - 1;
}

}  // namespace

// ---- selections ------------------------------------------------------------------------------------

std::vector<char> simulated_vertices(const std::vector<int>& object_offsets, const std::vector<char>& obstacle) {
  if (object_offsets.empty()) return {};
  std::vector<char> mask(static_cast<std::size_t>(object_offsets.back()), 0);
  for (std::size_t k = 0; k + 1 < object_offsets.size() && k < obstacle.size(); ++k)
    if (!obstacle[k])
      std::fill(mask.begin() + object_offsets[k], mask.begin() + object_offsets[k + 1], char{1});
  return mask;
}

Faces simulated_faces(const Faces& F, const std::vector<int>& object_offsets, const std::vector<char>& obstacle) {
  std::vector<int> keep;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const int k = owner(object_offsets, F(f, 0));
    if (k >= 0 && static_cast<std::size_t>(k) < obstacle.size() && !obstacle[static_cast<std::size_t>(k)])
      keep.push_back(static_cast<int>(f));
  }
  Faces out(static_cast<Eigen::Index>(keep.size()), 3);
  for (std::size_t r = 0; r < keep.size(); ++r) out.row(static_cast<Eigen::Index>(r)) = F.row(keep[r]);
  return out;
}

// ---- per-vertex distance -------------------------------------------------------------------------------

DistanceStats distance_stats(std::vector<double> d) {
  DistanceStats s;
  s.count = d.size();
  if (d.empty()) {
    s.mean = s.p95 = s.max = kNaN;
    return s;
  }
  s.mean = std::accumulate(d.begin(), d.end(), 0.0) / static_cast<double>(d.size());
  // Nearest rank: index ceil(0.95 n) - 1, found without sorting everything.
  const std::size_t rank = static_cast<std::size_t>(std::ceil(0.95 * static_cast<double>(d.size()))) - 1;
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(rank), d.end());
  s.p95 = d[rank];
  s.max = *std::max_element(d.begin() + static_cast<std::ptrdiff_t>(rank), d.end());
  return s;
}

std::vector<double> vertex_distances(const Positions& a, const Positions& b, const std::vector<char>& mask) {
  require_same_shape(a, b, mask.size(), "vertex_distances");
  std::vector<double> d;
  for (Eigen::Index i = 0; i < a.rows(); ++i)
    if (mask[static_cast<std::size_t>(i)]) d.push_back((a.row(i) - b.row(i)).norm());
  return d;
}

DistanceStats vertex_distance(const Positions& a, const Positions& b, const std::vector<char>& mask) {
  return distance_stats(vertex_distances(a, b, mask));
}

// ---- Hausdorff -----------------------------------------------------------------------------------------

struct TriangleSurface::Impl {
  std::vector<Triangle> triangles;  // the tree holds iterators into it: never resized after the build
  Tree tree;
};

TriangleSurface::TriangleSurface(const Positions& V, const Faces& F) : impl_(std::make_unique<Impl>()) {
  if (F.rows() == 0) throw std::invalid_argument("TriangleSurface: no triangles");
  impl_->triangles.reserve(static_cast<std::size_t>(F.rows()));
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    impl_->triangles.emplace_back(to_point(V, F(f, 0)), to_point(V, F(f, 1)), to_point(V, F(f, 2)));
  impl_->tree.insert(impl_->triangles.cbegin(), impl_->triangles.cend());
  impl_->tree.build();
  impl_->tree.accelerate_distance_queries();
}

TriangleSurface::TriangleSurface(TriangleSurface&&) noexcept = default;
TriangleSurface& TriangleSurface::operator=(TriangleSurface&&) noexcept = default;
TriangleSurface::~TriangleSurface() = default;

double TriangleSurface::distance(const Vec3& p) const {
  return std::sqrt(impl_->tree.squared_distance(Point(p.x(), p.y(), p.z())));
}

double TriangleSurface::max_distance_from(const Positions& V, const Faces& F) const {
  // Each used vertex once (a vertex sits in about six faces).
  std::vector<char> used(static_cast<std::size_t>(V.rows()), 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) used[static_cast<std::size_t>(F(f, c))] = 1;
  double worst2 = 0.0;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (used[static_cast<std::size_t>(i)])
      worst2 = std::max(worst2, impl_->tree.squared_distance(to_point(V, static_cast<int>(i))));
  return std::sqrt(worst2);
}

double hausdorff_distance(const Positions& Va, const Faces& Fa, const TriangleSurface& ta, const Positions& Vb,
                          const Faces& Fb, const TriangleSurface& tb) {
  return std::max(tb.max_distance_from(Va, Fa), ta.max_distance_from(Vb, Fb));
}

double hausdorff_distance(const Positions& Va, const Faces& Fa, const Positions& Vb, const Faces& Fb) {
  const TriangleSurface ta(Va, Fa), tb(Vb, Fb);
  return hausdorff_distance(Va, Fa, ta, Vb, Fb, tb);
}

// ---- seam jitter ---------------------------------------------------------------------------------------

double acceleration_difference(const Positions& k_prev, const Positions& k_now, const Positions& k_next,
                               const Positions& one_prev, const Positions& one_now, const Positions& one_next,
                               const std::vector<char>& mask) {
  for (const Positions* p : {&k_now, &k_next, &one_prev, &one_now, &one_next})
    require_same_shape(k_prev, *p, mask.size(), "acceleration_difference");
  double worst = 0.0;
  for (Eigen::Index i = 0; i < k_prev.rows(); ++i) {
    if (!mask[static_cast<std::size_t>(i)]) continue;
    const Eigen::RowVector3d ak = k_next.row(i) - 2.0 * k_now.row(i) + k_prev.row(i);
    const Eigen::RowVector3d a1 = one_next.row(i) - 2.0 * one_now.row(i) + one_prev.row(i);
    worst = std::max(worst, (ak - a1).norm());
  }
  return worst;
}

namespace {

// Frames either side of a seam's pair {s, s + 1} that its pop's background is taken from.
constexpr int kSeamPopWindow = 20;

// num / den for the seam measures (ratio, pop): +inf when den is 0 and num > 0, NaN when both are 0
// or either is NaN.
double seam_ratio(double num, double den) {
  if (std::isnan(num) || std::isnan(den)) return kNaN;
  if (den > 0.0) return num / den;
  return num > 0.0 ? std::numeric_limits<double>::infinity() : kNaN;
}

double median(std::vector<double> v) {
  if (v.empty()) return kNaN;
  const std::size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  if (v.size() % 2 == 1) return v[mid];
  const double upper = v[mid];
  const double lower = *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid));
  return 0.5 * (lower + upper);
}

}  // namespace

SeamJitter seam_jitter(const std::vector<double>& d, const std::vector<int>& seam_starts) {
  SeamJitter out;
  const int n = static_cast<int>(d.size());
  for (const int t : seam_starts) {
    if (t < 0 || t >= n)
      throw std::invalid_argument("seam_jitter: seam frame " + std::to_string(t) + " outside 0.." +
                                  std::to_string(n - 1));
    out.seams.push_back(t);
    if (t + 1 < n) out.seams.push_back(t + 1);
  }
  std::sort(out.seams.begin(), out.seams.end());
  out.seams.erase(std::unique(out.seams.begin(), out.seams.end()), out.seams.end());

  out.max_seam_d = kNaN;
  for (const int t : out.seams) {
    const double v = d[static_cast<std::size_t>(t)];
    out.seam_d.push_back(v);
    if (!std::isnan(v) && !(v <= out.max_seam_d)) out.max_seam_d = v;  // first defined value, then the max
  }
  // Frames up to the first seam come from the first subset, which is the K = 1 run's own task: d is
  // 0 there by construction and says nothing, so the background is taken after the first seam.
  std::vector<double> other;
  const int first = out.seams.empty() ? n : out.seams.front();
  for (int t = first + 1; t < n; ++t)
    if (!std::isnan(d[static_cast<std::size_t>(t)]) && !std::binary_search(out.seams.begin(), out.seams.end(), t))
      other.push_back(d[static_cast<std::size_t>(t)]);
  out.median_other = median(std::move(other));

  out.ratio = seam_ratio(out.max_seam_d, out.median_other);
  return out;
}

// ---- seam pop ------------------------------------------------------------------------------------------

double max_second_difference(const Positions& prev, const Positions& now, const Positions& next,
                             const std::vector<char>& mask) {
  for (const Positions* p : {&now, &next}) require_same_shape(prev, *p, mask.size(), "max_second_difference");
  double worst = 0.0;
  for (Eigen::Index i = 0; i < prev.rows(); ++i)
    if (mask[static_cast<std::size_t>(i)])
      worst = std::max(worst, (next.row(i) - 2.0 * now.row(i) + prev.row(i)).norm());
  return worst;
}

std::vector<SeamPop> seam_pops(const std::vector<double>& m, const std::vector<int>& seams) {
  const int n = static_cast<int>(m.size());
  std::vector<int> starts = seams;
  std::sort(starts.begin(), starts.end());
  starts.erase(std::unique(starts.begin(), starts.end()), starts.end());
  std::vector<char> seam_frame(m.size(), 0);  // t in {s', s' + 1} of some seam s': in no background
  for (const int s : starts) {
    if (s < 0 || s >= n - 1)
      throw std::invalid_argument("seam_pops: seam frame " + std::to_string(s) + " outside 0.." +
                                  std::to_string(n - 2));
    seam_frame[static_cast<std::size_t>(s)] = seam_frame[static_cast<std::size_t>(s) + 1] = 1;
  }
  const auto defined = [&m](int t) { return !std::isnan(m[static_cast<std::size_t>(t)]); };
  std::vector<SeamPop> out;
  for (const int s : starts) {
    SeamPop p;
    p.seam = s;
    p.peak = kNaN;
    for (const int t : {s, s + 1})
      if (defined(t) && !(m[static_cast<std::size_t>(t)] <= p.peak)) p.peak = m[static_cast<std::size_t>(t)];
    std::vector<double> background;
    for (int t = std::max(0, s - kSeamPopWindow); t <= std::min(n - 1, s + 1 + kSeamPopWindow); ++t)
      if (defined(t) && !seam_frame[static_cast<std::size_t>(t)]) background.push_back(m[static_cast<std::size_t>(t)]);
    p.background_frames = static_cast<int>(background.size());
    p.background = distance_stats(std::move(background)).p95;  // NaN for none
    p.pop = seam_ratio(p.peak, p.background);
    out.push_back(p);
  }
  return out;
}

}  // namespace pd
