#include "physics/wind.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace pd {

namespace {
constexpr double kPi = 3.14159265358979323846;
Vec3 vertex(const Eigen::VectorXd& x, int i) { return x.segment<3>(3 * i); }
}  // namespace

WindTerm::WindTerm(const Faces& faces, const Wind& params)
    : faces_(faces),
      params_(params),
      lagged_(static_cast<size_t>(faces.rows())),
      min_dofs_(faces.size() == 0 ? 0 : 3 * (static_cast<Eigen::Index>(faces.maxCoeff()) + 1)) {}

Vec3 WindTerm::air_velocity(double t) const {
  const double gust = 1.0 + params_.gust_amplitude * std::sin(2.0 * kPi * params_.gust_frequency * t);
  return params_.air_velocity * gust;
}

// Checked in every build, not only where NDEBUG is off: once per step, one comparison per evaluation.
void WindTerm::begin_step(const StepStart& step) {
  if (!(step.h > 0.0) || !step.x || !step.v)
    throw std::invalid_argument("WindTerm::begin_step: needs a positive time step and start positions and velocities");
  if (step.x->size() < min_dofs_ || step.v->size() != step.x->size())
    throw std::invalid_argument("WindTerm::begin_step: positions have " + std::to_string(step.x->size()) +
                                " dofs and velocities " + std::to_string(step.v->size()) + "; the faces need " +
                                std::to_string(min_dofs_));
  h_ = step.h;
  const Vec3 w = air_velocity(step.time_end);
  const Eigen::VectorXd& xs = *step.x;
  const Eigen::VectorXd& vs = *step.v;
  for (Eigen::Index f = 0; f < faces_.rows(); ++f) {
    const int i0 = faces_(f, 0), i1 = faces_(f, 1), i2 = faces_(f, 2);
    const Vec3 p0 = vertex(xs, i0), p1 = vertex(xs, i1), p2 = vertex(xs, i2);
    const Vec3 cross = (p1 - p0).cross(p2 - p0);
    const double twice_area = cross.norm();
    Lagged& L = lagged_[f];
    if (!(twice_area > 0.0)) {  // collapsed triangle: no normal, no drag this step
      L = Lagged();
      continue;
    }
    L.n = cross / twice_area;
    const Vec3 centroid = (p0 + p1 + p2) / 3.0;
    const Vec3 v_c = (vertex(vs, i0) + vertex(vs, i1) + vertex(vs, i2)) / 3.0;
    const double u_start = L.n.dot(v_c - w);
    L.c = 0.5 * params_.air_density * params_.drag_coefficient * (0.5 * twice_area) *
          std::max(std::abs(u_start), kMinRelativeSpeed);
    L.offset = -L.n.dot(centroid) / h_ - L.n.dot(w);
  }
}

double WindTerm::normal_speed(const Eigen::VectorXd& x, int f) const {
  const Vec3 sum = vertex(x, faces_(f, 0)) + vertex(x, faces_(f, 1)) + vertex(x, faces_(f, 2));
  return lagged_[f].n.dot(sum) / (3.0 * h_) + lagged_[f].offset;
}

void WindTerm::check_state(const Eigen::VectorXd& x) const {
  if (!(h_ > 0.0)) throw std::logic_error("WindTerm: evaluated before begin_step");
  if (x.size() < min_dofs_)
    throw std::invalid_argument("WindTerm: x has " + std::to_string(x.size()) + " dofs; the faces need " +
                                std::to_string(min_dofs_));
}

std::vector<std::pair<std::string, double>> WindTerm::named_values(const Eigen::VectorXd& x) const {
  return {{name(), h_ > 0.0 ? value(x) : 0.0}};
}

double WindTerm::value(const Eigen::VectorXd& x) const {
  check_state(x);
  double D = 0.0;
  for (int f = 0; f < static_cast<int>(faces_.rows()); ++f) {
    const double u = normal_speed(x, f);
    D += 0.5 * lagged_[f].c * u * u;
  }
  return h_ * D;
}

// dD/dx_a = h c u (du/dx_a) = h c u n / (3 h) = c u n / 3: minus the drag force on each vertex.
void WindTerm::add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const {
  check_state(x);
  for (int f = 0; f < static_cast<int>(faces_.rows()); ++f) {
    const Vec3 g = (lagged_[f].c * normal_speed(x, f) / 3.0) * lagged_[f].n;
    for (int a = 0; a < 3; ++a) grad.segment<3>(3 * faces_(f, a)) += g;
  }
}

// d2D/dx_a dx_b = c / (9 h) n n^T for every pair (a, b): rank one and PSD. It still goes through
// project_hessian so that every term honours the caller's choice the same way.
void WindTerm::add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                           HessianAssembly& hessian) const {
  check_state(x);
  for (int f = 0; f < static_cast<int>(faces_.rows()); ++f) {
    const Mat3 block = (lagged_[f].c / (9.0 * h_)) * (lagged_[f].n * lagged_[f].n.transpose());
    Mat<9> H;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) H.block<3, 3>(3 * a, 3 * b) = block;
    hessian.add<3>({faces_(f, 0), faces_(f, 1), faces_(f, 2)}, project_hessian<9>(H, projection));
  }
}

}  // namespace pd
