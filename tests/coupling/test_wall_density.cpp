// The boundary's share of the density: no deficit next to a wall.
#include "coupling/boundary.hpp"

#include <gtest/gtest.h>
#include <omp.h>

#include <array>
#include <cmath>
#include <cstring>
#include <limits>
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

namespace {

/// Static walls (a no-slip tank and a half-slip block) and a two-way box turning as it
/// moves, with a viscous fluid at random around them at rest density and random speeds:
/// the walls' three passes (density share and shear, the samples' pressure, the walls'
/// pressure force) of one step.
struct WallPassScene {
  static FluidParams viscous(PressureGradient form) {
    FluidParams p;
    p.particle_radius = 0.01;
    p.speed_of_sound = 20.0;
    p.kinematic_viscosity = 1e-3;
    // The symmetric form's walls' term is a sum of its own (addWallPressure's `extra`),
    // checked bit for bit by default; the consistent form's sums have a test of their own.
    p.pressure_gradient = form;
    return p;
  }
  FluidParams params;
  Aabb domain{Vec3(-0.1, -0.1, -0.1), Vec3(0.5, 0.4, 0.3)};
  Boundaries walls;
  Fluid fluid;
  BodyPlacement at;

  explicit WallPassScene(bool moving, PressureGradient form = PressureGradient::Symmetric)
      : params(viscous(form)), walls(params, domain), fluid(params, domain) {
    BodySettings tank;
    tank.name = "tank";
    tank.shape = makeTank(Vec3::Zero(), Vec3(0.4, 0.3, 0.2), 0.04);
    walls.addBody(tank);
    BodySettings block;
    block.name = "block";
    block.slip = 0.5;
    block.shape = makeBox(Vec3(0.05, 0.04, 0.06));
    block.pose = Pose{Vec3(0.1, 0.04, 0.1), Quat(Eigen::AngleAxisd(0.3, Vec3::UnitY()))};
    walls.addBody(block);
    if (moving) {
      BodySettings box;
      box.name = "box";
      box.kind = BodyKind::Dynamic;
      box.shape = makeBox(Vec3(0.04, 0.03, 0.05));
      box.pose.position = Vec3(0.28, 0.12, 0.1);
      walls.addBody(box);
    }
    walls.finalize();
    std::vector<RigidState> states(walls.bodyCount());
    for (std::size_t b = 0; b < states.size(); ++b)
      states[b].pose = walls.body(b).pose;
    if (moving) {
      states[2].pose.orientation = Quat(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
      states[2].linear_velocity = Vec3(0.3, -0.2, 0.1);
      states[2].angular_velocity = Vec3(1.0, -2.0, 0.5);
    }
    walls.place(states, at);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(0.0, 1.0), v(-1.0, 1.0);
    for (std::uint32_t id = 0; fluid.state().size() < 4000; ++id) {
      const Vec3 x(0.4 * u(rng), 0.25 * u(rng), 0.2 * u(rng));
      if (walls.signedDistance(x, at) < params.particle_radius) continue;
      fluid.state().append(x, Vec3(v(rng), v(rng), v(rng)), id, params.kinematic_viscosity);
    }
    fluid.updateNeighbors();
  }

  struct Result {
    std::vector<double> density;
    std::vector<Vec3> shear, pressure_force;
    std::vector<Wrench> reaction, pressure_reaction;
    SamplePressure samples;
  };
  Result run() {
    Result r;
    fluid.computeFluidDensity();
    r.density = fluid.state().density;
    WallPairs pairs;
    walls.addWallTerms(fluid, at, r.density, r.shear, r.reaction, pairs);
    fluid.state().density = r.density;
    fluid.computePressure();
    walls.computeSamplePressure(fluid, at, Vec3(0, -9.81, 0), pairs, r.samples);
    r.pressure_reaction.assign(walls.bodyCount(), Wrench{});
    walls.addWallPressure(fluid, at, pairs, r.samples, r.pressure_force, fluid.wallPressureSums());
    walls.addBodyPressure(at, r.samples, r.pressure_reaction);
    return r;
  }
};

bool sameBits(double a, double b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}
bool sameBits(const Vec3& a, const Vec3& b) {
  return sameBits(a.x(), b.x()) && sameBits(a.y(), b.y()) && sameBits(a.z(), b.z());
}

}  // namespace

TEST(WallPasses, SeveralSamplesAtOnceGiveTheBitsOfOneSampleAtATime) {
  // Static walls: each pass against its sum written out one sample at a time, in the
  // samples' order (the static set is in cell order: worldSamples' first samples), on two
  // and, where the CPU has AVX, four lanes.
  for (bool wide : {false, true}) {
    WallPassScene scene(false);
    scene.walls.setWideLanes(wide);
    ASSERT_EQ(scene.walls.wideLanes(), wide && hasWideLanes());
    const FluidParams& f = scene.params;
    const FluidState& st = scene.fluid.state();
    const std::vector<double> fluid_density = (scene.fluid.computeFluidDensity(), st.density);
    const WallPassScene::Result got = scene.run();
    std::vector<Vec3> pos, nrm;
    std::vector<double> vol;
    std::vector<std::uint32_t> body;
    scene.walls.worldSamples(scene.at, pos, nrm, vol, body);
    const CubicSplineKernel kernel(f.smoothingLength());
    const double support_sq = kernel.supportRadius() * kernel.supportRadius();
    const double rb = f.particle_radius, two_nu = 2.0 * f.kinematic_viscosity;
    // The walls' shear factor (1 - slip) / (1 + 3 slip): the tank's (no slip), the block's.
    const double factor[2] = {1.0, (1.0 - 0.5) / (1.0 + 3.0 * 0.5)};
    const std::size_t n = st.size();
    std::vector<std::vector<std::uint32_t>> near(pos.size());
    std::size_t walled = 0;
    for (std::size_t i = 0; i < n; ++i) {
      double sum = 0.0;
      Vec3 s = Vec3::Zero();
      for (std::uint32_t k = 0; k < pos.size(); ++k) {
        const Vec3 d = st.position[i] - pos[k];
        const double d_sq = d.squaredNorm();
        if (d_sq >= support_sq) continue;
        near[k].push_back(static_cast<std::uint32_t>(i));
        const double r = std::sqrt(d_sq);
        sum += vol[k] * kernel.value(r);
        const double beyond = d.dot(nrm[k]) - rb;
        const double beta = beyond > rb ? 1.0 + rb / beyond : 2.0;
        const double w = -factor[body[k]] * two_nu * vol[k] * beta * kernel.derivativeOverR(r);
        s += w * (st.velocity[i] - Vec3::Zero().cross(pos[k]));
      }
      walled += sum > 0.0;
      ASSERT_TRUE(sameBits(got.density[i], fluid_density[i] + f.rest_density * sum)) << i;
      ASSERT_TRUE(sameBits(got.shear[i], Vec3(Vec3::Zero() - s))) << i;
    }
    EXPECT_GT(walled, n / 4);
    // The samples' pressure: sum_a W, sum_a P_a W, sum_a rho_a (x_k - x_a) W, particles
    // in order.
    std::size_t pressed = 0;
    for (std::size_t k = 0; k < pos.size(); ++k) {
      double w_sum = 0.0, p_sum = 0.0;
      Vec3 rise = Vec3::Zero();
      for (const std::uint32_t a : near[k]) {
        const Vec3 d = pos[k] - st.position[a];
        const double w = kernel.value(std::sqrt(d.squaredNorm()));
        w_sum += w;
        p_sum += st.pressure[a] * w;
        rise += (st.density[a] * w) * d;
      }
      double want = 0.0;
      const double p =
          w_sum > 0.0 ? std::max(0.0, (p_sum + Vec3(0, -9.81, 0).dot(rise)) / w_sum) : 0.0;
      if (p > 0.0) {
        const double rho = f.densityAt(p);
        want = p / (rho * rho);
        ++pressed;
      }
      ASSERT_TRUE(sameBits(got.samples.p_rho2[0][k], want)) << "sample " << k;
    }
    EXPECT_GT(pressed, 100u);
    // The walls' pressure force.
    for (std::size_t i = 0; i < n; ++i) {
      const double pr2 = st.pressure[i] / (st.density[i] * st.density[i]);
      Vec3 sum = Vec3::Zero();
      for (std::uint32_t k = 0; k < pos.size(); ++k) {
        const Vec3 d = st.position[i] - pos[k];
        const double d_sq = d.squaredNorm();
        if (d_sq >= support_sq) continue;
        const double dwr = kernel.derivativeOverR(std::sqrt(d_sq));
        sum += ((pr2 + got.samples.p_rho2[0][k]) * vol[k] * dwr) * d;
      }
      const Vec3 want = Vec3::Zero() + f.rest_density * Vec3(Vec3::Zero() - sum);
      ASSERT_TRUE(sameBits(got.pressure_force[i], want)) << i;
    }
  }
}

TEST(WallPasses, TheConsistentFormsSumsAreTheSamplesTermsInTheWorld) {
  // The walls' share of the consistent pressure gradient (static walls and a turning,
  // moving box): each sum written out over every sample in world coordinates, against
  // addWallPressure's (summed per set in the set's frame: to rounding).
  WallPassScene scene(true, PressureGradient::Consistent);
  const WallPassScene::Result got = scene.run();
  const FluidState& st = scene.fluid.state();
  const WallPressureSums& sums = scene.fluid.wallPressureSums();
  ASSERT_EQ(sums.difference.size(), st.size());
  for (const Vec3& a : got.pressure_force)
    ASSERT_EQ(a, Vec3::Zero());  // `extra` untouched
  std::vector<Vec3> pos, nrm;
  std::vector<double> vol;
  std::vector<std::uint32_t> body;
  scene.walls.worldSamples(scene.at, pos, nrm, vol, body);
  // The samples' pressures in worldSamples' order: the static set, then the box's.
  std::vector<double> pk, pr2;
  for (std::size_t s = 0; s < got.samples.pressure.size(); ++s) {
    pk.insert(pk.end(), got.samples.pressure[s].begin(), got.samples.pressure[s].end());
    pr2.insert(pr2.end(), got.samples.p_rho2[s].begin(), got.samples.p_rho2[s].end());
  }
  ASSERT_EQ(pk.size(), pos.size());
  const CubicSplineKernel kernel(scene.params.smoothingLength());
  const double rho0 = scene.params.rest_density;
  std::size_t walled = 0;
  for (std::size_t i = 0; i < st.size(); ++i) {
    const double ra2 = 1.0 / (st.density[i] * st.density[i]);
    Vec3 g = Vec3::Zero(), e = Vec3::Zero(), sym = Vec3::Zero();
    Eigen::Matrix3d b = Eigen::Matrix3d::Zero();
    double low = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < pos.size(); ++k) {
      const Vec3 d = st.position[i] - pos[k];
      const double r = d.norm();
      if (r >= kernel.supportRadius()) continue;
      const Vec3 grad = kernel.derivativeOverR(r) * d;
      const double rk2 = pk[k] > 0 ? pr2[k] / pk[k] : 1.0 / (rho0 * rho0);
      g += vol[k] * (pk[k] - st.pressure[i]) * grad;
      b -= vol[k] * grad * d.transpose();
      e += rho0 * vol[k] * (ra2 + rk2) * grad;
      sym -= rho0 * vol[k] * (st.pressure[i] * ra2 + pr2[k]) * grad;
      low = std::min(low, pk[k]);
    }
    if (!std::isfinite(low)) {
      ASSERT_EQ(sums.difference[i], Vec3::Zero());
      continue;
    }
    ++walled;
    // G's terms are differences of pressures of up to a few hundred Pa: rounding of P_a.
    const double scale_g = 1e-9 * (1.0 + g.norm() + 1e3 * st.pressure[i]);
    EXPECT_LT((sums.difference[i] - g).norm(), scale_g) << i;
    EXPECT_LT((sums.spread[i] - e).norm(), 1e-9 * (1.0 + e.norm())) << i;
    EXPECT_LT((sums.symmetric[i] - sym).norm(), 1e-9 * (1.0 + sym.norm())) << i;
    const std::array<double, 6>& m = sums.moment[i];
    const Eigen::Matrix3d got_b =
        (Eigen::Matrix3d() << m[0], m[3], m[4], m[3], m[1], m[5], m[4], m[5], m[2]).finished();
    EXPECT_LT((got_b - b).norm(), 1e-9) << i;
    EXPECT_LE(sums.reference[i], low) << i;
  }
  EXPECT_GT(walled, st.size() / 4);
}

