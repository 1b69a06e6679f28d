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
  const std::uint64_t* offset = neighbors_.offset.data();
  const double self = mass_ * kernel_.value(0.0);
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    // Two neighbours at a time (the kernel without branches), added in list order.
    const Lanes2 xi = Lanes2::all(x[i].x()), yi = Lanes2::all(x[i].y()), zi = Lanes2::all(x[i].z());
    double sum = 0.0;
    const std::uint64_t e = offset[i + 1];
    for (std::uint64_t k = offset[i]; k < e; k += 2) {
      const bool both = k + 1 < e;
      const std::uint32_t j0 = nb[k], j1 = both ? nb[k + 1] : j0;
      Lanes2 xj, yj, zj;
      Lanes2::gather3(x[j0].data(), x[j1].data(), xj, yj, zj);
      const Lanes2 dx = xi - xj, dy = yi - yj, dz = zi - zj;
      const Lanes2 w = kernel_.value(sqrt(dx * dx + dy * dy + dz * dz));
      sum += w.lane0();
      if (both) sum += w.lane1();
    }
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
///
/// Two neighbours at a time: the kernel and the artificial viscosity's branch become masks,
/// and each lane's terms are added to the sums in list order, so the result is the same
/// as one neighbour at a time, bit for bit:
///   acc -= m (P_a / rho_a^2 + P_b / rho_b^2 + Pi_ab) W'(r) / r x_ab,
///   Pi_ab = -visc / (rho_a + rho_b) (v_ab . x_ab) / (r^2 + eps^2) where v_ab . x_ab < 0,
///   lap += mu_ab W'(r) / r v_ab.
template <bool kUniformNu>
void accelerationLoop(std::int64_t n, const Vec3* x, const Vec3* v, const double* rho,
                      const double* inv_rho, const double* nu, const double* pr2,
                      const NeighborList& neighbors, const CubicSplineKernel& kernel, double eps_sq,
                      double visc, double m, const Vec3& gravity, const Vec3* add, Vec3* out) {
  const std::uint32_t* nb = neighbors.index.data();
  const std::uint64_t* offset = neighbors.offset.data();
  const double nu0 = n > 0 ? nu[0] : 0.0;
  const Lanes2 mass = Lanes2::all(m), zero = Lanes2::all(0.0);
  const Lanes2 minus_visc = Lanes2::all(-visc), eps = Lanes2::all(eps_sq);
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    const Lanes2 xi = Lanes2::all(x[i].x()), yi = Lanes2::all(x[i].y()), zi = Lanes2::all(x[i].z());
    const Lanes2 ui = Lanes2::all(v[i].x()), vi = Lanes2::all(v[i].y()), wi = Lanes2::all(v[i].z());
    const Lanes2 rho_i = Lanes2::all(rho[i]), inv_rho_i = Lanes2::all(inv_rho[i]);
    const Lanes2 nu_i = Lanes2::all(kUniformNu ? nu0 : nu[i]), pi_term = Lanes2::all(pr2[i]);
    // (acc.x, acc.y), (acc.z, lap.x), (lap.y, lap.z)
    Lanes2 acc_xy = zero, acc_z_lap_x = zero, lap_yz = zero;
    const std::uint64_t e = offset[i + 1];
    for (std::uint64_t k = offset[i]; k < e; k += 2) {
      const bool both = k + 1 < e;
      const std::uint32_t j0 = nb[k], j1 = both ? nb[k + 1] : j0;
      Lanes2 xj, yj, zj, uj, vj, wj;
      Lanes2::gather3(x[j0].data(), x[j1].data(), xj, yj, zj);
      Lanes2::gather3(v[j0].data(), v[j1].data(), uj, vj, wj);
      const Lanes2 dx = xi - xj, dy = yi - yj, dz = zi - zj;
      const Lanes2 du = ui - uj, dv = vi - vj, dw = wi - wj;
      const Lanes2 r_sq = dx * dx + dy * dy + dz * dz;
      const Lanes2 dwr = kernel.derivativeOverR(sqrt(r_sq));
      Lanes2 coeff = pi_term + Lanes2::gather(pr2, j0, j1);
      const Lanes2 vx = du * dx + dv * dy + dw * dz;
      coeff = select(vx < zero,
                     coeff + minus_visc / (rho_i + Lanes2::gather(rho, j0, j1)) * vx / (r_sq + eps),
                     coeff);
      const Lanes2 f = mass * coeff * dwr;
      // Morris: x . grad W / |x|^2 = dW/dr / r (< 0), so v_a is drawn towards v_b.
      const Lanes2 inv_rho_j = Lanes2::gather(inv_rho, j0, j1);
      const Lanes2 mu = kUniformNu ? nu_i * (inv_rho_j + inv_rho_i)
                                   : nu_i * inv_rho_j + Lanes2::gather(nu, j0, j1) * inv_rho_i;
      const Lanes2 g = mu * dwr;
      // lap += g v_ab, written as lap -= -(g v_ab) (the same bits).
      acc_xy = subtractInOrder(acc_xy, f * dx, f * dy, !both);
      acc_z_lap_x = subtractInOrder(acc_z_lap_x, f * dz, -(g * du), !both);
      lap_yz = subtractInOrder(lap_yz, -(g * dv), -(g * dw), !both);
    }
    Vec3 acc(acc_xy.lane0(), acc_xy.lane1(), acc_z_lap_x.lane0());
    const Vec3 lap(acc_z_lap_x.lane1(), lap_yz.lane0(), lap_yz.lane1());
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
