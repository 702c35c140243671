#pragma once
// Strain limiting as an energy term: a log barrier on the principal stretches of every triangle, in
// the form of codimensional IPC (C-IPC; Li, Kaufman & Jiang 2021, "Codimensional Incremental
// Potential Contact", ACM TOG 40(4), section on strain limiting). The form below is the one C-IPC's
// reference implementation evaluates (github.com/ipc-sim/Codim-IPC, Library/FEM/Shell/INEXT.h,
// f_sl_u and its derivatives); this file is an independent implementation with its own derivation
// (in the .cpp).
//
// Conventions. Per triangle, rest vertices X0, X1, X2 and deformed vertices x0, x1, x2 (metres);
// x = (x0, x1, x2) stacked as on every element signature here: x[3*v + k] = coordinate k of local
// vertex v (9 entries).
//   rest frame: orthonormal axes (t1, t2) of the rest triangle's plane, t1 along X1 - X0
//   Dm = [t1 t2]^T [X1 - X0, X2 - X0]         (2x2, m; rest edges in the rest frame)
//   B  = Dm^{-1}                              (2x2, 1/m)
//   F  = [x1 - x0, x2 - x0] B                 (3x2, dimensionless deformation gradient of the
//                                              membrane; column j = image of rest axis t_j)
//   C  = F^T F,  eigenvalues lambda1 >= lambda2 >= 0,  principal stretches sigma_i = sqrt(lambda_i)
// sigma_max = sigma_1 is the largest stretch of any material direction in the triangle (1 = rest).
//
// Energy (J), with s = limit (> 1), g_hat = activation (in (0, limit - 1]), s_hat = s - g_hat:
//   E_t  = kappa_s * A_t * sum_{i=1,2} beta((s - sigma_i) / g_hat)
//   beta(t) = -(t - 1)^2 ln t   for 0 < t < 1      (sigma_i in (s_hat, s): active)
//   beta(t) = 0                 for t >= 1         (sigma_i <= s_hat: inactive)
//   beta(t) = +infinity         for t <= 0         (sigma_i >= s: inadmissible)
// A_t is the rest area (m^2) and kappa_s a stiffness in J/m^2 = Pa*m (energy per rest area); beta
// is dimensionless. beta is IPC's clamped log barrier b(g, g_hat) = -(g - g_hat)^2 ln(g / g_hat)
// divided by g_hat^2, as C-IPC's f_sl_u divides by (s - s_hat)^2, so that kappa_s keeps its meaning
// when the activation band changes. beta, beta' and beta'' vanish at t = 1: the term is C^2.
//
// Relation to C-IPC: it sums f_sl_u over both singular values above s_hat with weight
// h^2 * vol * kappa_s, in a potential that is h^2 times an energy; here the potential is in joules
// and the weight is the rest area, so our kappa_s is C-IPC's kappa_s times the element measure per
// unit area (its thickness if C-IPC's vol is area * thickness). C-IPC's default s_hat = 1 (the whole
// stretch range is the activation band) corresponds to activation = limit - 1, the widest band
// allowed (rest and compressed triangles stay inactive: the barrier acts only for sigma > s_hat).
// Our default band is narrower (see StrainLimitSettings::from), so that moderate stretches feel
// only the membrane; the price is that Newton's model sees the limit only in its last tenth, and a
// large step into stretch is then cut short by max_step again and again (a scene can widen the
// band: scene key strain_limit.barrier_start; docs/performance.md, "The strain limit's band").
//
// Why both singular values (as C-IPC) and not sigma_max alone: the admissible set is the same
// (sigma_2 <= sigma_1), but sigma_max is not differentiable where sigma_1 == sigma_2 (rest state,
// uniform stretch), so a barrier on sigma_max alone has a kink exactly where an equibiaxially
// pulled sheet sits. With psi(lambda) = beta((s - sqrt(lambda)) / g_hat),
// E_t = kappa_s A_t sum_i psi(lambda_i), a spectral function of the symmetric 2x2 C: it is as
// smooth as psi (C^2 here) for every C, repeated eigenvalues included. Its Hessian needs the
// divided difference (psi'(lambda1) - psi'(lambda2)) / (lambda1 - lambda2), whose limit at
// lambda1 == lambda2 is psi''; the .cpp evaluates it without cancellation (Gauss quadrature of
// psi'' over [lambda2, lambda1] when the eigenvalues are close). A triangle stretched uniformly to
// 1.095 under limit 1.1 therefore has finite, exact, finite-difference-checked derivatives.
//
// Convexity: phi(sigma) = beta((s - sigma) / g_hat) is convex and nondecreasing in sigma (0 below the
// band), so sum_i phi(sigma_i(F)) is a convex function of F (an absolutely symmetric convex function
// of the singular values; Lewis 1995, "The convex analysis of unitarily invariant matrix
// functions"), and F is linear in x: each element energy is convex in x on the admissible set, and
// its exact Hessian is PSD up to round-off. project_hessian is still applied as for every term; it
// leaves these blocks unchanged except for round-off-level negative eigenvalues.
//
// Units: energy J; gradient N; Hessian N/m; kappa_s J/m^2; limit and activation dimensionless
// (stretch ratios).
//
// Degenerate deformed triangles (zero area) need no special case: C keeps a zero eigenvalue, whose
// barrier is inactive. Only a stretch at or over the limit is inadmissible: value() returns
// +infinity there, and element gradient / Hessian return NaN entries (the solver never asks for
// them: max_step keeps every trial below the limit).
#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "geometry/mesh.h"
#include "physics/energy_term.h"