TEST(WallPasses, TwoAndFourLanesGiveTheSameBitsWithAMovingBody) {
  // A two-way box turning as it moves among static walls: the three passes, their sums
  // per particle and sample and the box's reactions, on two lanes and on four.
  if (!hasWideLanes()) GTEST_SKIP() << "no AVX: one way only";
  WallPassScene two(true), four(true);
  two.walls.setWideLanes(false);
  four.walls.setWideLanes(true);
  const WallPassScene::Result a = two.run(), b = four.run();
  ASSERT_EQ(a.density.size(), b.density.size());
  for (std::size_t i = 0; i < a.density.size(); ++i) {
    ASSERT_TRUE(sameBits(a.density[i], b.density[i])) << i;
    ASSERT_TRUE(sameBits(a.shear[i], b.shear[i])) << i;
    ASSERT_TRUE(sameBits(a.pressure_force[i], b.pressure_force[i])) << i;
  }
  ASSERT_EQ(a.samples.p_rho2.size(), 2u);
  for (std::size_t s = 0; s < 2; ++s) {
    ASSERT_EQ(a.samples.p_rho2[s].size(), b.samples.p_rho2[s].size());
    for (std::size_t k = 0; k < a.samples.p_rho2[s].size(); ++k)
      ASSERT_TRUE(sameBits(a.samples.p_rho2[s][k], b.samples.p_rho2[s][k])) << s << " " << k;
  }
  const Wrench& ra = a.reaction[2];
  const Wrench& rb = b.reaction[2];
  EXPECT_GT(ra.force.norm(), 0.0);  // the box is sheared and pressed
  EXPECT_GT(a.pressure_reaction[2].torque.norm(), 0.0);
  EXPECT_TRUE(sameBits(ra.force, rb.force) && sameBits(ra.torque, rb.torque));
  EXPECT_TRUE(sameBits(a.pressure_reaction[2].force, b.pressure_reaction[2].force) &&
              sameBits(a.pressure_reaction[2].torque, b.pressure_reaction[2].torque));
}
