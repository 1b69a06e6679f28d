#include "bullet_bridge/coupled_world.hpp"

#include "bullet_bridge/bullet_shapes.hpp"
#include "bullet_bridge/convert.hpp"

#include <BulletDynamics/Dynamics/btActionInterface.h>
#include <btBulletDynamicsCommon.h>

#include <cmath>
#include <stdexcept>

namespace wake {

using bullet::toBt;
using bullet::toMat;
using bullet::toPose;
using bullet::toVec;

namespace {

BodyKind kindOf(const btRigidBody& body) {
  if (body.isKinematicObject()) return BodyKind::Kinematic;
  if (body.isStaticObject() || body.getInvMass() == btScalar(0)) return BodyKind::Static;
  return BodyKind::Dynamic;
}

/// Undoes Bullet's linear/angular factor on a force it has already scaled.
Vec3 unscaled(const Vec3& v, const Vec3& factor) {
  Vec3 out;
  for (int k = 0; k < 3; ++k)
    out[k] = factor[k] != 0.0 ? v[k] / factor[k] : 0.0;
  return out;
}

}  // namespace

/// Sees every Bullet step: steps not taken by advance() are counted.
class CoupledWorld::StepWatch final : public btActionInterface {
 public:
  void updateAction(btCollisionWorld*, btScalar) override {
    if (!inside_advance_) ++external_;
  }
  void debugDraw(btIDebugDraw*) override {}
  bool inside_advance_ = false;
  std::size_t external_ = 0;
};

/// The coupled Bullet bodies as the coupling's RigidBodies.
class CoupledWorld::Bodies final : public RigidBodies {
 public:
  Bodies(CoupledWorld& owner) : owner_(owner) {
    const std::size_t n = owner.bodies_.size();
    user_force_.assign(n, Vec3::Zero());
    user_torque_.assign(n, Vec3::Zero());
  }

  std::size_t count() const override { return owner_.bodies_.size(); }

  RigidState state(std::size_t b) const override {
    const btRigidBody& body = *owner_.bodies_[b];
    RigidState s;
    s.pose = toPose(body.getCenterOfMassTransform());
    if (kindOf(body) == BodyKind::Kinematic) {
      s.linear_velocity = owner_.kinematic_linear_[b];
      s.angular_velocity = owner_.kinematic_angular_[b];
    } else {
      s.linear_velocity = toVec(body.getLinearVelocity());
      s.angular_velocity = toVec(body.getAngularVelocity());
    }
    return s;
  }

  /// Forces the user applied before this frame: Bullet clears forces after each of its
  /// steps, so they are applied again at every sub-step of the frame.
  void beginFrame() {
    for (std::size_t b = 0; b < count(); ++b) {
      const btRigidBody& body = *owner_.bodies_[b];
      user_force_[b] = unscaled(toVec(body.getTotalForce()), toVec(body.getLinearFactor()));
      user_torque_[b] = unscaled(toVec(body.getTotalTorque()), toVec(body.getAngularFactor()));
    }
  }

  void predict(double dt, std::vector<RigidPrediction>& out) const override {
    out.resize(count());
    for (std::size_t b = 0; b < count(); ++b) {
      const btRigidBody& body = *owner_.bodies_[b];
      RigidPrediction& p = out[b];
      p = RigidPrediction{};
      const BodyKind kind = kindOf(body);
      Vec3 linear = Vec3::Zero(), angular = Vec3::Zero();
      double linear_damping = 1.0, angular_damping = 1.0;
      if (kind == BodyKind::Dynamic) {
        // As Bullet's step before contacts: gravity and user forces, then damping.
        p.inverse_mass = double(body.getInvMass());
        p.inverse_inertia_world = toMat(body.getInvInertiaTensorWorld());
        const Vec3 lf = toVec(body.getLinearFactor()), af = toVec(body.getAngularFactor());
        linear = toVec(body.getGravity()).cwiseProduct(lf) +
                 (user_force_[b] * p.inverse_mass).cwiseProduct(lf);
        angular = p.inverse_inertia_world * user_torque_[b].cwiseProduct(af);
        linear_damping = std::pow(1.0 - double(body.getLinearDamping()), dt);
        angular_damping = std::pow(1.0 - double(body.getAngularDamping()), dt);
      }
      p.state = stepBody(kind, state(b), linear, angular, dt, linear_damping, angular_damping);
    }
  }

