#include "coupling/simulation.hpp"

#include "sph/time_step.hpp"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace wake {

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

bool finite(const Vec3& v) {
  return v.allFinite();
}

/// Average over the particles of max(0, rho / rho0 - 1), summed in particle order.
double averageCompression(const std::vector<double>& density, double rho0) {
  if (density.empty()) return 0.0;
  double sum = 0.0;
  for (const double rho : density)
    sum += std::max(0.0, rho / rho0 - 1.0);
  return sum / double(density.size());
}

void require(bool ok, const std::string& field, const std::string& what) {
  if (!ok) throw std::invalid_argument(field + ": " + what);
}

/// Bounds of everything finite in the scene: fluid blocks and bodies except planes.
Aabb sceneBounds(const SimulationSettings& s) {
  Aabb box;
  for (const FluidBlock& b : s.blocks) {
    box.extend(b.min);
    box.extend(b.max);
  }
  const Aabb unbounded;  // empty clip: infinite shapes contribute nothing
  for (const BodySettings& body : s.bodies) {
    if (!body.shape) continue;
    const Aabb local = body.shape->bounds(unbounded);
    if (local.empty() || !local.min.allFinite() || !local.max.allFinite()) continue;
    box.extend(transformBounds(local, body.pose, /*to_world=*/true));
  }
  return box;
}

void validate(const SimulationSettings& s) {
  const FluidParams& f = s.fluid;
  require(finite(s.gravity), "gravity", "must be finite");
  require(std::isfinite(f.particle_radius) && f.particle_radius > 0, "fluid.particle_radius",
          "must be > 0");
  require(std::isfinite(f.rest_density) && f.rest_density > 0, "fluid.rest_density", "must be > 0");
  require(std::isfinite(f.speed_of_sound) && f.speed_of_sound >= 0, "fluid.speed_of_sound",
          "must be > 0 or auto");
  require(std::isfinite(f.viscosity) && f.viscosity >= 0, "fluid.viscosity", "must be >= 0");
  require(std::isfinite(f.kinematic_viscosity) && f.kinematic_viscosity >= 0,
          "fluid.kinematic_viscosity", "must be >= 0");
  require(std::isfinite(f.gamma) && f.gamma > 0, "fluid.gamma", "must be > 0");
  require(f.smoothing_ratio >= 0.8 && f.smoothing_ratio <= 2.0, "fluid.smoothing_ratio",
          "must be in [0.8, 2]");
  require(s.cfl > 0 && s.cfl <= 1, "time.cfl", "must be in (0, 1]");
  require(std::isfinite(s.neighbor_skin), "neighbor_skin", "must be finite");
  if (s.solver == FluidSolver::Dfsph) {
    require(s.cfl <= 0.6, "time.cfl", "must be in (0, 0.6] with fluid.solver \"dfsph\"");
    const DfsphParams& d = s.dfsph;
    require(d.max_density_error > 0 && d.max_density_error <= 0.1, "fluid.dfsph.max_density_error",
            "must be in (0, 0.1]");
    require(d.max_divergence_error > 0 && d.max_divergence_error <= 1,
            "fluid.dfsph.max_divergence_error", "must be in (0, 1]");
    require(d.max_iterations >= 2, "fluid.dfsph.max_iterations", "must be >= 2");
    require(d.max_divergence_iterations >= 0, "fluid.dfsph.max_divergence_iterations",
            "must be >= 0");
  }
  require(std::isfinite(s.max_dt) && s.max_dt > 0, "time.max_dt", "must be > 0");
  for (std::size_t i = 0; i < s.blocks.size(); ++i) {
    const FluidBlock& b = s.blocks[i];
    const std::string field = "fluid.blocks[" + std::to_string(i) + "]";
    require(finite(b.min) && finite(b.max) && finite(b.velocity), field, "must be finite");
    require(std::isfinite(b.kinematic_viscosity), field + ".kinematic_viscosity",
            "must be finite (>= 0, or < 0 for the fluid's)");
    require((b.max.array() > b.min.array()).all(), field + ".max",
            "must be greater than min on every axis");
  }
  for (std::size_t i = 0; i < s.bodies.size(); ++i) {
    const BodySettings& b = s.bodies[i];
    const std::string field = "bodies[" + std::to_string(i) + "]";
    require(b.shape != nullptr, field + ".shape", "missing");
    require(finite(b.linear_velocity) && finite(b.angular_velocity), field + ".linear_velocity",
            "must be finite");
    require(b.slip >= 0 && b.slip <= 1, field + ".slip", "must be in [0, 1]");
    require(b.restitution >= 0 && b.restitution <= 1, field + ".restitution", "must be in [0, 1]");
    require(finite(b.pose.position) && b.pose.orientation.coeffs().allFinite(), field + ".position",
            "must be finite");
  }
  require(std::isfinite(s.penalty_strength) && s.penalty_strength >= 0, "coupling.penalty_strength",
          "must be > 0 or automatic");
  require(std::isfinite(s.health.max_density_ratio) && s.health.max_density_ratio > 1,
          "health.max_density_ratio", "must be > 1");
}

