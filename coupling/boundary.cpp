#include "coupling/boundary.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace wake {

namespace {

/// Sum of W over a flat square lattice of spacing s through the origin: what one boundary
/// sample sees of a flat wall sampled at the fluid spacing.
double flatLatticeKernelSum(const CubicSplineKernel& kernel, double s) {
  const int reach = static_cast<int>(std::ceil(kernel.supportRadius() / s)) + 1;
  double sum = 0.0;
  for (int i = -reach; i <= reach; ++i)
    for (int j = -reach; j <= reach; ++j)
      sum += kernel.value(s * std::hypot(i, j));
  return sum;
}

/// Share of a no-slip wall's viscous shear that a wall of slip eps exerts: the wall with
/// Navier slip length b = eps / (1 - eps) * 2H (2H: the kernel support, 4 particle radii
/// at H = one spacing) over the first fluid layer, which lies one radius r from the
/// surface: r / (r + b) = (1 - eps) / (1 + 3 eps).
double wallShearFactor(double eps) {
  return (1.0 - eps) / (1.0 + 3.0 * eps);
}

Aabb grown(Aabb b, double by) {
  b.min.array() -= by;
  b.max.array() += by;
  return b;
}

}  // namespace

Boundaries::Boundaries(const FluidParams& fluid, const Aabb& domain)
    : fluid_(fluid),
      kernel_(fluid.smoothingLength()),
      domain_(domain),
      spacing_(fluid.spacing()),
      radius_(fluid.particle_radius),
      volume_scale_(spacing_ * spacing_ * spacing_ * flatLatticeKernelSum(kernel_, spacing_)) {}

std::size_t Boundaries::addBody(const BodySettings& settings) {
  if (finalized_) throw std::logic_error("Boundaries::addBody after finalize()");
  if (!settings.shape) throw std::invalid_argument("body '" + settings.name + "' has no shape");
  Body b;
  b.settings = settings;
  // Infinite shapes are sampled within the domain (grown by a support for the density).
  const Aabb clip = transformBounds(grown(domain_, fluid_.supportRadius()), settings.pose, false);
  settings.shape->sample(spacing_, radius_, clip, b.local);
  b.sample_count = b.local.size();
  for (const Vec3& p : b.local.position)
    b.extent = std::max(b.extent, p.norm() + radius_);
  b.rotation = settings.pose.orientation.toRotationMatrix();
  updateWorldBounds(b);
  shear_factor_.push_back(wallShearFactor(settings.slip));
  any_shear_ = any_shear_ || settings.slip < 1.0;
  bodies_.push_back(std::move(b));
  return bodies_.size() - 1;
}

void Boundaries::updateWorldBounds(Body& b) {
  const Aabb clip = transformBounds(domain_, b.settings.pose, false);
  b.world_bounds = transformBounds(b.settings.shape->bounds(clip), b.settings.pose, true);
  b.contact_bounds = grown(b.world_bounds, radius_);
}

