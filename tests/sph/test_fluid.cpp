// Fluid-only physics: summation density, Tait pressure, momentum conservation.
#include "sph/fluid.hpp"

#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <utility>

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

/// The fluid's neighbour pairs as pairs of particle ids (lower first).
std::set<std::pair<std::uint32_t, std::uint32_t>> pairsById(const Fluid& fluid) {
  const PairLists& pairs = fluid.neighbors();
  const std::vector<std::uint32_t>& id = fluid.state().id;
  std::set<std::pair<std::uint32_t, std::uint32_t>> out;
  for (std::size_t r = 0; r < pairs.ranges(); ++r)
    for (std::size_t i = pairs.range[r]; i < pairs.range[r + 1]; ++i)
      for (std::uint32_t k = 0; k < pairs.count[i]; ++k) {
        const std::uint32_t j = pairs.later[r][pairs.begin[i] + k];
        out.insert(std::minmax(id[i], id[j]));
      }
  return out;
}

/// Each particle's density, by id (-1 for an id not there).
std::vector<double> densityById(const FluidState& st) {
  std::vector<double> out(*std::max_element(st.id.begin(), st.id.end()) + 1, -1.0);
  for (std::size_t i = 0; i < st.size(); ++i)
    out[st.id[i]] = st.density[i];
  return out;
}

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
  // Random velocities and a compressed, jittered block: with the symmetric pressure form
  // the forces are pairwise antisymmetric, so without gravity or boundaries sum m a = 0.
  FluidParams params = testParams();
  params.pressure_gradient = PressureGradient::Symmetric;
  Fluid fluid(params, kDomain);
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

TEST(Accelerations, ExtraTermsInTheAccelerationArrayItselfAreAddedAsFromTheirOwn) {
  // The walls' terms written into the state's acceleration array (what Simulation does)
  // give the bits they give from an array of their own, on 1 and 2 threads; and with no
  // extra terms the array is sized by the call.
  const int threads_before = omp_get_max_threads();
  for (int threads : {1, 2}) {
    omp_set_num_threads(threads);
    Fluid fluid(testParams(), kDomain);
    fillLattice(fluid, 9, 0.019);
    std::mt19937 rng(13);
    std::uniform_real_distribution<double> u(-1, 1);
    std::vector<Vec3> extra(fluid.state().size());
    for (std::size_t i = 0; i < fluid.state().size(); ++i) {
      fluid.state().velocity[i] = Vec3(u(rng), u(rng), u(rng));
      extra[i] = 50.0 * Vec3(u(rng), u(rng), u(rng));
    }
    fluid.updateNeighbors();
    fluid.computeFluidDensity();
    fluid.computePressure();
    fluid.computeAccelerations(Vec3(0, -9.81, 0), extra);
    const std::vector<Vec3> own = fluid.state().acceleration;
    fluid.state().acceleration = extra;
    fluid.computeAccelerations(Vec3(0, -9.81, 0), fluid.state().acceleration);
    ASSERT_EQ(fluid.state().acceleration.size(), own.size());
    for (std::size_t i = 0; i < own.size(); ++i)
      ASSERT_EQ(fluid.state().acceleration[i], own[i]) << "particle " << i << ", " << threads;
    fluid.computeAccelerations(Vec3(0, -9.81, 0));
    const std::vector<Vec3> none = fluid.state().acceleration;
    fluid.state().acceleration.clear();
    fluid.computeAccelerations(Vec3(0, -9.81, 0), fluid.state().acceleration);
    EXPECT_EQ(fluid.state().acceleration, none) << threads;
    std::size_t differ = 0;
    for (std::size_t i = 0; i < own.size(); ++i)
      differ += own[i] != none[i];
    EXPECT_EQ(differ, own.size());
  }
  omp_set_num_threads(threads_before);
  Fluid fluid(testParams(), kDomain);
  fillLattice(fluid, 4, 0.019);
  fluid.updateNeighbors();
  fluid.computeFluidDensity();
  fluid.computePressure();
  EXPECT_THROW(fluid.computeAccelerations(Vec3::Zero(), std::vector<Vec3>(3)),
               std::invalid_argument);
}

