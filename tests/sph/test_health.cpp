// The fluid's health check: which particle it names, and that it names it on any number
// of threads.
#include "sph/fluid.hpp"
#include "sph/health.hpp"

#include <gtest/gtest.h>
#include <omp.h>

#include <limits>

using namespace wake;

namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

/// n particles at rest density on a line.
FluidState line(std::size_t n) {
  FluidState st;
  for (std::size_t i = 0; i < n; ++i)
    st.append(Vec3(0.02 * i, 0, 0), Vec3::Zero(), static_cast<std::uint32_t>(100 + i), 1e-6);
  st.density.assign(n, 1000.0);
  return st;
}

FluidHealth check(const FluidState& st, int threads) {
  const int before = omp_get_max_threads();
  omp_set_num_threads(threads);
  const FluidHealth h = checkFluidHealth(st, 1000.0, 3.0);
  omp_set_num_threads(before);
  return h;
}

}  // namespace

TEST(Health, AFluidAtRestIsHealthy) {
  FluidState st = line(1000);
  st.density[17] = 2999.0;  // dense, within the limit
  const FluidHealth h = check(st, 2);
  EXPECT_TRUE(h.ok());
  EXPECT_DOUBLE_EQ(h.max_density_ratio, 2.999);
}

TEST(Health, NamesTheLowestSlotWithANonFiniteValueOnAnyNumberOfThreads) {
  FluidState st = line(1000);
  st.velocity[900].y() = kInf;
  st.position[731].z() = kNan;
  st.density[5] = 5000.0;  // a non-finite value is named before a dense particle
  for (const int threads : {1, 2, 3}) {
    const FluidHealth h = check(st, threads);
    EXPECT_EQ(h.problem, FluidHealth::Problem::NonFinitePosition) << threads;
    EXPECT_EQ(h.slot, 731u) << threads;
  }
  st.position[731].z() = 0.0;
  const FluidHealth h = check(st, 2);
  EXPECT_EQ(h.problem, FluidHealth::Problem::NonFiniteVelocity);
  EXPECT_EQ(h.slot, 900u);
  EXPECT_EQ(describeProblem(h, st, 1000.0), "a non-finite velocity");
}

TEST(Health, NamesTheDensestParticleAboveTheLimit) {
  FluidState st = line(1000);
  st.density[10] = 3100.0;
  st.density[600] = 4000.0;
  st.density[601] = 3000.0;  // at the limit: allowed
  for (const int threads : {1, 2}) {
    const FluidHealth h = check(st, threads);
    EXPECT_EQ(h.problem, FluidHealth::Problem::DensityRatio);
    EXPECT_EQ(h.slot, 600u);
    EXPECT_DOUBLE_EQ(h.max_density_ratio, 4.0);
    EXPECT_EQ(describeProblem(h, st, 1000.0), "a density of 4 x rest density");
  }
  st.density[10] = st.density[600] = 1000.0;
  EXPECT_TRUE(check(st, 2).ok());
  st.density[42] = kNan;  // a NaN density is no density within the limit
  const FluidHealth h = check(st, 2);
  EXPECT_EQ(h.problem, FluidHealth::Problem::DensityRatio);
  EXPECT_EQ(h.slot, 42u);
}
