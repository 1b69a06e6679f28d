// A fluid with rigid bodies, stepped by direct forcing (DESIGN.md §4-5, Algorithm 1).
// The coupling owns the step order. Rigid bodies enter through the RigidBodies interface
// (coupling/rigid_body.hpp): Bullet in bullet_bridge/, or SimpleRigidBodies (gravity, no
// body-body contact) when none is given. With CouplingMethod::Penalty (the paper's baseline,
// coupling/penalty.hpp) the boundary force joins the fluid's forces instead, and there is
// no velocity control and no position correction.
#pragma once

#include "coupling/boundary.hpp"
#include "coupling/consistent_solve.hpp"
#include "coupling/direct_forcing.hpp"
#include "coupling/penalty.hpp"
#include "coupling/position_correction.hpp"
#include "coupling/rigid_body.hpp"
#include "geometry/shape.hpp"
#include "sph/dfsph.hpp"
#include "sph/fluid.hpp"
#include "sph/health.hpp"

#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace wake {

/// A box of fluid filled with particles on a lattice of spacing 2 * particle_radius.
struct FluidBlock {
  Vec3 min = Vec3::Zero();       ///< m
  Vec3 max = Vec3::Zero();       ///< m, > min on every axis
  Vec3 velocity = Vec3::Zero();  ///< m/s, initial velocity of the block
  /// m^2/s, kinematic viscosity of this block's fluid, >= 0; < 0 (default): the fluid's
  /// FluidParams::kinematic_viscosity. Blocks of different viscosities may share a run.
  double kinematic_viscosity = -1.0;
};

/// Limits checked after every step. A run that breaks one stops with a HealthError.
struct HealthLimits {
  /// Largest density / rest density a particle may reach, > 1. A weakly compressible fluid
  /// stays within a few percent of its rest density; far above it, the step is unstable
  /// or the speed of sound too low for the scene.
  double max_density_ratio = 3.0;
};

/// The fluid's pressure: weakly compressible (Tait's equation of state, the paper's fluid;
/// the time step bound by the speed of sound) or incompressible (the divergence-free
/// solver, sph/dfsph.hpp; the time step bound by the flow's speed only).
enum class FluidSolver { Wcsph, Dfsph };

/// How the fluid is modelled and stepped: one set of settings (and defaults) for the scene
/// loader, CoupledWorld and the benchmarks. SimulationSettings adds the scene's content.
struct SolverSettings {
  FluidParams fluid;  ///< speed_of_sound <= 0 means "auto"
  FluidSolver solver = FluidSolver::Wcsph;
  DfsphParams dfsph;  ///< solver Dfsph only
  CouplingMethod method = CouplingMethod::Local;
  /// m^2/s^2, D of the penalty baseline (method Penalty); 0 = defaultPenaltyStrength(c).
  double penalty_strength = 0.0;
  double cfl = 0.4;      ///< lambda of the CFL condition, in (0, 1]; (0, 0.6] with Dfsph
  double max_dt = 1e-3;  ///< s, upper bound of the time step, > 0
  Aabb domain;           ///< m; particles leaving it are lost; empty = automatic
  HealthLimits health;
  /// m, finite: the skin of the fluid's neighbour lists (Fluid::setNeighborSkin: the
  /// particles sorted and the lists built only when one has moved half of it). < 0
  /// (default): automatic, kAutoSkin x the support radius, with either solver: a build
  /// lists it only where it will last (Fluid::updateNeighbors: DFSPH's longer steps in a
  /// fast flow search every step, as without a skin). The skin changes only where the
  /// particles lie in memory, so the order of the sums: not the physics.
  double neighbor_skin = -1.0;
  static constexpr double kAutoSkin = 0.1;
};

/// A whole scene: the solver's settings, gravity, the fluid's blocks and the bodies.
struct SimulationSettings : SolverSettings {
  Vec3 gravity = Vec3(0, -9.81, 0);  ///< m/s^2
  std::vector<FluidBlock> blocks;
  std::vector<BodySettings> bodies;
};

