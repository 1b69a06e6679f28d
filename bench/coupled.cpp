// Coupled benchmark: floating boxes on a pool of fluid, Bullet in the loop, timed on 1 and
// 2 threads. Prints the fluid step's cost and the coupling's (contacts and control forces,
// position correction, the bodies' prediction and Bullet step) as a fraction of it.
//
//   wake_bench_coupled [--particles N] [--bodies B] [--steps S] [--warmup W] [--threads 1,2]
//                      [--pressure-gradient consistent|symmetric]
#include "bench/common.hpp"
#include "bullet_bridge/scene_world.hpp"
#include "io/process.hpp"

#include <omp.h>

#include <chrono>
#include <cmath>
#include <cstdio>

using namespace wake;
using namespace wake::bench;

namespace {

/// A pool 20 cm deep (spacing 1 cm) in a tank twice as long as wide, with `bodies`
/// boxes (10 x 6 x 10 cm, 500 kg/m^3) resting on the surface in a grid.
std::pair<SimulationSettings, std::vector<BodySpec>> pool(long particles, int bodies,
                                                          CouplingMethod method,
                                                          PressureGradient gradient) {
  const double r = 0.005, s = 2 * r, depth = 0.2;
  const double area = double(particles) / (depth / s) * s * s;
  const double width = std::sqrt(area / 2.0), length = 2.0 * width;
  SimulationSettings sim;
  sim.fluid.particle_radius = r;
  sim.fluid.pressure_gradient = gradient;
  sim.method = method;
  sim.blocks.push_back({Vec3::Zero(), Vec3(length, depth, width)});
  std::vector<BodySpec> specs(1);
  specs[0].name = "tank";
  specs[0].coupling = CouplingMode::OneWay;
  specs[0].shape.type = "tank";
  specs[0].shape.max = Vec3(length, 2 * depth, width);
  const int columns = std::max(1, int(std::ceil(std::sqrt(2.0 * bodies))));
  const int rows = std::max(1, (bodies + columns - 1) / columns);
  for (int k = 0; k < bodies; ++k) {
    BodySpec b;
    b.name = "box" + std::to_string(k);
    b.kind = BodyKind::Dynamic;
    b.shape.type = "box";
    b.shape.half_extents = Vec3(0.05, 0.03, 0.05);
    b.density = 500;
    b.pose.position = Vec3(length * (k % columns + 0.5) / columns, depth + 0.015,
                           width * (k / columns + 0.5) / rows);
    specs.push_back(b);
  }
  return {sim, specs};
}

}  // namespace

int main(int argc, char** argv) {
  wake::mapLargeBlocksApart();
  const Options opt = parse(argc, argv);
  std::printf(
      "# Wake coupled benchmark: %ld requested particles, %d floating boxes, "
      "%d warm-up + %d timed steps\n",
      opt.particles, opt.bodies, opt.warmup, opt.steps);
  std::printf("%7s %7s %9s %9s %8s %10s %11s %10s %10s %8s %8s %8s %9s %18s\n", "method", "threads",
              "fluid", "boundary", "contacts", "s/step", "ns/p/step", "fluid[s]", "coupl[s]",
              "coupl%", "ctrl%", "corr%", "bullet%", "state_hash");
  for (CouplingMethod method : {CouplingMethod::Local, CouplingMethod::Global}) {
    double single = 0.0;
    for (int threads : opt.threads) {
      omp_set_num_threads(threads);
      auto [settings, specs] = pool(opt.particles, opt.bodies, method, opt.pressure_gradient);
      SceneWorld world(settings, specs);
      CoupledWorld& coupled = world.coupled();
      coupled.start();
      const Simulation& sim = coupled.simulation();
      auto stepOnce = [&] { coupled.advanceTo(sim.time() + 1e-12 + 0.9 * settings.max_dt); };
      for (int i = 0; i < opt.warmup; ++i)
        stepOnce();
      const StepTimings before = sim.timings();
      const std::uint64_t steps0 = sim.steps();
      std::size_t contacts = 0;
      const auto t0 = std::chrono::steady_clock::now();
      while (sim.steps() - steps0 < std::uint64_t(opt.steps)) {
        stepOnce();
        contacts += sim.lastContacts();
      }
      const double wall =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const int steps = int(sim.steps() - steps0);
      const StepTimings t = since(sim.timings(), before);
      const double coupling = t.coupling();
      const double fluid = t.total() - coupling;
      const double per_step = wall / steps;
      std::printf(
          "%7s %7d %9zu %9zu %8zu %10.5f %11.1f %10.5f %10.5f %8.1f %8.1f %8.1f %9.1f %18llx\n",
          method == CouplingMethod::Global ? "global" : "local", threads, sim.fluidParticles(),
          sim.boundaryParticles(), contacts / steps, per_step,
          1e9 * per_step / double(sim.fluidParticles()), fluid / steps, coupling / steps,
          100 * coupling / fluid, 100 * t.control / fluid, 100 * t.correction / fluid,
          100 * t.rigid / fluid, static_cast<unsigned long long>(stateHash(sim)));
      if (threads == 1)
        single = per_step;
      else if (single > 0)
        std::printf("# %s: speed-up on %d threads: %.2fx\n",
                    method == CouplingMethod::Global ? "global" : "local", threads,
                    single / per_step);
    }
  }
  return 0;
}
