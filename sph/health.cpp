#include "sph/health.hpp"

#include "sph/fluid.hpp"

#include <omp.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>

namespace wake {

FluidHealth checkFluidHealth(const FluidState& st, double rest_density, double density_limit) {
  const std::int64_t n = static_cast<std::int64_t>(st.size());
  const double rho_limit = density_limit * rest_density;
  double rho_max = 0.0;
  bool nan_density = false;
  std::int64_t first_bad = n;  // lowest slot with a non-finite position or velocity
#pragma omp parallel for schedule(static) reduction(max                               \
                                                    : rho_max) reduction(min          \
                                                                         : first_bad) \
    reduction(||                                                                      \
              : nan_density)
  for (std::int64_t i = 0; i < n; ++i) {
    const double rho = st.density[i];
    rho_max = std::max(rho_max, rho);
    nan_density = nan_density || std::isnan(rho);
    if (!st.position[i].allFinite() || !st.velocity[i].allFinite())
      first_bad = std::min(first_bad, i);
  }

  FluidHealth h;
  h.max_density_ratio =
      nan_density ? std::numeric_limits<double>::quiet_NaN() : rho_max / rest_density;
  if (first_bad < n) {
    h.slot = static_cast<std::size_t>(first_bad);
    h.problem = st.position[h.slot].allFinite() ? FluidHealth::Problem::NonFiniteVelocity
                                                : FluidHealth::Problem::NonFinitePosition;
    return h;
  }
  if (nan_density || rho_max > rho_limit) {
    // Name the densest particle (the first NaN density when there is one).
    std::size_t worst = 0;
    for (std::size_t i = 0; i < st.size(); ++i) {
      if (std::isnan(st.density[i])) {
        worst = i;
        break;
      }
      if (st.density[i] > st.density[worst]) worst = i;
    }
    h.slot = worst;
    h.problem = FluidHealth::Problem::DensityRatio;
  }
  return h;
}

std::string describeProblem(const FluidHealth& h, const FluidState& st, double rest_density) {
  std::ostringstream m;
  switch (h.problem) {
    case FluidHealth::Problem::None:
      return "no problem";
    case FluidHealth::Problem::NonFinitePosition:
      m << "a non-finite position";
      break;
    case FluidHealth::Problem::NonFiniteVelocity:
      m << "a non-finite velocity";
      break;
    case FluidHealth::Problem::DensityRatio:
      m << "a density of " << st.density[h.slot] / rest_density << " x rest density";
      break;
  }
  return m.str();
}

}  // namespace wake