  /// Per body (kPerBody numbers): world and interpolation transforms (basis row by row,
  /// then origin: Bullet's own numbers, no quaternion round trip), linear and angular
  /// velocities and their interpolation copies, activation state, deactivation time, and
  /// the kinematic velocities Wake moves a kinematic body with.
  static constexpr std::size_t kPerBody = 12 + 12 + 12 + 2 + 6;

  std::vector<double> saveState() const override {
    std::vector<double> out;
    out.reserve(kPerBody * count());
    auto put = [&](const btVector3& v) {
      for (int k = 0; k < 3; ++k)
        out.push_back(double(v[k]));
    };
    auto putTransform = [&](const btTransform& t) {
      for (int r = 0; r < 3; ++r)
        put(t.getBasis()[r]);
      put(t.getOrigin());
    };
    for (std::size_t b = 0; b < count(); ++b) {
      const btRigidBody& body = *owner_.bodies_[b];
      putTransform(body.getWorldTransform());
      putTransform(body.getInterpolationWorldTransform());
      put(body.getLinearVelocity());
      put(body.getAngularVelocity());
      put(body.getInterpolationLinearVelocity());
      put(body.getInterpolationAngularVelocity());
      out.push_back(double(body.getActivationState()));
      out.push_back(double(body.getDeactivationTime()));
      out.insert(out.end(), owner_.kinematic_linear_[b].data(),
                 owner_.kinematic_linear_[b].data() + 3);
      out.insert(out.end(), owner_.kinematic_angular_[b].data(),
                 owner_.kinematic_angular_[b].data() + 3);
    }
    saveContacts(out);
    return out;
  }

  void loadState(const std::vector<double>& state) override {
    if (state.size() < kPerBody * count() + 1)
      throw std::invalid_argument("rigid-body state: " + std::to_string(state.size()) +
                                  " numbers for " + std::to_string(count()) + " bodies (" +
                                  std::to_string(kPerBody) + " each, then the contacts)");
    const double* v = state.data();
    auto get = [&]() {
      const btVector3 out{btScalar(v[0]), btScalar(v[1]), btScalar(v[2])};
      v += 3;
      return out;
    };
    auto getTransform = [&]() {
      const btVector3 r0 = get(), r1 = get(), r2 = get();
      const btVector3 origin = get();
      return btTransform(
          btMatrix3x3(r0.x(), r0.y(), r0.z(), r1.x(), r1.y(), r1.z(), r2.x(), r2.y(), r2.z()),
          origin);
    };
    for (std::size_t b = 0; b < count(); ++b) {
      btRigidBody& body = *owner_.bodies_[b];
      const btTransform world = getTransform(), interpolation = getTransform();
      const btVector3 linear = get(), angular = get();
      const btVector3 interpolation_linear = get(), interpolation_angular = get();
      const int activation = static_cast<int>(v[0]);
      const btScalar deactivation = btScalar(v[1]);
      v += 2;
      owner_.kinematic_linear_[b] = Vec3(v[0], v[1], v[2]);
      owner_.kinematic_angular_[b] = Vec3(v[3], v[4], v[5]);
      v += 6;
      body.setLinearVelocity(linear);
      body.setAngularVelocity(angular);
      body.setCenterOfMassTransform(world);  // also updates the world inertia tensor
      if (body.getMotionState()) body.getMotionState()->setWorldTransform(world);
      body.setInterpolationWorldTransform(interpolation);
      body.setInterpolationLinearVelocity(interpolation_linear);
      body.setInterpolationAngularVelocity(interpolation_angular);
      body.forceActivationState(activation);
      body.setDeactivationTime(deactivation);
      // Bullet's broadphase must see the bodies where they are now.
      owner_.world_.updateSingleAabb(&body);
    }
    loadContacts(state, static_cast<std::size_t>(v - state.data()));
  }

  /// Bullet's contact cache: each contact manifold between coupled bodies, in the
  /// dispatcher's order (the order its solver visits them), with every field of its
  /// points (among them the impulses it warm-starts the next step with). Appended as:
  /// manifold count, then per manifold body0, body1 (indices of coupled bodies), point
  /// count and kPerPoint numbers per point.
  static constexpr std::size_t kPerPoint = 5 * 3 + 5 + 5 + 6 + 3 + 1 + 2 * 3;

