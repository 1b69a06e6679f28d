// Dam-break benchmark: a water column collapsing in a static tank, timed on 1 and 2
// threads. Prints particles, steps, seconds per step, nanoseconds per particle per step,
// the split of the step, a state hash (equal hashes = identical results) and the peak
// resident memory of the process per fluid particle.
//
//   wake_bench_dambreak [--particles N] [--steps S] [--warmup W] [--threads 1,2]
//                       [--scene FILE] [--solver wcsph|dfsph]
//                       [--pressure-gradient consistent|symmetric]
//
// Without --scene: a synthetic column (nx x 2nx x nx particles of radius 5 mm) at one end
// of a tank four columns long. With --scene: that scene file (its static bodies through
// Bullet, as `wake run` has them), refined or coarsened to about N fluid particles when
// --particles is given; bench/spheric2.json is the SPHERIC-2 dam break.
#include "bench/common.hpp"
#include "bullet_bridge/scene_world.hpp"
#include "coupling/simulation.hpp"
#include "io/process.hpp"
#include "io/scene.hpp"

#include <sys/resource.h>

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

using namespace wake;
using namespace wake::bench;

namespace {

/// Column of nx x 2nx x nx particles (spacing 1 cm) at one end of a tank 4 columns long.
SimulationSettings damBreak(long particles) {
  const double r = 0.005, s = 2 * r;
  const int nx = std::max(1, int(std::lround(std::cbrt(particles / 2.0))));
  const Vec3 column = s * Vec3(nx, 2 * nx, nx);
  SimulationSettings set;
  set.fluid.particle_radius = r;
  set.blocks.push_back({Vec3::Zero(), column, Vec3::Zero()});
  BodySettings tank;
  tank.name = "tank";
  tank.shape = makeTank(Vec3::Zero(), Vec3(4 * column.x(), 1.5 * column.y(), column.z()), 2 * s);
  set.bodies.push_back(tank);
  return set;
}

/// The simulation a run times: the synthetic dam break, or the scene's through Bullet.
struct Bench {
  std::unique_ptr<Simulation> own;
  std::unique_ptr<SceneWorld> world;
  Simulation& sim() { return own ? *own : world->coupled().simulation(); }
};

Bench make(const Options& opt) {
  Bench b;
  if (opt.scene.empty()) {
    SimulationSettings s = damBreak(opt.particles);
    if (opt.dfsph) s.solver = FluidSolver::Dfsph;
    s.fluid.pressure_gradient = opt.pressure_gradient;
    if (opt.skin >= 0) s.neighbor_skin = opt.skin * s.fluid.supportRadius();
    b.own = std::make_unique<Simulation>(s);
    return b;
  }
  SceneFile scene = loadScene(opt.scene);
  if (opt.dfsph) scene.sim.solver = FluidSolver::Dfsph;
  if (!opt.dfsph && scene.sim.solver == FluidSolver::Wcsph)
    scene.sim.fluid.pressure_gradient = opt.pressure_gradient;
  if (opt.particles_given)
    overrideResolution(scene, std::cbrt(double(opt.particles) / estimateFluidParticles(scene.sim)));
  if (opt.skin >= 0) scene.sim.neighbor_skin = opt.skin * scene.sim.fluid.supportRadius();
  b.world = std::make_unique<SceneWorld>(scene.sim, scene.bodies);
  b.world->coupled().start();
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  wake::mapLargeBlocksApart();
  const Options opt = parse(argc, argv);
  std::printf(
      "# Wake dam-break benchmark: %s, %ld requested particles, %d warm-up + %d timed "
      "steps\n",
      opt.scene.empty() ? "synthetic column" : opt.scene.c_str(), opt.particles, opt.warmup,
      opt.steps);
  std::printf("%7s %9s %9s %6s %10s %11s %8s %8s %8s %8s %8s %9s %18s\n", "threads", "fluid",
              "boundary", "steps", "s/step", "ns/p/step", "nbr%", "dens%", "force%", "bound%",
              "integ%", "sim_t[s]", "state_hash");
  double single = 0.0;
  std::size_t most_particles = 0;
  for (int threads : opt.threads) {
    omp_set_num_threads(threads);
    Bench bench;
    try {
      bench = make(opt);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "error: %s\n", e.what());
      return 1;
    }
    Simulation& sim = bench.sim();
    most_particles = std::max(most_particles, sim.fluidParticles());
    for (int i = 0; i < opt.warmup; ++i)
      sim.step(1e9);
    const StepTimings before = sim.timings();
    const std::uint64_t iterations0 = sim.densityIterations();
    const std::uint64_t divergence0 = sim.divergenceIterations();
    const std::uint64_t builds0 = sim.fluid().neighborBuilds();
    const std::uint64_t skinned0 = sim.fluid().neighborSkinnedBuilds();
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < opt.steps; ++i)
      sim.step(1e9);
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const StepTimings t = since(sim.timings(), before);
    const double per_step = wall / opt.steps;
    const double ns = 1e9 * per_step / double(sim.fluidParticles());
    const double total = t.total();
    std::printf("%7d %9zu %9zu %6d %10.5f %11.1f %8.1f %8.1f %8.1f %8.1f %8.1f %9.5f %18llx\n",
                threads, sim.fluidParticles(), sim.boundaryParticles(), opt.steps, per_step, ns,
                100 * t.neighbors / total, 100 * t.density / total, 100 * t.forces / total,
                100 * t.boundary / total, 100 * t.integration / total, sim.time(),
                static_cast<unsigned long long>(stateHash(sim)));
    // The phases per particle and step, and the rest of the step's wall time (the time
    // step, the health check and the penetration count, the step's bookkeeping): what
    // each costs and, between the thread counts, how each scales.
    const double per = 1e9 / opt.steps / double(sim.fluidParticles());
    std::printf(
        "# ns/particle/step: neighbours %.1f, density %.1f, forces %.1f, boundary %.1f, "
        "integration %.1f, rigid %.1f, rest of the step %.1f\n",
        per * t.neighbors, per * t.density, per * t.forces, per * t.boundary, per * t.integration,
        per * t.rigid, per * (wall - total));
    std::printf(
        "# neighbour lists sorted and built at %llu of %d steps, %llu of them with the skin "
        "(%.3g m)\n",
        static_cast<unsigned long long>(sim.fluid().neighborBuilds() - builds0), opt.steps,
        static_cast<unsigned long long>(sim.fluid().neighborSkinnedBuilds() - skinned0),
        sim.fluid().neighborSkin());
    if (opt.dfsph) {
      const double it = double(sim.densityIterations() - iterations0) / opt.steps;
      const double itv = double(sim.divergenceIterations() - divergence0) / opt.steps;
      std::printf(
          "# dfsph: %.2f density + %.2f divergence iterations per step, %.1f ns per "
          "particle per iteration (the solves' time / iterations)\n",
          it, itv,
          1e9 * t.solver / opt.steps / double(sim.fluidParticles()) / std::max(it + itv, 1.0));
    }
    if (threads == 1)
      single = per_step;
    else if (single > 0)
      std::printf("# speed-up on %d threads: %.2fx\n", threads, single / per_step);
  }
  // Peak resident set of the process (what /usr/bin/time -v reports), over all runs.
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const double peak = 1024.0 * double(usage.ru_maxrss);
  std::printf("# peak resident memory: %.0f MiB, %.0f bytes per fluid particle\n",
              peak / (1024.0 * 1024.0), peak / double(std::max<std::size_t>(most_particles, 1)));
  return 0;
}