/// The particles' slots in order of their permanent numbers (a snapshot's order).
std::vector<std::uint32_t> idOrder(const FluidState& st) {
  std::vector<std::uint32_t> order(st.size());
  for (std::size_t i = 0; i < order.size(); ++i)
    order[i] = static_cast<std::uint32_t>(i);
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t a, std::uint32_t b) { return st.id[a] < st.id[b]; });
  return order;
}

}  // namespace

double autoSpeedOfSound(const SimulationSettings& s) {
  const double g = s.gravity.norm();
  const Vec3 up = g > 0 ? Vec3(-s.gravity / g) : Vec3(0, 1, 0);
  // Fall height: from the highest fluid to the lowest point of the scene.
  double fluid_top = -std::numeric_limits<double>::infinity();
  double v_max = 0.0;
  for (const FluidBlock& b : s.blocks) {
    for (int corner = 0; corner < 8; ++corner) {
      fluid_top = std::max(fluid_top, Aabb{b.min, b.max}.corner(corner).dot(up));
    }
    v_max = std::max(v_max, b.velocity.norm());
  }
  for (const BodySettings& b : s.bodies)
    v_max = std::max(v_max, b.linear_velocity.norm());
  const Aabb box = sceneBounds(s);
  double bottom = fluid_top;
  if (!box.empty()) {
    for (int corner = 0; corner < 8; ++corner) {
      bottom = std::min(bottom, box.corner(corner).dot(up));
    }
  }
  const double fall = std::max(0.0, fluid_top - bottom);
  // A column of height `fall` released on a floor spreads with Ritter's front speed
  // 2 sqrt(g fall), faster than free fall over that height (sqrt(2 g fall)).
  v_max = std::max({v_max, 2.0 * std::sqrt(g * fall), 0.1});
  return 10.0 * v_max;
}

