#include "scene/vertex_animation.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace pd {

VertexAnimation::VertexAnimation(std::vector<Positions> frames, double start, double step,
                                 AnimationInterpolation interpolation)
    : frames_(std::move(frames)), start_(start), step_(step), interpolation_(interpolation) {
  if (frames_.empty()) throw std::invalid_argument("VertexAnimation: no frames");
  for (const Positions& f : frames_)
    if (f.rows() != frames_.front().rows() || f.cols() != 3)
      throw std::invalid_argument("VertexAnimation: frames of different sizes");
  if (!(step_ > 0.0) || !std::isfinite(step_) || !std::isfinite(start_))
    throw std::invalid_argument("VertexAnimation: the frame step must be positive and finite");
}

void VertexAnimation::locate(double t, int& k, double& s) const {
  const double u = (t - start_) / step_;  // in cache frames
  if (!(u > 0.0)) {  // before the first frame (or NaN): the first pose
    k = 0, s = 0.0;
    return;
  }
  const double last = frames() - 1;
  if (u >= last) {
    k = frames() - 1, s = 0.0;
    return;
  }
  const double whole = std::floor(u);
  k = static_cast<int>(whole);
  s = u - whole;
}

Vec3 VertexAnimation::position(int v, double t) const {
  int k = 0;
  double s = 0.0;
  locate(t, k, s);
  const Vec3 p1 = frames_[static_cast<std::size_t>(k)].row(v).transpose();
  if (s == 0.0) return p1;
  const Vec3 p2 = frames_[static_cast<std::size_t>(k) + 1].row(v).transpose();
  if (interpolation_ == AnimationInterpolation::Linear) return (1.0 - s) * p1 + s * p2;
  // Uniform Catmull-Rom (tangents (p_{k+1} - p_{k-1}) / 2), ends repeated.
  const Vec3 p0 = frames_[static_cast<std::size_t>(std::max(k - 1, 0))].row(v).transpose();
  const Vec3 p3 = frames_[static_cast<std::size_t>(std::min(k + 2, frames() - 1))].row(v).transpose();
  const double s2 = s * s, s3 = s2 * s;
  return 0.5 * (2.0 * p1 + (p2 - p0) * s + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * s2 +
                (3.0 * (p1 - p2) + p3 - p0) * s3);
}

Positions VertexAnimation::positions(double t) const {
  Positions out(vertices(), 3);
  for (int v = 0; v < vertices(); ++v) out.row(v) = position(v, t).transpose();
  return out;
}

}  // namespace pd