/// The run stopped because a health limit was broken (a non-finite position or velocity,
/// a density ratio above HealthLimits::max_density_ratio). what() names the step, the
/// time, the particle and what to change.
class HealthError : public std::runtime_error {
 public:
  HealthError(const std::string& message, std::uint64_t step, double time, std::uint32_t particle,
              const Vec3& position)
      : std::runtime_error(message),
        step_(step),
        time_(time),
        particle_(particle),
        position_(position) {}
  std::uint64_t step() const { return step_; }          ///< the step that broke the limit (1-based)
  double time() const { return time_; }                 ///< s, at the end of that step
  std::uint32_t particle() const { return particle_; }  ///< permanent id
  const Vec3& position() const { return position_; }    ///< m, where it was (may be NaN)

 private:
  std::uint64_t step_;
  double time_;
  std::uint32_t particle_;
  Vec3 position_;
};

/// One fluid frame, in permanent particle order (id ascending).
struct FluidSnapshot {
  std::vector<std::uint32_t> id;
  std::vector<Vec3> position, velocity;
  std::vector<double> density;
  /// Pa. With the divergence-free solver its running mean over the last steps
  /// (FluidState::pressure_mean, DivergenceFreeSolver::kPressureMeanTime), not one step's
  /// solve: that one comes in kicks around it.
  std::vector<double> pressure;
};

/// Body state at the current time.
struct BodyState {
  std::string name;
  Vec3 position = Vec3::Zero();  ///< centre of mass, m
  Quat orientation = Quat::Identity();
  Vec3 linear_velocity = Vec3::Zero();   ///< m/s
  Vec3 angular_velocity = Vec3::Zero();  ///< rad/s
};

/// The run's counters and maxima: what changes besides the particles and the bodies.
struct RunCounters {
  double time = 0;                     ///< s
  std::uint64_t steps = 0;             ///< steps taken
  double last_dt = 0;                  ///< s
  std::uint64_t removed_at_start = 0;  ///< fluid particles not placed (inside a body, ...)
  std::uint64_t lost = 0;              ///< fluid particles that left the domain
  std::uint64_t max_penetrating = 0;   ///< most fluid centres inside a body after a step
  std::uint64_t window_penetrating = 0;
  std::uint64_t last_contacts = 0;  ///< particle-body contacts in the last step
  double max_density_ratio = 0;     ///< largest density / rest density after a step
  double window_density_ratio = 0;  ///< the same since the last resetWindow()
  /// Sum over the steps of the average compression max(0, rho / rho0 - 1) of the fluid's
  /// particles at the step's start (their summed densities).
  double density_error_sum = 0;
  double max_step_density_error = 0;        ///< the largest of those steps' averages
  std::uint64_t solver_iterations = 0;      ///< Dfsph: density solve iterations, all steps
  std::uint64_t divergence_iterations = 0;  ///< Dfsph: divergence solve iterations, all steps
};

/// What changes during a run on the fluid's side, in the one place Simulation keeps it
/// (the bodies' states are the rigid-body side's). The fluid's arrays are in the
/// simulation's current slot order (not id order): the order decides the order of sums,
/// so it is part of the state.
struct RunData {
  RunCounters run;
  FluidState fluid;              ///< every per-particle array
  std::vector<Wrench> wrenches;  ///< (bodies) the fluid's wrench in the last step
  /// (bodies) The divergence-free density solve's pressure force on each two-way body in the
  /// last step (part of `wrenches`; zero otherwise): DivergenceFreeSolver::bodyForces.
  std::vector<Wrench> solver_forces;
};

