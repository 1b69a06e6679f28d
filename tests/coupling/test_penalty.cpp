// Monaghan's penalty boundary, the paper's baseline (coupling/penalty.hpp).
#include "coupling/penalty.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

namespace wake {
namespace {

using test::sheetOnFreeBox;
using test::staticBody;
using test::totalMomentum;

TEST(Penalty, PushesAlongTheNormalOnlyWithinReach) {
  const double r = 0.01;
  FluidParams fluid;
  fluid.particle_radius = r;
  Boundaries boundaries(fluid, Aabb{Vec3::Constant(-1), Vec3::Constant(1)});
  boundaries.addBody(staticBody("floor", makeBox(Vec3(0.2, 0.05, 0.2))));
  boundaries.finalize();
  PenaltyBoundary::Terms terms;
  // Samples sit r under the surface y = 0.05, one at (0.01, 0.04, 0.01); the force
  // reaches to 2 r from a sample.
  const PenaltyBoundary penalty(fluid, 10.0);
  double previous = 0.0;
  for (const double h : {0.8 * r, 0.5 * r, 0.2 * r}) {
    ASSERT_EQ(
        penalty.terms(boundaries, boundaries.placeAtStart(), Vec3(0.01, 0.05 + h, 0.01), terms),
        1u);
    const Vec3 a = terms[0].accel;
    EXPECT_GT(a.y(), 0.0) << "h " << h;
    EXPECT_LT(std::hypot(a.x(), a.z()), 1e-9 * a.y()) << "h " << h;  // right above the sample
    EXPECT_GT(a.y(), previous) << "closer must push harder";
    previous = a.y();
  }
  EXPECT_EQ(penalty.terms(boundaries, boundaries.placeAtStart(), Vec3(0.01, 0.05 + 1.01 * r, 0.01),
                          terms),
            0u);
}

TEST(Penalty, FluidPlusBodyMomentumIsConserved) {
  Simulation sim = sheetOnFreeBox(CouplingMethod::Penalty, 0.0);
  const Vec3 p0 = totalMomentum(sim, 0.5);
  std::size_t max_pairs = 0;
  while (sim.time() < 0.04) {
    sim.step(0.04);
    max_pairs = std::max(max_pairs, sim.lastContacts());
  }
  EXPECT_GE(max_pairs, 5u);
  EXPECT_LT(sim.bodyStates()[0].linear_velocity.y(), -0.1) << "the box took no momentum";
  const Vec3 p1 = totalMomentum(sim, 0.5);
  EXPECT_LT((p1 - p0).norm(), 1e-9 * p0.norm())
      << "p0 " << p0.transpose() << " p1 " << p1.transpose();
}

TEST(Penalty, SameStateOnOneAndTwoThreads) {
  std::vector<Vec3> result[2];
  for (int threads = 1; threads <= 2; ++threads) {
    Simulation sim = sheetOnFreeBox(CouplingMethod::Penalty, 0.0, threads);
    sim.advanceTo(0.03);
    FluidSnapshot snap;
    sim.snapshot(snap);
    result[threads - 1] = snap.position;
    result[threads - 1].push_back(sim.bodyStates()[0].position);
  }
  omp_set_num_threads(2);
  ASSERT_EQ(result[0].size(), result[1].size());
  for (std::size_t i = 0; i < result[0].size(); ++i)
    ASSERT_EQ(result[0][i], result[1][i]) << i;
}

}  // namespace
}  // namespace wake
