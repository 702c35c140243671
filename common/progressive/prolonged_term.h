#pragma once
// A finest-level energy felt by a coarser level through the shell prolongation (PD eq. 4, PSQ
// section 4.3): a coarse level l is stepped on its own vertices x (stacked, 3 n_l), but its shell
// elasticity is the finest level's, evaluated on the prolonged shape y = P^l(x) = U x + a(x).
//
// Frozen offsets (PSQ, PD 4.6). The nonlinear offsets a(x) are held fixed while derivatives are taken:
// with A the offsets frozen at some state x_f,
//   value(x)    = Psi(U x + A)                     (J)
//   gradient    = U^T grad Psi(U x + A)            (N)
//   Hessian     = U^T H_Psi(U x + A) U  (Galerkin, N/m), or a stand-in (below)
// which are the exact derivatives of value() for the frozen A, so Newton's line search and a
// finite-difference test see one consistent function. The offsets are refreshed at the start of each
// step and after every accepted Newton iterate (ProlongationState::refresh, called through the
// solver's after_iteration hook), so at convergence x satisfies U^T grad Psi(P(x)) = 0 with the offsets
// of x itself: the PSQ fixed point.
//
// Hessian choice (issue 5 asks for both; measured with bench/progressive_scenes.cpp, see
// docs/progressive.md):
//   Galerkin  U^T H_fine U: each fine element block (projected as asked) is carried through U, so the
//             result is positive semi-definite when the blocks are; one sparse product per assembly.
//             The default: the cube-trampoline preview converges in 3.1 iterations per step.
//   Lagged    the Galerkin Hessian of the step's first Newton iterate, reused for the next few iterates
//             and then recomputed (a modified Newton method, see kLaggedRefreshEvery): the fine element
//             Hessians, their projections and the product are paid once every few iterates, and the
//             iterates in between cost a fine gradient and the coarse solve. Still positive
//             semi-definite, so every direction descends; convergence is linear between refreshes.
//   Coarse    the Hessian of a stand-in term on the level's own mesh (the same material on level l's
//             rest shape, PSQ eq. 10's preconditioner): cheaper per iteration, not the exact Hessian
//             of value(); the coarse shell is much stiffer than the finest seen through P, and the
//             same preview needed 176 iterations per step (most steps hit the cap).
//
// Velocities prolong with U alone (begin_step gives the fine term the start state U x + A, U v).
//
// Conventions: stacked vectors, x[3i + k] = coordinate k of vertex i (m); fine vertex ids are the
// finest level's global ids, coarse ids level l's.
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hierarchy/shell_prolongation.h"
#include "physics/energy_term.h"

namespace pd {

// The prolongation of one level and its frozen offsets, shared by all the level's prolonged terms
// (so the offsets are computed once per refresh, not once per term).
class ProlongationState {
 public:
  // prolongation: P^l (fine = finest level, coarse = level l); not owned, must outlive this.
  // coarse_rest: level l's rest positions (stacked), where the offsets start (a(rest) = the rest
  // offsets).
  ProlongationState(const ShellProlongation& prolongation, const Eigen::VectorXd& coarse_rest);

  // Recomputes the frozen offsets at x (stacked coarse positions). A deformed coarse face with
  // (numerically) zero area has no normal or rotation: the offsets are then kept as they were
  // (returns false) rather than replaced by NaN; true when they were refreshed.
  bool refresh(const Eigen::VectorXd& x);

  // U x + A, stacked fine positions (m).
  Eigen::VectorXd fine_positions(const Eigen::VectorXd& x) const;
  // U^T g (stacked fine -> stacked coarse).
  Eigen::VectorXd restrict(const Eigen::VectorXd& g_fine) const { return P_->restrict_gradient(g_fine); }
  // U (x) I3, stacked (3 n_fine x 3 n_coarse).
  const Eigen::SparseMatrix<double>& U() const { return P_->U_stacked(); }
  int num_coarse() const { return P_->num_coarse(); }
  int num_fine() const { return P_->num_fine(); }

 private:
  const ShellProlongation* P_;
  Positions offsets_;  // A, (n_fine, 3) m
};

enum class ProlongedHessian {
  Galerkin,  // U^T H_fine U, at every Newton iterate
  Lagged,    // U^T H_fine U at the first Newton iterate of each step and every kLaggedRefreshEvery-th
             // after it, reused in between
  Coarse,    // the stand-in term's Hessian on the level's own mesh
};

// Lagged: the Galerkin Hessian is recomputed at every this-many-th assembly within a step. Measured
// on 30-50-frame previews (docs/progressive.md): reusing it for the whole step left 22 of 30
// spin-sphere steps unconverged; recomputing every 4 / 6 / 10 assemblies cost 36 / 34 / 36 s against
// 64 s for plain Galerkin there, and 6 sits on the plateau for the flag and the large trampoline too.
constexpr int kLaggedRefreshEvery = 6;

// "galerkin", "lagged" or "coarse" (command-line and benchmark spelling); throws
// std::invalid_argument naming the accepted words for anything else.
ProlongedHessian parse_prolonged_hessian(const std::string& name);

class ProlongedTerm : public EnergyTerm {
 public:
  // fine: the finest-level term (global finest ids). state: the level's shared prolongation state.
  // mode Coarse needs `coarse_stand_in` (the same energy on level l's mesh, level l ids); Galerkin
  // ignores it. Throws std::invalid_argument for a missing term/state or a Coarse mode without a
  // stand-in.
  ProlongedTerm(std::unique_ptr<EnergyTerm> fine, std::shared_ptr<ProlongationState> state, ProlongedHessian mode,
                std::unique_ptr<EnergyTerm> coarse_stand_in = nullptr);

  // The fine term's name ("membrane", "bending", ...), so frame statistics keep their keys.
  std::string name() const override { return fine_->name(); }
  double value(const Eigen::VectorXd& x) const override;
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const override;
  void add_hessian(const Eigen::VectorXd& x, HessianProjection projection, HessianAssembly& hessian) const override;
  // Hands the fine term the prolonged start state (positions U x + A, velocities U v).
  void begin_step(const StepStart& step) override;
  // The fine term's admissible step along the prolonged motion U dx (pressure's volume guard).
  double max_step(const Eigen::VectorXd& x, const Eigen::VectorXd& dx) const override;

 private:
  std::unique_ptr<EnergyTerm> fine_;
  std::shared_ptr<ProlongationState> state_;
  ProlongedHessian mode_;
  std::unique_ptr<EnergyTerm> coarse_;
  // U^T H_fine U as 3x3 blocks (i, j), i >= j coarse vertex ids, column by column.
  struct GalerkinBlock {
    int i, j;
    Mat3 block;
  };
  void compute_galerkin_blocks(const Eigen::VectorXd& x, HessianProjection projection) const;

  mutable HessianAssembly fine_hessian_;  // reused so its sparsity pattern is analysed once
  mutable std::vector<GalerkinBlock> blocks_;
  // Lagged bookkeeping: begin_step marks the blocks stale; they were computed with blocks_projection_,
  // assemblies_since_refresh_ assemblies ago.
  mutable bool blocks_stale_ = true;
  mutable int assemblies_since_refresh_ = 0;
  mutable HessianProjection blocks_projection_ = HessianProjection::None;
};

}  // namespace pd
