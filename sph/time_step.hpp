// The fluid step's stability limits (DESIGN.md §2): the largest time step the
// fluid allows, from its speed of sound, its fastest particle (or wall), its largest
// acceleration and its viscosity.
#pragma once

#include "sph/fluid.hpp"

namespace wake {

/// min(max_dt,                         upper bound, s
///     cfl H / (c + v_max),            CFL condition (speed of sound and flow)
///     0.25 sqrt(H / a_max),           force condition (Monaghan 1992)
///     r / v_max,                      no particle moves more than its radius
///     0.125 H^2 / nu_max)             explicit viscosity (Morris et al. 1997)
/// with H the smoothing length and r the particle radius; a limit whose input is 0 is
/// left out. v_max (m/s): the fastest particle or moving wall; a_max (m/s^2); nu_max (m^2/s).
double stableTimeStep(const FluidParams& fluid, double cfl, double max_dt, double v_max,
                      double a_max, double nu_max);

/// The incompressible solver's limits: stableTimeStep without the speed of sound and
/// without r / v_max (the flow's CFL condition alone bounds the distance a particle moves,
/// cfl H <= 0.6 H: r / v_max, half of H at the default smoothing ratio, would cap
/// time.cfl at 0.5 whatever the scene asks),
///   min(max_dt, cfl H / v_max, 0.25 sqrt(H / a_max), 0.125 H^2 / nu),
/// nu = nu_max + alpha H c / 10, the artificial viscosity's share (Monaghan 2005) when the
/// fluid has one (alpha = fluid.viscosity, c = fluid.speed_of_sound scales it).
double incompressibleTimeStep(const FluidParams& fluid, double cfl, double max_dt, double v_max,
                              double a_max, double nu_max);

}  // namespace wake