Simulation::Simulation(SimulationSettings settings, std::unique_ptr<RigidBodies> rigid)
    : settings_(std::move(settings)),
      model_(settings_),
      rigid_(std::move(rigid)),
      forcing_(model_.fluid) {
  validate(model_);
  SimulationSettings& s = model_;  // "auto" values are resolved here, in the model only
  if (s.fluid.speed_of_sound <= 0) s.fluid.speed_of_sound = autoSpeedOfSound(s);
  if (s.method == CouplingMethod::Penalty) {
    if (s.penalty_strength <= 0)
      s.penalty_strength = defaultPenaltyStrength(s.fluid.speed_of_sound);
    penalty_ = std::make_unique<PenaltyBoundary>(s.fluid, s.penalty_strength);
  }

  if (s.domain.empty()) {
    // Automatic domain: the scene's bounds grown by a quarter of their largest extent
    // and two kernel supports on every side, and upwards by twice the height the
    // fastest expected fluid (c / 10) could rise, at most the scene's extent, so that
    // splashes and jets up a wall fall back instead of being lost.
    Aabb box = sceneBounds(s);
    require(!box.empty(), "domain", "cannot be derived: the scene has no fluid and no bodies");
    const double extent = (box.max - box.min).maxCoeff();
    const double grow = 0.25 * extent + 2.0 * s.fluid.supportRadius();
    box.min.array() -= grow;
    box.max.array() += grow;
    const double g = s.gravity.norm();
    if (g > 0) {
      const double v = 0.1 * s.fluid.speed_of_sound;
      const Vec3 rise = (-s.gravity / g) * std::min(v * v / g, extent);
      box.min = box.min.cwiseMin(box.min + rise);
      box.max = box.max.cwiseMax(box.max + rise);
    }
    s.domain = box;
  }
  require(finite(s.domain.min) && finite(s.domain.max) &&
              (s.domain.max.array() > s.domain.min.array()).all(),
          "domain", "max must be greater than min on every axis");

  if (!rigid_) {
    std::vector<RigidBodyInit> init;
    for (const BodySettings& b : s.bodies)
      init.push_back({b.kind, {b.pose, b.linear_velocity, b.angular_velocity}, b.mass, b.inertia});
    rigid_ = std::make_unique<SimpleRigidBodies>(std::move(init), s.gravity);
  }
  require(rigid_->count() == s.bodies.size(), "bodies",
          "the rigid-body integrator has a different number of bodies");
  fluid_ = std::make_unique<Fluid>(s.fluid, s.domain, &data_.fluid);
  fluid_->setNeighborSkin(
      s.neighbor_skin >= 0 ? s.neighbor_skin : SolverSettings::kAutoSkin * s.fluid.supportRadius());
  if (s.solver == FluidSolver::Dfsph) dfsph_ = std::make_unique<DivergenceFreeSolver>(s.dfsph);
  if (dfsph_ && s.dfsph.pressure_force == DfsphParams::PressureForce::Consistent)
    consistent_ = std::make_unique<ConsistentDensitySolve>();
  // The contacts where the fluid's own pressure force leaves its first layer: DFSPH's
  // symmetric impulse holds it a radius off a wall, the consistent force half a radius.
  boundaries_ = std::make_unique<Boundaries>(
      s.fluid, s.domain,
      dfsph_ && !consistent_ ? Boundaries::kDfsphContactFraction : Boundaries::kContactFraction);
  for (const BodySettings& b : s.bodies)
    boundaries_->addBody(b);
  boundaries_->finalize();
  const BodyPlacement start = placement();
  data_.wrenches.assign(s.bodies.size(), Wrench{});
  data_.solver_forces.assign(s.bodies.size(), Wrench{});

  // Fill the blocks on the lattice; drop particles outside the domain, inside a body, or
  // closer to a body's surface than their radius (starting overlap blows up runs).
  const double sp = s.fluid.spacing();
  const double rf = s.fluid.particle_radius;
  FluidState& st = fluid_->state();
  std::uint32_t next_id = 0;
  // Room for every lattice point at once (appending one by one left up to half of each
  // array's memory unused), trimmed to what is kept below.
  auto lattice = [&](const FluidBlock& b, int k) {
    return std::max(1, static_cast<int>(std::lround((b.max[k] - b.min[k]) / sp)));
  };
  std::size_t room = 0;
  for (const FluidBlock& b : s.blocks)
    room += std::size_t(lattice(b, 0)) * std::size_t(lattice(b, 1)) * std::size_t(lattice(b, 2));
  st.reserve(st.size() + room);
  for (const FluidBlock& b : s.blocks) {
    const double nu =
        b.kinematic_viscosity >= 0 ? b.kinematic_viscosity : s.fluid.kinematic_viscosity;
    const Eigen::Vector3i count(lattice(b, 0), lattice(b, 1), lattice(b, 2));
    for (int k = 0; k < count[2]; ++k)
      for (int j = 0; j < count[1]; ++j)
        for (int i = 0; i < count[0]; ++i) {
          const Vec3 x = b.min + sp * Vec3(i + 0.5, j + 0.5, k + 0.5);
          const bool inside_domain = s.domain.contains(x);
          if (!inside_domain || boundaries_->signedDistance(x, start) < (1.0 - 1e-6) * rf) {
            ++data_.run.removed_at_start;
            ++next_id;
            continue;
          }
          st.append(x, b.velocity, next_id++, nu);
        }
  }
  st.shrinkToFit();
  nu_max_ = fluid_->maxKinematicViscosity();
  if (dfsph_ && st.size() > 0) {
    // The walls' density share made to agree with the fluid as it starts (on a sorted copy:
    // the run's state is not touched).
    FluidState copy = st;
    Fluid probe(s.fluid, s.domain, &copy);
    probe.updateNeighbors();
    probe.computeFluidDensity();
    boundaries_->calibrateVolumes(probe, start);
  }
}

Simulation::~Simulation() = default;

std::size_t Simulation::boundaryParticles() const {
  return boundaries_->sampleCount();
}

std::size_t Simulation::countPenetrating() const {
  return boundaries_->countInside(fluid_->state().position, placement());
}

void Simulation::removeOutsideDomain() {
  FluidState& st = fluid_->state();
  const std::int64_t n = static_cast<std::int64_t>(st.size());
  const Aabb& domain = model_.domain;
  // A NaN position is not "outside": it stops the run (the user's code may have set it).
  auto outside = [&](std::int64_t i) {
    return finite(st.position[i]) && !domain.contains(st.position[i]);
  };
  std::size_t out = 0;
  bool non_finite = false;
#pragma omp parallel for schedule(static) reduction(+ : out) reduction(|| : non_finite)
  for (std::int64_t i = 0; i < n; ++i) {
    const bool ok = finite(st.position[i]);
    non_finite = non_finite || !ok;
    out += ok && !domain.contains(st.position[i]);
  }
  if (non_finite)
    fail(checkFluidHealth(st, model_.fluid.rest_density, model_.health.max_density_ratio));
  if (out == 0) return;  // the usual step: nothing written
  work_.flags.resize(st.size());
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i)
    work_.flags[i] = outside(i);
  st.removeIf(work_.flags);
  data_.run.lost += out;
}

