#include "sph/dfsph.hpp"

#include "sph/pair_loops.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace wake {

namespace {

/// Sums of one particle while its factor is found: sum_b g_ab and sum_b |g_ab|^2.
struct GradientSums {
  Vec3 g = Vec3::Zero();
  double sq = 0.0;
  std::uint32_t count = 0;     ///< fluid neighbours
  Vec3 offset = Vec3::Zero();  ///< sum_b |g_ab|^2 (x_b - x_a)
};

/// Neighbours of a particle inside a fluid at rest on the lattice (spacing s, support 2H):
/// the lattice points closer than the support, itself left out.
int latticeNeighbors(const FluidParams& f) {
  const double reach = f.supportRadius() / f.spacing();
  const int k = static_cast<int>(std::ceil(reach));
  int count = 0;
  for (int x = -k; x <= k; ++x)
    for (int y = -k; y <= k; ++y)
      for (int z = -k; z <= k; ++z)
        count += (x * x + y * y + z * z < reach * reach) ? 1 : 0;
  return count - 1;
}

Vec3 load(const float* g) {
  return Vec3(static_cast<double>(g[0]), static_cast<double>(g[1]), static_cast<double>(g[2]));
}

}  // namespace

template <class T, class Term>
void DivergenceFreeSolver::pairSums(const PairLists& pairs, const T& zero, std::vector<T>& sum,
                                    Term&& term) {
  pairSums(pairs, nullptr, zero, sum, term);
}

template <class T, class Term>
void DivergenceFreeSolver::pairSums(const PairLists& pairs, const GradientSource* fill,
                                    const T& zero, std::vector<T>& sum, Term&& term) {
  sum.resize(pairs.size());
  forEachRange(pairs, [&](std::int64_t i0, std::int64_t i1, std::size_t r) {
    const std::uint32_t end = static_cast<std::uint32_t>(i1);
    forEachListOfRange(
        pairs, r, i0, i1,
        [&](std::int64_t i, const std::uint32_t* nb, std::uint64_t k, std::uint64_t e, bool later) {
          float* grad = (later ? later_grad_[r] : before_grad_[r]).data();
          T own = later ? sum[i] : zero;
          for (std::uint64_t t = k; t < e; ++t) {
            const std::uint32_t j = nb[t];
            if (fill) {
              const Vec3 d = fill->x[i] - fill->x[j];
              const Vec3 g =
                  (fill->mass * fill->kernel->derivativeOverR(std::sqrt(d.squaredNorm()))) * d;
              for (int c = 0; c < 3; ++c)
                grad[3 * t + c] = static_cast<float>(g[c]);
            }
            term(static_cast<std::size_t>(i), j, load(grad + 3 * t), own,
                 later && j < end ? &sum[j] : nullptr);
          }
          sum[i] = own;
        });
  });
}

template <class F>
double DivergenceFreeSolver::chunkedSum(std::size_t n, F&& f) {
  constexpr std::size_t kChunk = 4096;
  const std::int64_t chunks = static_cast<std::int64_t>((n + kChunk - 1) / kChunk);
  std::vector<double> part(static_cast<std::size_t>(chunks), 0.0);
#pragma omp parallel for schedule(static)
  for (std::int64_t c = 0; c < chunks; ++c) {
    double s = 0.0;
    const std::size_t end = std::min(n, (c + 1) * kChunk);
    for (std::size_t i = c * kChunk; i < end; ++i)
      s += f(i);
    part[c] = s;
  }
  double total = 0.0;
  for (double s : part)
    total += s;
  return total;
}

