#include "physics/contact/start_check.h"

// Piercing test (b): segment [p, q] against the closed triangle (t0, t1, t2), by clipping.
//
// With n the triangle's unit normal, the points of the triangle are those of its plane (signed
// distance n . (X - t0) = 0) inside its three edges (m_i . (X - t_i) >= 0, with m_i = n x (t_{i+1} -
// t_i) / |t_{i+1} - t_i| the in-plane unit normal of edge i pointing into the triangle). Along the
// segment X(t) = p + t (q - p), t in [0, 1], each of these is a linear function of t, so the set of t
// where all hold is an interval, found by clipping [0, 1] with one linear inequality at a time
// (Cyrus-Beck). The segment meets the triangle iff the interval is not empty. One routine handles
// every case - crossing the interior, touching at an endpoint, meeting an edge or a vertex, lying in
// the plane (coplanar overlap: the plane condition holds for every t, and the edge conditions decide)
// and being parallel to the plane - without case analysis.
//
// Tolerance. Every inequality is relaxed by tol = kRelativeTolerance * (L + C), metres, where L is
// the longest of the segment and the triangle's sides and C the largest absolute coordinate involved
// (the coordinates' rounding is relative to C): the plane becomes a slab of half-thickness tol and
// each edge moves out by tol. So the test answers "does the segment come within about tol of the
// triangle", and errs towards reporting: exact touching and coplanar overlap are always reported, a
// segment passing at a distance below ~tol (1e-12 m at metre scale) is reported too, and only
// configurations within that band can go either way under rounding. Reporting them is right for a
// start check: a gap of 1e-12 m is no usable start for a barrier either.
//
// Degenerate triangles (area below kDegenerateArea * L^2, a sliver or repeated vertices) have no
// reliable normal and are not tested here: a zero-area triangle has no interior to pierce, and
// anything meeting it meets one of its edges, which the edge-edge distances of (a) see.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include <Eigen/Geometry>

#include "physics/contact/distance.h"

