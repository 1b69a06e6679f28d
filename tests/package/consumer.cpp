// Uses Wake through its installed CMake package (tests/package/CMakeLists.txt): a small
// fluid block settles in a static tank; prints the Bullet version. Exits non-zero when
// anything is off.
#include "bullet_bridge/bullet_info.hpp"
#include "coupling/simulation.hpp"

#include <cstdio>
#include <exception>
#include <memory>
#include <utility>

int main() try {
  using wake::Vec3;
  const double radius = 0.02;  // m

  wake::SimulationSettings settings;
  settings.fluid.particle_radius = radius;
  wake::FluidBlock block;
  block.min = Vec3(0.0, 0.0, 0.0);
  block.max = Vec3(0.16, 0.16, 0.16);
  settings.blocks.push_back(block);
  wake::BodySettings tank;
  tank.name = "tank";
  tank.kind = wake::BodyKind::Static;
  tank.shape = wake::makeTank(Vec3::Zero(), Vec3(0.4, 0.4, 0.4), 4.0 * radius);
  settings.bodies.push_back(std::move(tank));

  wake::Simulation sim(std::move(settings));
  const std::size_t particles = sim.fluidParticles();
  for (int i = 0; i < 5; ++i)
    sim.step(1.0);

  const bool double_precision = wake::bullet::doublePrecision();
#ifdef BT_USE_DOUBLE_PRECISION
  const bool compiled_double = true;
#else
  const bool compiled_double = false;
#endif
  std::printf("wake_consumer: Bullet %d (%s), %zu fluid particles, %llu steps to t = %g s\n",
              wake::bullet::version(), double_precision ? "double" : "single", particles,
              static_cast<unsigned long long>(sim.steps()), sim.time());

  int failures = 0;
  auto check = [&failures](bool ok, const char* what) {
    if (!ok) {
      std::fprintf(stderr, "wake_consumer: FAILED: %s\n", what);
      ++failures;
    }
  };
  check(wake::bullet::version() >= 280, "Bullet version >= 2.80");
  check(double_precision == compiled_double,
        "BT_USE_DOUBLE_PRECISION of this program matches the Bullet library Wake uses");
  check(particles > 0, "the fluid block has particles");
  check(sim.fluidParticles() == particles, "no particle lost");
  check(sim.steps() == 5 && sim.time() > 0.0, "five steps advance the time");
  check(sim.countPenetrating() == 0, "no fluid inside the tank's walls");
  return failures == 0 ? 0 : 1;
} catch (const std::exception& e) {
  std::fprintf(stderr, "wake_consumer: FAILED: %s\n", e.what());
  return 1;
}