void Boundaries::buildSet(SampleSet& set, const Aabb& box, const std::vector<Vec3>& pos,
                          const std::vector<Vec3>& nrm, const std::vector<std::uint32_t>& body,
                          bool flags) {
  // Cells of half the support: the density share searches 2 cells around a particle,
  // contacts (reach r_f + r_b = half the support) only 1. Too many cells: full support.
  const double support = kernel_.supportRadius();
  const Aabb grid_box = grown(box, support);
  if (UniformGrid::cellsFor(grid_box, 0.5 * support) <= double(UniformGrid::kMaxCells))
    set.grid = UniformGrid(grid_box, 0.5 * support, UniformGrid::kMaxCells, 2);
  else
    set.grid = UniformGrid(grid_box, support, UniformGrid::kMaxCells, 1);
  auto cellsToCover = [&](double distance) {
    return std::max(1, static_cast<int>(std::ceil(distance / set.grid.cellSize() - 1e-12)));
  };
  set.density_reach = cellsToCover(support);
  set.sample_reach = cellsToCover(2.0 * radius_);
  // A centre within r of the surface is within r + r_b of a sample's centre along the
  // normal and at most about a spacing beside it (between samples): 4 r covers it.
  set.contact_reach = cellsToCover(4.0 * radius_);
  set.reach_box = grid_box;

  std::vector<std::uint32_t> order;
  set.grid.sort(pos, order);
  const std::size_t total = pos.size();
  set.position.resize(total);
  set.normal.resize(total);
  set.body.resize(total);
  for (std::size_t k = 0; k < total; ++k) {
    set.position[k] = pos[order[k]];
    set.normal[k] = nrm[order[k]];
    set.body[k] = body[order[k]];
  }

  // Volumes (Akinci et al. 2012), normalised so that a flat wall sampled at the fluid
  // spacing stands for exactly one missing fluid layer: V_k = s^3 S_flat / sum_l W_kl.
  // Samples of an opposite face (a thin wall's other side) are not neighbours.
  set.volume.assign(total, 0.0);
  const double support_sq = support * support;
  const std::int64_t n = static_cast<std::int64_t>(total);
#pragma omp parallel for schedule(static)
  for (std::int64_t k = 0; k < n; ++k) {
    double sum = 0.0;
    const Vec3 xk = set.position[k], nk = set.normal[k];
    set.grid.forEachRangeWithin(xk, set.density_reach, [&](std::uint32_t lo, std::uint32_t hi) {
      for (std::uint32_t l = lo; l < hi; ++l) {
        const double d_sq = (xk - set.position[l]).squaredNorm();
        if (d_sq < support_sq && nk.dot(set.normal[l]) > -0.5)
          sum += kernel_.value(std::sqrt(d_sq));
      }
    });
    set.volume[k] = volume_scale_ / sum;
  }

  // Flag the cells from which a sample can be within the kernel support or contact reach.
  set.near.clear();
  if (!flags) return;
  set.near.assign(set.grid.cellCount(), 0);
  const Eigen::Vector3i dims = set.grid.dims();
  auto mark = [&](const Eigen::Vector3i& c, int reach, std::uint8_t bit) {
    for (int z = std::max(0, c[2] - reach); z <= std::min(dims[2] - 1, c[2] + reach); ++z)
      for (int y = std::max(0, c[1] - reach); y <= std::min(dims[1] - 1, c[1] + reach); ++y)
        for (int x = std::max(0, c[0] - reach); x <= std::min(dims[0] - 1, c[0] + reach); ++x)
          set.near[set.grid.cellIndex(Eigen::Vector3i(x, y, z))] |= bit;
  };
  for (std::size_t k = 0; k < total; ++k) {
    const Eigen::Vector3i c = set.grid.cellCoord(set.position[k]);
    mark(c, set.density_reach, kNearDensity);
    mark(c, set.contact_reach, kNearContact);
  }
}

void Boundaries::finalize() {
  if (finalized_) throw std::logic_error("Boundaries::finalize called twice");
  finalized_ = true;
  // Static bodies: one world-space set over the domain.
  std::vector<Vec3> pos, nrm;
  std::vector<std::uint32_t> owner;
  for (std::size_t bi = 0; bi < bodies_.size(); ++bi) {
    Body& b = bodies_[bi];
    if (b.settings.moves()) continue;
    for (std::size_t k = 0; k < b.local.size(); ++k) {
      pos.push_back(b.settings.pose.toWorld(b.local.position[k]));
      nrm.push_back(b.settings.pose.rotate(b.local.normal[k]));
      owner.push_back(static_cast<std::uint32_t>(bi));
    }
    b.local.clear();
  }
  if (!pos.empty()) buildSet(static_, domain_, pos, nrm, owner, /*flags=*/true);
  for (std::size_t bi = 0; bi < bodies_.size(); ++bi)
    if (!bodies_[bi].settings.moves()) static_bodies_.push_back(static_cast<std::uint32_t>(bi));
  // Moving bodies: one body-space set each.
  for (std::size_t bi = 0; bi < bodies_.size(); ++bi) {
    Body& b = bodies_[bi];
    if (!b.settings.moves()) continue;
    MovingBody m;
    m.body = static_cast<std::uint32_t>(bi);
    Aabb box;
    for (const Vec3& p : b.local.position)
      box.extend(p);
    if (!box.empty()) {
      buildSet(m.samples, box, b.local.position, b.local.normal,
               std::vector<std::uint32_t>(b.local.size(), m.body), /*flags=*/true);
    }
    b.local.clear();
    b.moving = static_cast<std::int32_t>(moving_.size());
    moving_.push_back(std::move(m));
  }
  for (std::size_t bi = 0; bi < bodies_.size(); ++bi) {
    const Body& b = bodies_[bi];
    if (b.moving >= 0)
      setBodyState(bi, {b.settings.pose, b.settings.linear_velocity, b.settings.angular_velocity});
  }
  // The walls' own share of each sample's density (body-frame data: once).
  computeWallShare(static_, /*body_space=*/false);
  for (MovingBody& m : moving_)
    computeWallShare(m.samples, /*body_space=*/true);
}

