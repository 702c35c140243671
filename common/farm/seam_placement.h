#pragma once
// Where a refinement level's time subsets meet (the seams), chosen from the stored preview.
//
// A later subset (s, b] starts vertically at frame s: it upsamples the level below's frame s, takes
// its velocity from frames s - 1 and s, and a viewer sees the seam, if at all, in frames s and s + 1.
// A vertical start in an impact costs the most (cube-trampoline's seam on the impact: 73-98 s against
// 6-16 s for the first subsets, docs/farm.md) and differs most from the single run. The preview
// predicts the shot's motion, so once it is stored the seams can be put where it is calm.
//
// The rule, for K subsets of frames 0..N (K clamped to N; K - 1 seams):
//   even split   b_k = round(k N / K), k = 1..K-1, as farm/task_graph.h cuts without a preview;
//   window       seam k is chosen in [b_k - w, b_k + w], w = floor(N / (4 K)) (a quarter of a subset
//                either way), clipped to [2, N - 2] and to at least 2 frames after seam k - 1;
//   activity     a(s) = max of motion(t) for t in [s - 1, s + 2], over the median of motion over the
//                shot (motion: the preview's per-frame largest per-vertex second difference, m per
//                frame^2; a median of 0 counts as 1e-300, so that any motion is large against it);
//   contact      c(s) = 1 when the preview's active contact pairs, over frames s - 2 .. s + 2, go
//                from none to some (or back), or their largest count is more than twice the smallest
//                (a contact starting or spreading: an impact); 0 otherwise or without contact data;
//   acceptable   a(s) <= 1.5 and c(s) = 0: no more motion than the shot's ordinary, no impact;
//   choice       the acceptable frame nearest the even split (the earlier of two); when none is,
//                the lowest score a(s) + 2 c(s) + 0.25 |s - b_k| / max(w, 1).
// Nearest, not calmest: a seam moved farther than it must unbalances the subsets, and the wall time
// follows the longest (the flag's 600 frames, K = 2 on two workers: pd plan predicts 39.2 s with the
// calmest frame, 364, against 32.7 s measured at the even split 300).
// Deterministic: the same profile gives the same seams.
#include <functional>
#include <string>
#include <vector>

#include "geometry/mesh.h"

namespace pd::farm {

// The stored preview (level 0), one entry per frame t = 0..N; NaN where not defined (motion at 0
// and N, a statistic not recorded).
struct PreviewProfile {
  std::vector<double> motion;         // largest per-vertex |x(t+1) - 2 x(t) + x(t-1)|, m per frame^2
  std::vector<double> contact_pairs;  // the frame statistic contact_active_pairs
};

// The profile of a stored preview of frames 0..N: frame(t) its positions (all vertices, m),
// contact_pairs(t) its contact_active_pairs statistic (NaN where not recorded). Asks for each frame
// once, in increasing t, frame(t) before contact_pairs(t).
PreviewProfile preview_profile(int frames, const std::function<Positions(int)>& frame,
                               const std::function<double(int)>& contact_pairs);

struct PlacedSeam {
  int frame = 0;   // s: the later subset is (s, b]
  int even = 0;    // b_k, the even split it replaces
  double activity = 0.0;  // a(s)
  bool contact_change = false;  // c(s)
  std::string reason;  // one line: where, and why there
};

// The K - 1 seams of K subsets. Throws std::invalid_argument for subsets < 1, a profile shorter than
// 2 frames, or contact_pairs of another length than motion (empty is allowed: no contact data).
std::vector<PlacedSeam> place_seams(const PreviewProfile& preview, int subsets);

}  // namespace pd::farm
