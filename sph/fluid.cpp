#include "sph/fluid.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace wake {

namespace {
template <class T>
void gather(const std::vector<T>& src, const std::vector<std::uint32_t>& order,
            std::vector<T>& dst) {
  dst.resize(order.size());
  const std::int64_t n = static_cast<std::int64_t>(order.size());
#pragma omp parallel for schedule(static)
  for (std::int64_t k = 0; k < n; ++k)
    dst[k] = src[order[k]];
}

template <class T>
void compact(std::vector<T>& v, const std::vector<std::uint8_t>& remove) {
  std::size_t w = 0;
  for (std::size_t i = 0; i < v.size(); ++i)
    if (!remove[i]) v[w++] = v[i];
  v.resize(w);
}
}  // namespace

void FluidState::resize(std::size_t n) {
  position.resize(n);
  velocity.resize(n);
  acceleration.resize(n);
  density.resize(n);
  pressure.resize(n);
  id.resize(n);
  kinematic_viscosity.resize(n);
}

void FluidState::permute(const std::vector<std::uint32_t>& order, FluidState& scratch) {
  // Persistent fields move with their particle. acceleration, density and pressure are
  // derived each step after the sort, so they are only resized.
  gather(position, order, scratch.position);
  gather(velocity, order, scratch.velocity);
  gather(id, order, scratch.id);
  gather(kinematic_viscosity, order, scratch.kinematic_viscosity);
  position.swap(scratch.position);
  velocity.swap(scratch.velocity);
  id.swap(scratch.id);
  kinematic_viscosity.swap(scratch.kinematic_viscosity);
  acceleration.resize(order.size());
  density.resize(order.size());
  pressure.resize(order.size());
}

void FluidState::removeIf(const std::vector<std::uint8_t>& remove) {
  compact(position, remove);
  compact(velocity, remove);
  compact(acceleration, remove);
  compact(density, remove);
  compact(pressure, remove);
  compact(id, remove);
  compact(kinematic_viscosity, remove);
}

void FluidState::append(const Vec3& x, const Vec3& v, std::uint32_t particle_id, double nu) {
  position.push_back(x);
  velocity.push_back(v);
  acceleration.push_back(Vec3::Zero());
  density.push_back(0.0);
  pressure.push_back(0.0);
  id.push_back(particle_id);
  kinematic_viscosity.push_back(nu);
}

Fluid::Fluid(const FluidParams& params, const Aabb& domain, FluidState* state)
    : params_(params),
      kernel_(params.smoothingLength()),
      domain_(domain),
      mass_(params.particleMass()),
      grid_(domain, params.supportRadius()),
      state_(state ? *state : own_) {
  if (!(params.speed_of_sound > 0.0) || !std::isfinite(params.speed_of_sound))
    throw std::invalid_argument("fluid.speed_of_sound must be finite and > 0");
}

void Fluid::updateNeighbors() {
  // Fit the grid to the particles' current bounds: cells of half the support radius
  // (125 small cells per query, fewer candidates) while that grid stays small; else
  // cells of the full support (the domain-sized fallback checked at construction).
  const std::int64_t n = static_cast<std::int64_t>(state_.size());
  double lo[3] = {domain_.max.x(), domain_.max.y(), domain_.max.z()};
  double hi[3] = {domain_.min.x(), domain_.min.y(), domain_.min.z()};
#pragma omp parallel for schedule(static) reduction(min : lo[:3]) reduction(max : hi[:3])
  for (std::int64_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], state_.position[i][k]);
      hi[k] = std::max(hi[k], state_.position[i][k]);
    }
  const double support = kernel_.supportRadius();
  Aabb box{Vec3(lo[0], lo[1], lo[2]), Vec3(hi[0], hi[1], hi[2])};
  bounds_ = box;
  if (box.empty()) box = domain_;
  const double fine = 0.5 * support;
  const double fine_cells = UniformGrid::cellsFor(box, fine);
  if (fine_cells <= std::max(8.0 * double(n), 65536.0) &&
      fine_cells <= double(UniformGrid::kMaxCells))
    grid_.reset(box, fine, 2);
  else
    grid_.reset(domain_, support, 1);
  grid_.sort(state_.position, order_);
  state_.permute(order_, scratch_);
  buildNeighborList(grid_, state_.position, kernel_.supportRadius(), neighbors_);
}

void Fluid::computeFluidDensity() {
  const std::int64_t n = static_cast<std::int64_t>(state_.size());
  const Vec3* x = state_.position.data();
  const std::uint32_t* nb = neighbors_.index.data();
  const double self = mass_ * kernel_.value(0.0);
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    double sum = 0.0;
    const Vec3 xi = x[i];
    for (std::uint64_t k = neighbors_.offset[i], e = neighbors_.offset[i + 1]; k < e; ++k)
      sum += kernel_.value((xi - x[nb[k]]).norm());
    state_.density[i] = self + mass_ * sum;
  }
}

void Fluid::computePressure() {
  const std::int64_t n = static_cast<std::int64_t>(state_.size());
  p_over_rho_sq_.resize(state_.size());
  inv_rho_.resize(state_.size());
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    const double p = params_.pressure(state_.density[i]);
    state_.pressure[i] = p;
    const double inv_rho = 1.0 / state_.density[i];
    inv_rho_[i] = inv_rho;
    p_over_rho_sq_[i] = p * inv_rho * inv_rho;
  }
}

