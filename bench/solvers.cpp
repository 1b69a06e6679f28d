// The two pressure solvers on one scene, per simulated second: the weakly compressible
// fluid (the scene as it is) and the divergence-free solver (fluid.solver "dfsph", its
// time step bound by the flow's speed and by --dfsph-max-dt). Prints, per solver: fluid
// particles, steps, wall seconds, wall seconds per simulated second, ns per particle per
// step, the divergence-free solver's iterations per step and ns per particle per iteration,
// the density error (average over the steps of the average compression, the worst step's
// average, the largest single density ratio) and whether any fluid entered a body; then
// how many times less wall time the divergence-free solver needed, and where each run's
// time went (Simulation::timings: neighbours, density, forces with the solves, boundary).
//
//   wake_bench_solvers [--scene FILE] [--particles N] [--sim-time T] [--threads K]
//                      [--dfsph-max-dt DT] [--dfsph-cfl L] [--dfsph-max-error E]
//                      [--solvers wcsph,dfsph,dfsph-consistent] [--skin F] [--interleave T]
//
// "dfsph-consistent" is the divergence-free solver with fluid.dfsph.pressure_force
// "consistent" (coupling/consistent_solve.hpp), with the same step settings as "dfsph".
//
// Defaults: bench/spheric2.json at its own resolution (~105k particles), 1 simulated
// second, 1 thread; the weakly compressible run as the scene has it (its time.cfl and
// max_dt), the divergence-free one with time.cfl 0.6 (the largest it takes: dt <= 0.6 H /
// |v|max), max_dt 4 ms (the CFL condition bounds the step but where the flow is slow: the
// dam's first 0.1 s) and the scene's fluid.dfsph.max_density_error (--dfsph-cfl,
// --dfsph-max-dt and --dfsph-max-error replace them). The runs take turns of T simulated
// seconds (--interleave, default 0.01), each timed on its own: a machine whose speed drifts
// over the minutes of a run slows both solvers alike.
#include "bullet_bridge/scene_world.hpp"
#include "coupling/simulation.hpp"
#include "io/process.hpp"
#include "io/scene.hpp"

#include <omp.h>

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

