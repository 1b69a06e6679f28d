// Drop-in two-way coupling of a Wake fluid with an existing Bullet world
// (DESIGN.md §5, Algorithm 1 with Bullet in the loop).
//
//   btDiscreteDynamicsWorld world(...);            // yours, with your bodies
//   wake::CoupledWorld fluid(world, settings);     // gravity comes from the world
//   fluid.addFluidBlock({0, 0, 0}, {0.5, 0.3, 0.2});
//   fluid.couple(tank_body, {"tank"});             // static: mass 0
//   fluid.couple(box_body, {"box"});               // dynamic: two-way
//   for (;;) fluid.advance(1.0 / 60);              // instead of world.stepSimulation
//
// advance(frame_time) sub-steps with the fluid's CFL step and takes exactly one Bullet
// step (stepSimulation(dt, 0)) per sub-step: predict the bodies, control the fluid at
// their surfaces, apply the fluid's force and torque to each two-way body, step Bullet,
// correct the fluid's positions against the bodies' new poses. Bullet integrates the
// bodies and resolves body-body contact; forces never leak into the next step (Bullet
// clears them after each step; forces you applied before advance() act over the whole
// frame, as they would in one stepSimulation call).
//
// Stepping the world yourself: while a CoupledWorld is attached, the world must only be
// stepped through advance(). A stepSimulation() call of your own moves the bodies
// without the fluid; it is detected (a btActionInterface sees every Bullet step) and the
// next advance() throws std::logic_error saying so. Detach by destroying the CoupledWorld.
//
// Body kinds follow Bullet: mass 0 -> static; CF_KINEMATIC_OBJECT -> kinematic, one-way,
// moved by Wake with the velocity given to setKinematicVelocity() (Bullet derives its
// velocity from that motion); other bodies -> dynamic, two-way unless coupled one-way.
// Coupled dynamic bodies are kept awake. Bodies are sampled on the surface Bullet
// collides with (bullet_bridge/bullet_shapes.hpp).
#pragma once

#include "coupling/simulation.hpp"

#include <memory>
#include <string>
#include <vector>

class btDiscreteDynamicsWorld;
class btRigidBody;

namespace wake {

/// The solver's settings (coupling/simulation.hpp): the same fields and defaults as a
/// scene file's. Gravity comes from the Bullet world.
using CoupledWorldSettings = SolverSettings;

/// How one Bullet body meets the fluid: BodyFluidSettings (name, default "body<k>";
/// slip; restitution; coupling, for dynamic bodies) and, optionally, its exact shape.
struct BodyCoupling : BodyFluidSettings {
  BodyCoupling(std::string name_ = {}, double slip_ = 0.0, double restitution_ = 0.0,
               CouplingMode coupling_ = CouplingMode::TwoWay)
      : BodyFluidSettings{std::move(name_), slip_, restitution_, coupling_} {}
  BodyCoupling(const BodyFluidSettings& fluid) : BodyFluidSettings(fluid) {}
  /// Exact surface to sample, in the body's centre-of-mass frame. Default (null): read
  /// from the body's collision shape (bullet_bridge/bullet_shapes.hpp).
  std::shared_ptr<const Shape> shape;
};

class CoupledWorld {
 public:
  /// Attaches to `world` (not owned; it must outlive this object).
  explicit CoupledWorld(btDiscreteDynamicsWorld& world, CoupledWorldSettings settings = {});
  ~CoupledWorld();
  CoupledWorld(const CoupledWorld&) = delete;
  CoupledWorld& operator=(const CoupledWorld&) = delete;

  /// A box of fluid on the lattice (spacing 2 particle radii). Before the first advance().
  void addFluidBlock(const Vec3& min, const Vec3& max, const Vec3& velocity = Vec3::Zero());
  /// The same with every FluidBlock field (e.g. its own kinematic viscosity).
  void addFluidBlock(const FluidBlock& block);
  /// Couples a body of the world with the fluid. Before the first advance().
  /// Returns its index in simulation().bodyStates().
  std::size_t couple(btRigidBody* body, const BodyCoupling& coupling = {});
  /// Velocity (world frame, about the centre of mass) of a coupled kinematic body.
  void setKinematicVelocity(btRigidBody* body, const Vec3& linear, const Vec3& angular);

  /// Forces of your own on the fluid, added every sub-step after the fluid's forces and
  /// before the bodies' prediction (coupling/simulation.hpp, FluidForces). Any time.
  void setFluidForces(FluidForces forces);

  /// Builds the fluid and the boundary samples (done by the first advance()).
  void start();
  /// Advances fluid and bodies by `frame_time` (s, >= 0); returns the sub-steps taken.
  /// Throws HealthError (coupling/simulation.hpp) when the fluid's health check fails
  /// after a sub-step: a non-finite position or velocity, or a density ratio above
  /// settings.health.max_density_ratio. The message names the step, the time, the
  /// particle and what to change; later calls throw the same error.
  std::size_t advance(double frame_time);
  /// Advances fluid and bodies to time `t` (s); returns the sub-steps taken.
  std::size_t advanceTo(double t);

  double time() const;
  bool started() const { return sim_ != nullptr; }
  /// The coupled simulation (fluid state, timings, body states); after start().
  const Simulation& simulation() const;
  Simulation& simulation();

 private:
  class Bodies;
  class StepWatch;
  btDiscreteDynamicsWorld& world_;
  CoupledWorldSettings settings_;
  std::vector<FluidBlock> blocks_;
  std::vector<BodyCoupling> couplings_;
  std::vector<btRigidBody*> bodies_;
  std::vector<Vec3> kinematic_linear_, kinematic_angular_;
  FluidForces fluid_forces_;
  Bodies* rigid_ = nullptr;  ///< owned by sim_
  std::unique_ptr<StepWatch> watch_;
  std::unique_ptr<Simulation> sim_;
};

}  // namespace wake
