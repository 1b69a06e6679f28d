// Health every step through the C++ API: a non-finite value or a density above the limit
// stops the run with one error that names the step, the time and the particle; particles
// that leave the domain are lost, never an error; NaN is never counted as lost.
#include "bullet_bridge/coupled_world.hpp"

#include <btBulletDynamicsCommon.h>
#include <gtest/gtest.h>

#include <limits>
#include <memory>
#include <string>

namespace wake {
namespace {

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

/// A Bullet world with a static floor (top at y = 0) and a block of fluid above it.
struct FluidOnAFloor {
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world{&dispatcher, &broadphase, &solver, &config};
  btBoxShape floor_shape{btVector3(0.5f, 0.05f, 0.5f)};
  std::unique_ptr<btRigidBody> floor;
  std::unique_ptr<CoupledWorld> fluid;

  explicit FluidOnAFloor(const CoupledWorldSettings& settings,
                         const Vec3& block_min = Vec3(0, 0, 0),
                         const Vec3& block_max = Vec3(0.1, 0.1, 0.1),
                         const Vec3& velocity = Vec3::Zero()) {
    world.setGravity(btVector3(0, -9.81f, 0));
    btTransform t;
    t.setIdentity();
    t.setOrigin(btVector3(0, -0.05f, 0));
    btRigidBody::btRigidBodyConstructionInfo info(0, nullptr, &floor_shape);
    info.m_startWorldTransform = t;
    floor = std::make_unique<btRigidBody>(info);
    world.addRigidBody(floor.get());
    fluid = std::make_unique<CoupledWorld>(world, settings);
    fluid->addFluidBlock(block_min, block_max, velocity);
    fluid->couple(floor.get(), {"floor"});
  }
  ~FluidOnAFloor() {
    fluid.reset();
    world.removeRigidBody(floor.get());
  }
  FluidState& state() { return fluid->simulation().fluid().state(); }
};

CoupledWorldSettings settings() {
  CoupledWorldSettings s;
  s.fluid.particle_radius = 0.01;
  return s;
}

TEST(Health, NonFiniteVelocityStopsTheNextStepNamingTheParticle) {
  FluidOnAFloor w(settings());
  w.fluid->advance(0.01);
  const std::uint64_t steps = w.fluid->simulation().steps();
  const std::size_t slot = w.state().size() / 2;
  w.state().velocity[slot].x() = std::numeric_limits<double>::quiet_NaN();
  try {
    w.fluid->advance(0.01);
    FAIL() << "no HealthError";
  } catch (const HealthError& e) {
    const std::string m = e.what();
    // Within the step the NaN reaches the particle's neighbours (through the viscous
    // forces): the one named is a particle that is not finite now, in the first step.
    const FluidState& st = w.state();
    std::size_t named = st.size();
    for (std::size_t i = 0; i < st.size(); ++i)
      if (st.id[i] == e.particle()) named = i;
    ASSERT_LT(named, st.size());
    EXPECT_FALSE(st.position[named].allFinite() && st.velocity[named].allFinite());
    const std::uint32_t id = e.particle();
    EXPECT_EQ(e.step(), steps + 1);
    EXPECT_GT(e.time(), 0.01);
    EXPECT_TRUE(contains(m, "step " + std::to_string(steps + 1))) << m;
    EXPECT_TRUE(contains(m, "fluid particle " + std::to_string(id))) << m;
    EXPECT_TRUE(contains(m, "non-finite")) << m;
    EXPECT_TRUE(contains(m, "time.cfl")) << m;
  }
  EXPECT_EQ(w.fluid->simulation().lostParticles(), 0u);
  // It stays stopped: the next call says the same.
  EXPECT_THROW(w.fluid->advance(0.01), HealthError);
}

TEST(Health, NonFinitePositionIsAnErrorNotALostParticle) {
  FluidOnAFloor w(settings());
  w.fluid->advance(0.01);
  const std::uint32_t id = w.state().id[3];
  w.state().position[3].y() = std::numeric_limits<double>::infinity();
  try {
    w.fluid->advance(0.01);
    FAIL() << "no HealthError";
  } catch (const HealthError& e) {
    EXPECT_EQ(e.particle(), id);
    EXPECT_TRUE(contains(e.what(), "a non-finite position")) << e.what();
  }
  EXPECT_EQ(w.fluid->simulation().lostParticles(), 0u);
}

TEST(Health, DensityAboveTheLimitStopsTheRunNamingTheDensestParticle) {
  // A speed of sound far too low for the scene: the fluid falls onto the floor as dust and
  // piles up far beyond its rest density.
  CoupledWorldSettings s = settings();
  s.fluid.speed_of_sound = 0.05;
  FluidOnAFloor w(s, Vec3(0, 0, 0), Vec3(0.1, 0.3, 0.1));
  try {
    w.fluid->advance(1.0);
    FAIL() << "no HealthError within 1 s, max density ratio "
           << w.fluid->simulation().maxDensityRatio();
  } catch (const HealthError& e) {
    const std::string m = e.what();
    EXPECT_TRUE(contains(m, "above health.max_density_ratio = 3")) << m;
    EXPECT_TRUE(contains(m, "fluid.speed_of_sound (now 0.05 m/s")) << m;
    // The particle named is the densest one, above the limit, where the message says.
    const FluidState& st = w.state();
    std::size_t slot = st.size();
    for (std::size_t i = 0; i < st.size(); ++i)
      if (st.id[i] == e.particle()) slot = i;
    ASSERT_LT(slot, st.size());
    EXPECT_GT(st.density[slot], 3000.0);
    for (std::size_t i = 0; i < st.size(); ++i)
      EXPECT_LE(st.density[i], st.density[slot]);
    EXPECT_EQ(st.position[slot], e.position());
    EXPECT_NEAR(e.time(), w.fluid->simulation().time(), 0.0);
  }
  // A higher limit lets the same run go on past that point.
  s.health.max_density_ratio = 1e3;
  FluidOnAFloor lenient(s, Vec3(0, 0, 0), Vec3(0.1, 0.3, 0.1));
  EXPECT_NO_THROW(lenient.fluid->advance(0.3));
}

TEST(Health, FluidLeavingTheDomainIsLostNotAnError) {
  CoupledWorldSettings s = settings();
  s.domain = Aabb{Vec3(-0.2, -0.1, -0.2), Vec3(0.3, 0.3, 0.3)};
  // Thrown sideways at 3 m/s: most of the block leaves the domain through x = 0.3.
  FluidOnAFloor w(s, Vec3(0, 0, 0), Vec3(0.1, 0.1, 0.1), Vec3(3, 0, 0));
  EXPECT_NO_THROW(w.fluid->advance(0.15));
  EXPECT_GT(w.fluid->simulation().lostParticles(), 50u);
  EXPECT_EQ(w.fluid->simulation().lostParticles() + w.state().size(), 125u);
}

TEST(Health, ALimitAtOrBelowOneIsRefusedNamingTheField) {
  CoupledWorldSettings s = settings();
  s.health.max_density_ratio = 1.0;
  FluidOnAFloor w(s);
  try {
    w.fluid->start();
    FAIL() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_TRUE(contains(e.what(), "health.max_density_ratio")) << e.what();
  }
}

TEST(CoupledWorldSettings, EveryFieldReachesTheSimulation) {
  CoupledWorldSettings s = settings();
  s.method = CouplingMethod::Penalty;
  s.penalty_strength = 12.5;
  s.cfl = 0.3;
  s.max_dt = 5e-4;
  s.health.max_density_ratio = 2.0;
  FluidOnAFloor w(s);
  w.fluid->start();
  const SimulationSettings& got = w.fluid->simulation().settings();
  EXPECT_EQ(got.method, CouplingMethod::Penalty);
  EXPECT_EQ(got.penalty_strength, 12.5);
  EXPECT_EQ(got.cfl, 0.3);
  EXPECT_EQ(got.max_dt, 5e-4);
  EXPECT_EQ(got.health.max_density_ratio, 2.0);
}

}  // namespace
}  // namespace wake
