#include "coupling/rigid_body.hpp"

#include <cmath>
#include <stdexcept>

namespace wake {

Pose integratePose(const Pose& pose, const Vec3& linear_velocity, const Vec3& angular_velocity,
                   double dt) {
  Pose out;
  out.position = pose.position + dt * linear_velocity;
  const double angle = angular_velocity.norm() * dt;
  Quat rotation = Quat::Identity();
  if (angle > 0.0) rotation = Quat(Eigen::AngleAxisd(angle, angular_velocity.normalized()));
  out.orientation = (rotation * pose.orientation).normalized();
  return out;
}

SimpleRigidBodies::SimpleRigidBodies(std::vector<RigidBodyInit> bodies, const Vec3& gravity)
    : bodies_(std::move(bodies)), gravity_(gravity) {
  for (std::size_t b = 0; b < bodies_.size(); ++b) {
    const RigidBodyInit& body = bodies_[b];
    if (body.kind != BodyKind::Dynamic) continue;
    if (!(body.mass > 0) || !std::isfinite(body.mass))
      throw std::invalid_argument("bodies[" + std::to_string(b) + "].mass: must be > 0");
    if (!(body.inertia.array() > 0).all() || !body.inertia.allFinite())
      throw std::invalid_argument("bodies[" + std::to_string(b) + "].inertia: must be > 0");
  }
}

RigidState stepBody(BodyKind kind, const RigidState& state, const Vec3& linear_acceleration,
                    const Vec3& angular_acceleration, double dt, double linear_damping,
                    double angular_damping) {
  RigidState out = state;
  if (kind == BodyKind::Static) return out;
  if (kind == BodyKind::Dynamic) {
    out.linear_velocity += dt * linear_acceleration;
    out.angular_velocity += dt * angular_acceleration;
    out.linear_velocity *= linear_damping;
    out.angular_velocity *= angular_damping;
  }
  out.pose = integratePose(state.pose, out.linear_velocity, out.angular_velocity, dt);
  return out;
}

RigidPrediction SimpleRigidBodies::advance(const RigidBodyInit& b, double dt,
                                           const Wrench& w) const {
  RigidPrediction p;
  Vec3 linear = Vec3::Zero(), angular = Vec3::Zero();
  if (b.kind == BodyKind::Dynamic) {
    // The inverse inertia is taken at the step's start pose.
    const Mat3 rot = b.state.pose.orientation.toRotationMatrix();
    p.inverse_mass = 1.0 / b.mass;
    p.inverse_inertia_world = rot * b.inertia.cwiseInverse().asDiagonal() * rot.transpose();
    linear = gravity_ + p.inverse_mass * w.force;
    angular = p.inverse_inertia_world * w.torque;
  }
  p.state = stepBody(b.kind, b.state, linear, angular, dt);
  return p;
}

void SimpleRigidBodies::predict(double dt, std::vector<RigidPrediction>& out) const {
  out.resize(bodies_.size());
  for (std::size_t b = 0; b < bodies_.size(); ++b)
    out[b] = advance(bodies_[b], dt, Wrench{});
}

void SimpleRigidBodies::step(double dt, const std::vector<Wrench>& fluid) {
  for (std::size_t b = 0; b < bodies_.size(); ++b)
    bodies_[b].state = advance(bodies_[b], dt, fluid[b]).state;
}

}  // namespace wake
