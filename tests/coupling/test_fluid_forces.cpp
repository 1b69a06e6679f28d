// The user's fluid forces (Simulation::setFluidForces): added after the fluid's own forces
// and before the prediction, seen by the time step, by the bodies through direct forcing,
// and removable.
#include "test_support.hpp"

#include <gtest/gtest.h>

namespace wake {
namespace {

/// A 6 x 6 x 6 block of fluid alone in space (no gravity, no bodies).
SimulationSettings freeBlock() {
  SimulationSettings s;
  s.gravity = Vec3::Zero();
  s.fluid.particle_radius = 0.01;
  s.fluid.speed_of_sound = 20.0;
  s.blocks.push_back({Vec3(0, 0, 0), Vec3(0.12, 0.12, 0.12)});
  s.domain = Aabb{Vec3::Constant(-1), Vec3::Constant(1)};
  return s;
}

Vec3 meanVelocity(const Simulation& sim) {
  const FluidState& st = sim.fluid().state();
  Vec3 v = Vec3::Zero();
  for (const Vec3& vi : st.velocity)
    v += vi;
  return v / double(st.size());
}

TEST(FluidForces, AUniformForceAcceleratesTheWholeFluid) {
  Simulation sim(freeBlock());
  double seen_time = -1;
  std::size_t calls = 0;
  sim.setFluidForces([&](const FluidState& fluid, std::vector<Vec3>& a, double time) {
    EXPECT_EQ(a.size(), fluid.size());
    EXPECT_EQ(&a, &fluid.acceleration);
    seen_time = time;
    ++calls;
    for (Vec3& ai : a)
      ai += Vec3(2.0, 0, 0);  // a wind of 2 m/s^2 along x
  });
  sim.advanceTo(0.1);
  EXPECT_EQ(calls, sim.steps());
  EXPECT_LT(seen_time, 0.1);
  EXPECT_GT(seen_time, 0.09);
  // Internal forces cancel: the mean velocity is the wind's alone.
  EXPECT_NEAR(meanVelocity(sim).x(), 0.2, 1e-9);
  EXPECT_NEAR(meanVelocity(sim).y(), 0.0, 1e-9);
  // Removed, it acts no more.
  sim.setFluidForces({});
  sim.advanceTo(0.2);
  EXPECT_NEAR(meanVelocity(sim).x(), 0.2, 1e-9);
}

TEST(FluidForces, ALargeForceShortensTheTimeStep) {
  Simulation calm(freeBlock()), pushed(freeBlock());
  pushed.setFluidForces([](const FluidState&, std::vector<Vec3>& a, double) {
    for (Vec3& ai : a)
      ai += Vec3(0, 0, 5e4);
  });
  calm.step(1.0);
  pushed.step(1.0);
  // dt <= 0.25 sqrt(H / a_max) = 0.25 sqrt(0.02 / 5e4) = 0.16 ms, below the CFL step
  // 0.4 H / c = 0.4 ms.
  EXPECT_LE(pushed.lastDt(), 0.25 * std::sqrt(0.02 / 5e4) * (1 + 1e-12));
  EXPECT_LT(pushed.lastDt(), calm.lastDt());
}

TEST(FluidForces, TheBodiesFeelThemThroughTheFluid) {
  // Fluid pushed down onto a free box by the user's force (no gravity): direct forcing
  // passes the push on, so the box moves down; without the force it stays.
  auto run = [](bool push) {
    SimulationSettings s = freeBlock();
    s.blocks[0] = FluidBlock{Vec3(0, 0.03, 0), Vec3(0.12, 0.09, 0.12)};
    BodySettings box;
    box.name = "box";
    box.kind = BodyKind::Dynamic;
    box.shape = makeBox(Vec3(0.06, 0.01, 0.06));
    box.pose.position = Vec3(0.06, 0.01, 0.06);
    box.mass = 0.2;
    box.inertia = Vec3(2.4e-4, 4.8e-4, 2.4e-4);
    s.bodies.push_back(box);
    Simulation sim(s);
    if (push)
      sim.setFluidForces([](const FluidState&, std::vector<Vec3>& a, double) {
        for (Vec3& ai : a)
          ai += Vec3(0, -9.81, 0);
      });
    sim.advanceTo(0.1);
    EXPECT_EQ(sim.maxPenetrating(), 0u);
    return sim.bodyStates()[0].linear_velocity.y();
  };
  EXPECT_EQ(run(false), 0.0);
  EXPECT_LT(run(true), -0.05);
}

TEST(Model, AutomaticValuesAreResolvedInTheModelNotInTheSettings) {
  SimulationSettings given = freeBlock();
  given.fluid.speed_of_sound = 0.0;  // "auto"
  given.domain = Aabb{};             // automatic
  given.method = CouplingMethod::Penalty;
  given.penalty_strength = 0.0;  // automatic
  const Simulation sim(given);
  EXPECT_EQ(sim.settings().fluid.speed_of_sound, 0.0);
  EXPECT_TRUE(sim.settings().domain.empty());
  EXPECT_EQ(sim.settings().penalty_strength, 0.0);
  EXPECT_GT(sim.model().fluid.speed_of_sound, 0.0);
  EXPECT_EQ(sim.model().fluid.speed_of_sound, sim.fluid().params().speed_of_sound);
  EXPECT_EQ(sim.model().fluid.speed_of_sound, autoSpeedOfSound(given));
  EXPECT_FALSE(sim.model().domain.empty());
  EXPECT_EQ(sim.model().penalty_strength, defaultPenaltyStrength(sim.model().fluid.speed_of_sound));
}

}  // namespace
}  // namespace wake