  void saveContacts(std::vector<double>& out) const {
    btDispatcher& dispatcher = *owner_.world_.getDispatcher();
    const std::size_t at = out.size();
    out.push_back(0.0);
    std::size_t saved = 0;
    for (int m = 0; m < dispatcher.getNumManifolds(); ++m) {
      const btPersistentManifold& manifold = *dispatcher.getManifoldByIndexInternal(m);
      const int a = indexOf(manifold.getBody0()), b = indexOf(manifold.getBody1());
      if (a < 0 || b < 0) continue;  // a body of the world that is not coupled
      ++saved;
      out.push_back(a);
      out.push_back(b);
      out.push_back(manifold.getNumContacts());
      for (int k = 0; k < manifold.getNumContacts(); ++k)
        savePoint(manifold.getContactPoint(k), out);
    }
    out[at] = double(saved);
  }

  void loadContacts(const std::vector<double>& state, std::size_t at) {
    auto fail = [] {
      throw std::invalid_argument("rigid-body state: the contacts do not fit the bodies");
    };
    // The manifolds of the pairs that overlap now, then their points as saved.
    owner_.world_.performDiscreteCollisionDetection();
    btDispatcher& dispatcher = *owner_.world_.getDispatcher();
    std::vector<btPersistentManifold*> live, ordered;
    for (int m = 0; m < dispatcher.getNumManifolds(); ++m)
      live.push_back(dispatcher.getManifoldByIndexInternal(m));
    const std::size_t manifolds = static_cast<std::size_t>(state[at++]);
    for (std::size_t j = 0; j < manifolds; ++j) {
      if (at + 3 > state.size()) fail();
      const std::size_t a = static_cast<std::size_t>(state[at]),
                        b = static_cast<std::size_t>(state[at + 1]);
      const int points = static_cast<int>(state[at + 2]);
      at += 3;
      if (a >= count() || b >= count() || points < 0 || points > MANIFOLD_CACHE_SIZE ||
          at + points * kPerPoint > state.size())
        fail();
      std::vector<btManifoldPoint> saved(points);
      for (btManifoldPoint& p : saved)
        at = loadPoint(state, at, p);
      // The live manifold of the same pair (and, for compound shapes, the same parts).
      btPersistentManifold** match = nullptr;
      for (btPersistentManifold*& m : live) {
        if (!m || m->getBody0() != owner_.bodies_[a] || m->getBody1() != owner_.bodies_[b])
          continue;
        if (!match) match = &m;
        if (points > 0 && m->getNumContacts() > 0 &&
            m->getContactPoint(0).m_index0 == saved[0].m_index0 &&
            m->getContactPoint(0).m_index1 == saved[0].m_index1) {
          match = &m;
          break;
        }
      }
      if (!match) continue;  // no longer overlapping: Bullet would have dropped it too
      btPersistentManifold* manifold = *match;
      *match = nullptr;
      manifold->clearManifold();
      for (const btManifoldPoint& p : saved)
        manifold->addManifoldPoint(p, true);
      ordered.push_back(manifold);
    }
    if (at != state.size()) fail();
    // The dispatcher's order as saved; manifolds new since then after them.
    for (btPersistentManifold* m : live)
      if (m) ordered.push_back(m);
    btPersistentManifold** array = dispatcher.getInternalManifoldPointer();
    for (std::size_t k = 0; k < ordered.size(); ++k) {
      array[k] = ordered[k];
      ordered[k]->m_index1a = static_cast<int>(k);
    }
  }

  int indexOf(const btCollisionObject* object) const {
    for (std::size_t b = 0; b < count(); ++b)
      if (owner_.bodies_[b] == object) return static_cast<int>(b);
    return -1;
  }

  static void savePoint(const btManifoldPoint& p, std::vector<double>& out) {
    for (const btVector3* v : {&p.m_localPointA, &p.m_localPointB, &p.m_positionWorldOnB,
                               &p.m_positionWorldOnA, &p.m_normalWorldOnB})
      for (int k = 0; k < 3; ++k)
        out.push_back(double((*v)[k]));
    for (const btScalar x : {p.m_distance1, p.m_combinedFriction, p.m_combinedRollingFriction,
                             p.m_combinedSpinningFriction, p.m_combinedRestitution})
      out.push_back(double(x));
    for (const int i : {p.m_partId0, p.m_partId1, p.m_index0, p.m_index1, p.m_contactPointFlags})
      out.push_back(double(i));
    for (const btScalar x : {p.m_appliedImpulse, p.m_prevRHS, p.m_appliedImpulseLateral1,
                             p.m_appliedImpulseLateral2, p.m_contactMotion1, p.m_contactMotion2})
      out.push_back(double(x));
    for (const btScalar x : {p.m_contactCFM, p.m_contactERP, p.m_frictionCFM})
      out.push_back(double(x));
    out.push_back(double(p.m_lifeTime));
    for (const btVector3* v : {&p.m_lateralFrictionDir1, &p.m_lateralFrictionDir2})
      for (int k = 0; k < 3; ++k)
        out.push_back(double((*v)[k]));
  }