void Boundaries::setBodyState(std::size_t body, const RigidState& state) {
  Body& b = bodies_[body];
  if (b.moving < 0) throw std::logic_error("body '" + b.settings.name + "' is static");
  b.settings.pose = state.pose;
  b.settings.linear_velocity = state.linear_velocity;
  b.settings.angular_velocity = state.angular_velocity;
  b.rotation = state.pose.orientation.toRotationMatrix();
  updateWorldBounds(b);
  MovingBody& m = moving_[b.moving];
  m.world_reach = m.samples.position.empty()
                      ? Aabb()
                      : transformBounds(m.samples.reach_box, state.pose, /*to_world=*/true);
  moving_reach_ = Aabb();
  for (const MovingBody& other : moving_)
    moving_reach_.extend(other.world_reach);
}

RigidState Boundaries::bodyState(std::size_t b) const {
  const BodySettings& s = bodies_[b].settings;
  return {s.pose, s.linear_velocity, s.angular_velocity};
}

std::size_t Boundaries::sampleCount() const {
  std::size_t total = static_.position.size();
  for (const MovingBody& m : moving_)
    total += m.samples.position.size();
  return total;
}

void Boundaries::worldSamples(std::vector<Vec3>& position, std::vector<Vec3>& normal,
                              std::vector<double>& volume, std::vector<std::uint32_t>& body) const {
  position = static_.position;
  normal = static_.normal;
  volume = static_.volume;
  body = static_.body;
  for (const MovingBody& m : moving_) {
    const Pose& pose = bodies_[m.body].settings.pose;
    for (std::size_t k = 0; k < m.samples.position.size(); ++k) {
      position.push_back(pose.toWorld(m.samples.position[k]));
      normal.push_back(pose.rotate(m.samples.normal[k]));
      volume.push_back(m.samples.volume[k]);
      body.push_back(m.body);
    }
  }
}

void Boundaries::addDensity(const Fluid& fluid, std::vector<double>& density) const {
  wallPass(fluid, density, nullptr, nullptr);
}

void Boundaries::addWallTerms(const Fluid& fluid, std::vector<double>& density,
                              std::vector<Vec3>& shear, std::vector<Wrench>& reaction) const {
  wallPass(fluid, density, &shear, &reaction);
}

