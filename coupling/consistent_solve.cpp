#include "coupling/consistent_solve.hpp"

#include "sph/pair_loops.hpp"

#include <algorithm>
#include <cstdint>

namespace wake {

int ConsistentDensitySolve::solve(Fluid& fluid, const Boundaries& boundaries,
                                  const BodyPlacement& at, const Vec3& gravity, WallPairs& pairs,
                                  const SolverBoundary& walls, const PairDerivatives& derivatives,
                                  SamplePressure& samples, const DfsphParams& params, double dt,
                                  double& error) {
  FluidState& st = fluid.state();
  st.keepPressureMean();
  const std::size_t un = st.size();
  const std::int64_t n = static_cast<std::int64_t>(un);
  error = 0.0;
  if (un == 0) return 0;
  const double rho0 = fluid.params().rest_density;
  const double mass = fluid.particleMass();
  const PairLists& lists = fluid.neighbors();
  const bool walled = walls.gradient.size() == un;
  const Vec3* x = st.position.data();
  const double inv_dt2 = 1.0 / (dt * dt);
  // The fluid's compliance d rho / d p: the linearised equation of state's 1 / c^2.
  const double sound = fluid.params().speed_of_sound;
  const double compliance = 1.0 / (sound * sound);

  if (derivatives.later.size() != lists.ranges() || derivatives.before.size() != lists.ranges())
    throw std::invalid_argument("ConsistentDensitySolve: derivatives of other pair lists");
  // g_ab = m grad_a W_ab from each pair's stored W'(r) / r (no square root and kernel per
  // pair; the product kernel.gradient takes).
  auto gradient = [&](std::size_t i, std::uint32_t j, double dwr) {
    return Vec3(mass * ((x[i] - x[j]) * dwr));
  };
  predicted_ = st.velocity;

  // a_a = 1 / (|sum_b g_ab + G_a|^2 + sum_b |g_ab|^2).
  gradient_sum_.assign(un, Vec3::Zero());
  factor_.assign(un, 0.0);
  forEachPairOnceWith(lists, derivatives.later, derivatives.before,
                      [&](std::size_t i, std::uint32_t j, bool both, double dwr) {
                        const Vec3 g = gradient(i, j, dwr);
                        const double g2 = g.squaredNorm();
                        gradient_sum_[i] += g;
                        factor_[i] += g2;
                        if (both) {
                          gradient_sum_[j] -= g;
                          factor_[j] += g2;
                        }
                      });
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    const Vec3 g = gradient_sum_[i] + (walled ? walls.gradient[i] : Vec3(Vec3::Zero()));
    const double d = g.squaredNorm() + factor_[i];
    factor_[i] = d > 0.0 ? 1.0 / d : 0.0;
  }

  // The start: the pressure the equation of state gives the density now, c^2 (rho_a -
  // rho0), not the last step's pressure. With the compliance the density holds the pressure
  // (a converged step leaves rho_a = rho0 + p_a / c^2), so the two differ by what the last
  // solve left unconverged; starting from the last pressure carries that part over as a
  // pressure lagging the motion, which pumps the slow modes the few iterations leave (a
  // column at rest bounced at 4 cm/s; docs/forces.md, "A column that would not come to
  // rest"). From the state, the unconverged part is the weakly compressible fluid's explicit
  // pressure: stable for modes slower than the step, and the fast ones converge first.
  pressure_.resize(un);
  for (std::size_t i = 0; i < un; ++i)
    pressure_[i] = std::max(0.0, (st.density[i] - rho0) / compliance);
  velocity_.resize(un);
  rate_.resize(un);
  step_.resize(un);
  wall_unused_.assign(un, Vec3::Zero());
  // The pressure's accelerations with p: WCSPH's path from the pressure on (the free
  // surface, the walls' moments and what of the force depends on the positions alone found
  // once: the positions and densities are the step's throughout), and the velocities they
  // give, into velocity_.
  auto apply = [&](const std::vector<double>& p, bool same_positions) {
    st.pressure = p;
    fluid.computePressureFromState(same_positions);
    boundaries.computeSamplePressure(fluid, at, gravity, pairs, samples);
    boundaries.addWallPressure(fluid, at, pairs, samples, wall_unused_, fluid.wallPressureSums());
    fluid.computePressureAccelerations(&derivatives, same_positions);
#pragma omp parallel for schedule(static)
    for (std::int64_t i = 0; i < n; ++i)
      velocity_[i] = predicted_[i] + dt * st.acceleration[i];
  };
  int iterations = 0, best_iteration = 0;
  double best_error = 0.0;
  bool converged = false;
  for (;; ++iterations) {
    apply(pressure_, /*same_positions=*/iterations > 0);
    std::fill(rate_.begin(), rate_.end(), 0.0);
    forEachPairOnceWith(lists, derivatives.later, derivatives.before,
                        [&](std::size_t i, std::uint32_t j, bool both, double dwr) {
                          const Vec3 g = gradient(i, j, dwr);
                          const double r = (velocity_[i] - velocity_[j]).dot(g);
                          rate_[i] += r;
                          if (both) rate_[j] += r;
                        });
    // Each particle's deviation at the step's end: compression always, expansion while it
    // has pressure to give up.
#pragma omp parallel for schedule(static)
    for (std::int64_t i = 0; i < n; ++i) {
      double rate = rate_[i];
      if (walled) rate += velocity_[i].dot(walls.gradient[i]) - walls.flux[i];
      const double rho = st.density[i];
      const double deviation = rho + dt * rate - rho0 - compliance * st.pressure[i];
      // Pa per unit of density: the pressure's own response, and the compliance's
      const double response = rho * rho * factor_[i] * inv_dt2;
      const double gain = response > 0.0 ? response / (1.0 + compliance * response) : 0.0;
      double counted = 0.0;
      if (deviation > 0.0)
        counted = deviation;
      else if (st.pressure[i] > 0.0 && gain > 0.0)
        counted = -std::min(-deviation, st.pressure[i] / gain);
      step_[i] = counted * gain;
      rate_[i] = std::abs(counted);
    }
    double sum = 0.0;  // in particle order: the same bits on any number of threads
    for (std::size_t i = 0; i < un; ++i)
      sum += rate_[i];
    error = sum / (double(un) * rho0);
    if (error <= params.max_density_error && iterations >= 2) {
      converged = true;
      break;
    }
    // The best iterate so far, kept: where the Jacobi iteration stalls or turns away (a
    // squeezed film beside a jammed body: a lone particle's pressure the consistent force
    // barely answers grows each iteration), the solve ends on it.
    if (iterations == 0 || error < best_error) {
      best_error = error;
      best_iteration = iterations;
      best_pressure_ = pressure_;
    } else if (iterations - best_iteration >= kPatience) {
      break;
    }
    if (iterations >= params.max_iterations) break;
#pragma omp parallel for schedule(static)
    for (std::int64_t i = 0; i < n; ++i)
      pressure_[i] = std::max(0.0, st.pressure[i] + kRelaxation * step_[i]);
  }
  if (!converged && error > best_error) {
    // Back to the best iterate: its pressure (with the free surface's raise), samples and
    // velocities, found again (the same bits as when it was evaluated).
    apply(best_pressure_, /*same_positions=*/true);
    error = best_error;
  }
  st.velocity = velocity_;
  return iterations;
}

}  // namespace wake