/// Everything of a run that changes from step to step (what a checkpoint holds): the run's
/// data and the rigid-body side's numbers. With a Simulation built again from the same
/// settings, restoreState() continues the run bit for bit.
struct SimulationState : RunData {
  std::vector<double> rigid;  ///< RigidBodies::saveState()
  /// Fluid::neighborReference() (its floats, exact as doubles) and its ids: where the
  /// fluid's lists were last built
  /// (empty without a skin, or from a checkpoint written before skins: the first step
  /// then builds).
  std::vector<Vec3> neighbor_reference;
  std::vector<std::uint32_t> neighbor_reference_id;
};

/// The fluid's wrench on one body in one step, by the term it comes from (each zero for
/// one-way bodies). Their sum is the body's whole wrench (Simulation::lastWrenches).
struct WrenchParts {
  /// The walls' pressure force: with WCSPH the surface integral of the samples' pressure
  /// (Boundaries::addBodyPressure), with DFSPH the divergence-free solves' pressure impulse
  /// on the body.
  Wrench pressure;
  Wrench shear;    ///< the walls' viscous shear (no-slip and partial-slip walls)
  Wrench control;  ///< direct forcing's velocity control (or the penalty force)
};

/// Wall-clock seconds spent in each part of the step, summed over steps.
/// `boundary` is all boundary-particle work: the density share plus `control` (contacts
/// and velocity control) plus `correction` (position correction). `rigid` is the rigid
/// bodies' prediction and step (Bullet's step with the bridge).
struct StepTimings {
  double neighbors = 0, density = 0, forces = 0, boundary = 0, integration = 0, rigid = 0;
  double control = 0, correction = 0;  ///< parts of `boundary`
  /// The divergence-free solves (their iterations over the lists; part of `forces`).
  double solver = 0;
  double total() const { return neighbors + density + forces + boundary + integration + rigid; }
  /// The coupling's own cost: contacts, control forces, position correction, rigid step.
  double coupling() const { return control + correction + rigid; }
};

/// Forces of the user's own (wind, a vortex, a magnet, another solver's coupling): called
/// once per step after the fluid's forces (pressure, viscosity, gravity; with the penalty
/// method the boundary force too) and before the prediction, the time step and direct
/// forcing. It adds accelerations (m/s^2) to `acceleration` (n, the particles in the
/// state's current slot order; `fluid` gives their positions, velocities, ids and
/// densities; fluid.acceleration is the same array). `time` is the step's start (s). It
/// must not keep references into the state (slots are reordered every step).
using FluidForces =
    std::function<void(const FluidState& fluid, std::vector<Vec3>& acceleration, double time)>;

class Simulation {
 public:
  /// Builds the fluid and boundaries. `rigid` integrates the bodies (same order and count
  /// as settings.bodies; it owns their state from now on); without one, SimpleRigidBodies
  /// is built from the settings. Throws std::invalid_argument naming the offending field
  /// (e.g. "fluid.particle_radius") when the settings are unusable.
  explicit Simulation(SimulationSettings settings, std::unique_ptr<RigidBodies> rigid = nullptr);
  ~Simulation();

  /// Advances one time step (CFL-limited, never beyond `t_limit`); returns dt taken.
  /// Checks the fluid's health after the step (and non-finite positions before it):
  /// throws HealthError when a limit of model().health is broken or a position or
  /// velocity is not finite. The simulation then stays stopped: every later step()
  /// throws the same error.
  double step(double t_limit);
  /// Steps until time() reaches t.
  void advanceTo(double t);
  /// Sets (or, with an empty function, removes) the user's fluid forces (FluidForces).
  /// Their accelerations count in the time step's limits like the fluid's own.
  void setFluidForces(FluidForces forces) { fluid_forces_ = std::move(forces); }

