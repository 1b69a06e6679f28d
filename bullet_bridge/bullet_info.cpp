#include "bullet_bridge/bullet_info.hpp"

#include <btBulletDynamicsCommon.h>

#include <memory>

namespace wake::bullet {

int version() {
  return btGetVersion();
}

bool doublePrecision() {
  return sizeof(btScalar) == sizeof(double);
}

double freeFallDrop(double seconds, double dt) {
  // Owned in dependency order: destroyed in reverse.
  auto config = std::make_unique<btDefaultCollisionConfiguration>();
  auto dispatcher = std::make_unique<btCollisionDispatcher>(config.get());
  auto broadphase = std::make_unique<btDbvtBroadphase>();
  auto solver = std::make_unique<btSequentialImpulseConstraintSolver>();
  auto world = std::make_unique<btDiscreteDynamicsWorld>(dispatcher.get(), broadphase.get(),
                                                         solver.get(), config.get());
  world->setGravity(btVector3(0, -9.81, 0));
  auto shape = std::make_unique<btSphereShape>(btScalar(0.1));
  btVector3 inertia(0, 0, 0);
  shape->calculateLocalInertia(1.0, inertia);
  btRigidBody::btRigidBodyConstructionInfo info(1.0, nullptr, shape.get(), inertia);
  auto body = std::make_unique<btRigidBody>(info);
  world->addRigidBody(body.get());
  const double y0 = body->getWorldTransform().getOrigin().y();
  const int steps = static_cast<int>(seconds / dt + 0.5);
  for (int i = 0; i < steps; ++i)
    world->stepSimulation(btScalar(dt), 0);
  const double y1 = body->getWorldTransform().getOrigin().y();
  world->removeRigidBody(body.get());
  return y1 - y0;
}

}  // namespace wake::bullet
