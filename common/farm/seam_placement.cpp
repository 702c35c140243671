#include "farm/seam_placement.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>

namespace pd::farm {
namespace {

// Weights of the score (seam_placement.h): a contact change counts as twice the shot's median motion;
// a quarter of the window's width from the even split as a quarter of it.
constexpr double kContactWeight = 2.0;
constexpr double kDistanceWeight = 0.25;
// A frame whose activity is at most this (in units of the shot's median motion), without a contact
// change, is acceptable as it is.
constexpr double kAcceptableActivity = 1.5;

double median_of_defined(const std::vector<double>& v) {
  std::vector<double> d;
  for (double x : v)
    if (std::isfinite(x)) d.push_back(x);
  if (d.empty()) return 0.0;
  std::sort(d.begin(), d.end());
  const std::size_t mid = d.size() / 2;
  return d.size() % 2 ? d[mid] : 0.5 * (d[mid - 1] + d[mid]);
}

// max over t in [from, to] of v(t) where defined (0 when none is).
double max_over(const std::vector<double>& v, int from, int to) {
  double m = 0.0;
  for (int t = std::max(from, 0); t <= std::min(to, static_cast<int>(v.size()) - 1); ++t)
    if (std::isfinite(v[static_cast<std::size_t>(t)])) m = std::max(m, v[static_cast<std::size_t>(t)]);
  return m;
}

bool contact_changes(const std::vector<double>& pairs, int s) {
  double lo = INFINITY, hi = -INFINITY;
  for (int t = std::max(s - 2, 0); t <= std::min(s + 2, static_cast<int>(pairs.size()) - 1); ++t) {
    const double p = pairs[static_cast<std::size_t>(t)];
    if (!std::isfinite(p)) continue;
    lo = std::min(lo, p);
    hi = std::max(hi, p);
  }
  if (!(hi >= lo)) return false;  // no data in the window
  return (lo == 0.0 && hi > 0.0) || hi > 2.0 * lo;
}

std::string describe(const PlacedSeam& s, double even_activity, bool even_contact) {
  char text[240];
  const char* contact = s.contact_change ? "a contact starts, ends or spreads" : "contact steady";
  if (s.frame == s.even)
    std::snprintf(text, sizeof text, "frame %d, the even split: motion %.2fx the shot's median, %s", s.frame,
                  s.activity, contact);
  else
    std::snprintf(text, sizeof text, "frame %d, moved from the even split %d (motion %.2fx the median%s): motion %.2fx, %s",
                  s.frame, s.even, even_activity, even_contact ? ", a contact change" : "", s.activity, contact);
  return text;
}

}  // namespace

PreviewProfile preview_profile(int frames, const std::function<Positions(int)>& frame,
                               const std::function<double(int)>& contact_pairs) {
  PreviewProfile p;
  p.motion.assign(static_cast<std::size_t>(frames + 1), NAN);
  p.contact_pairs.resize(p.motion.size());
  Positions x[3];  // frames t - 2, t - 1, t
  for (int t = 0; t <= frames; ++t) {
    x[0] = std::move(x[1]), x[1] = std::move(x[2]), x[2] = frame(t);
    p.contact_pairs[static_cast<std::size_t>(t)] = contact_pairs(t);
    if (t < 2) continue;
    if (x[0].rows() != x[2].rows() || x[1].rows() != x[2].rows())
      throw std::invalid_argument("preview_profile: frames " + std::to_string(t - 2) + ".." + std::to_string(t) +
                                  " have different vertex counts");
    p.motion[static_cast<std::size_t>(t - 1)] = (x[2] - 2.0 * x[1] + x[0]).rowwise().norm().maxCoeff();
  }
  return p;
}

std::vector<PlacedSeam> place_seams(const PreviewProfile& preview, int subsets) {
  if (subsets < 1) throw std::invalid_argument("place_seams: subsets must be >= 1, got " + std::to_string(subsets));
  const int n = static_cast<int>(preview.motion.size()) - 1;  // N
  if (n < 1) throw std::invalid_argument("place_seams: the preview profile needs frames 0 and 1 at least");
  if (!preview.contact_pairs.empty() && preview.contact_pairs.size() != preview.motion.size())
    throw std::invalid_argument("place_seams: contact_pairs needs one entry per frame, as motion");
  const int K = std::min(subsets, n);
  const int64_t N = n;
  const int w = static_cast<int>(N / (4 * static_cast<int64_t>(K)));
  double median = median_of_defined(preview.motion);
  if (!(median > 0.0)) median = 1e-300;
  const auto activity = [&](int s) { return max_over(preview.motion, s - 1, s + 2) / median; };
  const auto contact = [&](int s) { return !preview.contact_pairs.empty() && contact_changes(preview.contact_pairs, s); };

  std::vector<PlacedSeam> out;
  int previous = 0;
  for (int k = 1; k < K; ++k) {
    const int even = static_cast<int>((k * N + K / 2) / K);
    const int lo = std::max({even - w, 2, previous + 2}), hi = std::min(even + w, n - 2);
    PlacedSeam best;
    best.frame = -1;
    double best_score = INFINITY;
    bool found_acceptable = false;
    for (int s = lo; s <= hi; ++s) {
      const double a = activity(s);
      const bool c = contact(s);
      const bool acceptable = a <= kAcceptableActivity && !c;
      const double score = a + kContactWeight * c + kDistanceWeight * std::abs(s - even) / std::max(w, 1);
      const int distance = std::abs(s - even), best_distance = std::abs(best.frame - even);
      // Acceptable frames by distance to the even split (earlier first); others, only while none is
      // acceptable, by score.
      const bool better = acceptable ? !found_acceptable || distance < best_distance
                                     : !found_acceptable && (score < best_score ||
                                                             (score == best_score && distance < best_distance));
      if (!better) continue;
      found_acceptable = found_acceptable || acceptable;
      best_score = score;
      best.frame = s;
      best.activity = a;
      best.contact_change = c;
    }
    if (best.frame < 0) {  // no frame in the window (N too small for the clips): the even split
      best.frame = std::max(even, previous + 1);
      best.activity = activity(best.frame);
      best.contact_change = contact(best.frame);
    }
    best.even = even;
    best.reason = describe(best, activity(even), contact(even));
    previous = best.frame;
    out.push_back(best);
  }
  return out;
}

}  // namespace pd::farm