void DivergenceFreeSolver::prepare(const Fluid& fluid, const SolverBoundary& boundary) {
  const FluidState& st = fluid.state();
  const PairLists& pairs = fluid.neighbors();
  const std::size_t n = st.size();
  if (pairs.size() != n)
    throw std::logic_error("DivergenceFreeSolver::prepare before updateNeighbors");
  const bool walls = !boundary.gradient.empty();
  if (walls && (boundary.gradient.size() != n || boundary.flux.size() != n ||
                boundary.neighbors.size() != n || boundary.hydrostatic.size() != n ||
                boundary.hydrostatic_above.size() != n))
    throw std::logic_error("DivergenceFreeSolver::prepare: boundary terms of another size");
  boundary_ = walls ? &boundary : nullptr;
  const std::size_t ranges = pairs.ranges();
  later_grad_.resize(ranges);
  before_grad_.resize(ranges);
  const CubicSplineKernel& kernel = fluid.kernel();
  const double m = fluid.particleMass();
  // g_ab = m grad_a W(x_a - x_b), for each list from its own point's side (g_ba = -g_ab
  // bit for bit: x_b - x_a is -(x_a - x_b) exactly), stored as the factor's sums read them.
  for (std::size_t r = 0; r < ranges; ++r) {
    const std::size_t i0 = pairs.range[r], i1 = pairs.range[r + 1];
    const std::size_t used = i1 > i0 ? pairs.begin[i1 - 1] + pairs.count[i1 - 1] : 0;
    later_grad_[r].resize(3 * used);
    before_grad_[r].resize(3 * pairs.before[r].size());
  }
  // The particles with samples in their support: the walls' terms are theirs alone.
  near_wall_.assign(n, 0);
  if (walls)
    for (std::size_t i = 0; i < n; ++i)
      near_wall_[i] = boundary.gradient[i].squaredNorm() > 0.0 ? 1 : 0;
  const std::uint8_t* near = near_wall_.data();
  const Vec3* x = st.position.data();
  const GradientSource source{x, &kernel, m};
  std::vector<GradientSums> sums;
  pairSums(pairs, &source, GradientSums{}, sums,
           [x, near](std::size_t i, std::uint32_t j, const Vec3& g, GradientSums& own,
                     GradientSums* other) {
             const double sq = g.squaredNorm();
             own.g += g;
             own.sq += sq;
             ++own.count;
             if (near[i]) own.offset += sq * (x[j] - x[i]);
             if (!other) return;
             other->g -= g;
             other->sq += sq;
             ++other->count;
             if (near[j]) other->offset += sq * (x[i] - x[j]);
           });
  // A particle with (almost) no neighbours has no pressure to find.
  const double h = kernel.smoothingLength();
  const double scale = m * std::abs(kernel.derivativeOverR(h)) * h;
  const double eps = 1e-6 * scale * scale;
  factor_.resize(n);
  sparse_.resize(n);
  weight_.resize(n);
  centre_.resize(n);
  // Fewer than 3/4 of a resting particle's neighbours (fluid and wall samples): a splash,
  // whose rate of compression says little (SPlisHSPlasH's 20 of ~26 at this support).
  const std::uint32_t enough =
      static_cast<std::uint32_t>(std::ceil(0.75 * latticeNeighbors(fluid.params())));
  const std::int64_t sn = static_cast<std::int64_t>(n);
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < sn; ++i) {
    // s_a's own push: -s_a (sum_b g_ab + 3/2 G_a) (its own half of s^w_a); the change of
    // D_a it makes: -s_a [(sum_b g_ab + G_a) . (sum_b g_ab + 3/2 G_a) + sum_b |g_ab|^2].
    const Vec3 wall = walls ? boundary.gradient[i] : Vec3(Vec3::Zero());
    const Vec3 g = sums[i].g + wall;
    const double denominator = std::max(g.dot(g + 0.5 * wall), 0.0) + sums[i].sq;
    factor_[i] = denominator > eps ? 1.0 / denominator : 0.0;
    const std::uint32_t around = sums[i].count + (walls ? boundary.neighbors[i] : 0u);
    sparse_[i] = around < enough;
    weight_[i] = sums[i].sq;
    // The fluid around a, a itself weighing as much as its neighbours together.
    centre_[i] = sums[i].sq > 0.0 ? Vec3(0.5 / sums[i].sq * sums[i].offset) : Vec3(Vec3::Zero());
  }
  wall_impulse_.assign(n, 0.0);  // a new step
  lift_.assign(n, 0.0);
  above_.assign(n, 0.0);
  rates_fresh_ = false;
}

void DivergenceFreeSolver::densityRates(const Fluid& fluid) {
  const FluidState& st = fluid.state();
  const Vec3* v = st.velocity.data();
  pairSums(fluid.neighbors(), 0.0, rate_,
           [v](std::size_t i, std::uint32_t j, const Vec3& g, double& own, double* other) {
             const double t = (v[i] - v[j]).dot(g);
             own += t;
             if (other) *other += t;
           });
  if (!boundary_) return;
  const std::int64_t n = static_cast<std::int64_t>(st.size());
  const SolverBoundary& b = *boundary_;
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i)
    rate_[i] += v[i].dot(b.gradient[i]) - b.flux[i];
}

void DivergenceFreeSolver::applyImpulse(Fluid& fluid) {
  FluidState& st = fluid.state();
  const double* ds = ds_.data();
  pairSums(fluid.neighbors(), PairChange{}, change_,
           [ds](std::size_t i, std::uint32_t j, const Vec3& g, PairChange& own, PairChange* other) {
             // No branch on the pair's values: s is zero at random where the fluid is not
             // compressed, and a mispredicted branch costs more than the terms.
             const double ds_i = ds[i], ds_j = ds[j];
             const Vec3 f = (ds_i + ds_j) * g;
             const double w = g.squaredNorm();
             own.dv -= f;
             own.weighted += w * ds_j;
             if (!other) return;
             other->dv += f;
             other->weighted += w * ds_i;
           });
  const std::int64_t n = static_cast<std::int64_t>(st.size());
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    Vec3 change = change_[i].dv;
    if (near_wall_[i]) {
      // s_a + s^w_a: a's own and the mean of the fluid's around it.
      const double around = weight_[i] > 0.0 ? change_[i].weighted / weight_[i] : ds_[i];
      const double wall = 1.5 * ds_[i] + 0.5 * around;
      change -= wall * boundary_->gradient[i];
      wall_impulse_[i] += wall;
    }
    st.velocity[i] += change;
    s_[i] += ds_[i];
  }
}