namespace {

struct Options {
  std::string scene = "bench/spheric2.json";
  long particles = 0;  ///< 0: the scene's own resolution
  double sim_time = 1.0;
  int threads = 1;
  double dfsph_max_dt = 4e-3;
  double dfsph_cfl = 0.6;       ///< time.cfl of the DFSPH run
  double dfsph_max_error = -1;  ///< > 0: fluid.dfsph.max_density_error for the DFSPH run
  std::vector<std::string> solvers = {"wcsph", "dfsph"};
  double skin = -1;  ///< --skin F: the neighbour lists' skin, F x the support (< 0: automatic)
  double interleave = 0.01;  ///< simulated seconds each run takes in its turn
};

[[noreturn]] void usage(const char* program, const std::string& msg) {
  std::fprintf(stderr,
               "error: %s\nusage: %s [--scene FILE] [--particles N] [--sim-time T] [--threads K]"
               " [--dfsph-max-dt DT] [--dfsph-cfl L] [--dfsph-max-error E]"
               " [--solvers wcsph,dfsph,dfsph-consistent]"
               " [--skin F] [--interleave T]\n",
               msg.c_str(), program);
  std::exit(2);
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    auto value = [&](const char* name) -> std::string {
      if (i + 1 >= argc) usage(argv[0], std::string(name) + " needs a value");
      return argv[++i];
    };
    const std::string a = argv[i];
    if (a == "--scene")
      o.scene = value("--scene");
    else if (a == "--particles")
      o.particles = std::stol(value("--particles"));
    else if (a == "--sim-time")
      o.sim_time = std::stod(value("--sim-time"));
    else if (a == "--threads")
      o.threads = std::stoi(value("--threads"));
    else if (a == "--dfsph-max-dt")
      o.dfsph_max_dt = std::stod(value("--dfsph-max-dt"));
    else if (a == "--dfsph-cfl") {
      o.dfsph_cfl = std::stod(value("--dfsph-cfl"));
      if (!(o.dfsph_cfl > 0 && o.dfsph_cfl <= 0.6))
        usage(argv[0], "--dfsph-cfl must be in (0, 0.6]");
    } else if (a == "--dfsph-max-error") {
      o.dfsph_max_error = std::stod(value("--dfsph-max-error"));
      if (!(o.dfsph_max_error > 0 && o.dfsph_max_error <= 0.1))
        usage(argv[0], "--dfsph-max-error must be in (0, 0.1]");
    } else if (a == "--skin") {
      o.skin = std::stod(value("--skin"));
      if (!(o.skin >= 0) || !std::isfinite(o.skin)) usage(argv[0], "--skin must be >= 0");
    } else if (a == "--interleave") {
      o.interleave = std::stod(value("--interleave"));
      if (!(o.interleave > 0) || !std::isfinite(o.interleave))
        usage(argv[0], "--interleave must be > 0");
    } else if (a == "--solvers") {
      o.solvers.clear();
      std::stringstream ss(value("--solvers"));
      for (std::string s; std::getline(ss, s, ',');) {
        if (s != "wcsph" && s != "dfsph" && s != "dfsph-consistent")
          usage(argv[0], "unknown solver " + s);
        o.solvers.push_back(s);
      }
    } else
      usage(argv[0], "unknown option " + a);
  }
  if (!(o.sim_time > 0) || o.threads < 1 || o.particles < 0 || !(o.dfsph_max_dt > 0) ||
      o.solvers.empty())
    usage(argv[0], "values must be positive");
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  wake::mapLargeBlocksApart();
  const Options opt = parse(argc, argv);
  omp_set_num_threads(opt.threads);
  std::printf("# Wake solver benchmark: %s, %.3g simulated s, %d thread(s)\n", opt.scene.c_str(),
              opt.sim_time, opt.threads);
  std::printf("%16s %8s %7s %9s %10s %10s %8s %8s %10s %10s %10s %9s %4s\n", "solver", "fluid",
              "steps", "wall[s]", "s/sim_s", "ns/p/step", "it/step", "div/step", "ns/p/it",
              "avg_err", "worst_err", "max_rho", "pen");
  // Every solver's world first, then their steps in turns of `interleave` simulated
  // seconds (each run still steps towards the end time: the same steps as alone), so that
  // a machine whose speed drifts over minutes slows them alike.
  struct Run {
    std::string name;
    bool dfsph = false;
    std::unique_ptr<SceneWorld> world;
    double wall = 0;
  };
  std::vector<Run> runs;
  for (const std::string& name : opt.solvers) {
    SceneFile scene;
    try {
      scene = loadScene(opt.scene);
      if (opt.particles > 0)
        overrideResolution(scene,
                           std::cbrt(double(opt.particles) / estimateFluidParticles(scene.sim)));
    } catch (const std::exception& e) {
      std::fprintf(stderr, "error: %s\n", e.what());
      return 1;
    }
    Run run;
    run.name = name;
    run.dfsph = name != "wcsph";
    if (name == "dfsph-consistent")
      scene.sim.dfsph.pressure_force = DfsphParams::PressureForce::Consistent;
    if (run.dfsph) {
      scene.sim.solver = FluidSolver::Dfsph;
      scene.sim.max_dt = opt.dfsph_max_dt;
      scene.sim.cfl = opt.dfsph_cfl;
      if (opt.dfsph_max_error > 0) scene.sim.dfsph.max_density_error = opt.dfsph_max_error;
    }
    if (opt.skin >= 0) scene.sim.neighbor_skin = opt.skin * scene.sim.fluid.supportRadius();
    run.world = std::make_unique<SceneWorld>(scene.sim, scene.bodies);
    run.world->coupled().start();
    runs.push_back(std::move(run));
  }
  for (double until = 0.0; until < opt.sim_time;) {
    until = std::min(opt.sim_time, until + opt.interleave);
    for (Run& run : runs) {
      Simulation& sim = run.world->coupled().simulation();
      const auto t0 = std::chrono::steady_clock::now();
      while (sim.time() < until)
        sim.step(opt.sim_time);
      run.wall += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
  }
  double wall_wcsph = 0, wall_dfsph = 0;
  for (Run& run : runs) {
    const Simulation& sim = run.world->coupled().simulation();
    const double wall = run.wall;
    const double steps = double(sim.steps());
    const double n = double(sim.fluidParticles());
    const double iterations = double(sim.densityIterations()) / steps;
    const double divergence = double(sim.divergenceIterations()) / steps;
    // The solves' own time (their passes over the lists, the error sums and the
    // impulses) per particle and per iteration of either solve.
    const double per_iteration = run.dfsph ? 1e9 * sim.timings().solver / n /
                                                 std::max(1.0, steps * (iterations + divergence))
                                           : 0.0;
    std::printf(
        "%16s %8.0f %7.0f %9.2f %10.2f %10.1f %8.2f %8.2f %10.1f %10.5f %10.5f %9.4f %4zu\n",
        run.name.c_str(), n, steps, wall, wall / sim.time(), 1e9 * wall / steps / n, iterations,
        divergence, per_iteration, sim.averageDensityError(), sim.maxStepDensityError(),
        sim.maxDensityRatio(), sim.maxPenetrating());
    if (run.name == "dfsph") wall_dfsph = wall;
    if (run.name == "wcsph") wall_wcsph = wall;
  }
  // Where each run's time went (Simulation::timings: seconds over the run).
  for (Run& run : runs) {
    const StepTimings& t = run.world->coupled().simulation().timings();
    std::printf(
        "# %s s: neighbours %.2f, density %.2f, forces %.2f (solves %.2f), boundary %.2f "
        "(control %.2f, correction %.2f), integration %.2f, rigid %.2f\n",
        run.name.c_str(), t.neighbors, t.density, t.forces, t.solver, t.boundary, t.control,
        t.correction, t.integration, t.rigid);
  }
  if (wall_wcsph > 0 && wall_dfsph > 0)
    std::printf("# dfsph needs %.2fx less wall time than wcsph for the same simulated time\n",
                wall_wcsph / wall_dfsph);
  return 0;
}
