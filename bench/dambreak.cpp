// Dam-break benchmark: a water column collapsing in a static tank, timed on 1 and 2
// threads. Prints particles, steps, seconds per step, nanoseconds per particle per step,
// the split of the step, and a state hash (equal hashes = identical results).
//
//   wake_bench_dambreak [--particles N] [--steps S] [--warmup W] [--threads 1,2]
#include "bench/common.hpp"
#include "coupling/simulation.hpp"

#include <omp.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
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

}  // namespace

int main(int argc, char** argv) {
  const Options opt = parse(argc, argv);
  std::printf("# Wake dam-break benchmark: %ld requested particles, %d warm-up + %d timed steps\n",
              opt.particles, opt.warmup, opt.steps);
  std::printf("%7s %9s %9s %6s %10s %11s %8s %8s %8s %8s %8s %9s %18s\n", "threads", "fluid",
              "boundary", "steps", "s/step", "ns/p/step", "nbr%", "dens%", "force%", "bound%",
              "integ%", "sim_t[s]", "state_hash");
  double single = 0.0;
  for (int threads : opt.threads) {
    omp_set_num_threads(threads);
    Simulation sim(damBreak(opt.particles));
    for (int i = 0; i < opt.warmup; ++i)
      sim.step(1e9);
    const StepTimings before = sim.timings();
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
    if (threads == 1)
      single = per_step;
    else if (single > 0)
      std::printf("# speed-up on %d threads: %.2fx\n", threads, single / per_step);
  }
  return 0;
}