  double time() const { return data_.run.time; }
  std::uint64_t steps() const { return data_.run.steps; }
  /// The settings as given (speed_of_sound 0 = "auto", an empty domain, ...).
  const SimulationSettings& settings() const { return settings_; }
  /// The run's constant model: the settings with every automatic value resolved (speed of
  /// sound, domain, penalty strength). What the step uses.
  const SimulationSettings& model() const { return model_; }
  const Fluid& fluid() const { return *fluid_; }
  Fluid& fluid() { return *fluid_; }
  const Boundaries& boundaries() const { return *boundaries_; }
  const RigidBodies& rigidBodies() const { return *rigid_; }
  /// The fluid's wrench on each body in the last step (zero for one-way bodies).
  const std::vector<Wrench>& lastWrenches() const { return data_.wrenches; }
  /// The same wrenches split by where they come from (WrenchParts; their sum is
  /// lastWrenches()).
  const std::vector<WrenchParts>& lastWrenchParts() const { return work_.parts; }
  /// Particle-body contacts found in the last step.
  std::size_t lastContacts() const { return data_.run.last_contacts; }
  /// (n) 1 where a fluid particle (in the current order) was in contact in the last step
  /// (with the penalty method: a sample within the penalty reach).
  const std::vector<std::uint8_t>& lastInContact() const { return work_.flags; }

  std::size_t fluidParticles() const { return fluid_->state().size(); }
  std::size_t boundaryParticles() const;
  std::size_t removedAtStart() const { return data_.run.removed_at_start; }
  /// Fluid particles removed because they left the domain (never for a non-finite value:
  /// that stops the run with a HealthError).
  std::size_t lostParticles() const { return data_.run.lost; }
  /// Most fluid particle centres strictly inside a body's exact shape after any step.
  std::size_t maxPenetrating() const { return data_.run.max_penetrating; }
  /// Fluid centres strictly inside a body's exact shape now.
  std::size_t countPenetrating() const;
  /// Largest density / rest density seen after any step.
  double maxDensityRatio() const { return data_.run.max_density_ratio; }
  /// The same two maxima over the steps since the last resetWindow() (e.g. one frame).
  double windowMaxDensityRatio() const { return data_.run.window_density_ratio; }
  std::size_t windowMaxPenetrating() const { return data_.run.window_penetrating; }
  void resetWindow() {
    data_.run.window_density_ratio = 0;
    data_.run.window_penetrating = 0;
  }
  double lastDt() const { return data_.run.last_dt; }
  /// Average over the steps of the fluid's average compression max(0, rho / rho0 - 1) at
  /// each step's start (0 before the first step).
  double averageDensityError() const {
    return data_.run.steps ? data_.run.density_error_sum / double(data_.run.steps) : 0.0;
  }
  /// Iterations of the divergence-free solver's density and divergence solves over all
  /// steps (solver Dfsph; 0 otherwise).
  std::uint64_t densityIterations() const { return data_.run.solver_iterations; }
  std::uint64_t divergenceIterations() const { return data_.run.divergence_iterations; }
  /// The largest average compression of one step (as averageDensityError()).
  double maxStepDensityError() const { return data_.run.max_step_density_error; }
  /// The divergence-free solver's iterations and errors in the last step (solver Dfsph).
  const DfsphStats* solverStats() const { return dfsph_ ? &dfsph_->stats() : nullptr; }

  /// The run's changing state (checkpoints). Throws std::logic_error when the rigid-body
  /// integrator cannot be saved.
  SimulationState saveState() const;
  /// Continues from `state`, saved by a Simulation built from the same settings and rigid
  /// bodies. Throws std::invalid_argument when it does not fit them (counts, sizes).
  void restoreState(const SimulationState& state);

  /// The fluid now, in id order. Before the first step its densities and pressures are
  /// summed for it (on a copy: the run is not touched), as the first step will.
  void snapshot(FluidSnapshot& out) const;
  std::vector<BodyState> bodyStates() const;
  /// The bodies placed where the rigid-body side has them now (for the boundaries'
  /// queries: Boundaries::worldSamples, countInside, ...).
  BodyPlacement placement() const;
  const StepTimings& timings() const { return timings_; }

