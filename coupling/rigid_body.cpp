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

std::vector<double> RigidBodies::saveState() const {
  throw std::logic_error("this rigid-body integrator cannot be saved in a checkpoint");
}

void RigidBodies::loadState(const std::vector<double>&) {
  throw std::logic_error("this rigid-body integrator cannot be restored from a checkpoint");
}

std::vector<double> SimpleRigidBodies::saveState() const {
  std::vector<double> out;
  out.reserve(13 * bodies_.size());
  for (const RigidBodyInit& b : bodies_) {
    const RigidState& s = b.state;
    out.insert(out.end(), s.pose.position.data(), s.pose.position.data() + 3);
    out.insert(out.end(), s.pose.orientation.coeffs().data(),
               s.pose.orientation.coeffs().data() + 4);
    out.insert(out.end(), s.linear_velocity.data(), s.linear_velocity.data() + 3);
    out.insert(out.end(), s.angular_velocity.data(), s.angular_velocity.data() + 3);
  }
  return out;
}

void SimpleRigidBodies::loadState(const std::vector<double>& state) {
  if (state.size() != 13 * bodies_.size())
    throw std::invalid_argument("rigid-body state: " + std::to_string(state.size()) +
                                " numbers for " + std::to_string(bodies_.size()) +
                                " bodies (13 each)");
  const double* v = state.data();
  for (RigidBodyInit& b : bodies_) {
    RigidState& s = b.state;
    s.pose.position = Vec3(v[0], v[1], v[2]);
    s.pose.orientation.coeffs() = Eigen::Vector4d(v[3], v[4], v[5], v[6]);
    s.linear_velocity = Vec3(v[7], v[8], v[9]);
    s.angular_velocity = Vec3(v[10], v[11], v[12]);
    v += 13;
  }
}

}  // namespace wake
