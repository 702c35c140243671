#pragma once
// The IPC contact potential as one term of the incremental potential (C-IPC):
//   E_c(x) = kappa * ( sum_{(v,f) point-triangle} b(d^2_vf(x))
//                    + sum_{(a,b) edge-edge} m_ab(x) b(d^2_ab(x)) )
// over the broad phase's candidate pairs, with b the offset log barrier of barrier.h (active when
// the gap d - offset is below dhat), d^2 the squared distances of distance.h (closest-point type
// chosen per pair and evaluation) and m_ab the edge-edge mollifier that smooths the barrier of
// nearly parallel edges. max_step() is the CCD filter: no line-search step may bring any pair to
// the offset distance, so every iterate, and so every stored frame, stays intersection-free.
//
// Variables: the stacked positions x of the whole scene (global vertex indices), metres.
// Duplicated point-point / point-edge contacts (a vertex near a shared edge counts once per face)
// are kept, as in IPC: they only scale the barrier locally.
#include <vector>

#include "physics/contact/broad_phase.h"
#include "physics/contact/friction_contact.h"
#include "physics/energy_term.h"
#include "util/state_key.h"

namespace pd {

struct ContactSettings {
  double dhat = 1e-3;      // activation gap, m: the barrier acts while d - offset < dhat
  double offset = 0.0;     // xi, m: mid-surface distance at which contact happens (shell thickness)
  double kappa = 0.0;      // barrier stiffness, J/m^4 (barrier.h: barrier_stiffness_bounds)
  double ccd_ratio = 0.9;  // fraction of each certified-safe ACCD advance that is taken
};

// What the last evaluation saw (for frame statistics).
struct ContactStats {
  int active_point_triangle = 0;  // pairs with gap < dhat
  int active_edge_edge = 0;
  double min_gap = 0.0;           // min over candidate pairs of d - offset, m (+inf if none)
};

class BarrierPotential : public EnergyTerm, public FrictionSource {
 public:
  // rest: rest positions (rows = global vertices), for the mollifier thresholds.
  BarrierPotential(ContactPrimitives primitives, const Positions& rest, const ContactSettings& settings);

  std::string name() const override { return "contact"; }
  double value(const Eigen::VectorXd& x) const override;
  void add_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& grad) const override;
  // The gradient at x over the broad-phase pairs of `reference` (the .cpp says why that is exact
  // enough for a difference of gradients): no broad phase at x.
  void add_gradient_near(const Eigen::VectorXd& reference, const Eigen::VectorXd& x,
                         Eigen::VectorXd& grad) const override;
  void add_hessian(const Eigen::VectorXd& x, HessianProjection projection,
                   HessianAssembly& hessian) const override;
  // Largest alpha in [0, 1] such that no candidate pair reaches the offset distance on x -> x + alpha dx.
  double max_step(const Eigen::VectorXd& x, const Eigen::VectorXd& dx) const override;

  // Statistics of the pairs at x (candidates, gaps, active counts).
  ContactStats stats(const Eigen::VectorXd& x) const;

  // The barrier's gradient without kappa (for initial_barrier_stiffness).
  Eigen::VectorXd unit_stiffness_gradient(const Eigen::VectorXd& x) const;

  // Pairs that contact at distance 0 instead of settings().offset: pairs that already sit within
  // the offset in a state the caller must start from (a freshly split edge in safe upsampling is
  // shorter than the shell thickness). With the offset, the barrier is infinite there and no Newton
  // step can start; with offset 0 for the whole term, every other pair could be pressed into the
  // offset. A thin pair is active over the same distances as the others (d < offset + dhat): its
  // barrier is b(d^2; offset + dhat, 0), so it still pushes the pair out past the offset.
  // Pairs in broad-phase form (point-triangle (vertex, face), edge-edge (edge a < edge b));
  // sorted and de-duplicated here. Empty by default (every pair uses the offset).
  void set_thin_pairs(CandidatePairs pairs);
  // The candidate pairs at x (positions, stacked) whose distance is <= settings().offset: what
  // set_thin_pairs needs for a start state x.
  CandidatePairs pairs_within_offset(const Eigen::VectorXd& x) const;

  const ContactSettings& settings() const { return settings_; }
  void set_kappa(double kappa) { settings_.kappa = kappa; }
  const ContactPrimitives& primitives() const { return primitives_; }

