// The divergence-free solver's density solve with WCSPH's consistent pressure force
// (fluid.dfsph.pressure_force "consistent"; docs/forces.md, "DFSPH with the consistent
// pressure force").
//
// DFSPH's own impulse is the symmetric SPH form, which for a pressure level s̄ also pushes
// -2 s̄ (sum_b g_ab + G_a): it holds the particles' arrangement with a stiffness in
// proportion to the depth, and a slowly moving body under a few centimetres of fluid feels
// two to three times its drag. Here the pressure acts through the weakly compressible
// fluid's force instead (Fluid::computeAccelerations with PressureGradient::Consistent: the
// gradient corrected by each particle's moment, the walls' samples at the pressure the fluid
// has there, Boundaries::computeSamplePressure, and a repulsion in proportion to the
// pressure's variation over a support only), and the pressure is the one that brings the
// predicted velocities v* to the rest density at the step's end: a projected Jacobi solve of
//   p >= 0,  rho*_a = rho_a + dt D_a(v* + dt a^p(p)) <= rho0,  p_a (rho*_a - rho0) = 0,
// D_a = sum_b (v_a - v_b) . g_ab + v_a . G_a - B_a (sph/dfsph.hpp). Each iteration computes
// the pressure's accelerations a^p of the whole field, the rates, and moves each p_a by
// omega (rho*_a - rho0) rho_a^2 a_a / dt^2, a_a = 1 / (|sum_b g_ab + G_a|^2 + sum_b |g_ab|^2)
// (the symmetric form's own response, a bound on the consistent one's), never below 0; a
// particle that would end below the rest density gives up pressure it has, as one above
// takes more. It starts from the last step's pressure. The bodies' pressure force is their
// samples' pressure (Boundaries::addBodyPressure), as with WCSPH; they see the solve's
// pressure after it, not within it.
//
// Experimental: in two of the scenes tried (a sphere held at r = 2 mm with 1 ms steps, a
// sphere settling at Re 10) the iterations often ran to max_iterations, the pressure came in
// kicks several times the hydrostatic and the fluid blew up; the cause is not known.
#pragma once

#include "coupling/boundary.hpp"
#include "sph/dfsph.hpp"
#include "sph/fluid.hpp"

#include <vector>

namespace wake {

class ConsistentDensitySolve {
 public:
  /// Relaxation of the Jacobi step (0, 1].
  static constexpr double kRelaxation = 0.5;

  /// Finds the pressure for the predicted velocities (the state's, every non-pressure
  /// force in them) and applies its accelerations over dt to them; the state's pressure is
  /// the pressure found (with the free surface's raise, Fluid::computePressureFromState),
  /// `samples` the walls' and bodies' samples' pressure for it. `walls`: this step's
  /// Boundaries::solverTerms (G_a, B_a; empty without boundaries). `viscous`: scratch.
  /// Returns the iterations; `error` the last average of the deviations counted (fraction).
  int solve(Fluid& fluid, const Boundaries& boundaries, const BodyPlacement& at,
            const Vec3& gravity, WallPairs& pairs, const SolverBoundary& walls,
            SamplePressure& samples, const DfsphParams& params, double dt, double& error);

 private:
  std::vector<Vec3> predicted_, viscous_, velocity_, no_extra_, wall_unused_;
  std::vector<double> pressure_, factor_, rate_, step_;
};

}  // namespace wake
