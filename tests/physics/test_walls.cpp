// Walls in a viscous fluid: a no-slip wall holds the fluid at the wall to the wall's
// velocity through the fluid's viscosity (Stokes' first problem), and never holds fluid
// against gravity (a film on a vertical wall falls).
#include "coupling/simulation.hpp"
#include "coupling/test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>

using namespace wake;
using wake::test::runWithoutPenetration;
using wake::test::staticBody;

class Viscosity : public test::SolverTest {};
class NoSlipWall : public test::SolverTest {};

INSTANTIATE_TEST_SUITE_P(, Viscosity, test::kSolvers, test::solverName);
INSTANTIATE_TEST_SUITE_P(, NoSlipWall, test::kSolvers, test::solverName);

TEST_P(Viscosity, StokesFirstProblemProfileNextToAMovingPlate) {
  // A plate (kinematic, top face at y = 0) set moving at U under fluid at rest, no gravity:
  // u(y, t) = U erfc(y / (2 sqrt(nu t))), y the height above the plate's surface.
  const double r = 0.005, nu = 1e-2, U = 0.05;
  SimulationSettings s;
  s.solver = solver();
  s.gravity = Vec3::Zero();
  s.fluid.particle_radius = r;
  s.fluid.kinematic_viscosity = nu;
  s.fluid.speed_of_sound = 1.0;  // Mach 0.05
  s.blocks.push_back({Vec3(-0.1, 0.0, -0.04), Vec3(0.1, 0.25, 0.04), Vec3::Zero()});
  BodySettings plate = staticBody("plate", makeBox(Vec3(0.2, 0.02, 0.08)));
  plate.kind = BodyKind::Kinematic;
  plate.pose.position = Vec3(0, -0.02, 0);
  plate.linear_velocity = Vec3(U, 0, 0);
  s.bodies.push_back(plate);
  s.domain = Aabb{Vec3(-0.4, -0.1, -0.2), Vec3(0.4, 0.4, 0.2)};
  Simulation sim(s);
  for (const double t : {0.1, 0.25}) {
    runWithoutPenetration(sim, t);
    // Mean u_x per lattice layer in the middle of the block (away from its free ends).
    std::map<int, std::pair<double, int>> layers;
    const FluidState& st = sim.fluid().state();
    for (std::size_t i = 0; i < st.size(); ++i) {
      const Vec3& x = st.position[i];
      if (std::abs(x.z()) > 0.015 || std::abs(x.x()) > 0.05) continue;
      auto& layer = layers[int(std::floor(x.y() / (2 * r)))];
      layer.first += st.velocity[i].x();
      layer.second += 1;
    }
    double worst = 0;
    int checked = 0;
    for (const auto& [k, acc] : layers) {
      const double y = (k + 0.5) * 2 * r;
      if (y > 0.2) continue;  // the free surface at 0.25 m is no half-space
      const double u = acc.first / acc.second;
      const double exact = U * std::erfc(y / (2 * std::sqrt(nu * t)));
      worst = std::max(worst, std::abs(u - exact));
      if (k < 4 || k % 4 == 0)
        std::printf("[ stokes ] t %.2f s, y %.3f m: u %.4f m/s, exact %.4f m/s\n", t, y, u, exact);
      ++checked;
    }
    std::printf("[ stokes ] t %.2f s: largest error %.4f m/s = %.1f%% of U\n", t, worst,
                100 * worst / U);
    EXPECT_GE(checked, 15);
    EXPECT_LT(worst, 0.05 * U) << "t = " << t;
  }
}

namespace {

/// Time (s) until the lowest particle of a film `layers` particles thick, 10 cm tall, its
/// bottom `height` above the floor, lying against a vertical no-slip wall, reaches the
/// floor (or `limit`).
double filmFallTime(FluidSolver solver, int layers, double height, double limit) {
  const double r = 0.005;
  SimulationSettings s;
  s.solver = solver;
  s.fluid.particle_radius = r;  // water: kinematic viscosity 1e-6 m^2/s
  s.blocks.push_back(
      {Vec3(0, height, -0.03), Vec3(2 * r * layers, height + 0.1, 0.03), Vec3::Zero()});
  s.bodies.push_back(staticBody("wall", makeBox(Vec3(0.02, 0.25, 0.1)), 0.0, 0.0,
                                Pose{Vec3(-0.02, 0.25, 0), Quat::Identity()}));
  s.bodies.push_back(staticBody("floor", makeBox(Vec3(0.2, 0.02, 0.1)), 0.0, 0.0,
                                Pose{Vec3(0.15, -0.02, 0), Quat::Identity()}));
  s.domain = Aabb{Vec3(-0.1, -0.1, -0.15), Vec3(0.4, 0.5, 0.15)};
  Simulation sim(s);
  while (sim.time() < limit) {
    sim.step(limit);
    EXPECT_EQ(sim.countPenetrating(), 0u) << "t = " << sim.time();
    double lowest = 1.0;
    for (const Vec3& x : sim.fluid().state().position)
      lowest = std::min(lowest, x.y());
    if (lowest < 1.5 * r) return sim.time();
  }
  return limit;
}

}  // namespace

TEST_P(NoSlipWall, FilmOnAVerticalWallFallsToTheFloor) {
  // Water does not hang on a no-slip wall: a film one or two particles thick reaches the
  // floor within three times its free-fall time.
  const double height = 0.2, g = 9.81;
  const double free_fall = std::sqrt(2 * height / g);
  for (const int layers : {1, 2}) {
    const double t = filmFallTime(solver(), layers, height, 3 * free_fall + 0.05);
    std::printf("[ film ] %d layer(s): floor reached after %.3f s (free fall %.3f s)\n", layers, t,
                free_fall);
    EXPECT_LT(t, 3 * free_fall) << layers << " layer(s)";
  }
}