  static std::size_t loadPoint(const std::vector<double>& in, std::size_t at, btManifoldPoint& p) {
    auto scalar = [&]() { return btScalar(in[at++]); };
    auto integer = [&]() { return static_cast<int>(in[at++]); };
    for (btVector3* v : {&p.m_localPointA, &p.m_localPointB, &p.m_positionWorldOnB,
                         &p.m_positionWorldOnA, &p.m_normalWorldOnB})
      for (int k = 0; k < 3; ++k)
        (*v)[k] = scalar();
    for (btScalar* x : {&p.m_distance1, &p.m_combinedFriction, &p.m_combinedRollingFriction,
                        &p.m_combinedSpinningFriction, &p.m_combinedRestitution})
      *x = scalar();
    for (int* i : {&p.m_partId0, &p.m_partId1, &p.m_index0, &p.m_index1, &p.m_contactPointFlags})
      *i = integer();
    for (btScalar* x : {&p.m_appliedImpulse, &p.m_prevRHS, &p.m_appliedImpulseLateral1,
                        &p.m_appliedImpulseLateral2, &p.m_contactMotion1, &p.m_contactMotion2})
      *x = scalar();
    for (btScalar* x : {&p.m_contactCFM, &p.m_contactERP, &p.m_frictionCFM})
      *x = scalar();
    p.m_lifeTime = integer();
    for (btVector3* v : {&p.m_lateralFrictionDir1, &p.m_lateralFrictionDir2})
      for (int k = 0; k < 3; ++k)
        (*v)[k] = scalar();
    p.m_userPersistentData = nullptr;
    return at;
  }

  void step(double dt, const std::vector<Wrench>& fluid) override {
    for (std::size_t b = 0; b < count(); ++b) {
      btRigidBody& body = *owner_.bodies_[b];
      switch (kindOf(body)) {
        case BodyKind::Static:
          break;
        case BodyKind::Kinematic: {
          // Bullet derives a kinematic body's velocity from its motion over the step.
          const RigidState s = state(b);
          const btTransform target =
              toBt(integratePose(s.pose, s.linear_velocity, s.angular_velocity, dt));
          if (body.getMotionState()) body.getMotionState()->setWorldTransform(target);
          body.setWorldTransform(target);
          break;
        }
        case BodyKind::Dynamic:
          body.clearForces();
          body.applyCentralForce(toBt(user_force_[b] + fluid[b].force));
          body.applyTorque(toBt(user_torque_[b] + fluid[b].torque));
          body.activate(true);
          break;
      }
    }
    owner_.watch_->inside_advance_ = true;
    owner_.world_.stepSimulation(btScalar(dt), 0, btScalar(dt));
    owner_.watch_->inside_advance_ = false;
  }