namespace {

/// The pair loop of Fluid::computeAccelerations. kUniformNu: every particle has the same
/// kinematic viscosity nu0 (one fluid: the usual case), so Morris's coefficient is
/// nu0 (1 / rho_a + 1 / rho_b) and the per-neighbour viscosity is not read.
template <bool kUniformNu>
void accelerationLoop(std::int64_t n, const Vec3* x, const Vec3* v, const double* rho,
                      const double* inv_rho, const double* nu, const double* pr2,
                      const NeighborList& neighbors, const CubicSplineKernel& kernel, double eps_sq,
                      double visc, double m, const Vec3& gravity, const Vec3* add, Vec3* out) {
  const std::uint32_t* nb = neighbors.index.data();
  const std::uint64_t* offset = neighbors.offset.data();
  const double nu0 = n > 0 ? nu[0] : 0.0;
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    const Vec3 xi = x[i], vi = v[i];
    const double rho_i = rho[i], inv_rho_i = inv_rho[i], nu_i = nu[i];
    const double pi_term = pr2[i];
    Vec3 acc = Vec3::Zero(), lap = Vec3::Zero();
    for (std::uint64_t k = offset[i], e = offset[i + 1]; k < e; ++k) {
      const std::uint32_t j = nb[k];
      const Vec3 xij = xi - x[j];
      const Vec3 vij = vi - v[j];
      const double r_sq = xij.squaredNorm();
      const double dwr = kernel.derivativeOverR(std::sqrt(r_sq));
      double coeff = pi_term + pr2[j];
      const double vx = vij.dot(xij);
      if (vx < 0.0) coeff += -visc / (rho_i + rho[j]) * vx / (r_sq + eps_sq);
      acc -= (m * coeff * dwr) * xij;
      // Morris: x . grad W / |x|^2 = dW/dr / r (< 0), so v_a is drawn towards v_b.
      const double mu =
          kUniformNu ? nu0 * (inv_rho[j] + inv_rho_i) : nu_i * inv_rho[j] + nu[j] * inv_rho_i;
      lap += (mu * dwr) * vij;
    }
    acc += m * lap + gravity;
    if (add) acc += add[i];
    out[i] = acc;
  }
}

}  // namespace

void Fluid::computeAccelerations(const Vec3& gravity, const std::vector<Vec3>& extra) {
  const std::int64_t n = static_cast<std::int64_t>(state_.size());
  const double* nu = state_.kinematic_viscosity.data();
  bool uniform = true;
  for (std::int64_t i = 1; i < n && uniform; ++i)
    uniform = nu[i] == nu[0];
  const double h = kernel_.smoothingLength();
  const double eps_sq = 0.01 * h * h;
  // nu = 2 alpha H c / (rho_a + rho_b): the numerator is constant.
  const double visc = 2.0 * params_.viscosity * h * params_.speed_of_sound;
  const Vec3* add = extra.empty() ? nullptr : extra.data();
  (uniform ? accelerationLoop<true>
           : accelerationLoop<false>)(n, state_.position.data(), state_.velocity.data(),
                                      state_.density.data(), inv_rho_.data(), nu,
                                      p_over_rho_sq_.data(), neighbors_, kernel_, eps_sq, visc,
                                      mass_, gravity, add, state_.acceleration.data());
}

double Fluid::maxSpeed() const {
  double m = 0.0;
  const std::int64_t n = static_cast<std::int64_t>(state_.size());
#pragma omp parallel for reduction(max : m) schedule(static)
  for (std::int64_t i = 0; i < n; ++i)
    m = std::max(m, state_.velocity[i].squaredNorm());
  return std::sqrt(m);
}

double Fluid::maxKinematicViscosity() const {
  double m = 0.0;
  const std::int64_t n = static_cast<std::int64_t>(state_.size());
#pragma omp parallel for reduction(max : m) schedule(static)
  for (std::int64_t i = 0; i < n; ++i)
    m = std::max(m, state_.kinematic_viscosity[i]);
  return m;
}

double Fluid::maxAcceleration() const {
  double m = 0.0;
  const std::int64_t n = static_cast<std::int64_t>(state_.size());
#pragma omp parallel for reduction(max : m) schedule(static)
  for (std::int64_t i = 0; i < n; ++i)
    m = std::max(m, state_.acceleration[i].squaredNorm());
  return std::sqrt(m);
}

void Fluid::predict(double dt, std::vector<Vec3>& x_pred, std::vector<Vec3>& v_old) {
  FluidState& st = state_;
  const std::int64_t n = static_cast<std::int64_t>(st.size());
  x_pred.resize(st.size());
  v_old.resize(st.size());
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    v_old[i] = st.velocity[i];
    st.velocity[i] += dt * st.acceleration[i];
    x_pred[i] = st.position[i] + dt * st.velocity[i];
  }
}

void Fluid::integratePositions(double dt) {
  FluidState& st = state_;
  const std::int64_t n = static_cast<std::int64_t>(st.size());
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i)
    st.position[i] += dt * st.velocity[i];
}

}  // namespace wake