/// A jittered, compressed block with a linear pressure field P = P0 + k . x set after
/// computePressure (the references set to the pressure: no repulsion): an inner particle's
/// pressure acceleration is -k / rho_a exactly with the consistent form; the symmetric form
/// is off by its zero-order error times P0 (the check that the test can fail).
TEST(ConsistentPressure, IsExactForALinearPressureInside) {
  const Vec3 k(3000.0, -9810.0, 1500.0);  // Pa/m
  const double p0 = 20000.0;              // Pa: about 2 m of water
  double worst[2] = {0.0, 0.0};
  for (PressureGradient form : {PressureGradient::Consistent, PressureGradient::Symmetric}) {
    FluidParams params = testParams();
    params.viscosity = 0.0;
    params.kinematic_viscosity = 0.0;
    params.pressure_gradient = form;
    Fluid fluid(params, kDomain);
    fillLattice(fluid, 11, 0.019);
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> u(-1, 1);
    FluidState& st = fluid.state();
    for (std::size_t i = 0; i < st.size(); ++i)
      st.position[i] += 0.003 * Vec3(u(rng), u(rng), u(rng));
    fluid.updateNeighbors();
    fluid.computeFluidDensity();
    fluid.computePressure();
    for (std::size_t i = 0; i < st.size(); ++i)
      st.pressure[i] = p0 + k.dot(st.position[i]);
    if (form == PressureGradient::Consistent) {
      ASSERT_EQ(fluid.wallPressureSums().reference.size(), st.size());
      fluid.wallPressureSums().reference = st.pressure;
    }
    fluid.computeAccelerations(Vec3::Zero());
    const double support = fluid.kernel().supportRadius();
    std::size_t inner = 0;
    for (std::size_t i = 0; i < st.size(); ++i) {
      const Vec3& x = st.position[i];
      if ((x.array() < support + 0.004).any() || (x.array() > 11 * 0.019 - support - 0.004).any())
        continue;
      ++inner;
      const Vec3 want = -k / st.density[i];
      const double err = (st.acceleration[i] - want).norm() / want.norm();
      double& w = worst[form == PressureGradient::Consistent ? 0 : 1];
      w = std::max(w, err);
    }
    ASSERT_GT(inner, 50u);
  }
  std::printf("[ linear pressure ] worst relative error inside: consistent %.3g, symmetric %.3g\n",
              worst[0], worst[1]);
  EXPECT_LT(worst[0], 1e-9);
  EXPECT_GT(worst[1], 0.05);
}

/// A block of 10^3 particles 0.0185 m apart, each moved by up to 3 mm and given a velocity
/// of up to 1 m/s per component (drawn with `seed`), with its neighbours, densities and
/// pressure.
void jitteredBlock(Fluid& fluid, unsigned seed) {
  fillLattice(fluid, 10, 0.0185);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  FluidState& st = fluid.state();
  for (std::size_t i = 0; i < st.size(); ++i) {
    st.position[i] += 0.003 * Vec3(u(rng), u(rng), u(rng));
    st.velocity[i] = Vec3(u(rng), u(rng), u(rng));
  }
  fluid.updateNeighbors();
  fluid.computeFluidDensity();
  fluid.computePressure();
}

/// The consistent form's sums are pair loops like the others: the same bits on one, two
/// and three threads (pairs across the ranges), surface pressure and references included.
TEST(ConsistentPressure, SameBitsOnAnyNumberOfThreads) {
  const int threads_before = omp_get_max_threads();
  std::vector<Vec3> first;
  std::vector<double> first_p;
  for (int threads : {1, 2, 3}) {
    omp_set_num_threads(threads);
    Fluid fluid(testParams(), kDomain);
    jitteredBlock(fluid, 23);
    FluidState& st = fluid.state();
    fluid.computeAccelerations(Vec3(0, -9.81, 0));
    // Order by id: the lists' order is the same, but compare what the user sees.
    std::vector<Vec3> acc(st.size());
    std::vector<double> p(st.size());
    for (std::size_t i = 0; i < st.size(); ++i) {
      acc[st.id[i]] = st.acceleration[i];
      p[st.id[i]] = st.pressure[i];
    }
    if (first.empty()) {
      first = acc;
      first_p = p;
      continue;
    }
    for (std::size_t i = 0; i < acc.size(); ++i) {
      ASSERT_EQ(acc[i], first[i]) << "particle " << i << ", " << threads << " threads";
      ASSERT_EQ(p[i], first_p[i]) << "particle " << i << ", " << threads << " threads";
    }
  }
  omp_set_num_threads(threads_before);
}