namespace pd {

struct StrainLimitSettings {
  double limit = 1.1;       // s: largest admissible principal stretch (> 1; 1.1 = 10 % stretch)
  double activation = 0.0;  // g_hat: width of the band below the limit where the barrier acts, in
                            // (0, limit - 1] (stretch ratio; the barrier starts at limit -
                            // activation). 0 (the default) = default_strain_limit_activation(limit).
  double stiffness = 0.0;   // kappa_s, J/m^2 (energy per rest area), >= 0; see
                            // default_strain_limit_stiffness. 0 leaves only the hard limit.

  // Suggested settings for a membrane of Young's modulus E (Pa) and thickness h (m): the two
  // defaults below. Throws std::invalid_argument for limit <= 1, E < 0 or h <= 0.
  static StrainLimitSettings from(double limit, double youngs, double thickness);
};

// Default activation band: 0.1 * (limit - 1), the last tenth of the allowed stretch (1.09 .. 1.1 for
// limit 1.1), so that moderate stretches feel only the membrane. A fraction of the allowed stretch,
// not of the limit, so that it stays inside (0, limit - 1) for tight limits (1.01).
double default_strain_limit_activation(double limit);

// Default stiffness kappa_s = E * h (J/m^2), Young's modulus E in Pa, thickness h in m: the
// membrane's own energy-per-area scale (its plane-stress stiffness is E h / (1 - nu^2) N/m), so the
// barrier and the membrane it limits are commensurate.
double default_strain_limit_stiffness(double youngs, double thickness);

// Throws std::invalid_argument unless limit > 1, 0 < activation <= limit - 1 and stiffness >= 0
// (all finite). Pass resolved settings (activation 0 is rejected here).
void check_strain_limit_settings(const StrainLimitSettings& settings);

// settings with activation 0 replaced by default_strain_limit_activation(limit), then checked
// (std::invalid_argument as check_strain_limit_settings).
StrainLimitSettings resolve_strain_limit_settings(const StrainLimitSettings& settings);

// Fraction of the distance to the limit a step may use: max_step returns this fraction of the step
// at which a triangle would reach the limit (see strain_limit_step).
inline constexpr double kStrainLimitStepSafety = 0.9;

// Rest data of one triangle, precomputed once.
struct StrainLimitRest {
  Eigen::Matrix2d B;  // Dm^{-1}, 1/m: F = [x1 - x0, x2 - x0] B
  double area;        // rest area, m^2
};

// Rest data from rest vertices (m). Throws std::invalid_argument for a zero-area (or non-finite)
// rest triangle.
StrainLimitRest strain_limit_rest(const Vec3& X0, const Vec3& X1, const Vec3& X2);

// F (3x2, dimensionless) of a triangle x = (x0, x1, x2).
Eigen::Matrix<double, 3, 2> strain_limit_deformation_gradient(const Vec<9>& x, const StrainLimitRest& rest);

// (sigma_max, sigma_min): the singular values of F, largest first (closed form via C = F^T F).
Eigen::Vector2d principal_stretches(const Vec<9>& x, const StrainLimitRest& rest);

// Element energy (J); +infinity if sigma_max >= limit. settings are not re-validated here.
double strain_limit_energy(const Vec<9>& x, const StrainLimitRest& rest, const StrainLimitSettings& settings);
// d energy / d x (N), ordered as x. Zero below the band; NaN entries if sigma_max >= limit.
Vec<9> strain_limit_gradient(const Vec<9>& x, const StrainLimitRest& rest, const StrainLimitSettings& settings);
// d^2 energy / d x^2 (N/m), exact (not projected; PSD up to round-off, see Convexity). Zero below
// the band; NaN entries if sigma_max >= limit.
Mat<9> strain_limit_hessian(const Vec<9>& x, const StrainLimitRest& rest, const StrainLimitSettings& settings);

// Largest admissible step fraction for one triangle moving from x along dx (both 9-vectors, m):
//   0     if sigma_max(x) >= limit already (the start is inadmissible),
//   1     if sigma_max(x + dx) < limit,
//   kStrainLimitStepSafety * a otherwise, a = the largest alpha found by bisection with
//         sigma_max(x + alpha dx) < limit (a is within a relative 1e-6 below the crossing).
// Why this is safe: sigma_max(F) is the spectral norm and F(alpha) is affine in alpha, so
// sigma_max(x + alpha dx) is convex in alpha. Starting below the limit, the admissible alphas form
// one interval [0, alpha*), bisection cannot be fooled by a second crossing, and every alpha in
// [0, 1] is admissible when alpha = 1 is. Convexity also bounds the stretch after the scaled step:
// sigma_max(0.9 a) <= 0.1 sigma_max(x) + 0.9 limit, i.e. the triangle keeps at least a tenth of its
// current gap to the limit, so the line search never starts at the barrier's wall.
double strain_limit_step(const Vec<9>& x, const Vec<9>& dx, const StrainLimitRest& rest, double limit);

// The strain-limit barrier summed over a set of triangles.
class StrainLimitTerm : public EnergyTerm {
 public:
  // faces: global vertex indices (into the stacked x); rest: global rest positions, one row per
  // vertex (m; rows not used by `faces` are ignored). settings are resolved
  // (resolve_strain_limit_settings: activation 0 = default band). Throws std::invalid_argument for
  // bad settings, an index outside `rest` or a zero-area rest triangle.
  StrainLimitTerm(const Faces& faces, const Positions& rest, const StrainLimitSettings& settings);