void Simulation::fail(const FluidHealth& health) {
  const FluidState& st = fluid_->state();
  const FluidParams& f = model_.fluid;
  const std::size_t i = health.slot;
  const Vec3 x = st.position[i];
  std::ostringstream m;
  m << "step " << data_.run.steps << " (t = " << data_.run.time << " s): fluid particle "
    << st.id[i] << " at (" << x.x() << ", " << x.y() << ", " << x.z() << ") m has "
    << describeProblem(health, st, f.rest_density);
  if (health.problem == FluidHealth::Problem::DensityRatio && dfsph_) {
    m << ", above health.max_density_ratio = " << model_.health.max_density_ratio
      << ": the pressure solve did not hold the fluid at its rest density; lower time.cfl (now "
      << model_.cfl << ") or time.max_dt (now " << model_.max_dt
      << " s), or raise fluid.dfsph.max_iterations (now " << model_.dfsph.max_iterations << ")";
  } else if (health.problem == FluidHealth::Problem::DensityRatio) {
    m << ", above health.max_density_ratio = " << model_.health.max_density_ratio
      << ": the fluid is compressed far more than a weakly compressible fluid may be; raise "
         "fluid.speed_of_sound (now "
      << f.speed_of_sound
      << " m/s; \"auto\" picks one for the scene), or raise health.max_density_ratio if such "
         "a density is expected";
  } else {
    m << ": the step became unstable; lower time.cfl (now " << model_.cfl
      << ") or time.max_dt (now " << model_.max_dt << " s), or raise fluid.speed_of_sound (now "
      << f.speed_of_sound << " m/s)";
  }
  failure_.emplace(m.str(), data_.run.steps, data_.run.time, st.id[i], x);
  throw *failure_;
}

void Simulation::currentStates(std::vector<RigidState>& out) const {
  out.resize(rigid_->count());
  for (std::size_t b = 0; b < out.size(); ++b)
    out[b] = rigid_->state(b);
}

BodyPlacement Simulation::placement() const {
  std::vector<RigidState> states;
  currentStates(states);
  BodyPlacement at;
  boundaries_->place(states, at);
  return at;
}

double Simulation::chooseDt(double t_limit) const {
  // Fluid at a moving body's surface takes on its speed: count surface speeds too.
  double v_max = fluid_->maxSpeed();
  for (std::size_t b = 0; b < boundaries_->bodyCount(); ++b) {
    if (!boundaries_->body(b).moves()) continue;
    const RigidState& s = work_.body_now[b];
    v_max = std::max(
        v_max, s.linear_velocity.norm() + s.angular_velocity.norm() * boundaries_->bodyExtent(b));
  }
  const double dt = dfsph_ ? incompressibleTimeStep(model_.fluid, model_.cfl, model_.max_dt, v_max,
                                                    fluid_->maxAcceleration(), nu_max_)
                           : stableTimeStep(model_.fluid, model_.cfl, model_.max_dt, v_max,
                                            fluid_->maxAcceleration(), nu_max_);
  const double remaining = t_limit - data_.run.time;
  // Land exactly on t_limit, and never leave a sliver step behind (nor split a step that
  // ends on t_limit but for rounding: a time step that changes for nothing disturbs the
  // divergence-free solver's warm start).
  if (remaining <= dt * (1.0 + 1e-9)) return remaining;
  if (dfsph_) {
    // The last few steps before t_limit share what is left evenly: the solver's pressure
    // (its warm start, its correction of the density error within one step) is that of a
    // steady step; a half step at each output time set a column at rest moving (0.019 m/s
    // instead of 0.008) and raised its pressure by 11 %.
    const double steps = std::ceil(remaining / dt - 1e-9);
    if (steps <= 4.0) return remaining / steps;
    return dt;
  }
  if (remaining < 1.5 * dt) return 0.5 * remaining;
  return dt;
}

double Simulation::step(double t_limit) {
  if (failure_) throw *failure_;
  if (!(t_limit > data_.run.time)) return 0.0;
  findNeighbors();
  computeFluidForces();
  auto t0 = Clock::now();
  const double dt = chooseDt(t_limit);
  timings_.integration += secondsSince(t0);
  predict(dt);
  const ControlResult control = controlVelocities(dt);
  stepBodies(dt);
  integrateAndCorrect(dt, control);
  data_.run.time = (t_limit - data_.run.time == dt) ? t_limit : data_.run.time + dt;
  data_.run.last_dt = dt;
  ++data_.run.steps;
  checkHealth();
  return dt;
}

