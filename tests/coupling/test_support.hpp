// Small scene builders shared by the coupling tests.
#pragma once

#include "coupling/simulation.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <memory>

namespace wake::test {

inline BodySettings staticBody(const std::string& name, std::shared_ptr<const Shape> shape,
                               double slip = 0.0, double restitution = 0.0,
                               const Pose& pose = Pose()) {
  BodySettings b;
  b.name = name;
  b.kind = BodyKind::Static;
  b.shape = std::move(shape);
  b.pose = pose;
  b.slip = slip;
  b.restitution = restitution;
  return b;
}

/// Total surface area of a sampling (m^2).
inline double totalArea(const SurfaceSamples& s) {
  double sum = 0.0;
  for (double a : s.area)
    sum += a;
  return sum;
}

/// Central-difference gradient of the signed distance, not normalised: an independent
/// check of shapes' distances (|grad| = 1) and normals.
inline Vec3 rawGradient(const Shape& shape, const Vec3& p, double step) {
  Vec3 g;
  for (int a = 0; a < 3; ++a) {
    const Vec3 d = step * Vec3::Unit(a);
    g[a] = (shape.signedDistance(p + d) - shape.signedDistance(p - d)) / (2.0 * step);
  }
  return g;
}

/// A tank (cavity [0, size]) with one fluid block.
inline SimulationSettings tankScene(const Vec3& tank_size, const FluidBlock& block,
                                    double particle_radius) {
  SimulationSettings s;
  s.fluid.particle_radius = particle_radius;
  s.blocks.push_back(block);
  s.bodies.push_back(staticBody("tank", makeTank(Vec3::Zero(), tank_size, 4.0 * particle_radius)));
  return s;
}

/// Steps the simulation to time t, asserting after every step that no fluid centre is
/// inside a body's exact shape (the direct-forcing guarantee).
inline void runWithoutPenetration(Simulation& sim, double t) {
  while (sim.time() < t) {
    sim.step(t);
    const std::size_t inside = sim.countPenetrating();
    ASSERT_EQ(inside, 0u) << "fluid inside a body at t = " << sim.time() << " (step " << sim.steps()
                          << ")";
  }
}

}  // namespace wake::test
