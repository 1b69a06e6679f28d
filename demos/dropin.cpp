// A Wake fluid dropped into an existing Bullet world (README.md shows this file).
#include <bullet_bridge/coupled_world.hpp>

#include <btBulletDynamicsCommon.h>

#include <cstdio>
#include <memory>
#include <vector>

int main() {
  // Your Bullet world, as you already have it: an open box of 5 static walls and a crate.
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
  world.setGravity(btVector3(0, -9.81f, 0));
  std::vector<std::unique_ptr<btCollisionShape>> shapes;
  std::vector<std::unique_ptr<btRigidBody>> bodies;
  auto add = [&](btCollisionShape* shape, btScalar mass, btVector3 at) {
    btVector3 inertia(0, 0, 0);
    if (mass > 0) shape->calculateLocalInertia(mass, inertia);
    btRigidBody::btRigidBodyConstructionInfo info(mass, nullptr, shape, inertia);
    info.m_startWorldTransform.setOrigin(at);
    shapes.emplace_back(shape);
    bodies.push_back(std::make_unique<btRigidBody>(info));
    world.addRigidBody(bodies.back().get());
    return bodies.back().get();
  };
  add(new btBoxShape(btVector3(0.22f, 0.02f, 0.12f)), 0, btVector3(0, -0.02f, 0));  // floor
  add(new btBoxShape(btVector3(0.02f, 0.15f, 0.12f)), 0, btVector3(-0.2f, 0.15f, 0));
  add(new btBoxShape(btVector3(0.02f, 0.15f, 0.12f)), 0, btVector3(0.2f, 0.15f, 0));
  add(new btBoxShape(btVector3(0.22f, 0.15f, 0.02f)), 0, btVector3(0, 0.15f, -0.1f));
  add(new btBoxShape(btVector3(0.22f, 0.15f, 0.02f)), 0, btVector3(0, 0.15f, 0.1f));
  btRigidBody* crate = add(new btBoxShape(btVector3(0.05f, 0.03f, 0.05f)), 0.15f,
                           btVector3(0, 0.2f, 0));  // 500 kg/m^3

  // Wake: a block of water, every body coupled, then advance by frame time.
  wake::CoupledWorldSettings settings;
  settings.fluid.particle_radius = 0.005;  // m
  settings.method = wake::CouplingMethod::Global;
  wake::CoupledWorld water(world, settings);
  water.addFluidBlock({-0.18, 0.0, -0.08}, {0.18, 0.1, 0.08});
  for (auto& body : bodies)
    water.couple(body.get());
  for (int frame = 1; frame <= 30; ++frame) {
    water.advance(1.0 / 60);  // instead of world.stepSimulation(1.0 / 60)
    std::printf("t %.3f s  crate y %.4f m\n", water.time(), crate->getCenterOfMassPosition().y());
  }
  const wake::Simulation& sim = water.simulation();
  std::printf("%zu fluid particles, %zu steps, max penetrating %zu\n", sim.fluidParticles(),
              static_cast<std::size_t>(sim.steps()), sim.maxPenetrating());
  // The crate floats: above the floor and not through the surface.
  const double y = crate->getCenterOfMassPosition().y();
  return sim.maxPenetrating() == 0 && y > 0.06 && y < 0.14 ? 0 : 1;
}