double Boundaries::wallSums(const SampleSet& set, const Vec3& p, double nu, const Vec3& u,
                            const Vec3& omega, Vec3& shear, Vec3* moment, PressureSums* pressure,
                            bool pressure_moments) const {
  const double support_sq = kernel_.supportRadius() * kernel_.supportRadius();
  const double rb = radius_;
  const double two_nu = 2.0 * nu;
  double sum = 0.0;
  set.grid.forEachRangeWithin(p, set.density_reach, [&](std::uint32_t lo, std::uint32_t hi) {
    for (std::uint32_t k = lo; k < hi; ++k) {
      const Vec3 d = p - set.position[k];
      const double d_sq = d.squaredNorm();
      if (d_sq >= support_sq) continue;
      const double r = std::sqrt(d_sq);
      sum += set.volume[k] * kernel_.value(r);
      if (pressure) {
        const Vec3 g = (set.volume[k] * kernel_.derivativeOverR(r)) * d;
        const Vec3 gs = set.p_rho2[k] * g;
        pressure->grad += g;
        pressure->scaled += gs;
        if (pressure_moments) {
          pressure->grad_moment += set.position[k].cross(g);
          pressure->scaled_moment += set.position[k].cross(gs);
        }
      }
      if (!(nu > 0.0)) continue;
      const double factor = shear_factor_[set.body[k]];
      if (factor <= 0.0) continue;
      // Morris's ghost velocity: the sample lies rb behind the surface, the particle
      // `beyond` in front of it; 1 + rb / beyond, at most 2 (a particle at or inside its
      // radius).
      const double beyond = d.dot(set.normal[k]) - rb;
      const double beta = beyond > rb ? 1.0 + rb / beyond : 2.0;
      const double w = -factor * two_nu * set.volume[k] * beta * kernel_.derivativeOverR(r);
      const Vec3 rel = u - omega.cross(set.position[k]);
      shear += w * rel;
      if (moment) *moment += w * set.position[k].cross(rel);
    }
  });
  return sum;
}

void Boundaries::wallPass(const Fluid& fluid, std::vector<double>& density,
                          std::vector<Vec3>* shear, std::vector<Wrench>* reaction) const {
  const FluidState& st = fluid.state();
  const std::vector<Vec3>& x = st.position;
  const double rho0 = fluid_.rest_density;
  const double mass = fluid.particleMass();
  const bool has_static = !static_.position.empty();
  const std::size_t n = x.size(), nb = bodies_.size();
  const bool with_shear = shear && any_shear_;
  // Without shear (every wall free-slip, or density only) `shear` is left empty.
  if (shear) {
    shear->clear();
    if (with_shear) shear->resize(n);
  }
  if (reaction) reaction->assign(nb, Wrench{});
  bool two_way = false;
  for (const MovingBody& m : moving_)
    two_way = two_way || (with_shear && bodies_[m.body].settings.twoWay());
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  if (two_way) chunk_reaction_.assign(chunks * nb, Wrench{});
  // The pressure sums ride along when the wall terms are asked for (addWallPressure);
  // they need this step's sample pressures.
  const bool with_pressure = reaction != nullptr;
  if (with_pressure) {
    bool ready = static_.p_rho2.size() == static_.position.size();
    for (const MovingBody& m : moving_)
      ready = ready && m.samples.p_rho2.size() == m.samples.position.size();
    if (!ready) throw std::logic_error("Boundaries::addWallTerms before computeSamplePressure");
    chunk_wall_pressure_.resize(chunks);
    chunk_pressure_.resize(chunks);
  }
  const Vec3 zero = Vec3::Zero();
#pragma omp parallel for schedule(static)
  for (std::int64_t c = 0; c < static_cast<std::int64_t>(chunks); ++c) {
    const std::size_t end = std::min(n, (c + 1) * kChunk);
    if (with_pressure) {
      chunk_wall_pressure_[c].clear();
      chunk_pressure_[c].clear();
    }
    for (std::size_t i = c * kChunk; i < end; ++i) {
      const Vec3 xi = x[i], vi = st.velocity[i];
      const double nu = with_shear ? st.kinematic_viscosity[i] : 0.0;
      double sum = 0.0;
      Vec3 a = Vec3::Zero();
      WallPressure wp{static_cast<std::uint32_t>(i), Vec3::Zero(), Vec3::Zero()};
      if (has_static && (static_.near[static_.grid.cellIndex(xi)] & kNearDensity)) {
        Vec3 s = Vec3::Zero();
        PressureSums ps;
        sum += wallSums(static_, xi, nu, vi, zero, s, nullptr, with_pressure ? &ps : nullptr,
                        /*pressure_moments=*/false);
        a -= s;
        wp.grad += ps.grad;
        wp.scaled += ps.scaled;
      }
      if (moving_reach_.contains(xi)) {
        for (const MovingBody& m : moving_) {
          if (!m.world_reach.contains(xi)) continue;
          const Body& b = bodies_[m.body];
          const Mat3 rt = b.rotation.transpose();
          const Vec3 p = rt * (xi - b.settings.pose.position);
          if (!m.samples.reach_box.contains(p)) continue;
          const bool react = nu > 0.0 && b.settings.twoWay();
          Vec3 s = Vec3::Zero(), moment = Vec3::Zero();
          PressureSums ps;
          const bool two_way_body = b.settings.twoWay();
          sum += wallSums(m.samples, p, nu, rt * (vi - b.settings.linear_velocity),
                          rt * b.settings.angular_velocity, s, react ? &moment : nullptr,
                          with_pressure ? &ps : nullptr, two_way_body);
          if (with_pressure && (ps.grad.squaredNorm() > 0.0 || ps.scaled.squaredNorm() > 0.0)) {
            const Mat3& rot = b.rotation;
            wp.grad += rot * ps.grad;
            wp.scaled += rot * ps.scaled;
            if (two_way_body) {
              PressureSums world{rot * ps.grad, rot * ps.scaled, rot * ps.grad_moment,
                                 rot * ps.scaled_moment};
              chunk_pressure_[c].push_back({static_cast<std::uint32_t>(i), m.body, world});
            }
          }
          const Vec3 force = b.rotation * s;  // per unit fluid mass, on the body
          a -= force;
          if (react) {
            Wrench& w = chunk_reaction_[c * nb + m.body];
            w.force += mass * force;
            w.torque += mass * (b.rotation * moment);
          }
        }
      }
      density[i] += rho0 * sum;
      if (with_shear) (*shear)[i] = a;
      // Only particles within reach of a wall are kept (most of the fluid has none). A
      // mirror-symmetric neighbourhood may cancel one sum but not the other: keep both.
      if (with_pressure && (wp.grad.squaredNorm() > 0.0 || wp.scaled.squaredNorm() > 0.0))
        chunk_wall_pressure_[c].push_back(wp);
    }
  }
  if (!two_way) return;
  for (std::size_t c = 0; c < chunks; ++c)
    for (std::size_t b = 0; b < nb; ++b) {
      (*reaction)[b].force += chunk_reaction_[c * nb + b].force;
      (*reaction)[b].torque += chunk_reaction_[c * nb + b].torque;
    }
}

