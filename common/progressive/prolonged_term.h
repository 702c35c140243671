#pragma once
// Finest-level energies felt by a coarser level through the shell prolongation (PD eq. 4, PSQ
// section 4.3): a coarse level l is stepped on its own vertices x (stacked, 3 n_l), but its shell
// elasticity is the finest level's, evaluated on the prolonged shape y = P^l(x) = U x + a(x).
//
// Exact gradient (the default). The offsets a(x) follow x everywhere, and the derivatives are those
// of Psi(P(x)):
//   value(x)    = Psi(P(x))                        (J)
//   gradient    = J(x)^T grad Psi(P(x)),  J = dP/dx = U + da/dx (ShellProlongation::jacobian)   (N)
//   Hessian     = J(x)^T H_Psi(P(x)) J(x)  (Galerkin, Gauss-Newton: the term grad Psi . d2a/dx2 is
//                 dropped, so the Hessian is positive semi-definite when the fine blocks are), or a
//                 stand-in (below).
// Why not PSQ's frozen offsets. PSQ and PD (4.6) hold the offsets fixed while taking derivatives
// (value Psi(U x + A), gradient U^T grad Psi, A refreshed after every accepted iterate): cheaper, and
// its fixed point U^T grad Psi(P(x)) = 0 is right for quasistatics. In dynamics the dropped
// (da/dx)^T grad Psi is not a small correction: U's rows sum to 1, so the restricted forces
// F = -U^T grad Psi have the net torque -sum_i A_i x f_i (f_i the fine forces), zero only where the
// offsets A_i are parallel to the fine forces. A pressurised ball at rest under a 10x coarser level
// (fine forces balancing the gas, offsets of centimetres) spun itself up from nothing to 45 rad/s
// and gained 3.4 J of kinetic energy; a sheet folded on a sharp edge gained 0.64 J in one step
// (docs/stress.md, findings 1 and 2). Psi(P(x)) is invariant under rigid motions of x (the offsets
// turn with the coarse triangles), so its exact gradient has zero net force and torque, and the
// level is an ordinary conservative system again. Frozen stays selectable (ProlongedGradient) to
// measure that difference.
// A trial state whose deformed coarse face that carries fine vertices has (numerically) zero area has
// no prolongation: value() is then +infinity, so Newton's line search rejects it as it rejects an
// inverted membrane triangle.
//
// Hessian choice (issue 5 asks for both; measured with bench/progressive_scenes.cpp, see
// docs/progressive.md):
//   Galerkin  J^T H_fine J (U^T H_fine U when frozen): each fine element block (projected as asked) is
//             carried through the prolongation's Jacobian, so the result is positive semi-definite when
//             the blocks are; one sparse product per assembly.
//   Lagged    the Galerkin Hessian of the step's first Newton iterate, reused for the next few iterates
//             and then recomputed (a modified Newton method, see kLaggedRefreshEvery): the fine element
//             Hessians, their projections and the product are paid once every few iterates, and the
//             iterates in between cost a fine gradient and the coarse solve. Still positive
//             semi-definite, so every direction descends; convergence is linear between refreshes.
//   Coarse    the Hessian of a stand-in term on the level's own mesh (the same material on level l's
//             rest shape, PSQ eq. 10's preconditioner): cheaper per iteration, not the exact Hessian
//             of value(); the coarse shell is much stiffer than the finest seen through P, and the
//             same preview needed 176 iterations per step (most steps hit the cap) in 2026-11 (frozen
//             offsets); with the exact gradient it converges on most scenes (docs/progressive.md).
//   CoarseFirst  the stand-in's Hessian for a step's first kCoarseFirstAssemblies Newton iterates, then
//             Lagged for the rest of that step: cheap iterates where the stand-in is good enough, the
//             Galerkin Hessian where it stalls (the pressurised ball, the cloth winding on a sphere).
//             The solver may keep the stand-in past those assemblies when it finds it right where
//             Newton is (keep_stand_in_hessian; solver/newton.cpp probes it): a Galerkin refresh takes
//             as long as about twelve fine values (flag-large's preview: 19 ms against 1.6 ms).
//             Both phases assemble the union of their block patterns (zeros where a phase has no
//             block) from the term's first assembly on, so switching does not re-analyse the coarse
//             matrix and a run continued from stored frames assembles the same matrices.
//
// Velocities prolong with the Jacobian at the start state (begin_step gives the fine term P(x), J v;
// frozen: U x + A, U v): the velocity of the prolonged shape.
//
// Conventions: stacked vectors, x[3i + k] = coordinate k of vertex i (m); fine vertex ids are the
// finest level's global ids, coarse ids level l's.
#include <array>
#include <cstddef>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "hierarchy/shell_prolongation.h"
#include "physics/energy_term.h"
#include "progressive/galerkin_product.h"
#include "util/state_key.h"

