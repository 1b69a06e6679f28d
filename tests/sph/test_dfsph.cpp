// The divergence-free solver on a free block of fluid (no walls): it removes compression and
// compression rates, pushes fluid apart without creating momentum, and gives the same bits
// on one and two threads.
#include "sph/dfsph.hpp"

#include <gtest/gtest.h>
#include <omp.h>

#include <random>

using namespace wake;

namespace {

const SolverBoundary kNoBoundary;  // no walls

FluidParams solverFluid() {
  FluidParams p;
  p.particle_radius = 0.01;
  p.rest_density = 1000.0;
  p.speed_of_sound = 20.0;  // not used by the solver
  return p;
}

const Aabb kSolverDomain{Vec3(-0.2, -0.2, -0.2), Vec3(0.4, 0.4, 0.4)};

/// n^3 particles on a lattice of `spacing`, jittered by up to `jitter` (m), moving with
/// velocity(x).
template <class Velocity>
void fillBlock(Fluid& fluid, int n, double spacing, double jitter, Velocity&& velocity) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-jitter, jitter);
  std::uint32_t id = 0;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const Vec3 x = spacing * Vec3(i + 0.5, j + 0.5, k + 0.5) + Vec3(u(rng), u(rng), u(rng));
        fluid.state().append(x, velocity(x), id++, 0.0);
      }
}

/// Average over the particles of max(0, rho / rho0 - 1).
double averageCompression(const Fluid& fluid) {
  double sum = 0.0;
  for (double rho : fluid.state().density)
    sum += std::max(0.0, rho / fluid.params().rest_density - 1.0);
  return sum / double(fluid.state().size());
}

Vec3 momentum(const FluidState& st) {
  Vec3 p = Vec3::Zero();
  for (const Vec3& v : st.velocity)
    p += v;
  return p;
}

}  // namespace

TEST(Dfsph, DensitySolveBringsACompressedBlockToRestDensityWithoutMomentum) {
  // A block squeezed by 3 % per axis (~9 % denser inside), at rest: one step's pressure
  // must push it apart so that after the move it is nearly at rest density.
  Fluid fluid(solverFluid(), kSolverDomain);
  const double s = fluid.params().spacing();
  fillBlock(fluid, 10, 0.97 * s, 0.05 * s, [](const Vec3&) { return Vec3::Zero(); });
  fluid.updateNeighbors();
  fluid.computeFluidDensity();
  const double before = averageCompression(fluid);
  DfsphParams params;
  params.max_iterations = 1000;
  DivergenceFreeSolver solver(params);
  solver.prepare(fluid, kNoBoundary);
  const double dt = 1e-3;
  const int iterations = solver.solveDensity(fluid, Vec3::Zero(), dt);
  std::printf("[ dfsph ] compression %.4f before, %d iterations, predicted error %.2e\n", before,
              iterations, solver.stats().density_error);
  EXPECT_GT(before, 0.03);
  EXPECT_LE(solver.stats().density_error, params.max_density_error);
  EXPECT_LT(iterations, params.max_iterations);

  // Pressure pushes outwards, creates no momentum, and is never negative.
  const FluidState& st = fluid.state();
  Vec3 centre = Vec3::Zero();
  for (const Vec3& x : st.position)
    centre += x;
  centre /= double(st.size());
  double outward = 0.0, speed = 0.0;
  for (std::size_t i = 0; i < st.size(); ++i) {
    outward += st.velocity[i].dot(st.position[i] - centre);
    speed += st.velocity[i].norm();
    EXPECT_GE(st.pressure[i], 0.0);
  }
  EXPECT_GT(outward, 0.0);
  EXPECT_LT(momentum(st).norm(), 1e-12 * speed);

  // The move itself: the summed density after it is far closer to rest.
  fluid.integratePositions(dt);
  fluid.updateNeighbors();
  fluid.computeFluidDensity();
  const double after = averageCompression(fluid);
  std::printf("[ dfsph ] compression after the step %.5f\n", after);
  EXPECT_LT(after, 0.1 * before);
}