 private:
  // The step's stages, in order (DESIGN.md §5, Algorithm 1).
  /// Lost particles out, the fluid's neighbours, the bodies placed where they are now.
  void findNeighbors();
  /// Density (with the walls' share), pressure, the walls' pressure and shear, the
  /// fluid's forces, the penalty force (method Penalty), the user's forces.
  void computeFluidForces();
  /// The time step: CFL on the fluid's and the moving surfaces' speeds, the fluid's
  /// accelerations and viscosity, max_dt; lands on t_limit.
  double chooseDt(double t_limit) const;
  /// Fluid v*, x*; bodies predicted over dt without fluid forces.
  void predict(double dt);
  /// Direct forcing's velocity control at x*, bodies placed at their predictions.
  ControlResult controlVelocities(double dt);
  /// One rigid-body step with the fluid's wrench.
  void stepBodies(double dt);
  /// x(t + dt) from the controlled velocities; position correction at the final poses.
  void integrateAndCorrect(double dt, const ControlResult& control);
  /// Health limits and penetration count after the step.
  void checkHealth();

  void removeOutsideDomain();
  /// Throws HealthError for `health`'s problem (and remembers it: the run stays stopped).
  [[noreturn]] void fail(const FluidHealth& health);
  /// Every body's state as the rigid-body side has it now.
  void currentStates(std::vector<RigidState>& out) const;

  const SimulationSettings settings_;  // as given
  SimulationSettings model_;           // resolved in the constructor, constant after
  RunData data_;  // what changes (with the rigid side's states); fluid_ steps data_.fluid
  /// snapshot() before the first step: the densities and pressures of `out` summed on a
  /// copy of the fluid.
  void startDensities(FluidSnapshot& out) const;
  std::unique_ptr<Fluid> fluid_;  // the fluid's model and scratch; steps data_.fluid
  std::unique_ptr<Boundaries> boundaries_;
  std::unique_ptr<RigidBodies> rigid_;
  DirectForcing forcing_;
  std::unique_ptr<PenaltyBoundary> penalty_;     // method Penalty only
  std::unique_ptr<DivergenceFreeSolver> dfsph_;  // solver Dfsph only
  // solver Dfsph with pressure_force Consistent only: its density solve
  std::unique_ptr<ConsistentDensitySolve> consistent_;
  double nu_max_ = 0;  // m^2/s, largest kinematic viscosity of the fluid (set at start)
  StepTimings timings_;
  /// Scratch space of the step, reused every step (no state: nothing in it outlives one).
  struct Workspace {
    std::vector<std::uint8_t> flags;               // (n) in contact / to remove
    std::vector<RigidState> body_now, body_final;  // (bodies) states at t and t + dt
    std::vector<RigidPrediction> body_pred;        // (bodies) predicted states
    std::vector<Wrench> wall_reaction;             // (bodies) its reaction on two-way bodies
    std::vector<WrenchParts> parts;                // (bodies) the last step's wrenches by term
    SamplePressure sample_pressure;                // the boundary samples' pressure
    WallPairs wall_pairs;                          // the step's (particle, sample) pairs
    std::vector<RigidPrediction> body_mass;        // Dfsph: the bodies' masses now (a zero step)
    SolverBoundary solver_boundary;  // Dfsph: the walls' and bodies' terms of the solves
    BodyPlacement placed;  // the bodies placed for the current stage (now, predicted, final)
  } work_;
  std::optional<HealthError> failure_;  // the error that stopped the run
  FluidForces fluid_forces_;            // the user's, or empty
};

/// FNV-1a hash of the fluid's positions and velocities in id order (the benchmarks' and
/// summary.json's state_hash): equal hashes, equal states bit for bit.
std::uint64_t stateHash(const Simulation& sim);

/// Resolves speed_of_sound "auto": 10 x the largest speed expected in the scene
/// (free fall over the scene's height, initial block and body speeds), so Mach < 0.1.
double autoSpeedOfSound(const SimulationSettings& s);

}  // namespace wake
