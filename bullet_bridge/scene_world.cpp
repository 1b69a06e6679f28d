#include "bullet_bridge/scene_world.hpp"

#include "bullet_bridge/bullet_shapes.hpp"
#include "bullet_bridge/convert.hpp"

#include <BulletCollision/Gimpact/btGImpactCollisionAlgorithm.h>
#include <btBulletDynamicsCommon.h>

#include <stdexcept>

namespace wake {

using bullet::toBt;
using bullet::toPose;
using bullet::toVec;

namespace {}  // namespace

struct SceneWorld::BulletParts {
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world{&dispatcher, &broadphase, &solver, &config};
  bullet::ShapeStore shapes;
  std::vector<std::unique_ptr<btDefaultMotionState>> motion;
  std::vector<std::unique_ptr<btRigidBody>> bodies;

  BulletParts() { btGImpactCollisionAlgorithm::registerAlgorithm(&dispatcher); }
  ~BulletParts() {
    for (auto& b : bodies)
      world.removeRigidBody(b.get());
  }
};

SceneWorld::SceneWorld(const SimulationSettings& sim, const std::vector<BodySpec>& bodies)
    : bullet_(std::make_unique<BulletParts>()) {
  if (!sim.bodies.empty())
    throw std::invalid_argument("SceneWorld: settings.bodies must be empty (bodies come as specs)");
  btDiscreteDynamicsWorld& world = bullet_->world;
  world.setGravity(toBt(sim.gravity));
  // Bodies' overlaps are undone by moving them apart (split impulse), not by giving them
  // velocity (Bullet's default below 4 cm of overlap): a body held by fluid pressed
  // against the floor, with another body resting on it, must not throw that one off.
  world.getSolverInfo().m_splitImpulse = 1;
  world.getSolverInfo().m_splitImpulsePenetrationThreshold = 0;
  coupled_ = std::make_unique<CoupledWorld>(world, static_cast<const SolverSettings&>(sim));
  for (const FluidBlock& b : sim.blocks)
    coupled_->addFluidBlock(b);

  for (std::size_t k = 0; k < bodies.size(); ++k) {
    const BodySpec& spec = bodies[k];
    const std::string field = "bodies[" + std::to_string(k) + "]";
    const bool dynamic = spec.kind == BodyKind::Dynamic;
    bullet::BuiltShape shape = bullet::buildShape(spec.shape, dynamic, sim.fluid.particle_radius,
                                                  bullet_->shapes, field + ".shape");
    BodyMass m;
    btCollisionShape* collision = shape.collision;
    if (dynamic) {
      const double volume = shape.exact->volume();
      m.mass = spec.mass > 0 ? spec.mass : spec.density * volume;
      if (!(m.mass > 0) || !std::isfinite(m.mass))
        throw std::invalid_argument(field + ".density: gives no finite positive mass");
      if (spec.shape.type == "compound") {
        // Bullet's principal-axis transform: the body frame is the centre of mass, the
        // children are placed relative to it (masses in proportion to child volumes).
        auto* compound = static_cast<btCompoundShape*>(collision);
        std::vector<btScalar> masses;
        double total = 0;
        for (int c = 0; c < compound->getNumChildShapes(); ++c) {
          const double v = bullet::exactShape(*compound->getChildShape(c))->volume();
          masses.push_back(btScalar(v));
          total += v;
        }
        for (btScalar& mm : masses)
          mm = btScalar(m.mass * double(mm) / total);
        btTransform principal;
        btVector3 inertia;
        compound->calculatePrincipalAxisTransform(masses.data(), principal, inertia);
        auto shifted = std::make_unique<btCompoundShape>();
        for (int c = 0; c < compound->getNumChildShapes(); ++c)
          shifted->addChildShape(principal.inverse() * compound->getChildTransform(c),
                                 compound->getChildShape(c));
        collision = shifted.get();
        bullet_->shapes.shapes.push_back(std::move(shifted));
        m.com = toPose(principal);
        m.inertia = toVec(inertia);
      } else {
        btVector3 inertia;
        collision->calculateLocalInertia(btScalar(m.mass), inertia);
        m.inertia = toVec(inertia);
      }
    }
    const Pose body_pose = {spec.pose.toWorld(m.com.position),
                            (spec.pose.orientation * m.com.orientation).normalized()};
    auto motion = std::make_unique<btDefaultMotionState>(toBt(body_pose));
    btRigidBody::btRigidBodyConstructionInfo info(btScalar(m.mass), motion.get(), collision,
                                                  toBt(m.inertia));
    info.m_friction = btScalar(spec.friction);
    auto body = std::make_unique<btRigidBody>(info);
    if (spec.kind == BodyKind::Kinematic) {
      body->setCollisionFlags(body->getCollisionFlags() | btCollisionObject::CF_KINEMATIC_OBJECT);
      body->setActivationState(DISABLE_DEACTIVATION);
    }
    if (spec.kind != BodyKind::Static) {
      body->setLinearVelocity(toBt(spec.linear_velocity));
      body->setAngularVelocity(toBt(spec.angular_velocity));
    }
    world.addRigidBody(body.get());
    BodyCoupling c(static_cast<const BodyFluidSettings&>(spec));
    if (spec.shape.type == "tank") c.shape = shape.exact;  // the container, not 5 boxes
    coupled_->couple(body.get(), c);
    bullet_->motion.push_back(std::move(motion));
    bullet_->bodies.push_back(std::move(body));
    masses_.push_back(m);
  }
}

SceneWorld::~SceneWorld() {
  coupled_.reset();  // detaches from the world before the world goes
}

}  // namespace wake