/// Fluid::computePressureAccelerations, a pressure solver's evaluation (DFSPH's consistent
/// density solve): without viscosity it is computeAccelerations' pressure term, bit for
/// bit; on the same positions with another pressure (`same_positions`, the moments and
/// the free surface kept from the last call) it is what a fresh evaluation gives, bit for
/// bit; and it leaves the step's scratch (the step-start velocities) as it is.
TEST(ConsistentPressure, ThePressureAloneOnTheSamePositionsIsAFreshEvaluation) {
  const int threads_before = omp_get_max_threads();
  for (int threads : {1, 3}) {
    omp_set_num_threads(threads);
    FluidParams params = testParams();
    params.viscosity = 0.0;
    params.kinematic_viscosity = 0.0;
    Fluid fluid(params, kDomain);
    jitteredBlock(fluid, 29);
    FluidState& st = fluid.state();
    std::mt19937 rng(31);
    std::uniform_real_distribution<double> u(-1, 1);
    fluid.computeAccelerations(Vec3::Zero());
    const std::vector<Vec3> whole = st.acceleration;
    fluid.predict(1e-3);
    const std::vector<Vec3> start(fluid.stepStartVelocities(),
                                  fluid.stepStartVelocities() + st.size());
    fluid.computePressureFromState();
    fluid.computePressureAccelerations();
    for (std::size_t i = 0; i < st.size(); ++i)
      ASSERT_EQ(st.acceleration[i], whole[i]) << "particle " << i << ", " << threads;
    const std::vector<Vec3> first = st.acceleration;
    // Another pressure on the same positions, kept and fresh.
    std::vector<double> other(st.size());
    for (double& p : other)
      p = 2000.0 * (1.0 + u(rng));
    st.pressure = other;
    fluid.computePressureFromState(/*same_positions=*/true);
    fluid.computePressureAccelerations(nullptr, /*same_positions=*/true);
    const std::vector<Vec3> kept = st.acceleration;
    const std::vector<double> kept_p = st.pressure;
    st.pressure = other;
    fluid.computePressureFromState();
    fluid.computePressureAccelerations();
    std::size_t differ = 0;
    for (std::size_t i = 0; i < st.size(); ++i) {
      ASSERT_EQ(kept[i], st.acceleration[i]) << "particle " << i << ", " << threads;
      ASSERT_EQ(kept_p[i], st.pressure[i]) << "particle " << i << ", " << threads;
      differ += kept[i] != first[i];
    }
    EXPECT_EQ(differ, st.size());
    for (std::size_t i = 0; i < st.size(); ++i)
      ASSERT_EQ(fluid.stepStartVelocities()[i], start[i]) << "particle " << i;
  }
  omp_set_num_threads(threads_before);
  FluidParams symmetric = testParams();  // the symmetric form: no pressure alone
  symmetric.pressure_gradient = PressureGradient::Symmetric;
  Fluid fluid(symmetric, kDomain);
  fillLattice(fluid, 4, 0.019);
  fluid.updateNeighbors();
  fluid.computeFluidDensity();
  fluid.computePressure();
  EXPECT_THROW(fluid.computePressureAccelerations(), std::logic_error);
}

/// The free surface's pressure: a block at rest under gravity whose pressure is the
/// hydrostatic one (set as a compression that gives it) raises its top layer's pressure
/// from Tait's zero to about the weight of the r of fluid above its centres, and leaves
/// the particles inside as they are.
TEST(ConsistentPressure, TheTopLayerGetsTheHeadOfTheHalfSpacingAboveIt) {
  FluidParams params = testParams();
  Fluid fluid(params, kDomain);
  const double s = 0.02, g = 9.81;
  const int n = 10;
  fillLattice(fluid, n, s);
  FluidState& st = fluid.state();
  fluid.updateNeighbors();
  fluid.computeFluidDensity();
  // Each particle's density is the one whose Tait pressure is the head to the surface
  // (the lattice's top face, r above the top layer), in the fluid's inner columns.
  const double top = n * s;
  // Where the kernel is cut (the sides, the top) the summed density is lower and stays.
  std::vector<double> want(st.size());
  for (std::size_t i = 0; i < st.size(); ++i) {
    want[i] = params.rest_density * g * (top - st.position[i].y());
    st.density[i] = std::max(st.density[i], params.densityAt(want[i]));
  }
  fluid.computePressure();
  // Inner columns' top particles: a full kernel's width from the sides.
  const double support = fluid.kernel().supportRadius();
  std::size_t checked = 0;
  double ratio = 0.0;
  for (std::size_t i = 0; i < st.size(); ++i) {
    const Vec3& x = st.position[i];
    if (x.x() < support || x.x() > top - support || x.z() < support || x.z() > top - support ||
        x.y() < top - s)
      continue;
    ++checked;
    ratio += st.pressure[i] / want[i];
    // The head of r = s / 2 of water (98 Pa here), within a fifth.
    EXPECT_NEAR(st.pressure[i], want[i], 0.2 * want[i]) << x.transpose();
  }
  EXPECT_GT(checked, 4u);
  std::printf("[ surface pressure ] %zu top particles at %.3f of the head r above them\n", checked,
              ratio / static_cast<double>(checked));
  // With the symmetric form the top layer keeps Tait's zero.
  params.pressure_gradient = PressureGradient::Symmetric;
  Fluid plain(params, kDomain);
  fillLattice(plain, n, s);
  plain.updateNeighbors();
  plain.computeFluidDensity();
  plain.computePressure();
  const std::size_t corner = nearest(plain.state(), Vec3(0.1, top - 0.5 * s, 0.1));
  EXPECT_EQ(plain.state().pressure[corner], 0.0);
}

