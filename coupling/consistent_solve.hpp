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
// pressure's variation over a support only), and the pressure is found implicitly: the
// pressure whose accelerations bring the predicted velocities v* to the density the
// fluid's equation of state gives that pressure at the step's end (backward Euler of
// WCSPH's equation of state, linearised: rho0 + p / c^2, c the fluid's speed of sound), in
// a projected Jacobi solve of
//   p >= 0,  e_a = rho_a + dt D_a(v* + dt a^p(p)) - rho0 - p_a / c^2 <= 0,  p_a e_a = 0,
// D_a = sum_b (v_a - v_b) . g_ab + v_a . G_a - B_a (sph/dfsph.hpp). Each iteration computes
// the pressure's accelerations a^p of the whole field, the rates, and moves each p_a by
// omega e_a k_a, k_a = s_a / (1 + s_a / c^2), s_a = rho_a^2 a_a / dt^2 and a_a = 1 /
// (|sum_b g_ab + G_a|^2 + sum_b |g_ab|^2) (the symmetric form's own response; measured in a
// tank, the consistent operator's diagonal is 0.98-1.09 of it), never below 0; a particle
// with e_a < 0 gives up pressure it has, as one with e_a > 0 takes more. It starts from the
// pressure the equation of state gives the density at the step's start, max(0, c^2 (rho_a -
// rho0)), not from the last step's pressure (the .cpp says why). It ends when the mean
// deviation counted is under max_density_error, at max_iterations, or, where the iteration
// stalls or turns away (kPatience iterations without a smaller mean), on its best iterate.
// The bodies' pressure force is their samples' pressure (Boundaries::addBodyPressure), as
// with WCSPH; they see the solve's pressure after it, not within it.
//
// Why the compliance p / c^2: without it (the rest density itself, as DFSPH's own density
// solve) the solve was unstable. The consistent force gives a uniformly raised pressure no
// effect but at the free surface, so a column's pressure level is nearly free: in a tank at
// rest the solve ran to max_iterations, the level rose to three times the hydrostatic over
// thousands of particles and the column bounced; a settling sphere and a held one blew up
// (docs/forces.md, "DFSPH with the consistent pressure force"). With the compliance a
// pressure level needs the compression the equation of state gives it, as with WCSPH, so
// it cannot run away (that tank: 10.6 iterations per step instead of 38, its largest
// density ratio 1.06-1.11 instead of 1.09-1.10 with kicks); the fluid is then as
// compressible as WCSPH's with the same c (the tank's "auto" c, 22.6 m/s: 0.23 % at the
// bottom of its 12 cm), while the step is not bound by c.
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
  /// Iterations without a smaller average deviation after which the solve ends on its best
  /// iterate (the iteration stalls or turns away; the .cpp says where).
  static constexpr int kPatience = 10;

  /// Finds the pressure for the predicted velocities (the state's, every non-pressure
  /// force in them) and applies its accelerations over dt to them; the state's pressure is
  /// the pressure found (with the free surface's raise, Fluid::computePressureFromState),
  /// `samples` the walls' and bodies' samples' pressure for it. `walls`: this step's
  /// Boundaries::solverTerms (G_a, B_a; empty without boundaries). `derivatives`: W'(r) / r
  /// of the fluid's pair lists as they are (DivergenceFreeSolver::pairDerivatives). Leaves
  /// the fluid's step scratch (the step-start velocities the control's restitution reads)
  /// as it is. Returns the iterations; `error` the last average of the deviations counted
  /// (fraction).
  int solve(Fluid& fluid, const Boundaries& boundaries, const BodyPlacement& at,
            const Vec3& gravity, WallPairs& pairs, const SolverBoundary& walls,
            const PairDerivatives& derivatives, SamplePressure& samples, const DfsphParams& params,
            double dt, double& error);

 private:
  std::vector<Vec3> predicted_, velocity_, wall_unused_, gradient_sum_;
  std::vector<double> pressure_, best_pressure_, factor_, rate_, step_;
};

}  // namespace wake