  // Friction coefficients per pair of objects: mu(a, b) for objects a, b (primitives().vertex_object
  // ids), dimensionless. Must be #objects x #objects (#objects = object_self_contact.size()),
  // symmetric, finite and >= 0, else std::invalid_argument; an empty (0 x 0) matrix means no friction,
  // which is also the default. mu(a, a) is the self-friction of object a.
  void set_friction(Eigen::MatrixXd mu);

  // FrictionSource: one contact per active pair at x (gap d - offset < dhat) whose objects have
  // mu > 0, stencil in the barrier's variable order (p, t0, t1, t2) / (ea0, ea1, eb0, eb1):
  //   normal_force = -kappa b'(d^2) 2 d = kappa |d b / d d|   (N; no edge-edge mollifier, as in IPC)
  //   weights      = the closest points' barycentric coordinates, signed: (1, -b0, -b1, -b2) /
  //                  (1 - s, s, -(1 - t), -t), so sum_k w_k x_k = (closest point on the first
  //                  primitive) - (closest point on the second), the contact's normal vector
  //   basis        = two orthonormal vectors orthogonal to the contact normal n: the triangle normal
  //                  (point-triangle interior), ea x eb (edge-edge interiors), else the direction
  //                  between the closest points; its first column is the triangle's first edge /
  //                  edge a's direction made orthogonal to n.
  // The closest points are those of the pair's closest-point type (distance.h), i.e. clamped to the
  // primitives: see the .cpp for why not the unclamped plane / line projections.
  void friction_contacts(const Eigen::VectorXd& x, std::vector<FrictionContact>& out) const override;

 private:
  // A candidate pair within the activation distance at x: kind 0 = point-triangle, 1 = edge-edge;
  // v = the 4 global vertices in variable order; x12 their positions; d2 the squared distance
  // (m^2); eps_x the mollifier threshold (edge-edge, else 0); offset the pair's contact offset (m:
  // 0 for thin pairs, else settings_.offset; pair_dhat(offset) is then its activation distance).
  struct ActivePair {
    int kind;
    std::array<int, 4> v;
    Vec<12> x12;
    double d2, eps_x, offset;
  };
  // The active pairs at x, point-triangle pairs first, each list in the broad phase's order (the
  // order every sum over pairs uses). Distances are computed on every element thread. Kept while x
  // is bit-for-bit unchanged, as the candidates are: the reference is valid until the next call
  // with another x (or set_thin_pairs).
  const std::vector<ActivePair>& active_pairs(const Eigen::VectorXd& x) const;
  // The active pairs at x among `pairs` (candidates found at x or, for add_gradient_near, nearby).
  void collect_active_pairs(const Eigen::VectorXd& x, const CandidatePairs& pairs, std::vector<ActivePair>& out) const;
  Eigen::VectorXd unit_stiffness_gradient(const std::vector<ActivePair>& pairs, Eigen::Index n) const;
  // Calls f(kind, stencil, x12, d2, eps_x, offset) for every active pair, in active_pairs' order.
  template <class F>
  void for_each_active_pair(const Eigen::VectorXd& x, F&& f) const;
  // One pair's barrier (kappa = 1, J), its gradient and its unprojected Hessian in the pair's 12
  // variables.
  double pair_energy(const ActivePair& p) const;
  Vec<12> pair_gradient(const ActivePair& p) const;
  Mat<12> pair_hessian(const ActivePair& p) const;

  // The broad phase's pairs at x, reused while x is bit-for-bit unchanged: a Newton iteration asks
  // for the gradient and the Hessian at the positions the line search just evaluated.
  const CandidatePairs& candidates(const Eigen::VectorXd& x) const;

  ContactPrimitives primitives_;
  mutable Eigen::VectorXd cached_x_;
  mutable CandidatePairs cached_pairs_;
  mutable std::vector<ActivePair> cached_active_;  // active_pairs' cache, for the x in active_key_
  mutable StateKey active_key_;
  std::vector<double> edge_rest_length2_;  // |e_rest|^2 per edge, for the mollifier threshold
  ContactSettings settings_;
  Eigen::MatrixXd friction_mu_;  // (#objects, #objects) or empty (no friction)
  CandidatePairs thin_;          // pairs with offset 0 (set_thin_pairs), sorted
  double pair_offset(int kind, const std::array<int, 2>& pair) const;  // 0 for thin pairs
  double pair_dhat(double pair_offset) const;  // activation measured from the pair's offset
};

}  // namespace pd