TEST(StepScratch, ViewsWithinTheBlockShareItAndAGrownOneHoldsAll) {
  StepScratch scratch;
  // The largest view first, then others within it: all valid together.
  double* sums = scratch.view<double>(64, 100000);
  const std::size_t bytes = scratch.bytes();
  EXPECT_GE(bytes, 64 + 100000 * sizeof(double));
  std::uint32_t* ids = scratch.view<std::uint32_t>(0, 10);
  for (std::uint32_t k = 0; k < 10; ++k)
    ids[k] = 7 * k + 1;
  for (std::size_t k = 0; k < 100000; ++k)
    sums[k] = 0.5 * double(k);
  EXPECT_EQ(scratch.bytes(), bytes);
  const std::uint32_t* kept = scratch.at<std::uint32_t>(0);
  for (std::uint32_t k = 0; k < 10; ++k)
    EXPECT_EQ(kept[k], 7 * k + 1) << k;
  EXPECT_EQ(scratch.at<double>(64)[99999], 0.5 * 99999.0);
  EXPECT_EQ(static_cast<const void*>(scratch.view<double>(64, 5)), static_cast<const void*>(sums));
  // A view past the block grows it to hold the whole view.
  double* more = scratch.view<double>(bytes, 1000);
  EXPECT_GE(scratch.bytes(), bytes + 1000 * sizeof(double));
  more[999] = 1.0;
  EXPECT_EQ(scratch.at<double>(bytes)[999], 1.0);
}

