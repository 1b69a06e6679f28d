// Fluid-only physics: summation density, Tait pressure, momentum conservation.
#include "sph/fluid.hpp"

#include <gtest/gtest.h>
#include <omp.h>

#include <random>

using namespace wake;

namespace {

FluidParams testParams() {
  FluidParams p;
  p.particle_radius = 0.01;
  p.rest_density = 1000.0;
  p.speed_of_sound = 20.0;
  p.viscosity = 0.1;
  return p;
}

/// n^3 particles on a lattice of `spacing` starting at the origin.
void fillLattice(Fluid& fluid, int n, double spacing) {
  std::uint32_t id = 0;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        fluid.state().append(spacing * Vec3(i + 0.5, j + 0.5, k + 0.5), Vec3::Zero(), id++,
                             fluid.params().kinematic_viscosity);
}

/// Index of the particle nearest to p.
std::size_t nearest(const FluidState& st, const Vec3& p) {
  std::size_t best = 0;
  for (std::size_t i = 1; i < st.size(); ++i)
    if ((st.position[i] - p).squaredNorm() < (st.position[best] - p).squaredNorm()) best = i;
  return best;
}

const Aabb kDomain{Vec3(-0.1, -0.1, -0.1), Vec3(0.3, 0.3, 0.3)};

}  // namespace

TEST(Density, RestDensityInsideARegularLattice) {
  Fluid fluid(testParams(), kDomain);
  fillLattice(fluid, 10, 0.02);
  fluid.updateNeighbors();
  fluid.computeFluidDensity();
  const std::size_t c = nearest(fluid.state(), Vec3(0.1, 0.1, 0.1));
  EXPECT_NEAR(fluid.state().density[c] / 1000.0, 1.0, 0.01);
}

TEST(Density, CompressedLatticeIsDenser) {
  Fluid fluid(testParams(), kDomain);
  fillLattice(fluid, 12, 0.02 * 0.95);
  fluid.updateNeighbors();
  fluid.computeFluidDensity();
  fluid.computePressure();
  const std::size_t c = nearest(fluid.state(), Vec3(0.114, 0.114, 0.114));
  // Volume shrinks by 0.95^3: density should rise by about 1/0.857.
  EXPECT_GT(fluid.state().density[c], 1.10 * 1000.0);
  EXPECT_GT(fluid.state().pressure[c], 0.0);
}

TEST(Density, FreeSurfaceIsNotDenserAndPressureIsNotNegative) {
  Fluid fluid(testParams(), kDomain);
  fillLattice(fluid, 10, 0.02);
  fluid.updateNeighbors();
  fluid.computeFluidDensity();
  fluid.computePressure();
  const FluidState& st = fluid.state();
  const std::size_t corner = nearest(st, Vec3(0.19, 0.19, 0.19));
  const std::size_t face = nearest(st, Vec3(0.1, 0.19, 0.1));
  EXPECT_LE(st.density[corner], 1000.0 * (1 + 1e-12));
  EXPECT_LE(st.density[face], 1000.0 * (1 + 1e-12));
  EXPECT_LT(st.density[corner], st.density[face]);
  for (std::size_t i = 0; i < st.size(); ++i)
    EXPECT_GE(st.pressure[i], 0.0);
  EXPECT_EQ(st.pressure[corner], 0.0);
}

TEST(Momentum, FluidForcesConserveLinearMomentum) {
  // Random velocities and a compressed, jittered block: forces are pairwise antisymmetric,
  // so without gravity or boundaries sum m a = 0.
  Fluid fluid(testParams(), kDomain);
  fillLattice(fluid, 8, 0.018);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (std::size_t i = 0; i < fluid.state().size(); ++i) {
    fluid.state().position[i] += 0.002 * Vec3(u(rng), u(rng), u(rng));
    fluid.state().velocity[i] = Vec3(u(rng), u(rng), u(rng));
  }
  fluid.updateNeighbors();
  fluid.computeFluidDensity();
  fluid.computePressure();
  fluid.computeAccelerations(Vec3::Zero());
  Vec3 total = Vec3::Zero();
  double scale = 0.0;
  for (const Vec3& a : fluid.state().acceleration) {
    total += a;
    scale += a.norm();
  }
  ASSERT_GT(scale, 0.0);
  EXPECT_LT(total.norm(), 1e-12 * scale);
}

TEST(Determinism, SameAccelerationsWithOneAndTwoThreads) {
  auto run = [](int threads) {
    omp_set_num_threads(threads);
    Fluid fluid(testParams(), kDomain);
    fillLattice(fluid, 9, 0.019);
    std::mt19937 rng(9);
    std::uniform_real_distribution<double> u(-1, 1);
    for (std::size_t i = 0; i < fluid.state().size(); ++i)
      fluid.state().velocity[i] = Vec3(u(rng), u(rng), u(rng));
    fluid.updateNeighbors();
    fluid.computeFluidDensity();
    fluid.computePressure();
    fluid.computeAccelerations(Vec3(0, -9.81, 0));
    return fluid.state().acceleration;
  };
  const auto one = run(1);
  const auto two = run(2);
  ASSERT_EQ(one.size(), two.size());
  for (std::size_t i = 0; i < one.size(); ++i)
    ASSERT_EQ(one[i], two[i]) << i;
}