void Simulation::findNeighbors() {
  // The bodies as the rigid-body side has them now, placed for the walls' sums.
  const auto t0 = Clock::now();
  currentStates(work_.body_now);
  boundaries_->place(work_.body_now, work_.placed);
  removeOutsideDomain();
  fluid_->updateNeighbors(data_.run.last_dt);
  timings_.neighbors += secondsSince(t0);
  // The static samples near each particle, listed again when the fluid's lists were.
  const auto t1 = Clock::now();
  boundaries_->prepareWallCandidates(*fluid_);
  timings_.boundary += secondsSince(t1);
}

void Simulation::computeFluidForces() {
  FluidState& st = fluid_->state();
  auto t0 = Clock::now();
  // The divergence-free solver sums the densities as it lists each pair's kernel gradient
  // (the same bits, one pass over the pairs).
  if (dfsph_)
    dfsph_->prepareLists(*fluid_);
  else
    fluid_->computeFluidDensity();
  timings_.density += secondsSince(t0);
  t0 = Clock::now();
  // The walls' density share and viscous shear (their part of the fluid's sums). Their
  // accelerations go into the state's acceleration array, free until the fluid's forces
  // are computed (computeAccelerations reads each particle's before writing it).
  std::vector<Vec3>& wall_accelerations = st.acceleration;
  boundaries_->addWallTerms(*fluid_, work_.placed, st.density, wall_accelerations,
                            work_.wall_reaction, work_.wall_pairs);
  work_.parts.assign(boundaries_->bodyCount(), WrenchParts{});
  for (std::size_t b = 0; b < work_.parts.size(); ++b)
    work_.parts[b].shear = work_.wall_reaction[b];
  timings_.boundary += secondsSince(t0);
  const double compression = averageCompression(st.density, model_.fluid.rest_density);
  data_.run.density_error_sum += compression;
  data_.run.max_step_density_error = std::max(data_.run.max_step_density_error, compression);
  if (dfsph_) {
    // The pressure is the solver's: the velocities at the step's start made free of
    // compression here, the predicted ones held at the rest density in predict().
    t0 = Clock::now();
    boundaries_->solverTerms(*fluid_, work_.placed, work_.wall_pairs, model_.gravity,
                             work_.solver_boundary);
    // The solver's pressure pushes the bodies where fluid is near; their contact faces, rim
    // included, get the pressure of the water next to them (addContactPressure), from its
    // running mean.
    if (!consistent_ && boundaries_->hasTwoWayBodies()) {
      boundaries_->computeSamplePressure(*fluid_, work_.placed, model_.gravity, work_.wall_pairs,
                                         work_.sample_pressure, /*two_way_only=*/true);
      boundaries_->addContactPressure(work_.placed, model_.gravity, work_.sample_pressure,
                                      /*wet_too=*/true);
      boundaries_->addBodyPressure(work_.placed, work_.sample_pressure, work_.wall_reaction,
                                   /*touching_only=*/true);
    }
    // The two-way bodies as the solves see them: their masses now, and the density solve's
    // push on them in the last step, which their other forces are taken to balance.
    std::vector<SolverBody>& bodies = work_.solver_boundary.bodies;
    bodies.assign(boundaries_->bodyCount(), SolverBody{});
    if (!work_.solver_boundary.links.empty()) {
      rigid_->predict(0.0, work_.body_mass);
      for (std::size_t b = 0; b < bodies.size(); ++b) {
        if (!boundaries_->body(b).twoWay()) continue;
        bodies[b].inverse_mass = work_.body_mass[b].inverse_mass;
        bodies[b].inverse_inertia = work_.body_mass[b].inverse_inertia_world;
        bodies[b].last_force = data_.solver_forces[b].force;
        bodies[b].last_torque = data_.solver_forces[b].torque;
      }
    }
    timings_.boundary += secondsSince(t0);
    t0 = Clock::now();
    dfsph_->prepare(*fluid_, work_.solver_boundary);
    const double last_dt = data_.run.last_dt > 0 ? data_.run.last_dt : model_.max_dt;
    const auto t_solve = Clock::now();
    // The consistent force's solve has no divergence solve: its pressure starts from the
    // last step's, which already holds the flow's.
    if (!consistent_) data_.run.divergence_iterations += dfsph_->solveDivergence(*fluid_, last_dt);
    timings_.solver += secondsSince(t_solve);
    fluid_->computeWithoutPressure();
    timings_.forces += secondsSince(t0);
  } else {
    t0 = Clock::now();
    fluid_->computePressure();
    timings_.density += secondsSince(t0);
    t0 = Clock::now();
    // The walls' pressure force: the samples at the fluid's pressure there.
    boundaries_->computeSamplePressure(*fluid_, work_.placed, model_.gravity, work_.wall_pairs,
                                       work_.sample_pressure);
    boundaries_->addWallPressure(*fluid_, work_.placed, work_.wall_pairs, work_.sample_pressure,
                                 wall_accelerations, fluid_->wallPressureSums());
    boundaries_->addContactPressure(work_.placed, model_.gravity, work_.sample_pressure);
    boundaries_->addBodyPressure(work_.placed, work_.sample_pressure, work_.wall_reaction);
    timings_.boundary += secondsSince(t0);
  }

  t0 = Clock::now();
  fluid_->computeAccelerations(model_.gravity, wall_accelerations,
                               dfsph_ ? &dfsph_->pairDerivatives() : nullptr);
  timings_.forces += secondsSince(t0);
  if (penalty_) {
    // Baseline: boundary forces join the fluid's forces; no control, no correction.
    t0 = Clock::now();
    data_.run.last_contacts = penalty_->apply(*boundaries_, work_.placed, st.position,
                                              st.acceleration, work_.flags, data_.wrenches);
    const double t_penalty = secondsSince(t0);
    timings_.control += t_penalty;
    timings_.boundary += t_penalty;
  }
  if (fluid_forces_) {
    t0 = Clock::now();
    fluid_forces_(st, st.acceleration, data_.run.time);
    if (st.acceleration.size() != st.size())
      throw std::logic_error("FluidForces changed the size of the acceleration array");
    timings_.forces += secondsSince(t0);
  }
}

