#pragma once
// A deforming obstacle's vertex animation (docs/scene-format.md, "Animated obstacles"): one position
// per vertex per cache frame, read from an OBJ sequence or a PC2 point cache, and interpolated in
// time between cache frames.
//
// Time: cache frame k (0-based, in file order) is at  start + k * step  seconds, step = sample_rate /
// fps (PC2's sample rate is frames per sample; 1 for OBJ sequences). Before the first cache frame the
// first pose holds, after the last the last pose holds (the scene reader refuses a cache that ends
// before the shot does, so holding at the end only happens for a job run past the scene's frames).
//
// Interpolation between frames k and k + 1 at s in [0, 1):
//   linear: (1 - s) p_k + s p_{k+1}  (C0: the velocity jumps at cache frames);
//   smooth: the uniform Catmull-Rom spline through p_{k-1}, p_k, p_{k+1}, p_{k+2} (ends repeated), C1
//           and exact at every cache frame; it may overshoot a sharp turn by a few percent of a step.
// Both depend only on the cache and t, so every worker and level computes the same positions bit for
// bit.
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "geometry/mesh.h"

namespace pd {

enum class AnimationInterpolation { Linear, Smooth };

class VertexAnimation {
 public:
  // frames: the cache frames' positions (m), each (vertices, 3), at least one and all the same size.
  // start: time of frame 0 (s); step: seconds between frames (> 0). Throws std::invalid_argument on
  // an empty or ragged list or a step that is not positive and finite.
  VertexAnimation(std::vector<Positions> frames, double start, double step, AnimationInterpolation interpolation);

  int vertices() const { return static_cast<int>(frames_.front().rows()); }
  int frames() const { return static_cast<int>(frames_.size()); }
  double start() const { return start_; }
  double step() const { return step_; }
  double end() const { return start_ + step_ * (frames() - 1); }  // time of the last cache frame, s
  AnimationInterpolation interpolation() const { return interpolation_; }
  const Positions& frame(int k) const { return frames_[static_cast<std::size_t>(k)]; }

  // Where vertex v (0 <= v < vertices()) is at time t (s), m.
  Vec3 position(int v, double t) const;
  // Every vertex at time t, (vertices, 3), m.
  Positions positions(double t) const;

 private:
  // The cache frame k at or before t and the fraction s in [0, 1) toward k + 1 (k + 1 < frames()
  // whenever s > 0).
  void locate(double t, int& k, double& s) const;

  std::vector<Positions> frames_;
  double start_;
  double step_;
  AnimationInterpolation interpolation_;
};

}  // namespace pd
