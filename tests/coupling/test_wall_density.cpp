// The boundary's share of the density: no deficit next to a wall.
#include "coupling/boundary.hpp"

#include <gtest/gtest.h>
#include <omp.h>

#include <random>

using namespace wake;

namespace {

struct WallFixture {
  FluidParams params;
  Aabb domain{Vec3(-0.3, -0.2, -0.3), Vec3(0.3, 0.3, 0.3)};
  std::unique_ptr<Fluid> fluid;
  std::unique_ptr<Boundaries> walls;

  explicit WallFixture(bool with_wall) {
    params.particle_radius = 0.01;
    params.speed_of_sound = 20.0;
    fluid = std::make_unique<Fluid>(params, domain);
    walls = std::make_unique<Boundaries>(params, domain);
    if (with_wall) {
      BodySettings floor;
      floor.name = "floor";
      floor.shape = makeBox(Vec3(0.2, 0.05, 0.2));
      floor.pose.position = Vec3(0, -0.05, 0);  // top face at y = 0
      walls->addBody(floor);
    }
    walls->finalize();
    // Fluid lattice on the floor, aligned with the samples, first layer at y = r.
    std::uint32_t id = 0;
    for (int k = -6; k < 6; ++k)
      for (int j = 0; j < 8; ++j)
        for (int i = -6; i < 6; ++i)
          fluid->state().append(Vec3(0.02 * i + 0.01, 0.02 * j + 0.01, 0.02 * k + 0.01),
                                Vec3::Zero(), id++, fluid->params().kinematic_viscosity);
    fluid->updateNeighbors();
    fluid->computeFluidDensity();
    walls->addDensity(*fluid, walls->placeAtStart(), fluid->state().density);
  }

  double densityAt(const Vec3& p) const {
    const FluidState& st = fluid->state();
    for (std::size_t i = 0; i < st.size(); ++i)
      if ((st.position[i] - p).norm() < 1e-9) return st.density[i];
    ADD_FAILURE() << "no particle at " << p.transpose();
    return 0;
  }
};

}  // namespace

TEST(WallDensity, FirstLayerAtRestDensity) {
  WallFixture with(true), without(false);
  const Vec3 first(0.01, 0.01, 0.01), second(0.01, 0.03, 0.01), interior(0.01, 0.07, 0.01);
  EXPECT_NEAR(with.densityAt(first) / 1000.0, 1.0, 0.01);
  EXPECT_NEAR(with.densityAt(second) / 1000.0, 1.0, 0.01);
  EXPECT_NEAR(with.densityAt(interior) / 1000.0, 1.0, 0.01);
  // Without the boundary's share the first layer is clearly under-dense.
  EXPECT_LT(without.densityAt(first) / 1000.0, 0.9);
  // The share does not reach beyond the kernel support.
  EXPECT_EQ(with.densityAt(interior), without.densityAt(interior));
}

TEST(WallDensity, SampleVolumesMatchTheFluidLatticeOnAFlatFace) {
  WallFixture with(true);
  const Boundaries& w = *with.walls;
  // Samples in the middle of the top face have the volume of one fluid particle, s^3.
  std::vector<Vec3> position, normal;
  std::vector<double> volume;
  std::vector<std::uint32_t> body;
  w.worldSamples(w.placeAtStart(), position, normal, volume, body);
  ASSERT_EQ(position.size(), w.sampleCount());
  std::size_t checked = 0;
  for (std::size_t k = 0; k < w.sampleCount(); ++k) {
    const Vec3& p = position[k];
    if (normal[k].y() > 0.99 && std::abs(p.x()) < 0.1 && std::abs(p.z()) < 0.1) {
      EXPECT_NEAR(volume[k], 0.02 * 0.02 * 0.02, 1e-9);
      ++checked;
    }
  }
  EXPECT_GT(checked, 50u);
}

TEST(WallDensity, StaticCandidatesOfTheLastBuildGiveTheSearchsBits) {
  // A fluid with a skin: the walls' pass over the static samples listed where the
  // particles were at the lists' last build (prepareWallCandidates) gives the bits of the
  // pass that searches the samples' grid, step after step as the particles move up to
  // the skin's half, through builds, on one and two threads: densities, shear and the
  // pairs it records. Two static bodies (a no-slip floor and a half-slip wall), particles
  // at random near both.
  FluidParams params;
  params.particle_radius = 0.01;
  params.speed_of_sound = 20.0;
  const Aabb domain{Vec3(-0.3, -0.2, -0.3), Vec3(0.3, 0.3, 0.3)};
  Boundaries searched(params, domain), listed(params, domain);
  for (Boundaries* b : {&searched, &listed}) {
    BodySettings floor;
    floor.name = "floor";
    floor.shape = makeBox(Vec3(0.2, 0.05, 0.2));
    floor.pose.position = Vec3(0, -0.05, 0);  // top face at y = 0
    b->addBody(floor);
    BodySettings wall;
    wall.name = "wall";
    wall.slip = 0.5;
    wall.shape = makeBox(Vec3(0.05, 0.2, 0.2));
    wall.pose.position = Vec3(-0.15, 0.1, 0);  // face at x = -0.1
    b->addBody(wall);
    b->finalize();
  }
  const int threads_before = omp_get_max_threads();
  for (int threads : {1, 2}) {
    omp_set_num_threads(threads);
    Fluid fluid(params, domain);
    fluid.setNeighborSkin(0.1 * params.supportRadius());
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(0.0, 1.0), v(-1.0, 1.0);
    for (std::uint32_t id = 0; id < 3000; ++id)
      fluid.state().append(Vec3(-0.1 + 0.2 * u(rng), 0.15 * u(rng), -0.1 + 0.2 * u(rng)),
                           Vec3(v(rng), v(rng), v(rng)), id, 1e-3);
    const BodyPlacement at = listed.placeAtStart();
    std::uint64_t builds = 0;
    for (int step = 0; step < 40; ++step) {
      fluid.updateNeighbors();
      listed.prepareWallCandidates(fluid);
      const std::size_t n = fluid.state().size();
      std::vector<double> density_a(n, 0.0), density_b(n, 0.0);
      std::vector<Vec3> shear_a, shear_b;
      std::vector<Wrench> reaction_a, reaction_b;
      WallPairs pairs_a, pairs_b;
      searched.addWallTerms(fluid, at, density_a, shear_a, reaction_a, pairs_a);
      listed.addWallTerms(fluid, at, density_b, shear_b, reaction_b, pairs_b);
      ASSERT_EQ(density_a, density_b) << "step " << step << ", " << threads << " threads";
      ASSERT_EQ(shear_a, shear_b) << "step " << step;
      ASSERT_EQ(pairs_a.chunk, pairs_b.chunk) << "step " << step;
      ASSERT_EQ(pairs_a.end, pairs_b.end) << "step " << step;
      // Keep the particles in the box; a step of up to 0.35 mm (the skin is 4 mm).
      for (std::size_t i = 0; i < n; ++i) {
        Vec3& x = fluid.state().position[i];
        x += 2e-4 * fluid.state().velocity[i];
        x = x.cwiseMax(Vec3(-0.1, 0.0, -0.1)).cwiseMin(Vec3(0.1, 0.15, 0.1));
      }
      builds = fluid.neighborBuilds();
    }
    EXPECT_GE(builds, 3u) << "the lists were not built again: the test moved too little";
    EXPECT_LE(builds, 20u);
  }
  omp_set_num_threads(threads_before);
}