TEST(Dfsph, DivergenceSolveStopsAConvergingFlow) {
  // Every particle heads for the block's centre at 1 m/s per 10 cm: the divergence solve
  // must leave no compression rate (to its tolerance) and no momentum.
  Fluid fluid(solverFluid(), kSolverDomain);
  const double s = fluid.params().spacing();
  const Vec3 centre = Vec3::Constant(5 * s);
  fillBlock(fluid, 10, s, 0.0, [&](const Vec3& x) { return Vec3(-10.0 * (x - centre)); });
  fluid.updateNeighbors();
  fluid.computeFluidDensity();
  DfsphParams params;
  params.max_divergence_iterations = 1000;
  DivergenceFreeSolver solver(params);
  solver.prepare(fluid, kNoBoundary);
  const double dt = 1e-3;
  // The error measure of a converging flow before the solve: dt * (-div v) * rho / rho0.
  const int iterations = solver.solveDivergence(fluid, dt);
  std::printf("[ dfsph ] divergence solve: %d iterations, error %.2e\n", iterations,
              solver.stats().divergence_error);
  EXPECT_GT(iterations, 1);
  EXPECT_LT(iterations, params.max_divergence_iterations);
  EXPECT_LE(solver.stats().divergence_error, params.max_divergence_error);
  double speed = 0.0;
  const FluidState& st = fluid.state();
  for (const Vec3& v : st.velocity)
    speed += v.norm();
  EXPECT_LT(momentum(st).norm(), 1e-12 * speed);
  // The flow no longer compresses the inside of the block (two spacings from its faces;
  // the outer layer has too few neighbours for the solve, as a splash): over one step its
  // density changes by far less than the 3 % the converging flow would make.
  std::vector<double> rho_before(st.size());
  for (std::size_t i = 0; i < st.size(); ++i)
    rho_before[st.id[i]] = st.density[i];
  fluid.integratePositions(dt);
  fluid.updateNeighbors();
  fluid.computeFluidDensity();
  double change = 0.0;
  int inside = 0;
  for (std::size_t i = 0; i < st.size(); ++i) {
    if ((st.position[i] - centre).cwiseAbs().maxCoeff() > 3 * s) continue;
    change += std::abs(st.density[i] / rho_before[st.id[i]] - 1.0);
    ++inside;
  }
  change /= std::max(inside, 1);
  std::printf("[ dfsph ] density change inside over the step: %.2e (%d particles)\n", change,
              inside);
  EXPECT_GT(inside, 100);
  EXPECT_LT(change, 0.003);
}

TEST(Dfsph, SameBitsOnAnyNumberOfThreadsWithAndWithoutWideLanes) {
  auto run = [](int threads, bool wide, std::vector<Vec3>& velocity, DfsphStats& stats) {
    omp_set_num_threads(threads);
    Fluid fluid(solverFluid(), kSolverDomain);
    fluid.setWideLanes(wide);
    const double s = fluid.params().spacing();
    fillBlock(fluid, 12, 0.98 * s, 0.1 * s,
              [](const Vec3& x) { return Vec3(std::sin(40 * x.y()), -x.x(), 0.3 * x.z()); });
    fluid.updateNeighbors();
    fluid.computeFluidDensity();
    DivergenceFreeSolver solver{DfsphParams{}};
    solver.prepare(fluid, kNoBoundary);
    solver.solveDivergence(fluid, 1e-3);
    const int divergence = solver.stats().divergence_iterations;
    solver.solveDensity(fluid, Vec3::Zero(), 1e-3);
    stats = solver.stats();
    stats.divergence_iterations = divergence;
    // In id order (the slots are the grid's order, the same on any number of threads).
    velocity.assign(fluid.state().size(), Vec3::Zero());
    for (std::size_t i = 0; i < fluid.state().size(); ++i)
      velocity[fluid.state().id[i]] = fluid.state().velocity[i];
  };
  const int saved = omp_get_max_threads();
  std::vector<Vec3> one;
  DfsphStats a;
  run(1, true, one, a);
  EXPECT_GT(a.density_iterations, 0);
  // Pairs across ranges (2, 3 threads), and the passes in two lanes instead of AVX's four.
  for (auto [threads, wide] : {std::pair{2, true}, {3, true}, {1, false}, {3, false}}) {
    std::vector<Vec3> other;
    DfsphStats b;
    run(threads, wide, other, b);
    EXPECT_EQ(a.density_iterations, b.density_iterations) << threads << " threads, " << wide;
    EXPECT_EQ(a.divergence_iterations, b.divergence_iterations) << threads << " threads";
    ASSERT_EQ(one.size(), other.size());
    for (std::size_t i = 0; i < one.size(); ++i)
      ASSERT_EQ(one[i], other[i]) << "particle " << i << ", " << threads << " threads, " << wide;
  }
  omp_set_num_threads(saved);
}