  std::string name() const override { return "strain_limit"; }

  // Sum of element energies (J); +infinity as soon as one triangle is at or over the limit.
  double value(const Eigen::VectorXd& x) const override;
  // grad += d value / d x (N).
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const override;
  // Adds each element Hessian (N/m), projected per element with project_hessian<9>. Every triangle
  // adds its block, zeros when it is below the band, so the assembly's element stencils never
  // change and the Cholesky factorization keeps its symbolic analysis when triangles enter or
  // leave the band.
  void add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                   HessianAssembly& hessian) const override;
  // min over triangles of strain_limit_step: x + alpha dx keeps every triangle below the limit
  // (0 if x itself is inadmissible; call first_violating_triangle to refuse such a start).
  double max_step(const Eigen::VectorXd& x, const Eigen::VectorXd& dx) const override;

  // Largest principal stretch over the triangles (dimensionless; 0 without triangles).
  double max_stretch(const Eigen::VectorXd& x) const;
  // Index (into `faces`) of the first triangle with sigma_max >= limit (or not finite), -1 if none.
  // A time step must start from an admissible state: the barrier is +infinity otherwise.
  int first_violating_triangle(const Eigen::VectorXd& x) const;

  // kappa_s, J/m^2 (>= 0, finite; std::invalid_argument otherwise).
  void set_stiffness(double stiffness);
  // The resolved settings (the activation actually used).
  const StrainLimitSettings& settings() const { return settings_; }
  int num_faces() const { return static_cast<int>(faces_.size()); }

 private:
  void check_size(const Eigen::VectorXd& x) const;
  Vec<9> gather(const Eigen::VectorXd& x, int face) const;

  std::vector<std::array<int, 3>> faces_;
  std::vector<StrainLimitRest> rest_;
  StrainLimitSettings settings_;
  int min_dofs_ = 0;  // 3 * (largest vertex index + 1): x must be at least this long
};

}  // namespace pd
