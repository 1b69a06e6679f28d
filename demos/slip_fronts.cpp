// Slip-ramp fronts over time (README "Boundary conditions" plot, scripts/slip_plot.sh).
//
//   wake_slip_fronts SCENE [MAX_DT]
//
// Runs SCENE (scenes/slip_ramp.json or one like it: static bodies named ramp_*,
// tilted boxes whose own +x points downhill, each with a lane of fluid 12 cm wide around
// its centre's z) and prints, per output frame, how far each ramp's front (slipFront, as
// the scene test measures it) has travelled downhill from where it starts (m). MAX_DT
// (s, > 0) overrides time.max_dt. Prints CSV on stdout (time, then one column per ramp,
// named by its slip) and, on stderr, the steps taken and their mean length.
#include "bullet_bridge/scene_world.hpp"
#include "demos/slip_front.hpp"
#include "io/scene.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

namespace {

struct Lane {
  std::string name;
  double slip = 0;
  wake::Pose pose;
};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || argc > 3) {
    std::fprintf(stderr, "usage: wake_slip_fronts SCENE [MAX_DT]\n");
    return 2;
  }
  try {
    wake::SceneFile scene = wake::loadScene(argv[1]);
    if (argc == 3) {
      char* end = nullptr;
      const double max_dt = std::strtod(argv[2], &end);
      if (end == argv[2] || *end != '\0' || !(max_dt > 0) || !std::isfinite(max_dt)) {
        std::fprintf(stderr, "wake_slip_fronts: error: MAX_DT must be a number > 0 (got %s)\n",
                     argv[2]);
        return 2;
      }
      scene.sim.max_dt = max_dt;
    }
    std::vector<Lane> lanes;
    for (const wake::BodySpec& b : scene.bodies)
      if (b.name.rfind("ramp", 0) == 0) lanes.push_back({b.name, b.slip, b.pose});
    if (lanes.empty()) {
      std::fprintf(stderr, "wake_slip_fronts: error: %s has no body named ramp_*\n", argv[1]);
      return 2;
    }
    wake::SceneWorld world(scene.sim, scene.bodies);
    world.coupled().start();
    std::vector<double> start;
    for (const Lane& lane : lanes)
      start.push_back(wake::slipFront(world.simulation().fluid().state().position, lane.pose));
    std::printf("time");
    for (const Lane& lane : lanes)
      std::printf(",slip_%g", lane.slip);
    std::printf("\n0");
    for (std::size_t l = 0; l < lanes.size(); ++l)
      std::printf(",0");
    std::printf("\n");
    const std::size_t frames = wake::frameCount(scene);
    for (std::size_t k = 1; k <= frames; ++k) {
      world.coupled().advanceTo(wake::frameTime(scene, k));
      const wake::FluidState& st = world.simulation().fluid().state();
      std::printf("%.4f", world.simulation().time());
      for (std::size_t l = 0; l < lanes.size(); ++l)
        std::printf(",%.5f", wake::slipFront(st.position, lanes[l].pose) - start[l]);
      std::printf("\n");
    }
    const wake::Simulation& sim = world.simulation();
    std::fprintf(stderr, "%lld steps, mean step %.4g s, max_penetrating %zu\n",
                 static_cast<long long>(sim.steps()), sim.time() / double(sim.steps()),
                 sim.maxPenetrating());
    return sim.maxPenetrating() == 0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "wake_slip_fronts: error: %s\n", e.what());
    return 1;
  }
}