TEST(FluidState, PressureMeanIsKeptOnlyWhenAskedAndMovesWithItsParticle) {
  FluidState st;
  for (std::uint32_t k = 0; k < 6; ++k)
    st.append(Vec3(k, 0, 0), Vec3::Zero(), 10 + k, 1e-6);
  for (std::uint32_t k = 0; k < 6; ++k)
    st.pressure[k] = 100.0 * k;
  EXPECT_FALSE(st.keepsPressureMean());
  st.resize(7);
  EXPECT_TRUE(st.pressure_mean.empty());  // not kept: no memory
  st.resize(6);
  st.keepPressureMean();
  ASSERT_TRUE(st.keepsPressureMean());
  EXPECT_EQ(st.pressure_mean, st.pressure);  // starts as the pressure
  for (std::uint32_t k = 0; k < 6; ++k)
    st.pressure_mean[k] = 1000.0 + st.id[k];
  // Every operation that moves, removes or adds particles moves their means with them.
  const std::vector<std::uint32_t> order = {5, 3, 1, 0, 2, 4};
  std::vector<std::uint32_t> scratch(6);
  st.permute(order.data(), scratch.data());
  st.removeIf({0, 1, 0, 0, 1, 0});
  st.append(Vec3(9, 0, 0), Vec3::Zero(), 99, 1e-6);
  st.reserve(64);
  ASSERT_EQ(st.pressure_mean.size(), st.size());
  for (std::size_t i = 0; i + 1 < st.size(); ++i) {
    EXPECT_EQ(st.pressure_mean[i], 1000.0 + st.id[i]) << i;
    EXPECT_EQ(st.pressure[i], 100.0 * (st.id[i] - 10)) << i;
  }
  EXPECT_EQ(st.pressure_mean.back(), 0.0);  // a new particle: no history
  FluidState copy = st;
  EXPECT_TRUE(copy.keepsPressureMean());
  copy.resize(20);
  EXPECT_EQ(copy.pressure_mean.size(), 20u);
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

/// The pair loops take several neighbours at a time (SIMD lanes, branches as masks) and
/// compute each pair once for both particles, but must add each neighbour's terms in list
/// order: the same bits as the one-at-a-time sums over every neighbour written out below,
/// with two lanes and (where the CPU has AVX) four, with one fluid's viscosity and with a
/// viscosity per particle, on one thread and on three (pairs across the ranges).
TEST(Determinism, PairLoopsGiveTheBitsOfOneNeighbourAtATime) {
  const int threads_before = omp_get_max_threads();
  for (int threads : {1, 3})  // one range, and pairs that cross ranges
    for (bool per_particle_nu : {false, true}) {
      for (bool wide : {false, true}) {
        omp_set_num_threads(threads);
        FluidParams params = testParams();
        params.pressure_gradient = PressureGradient::Symmetric;  // the pair loop's own term
        Fluid fluid(params, kDomain);
        fillLattice(fluid, 9, 0.018);
        std::mt19937 rng(11);
        std::uniform_real_distribution<double> u(-1, 1);
        FluidState& st = fluid.state();
        for (std::size_t i = 0; i < st.size(); ++i) {
          st.position[i] += 0.003 * Vec3(u(rng), u(rng), u(rng));
          st.velocity[i] = Vec3(u(rng), u(rng), u(rng));
          if (per_particle_nu) st.kinematic_viscosity[i] = 1e-6 * (2.0 + u(rng));
        }
        fluid.setWideLanes(wide);
        fluid.updateNeighbors();
        fluid.computeFluidDensity();
        const std::vector<double> density = st.density;
        fluid.computePressure();
        fluid.computeAccelerations(Vec3(0, -9.81, 0));

        const CubicSplineKernel& kernel = fluid.kernel();
        NeighborList nb;  // every neighbour of each particle, ascending
        buildNeighborList(fluid.grid(), st.position, kernel.supportRadius(), nb);
        const double m = fluid.particleMass(), h = kernel.smoothingLength();
        const double eps_sq = 0.01 * h * h;
        const double visc = 2.0 * fluid.params().viscosity * h * fluid.params().speed_of_sound;
        for (std::size_t i = 0; i < st.size(); ++i) {
          double sum = 0.0;
          for (std::uint64_t k = nb.begin(i); k < nb.end(i); ++k)
            sum += kernel.value((st.position[i] - st.position[nb.index[k]]).norm());
          ASSERT_EQ(density[i], m * kernel.value(0.0) + m * sum) << i;
        }
        for (std::size_t i = 0; i < st.size(); ++i) {
          const double rho_i = st.density[i], inv_rho_i = 1.0 / rho_i;
          const double pr2_i = st.pressure[i] * inv_rho_i * inv_rho_i;
          Vec3 acc = Vec3::Zero(), lap = Vec3::Zero();
          for (std::uint64_t k = nb.begin(i); k < nb.end(i); ++k) {
            const std::uint32_t j = nb.index[k];
            const double inv_rho_j = 1.0 / st.density[j];
            const Vec3 xij = st.position[i] - st.position[j];
            const Vec3 vij = st.velocity[i] - st.velocity[j];
            const double r_sq = xij.squaredNorm();
            const double dwr = kernel.derivativeOverR(std::sqrt(r_sq));
            double coeff = pr2_i + st.pressure[j] * inv_rho_j * inv_rho_j;
            const double vx = vij.dot(xij);
            if (vx < 0.0) coeff += -visc / (rho_i + st.density[j]) * vx / (r_sq + eps_sq);
            acc -= (m * coeff * dwr) * xij;
            const double mu = per_particle_nu ? st.kinematic_viscosity[i] * inv_rho_j +
                                                    st.kinematic_viscosity[j] * inv_rho_i
                                              : st.kinematic_viscosity[0] * (inv_rho_j + inv_rho_i);
            lap += (mu * dwr) * vij;
          }
          acc += m * lap + Vec3(0, -9.81, 0);
          ASSERT_EQ(st.acceleration[i], acc)
              << "particle " << i << (wide ? ", wide lanes" : ", two lanes")
              << (per_particle_nu ? ", viscosity per particle" : "") << ", " << threads
              << " threads";
        }
      }
    }
  omp_set_num_threads(threads_before);
}

/// A jittered block whose particles move at random velocities (a few tenths of a
/// millimetre per step, the skin 4 mm), its corner at `origin`: with the skin the lists are
/// built only now and then (when `skinned`: else every step, the skin too thin for the
/// positions rounded to float there), yet every step has the same pairs as lists built
/// every step, and the same densities up to the order of their sums. Removing a particle
/// builds at once.
void checkSkinnedBlock(const Vec3& origin, bool skinned_builds) {
  FluidParams params = testParams();
  const Aabb domain{kDomain.min + origin, kDomain.max + origin};
  Fluid every(params, domain), skinned(params, domain);
  skinned.setNeighborSkin(0.1 * params.supportRadius());
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> u(-1, 1);
  for (Fluid* f : {&every, &skinned})
    fillLattice(*f, 8, 0.019);
  for (std::size_t i = 0; i < every.state().size(); ++i) {
    const Vec3 jitter = 0.003 * Vec3(u(rng), u(rng), u(rng));
    const Vec3 v = Vec3(u(rng), u(rng), u(rng));
    for (Fluid* f : {&every, &skinned}) {
      f->state().position[i] += origin + jitter;
      f->state().velocity[i] = v;
    }
  }
  const int steps = 60;
  for (int step = 0; step < steps; ++step) {
    if (step == 40) {  // a particle leaves
      for (Fluid* f : {&every, &skinned}) {
        std::vector<std::uint8_t> remove(f->state().size(), 0);
        for (std::size_t i = 0; i < remove.size(); ++i)
          remove[i] = f->state().id[i] == 100;
        f->state().removeIf(remove);
      }
    }
    const std::uint64_t builds = skinned.neighborBuilds();
    for (Fluid* f : {&every, &skinned}) {
      f->updateNeighbors();
      f->computeFluidDensity();
    }
    if (step == 40) {
      EXPECT_EQ(skinned.neighborBuilds(), builds + 1) << "no build after a removal";
    }
    ASSERT_EQ(pairsById(skinned), pairsById(every)) << "step " << step;
    const std::vector<double> a = densityById(every.state()), b = densityById(skinned.state());
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t k = 0; k < a.size(); ++k)
      ASSERT_NEAR(b[k], a[k], 1e-12 * std::abs(a[k])) << "step " << step << ", particle " << k;
    for (Fluid* f : {&every, &skinned})
      for (std::size_t i = 0; i < f->state().size(); ++i)
        f->state().position[i] += 2e-4 * f->state().velocity[i];
  }
  EXPECT_EQ(every.neighborBuilds(), std::uint64_t(steps));
  if (!skinned_builds) {
    EXPECT_EQ(skinned.neighborBuilds(), std::uint64_t(steps));
    EXPECT_EQ(skinned.neighborSkinnedBuilds(), 0u);
    EXPECT_TRUE(skinned.neighborReference().empty());
    return;
  }
  EXPECT_GE(skinned.neighborBuilds(), 3u);  // it did build again as the particles moved
  EXPECT_LE(skinned.neighborBuilds(), std::uint64_t(steps / 4));
  EXPECT_EQ(skinned.neighborSkinnedBuilds(), skinned.neighborBuilds());
}

