// Two-way coupling with Bullet in the loop, through the scene path (SceneWorld): buoyancy
// (Archimedes), viscous drag, body-body contact under water. Every test also asserts that
// no fluid centre ever entered a body's exact shape (max_penetrating == 0).
#include "bullet_bridge/scene_world.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <vector>

namespace wake {
namespace {

constexpr double kRadius = 0.005;  // fluid particle radius (m): spacing 1 cm

SimulationSettings fluidBox(const Vec3& fluid_size, CouplingMethod method, double viscosity = 0.1) {
  SimulationSettings s;
  s.fluid.particle_radius = kRadius;
  s.fluid.viscosity = viscosity;
  s.method = method;
  s.blocks.push_back({Vec3::Zero(), fluid_size});
  return s;
}

BodySpec tank(const Vec3& size) {
  BodySpec b;
  b.name = "tank";
  b.kind = BodyKind::Static;
  b.coupling = CouplingMode::OneWay;
  b.shape.type = "tank";
  b.shape.min = Vec3::Zero();
  b.shape.max = size;
  return b;
}

BodySpec box(const std::string& name, const Vec3& half, double density, const Vec3& at) {
  BodySpec b;
  b.name = name;
  b.kind = BodyKind::Dynamic;
  b.shape.type = "box";
  b.shape.half_extents = half;
  b.density = density;
  b.pose.position = at;
  return b;
}

const char* name(CouplingMethod m) {
  return m == CouplingMethod::Global ? "global" : "local";
}

/// Fluid surface height away from x-range [x0, x1]: median over lattice columns of the
/// top particle centre, plus the particle radius.
double surfaceHeight(const Simulation& sim, double x0, double x1) {
  std::map<std::pair<int, int>, double> top;
  const FluidState& st = sim.fluid().state();
  const double s = 2 * kRadius;
  for (std::size_t i = 0; i < st.size(); ++i) {
    const Vec3& x = st.position[i];
    if (x.x() > x0 && x.x() < x1) continue;
    const auto key = std::make_pair(int(std::floor(x.x() / s)), int(std::floor(x.z() / s)));
    auto it = top.emplace(key, x.y()).first;
    it->second = std::max(it->second, x.y());
  }
  std::vector<double> tops;
  for (const auto& kv : top)
    tops.push_back(kv.second);
  std::nth_element(tops.begin(), tops.begin() + tops.size() / 2, tops.end());
  return tops[tops.size() / 2] + kRadius;
}

struct Floating {
  double draft = 0;   ///< m, surface - bottom face, averaged over the last 0.3 s
  double tilt = 0;    ///< rad, largest in that window
  double bottom = 0;  ///< m, height of the bottom face at the end
  double speed = 0;   ///< m/s, at the end
  std::size_t max_penetrating = 0;
};

/// A flat box (0.16 x 0.10 x 0.14 m) dropped from 1 cm above the surface of 15 cm of
/// fluid, settled for `end` seconds.
Floating floatBox(double density_ratio, CouplingMethod method, double end, double slip = 0.0) {
  const Vec3 size(0.32, 0.30, 0.18), half(0.08, 0.05, 0.07);
  const double depth = 0.15;
  SimulationSettings sim = fluidBox(Vec3(size.x(), depth, size.z()), method);
  std::vector<BodySpec> bodies = {
      tank(size), box("box", half, density_ratio * 1000.0,
                      Vec3(0.5 * size.x(), depth + half.y() + 0.01, 0.5 * size.z()))};
  bodies[0].slip = bodies[1].slip = slip;
  SceneWorld world(sim, bodies);
  Floating out;
  double sum = 0;
  int samples = 0;
  for (double t = 0.01; t < end + 1e-9; t += 0.01) {
    world.coupled().advanceTo(t);
    if (t < end - 0.3) continue;
    const BodyState b = world.simulation().bodyStates()[1];
    const double surface = surfaceHeight(world.simulation(), b.position.x() - half.x() - 0.02,
                                         b.position.x() + half.x() + 0.02);
    sum += surface - (b.position.y() - half.y());
    ++samples;
    out.tilt = std::max(out.tilt, std::acos(std::min(1.0, (b.orientation * Vec3::UnitY()).y())));
  }
  const BodyState b = world.simulation().bodyStates()[1];
  out.draft = sum / samples;
  out.bottom = b.position.y() - half.y();
  out.speed = b.linear_velocity.norm();
  out.max_penetrating = world.simulation().maxPenetrating();
  std::printf(
      "[ buoyancy ] %s density ratio %.2f: draft %.4f m, Archimedes %.4f m (%+.1f%%), "
      "tilt %.3f rad, bottom %.4f m, max_penetrating %zu\n",
      name(method), density_ratio, out.draft, density_ratio * 2 * half.y(),
      100.0 * (out.draft / (density_ratio * 2 * half.y()) - 1.0), out.tilt, out.bottom,
      out.max_penetrating);
  return out;
}

class Buoyancy : public ::testing::TestWithParam<std::tuple<double, CouplingMethod>> {};

TEST_P(Buoyancy, FloatsFlatAtTheArchimedesDraft) {
  const auto [ratio, method] = GetParam();
  const Floating f = floatBox(ratio, method, 1.5);
  EXPECT_NEAR(f.draft, ratio * 0.10, 0.10 * ratio * 0.10);
  EXPECT_LT(f.tilt, 0.1);
  EXPECT_EQ(f.max_penetrating, 0u);
}

INSTANTIATE_TEST_SUITE_P(Ratios, Buoyancy,
                         ::testing::Combine(::testing::Values(0.3, 0.5, 0.7),
                                            ::testing::Values(CouplingMethod::Local,
                                                              CouplingMethod::Global)));

TEST(Sinking, DenseBoxSinksToTheFloorAndStays) {
  // Free slip: with no-slip walls the last two particle layers between the box and the
  // floor are each pinned to a wall's tangential velocity and cannot drain, so the box
  // would rest on a 2-layer film (2.3 cm here) instead of the floor.
  for (CouplingMethod method : {CouplingMethod::Local, CouplingMethod::Global}) {
    const Floating f = floatBox(2.0, method, 1.0, /*slip=*/1.0);
    // Resting on the tank floor (Bullet's contact; its margin lies inside the box).
    EXPECT_NEAR(f.bottom, 0.0, 0.002) << name(method);
    EXPECT_LT(f.speed, 0.02) << name(method);
    EXPECT_EQ(f.max_penetrating, 0u);
  }
}

}  // namespace
}  // namespace wake