TEST(Dfsph, GradientCorrectionIsTheInverseOfTheBulksSecondMoment) {
  // On the cubic lattice of the particles' spacing, with the support two spacings wide,
  // sum_b V_b x_ba (x) grad_a W_ab is 1.0200 I (the sum, worked out by hand with the cubic
  // spline, falls 2 % from the integral's I), so SPH's pressure gradient there is 2 % too
  // steep and the fluid's pressure 2 % low. Every particle but the outer layer has its
  // whole support (the lattice points two spacings away are where W' ends): 10^3 of 12^3.
  Fluid fluid(solverFluid(), kSolverDomain);
  const double s = fluid.params().spacing();
  fillBlock(fluid, 12, s, 0.0, [](const Vec3&) { return Vec3::Zero(); });
  fluid.updateNeighbors();
  fluid.computeFluidDensity();
  DivergenceFreeSolver solver{DfsphParams{}};
  solver.prepare(fluid, kNoBoundary);
  EXPECT_EQ(solver.bulkParticles(), 1000u);
  const Eigen::Matrix3d expected = Eigen::Matrix3d::Identity() / 1.0200417;
  EXPECT_LT((solver.gradientCorrection() - expected).cwiseAbs().maxCoeff(), 1e-5)
      << solver.gradientCorrection();

  // A block squeezed along y by 5 %: C is the inverse of the bulk's mean moment, summed
  // here pair by pair (V_b = m / rho0) over the particles whose own moment is within 0.1
  // of I on the diagonal and 0.05 off it.
  Fluid squeezed(solverFluid(), kSolverDomain);
  std::uint32_t id = 0;
  for (int k = 0; k < 12; ++k)
    for (int j = 0; j < 12; ++j)
      for (int i = 0; i < 12; ++i)
        squeezed.state().append(Vec3(s * i, 0.95 * s * j, s * k), Vec3::Zero(), id++, 0.0);
  squeezed.updateNeighbors();
  squeezed.computeFluidDensity();
  solver.prepare(squeezed, kNoBoundary);
  const CubicSplineKernel& kernel = squeezed.kernel();
  const double volume = squeezed.particleMass() / squeezed.params().rest_density;
  Eigen::Matrix3d mean = Eigen::Matrix3d::Zero();
  std::size_t bulk = 0;
  for (const Vec3& a : squeezed.state().position) {
    Eigen::Matrix3d moment = Eigen::Matrix3d::Zero();
    for (const Vec3& b : squeezed.state().position) {
      const Vec3 d = a - b;
      if (d.norm() < kernel.supportRadius())
        moment -= volume * kernel.derivativeOverR(d.norm()) * d * d.transpose();
    }
    const Eigen::Matrix3d off = moment - Eigen::Matrix3d::Identity();
    if (off.diagonal().cwiseAbs().maxCoeff() > 0.1 ||
        std::max({std::abs(off(0, 1)), std::abs(off(0, 2)), std::abs(off(1, 2))}) > 0.05)
      continue;
    mean += moment;
    ++bulk;
  }
  mean /= double(bulk);
  const Eigen::Matrix3d& c = solver.gradientCorrection();
  std::printf("[ dfsph ] lattice squeezed 5 %% along y: bulk %zu, M = diag(%.4f, %.4f, %.4f)\n",
              bulk, mean(0, 0), mean(1, 1), mean(2, 2));
  EXPECT_EQ(solver.bulkParticles(), bulk);
  EXPECT_GT(bulk, 500u);
  // (The solver sums its stored gradients, floats: 1e-8 apart.)
  EXPECT_LT((c - mean.inverse()).cwiseAbs().maxCoeff(), 1e-6) << c;
  EXPECT_GT(std::abs(mean(1, 1) - mean(0, 0)), 1e-4);  // anisotropic

  // Off: the plain SPH gradient.
  DfsphParams off;
  off.correct_gradient = false;
  DivergenceFreeSolver plain(off);
  plain.prepare(fluid, kNoBoundary);
  EXPECT_EQ(plain.bulkParticles(), 0u);
  EXPECT_EQ(plain.gradientCorrection(), Eigen::Matrix3d::Identity());
}