TEST(Neighbors, SkinKeepsThePairsAndDensitiesAndBuildsLessOften) {
  checkSkinnedBlock(Vec3::Zero(), true);
  Fluid fluid(testParams(), kDomain);
  EXPECT_THROW(fluid.setNeighborSkin(-1.0), std::invalid_argument);
}

TEST(Neighbors, SkinKeepsThePairsAHundredMetresFromTheOrigin) {
  // The reference positions are floats (rounding ~4e-6 m at 100 m, the skin 4 mm): the
  // same pairs, as rarely built.
  checkSkinnedBlock(Vec3(100.0, -100.0, 60.0), true);
}

TEST(Neighbors, SkinTooThinForFloatsFarFromTheOriginIsNotBuilt) {
  // 300 km out a float's rounding (~8 mm) exceeds half the skin: lists built at every call
  // from the double positions, the pairs still exact.
  checkSkinnedBlock(Vec3(3.0e5, 1.0, -2.0e5), false);
}

TEST(Neighbors, ParticlesThatAreNotTheReferencesBuildAgain) {
  // The reference's ids are a digest: the same particles keep the lists; another id in
  // one slot, two ids swapped, or a particle fewer and one more (as many as before) build
  // again; the saved ids are the state's while it holds the reference's particles.
  FluidParams params = testParams();
  Fluid fluid(params, kDomain);
  fluid.setNeighborSkin(0.1 * params.supportRadius());
  fillLattice(fluid, 6, 0.019);
  FluidState& st = fluid.state();
  fluid.updateNeighbors();
  std::uint64_t builds = fluid.neighborBuilds();
  fluid.updateNeighbors();
  EXPECT_EQ(fluid.neighborBuilds(), builds) << "the same particles";
  EXPECT_EQ(fluid.neighborReferenceIds(), st.id);
  auto expectBuild = [&](const char* what) {
    EXPECT_TRUE(fluid.neighborReferenceIds().empty()) << what;
    fluid.updateNeighbors();
    EXPECT_EQ(fluid.neighborBuilds(), builds + 1) << what;
    builds = fluid.neighborBuilds();
    EXPECT_EQ(fluid.neighborReferenceIds(), st.id) << what;
  };
  st.id[17] += 1000;
  expectBuild("one id changed");
  std::swap(st.id[3], st.id[150]);
  expectBuild("two ids swapped");
  const std::uint32_t last = st.id.back();
  std::vector<std::uint8_t> remove(st.size(), 0);
  remove[40] = 1;
  st.removeIf(remove);
  st.append(st.position.back() + Vec3(0.001, 0, 0), Vec3::Zero(), last + 1,
            params.kinematic_viscosity);
  expectBuild("one removed, one added");
  // A restored reference with other ids than the particles': a build.
  std::vector<Vec3> reference(st.position);
  std::vector<std::uint32_t> ids(st.id);
  ids[5] += 1;
  fluid.restoreNeighborReference(reference, ids);
  expectBuild("restored with another id");
  ids[5] -= 1;
  fluid.restoreNeighborReference(reference, ids);
  fluid.updateNeighbors();
  EXPECT_EQ(fluid.neighborBuilds(), builds) << "restored with the particles' own ids";
}