namespace pd {

enum class ProlongedGradient {
  Exact,   // offsets follow x: value Psi(P(x)), gradient J^T grad Psi (the default; see above)
  Frozen,  // PSQ / PD 4.6: offsets frozen at the last accepted iterate, gradient U^T grad Psi
};

// The prolongation of one level, shared by the level's prolonged term and its stepper (which
// refreshes frozen offsets), so P(x) and its Jacobian are computed once per state x: the last
// state's are kept (value, gradient and Hessian of one Newton iterate ask for the same x). Not
// thread-safe (the cache is mutable).
class ProlongationState {
 public:
  // prolongation: P^l (fine = finest level, coarse = level l); not owned, must outlive this.
  // coarse_rest: level l's rest positions (stacked), where frozen offsets start (a(rest) = the rest
  // offsets).
  ProlongationState(const ShellProlongation& prolongation, const Eigen::VectorXd& coarse_rest,
                    ProlongedGradient gradient = ProlongedGradient::Exact);

  ProlongedGradient gradient_mode() const { return mode_; }

  // Frozen: recomputes the frozen offsets at x (stacked coarse positions); a deformed coarse face
  // with (numerically) zero area has no normal or rotation, and the offsets are then kept as they
  // were (returns false) rather than replaced by NaN; true when they were refreshed.
  // Exact: nothing to refresh (the offsets are always those of the state asked about): false.
  bool refresh(const Eigen::VectorXd& x);

  // The prolonged shape, stacked fine positions (m): P(x) (exact; throws
  // DegenerateProlongationTriangle) or U x + A (frozen).
  Eigen::VectorXd fine_positions(const Eigen::VectorXd& x) const;
  // The derivative of fine_positions at x, stacked (3 n_fine x 3 n_coarse): J(x) (exact; throws
  // DegenerateProlongationTriangle) or U (x) I3 (frozen). The reference is valid until the next call.
  const Eigen::SparseMatrix<double>& jacobian(const Eigen::VectorXd& x) const;
  // jacobian(x)^T g (stacked fine -> stacked coarse), e.g. a fine gradient (N) to the coarse one.
  Eigen::VectorXd restrict(const Eigen::VectorXd& x, const Eigen::VectorXd& g_fine) const;
  // U (x) I3, stacked (3 n_fine x 3 n_coarse).
  const Eigen::SparseMatrix<double>& U() const { return P_->U_stacked(); }
  int num_coarse() const { return P_->num_coarse(); }
  int num_fine() const { return P_->num_fine(); }

 private:
  const ShellProlongation* P_;
  ProlongedGradient mode_;
  Positions offsets_;  // frozen A, (n_fine, 3) m
  // Exact mode's cache: the state last asked about, its P(x) and J(x) (J computed on first use).
  mutable Eigen::VectorXd cached_y_;
  mutable StateKey y_key_;
  mutable ShellProlongation::JacobianPlan jacobian_;  // J's pattern made once, values per state
  mutable StateKey jacobian_key_;
};

enum class ProlongedHessian {
  Galerkin,  // J^T H_fine J, at every Newton iterate
  Lagged,    // J^T H_fine J at the first Newton iterate of each step and every kLaggedRefreshEvery-th
             // after it, reused in between
  Coarse,    // the stand-in term's Hessian on the level's own mesh
  CoarseFirst,  // the stand-in's Hessian for a step's first kCoarseFirstAssemblies assemblies, then
                // Lagged (refreshed at the switch) for the rest of the step
};

// Lagged: the Galerkin Hessian is recomputed at every this-many-th assembly within a step. Measured
// on 30-50-frame previews (docs/progressive.md): reusing it for the whole step left 22 of 30
// spin-sphere steps unconverged; recomputing every 4 / 6 / 10 assemblies cost 36 / 34 / 36 s against
// 64 s for plain Galerkin there, and 6 sits on the plateau for the flag and the large trampoline too.
constexpr int kLaggedRefreshEvery = 6;

// CoarseFirst: assemblies per step that use the coarse stand-in before the step turns to the lagged
// Galerkin Hessian. The decision depends only on the step's own iterates, so a step's solve is the
// same whichever task or worker runs it. 8 against 4, 30-frame previews, one thread, 2026-12-03:
// flag-large 10.8 / 15.1 s, spin-sphere 31.4 / 43.6 s, ball-drop 5.4 / 5.5 s (docs/progressive.md).
constexpr int kCoarseFirstAssemblies = 8;

// "galerkin", "lagged", "coarse" or "coarse-first" (command-line and benchmark spelling); throws
// std::invalid_argument naming the accepted words for anything else.
ProlongedHessian parse_prolonged_hessian(const std::string& name);

// The finest-level shell terms of a coarse level (membrane, bending and pressure of every
// deformable object), felt together through the level's prolongation. One term for all of them, not
// one per energy: an iterate then computes one prolonged shape, one fine Hessian assembly, one
// Galerkin product and one restriction (J^T (g_1 + g_2 + ...)), which were each paid once per
// energy and object before (about 15% of a one-thread flag-large preview, docs/performance.md).
class ProlongedTerm : public EnergyTerm {
 public:
  // fine: the finest-level terms (global finest ids), at least one. state: the level's shared
  // prolongation state. Modes Coarse and CoarseFirst need `coarse_stand_ins` (the same energies on
  // level l's mesh, level l ids; their Hessians are summed); Galerkin and Lagged ignore them.
  // Throws std::invalid_argument for no term, a null term or state, or a Coarse or CoarseFirst mode
  // without stand-ins.
  ProlongedTerm(std::vector<std::unique_ptr<EnergyTerm>> fine, std::shared_ptr<ProlongationState> state,
                ProlongedHessian mode, std::vector<std::unique_ptr<EnergyTerm>> coarse_stand_ins = {});
  // One fine term (and its stand-in, may be null).
  ProlongedTerm(std::unique_ptr<EnergyTerm> fine, std::shared_ptr<ProlongationState> state, ProlongedHessian mode,
                std::unique_ptr<EnergyTerm> coarse_stand_in = nullptr);

