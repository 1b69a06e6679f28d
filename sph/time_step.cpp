#include "sph/time_step.hpp"

#include <algorithm>
#include <cmath>

namespace wake {

double stableTimeStep(const FluidParams& f, double cfl, double max_dt, double v_max, double a_max,
                      double nu_max) {
  const double h = f.smoothingLength();
  double dt = max_dt;
  dt = std::min(dt, cfl * h / (f.speed_of_sound + v_max));
  if (a_max > 0) dt = std::min(dt, 0.25 * std::sqrt(h / a_max));
  if (v_max > 0) dt = std::min(dt, f.particle_radius / v_max);
  if (nu_max > 0) dt = std::min(dt, 0.125 * h * h / nu_max);
  return dt;
}

double incompressibleTimeStep(const FluidParams& f, double cfl, double max_dt, double v_max,
                              double a_max, double nu_max) {
  const double h = f.smoothingLength();
  double dt = max_dt;
  if (v_max > 0) dt = std::min(dt, cfl * h / v_max);
  if (a_max > 0) dt = std::min(dt, 0.25 * std::sqrt(h / a_max));
  const double nu = nu_max + f.viscosity * h * f.speed_of_sound / 10.0;
  if (nu > 0) dt = std::min(dt, 0.125 * h * h / nu);
  return dt;
}

}  // namespace wake