void Simulation::predict(double dt) {
  // v* = v + dt a, x* = x + dt v* (all forces but direct forcing's); the bodies over dt
  // without fluid forces.
  auto t0 = Clock::now();
  fluid_->predict(dt);
  timings_.integration += secondsSince(t0);
  if (consistent_) {
    // The pressure that brings v* to the rest density at the step's end through the
    // consistent pressure force, x* from the new v*, and the bodies' pressure force from
    // their samples at that pressure (contact faces included), as the weakly compressible
    // fluid's.
    t0 = Clock::now();
    double error = 0.0;
    data_.run.solver_iterations +=
        consistent_->solve(*fluid_, *boundaries_, work_.placed, model_.gravity, work_.wall_pairs,
                           work_.solver_boundary, dfsph_->pairDerivatives(), work_.sample_pressure,
                           model_.dfsph, dt, error);
    FluidState& st = fluid_->state();
    const double follow = dt / (DivergenceFreeSolver::kPressureMeanTime + dt);
    const std::int64_t n = static_cast<std::int64_t>(st.size());
#pragma omp parallel for schedule(static)
    for (std::int64_t i = 0; i < n; ++i)
      st.pressure_mean[i] += follow * (st.pressure[i] - st.pressure_mean[i]);
    for (Wrench& w : data_.solver_forces)
      w = Wrench{};
    fluid_->predictPositions(dt);
    timings_.solver += secondsSince(t0);
    t0 = Clock::now();
    boundaries_->addContactPressure(work_.placed, model_.gravity, work_.sample_pressure);
    boundaries_->addBodyPressure(work_.placed, work_.sample_pressure, work_.wall_reaction);
    timings_.boundary += secondsSince(t0);
  } else if (dfsph_) {
    // The pressure that brings v* to the rest density at the step's end, its push on the
    // two-way bodies, and x* from the new v*.
    t0 = Clock::now();
    data_.run.solver_iterations += dfsph_->solveDensity(*fluid_, model_.gravity, dt);
    timings_.solver += secondsSince(t0);
    for (std::size_t b = 0; b < dfsph_->bodyForces().size(); ++b)
      data_.solver_forces[b] = Wrench{dfsph_->bodyForces()[b], dfsph_->bodyTorques()[b]};
    fluid_->predictPositions(dt);
    timings_.forces += secondsSince(t0);
    t0 = Clock::now();
    boundaries_->addSolverReaction(*fluid_, work_.placed, work_.wall_pairs, dfsph_->wallImpulse(),
                                   dfsph_->wallLift(), work_.solver_boundary.above_share,
                                   model_.gravity, dt, work_.wall_reaction);
    timings_.boundary += secondsSince(t0);
  }
  t0 = Clock::now();
  rigid_->predict(dt, work_.body_pred);
  // The walls' pressure and shear on each two-way body are known before the control: the
  // body is predicted with them, so the control sees only what they leave to it.
  for (std::size_t b = 0; b < work_.body_pred.size(); ++b) {
    RigidPrediction& p = work_.body_pred[b];
    if (!boundaries_->body(b).twoWay() || !(p.inverse_mass > 0.0)) continue;
    const Vec3 dv = (dt * p.inverse_mass) * work_.wall_reaction[b].force;
    const Vec3 dw = dt * (p.inverse_inertia_world * work_.wall_reaction[b].torque);
    p.state.linear_velocity += dv;
    p.state.angular_velocity += dw;
    p.state.pose = integratePose(p.state.pose, dv, dw, dt);
  }
  timings_.rigid += secondsSince(t0);
}

