// The incremental potential as a sum of terms: its Hessian products by differences of gradients
// (what a coarse level's Newton uses to check its model Hessian, solver/newton.h).
#include "solver/incremental_potential.h"

#include <gtest/gtest.h>

#include <memory>

#include "geometry/topology.h"
#include "physics/bending_hinge.h"
#include "physics/contact/barrier_potential.h"
#include "physics/inertia.h"
#include "physics/membrane_neo_hookean.h"
#include "support/contact_settings.h"
#include "support/term_eval.h"
#include "support/two_squares.h"

namespace pd {
namespace {

// Two squares in contact (active point-triangle and edge-edge pairs), each a membrane with hinges,
// with inertia, at a deformed state: every kind of term a step assembles, with curvature of both
// signs. The first square's corner vertex 0 is fixed.
struct ContactSheets {
  test::TwoSquares s;
  IncrementalPotential ip;
  Eigen::VectorXd x;
  explicit ContactSheets(double kappa) {
    const TriMesh mesh{s.rest, s.prims.faces};
    const Topology topology = build_topology(mesh);
    ip.add_term(std::make_unique<InertiaTerm>(Eigen::VectorXd::Constant(s.x.size(), 0.01)));
    ip.add_term(std::make_unique<NeoHookeanMembrane>(s.prims.faces, s.rest,
                                                     MembraneMaterialParams::from(1e4, 0.3, 1e-3)));
    ip.add_term(std::make_unique<HingeBending>(topology.hinges, s.rest, 0.05));
    ip.add_term(std::make_unique<BarrierPotential>(s.prims, s.rest, test::contact_settings(0.2, 0.01, kappa)));
    std::vector<char> fixed(s.x.size(), 0);
    fixed[0] = fixed[1] = fixed[2] = 1;
    ip.set_fixed_dofs(fixed);
    StepStart start;
    start.h = 0.01;
    start.x = &s.x;
    const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(s.x.size());
    start.v = &v0;
    ip.begin_step(start);
    // Compress and bend a little: membrane triangles and hinges off their rest shapes.
    x = s.x;
    for (Eigen::Index i = 3; i < x.size(); ++i) x[i] += 0.004 * std::sin(1.7 * static_cast<double>(i));
  }
};

TEST(IncrementalPotential, HessianProductByDifferencesMatchesTheAssembledExactHessian) {
  ContactSheets c(10.0);
  const Eigen::VectorXd g = c.ip.gradient(c.x);
  HessianAssembly assembly;
  c.ip.hessian(c.x, HessianProjection::None, assembly);
  const Eigen::MatrixXd H = Eigen::MatrixXd(assembly.finish(nullptr)).selfadjointView<Eigen::Lower>();
  int compared = 0;
  for (int k = 0; k < 4; ++k) {
    Eigen::VectorXd v = Eigen::VectorXd::Zero(c.x.size());
    for (Eigen::Index i = 3; i < v.size(); ++i) v[i] = std::cos(0.9 * static_cast<double>(i * (k + 1)) + k);
    Eigen::VectorXd product;
    ASSERT_TRUE(c.ip.hessian_product(c.x, g, v, product));
    const Eigen::VectorXd expected = H * v;
    ASSERT_GT(expected.norm(), 0.0);
    EXPECT_LT((product - expected).norm(), 1e-5 * expected.norm()) << "direction " << k;
    EXPECT_EQ(product.head<3>().norm(), 0.0) << "fixed dofs have no product";
    ++compared;
  }
  EXPECT_EQ(compared, 4);
}

TEST(IncrementalPotential, HessianProductOfAZeroDirectionIsRefused) {
  ContactSheets c(10.0);
  const Eigen::VectorXd g = c.ip.gradient(c.x);
  Eigen::VectorXd product;
  EXPECT_FALSE(c.ip.hessian_product(c.x, g, Eigen::VectorXd::Zero(c.x.size()), product));
}

}  // namespace
}  // namespace pd