namespace pd {

namespace {

constexpr double kRelativeTolerance = 1e-12;
constexpr double kDegenerateArea = 1e-14;  // |(t1 - t0) x (t2 - t0)| / L^2: twice the area, relative

bool segment_meets_triangle(const Vec3& p, const Vec3& q, const Vec3& t0, const Vec3& t1, const Vec3& t2) {
  const Vec3 t[3] = {t0, t1, t2};
  const Vec3 N = (t1 - t0).cross(t2 - t0);
  double L = (q - p).norm(), C = std::max(p.cwiseAbs().maxCoeff(), q.cwiseAbs().maxCoeff());
  for (int i = 0; i < 3; ++i) {
    L = std::max(L, (t[(i + 1) % 3] - t[i]).norm());
    C = std::max(C, t[i].cwiseAbs().maxCoeff());
  }
  const double area2 = N.norm();
  if (!(area2 > kDegenerateArea * L * L)) return false;
  const Vec3 n = N / area2;
  const double tol = kRelativeTolerance * (L + C);
  const Vec3 dir = q - p;

  // Keeps the t in [lo, hi] with f0 + t f1 >= -tol; returns false once the interval is empty.
  double lo = 0.0, hi = 1.0;
  auto clip = [&](double f0, double f1) {
    if (f1 > 0.0)
      lo = std::max(lo, (-tol - f0) / f1);
    else if (f1 < 0.0)
      hi = std::min(hi, (-tol - f0) / f1);
    else if (f0 < -tol)
      hi = -1.0;
    return lo <= hi;
  };
  // The slab around the plane: -tol <= n . (X - t0) <= tol.
  const double h0 = n.dot(p - t0), h1 = n.dot(dir);
  if (!clip(h0, h1) || !clip(-h0, -h1)) return false;
  // Inside each edge (the triangle is counter-clockwise about n, so n x edge points inwards).
  for (int i = 0; i < 3; ++i) {
    const Vec3 e = t[(i + 1) % 3] - t[i];
    const Vec3 m = n.cross(e) / e.norm();
    if (!clip(m.dot(p - t[i]), m.dot(dir))) return false;
  }
  return true;
}

Vec<12> gather(const Positions& V, int a, int b, int c, int d) {
  Vec<12> x;
  x << V.row(a).transpose(), V.row(b).transpose(), V.row(c).transpose(), V.row(d).transpose();
  return x;
}

// Index of every entry among the earlier entries with the same object id (object-local numbering).
std::vector<int> local_indices(const std::vector<int>& object_of, std::size_t objects) {
  std::vector<int> next(objects, 0), local(object_of.size());
  for (std::size_t i = 0; i < object_of.size(); ++i) local[i] = next[static_cast<std::size_t>(object_of[i])]++;
  return local;
}

}  // namespace

std::vector<StartViolation> find_start_violations(const ContactPrimitives& prims, const Positions& V,
                                                  double offset, int max_reports, int* total_found) {
  if (!(offset >= 0.0) || !std::isfinite(offset))
    throw std::invalid_argument("start check: the contact offset must be finite and >= 0");
  if (max_reports < 0) throw std::invalid_argument("start check: max_reports must be >= 0");
  // The broad phase promises every pair within r up to rounding of the grown boxes; the margin
  // (1e-9 of the scene's coordinate scale, m) absorbs that rounding at the cost of a few extra
  // distance evaluations. It also validates the input (and throws) before anything reads it.
  const double scale = V.size() > 0 ? V.cwiseAbs().maxCoeff() : 0.0;
  const double margin = 1e-9 * (1.0 + (std::isfinite(scale) ? scale : 0.0));
  const CandidatePairs pairs = find_candidates(prims, V, offset + margin);

  const std::vector<int>& vobj = prims.vertex_object;
  const std::vector<int> vlocal = local_indices(vobj, prims.object_self_contact.size());
  std::vector<int> fobj(static_cast<std::size_t>(prims.faces.rows()));
  for (Eigen::Index f = 0; f < prims.faces.rows(); ++f) fobj[f] = vobj[prims.faces(f, 0)];
  const std::vector<int> flocal = local_indices(fobj, prims.object_self_contact.size());
  auto vertex_local = [&](int v) { return std::array<int, 2>{{vlocal[v], -1}}; };
  auto edge_local = [&](int e) {
    return std::array<int, 2>{{vlocal[prims.edges[e][0]], vlocal[prims.edges[e][1]]}};
  };
  auto face_local = [&](int f) { return std::array<int, 2>{{flocal[f], -1}}; };

  std::vector<StartViolation> out;
  int total = 0;
  const bool count_all = total_found != nullptr;
  // Records one violation; returns false once the search may stop.
  auto report = [&](StartViolation::Kind kind, int a, int b, int object_a, int object_b, double distance,
                    std::array<int, 2> a_local, std::array<int, 2> b_local) {
    ++total;
    if (static_cast<int>(out.size()) < max_reports) {
      StartViolation s;
      s.kind = kind;
      s.a = a;
      s.b = b;
      s.object_a = object_a;
      s.object_b = object_b;
      s.distance = distance;
      s.offset = offset;
      s.a_local = a_local;
      s.b_local = b_local;
      out.push_back(s);
    }
    return count_all || static_cast<int>(out.size()) < max_reports;
  };
  auto finish = [&]() {
    if (total_found) *total_found = total;
    return out;
  };
  if (!count_all && max_reports == 0) return finish();

  // (a) Distances, with the barrier's own criterion d^2 <= offset^2 (barrier.h: s <= 0).
  const double limit2 = offset * offset;
  for (const auto& [v, f] : pairs.point_triangle) {
    const double d2 = point_triangle_squared_distance(
        gather(V, v, prims.faces(f, 0), prims.faces(f, 1), prims.faces(f, 2)));
    if (d2 <= limit2 &&
        !report(StartViolation::Kind::PointTriangle, v, f, vobj[v], fobj[f], std::sqrt(d2), vertex_local(v),
                face_local(f)))
      return finish();
  }
  for (const auto& [a, b] : pairs.edge_edge) {
    const auto &ea = prims.edges[a], &eb = prims.edges[b];
    const double d2 = edge_edge_squared_distance(gather(V, ea[0], ea[1], eb[0], eb[1]));
    if (d2 <= limit2 &&
        !report(StartViolation::Kind::EdgeEdge, a, b, vobj[ea[0]], vobj[eb[0]], std::sqrt(d2), edge_local(a),
                edge_local(b)))
      return finish();
  }

  // (b) Piercing. Only pairs whose boxes touch can meet; the margin covers the test's tolerance.
  for (const auto& [e, f] : find_edge_face_candidates(prims, V, margin)) {
    const auto& ev = prims.edges[e];
    if (segment_meets_triangle(V.row(ev[0]).transpose(), V.row(ev[1]).transpose(),
                               V.row(prims.faces(f, 0)).transpose(), V.row(prims.faces(f, 1)).transpose(),
                               V.row(prims.faces(f, 2)).transpose()) &&
        !report(StartViolation::Kind::EdgeTriangle, e, f, vobj[ev[0]], fobj[f], 0.0, edge_local(e), face_local(f)))
      return finish();
  }
  return finish();
}

std::string describe(const StartViolation& s, const std::vector<std::string>& object_names) {
  auto object = [&](int o) {
    const std::string name =
        o >= 0 && o < static_cast<int>(object_names.size()) ? object_names[o] : "#" + std::to_string(o);
    return "object '" + name + "'";
  };
  auto edge = [](const std::array<int, 2>& v) {
    return "edge (" + std::to_string(v[0]) + ", " + std::to_string(v[1]) + ")";
  };
  auto mm = [](double metres) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g mm", 1e3 * metres);
    return std::string(buf);
  };
  const std::string a = object(s.object_a), b = object(s.object_b);
  switch (s.kind) {
    case StartViolation::Kind::PointTriangle:
      return a + " vertex " + std::to_string(s.a_local[0]) + " is " + mm(s.distance) + " from " + b + " face " +
             std::to_string(s.b_local[0]) + " (contact offset " + mm(s.offset) + ")";
    case StartViolation::Kind::EdgeEdge:
      return a + " " + edge(s.a_local) + " is " + mm(s.distance) + " from " + b + " " + edge(s.b_local) +
             " (contact offset " + mm(s.offset) + ")";
    case StartViolation::Kind::EdgeTriangle:
      return a + " " + edge(s.a_local) + " passes through " + b + " face " + std::to_string(s.b_local[0]);
  }
  return "unknown start violation";
}

}  // namespace pd