ControlResult Simulation::controlVelocities(double dt) {
  if (penalty_) return {};
  // Contacts and velocity control with the bodies at their predicted poses.
  const auto t0 = Clock::now();
  const std::size_t nb = boundaries_->bodyCount();
  std::vector<RigidState>& predicted = work_.body_final;  // scratch reuse
  predicted.resize(nb);
  for (std::size_t b = 0; b < nb; ++b)
    predicted[b] = work_.body_pred[b].state;
  boundaries_->place(predicted, work_.placed);
  FluidState& st = fluid_->state();
  const ControlResult control = forcing_.control(
      *boundaries_, {work_.placed, work_.body_now, work_.body_pred},
      {fluid_->predictedPositions(), fluid_->stepStartVelocities(), st.velocity, work_.flags},
      model_.method, dt, data_.wrenches);
  data_.run.last_contacts = control.contacts;
  const double t_control = secondsSince(t0);
  timings_.control += t_control;
  timings_.boundary += t_control;
  return control;
}

void Simulation::stepBodies(double dt) {
  // The bodies take exactly one step with the fluid's wrench: control (or penalty) plus
  // the walls' viscous shear and pressure.
  const auto t0 = Clock::now();
  const std::size_t nb = boundaries_->bodyCount();
  for (std::size_t b = 0; b < nb; ++b) {
    WrenchParts& part = work_.parts[b];
    part.control = data_.wrenches[b];
    part.pressure.force = work_.wall_reaction[b].force - part.shear.force;
    part.pressure.torque = work_.wall_reaction[b].torque - part.shear.torque;
    data_.wrenches[b].force += work_.wall_reaction[b].force;
    data_.wrenches[b].torque += work_.wall_reaction[b].torque;
  }
  if (nb > 0) rigid_->step(dt, data_.wrenches);
  currentStates(work_.body_final);
  timings_.rigid += secondsSince(t0);
}

void Simulation::integrateAndCorrect(double dt, const ControlResult& control) {
  auto t0 = Clock::now();
  fluid_->integratePositions(dt);
  timings_.integration += secondsSince(t0);
  // Position correction against the bodies' final poses (also where the step's health
  // counts penetration).
  t0 = Clock::now();
  boundaries_->place(work_.body_final, work_.placed);
  if (!penalty_ && (control.particles > 0 || boundaries_->hasMovingBodies()))
    correctPositions(*boundaries_, work_.placed, fluid_->state().position, work_.flags,
                     dfsph_ ? &fluid_->state().velocity : nullptr);
  const double t_correction = secondsSince(t0);
  timings_.correction += t_correction;
  timings_.boundary += t_correction;
}

void Simulation::checkHealth() {
  // Finite positions and velocities, the density ratio's limit; penetration against the
  // exact shapes at the bodies' final poses.
  const FluidState& st = fluid_->state();
  const FluidHealth health =
      checkFluidHealth(st, model_.fluid.rest_density, model_.health.max_density_ratio);
  if (!health.ok()) fail(health);
  const double ratio = health.max_density_ratio;
  const std::size_t penetrating = boundaries_->countInside(st.position, work_.placed);
  data_.run.max_density_ratio = std::max(data_.run.max_density_ratio, ratio);
  data_.run.max_penetrating = std::max(data_.run.max_penetrating, penetrating);
  data_.run.window_density_ratio = std::max(data_.run.window_density_ratio, ratio);
  data_.run.window_penetrating = std::max(data_.run.window_penetrating, penetrating);
}

void Simulation::advanceTo(double t) {
  while (data_.run.time < t)
    step(t);
}

SimulationState Simulation::saveState() const {
  SimulationState s;
  static_cast<RunData&>(s) = data_;
  s.rigid = rigid_->saveState();
  const std::vector<Vec3f>& reference = fluid_->neighborReference();
  s.neighbor_reference.resize(reference.size());
  for (std::size_t i = 0; i < reference.size(); ++i)
    s.neighbor_reference[i] = reference[i].cast<double>();  // exact
  s.neighbor_reference_id = fluid_->neighborReferenceIds();
  return s;
}

