// The drop-in API on a user's own Bullet world: one Bullet step per fluid sub-step,
// gravity from the world, forces that do not leak, kinematic bodies, and a clear error
// when the world is stepped behind Wake's back.
#include "bullet_bridge/coupled_world.hpp"

#include <BulletDynamics/Dynamics/btActionInterface.h>
#include <btBulletDynamicsCommon.h>
#include <gtest/gtest.h>

#include <memory>

namespace wake {
namespace {

/// A small Bullet world: a static floor box, its bodies owned here.
struct World {
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world{&dispatcher, &broadphase, &solver, &config};
  std::vector<std::unique_ptr<btCollisionShape>> shapes;
  std::vector<std::unique_ptr<btRigidBody>> bodies;

  World() { world.setGravity(btVector3(0, -9.81f, 0)); }
  ~World() {
    for (auto& b : bodies)
      world.removeRigidBody(b.get());
  }
  btRigidBody* add(std::unique_ptr<btCollisionShape> shape, double mass, const btVector3& at) {
    btVector3 inertia(0, 0, 0);
    if (mass > 0) shape->calculateLocalInertia(btScalar(mass), inertia);
    btTransform t;
    t.setIdentity();
    t.setOrigin(at);
    btRigidBody::btRigidBodyConstructionInfo info(btScalar(mass), nullptr, shape.get(), inertia);
    info.m_startWorldTransform = t;
    bodies.push_back(std::make_unique<btRigidBody>(info));
    shapes.push_back(std::move(shape));
    world.addRigidBody(bodies.back().get());
    return bodies.back().get();
  }
};

/// Counts every Bullet step.
struct StepCounter : btActionInterface {
  void updateAction(btCollisionWorld*, btScalar) override { ++steps; }
  void debugDraw(btIDebugDraw*) override {}
  std::size_t steps = 0;
};

CoupledWorldSettings smallFluid() {
  CoupledWorldSettings s;
  s.fluid.particle_radius = 0.01;
  return s;
}

TEST(CoupledWorld, FluidForcesSetBeforeTheStartAct) {
  World w;
  CoupledWorld fluid(w.world, smallFluid());
  fluid.addFluidBlock(Vec3(-0.05, 0.3, -0.05), Vec3(0.05, 0.4, 0.05));
  // Set before the first advance(): kept and handed to the simulation when it starts.
  fluid.setFluidForces([](const FluidState&, std::vector<Vec3>& a, double) {
    for (Vec3& ai : a)
      ai.y() += 9.81;  // cancels the world's gravity
  });
  fluid.advance(0.05);
  const FluidState& st = fluid.simulation().fluid().state();
  for (std::size_t i = 0; i < st.size(); ++i)
    EXPECT_NEAR(st.velocity[i].y(), 0.0, 1e-4);  // -9.81f as a float: a small remainder
}

TEST(CoupledWorld, OneBulletStepPerFluidSubStepAndGravityFromTheWorld) {
  World w;
  w.world.setGravity(btVector3(0, -4.0f, 0));
  btRigidBody* floor =
      w.add(std::make_unique<btBoxShape>(btVector3(0.5f, 0.05f, 0.5f)), 0, btVector3(0, -0.05f, 0));
  StepCounter counter;
  w.world.addAction(&counter);
  CoupledWorld fluid(w.world, smallFluid());
  fluid.addFluidBlock(Vec3(-0.05, 0.3, -0.05), Vec3(0.05, 0.4, 0.05));
  fluid.couple(floor, {"floor"});
  const std::size_t steps = fluid.advance(0.05);
  EXPECT_EQ(counter.steps, steps);
  EXPECT_EQ(fluid.simulation().steps(), steps);
  EXPECT_NEAR(fluid.time(), 0.05, 1e-12);
  // The block falls freely at the world's gravity (-4 m/s^2), not the default -9.81.
  double vy = 0;
  const FluidState& st = fluid.simulation().fluid().state();
  for (std::size_t i = 0; i < st.size(); ++i)
    vy += st.velocity[i].y() / double(st.size());
  EXPECT_NEAR(vy, -4.0 * 0.05, 0.01);
  w.world.removeAction(&counter);
}

TEST(CoupledWorld, SteppingTheWorldBehindItsBackIsAnError) {
  World w;
  btRigidBody* ball = w.add(std::make_unique<btSphereShape>(0.05f), 1.0, btVector3(0, 1, 0));
  CoupledWorld fluid(w.world, smallFluid());
  fluid.addFluidBlock(Vec3(-0.05, 0, -0.05), Vec3(0.05, 0.1, 0.05));
  fluid.couple(ball);
  fluid.advance(0.01);
  w.world.stepSimulation(1.0f / 60);  // the user's own step
  try {
    fluid.advance(0.01);
    FAIL() << "expected std::logic_error";
  } catch (const std::logic_error& e) {
    EXPECT_NE(std::string(e.what()).find("outside CoupledWorld::advance"), std::string::npos)
        << e.what();
  }
}

TEST(CoupledWorld, UserForcesActOverTheFrameAndDoNotLeak) {
  World w;
  btRigidBody* ball = w.add(std::make_unique<btSphereShape>(0.05f), 2.0, btVector3(0, 1, 0));
  ball->setDamping(0, 0);
  CoupledWorld fluid(w.world, smallFluid());
  fluid.addFluidBlock(Vec3(1, 0, 1), Vec3(1.1, 0.1, 1.1));  // far away
  fluid.couple(ball);
  // 2 kg, 19.62 N up: weightless during this frame only.
  ball->applyCentralForce(btVector3(0, 2.0f * 9.81f, 0));
  const std::size_t steps = fluid.advance(0.02);
  EXPECT_GT(steps, 1u);
  EXPECT_NEAR(ball->getLinearVelocity().y(), 0.0, 1e-4);
  EXPECT_EQ(ball->getTotalForce().length(), 0.0f);  // nothing left for the next step
  fluid.advance(0.02);
  EXPECT_NEAR(ball->getLinearVelocity().y(), -9.81 * 0.02, 1e-3);
}

TEST(CoupledWorld, KinematicBodyMovesWithItsVelocityAndPushesTheFluid) {
  World w;
  btRigidBody* floor =
      w.add(std::make_unique<btBoxShape>(btVector3(0.5f, 0.05f, 0.5f)), 0, btVector3(0, -0.05f, 0));
  btRigidBody* paddle = w.add(std::make_unique<btBoxShape>(btVector3(0.02f, 0.1f, 0.1f)), 0,
                              btVector3(-0.2f, 0.1f, 0));
  paddle->setCollisionFlags(paddle->getCollisionFlags() | btCollisionObject::CF_KINEMATIC_OBJECT);
  CoupledWorld fluid(w.world, smallFluid());
  fluid.addFluidBlock(Vec3(-0.16, 0.0, -0.08), Vec3(0.0, 0.08, 0.08));
  fluid.couple(floor, {"floor"});
  fluid.couple(paddle, {"paddle"});
  fluid.setKinematicVelocity(paddle, Vec3(0.5, 0, 0), Vec3::Zero());
  for (int f = 0; f < 10; ++f) {
    fluid.advance(0.01);
    EXPECT_EQ(fluid.simulation().countPenetrating(), 0u);
  }
  EXPECT_NEAR(double(paddle->getCenterOfMassPosition().x()), -0.2 + 0.05, 1e-5);
  EXPECT_NEAR(fluid.simulation().bodyStates()[1].position.x(), -0.2 + 0.05, 1e-5);
  EXPECT_EQ(fluid.simulation().maxPenetrating(), 0u);
  // The paddle is one-way: no wrench on it.
  EXPECT_EQ(fluid.simulation().lastWrenches()[1].force.norm(), 0.0);
  // Fluid in front of the paddle moves with it.
  double vx_front = 0;
  int front = 0;
  const FluidState& st = fluid.simulation().fluid().state();
  for (std::size_t i = 0; i < st.size(); ++i)
    if (st.position[i].x() < -0.1) vx_front += st.velocity[i].x(), ++front;
  ASSERT_GT(front, 0);
  EXPECT_GT(vx_front / front, 0.25);
}

TEST(CoupledWorld, FluidInsideABodyTheUserMovedIsExpelledInTheNextStep) {
  // User code puts a box down in the middle of the water, on the floor: the fluid it now
  // covers leaves it in the next step, to the box's nearest free side (never into the
  // floor, which the box rests on).
  World w;
  btRigidBody* floor =
      w.add(std::make_unique<btBoxShape>(btVector3(0.5f, 0.05f, 0.5f)), 0, btVector3(0, -0.05f, 0));
  const btVector3 half(0.07f, 0.04f, 0.06f);
  btRigidBody* box = w.add(std::make_unique<btBoxShape>(half), 2.0, btVector3(0, 0.5f, 0));
  CoupledWorld fluid(w.world, smallFluid());
  fluid.addFluidBlock(Vec3(-0.2, 0.0, -0.2), Vec3(0.2, 0.1, 0.2));
  fluid.couple(floor, {"floor"});
  fluid.couple(box, {"box"});
  fluid.advance(0.005);
  ASSERT_EQ(fluid.simulation().maxPenetrating(), 0u);
  btTransform moved;
  moved.setIdentity();
  moved.setOrigin(btVector3(0.01f, half.y(), -0.02f));
  box->setWorldTransform(moved);
  box->setLinearVelocity(btVector3(0, 0, 0));
  // Fluid centres under the box now (the box's shape, its new pose).
  std::size_t covered = 0;
  const FluidState& st = fluid.simulation().fluid().state();
  for (std::size_t i = 0; i < st.size(); ++i) {
    const Vec3 d = st.position[i] - Vec3(0.01, half.y(), -0.02);
    covered +=
        std::abs(d.x()) < half.x() && std::abs(d.y()) < half.y() && std::abs(d.z()) < half.z();
  }
  EXPECT_GT(covered, 50u);
  const std::size_t before = fluid.simulation().fluidParticles();
  fluid.advance(0.0005);
  EXPECT_EQ(fluid.simulation().maxPenetrating(), 0u);
  EXPECT_EQ(fluid.simulation().lostParticles(), 0u);
  EXPECT_EQ(fluid.simulation().fluidParticles(), before);
  for (std::size_t i = 0; i < st.size(); ++i)
    EXPECT_GT(st.position[i].y(), 0.0) << "pushed into the floor";
}

TEST(CoupledWorld, CoupleAfterStartIsRefused) {
  World w;
  btRigidBody* ball = w.add(std::make_unique<btSphereShape>(0.05f), 1.0, btVector3(0, 1, 0));
  CoupledWorld fluid(w.world, smallFluid());
  fluid.addFluidBlock(Vec3(-0.05, 0, -0.05), Vec3(0.05, 0.1, 0.05));
  fluid.advance(0.001);
  EXPECT_THROW(fluid.couple(ball), std::logic_error);
  EXPECT_THROW(fluid.addFluidBlock(Vec3::Zero(), Vec3::Ones()), std::logic_error);
}

}  // namespace
}  // namespace wake