void Boundaries::addWallPressure(const FluidState& st, std::vector<Vec3>& extra,
                                 std::vector<Wrench>& reaction) const {
  const std::size_t n = st.size();
  if (n == 0 || chunk_wall_pressure_.size() != (n + kChunk - 1) / kChunk) return;
  if (extra.empty()) extra.assign(n, Vec3::Zero());
  const double rho0 = fluid_.rest_density;
  const double mass = fluid_.particleMass();
  const std::int64_t chunks = static_cast<std::int64_t>(chunk_wall_pressure_.size());
#pragma omp parallel for schedule(static)
  for (std::int64_t c = 0; c < chunks; ++c)
    for (const WallPressure& e : chunk_wall_pressure_[c]) {
      const std::uint32_t i = e.particle;
      const double pr2 = st.pressure[i] / (st.density[i] * st.density[i]);
      extra[i] -= rho0 * (pr2 * e.grad + e.scaled);
    }
  // Fixed order (chunks, then particles): the same bits on any number of threads.
  for (const std::vector<BodyPressure>& list : chunk_pressure_)
    for (const BodyPressure& e : list) {
      const double pr2 =
          st.pressure[e.particle] / (st.density[e.particle] * st.density[e.particle]);
      const double f = mass * rho0;
      reaction[e.body].force += f * (pr2 * e.sums.grad + e.sums.scaled);
      reaction[e.body].torque += f * (pr2 * e.sums.grad_moment + e.sums.scaled_moment);
    }
}