void DivergenceFreeSolver::applyHydrostatic(Fluid& fluid, const Vec3& gravity, double dt) {
  if (!boundary_) return;
  FluidState& st = fluid.state();
  const SolverBoundary& b = *boundary_;
  const double inv_rho0 = 1.0 / fluid.params().rest_density;
  const std::int64_t n = static_cast<std::int64_t>(st.size());
  // Samples above a have less pressure than the fluid around it, by the weight between:
  // all of it where a's own (last) pressure exceeds the weight of a support's height of
  // fluid, less where a is near the free surface (never a pull towards a lid or a body's
  // underside that the fluid barely touches).
  const double deep = fluid.params().rest_density * gravity.norm() * fluid.kernel().supportRadius();
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    const double chi = deep > 0.0 ? std::clamp(st.pressure[i] / deep, 0.0, 1.0) : 0.0;
    const double l = -gravity.dot(centre_[i]);
    lift_[i] = l > 0.0 ? l : chi * l;
    above_[i] = chi;
    st.velocity[i] -= dt * (b.hydrostatic[i] + chi * b.hydrostatic_above[i] +
                            (lift_[i] * inv_rho0) * b.gradient[i]);
  }
}

int DivergenceFreeSolver::solveDivergence(Fluid& fluid, double dt) {
  const std::size_t n = fluid.state().size();
  stats_.divergence_iterations = 0;
  stats_.divergence_error = 0.0;
  if (n == 0 || params_.max_divergence_iterations <= 0) return 0;
  if (factor_.size() != n) throw std::logic_error("DivergenceFreeSolver: solve before prepare");
  // The error is averaged over the particles the solve takes part in.
  std::size_t dense = 0;
  for (std::size_t i = 0; i < n; ++i)
    dense += sparse_[i] ? 0 : 1;
  if (dense == 0) return 0;
  const double scale = dt / (double(dense) * fluid.params().rest_density);
  s_.assign(n, 0.0);
  ds_.resize(n);
  int iterations = 0;
  for (;;) {
    densityRates(fluid);
    // Each particle's pressure grows by what removes its own compression rate; a particle
    // with too few neighbours for a reliable rate (a splash) is left alone.
    const double error = scale * chunkedSum(n, [&](std::size_t i) {
                           const double rate = sparse_[i] ? 0.0 : std::max(0.0, rate_[i]);
                           ds_[i] = rate * factor_[i];
                           return rate;
                         });
    stats_.divergence_error = error;
    if (error <= params_.max_divergence_error || iterations >= params_.max_divergence_iterations)
      break;
    applyImpulse(fluid);
    ++iterations;
  }
  rates_fresh_ = true;  // rate_: of the velocities the solve leaves
  stats_.divergence_iterations = iterations;
  return iterations;
}

int DivergenceFreeSolver::solveDensity(Fluid& fluid, const Vec3& gravity, double dt) {
  FluidState& st = fluid.state();
  const std::size_t n = st.size();
  stats_.density_iterations = 0;
  stats_.density_error = 0.0;
  if (n == 0) return 0;
  if (factor_.size() != n) throw std::logic_error("DivergenceFreeSolver: solve before prepare");
  const double rho0 = fluid.params().rest_density;
  const double inv_dt = 1.0 / dt;
  s_.assign(n, 0.0);
  ds_.resize(n);
  // Warm start: half the last step's pressure (s = dt p / rho^2) where the fluid would be
  // compressed at the step's end with the velocities of its start (the divergence solve's
  // rates); the iterations only add pressure, so this is how it falls.
  if (!rates_fresh_) densityRates(fluid);
  rates_fresh_ = false;
  const double any = chunkedSum(n, [&](std::size_t i) {
    const double rho = st.density[i];
    const bool compressed = rho + dt * rate_[i] > rho0;
    ds_[i] = compressed && st.pressure[i] > 0.0 ? 0.5 * dt * st.pressure[i] / (rho * rho) : 0.0;
    return ds_[i] > 0.0 ? 1.0 : 0.0;
  });
  if (any > 0.0) applyImpulse(fluid);
  applyHydrostatic(fluid, gravity, dt);
  const double scale = 1.0 / (double(n) * rho0);
  int iterations = 0;
  for (;;) {
    densityRates(fluid);
    // Each particle's pressure grows by what removes its own compression at the step's end.
    const double error = scale * chunkedSum(n, [&](std::size_t i) {
                           const double excess =
                               std::max(0.0, st.density[i] + dt * rate_[i] - rho0);
                           ds_[i] = excess * factor_[i] * inv_dt;
                           return excess;
                         });
    stats_.density_error = error;
    if ((error <= params_.max_density_error && iterations >= 2) ||
        iterations >= params_.max_iterations)
      break;
    applyImpulse(fluid);
    ++iterations;
  }
  const std::int64_t sn = static_cast<std::int64_t>(n);
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < sn; ++i)
    st.pressure[i] = s_[i] * st.density[i] * st.density[i] * inv_dt;
  stats_.density_iterations = iterations;
  return iterations;
}

}  // namespace wake