TEST(Neighbors, SkinIsListedOnlyWhenItLastsSeveralSteps) {
  // The skin is listed at a build only when the fastest particle needs kMinSkinSteps steps
  // of dt or more to cross half of it. A block moving slowly, then too fast for the skin,
  // then slowly again: skinned builds now and then, then a plain build at every call
  // (no reference kept), then skinned builds again; the pairs always those of lists built
  // at every call.
  FluidParams params = testParams();
  const double skin = 0.1 * params.supportRadius(), dt = 2e-4;
  const double v_star = skin / (2.0 * Fluid::kMinSkinSteps * dt);  // the border speed
  Fluid every(params, kDomain), skinned(params, kDomain);
  skinned.setNeighborSkin(skin);
  std::mt19937 rng(43);
  std::uniform_real_distribution<double> u(-1, 1);
  for (Fluid* f : {&every, &skinned})
    fillLattice(*f, 8, 0.019);
  // Unit velocities, the largest exactly 1 (scaled per phase).
  std::vector<Vec3> unit(every.state().size());
  double largest = 0.0;
  for (Vec3& v : unit) {
    v = Vec3(u(rng), u(rng), u(rng));
    largest = std::max(largest, v.norm());
  }
  for (Vec3& v : unit)
    v /= largest;
  auto setSpeed = [&](double v_max) {
    for (Fluid* f : {&every, &skinned})
      for (std::size_t i = 0; i < f->state().size(); ++i)
        f->state().velocity[i] = v_max * unit[f->state().id[i]];
  };
  auto run = [&](int steps) {
    for (int step = 0; step < steps; ++step) {
      for (Fluid* f : {&every, &skinned})
        f->updateNeighbors(dt);
      ASSERT_EQ(pairsById(skinned), pairsById(every)) << "step " << step;
      for (Fluid* f : {&every, &skinned})
        for (std::size_t i = 0; i < f->state().size(); ++i)
          f->state().position[i] += dt * f->state().velocity[i];
    }
  };
  setSpeed(0.999 * v_star);
  run(30);
  const std::uint64_t slow_builds = skinned.neighborBuilds();
  EXPECT_EQ(skinned.neighborSkinnedBuilds(), slow_builds);
  EXPECT_GE(slow_builds, 3u);
  EXPECT_LE(slow_builds, 30u / 2);
  EXPECT_FALSE(skinned.neighborReference().empty());

  setSpeed(1.001 * v_star);
  run(20);
  // At most one skinned build at the new speed is left from before; then none.
  const std::uint64_t fast_skinned = skinned.neighborSkinnedBuilds();
  EXPECT_EQ(fast_skinned, slow_builds);
  EXPECT_GE(skinned.neighborBuilds() - slow_builds, 17u);  // the old lists last < 3 calls
  const std::uint64_t builds = skinned.neighborBuilds();
  run(5);
  EXPECT_EQ(skinned.neighborBuilds(), builds + 5) << "a plain build lasts one call";
  EXPECT_EQ(skinned.neighborSkinnedBuilds(), fast_skinned);
  EXPECT_TRUE(skinned.neighborReference().empty());

  setSpeed(0.5 * v_star);
  run(20);
  EXPECT_GT(skinned.neighborSkinnedBuilds(), fast_skinned) << "the skin is listed again";
  EXPECT_LE(skinned.neighborBuilds(), builds + 5 + 20 / 2);

  // dt = 0 (no step known): always the skin, however fast.
  setSpeed(100 * v_star);
  const std::uint64_t before = skinned.neighborSkinnedBuilds();
  for (int k = 0; k < 3; ++k) {
    for (std::size_t i = 0; i < skinned.state().size(); ++i)
      skinned.state().position[i] += dt * skinned.state().velocity[i];
    skinned.updateNeighbors();
  }
  EXPECT_EQ(skinned.neighborSkinnedBuilds(), before + 3);
  EXPECT_THROW(skinned.updateNeighbors(-dt), std::invalid_argument);
  EXPECT_THROW(skinned.updateNeighbors(std::nan("")), std::invalid_argument);
}