 private:
  CoupledWorld& owner_;
  std::vector<Vec3> user_force_, user_torque_;
};

CoupledWorld::CoupledWorld(btDiscreteDynamicsWorld& world, CoupledWorldSettings settings)
    : world_(world), settings_(std::move(settings)), watch_(std::make_unique<StepWatch>()) {
  world_.addAction(watch_.get());
}

CoupledWorld::~CoupledWorld() {
  world_.removeAction(watch_.get());
}

void CoupledWorld::addFluidBlock(const Vec3& min, const Vec3& max, const Vec3& velocity) {
  addFluidBlock(FluidBlock{min, max, velocity});
}

void CoupledWorld::addFluidBlock(const FluidBlock& block) {
  if (sim_) throw std::logic_error("CoupledWorld::addFluidBlock after the first advance()");
  blocks_.push_back(block);
}

std::size_t CoupledWorld::couple(btRigidBody* body, const BodyCoupling& coupling) {
  if (sim_) throw std::logic_error("CoupledWorld::couple after the first advance()");
  if (!body) throw std::invalid_argument("CoupledWorld::couple: null body");
  for (const btRigidBody* other : bodies_)
    if (other == body) throw std::invalid_argument("CoupledWorld::couple: body coupled twice");
  bodies_.push_back(body);
  BodyCoupling c = coupling;
  if (c.name.empty()) c.name = "body" + std::to_string(bodies_.size() - 1);
  couplings_.push_back(c);
  // A kinematic body keeps the velocity it has now until told otherwise.
  kinematic_linear_.push_back(toVec(body->getLinearVelocity()));
  kinematic_angular_.push_back(toVec(body->getAngularVelocity()));
  return bodies_.size() - 1;
}

void CoupledWorld::setKinematicVelocity(btRigidBody* body, const Vec3& linear,
                                        const Vec3& angular) {
  for (std::size_t b = 0; b < bodies_.size(); ++b) {
    if (bodies_[b] != body) continue;
    if (!body->isKinematicObject())
      throw std::invalid_argument("setKinematicVelocity: body '" + couplings_[b].name +
                                  "' is not kinematic");
    kinematic_linear_[b] = linear;
    kinematic_angular_[b] = angular;
    body->setLinearVelocity(toBt(linear));
    body->setAngularVelocity(toBt(angular));
    return;
  }
  throw std::invalid_argument("setKinematicVelocity: body is not coupled");
}

void CoupledWorld::setFluidForces(FluidForces forces) {
  fluid_forces_ = std::move(forces);
  if (sim_) sim_->setFluidForces(fluid_forces_);
}

void CoupledWorld::start() {
  if (sim_) return;
  SimulationSettings s;
  static_cast<SolverSettings&>(s) = settings_;
  s.gravity = toVec(world_.getGravity());
  s.blocks = blocks_;
  for (std::size_t b = 0; b < bodies_.size(); ++b) {
    const btRigidBody& body = *bodies_[b];
    BodySettings bs;
    static_cast<BodyFluidSettings&>(bs) = couplings_[b];
    bs.kind = kindOf(body);
    bs.coupling = bs.kind == BodyKind::Dynamic ? couplings_[b].coupling : CouplingMode::OneWay;
    try {
      bs.shape =
          couplings_[b].shape ? couplings_[b].shape : bullet::exactShape(*body.getCollisionShape());
    } catch (const std::exception& e) {
      throw std::invalid_argument("body '" + bs.name + "': " + e.what());
    }
    bs.pose = toPose(body.getCenterOfMassTransform());
    bs.linear_velocity =
        bs.kind == BodyKind::Kinematic ? kinematic_linear_[b] : toVec(body.getLinearVelocity());
    bs.angular_velocity =
        bs.kind == BodyKind::Kinematic ? kinematic_angular_[b] : toVec(body.getAngularVelocity());
    if (body.getInvMass() > 0) {
      bs.mass = 1.0 / double(body.getInvMass());
      bs.inertia = toVec(body.getLocalInertia());
    }
    s.bodies.push_back(std::move(bs));
  }
  auto rigid = std::make_unique<Bodies>(*this);
  rigid_ = rigid.get();
  sim_ = std::make_unique<Simulation>(std::move(s), std::move(rigid));
  if (fluid_forces_) sim_->setFluidForces(fluid_forces_);
}

std::size_t CoupledWorld::advance(double frame_time) {
  if (!(frame_time >= 0) || !std::isfinite(frame_time))
    throw std::invalid_argument("CoupledWorld::advance: frame_time must be finite and >= 0");
  return advanceTo(time() + frame_time);
}

std::size_t CoupledWorld::advanceTo(double end) {
  if (!std::isfinite(end)) throw std::invalid_argument("CoupledWorld::advanceTo: t must be finite");
  if (watch_->external_ > 0)
    throw std::logic_error(
        "the Bullet world was stepped " + std::to_string(watch_->external_) +
        " time(s) outside CoupledWorld::advance(): while a fluid is coupled, step the world "
        "only through advance(), which steps Bullet once per fluid sub-step");
  start();
  rigid_->beginFrame();
  std::size_t steps = 0;
  while (sim_->time() < end) {
    sim_->step(end);
    ++steps;
  }
  // User forces were for this frame only.
  for (btRigidBody* body : bodies_)
    body->clearForces();
  return steps;
}

double CoupledWorld::time() const {
  return sim_ ? sim_->time() : 0.0;
}

const Simulation& CoupledWorld::simulation() const {
  if (!sim_) throw std::logic_error("CoupledWorld::simulation before start()");
  return *sim_;
}

Simulation& CoupledWorld::simulation() {
  if (!sim_) throw std::logic_error("CoupledWorld::simulation before start()");
  return *sim_;
}

}  // namespace wake