void Boundaries::computeWallShare(SampleSet& set, bool body_space) const {
  const std::size_t n = set.position.size();
  set.wall_share.assign(n, 0.0);
  const double sp = spacing_, s3 = sp * sp * sp;
  const int reach = static_cast<int>(std::ceil(kernel_.supportRadius() / sp));
  for (std::size_t k = 0; k < n; ++k) {
    const Body& b = bodies_[set.body[k]];
    const Vec3 nk = set.normal[k];
    const Vec3 t1 = (std::abs(nk.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(nk).normalized();
    const Vec3 t2 = nk.cross(t1);
    double fluid = 0.0;
    for (int i = -reach; i <= reach; ++i)
      for (int j = -reach; j <= reach; ++j)
        for (int l = -reach; l <= reach; ++l) {
          const Vec3 off = sp * (i * t1 + j * t2 + l * nk);
          const double w = kernel_.value(off.norm());
          if (w <= 0.0) continue;
          Vec3 p = set.position[k] + off;
          if (!body_space) p = b.rotation.transpose() * (p - b.settings.pose.position);
          if (b.settings.shape->signedDistance(p) >= (1.0 - 1e-6) * radius_) fluid += w;
        }
    set.wall_share[k] = 1.0 - s3 * fluid;
  }
}

void Boundaries::computeSamplePressure(const Fluid& fluid) {
  samplePressure(fluid, static_, Mat3::Identity(), Vec3::Zero());
  for (MovingBody& m : moving_) {
    const Body& b = bodies_[m.body];
    samplePressure(fluid, m.samples, b.rotation, b.settings.pose.position);
  }
}

void Boundaries::samplePressure(const Fluid& fluid, SampleSet& set, const Mat3& rotation,
                                const Vec3& origin) const {
  const std::size_t n = set.position.size();
  set.p_rho2.assign(n, 0.0);
  const FluidState& st = fluid.state();
  if (st.size() == 0 || n == 0) return;
  const UniformGrid& grid = fluid.grid();
  const double m = fluid.particleMass();
  const double rho0 = fluid_.rest_density;
  const double support_sq = kernel_.supportRadius() * kernel_.supportRadius();
  const Aabb reach = grown(fluid.particleBounds(), kernel_.supportRadius());
  const std::int64_t count = static_cast<std::int64_t>(n);
#pragma omp parallel for schedule(static)
  for (std::int64_t k = 0; k < count; ++k) {
    const Vec3 xk = rotation * set.position[k] + origin;
    if (!reach.contains(xk)) continue;
    double sum = 0.0;
    grid.forEachNeighborRange(xk, [&](std::uint32_t lo, std::uint32_t hi) {
      for (std::uint32_t a = lo; a < hi; ++a) {
        const double d_sq = (xk - st.position[a]).squaredNorm();
        if (d_sq < support_sq) sum += kernel_.value(std::sqrt(d_sq));
      }
    });
    if (sum == 0.0) continue;  // no fluid near: no pressure
    const double rho = m * sum + rho0 * set.wall_share[k];
    set.p_rho2[k] = fluid_.pressure(rho) / (rho * rho);
  }
}

template <class F>
void Boundaries::forEachContactCandidate(const SampleSet& set, const Vec3& p, F&& f) const {
  const double reach = radius_ + radius_;  // r_f + r_b
  const double reach_sq = reach * reach;
  set.grid.forEachRangeWithin(p, set.sample_reach, [&](std::uint32_t lo, std::uint32_t hi) {
    for (std::uint32_t k = lo; k < hi; ++k) {
      const double d_sq = (p - set.position[k]).squaredNorm();
      if (d_sq < reach_sq) f(k, d_sq);
    }
  });
}

template <class F>
void Boundaries::forEachSampleNear(const Vec3& x, F&& f) const {
  if (!static_.position.empty() && (static_.near[static_.grid.cellIndex(x)] & kNearContact)) {
    forEachContactCandidate(static_, x, [&](std::uint32_t k, double d_sq) {
      f(static_.body[k], nullptr, static_, k, x, d_sq);
    });
  }
  if (!moving_reach_.contains(x)) return;
  for (const MovingBody& m : moving_) {
    if (!m.world_reach.contains(x)) continue;
    const Body& b = bodies_[m.body];
    const Vec3 p = b.rotation.transpose() * (x - b.settings.pose.position);
    if (!m.samples.reach_box.contains(p)) continue;
    forEachContactCandidate(
        m.samples, p, [&](std::uint32_t k, double d_sq) { f(m.body, &b, m.samples, k, p, d_sq); });
  }
}

std::size_t Boundaries::findContacts(const Vec3& x, std::array<Contact, kMaxContacts>& out) const {
  // A body is in contact when x is closer than the fluid radius to its exact surface: the
  // same test as the position correction and the penetration count, so that velocity
  // control stops fluid before the correction would have to move it (a correction of a
  // particle that control let through does work against the pressure: it pumps energy
  // into the fluid). Sample cells only say where a surface may be near.
  const double rf = radius_;
  std::size_t count = 0;
  auto offer = [&](std::uint32_t body, double d) {
    if (!(d < rf)) return;
    if (count < kMaxContacts) {
      out[count].body = body;
      out[count].distance = d;
      ++count;
      return;
    }
    // More bodies than slots: replace the farthest contact if this one is nearer.
    std::size_t far = 0;
    for (std::size_t q = 1; q < count; ++q)
      if (out[q].distance > out[far].distance) far = q;
    if (d < out[far].distance) out[far].body = body, out[far].distance = d;
  };
  if (!static_.position.empty() && (static_.near[static_.grid.cellIndex(x)] & kNearContact)) {
    for (const std::uint32_t bi : static_bodies_) {
      const Body& b = bodies_[bi];
      if (b.contact_bounds.contains(x))
        offer(bi, b.settings.shape->signedDistance(b.settings.pose.toBody(x)));
    }
  }
  if (moving_reach_.contains(x)) {
    for (const MovingBody& m : moving_) {
      if (!m.world_reach.contains(x)) continue;
      const Body& b = bodies_[m.body];
      const Vec3 p = b.rotation.transpose() * (x - b.settings.pose.position);
      if (!m.samples.reach_box.contains(p) ||
          !(m.samples.near[m.samples.grid.cellIndex(p)] & kNearContact))
        continue;
      offer(m.body, b.settings.shape->signedDistance(p));
    }
  }
  if (count == 0) return 0;
  std::sort(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(count),
            [](const Contact& a, const Contact& b) {
              return a.distance < b.distance || (a.distance == b.distance && a.body < b.body);
            });
  std::size_t kept = 0;
  for (std::size_t c = 0; c < count; ++c)
    if (contactGeometry(x, out[c])) out[kept++] = out[c];
  return kept;
}

std::size_t Boundaries::penaltyTerms(const Vec3& x, double strength,
                                     std::array<PenaltyTerm, kMaxContacts>& out) const {
  const double r0 = radius_ + radius_;
  std::size_t count = 0;
  // x_k and a_k in the set's frame; `to_world` rotates (moving bodies) into the world.
  auto add = [&](std::uint32_t body, const Vec3& xk_world, const Vec3& a_world) {
    std::size_t c = 0;
    while (c < count && out[c].body != body)
      ++c;
    if (c == count) {
      if (count == kMaxContacts) return;  // more bodies than slots: the rest are ignored
      out[count++] = PenaltyTerm{body, Vec3::Zero(), Vec3::Zero()};
    }
    out[c].accel += a_world;
    out[c].moment += xk_world.cross(a_world);
  };
  auto term = [&](const Vec3& p, const Vec3& xk, double d_sq) -> Vec3 {
    if (d_sq <= 0.0) return Vec3::Zero();
    const double q2 = r0 * r0 / d_sq;  // (r0/d)^2
    const double q4 = q2 * q2;
    const double q12 = q4 * q4 * q4;
    return strength * (q12 - q4) / d_sq * (p - xk);
  };
  forEachSampleNear(x, [&](std::uint32_t body, const Body* moving, const SampleSet& set,
                           std::uint32_t k, const Vec3& p, double d_sq) {
    const Vec3& xk = set.position[k];
    if (!moving)
      add(body, xk, term(p, xk, d_sq));
    else
      add(body, moving->rotation * xk + moving->settings.pose.position,
          moving->rotation * term(p, xk, d_sq));
  });
  return count;
}

bool Boundaries::contactGeometry(const Vec3& x, Contact& ct) const {
  // n = grad SDF at x, x_cp = x - SDF(x) n: edges and corners push the fluid the
  // shortest way out.
  const Body& b = bodies_[ct.body];
  const Shape& shape = *b.settings.shape;
  const Vec3 p = b.rotation.transpose() * (x - b.settings.pose.position);
  const double d = ct.distance;
  const Vec3 grad = sdfGradient(shape, p, 1e-3 * radius_);
  if (!grad.isZero() && std::isfinite(d)) {
    ct.normal = b.rotation * grad;
    ct.point = x - d * ct.normal;
    return true;
  }
  // No gradient (x on a medial point, e.g. midway in a slot of the body): the nearest
  // sample's normal and surface point.
  const SampleSet& set = b.moving < 0 ? static_ : moving_[b.moving].samples;
  const Vec3 q = b.moving < 0 ? x : p;
  double best = std::numeric_limits<double>::infinity();
  std::uint32_t nearest = 0;
  set.grid.forEachRangeWithin(q, set.contact_reach, [&](std::uint32_t lo, std::uint32_t hi) {
    for (std::uint32_t k = lo; k < hi; ++k) {
      const double d_sq = (q - set.position[k]).squaredNorm();
      if (set.body[k] == ct.body && (d_sq < best || (d_sq == best && k < nearest)))
        best = d_sq, nearest = k;
    }
  });
  if (!std::isfinite(best)) return false;
  ct.normal = b.rotation * set.normal[nearest];
  ct.point = b.rotation * (set.position[nearest] + radius_ * set.normal[nearest]);
  if (b.moving >= 0) ct.point += b.settings.pose.position;
  return true;
}

void Boundaries::correctPositions(std::vector<Vec3>& x,
                                  const std::vector<std::uint8_t>& candidates) const {
  if (bodies_.empty()) return;
  const std::int64_t n = static_cast<std::int64_t>(x.size());
  const double rf = radius_;
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    if (!candidates[i] && !moving_reach_.contains(x[i])) continue;
    Vec3 xi = x[i];
    std::array<Contact, kMaxContacts> contacts;
    // A few passes over all bodies, then (when a particle is still being pushed, i.e. it
    // is squeezed between bodies closer than its diameter) one pass over static bodies
    // only: a squeezed particle may end inside a moving body, never through a wall.
    bool moved = true;
    for (int pass = 0; pass < 5 && moved; ++pass) {
      const bool static_only = pass == 4;
      const std::size_t count = findContacts(xi, contacts);
      moved = false;
      for (std::size_t c = 0; c < count; ++c) {
        if (static_only && bodies_[contacts[c].body].moving >= 0) continue;
        const double d = rf - (xi - contacts[c].point).dot(contacts[c].normal);
        if (d > 0.0) {
          xi += d * contacts[c].normal;
          moved = true;
        }
      }
    }
    x[i] = xi;
  }
}

std::size_t Boundaries::countInside(const std::vector<Vec3>& x) const {
  const std::int64_t n = static_cast<std::int64_t>(x.size());
  std::size_t inside = 0;
#pragma omp parallel for schedule(static) reduction(+ : inside)
  for (std::int64_t i = 0; i < n; ++i) {
    for (const Body& b : bodies_) {
      if (!b.world_bounds.contains(x[i])) continue;
      if (b.settings.shape->contains(b.settings.pose.toBody(x[i]))) {
        ++inside;
        break;
      }
    }
  }
  return inside;
}

double Boundaries::signedDistance(const Vec3& x) const {
  double best = std::numeric_limits<double>::infinity();
  for (const Body& b : bodies_)
    best = std::min(best, b.settings.shape->signedDistance(b.settings.pose.toBody(x)));
  return best;
}

}  // namespace wake