/// The viscous term (Morris' Laplacian) inside a lattice: a shear wave v_x = sin(k y) has
/// the Laplacian -k^2 v_x, so the acceleration should be -nu k^2 v_x. Measured (nu_eff / nu
/// by least squares over the particles a support inside the block): 0.930, 0.969, 0.997,
/// 1.007, 1.017, 1.019 at wavelengths of 6, 8, 12, 16, 32, 64 spacings. Long waves feel
/// the lattice's second moment of the kernel's derivative (2 % above the integral at H =
/// one spacing), short ones the sum's own dispersion.
TEST(ViscousTerm, LaplacianOfAShearWaveInsideALattice) {
  for (int lambda : {6, 8, 12, 16, 32, 64}) {
    FluidParams params = testParams();
    params.viscosity = 0.0;
    params.kinematic_viscosity = 1e-3;
    params.pressure_gradient = PressureGradient::Symmetric;
    const int n = 24;
    const double spacing = 0.02, k = 2 * M_PI / (lambda * spacing);
    Fluid fluid(params, Aabb{Vec3::Constant(-0.1), Vec3::Constant(0.6)});
    fillLattice(fluid, n, spacing);
    FluidState& st = fluid.state();
    for (std::size_t i = 0; i < st.size(); ++i)
      st.velocity[i] = Vec3(std::sin(k * st.position[i].y()), 0, 0);
    fluid.updateNeighbors();
    fluid.computeFluidDensity();
    fluid.computePressure();
    std::fill(st.pressure.begin(), st.pressure.end(), 0.0);
    fluid.computeAccelerations(Vec3::Zero());
    const double support = fluid.kernel().supportRadius();
    double num = 0, den = 0, across = 0;
    for (std::size_t i = 0; i < st.size(); ++i) {
      const Vec3& x = st.position[i];
      if ((x.array() < support + 1e-3).any() || (x.array() > n * spacing - support - 1e-3).any())
        continue;
      const double want = -k * k * st.velocity[i].x();
      num += st.acceleration[i].x() * want;
      den += want * want;
      across =
          std::max(across, std::abs(st.acceleration[i].y()) + std::abs(st.acceleration[i].z()));
    }
    const double ratio = num / den / params.kinematic_viscosity;
    std::printf("[ laplacian ] wavelength %d spacings: effective nu / nu = %.4f\n", lambda, ratio);
    EXPECT_NEAR(ratio, 1.0, lambda >= 12 ? 0.025 : 0.08) << lambda;
    EXPECT_LT(across, 1e-9 * params.kinematic_viscosity * k * k) << lambda;  // shear only
  }
}
