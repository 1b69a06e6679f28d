// Property: no fluid centre inside any body after any step, and nothing leaves a closed
// tank, in random scenes. Boxes, spheres and capsules of random density (0.2-3 times the
// fluid's), size and orientation are dropped into narrow tanks, so that they float,
// sink, roll and jam against the walls and each other (some sized to leave a gap of
// zero to three spacings to the tank's narrow walls); sometimes a kinematic plate comes
// down on them. Local and global control, slip 0 and 1; the weakly compressible fluid, and
// the divergence-free solver at its largest steps (time.cfl 0.6, max_dt 4 ms: a particle
// moves up to 0.6 H a step; WAKE_PROPERTY_DFSPH_CFL and WAKE_PROPERTY_DFSPH_MAX_DT change
// them).
//
// A light box jammed across a narrow tank under the plate (seed 1028, global control) spun
// up step after step with the divergence-free solver (4, 10, 22, 83, 222, 2430 rad/s) and
// threw fluid out of the tank, at every time step tried (1 ms / cfl 0.4 too): the solve's
// pressure answered the body's velocity, the body took the push in Bullet's step after,
// and a light body boxed in by walls has far more fluid to push than its own mass (the
// added-mass instability of an explicit coupling). The solves now move the two-way bodies
// as they push them (DivergenceFreeSolver, sph/dfsph.hpp); seeds 1035 (local, r = 5 mm)
// and 511 (r = 4 mm), which lost a few particles the same way, pass too.
//
// CI runs a few cases at a small resolution. Run more, or finer, with
//   WAKE_PROPERTY_CASES=100 WAKE_PROPERTY_RADIUS=0.004 build/tests/wake_property_tests
// (cases per control method, first seed WAKE_PROPERTY_SEED, default 1; the bodies' density
// ratios drawn from WAKE_PROPERTY_DENSITY_MIN .. _MAX, default 0.2 .. 3; WAKE_PROPERTY_TRACE=1
// prints the bodies every 0.01 s, =2 also the fluid centres inside a body).
#include "bullet_bridge/scene_world.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