  // The fine terms' names joined by '+' ("membrane+bending"); frame statistics use named_values.
  std::string name() const override;
  double value(const Eigen::VectorXd& x) const override;
  // Each fine term's value at the one prolonged shape, under its own name ("membrane", "bending",
  // ...), so frame statistics keep their keys.
  std::vector<std::pair<std::string, double>> named_values(const Eigen::VectorXd& x) const override;
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const override;
  void add_hessian(const Eigen::VectorXd& x, HessianProjection projection, HessianAssembly& hessian) const override;
  // Hands every fine term the prolonged start state (positions P(x), velocities J v).
  void begin_step(const StepStart& step) override;
  // CoarseFirst: true while the next add_hessian would be the step's first after the stand-in's
  // kCoarseFirstAssemblies and nothing kept the stand-in. keep_stand_in_hessian(true) keeps it for
  // the rest of the step (begin_step forgets that); false lets the next assembly turn to the lagged
  // Galerkin Hessian, also after a keep.
  bool stand_in_hessian_ends() const override;
  void keep_stand_in_hessian(bool keep) const override;
  // The fine terms' admissible step along the linearised prolonged motion J dx (pressure's volume
  // guard); 1 without computing J dx when no fine term may limit the step (membrane and bending).
  double max_step(const Eigen::VectorXd& x, const Eigen::VectorXd& dx) const override;
  bool may_limit_step() const override { return may_limit_step_; }

 private:
  std::vector<std::unique_ptr<EnergyTerm>> fine_;
  std::shared_ptr<ProlongationState> state_;
  ProlongedHessian mode_;
  std::vector<std::unique_ptr<EnergyTerm>> coarse_;
  bool may_limit_step_ = false;  // some fine term may limit the step
  // Galerkin blocks at x into `product`; with values == false their pattern alone (zero blocks, no
  // fine element Hessian computed: HessianAssembly::begin_pattern, GalerkinProduct::pattern).
  void compute_galerkin_blocks(const Eigen::VectorXd& x, HessianProjection projection, GalerkinProduct& product,
                               bool values = true) const;
  void compute_coarse_blocks(const Eigen::VectorXd& x, HessianProjection projection) const;
  void add_blocks(const std::vector<GalerkinProduct::Block>& values,
                  const std::vector<GalerkinProduct::Block>& pattern_only, HessianAssembly& hessian) const;

  mutable HessianAssembly fine_hessian_;  // reused so its sparsity pattern is analysed once
  // Lagged bookkeeping, one set of J^T H_fine J's blocks per element projection: exact_first
  // alternates exact and clamped assemblies within a step, and one shared set, rebuilt at every
  // switch, made spin-sphere's preview 2.2x slower than clamp's. A set is reused while it was
  // computed in this step fewer than kLaggedRefreshEvery lagged assemblies (of any projection) ago,
  // so no block is older than it was with one set. begin_step restarts the count.
  struct LaggedBlocks {
    GalerkinProduct product;
    int computed_at = -1;  // lagged_assemblies_ when computed in this step, -1: not in this step
  };
  mutable std::array<LaggedBlocks, 4> lagged_;  // indexed by HessianProjection
  mutable int lagged_assemblies_ = 0;           // lagged add_hessian calls since begin_step
  mutable std::size_t last_lagged_ = 0;         // the set computed last (CoarseFirst's block pattern)
  mutable int assemblies_in_step_ = 0;  // CoarseFirst: add_hessian calls since begin_step
  mutable bool keep_stand_in_ = false;  // CoarseFirst: the solver kept the stand-in for this step
  mutable HessianAssembly coarse_hessian_;                 // CoarseFirst: the stand-in's, reused
  mutable std::vector<GalerkinProduct::Block> coarse_blocks_;  // its lower blocks, (column, row) order
};

}  // namespace pd