void Simulation::restoreState(const SimulationState& s) {
  const FluidState& f = s.fluid;
  const std::size_t n = f.size();
  const bool sizes_agree = f.velocity.size() == n && f.acceleration.size() == n &&
                           f.density.size() == n && f.pressure.size() == n && f.id.size() == n &&
                           f.kinematic_viscosity.size() == n &&
                           (!f.keepsPressureMean() || f.pressure_mean.size() == n);
  require(sizes_agree, "state.fluid", "its arrays differ in length");
  require(s.wrenches.size() == data_.wrenches.size(), "state.wrenches",
          "has " + std::to_string(s.wrenches.size()) + " bodies, the simulation " +
              std::to_string(data_.wrenches.size()));
  require(std::isfinite(s.run.time) && s.run.time >= 0, "state.run.time",
          "must be finite and >= 0");
  rigid_->loadState(s.rigid);
  require(s.solver_forces.empty() || s.solver_forces.size() == s.wrenches.size(),
          "state.solver_forces",
          "has " + std::to_string(s.solver_forces.size()) + " bodies, the simulation " +
              std::to_string(data_.wrenches.size()));
  data_ = static_cast<const RunData&>(s);  // fluid_ steps data_.fluid
  // A checkpoint written before the solver's body forces were kept: none (the solve's
  // first step after it sees the bodies as a first step does).
  if (data_.solver_forces.empty()) data_.solver_forces.assign(data_.wrenches.size(), Wrench{});
  fluid_->restoreNeighborReference(s.neighbor_reference, s.neighbor_reference_id);
  failure_.reset();
}

void Simulation::snapshot(FluidSnapshot& out) const {
  const FluidState& st = fluid_->state();
  const std::size_t n = st.size();
  const std::vector<std::uint32_t> order = idOrder(st);
  out.id.resize(n);
  out.position.resize(n);
  out.velocity.resize(n);
  out.density.resize(n);
  out.pressure.resize(n);
  // The divergence-free solver's pressure of one step comes in kicks (each solve stops once
  // the compression is within its tolerance: a column at rest swings 0.6-1.6 times its
  // mean pressure from step to step); its running mean is the pressure that holds the fluid.
  const std::vector<double>& pressure = st.keepsPressureMean() ? st.pressure_mean : st.pressure;
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t i = order[k];
    out.id[k] = st.id[i];
    out.position[k] = st.position[i];
    out.velocity[k] = st.velocity[i];
    out.density[k] = st.density[i];
    out.pressure[k] = pressure[i];
  }
  if (steps() == 0) startDensities(out);
}

void Simulation::startDensities(FluidSnapshot& out) const {
  // Before the first step nothing has summed the densities: a copy of the fluid is
  // sorted and summed as a step would (fluid and walls' share), the run's state untouched.
  // A fluid with particles the first step will remove (outside the domain, not finite)
  // keeps its densities as they are.
  for (const Vec3& x : out.position)
    if (!finite(x) || !model_.domain.contains(x)) return;
  FluidState copy = fluid_->state();
  Fluid probe(fluid_->params(), model_.domain, &copy);
  probe.updateNeighbors();
  probe.computeFluidDensity();
  boundaries_->addDensity(probe, placement(), copy.density);
  if (!dfsph_) probe.computePressure();  // the solver's pressure is found by a step
  std::vector<std::uint32_t> rank_of_id;
  for (std::size_t k = 0; k < out.id.size(); ++k) {
    const std::uint32_t id = out.id[k];
    if (id >= rank_of_id.size()) rank_of_id.resize(id + 1, 0);
    rank_of_id[id] = static_cast<std::uint32_t>(k);
  }
  for (std::size_t i = 0; i < copy.size(); ++i) {
    const std::uint32_t k = rank_of_id[copy.id[i]];
    out.density[k] = copy.density[i];
    out.pressure[k] = copy.pressure[i];
  }
}

std::uint64_t stateHash(const Simulation& sim) {
  // The bytes of the positions, then of the velocities, in particle-number order (the
  // snapshot's), read in place: no copy of the state.
  const FluidState& st = sim.fluid().state();
  const std::vector<std::uint32_t> order = idOrder(st);
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&](const Vec3& v) {
    const unsigned char* p = reinterpret_cast<const unsigned char*>(v.data());
    for (std::size_t i = 0; i < sizeof(Vec3); ++i)
      h = (h ^ p[i]) * 1099511628211ull;
  };
  for (const std::uint32_t i : order)
    mix(st.position[i]);
  for (const std::uint32_t i : order)
    mix(st.velocity[i]);
  return h;
}

std::vector<BodyState> Simulation::bodyStates() const {
  std::vector<BodyState> out;
  for (std::size_t b = 0; b < boundaries_->bodyCount(); ++b) {
    const RigidState s = rigid_->state(b);
    out.push_back({boundaries_->body(b).name, s.pose.position, s.pose.orientation,
                   s.linear_velocity, s.angular_velocity});
  }
  return out;
}

}  // namespace wake