namespace wake {
namespace {

int envInt(const char* name, int fallback) {
  const char* v = std::getenv(name);
  return v ? std::atoi(v) : fallback;
}
double envDouble(const char* name, double fallback) {
  const char* v = std::getenv(name);
  return v ? std::atof(v) : fallback;
}

struct Case {
  SimulationSettings sim;
  std::vector<BodySpec> bodies;
  std::string text;  ///< what was drawn, for the failure message
  double end = 0.6;  ///< s
};

/// One random scene: a narrow tank partly filled, one to three bodies, maybe a plate.
/// The bodies' density ratios are drawn from [lightest, heaviest].
Case randomCase(unsigned seed, CouplingMethod method, double radius, double lightest,
                double heaviest) {
  std::mt19937 rng(seed);
  auto uniform = [&](double a, double b) {
    return std::uniform_real_distribution<double>(a, b)(rng);
  };
  Case c;
  const double sp = 2 * radius;
  // Bodies and plate start below `height`; the walls go up to `rim`, high enough for the
  // splashes, so that a particle lost went through a wall: a dense body dropped into the
  // tank squeezes jets up its walls. Seed 18 (a box of 2.6 the water's density jammed
  // across the tank) threw one at 2 m/s to 0.258 m, over a rim at 0.25 m; seed 8 (WCSPH,
  // local: a box of 2.2 entering at 1.3 m/s) one at 2.5 m/s to 0.433 m and seed 7 (the
  // consistent pressure force, local: a jammed capsule of 2.9) one at 2.9 m/s to 0.586 m,
  // over a rim at 0.35 m. A jet of 4 m/s rises 0.8 m.
  const double width = uniform(0.10, 0.20), narrow = uniform(0.05, 0.10), height = 0.25;
  const double rim = 1.0;
  const double fill = uniform(0.06, 0.12);
  const double slip = seed % 2 == 0 ? 0.0 : 1.0;
  c.sim.fluid.particle_radius = radius;
  c.sim.fluid.viscosity = 0.05;
  c.sim.method = method;
  c.sim.blocks.push_back({Vec3::Zero(), Vec3(width, fill, narrow)});
  BodySpec tank;
  tank.name = "tank";
  tank.coupling = CouplingMode::OneWay;
  tank.shape.type = "tank";
  tank.shape.min = Vec3::Zero();
  tank.shape.max = Vec3(width, rim, narrow);
  tank.slip = slip;
  c.bodies.push_back(tank);
  char line[256];
  std::snprintf(line, sizeof line, "seed %u %s slip %.0f tank %.3f x %.3f fill %.3f;", seed,
                method == CouplingMethod::Global ? "global" : "local", slip, width, narrow, fill);
  c.text = line;

  struct Placed {
    Vec3 at;
    double r;
  };
  std::vector<Placed> placed;
  const int count = 1 + int(rng() % 3);
  for (int k = 0; k < count; ++k) {
    BodySpec b;
    b.name = "b" + std::to_string(k);
    b.kind = BodyKind::Dynamic;
    b.slip = slip;
    b.density = 1000.0 * uniform(lightest, heaviest);
    const int type = int(rng() % 3);
    // Jammed: as wide as the narrow side less a gap of 0 to 3 spacings.
    const bool jam = uniform(0, 1) < 0.4;
    const double gap = uniform(0, 3) * sp;
    const double half_z =
        jam ? std::max(0.01, 0.5 * narrow - gap) : uniform(0.01, std::min(0.035, 0.45 * narrow));
    bool aligned = jam || uniform(0, 1) < 0.3;
    double bound = 0;
    if (type == 0) {
      b.shape.type = "box";
      b.shape.half_extents = Vec3(uniform(0.01, 0.04), uniform(0.01, 0.035), half_z);
      bound = b.shape.half_extents.norm();
    } else if (type == 1) {
      b.shape.type = "sphere";
      b.shape.radius = half_z;
      bound = half_z;
      aligned = true;
    } else {
      b.shape.type = "capsule";
      b.shape.radius = std::min(half_z, 0.03);
      b.shape.height = uniform(0.0, 0.05);
      bound = b.shape.radius + 0.5 * b.shape.height;
    }
    if (!aligned) {
      b.pose.orientation =
          Quat(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)).normalized();
    } else if (type != 1) {
      // About z only (keeps the narrow extent); capsules lie along x half the time.
      const double a = (type == 2 && uniform(0, 1) < 0.5) ? 0.5 * M_PI : uniform(-0.4, 0.4);
      b.pose.orientation = Quat(Eigen::AngleAxisd(a, Vec3::UnitZ()));
    }
    bool ok = false;
    Vec3 at = Vec3::Zero();
    for (int tries = 0; tries < 200 && !ok; ++tries) {
      const double reach = aligned ? std::min(bound, 0.5 * width - 0.002) : bound;
      at.x() = uniform(reach + 0.002, width - reach - 0.002);
      at.y() = uniform(bound + sp, height - bound);
      at.z() = aligned ? 0.5 * narrow : uniform(bound, narrow - bound);
      ok = at.x() > 0 && at.x() < width && (aligned || (at.z() > bound && at.z() < narrow - bound));
      for (const Placed& p : placed)
        ok = ok && (at - p.at).norm() > p.r + bound + 0.003;
    }
    if (!ok) continue;
    placed.push_back({at, bound});
    b.pose.position = at;
    c.bodies.push_back(b);
    std::snprintf(line, sizeof line, " %s %s density %.0f at (%.3f %.3f %.3f)%s;", b.name.c_str(),
                  b.shape.type.c_str(), b.density, at.x(), at.y(), at.z(), jam ? " jammed" : "");
    c.text += line;
  }
  if (uniform(0, 1) < 0.3) {
    // A kinematic plate across the tank comes down through the bodies.
    BodySpec plate;
    plate.name = "plate";
    plate.kind = BodyKind::Kinematic;
    plate.coupling = CouplingMode::OneWay;
    plate.slip = slip;
    plate.shape.type = "box";
    plate.shape.half_extents = Vec3(0.3 * width, 0.01, 0.5 * narrow - uniform(0, 2) * sp);
    // Above every body (Bullet would throw an overlapping body out at once).
    double top = height - 0.01;
    for (const Placed& p : placed)
      top = std::max(top, p.at.y() + p.r + 0.015);
    plate.pose.position = Vec3(0.5 * width, top, 0.5 * narrow);
    plate.linear_velocity = Vec3(0, -uniform(0.1, 0.3), 0);
    c.bodies.push_back(plate);
    std::snprintf(line, sizeof line, " plate down at %.2f m/s;", -plate.linear_velocity.y());
    c.text += line;
  }
  return c;
}

/// The bodies at time t, and with WAKE_PROPERTY_TRACE=2 the fluid centres inside a body.
void trace(const Simulation& sim, double t) {
  std::printf("t %.2f steps %llu dt %.2e lost %zu pen %zu:", t,
              static_cast<unsigned long long>(sim.steps()), sim.lastDt(), sim.lostParticles(),
              sim.maxPenetrating());
  for (const BodyState& b : sim.bodyStates())
    std::printf(" %s y %.4f v (%.3f %.3f %.3f) w %.2f", b.name.c_str(), b.position.y(),
                b.linear_velocity.x(), b.linear_velocity.y(), b.linear_velocity.z(),
                b.angular_velocity.norm());
  std::printf("\n");
  if (envInt("WAKE_PROPERTY_TRACE", 0) < 2) return;
  const BodyPlacement at = sim.placement();
  FluidSnapshot snap;
  sim.snapshot(snap);
  for (std::size_t i = 0; i < snap.position.size(); ++i) {
    const Vec3& x = snap.position[i];
    if (!(sim.boundaries().signedDistance(x, at) < 0)) continue;
    const Boundaries::Clearance clear = sim.boundaries().clearance(x, at);
    std::printf("  inside: id %u at (%.4f %.4f %.4f) clearance %.5f (walls %.5f)\n", snap.id[i],
                x.x(), x.y(), x.z(), clear.all, clear.walls);
  }
}

/// Cases first .. first + cases - 1 (WAKE_PROPERTY_CASES, WAKE_PROPERTY_SEED and
/// WAKE_PROPERTY_DENSITY_MIN / _MAX replace the defaults; WAKE_PROPERTY_DFSPH_CONSISTENT=1
/// gives the divergence-free cases the consistent pressure force, as `consistent` does).
void runCases(CouplingMethod method, FluidSolver solver = FluidSolver::Wcsph, int default_cases = 3,
              int default_seed = 1, double lightest = 0.2, double heaviest = 3.0,
              bool consistent = false) {
  const int cases = envInt("WAKE_PROPERTY_CASES", default_cases);
  const unsigned first = unsigned(envInt("WAKE_PROPERTY_SEED", default_seed));
  const double radius = envDouble("WAKE_PROPERTY_RADIUS", 0.005);
  lightest = envDouble("WAKE_PROPERTY_DENSITY_MIN", lightest);
  heaviest = envDouble("WAKE_PROPERTY_DENSITY_MAX", heaviest);
  std::size_t worst_inside = 0, worst_lost = 0;
  for (unsigned seed = first; seed < first + unsigned(cases); ++seed) {
    Case c = randomCase(seed, method, radius, lightest, heaviest);
    if (solver == FluidSolver::Dfsph) {
      c.sim.solver = FluidSolver::Dfsph;
      c.sim.cfl = envDouble("WAKE_PROPERTY_DFSPH_CFL", 0.6);
      c.sim.max_dt = envDouble("WAKE_PROPERTY_DFSPH_MAX_DT", 4e-3);
      c.text += " dfsph;";
      if (consistent || envInt("WAKE_PROPERTY_DFSPH_CONSISTENT", 0)) {
        c.sim.dfsph.pressure_force = DfsphParams::PressureForce::Consistent;
        c.text += " consistent;";
      }
    }
    SceneWorld world(c.sim, c.bodies);
    std::size_t steps_checked = 0;
    for (double t = 0.01; t < c.end + 1e-9; t += 0.01) {
      world.coupled().advanceTo(t);  // max_penetrating counts after every step
      ++steps_checked;
      if (envInt("WAKE_PROPERTY_TRACE", 0)) trace(world.simulation(), t);
    }
    const Simulation& sim = world.simulation();
    std::printf("[ property ] %s steps %llu, max density %.3f: max_penetrating %zu, lost %zu\n",
                c.text.c_str(), static_cast<unsigned long long>(sim.steps()), sim.maxDensityRatio(),
                sim.maxPenetrating(), sim.lostParticles());
    std::fflush(stdout);
    EXPECT_EQ(sim.maxPenetrating(), 0u) << c.text;
    EXPECT_EQ(sim.lostParticles(), 0u) << c.text;
    worst_inside = std::max(worst_inside, sim.maxPenetrating());
    worst_lost = std::max(worst_lost, sim.lostParticles());
  }
  std::printf("[ property ] %d cases: worst max_penetrating %zu, worst lost %zu\n", cases,
              worst_inside, worst_lost);
}

TEST(NoFluidInside, RandomBodiesInNarrowTanksLocalControl) {
  runCases(CouplingMethod::Local);
}

TEST(NoFluidInside, RandomBodiesInNarrowTanksGlobalControl) {
  runCases(CouplingMethod::Global);
}

TEST(NoFluidInside, RandomBodiesInNarrowTanksDivergenceFreeLocalControl) {
  runCases(CouplingMethod::Local, FluidSolver::Dfsph);
}

TEST(NoFluidInside, RandomBodiesInNarrowTanksDivergenceFreeGlobalControl) {
  runCases(CouplingMethod::Global, FluidSolver::Dfsph);
}

TEST(NoFluidInside, DivergenceFreeSolveStaysBoundedBesideAJammedBoxAndAPlate) {
  // Seed 139: two boxes and a capsule jammed across the tank, a plate coming down. Two
  // particles beside a wall, each the other's only fluid neighbour, made the walls' pressure
  // of one (through its large wall gradient) feed the other's rate: the divergence solve
  // diverged (1e35 m/s) and 338 particles left the tank before the walls' mean pressure
  // took a floor (DivergenceFreeSolver::computeFactors).
  runCases(CouplingMethod::Global, FluidSolver::Dfsph, 1, 139);
}

TEST(NoFluidInside, DivergenceFreeSolveHoldsALightBoxJammedUnderAPlate) {
  // Seed 1028: a box of 0.21 the water's density jammed across the tank, the plate pressing
  // it down through the water from 0.5 s. With the bodies held at their velocities through
  // the solves it rocked across the narrow gap, each step's push the opposite of the last
  // and larger (0.25, 1.2, 3.4, 10.6, 54, 1340 N), and 161 particles left the tank.
  runCases(CouplingMethod::Global, FluidSolver::Dfsph, 1, 1028);
}

TEST(NoFluidInside, DivergenceFreeSolveHoldsVeryLightBodies) {
  // Seed 2015 with density ratios 0.05-0.3: spheres of 0.10 and 0.16 the water's density
  // (one jammed across the tank) under a box of 0.29 and the plate. Each iteration's
  // increments, taken as if the bodies were held, pushed the lightest sphere with many
  // times its mass of fluid; once the increments also left out the spheres' answer to them
  // (the body's change solved for with the particles it would take below zero held there),
  // it stopped rocking; before, the divergence solve diverged (753 particles out of the
  // tank; 321 with the bodies held at their velocities through the solves).
  runCases(CouplingMethod::Global, FluidSolver::Dfsph, 1, 2015, 0.05, 0.3);
}

TEST(NoFluidInside, ConsistentDensitySolveEndsOnItsBestIterate) {
  // Seed 17 with the consistent pressure force: a box of 2.4 the water's density jammed
  // across the tank sinks through the water under the plate. In one 3.3 ms step the
  // Jacobi iteration turned away after 40 iterations (the average deviation 7.5e-4, then
  // 1.75e-3 at 100): one particle beside the box, its neighbours at 5 kPa or less, was
  // at 34 kPa, went from 0.45 to 7.7 m/s and through the tank's wall. The solve now ends on
  // its best iterate (ConsistentDensitySolve::kPatience).
  runCases(CouplingMethod::Global, FluidSolver::Dfsph, 1, 17, 0.2, 3.0, /*consistent=*/true);
}

}  // namespace
}  // namespace wake
