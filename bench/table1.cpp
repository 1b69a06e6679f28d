// Table I of the paper for Wake's demo scenes: fluid and boundary particles, seconds for
// the fluid part of a step and for a whole step, speed of sound, max density ratio.
//
//   wake_bench_table1 [--resolution F] [--end T | --steps S] [--threads N] SCENE.json...
//
// Each scene is run headless (no output files) from t = 0 to its end (or T, or for S
// steps only: timings at large resolutions) at the scene's particle radius divided by F.
// The max density ratio is over the steps run. "fluid" is the fluid's own work per step
// (neighbour search, density, pressure, forces, integration); "step" adds the boundary
// (density share, velocity control, position correction) and the rigid bodies (Bullet).
// Prints one Markdown table row per scene.
#include "bullet_bridge/scene_world.hpp"
#include "io/process.hpp"
#include "io/scene.hpp"

#include <omp.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  wake::mapLargeBlocksApart();
  double resolution = 1.0, end = 0.0;
  int threads = 0;
  long steps = 0;
  std::vector<std::string> scenes;
  for (int i = 1; i < argc; ++i) {
    auto value = [&](const char* name) -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "error: %s needs a value\n", name);
        std::exit(2);
      }
      return argv[++i];
    };
    if (!std::strcmp(argv[i], "--resolution"))
      resolution = std::stod(value("--resolution"));
    else if (!std::strcmp(argv[i], "--end"))
      end = std::stod(value("--end"));
    else if (!std::strcmp(argv[i], "--steps"))
      steps = std::stol(value("--steps"));
    else if (!std::strcmp(argv[i], "--threads"))
      threads = std::stoi(value("--threads"));
    else
      scenes.push_back(argv[i]);
  }
  if (scenes.empty()) {
    std::fprintf(stderr, "usage: %s [--resolution F] [--end T] [--threads N] SCENE.json...\n",
                 argv[0]);
    return 2;
  }
  if (threads > 0) omp_set_num_threads(threads);
  std::printf(
      "| scene | fluid particles | boundary particles | steps | fluid [ms/step] | "
      "step [ms/step] | speed of sound [m/s] | max density ratio |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  for (const std::string& path : scenes) {
    try {
      wake::SceneFile scene = wake::loadScene(path);
      if (resolution != 1.0) wake::overrideResolution(scene, resolution);
      if (end > 0.0) wake::overrideEndTime(scene, end);
      wake::SceneWorld world(scene.sim, scene.bodies);
      world.coupled().start();
      if (steps > 0) {
        // Slices of 0.1 ms (a few steps each) until S steps are done.
        while (world.simulation().steps() < static_cast<std::uint64_t>(steps) &&
               world.simulation().time() < scene.end_time)
          world.coupled().advance(std::min(1e-4, scene.end_time - world.simulation().time()));
      } else {
        world.coupled().advanceTo(scene.end_time);
      }
      const wake::Simulation& sim = world.simulation();
      const wake::StepTimings& t = sim.timings();
      const double taken = static_cast<double>(sim.steps());
      const double fluid = t.neighbors + t.density + t.forces + t.integration;
      std::printf("| %s | %zu | %zu | %llu | %.2f | %.2f | %.0f | %.3f |\n", scene.name.c_str(),
                  sim.fluidParticles(), sim.boundaryParticles(),
                  static_cast<unsigned long long>(sim.steps()), 1e3 * fluid / taken,
                  1e3 * t.total() / taken, sim.fluid().params().speed_of_sound,
                  sim.maxDensityRatio());
      std::fflush(stdout);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "error: %s\n", e.what());
      return 1;
    }
  }
  std::printf("\n%d thread(s), resolution x%g", omp_get_max_threads(), resolution);
  if (steps > 0) std::printf(", %ld steps", steps);
  if (end > 0.0) std::printf(", end %g s", end);
  std::printf("\n");
  return 0;
}
