// The coupling's view of rigid bodies (DESIGN.md §4-5): state and mass properties in, one
// wrench per step out. Wake's coupling never integrates a dynamic body itself; a
// RigidBodies implementation does (Bullet in bullet_bridge/, or SimpleRigidBodies below
// for tests and Bullet-free use).
#pragma once

#include "sph/types.hpp"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace wake {

using Mat3 = Eigen::Matrix3d;

enum class BodyKind { Static, Kinematic, Dynamic };

/// How a body exchanges momentum with the fluid. One-way: the body pushes the fluid but
/// feels nothing (static and kinematic bodies always; a heavy dynamic body may choose it).
enum class CouplingMode { TwoWay, OneWay };

/// How a body meets the fluid: the part of a body's settings that every description of a
/// body shares (the scene's BodySpec, CoupledWorld's BodyCoupling, the coupling's
/// BodySettings), with one set of defaults.
struct BodyFluidSettings {
  std::string name;  ///< unique; output names (HDF5 group, summary, series)
  /// eps in [0, 1] towards the fluid: the wall exerts (1 - eps) times the viscous shear
  /// stress of a no-slip wall (Boundaries::addWallTerms): 0 no-slip, 1 free slip.
  double slip = 0.0;
  double restitution = 0.0;  ///< delta in [0, 1] towards the fluid: 0 inelastic
  /// Dynamic bodies: two-way (the fluid's forces act on the body) or one-way (a heavy
  /// body that pushes the fluid but feels nothing). Static and kinematic: one-way.
  CouplingMode coupling = CouplingMode::TwoWay;
};

/// Position, orientation and velocities of a rigid body.
struct RigidState {
  Pose pose;                             ///< body -> world; position = centre of mass
  Vec3 linear_velocity = Vec3::Zero();   ///< m/s, of the centre of mass
  Vec3 angular_velocity = Vec3::Zero();  ///< rad/s, world frame

  /// Velocity of the material point at world position x.
  Vec3 pointVelocity(const Vec3& x) const {
    return linear_velocity + angular_velocity.cross(x - pose.position);
  }
};

/// A body's state predicted one step ahead without fluid forces, with the mass
/// properties the velocity control needs at that state.
struct RigidPrediction {
  RigidState state;
  double inverse_mass = 0.0;                  ///< 1/kg; 0 for static, kinematic
  Mat3 inverse_inertia_world = Mat3::Zero();  ///< world inverse inertia at state.pose
};

/// Force and torque (about the centre of mass), world frame, for one step.
struct Wrench {
  Vec3 force = Vec3::Zero();   ///< N
  Vec3 torque = Vec3::Zero();  ///< N m
};

/// Rigid bodies seen by the coupling, in a fixed order (the Simulation's body order).
class RigidBodies {
 public:
  virtual ~RigidBodies() = default;
  virtual std::size_t count() const = 0;
  /// State at the current time.
  virtual RigidState state(std::size_t body) const = 0;
  /// Each body's state after `dt` under every force but the fluid's (gravity, user
  /// forces, damping; kinematic bodies along their motion), without body-body contact.
  virtual void predict(double dt, std::vector<RigidPrediction>& out) const = 0;
  /// Applies `fluid[b]` to body b for this step only and advances every body by exactly
  /// `dt` (integration and body-body contact). `fluid` has count() entries.
  virtual void step(double dt, const std::vector<Wrench>& fluid) = 0;

  /// Checkpoints: the integrator's whole changing state as numbers, enough to continue
  /// the run bit for bit after loadState() on an integrator built the same way. The
  /// default refuses (std::logic_error): an integrator that cannot be saved.
  virtual std::vector<double> saveState() const;
  /// Restores what saveState() gave. Throws std::invalid_argument when it does not fit.
  virtual void loadState(const std::vector<double>& state);
};

/// Rigid body description for SimpleRigidBodies and for the coupling's own bookkeeping.
struct RigidBodyInit {
  BodyKind kind = BodyKind::Static;
  RigidState state;
  double mass = 0.0;            ///< kg, > 0 for dynamic bodies
  Vec3 inertia = Vec3::Zero();  ///< kg m^2, principal moments in body space
};

/// Semi-implicit Euler integration under gravity, without body-body contact: static
/// bodies stay, kinematic bodies move with constant velocities, dynamic bodies integrate
/// gravity and the fluid's wrench. Used by tests and scenes without Bullet.
class SimpleRigidBodies final : public RigidBodies {
 public:
  SimpleRigidBodies(std::vector<RigidBodyInit> bodies, const Vec3& gravity);
  std::size_t count() const override { return bodies_.size(); }
  RigidState state(std::size_t body) const override { return bodies_[body].state; }
  void predict(double dt, std::vector<RigidPrediction>& out) const override;
  void step(double dt, const std::vector<Wrench>& fluid) override;
  /// 13 numbers per body: position, orientation (x y z w), linear, angular velocity.
  std::vector<double> saveState() const override;
  void loadState(const std::vector<double>& state) override;

 private:
  RigidPrediction advance(const RigidBodyInit& b, double dt, const Wrench& w) const;
  std::vector<RigidBodyInit> bodies_;
  Vec3 gravity_;
};

/// One semi-implicit Euler step of a body over dt: static bodies stay; kinematic bodies
/// move with their velocities; dynamic bodies' velocities gain dt times the accelerations
/// (m/s^2, rad/s^2), are then multiplied by the damping factors, and the pose moves with
/// the new velocities.
RigidState stepBody(BodyKind kind, const RigidState& state, const Vec3& linear_acceleration,
                    const Vec3& angular_acceleration, double dt, double linear_damping = 1.0,
                    double angular_damping = 1.0);

/// Pose after moving with constant linear and angular velocity for dt (exact rotation).
Pose integratePose(const Pose& pose, const Vec3& linear_velocity, const Vec3& angular_velocity,
                   double dt);

}  // namespace wake
