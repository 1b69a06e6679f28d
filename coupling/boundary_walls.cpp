// The walls' part of the fluid's sums (Boundaries, coupling/boundary.hpp): the density
// share, the viscous shear (Morris et al. 1997 with the wall's velocity) and the pressure
// force from the samples' extrapolated pressure (Adami, Hu & Adams 2012), each with its
// reaction on two-way bodies, summed in fixed particle chunks (the same bits on any
// number of threads).
#include "coupling/boundary.hpp"

#include <omp.h>

#include "sph/lanes.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iterator>
#include <stdexcept>

namespace wake {

namespace {

/// What the walls' sums of one particle read (Boundaries::wallSums).
struct WallSumsIn {
  const Vec3* position;
  const Vec3* normal;
  const double* volume;
  const std::uint32_t* body;
  const double* shear_factor;  ///< per body
  const CubicSplineKernel* kernel;
  double support_sq, rb, two_nu, nu;
  Vec3 p, u, omega;
};

/// Whether a lane of a stored mask is set.
inline bool laneSet(double mask) {
  std::uint64_t bits;
  std::memcpy(&bits, &mask, sizeof bits);
  return bits != 0;
}

/// The positions of a group of samples (or particles) j, several at a time, and p's
/// offsets from them.
template <class M>
struct GroupOffsets {
  M x, y, z, dx, dy, dz, d_sq;
};
template <class M>
inline GroupOffsets<M> offsetsFrom(const Vec3& p, const Vec3* position, const std::uint32_t* j) {
  const double* at[M::kWidth];
  for (int t = 0; t < M::kWidth; ++t)
    at[t] = position[j[t]].data();
  GroupOffsets<M> o;
  gather3Lanes(at, o.x, o.y, o.z);
  o.dx = M::all(p.x()) - o.x;
  o.dy = M::all(p.y()) - o.y;
  o.dz = M::all(p.z()) - o.z;
  o.d_sq = o.dx * o.dx + o.dy * o.dy + o.dz * o.dz;
  return o;
}

/// The walls' sums over the samples idx[0 .. count), several samples at a time: per
/// sample the operations of Boundaries::wallSums' one sample at a time (the kernel without
/// branches), its terms added to sum, shear and moment in the samples' order, so the same
/// bits. Returns the sum.
template <class L>
inline double wallTerms(const WallSumsIn& in, const std::uint32_t* idx, std::size_t count,
                        double sum, Vec3& shear, Vec3* moment, std::vector<std::uint32_t>* record) {
  // The sums in registers (not through the references: a store and a load per term).
  double sx = shear.x(), sy = shear.y(), sz = shear.z();
  double mx = 0.0, my = 0.0, mz = 0.0;
  if (moment) mx = moment->x(), my = moment->y(), mz = moment->z();
  forEachNeighborGroup<L>(idx, 0, count, [&](auto lanes, const std::uint32_t* j, int used) {
    using M = decltype(lanes);
    constexpr int kW = M::kWidth;
    const GroupOffsets<M> o = offsetsFrom<M>(in.p, in.position, j);
    const M &xk = o.x, &yk = o.y, &zk = o.z, &dx = o.dx, &dy = o.dy, &dz = o.dz, &d_sq = o.d_sq;
    const M r = sqrt(d_sq);
    const M volume = gatherLanes(lanes, in.volume, j);
    alignas(32) double far[kW], term[kW];
    (d_sq >= M::all(in.support_sq)).store(far);
    (volume * in.kernel->value(r)).store(term);
    if (!(in.nu > 0.0)) {
      for (int t = 0; t < used; ++t) {
        if (laneSet(far[t])) continue;
        if (record) record->push_back(j[t]);
        sum += term[t];
      }
      return;
    }
    // Morris's ghost velocity: the sample lies rb behind the surface, the particle
    // `beyond` in front of it; 1 + rb / beyond, at most 2.
    alignas(32) double factor[kW];
    for (int t = 0; t < kW; ++t)
      factor[t] = in.shear_factor[in.body[j[t]]];
    const double* at[kW];
    for (int t = 0; t < kW; ++t)
      at[t] = in.normal[j[t]].data();
    M nx, ny, nz;
    gather3Lanes(at, nx, ny, nz);
    const M rb = M::all(in.rb);
    const M beyond = (dx * nx + dy * ny + dz * nz) - rb;
    const M beta = select(rb < beyond, M::all(1.0) + rb / beyond, M::all(2.0));
    const M w =
        -M::load(factor) * M::all(in.two_nu) * volume * beta * in.kernel->derivativeOverR(r);
    const M ox = M::all(in.omega.x()), oy = M::all(in.omega.y()), oz = M::all(in.omega.z());
    const M rx = M::all(in.u.x()) - (oy * zk - oz * yk);
    const M ry = M::all(in.u.y()) - (oz * xk - ox * zk);
    const M rz = M::all(in.u.z()) - (ox * yk - oy * xk);
    alignas(32) double s[3][kW], m[3][kW];
    (w * rx).store(s[0]);
    (w * ry).store(s[1]);
    (w * rz).store(s[2]);
    if (moment) {
      (w * (yk * rz - zk * ry)).store(m[0]);
      (w * (zk * rx - xk * rz)).store(m[1]);
      (w * (xk * ry - yk * rx)).store(m[2]);
    }
    for (int t = 0; t < used; ++t) {
      if (laneSet(far[t])) continue;
      if (record) record->push_back(j[t]);
      sum += term[t];
      if (factor[t] <= 0.0) continue;
      sx += s[0][t];
      sy += s[1][t];
      sz += s[2][t];
      if (!moment) continue;
      mx += m[0][t];
      my += m[1][t];
      mz += m[2][t];
    }
  });
  shear = Vec3(sx, sy, sz);
  if (moment) *moment = Vec3(mx, my, mz);
  return sum;
}

/// Boundaries::pressureSum over the samples near[0 .. count) of one set, several at a time:
/// per sample the operations of one at a time, its terms added in the samples' order (the
/// same bits). position, volume, p_rho2: the set's.
template <class L>
inline Vec3 pressureTerms(const Vec3* position, const double* volume, const double* p_rho2,
                          const CubicSplineKernel& kernel, double support_sq, const Vec3& p,
                          double pr2, const std::uint32_t* near, std::size_t count) {
  double sx = 0.0, sy = 0.0, sz = 0.0;
  forEachNeighborGroup<L>(near, 0, count, [&](auto lanes, const std::uint32_t* j, int used) {
    using M = decltype(lanes);
    constexpr int kW = M::kWidth;
    const GroupOffsets<M> o = offsetsFrom<M>(p, position, j);
    const M c = (M::all(pr2) + gatherLanes(lanes, p_rho2, j)) * gatherLanes(lanes, volume, j) *
                kernel.derivativeOverR(sqrt(o.d_sq));
    alignas(32) double far[kW], g[3][kW];
    (o.d_sq >= M::all(support_sq)).store(far);
    (c * o.dx).store(g[0]);
    (c * o.dy).store(g[1]);
    (c * o.dz).store(g[2]);
    for (int t = 0; t < used; ++t) {
      if (laneSet(far[t])) continue;
      sx += g[0][t];
      sy += g[1][t];
      sz += g[2][t];
    }
  });
  return Vec3(sx, sy, sz);
}

Vec3 pressureTerms2(const Vec3* position, const double* volume, const double* p_rho2,
                    const CubicSplineKernel& kernel, double support_sq, const Vec3& p, double pr2,
                    const std::uint32_t* near, std::size_t count) {
  return pressureTerms<Lanes2>(position, volume, p_rho2, kernel, support_sq, p, pr2, near, count);
}
#if defined(WAKE_HAS_LANES4)
WAKE_TARGET_AVX Vec3 pressureTerms4(const Vec3* position, const double* volume,
                                    const double* p_rho2, const CubicSplineKernel& kernel,
                                    double support_sq, const Vec3& p, double pr2,
                                    const std::uint32_t* near, std::size_t count) {
  return pressureTerms<Lanes4>(position, volume, p_rho2, kernel, support_sq, p, pr2, near, count);
}
#endif

/// The sums of one sample's pressure (Boundaries::samplePressure) over its particles
/// particle[0 .. count), several at a time: sum W, sum P W and sum rho W (x_k - x_a), each
/// particle's terms added in the list's order (the same bits as one at a time).
struct SampleSums {
  double w = 0.0, p = 0.0;
  Vec3 rise = Vec3::Zero();
};
template <class L>
inline SampleSums sampleTerms(const FluidState& st, const double* pressure,
                              const CubicSplineKernel& kernel, double support_sq, const Vec3& xk,
                              const std::uint32_t* particle, std::size_t count) {
  double w_sum = 0.0, p_sum = 0.0, rx = 0.0, ry = 0.0, rz = 0.0;
  forEachNeighborGroup<L>(particle, 0, count, [&](auto lanes, const std::uint32_t* j, int used) {
    using M = decltype(lanes);
    constexpr int kW = M::kWidth;
    const GroupOffsets<M> o = offsetsFrom<M>(xk, st.position.data(), j);
    const M &dx = o.dx, &dy = o.dy, &dz = o.dz, &d_sq = o.d_sq;
    const M w = kernel.value(sqrt(d_sq));
    const M rho_w = gatherLanes(lanes, st.density.data(), j) * w;
    alignas(32) double far[kW], ws[kW], pw[kW], r[3][kW];
    (d_sq >= M::all(support_sq)).store(far);
    w.store(ws);
    (gatherLanes(lanes, pressure, j) * w).store(pw);
    (rho_w * dx).store(r[0]);
    (rho_w * dy).store(r[1]);
    (rho_w * dz).store(r[2]);
    for (int t = 0; t < used; ++t) {
      if (laneSet(far[t])) continue;
      w_sum += ws[t];
      p_sum += pw[t];
      rx += r[0][t];
      ry += r[1][t];
      rz += r[2][t];
    }
  });
  return {w_sum, p_sum, Vec3(rx, ry, rz)};
}

SampleSums sampleTerms2(const FluidState& st, const double* pressure,
                        const CubicSplineKernel& kernel, double support_sq, const Vec3& xk,
                        const std::uint32_t* particle, std::size_t count) {
  return sampleTerms<Lanes2>(st, pressure, kernel, support_sq, xk, particle, count);
}
#if defined(WAKE_HAS_LANES4)
WAKE_TARGET_AVX SampleSums sampleTerms4(const FluidState& st, const double* pressure,
                                        const CubicSplineKernel& kernel, double support_sq,
                                        const Vec3& xk, const std::uint32_t* particle,
                                        std::size_t count) {
  return sampleTerms<Lanes4>(st, pressure, kernel, support_sq, xk, particle, count);
}
#endif

double wallTerms2(const WallSumsIn& in, const std::uint32_t* idx, std::size_t count, double sum,
                  Vec3& shear, Vec3* moment, std::vector<std::uint32_t>* record) {
  return wallTerms<Lanes2>(in, idx, count, sum, shear, moment, record);
}
#if defined(WAKE_HAS_LANES4)
WAKE_TARGET_AVX double wallTerms4(const WallSumsIn& in, const std::uint32_t* idx, std::size_t count,
                                  double sum, Vec3& shear, Vec3* moment,
                                  std::vector<std::uint32_t>* record) {
  return wallTerms<Lanes4>(in, idx, count, sum, shear, moment, record);
}
#endif

}  // namespace

void Boundaries::addDensity(const Fluid& fluid, const BodyPlacement& at,
                            std::vector<double>& density) const {
  wallPass(fluid, at, density, nullptr, nullptr, nullptr);
}

void Boundaries::addWallTerms(const Fluid& fluid, const BodyPlacement& at,
                              std::vector<double>& density, std::vector<Vec3>& shear,
                              std::vector<Wrench>& reaction, WallPairs& pairs) const {
  wallPass(fluid, at, density, &shear, &reaction, &pairs);
}

void Boundaries::prepareWallCandidates(const Fluid& fluid) {
  WallCandidates& c = wall_candidates_;
  const double skin = fluid.neighborSkin();
  const std::vector<Vec3f>& x = fluid.neighborReference();
  const std::size_t n = x.size();
  // A sample within the support of a particle now is within support + skin / 2 of where
  // it was (it has moved less than skin / 2); a hair more for rounding.
  const double radius = (kernel_.supportRadius() + 0.5 * skin) * (1.0 + 1e-9);
  // Beyond the static grid's box no sample is within (kStaticMargin + 1) supports: a
  // larger radius (a skin over 4 supports) searches instead.
  if (!(skin > 0.0) || static_.position.empty() || n != fluid.state().size() ||
      !(radius <= (kStaticMargin + 1.0) * kernel_.supportRadius())) {
    c.fluid = nullptr;
    return;
  }
  if (c.fluid == &fluid && c.build == fluid.neighborGeneration() && c.offset.size() == n + 1)
    return;
  const double radius_sq = radius * radius;
  const int reach =
      std::max(1, static_cast<int>(std::ceil(radius / static_.grid.cellSize() - 1e-12)));
  // The cells from which a sample may be within the radius (most particles are far from
  // every wall: one bit read instead of a search).
  if (c.reach != reach) {
    for (std::uint8_t& f : static_.near)
      f &= static_cast<std::uint8_t>(~kNearCandidates);
    markNear(static_, reach, kNearCandidates, static_.near);
    c.reach = reach;
  }
  const std::int64_t sn = static_cast<std::int64_t>(n);
  auto each = [&](std::size_t i, auto&& f) {
    const Vec3 xi = x[i].cast<double>();
    if (!nearStatic(xi, kNearCandidates)) return;
    static_.grid.forEachRangeInSphere(xi, reach, radius, false,
                                      [&](std::uint32_t lo, std::uint32_t hi) {
                                        for (std::uint32_t k = lo; k < hi; ++k)
                                          if ((xi - static_.position[k]).squaredNorm() < radius_sq)
                                            f(k);
                                      });
  };
  c.offset.resize(n + 1);
  std::uint32_t* counts = c.offset.counts();
  counts[n] = 0;
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < sn; ++i) {
    std::uint32_t count = 0;
    each(static_cast<std::size_t>(i), [&](std::uint32_t) { ++count; });
    counts[i] = count;
  }
  c.index.resize(c.offset.startsFromCounts());
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < sn; ++i) {
    std::uint32_t* out = c.index.data() + c.offset[i];
    each(static_cast<std::size_t>(i), [&](std::uint32_t k) { *out++ = k; });
  }
  c.fluid = &fluid;
  c.build = fluid.neighborGeneration();
}

std::pair<const std::uint32_t*, std::size_t> Boundaries::staticCandidates(const Fluid& fluid,
                                                                          std::size_t i) const {
  const WallCandidates& c = wall_candidates_;
  if (c.fluid != &fluid || c.build != fluid.neighborGeneration() ||
      c.offset.size() != fluid.state().size() + 1)
    return {nullptr, 0};
  return {c.index.data() + c.offset[i], static_cast<std::size_t>(c.offset[i + 1] - c.offset[i])};
}

double Boundaries::wallSums(const SampleSet& set, const Vec3& p, double nu, const Vec3& u,
                            const Vec3& omega, Vec3& shear, Vec3* moment,
                            std::vector<std::uint32_t>* record, const std::uint32_t* candidates,
                            std::size_t count) const {
  const double support = kernel_.supportRadius();
  const WallSumsIn in{set.position.data(),
                      set.normal.data(),
                      set.volume.data(),
                      set.body.data(),
                      shear_factor_.data(),
                      &kernel_,
                      support * support,
                      radius_,
                      2.0 * nu,
                      nu,
                      p,
                      u,
                      omega};
  auto terms = wallTerms2;
#if defined(WAKE_HAS_LANES4)
  if (wide_lanes_) terms = wallTerms4;
#endif
  if (candidates) return terms(in, candidates, count, 0.0, shear, moment, record);
  // The cells the support's sphere reaches (the same samples pass, in the same order), a
  // batch of samples at a time.
  double sum = 0.0;
  std::uint32_t batch[64];
  std::size_t used = 0;
  set.grid.forEachRangeInSphere(p, set.density_reach, support, false,
                                [&](std::uint32_t lo, std::uint32_t hi) {
                                  for (std::uint32_t k = lo; k < hi; ++k) {
                                    batch[used++] = k;
                                    if (used < std::size(batch)) continue;
                                    sum = terms(in, batch, used, sum, shear, moment, record);
                                    used = 0;
                                  }
                                });
  return used ? terms(in, batch, used, sum, shear, moment, record) : sum;
}

Vec3 Boundaries::pressureSum(const SampleSet& set, const std::vector<double>& p_rho2, const Vec3& p,
                             double pr2, const std::uint32_t* near, std::size_t count) const {
  auto terms = pressureTerms2;
#if defined(WAKE_HAS_LANES4)
  if (wide_lanes_) terms = pressureTerms4;
#endif
  const double support = kernel_.supportRadius();
  return terms(set.position.data(), set.volume.data(), p_rho2.data(), kernel_, support * support, p,
               pr2, near, count);
}

void Boundaries::wallPass(const Fluid& fluid, const BodyPlacement& at, std::vector<double>& density,
                          std::vector<Vec3>* shear, std::vector<Wrench>* reaction,
                          WallPairs* pairs) const {
  const FluidState& st = fluid.state();
  const std::vector<Vec3>& x = st.position;
  const double rho0 = fluid_.rest_density;
  const double mass = fluid.particleMass();
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
  if (pairs) {
    if (pairs->chunk.size() < chunks) pairs->chunk.resize(chunks);
    pairs->end.resize(n);
    pairs->particles = n;
  }
  const Vec3 zero = Vec3::Zero();
#pragma omp parallel for schedule(static)
  for (std::int64_t c = 0; c < static_cast<std::int64_t>(chunks); ++c) {
    const std::size_t end = std::min(n, (c + 1) * kChunk);
    // The pairs: a segment (set number, count, samples) per set with samples near.
    std::vector<std::uint32_t>* record = pairs ? &pairs->chunk[c] : nullptr;
    if (record) record->clear();
    std::size_t head = 0;
    auto open = [&](std::uint32_t set) {
      if (!record) return;
      record->push_back(set);
      head = record->size();
      record->push_back(0);
    };
    auto close = [&] {
      if (!record) return;
      const std::size_t count = record->size() - head - 1;
      if (count == 0)
        record->resize(head - 1);
      else
        (*record)[head] = static_cast<std::uint32_t>(count);
    };
    for (std::size_t i = c * kChunk; i < end; ++i) {
      const Vec3 xi = x[i], vi = st.velocity[i];
      const double nu = with_shear ? st.kinematic_viscosity[i] : 0.0;
      double sum = 0.0;
      Vec3 a = Vec3::Zero();
      const auto [candidates, count] = staticCandidates(fluid, i);
      if (candidates ? count > 0 : nearStatic(xi, kNearDensity)) {
        Vec3 s = Vec3::Zero();
        open(0);
        sum += wallSums(static_, xi, nu, vi, zero, s, nullptr, record, candidates, count);
        close();
        a -= s;
      }
      at.forEachMovingNear(xi, [&](std::size_t mi) {
        const MovingBody& m = moving_[mi];
        const BodyFrame& f = at[m.body];
        if (!f.world_reach.contains(xi)) return true;
        const std::uint32_t set = static_cast<std::uint32_t>(mi) + 1;
        const Mat3 rt = f.rotation.transpose();
        const Vec3 p = rt * (xi - f.pose.position);
        if (!m.samples.reach_box.contains(p)) return true;
        const bool react = nu > 0.0 && bodies_[m.body].settings.twoWay();
        Vec3 s = Vec3::Zero(), moment = Vec3::Zero();
        open(set);
        sum += wallSums(m.samples, p, nu, rt * (vi - f.linear_velocity), rt * f.angular_velocity, s,
                        react ? &moment : nullptr, record);
        close();
        const Vec3 force = f.rotation * s;  // per unit fluid mass, on the body
        a -= force;
        if (react) {
          Wrench& w = chunk_reaction_[c * nb + m.body];
          w.force += mass * force;
          w.torque += mass * (f.rotation * moment);
        }
        return true;
      });
      density[i] += rho0 * sum;
      if (with_shear) (*shear)[i] = a;
      if (record) pairs->end[i] = static_cast<std::uint32_t>(record->size());
    }
  }
  if (!two_way) return;
  for (std::size_t c = 0; c < chunks; ++c)
    for (std::size_t b = 0; b < nb; ++b) {
      (*reaction)[b].force += chunk_reaction_[c * nb + b].force;
      (*reaction)[b].torque += chunk_reaction_[c * nb + b].torque;
    }
}

void Boundaries::addWallPressure(const Fluid& fluid, const BodyPlacement& at,
                                 const WallPairs& pairs, const SamplePressure& pressure,
                                 std::vector<Vec3>& extra, WallPressureSums& sums) const {
  const FluidState& st = fluid.state();
  const std::size_t n = st.size(), nb = bodies_.size();
  if (n == 0 || nb == 0) return;
  const std::vector<std::vector<double>>& p_rho2 = pressure.p_rho2;
  bool ready = p_rho2.size() == moving_.size() + 1 && p_rho2[0].size() == static_.position.size();
  for (std::size_t m = 0; m < moving_.size() && ready; ++m)
    ready = p_rho2[m + 1].size() == moving_[m].samples.position.size();
  if (!ready) throw std::logic_error("Boundaries::addWallPressure before computeSamplePressure");
  if (pairs.particles != n)
    throw std::logic_error("Boundaries::addWallPressure before addWallTerms");
  const std::int64_t sn = static_cast<std::int64_t>(n);
  if (fluid.params().pressure_gradient == PressureGradient::Consistent) {
    if (sums.difference.size() != n || sums.moment.size() != n || sums.spread.size() != n ||
        sums.reference.size() != n || pressure.pressure.size() != p_rho2.size())
      throw std::logic_error("Boundaries::addWallPressure: the pressure sums are not this step's");
    if (sums.symmetric.size() != n)
      throw std::logic_error("Boundaries::addWallPressure: the pressure sums are not this step's");
#pragma omp parallel for schedule(static)
    for (std::int64_t i = 0; i < sn; ++i)
      consistentWallSums(fluid, at, pairs, pressure, static_cast<std::size_t>(i), sums);
    return;
  }
  if (extra.empty()) extra.assign(n, Vec3::Zero());
  const double rho0 = fluid_.rest_density;
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < sn; ++i) {
    const std::size_t c = static_cast<std::size_t>(i) / kChunk;
    const Vec3 xi = st.position[i];
    const double pr2 = st.pressure[i] / (st.density[i] * st.density[i]);
    Vec3 a = Vec3::Zero();
    // The segments of addWallTerms: the static set first, then the moving bodies.
    pairs.forEachSegment(
        i, c, c * kChunk, [&](std::uint32_t set, const std::uint32_t* near, std::uint32_t count) {
          if (set == 0) {
            a -= pressureSum(static_, p_rho2[0], xi, pr2, near, count);
            return;
          }
          const MovingBody& m = moving_[set - 1];
          const BodyFrame& f = at[m.body];
          const Vec3 p = f.rotation.transpose() * (xi - f.pose.position);
          a -= f.rotation * pressureSum(m.samples, p_rho2[set], p, pr2, near, count);
        });
    extra[i] += rho0 * a;
  }
}

void Boundaries::consistentWallSums(const Fluid& fluid, const BodyPlacement& at,
                                    const WallPairs& pairs, const SamplePressure& pressure,
                                    std::size_t i, WallPressureSums& sums) const {
  const FluidState& st = fluid.state();
  const std::size_t c = i / kChunk;
  const Vec3 xi = st.position[i];
  const double pa = st.pressure[i];
  const double ra2 = 1.0 / (st.density[i] * st.density[i]);
  const double rho0 = fluid_.rest_density;
  const double support = kernel_.supportRadius();
  const double rest2 = 1.0 / (rho0 * rho0);  // 1 / rho_k^2 of a sample at P = 0
  const bool moments = sums.moments;
  Vec3 g = Vec3::Zero(), e = Vec3::Zero(), sym = Vec3::Zero();
  Mat3 b = Mat3::Zero();
  double ref = sums.reference[i];
  const double pa2 = pa * ra2;
  // The segments of addWallTerms: the static set first, then the moving bodies; each
  // sample's terms in the set's frame, turned into the world's.
  pairs.forEachSegment(i, c, c * kChunk,
                       [&](std::uint32_t set, const std::uint32_t* near, std::uint32_t count) {
                         const SampleSet& samples = set == 0 ? static_ : moving_[set - 1].samples;
                         const std::vector<double>& pk = pressure.pressure[set];
                         const std::vector<double>& pr2 = pressure.p_rho2[set];
                         Vec3 xs = xi;
                         Mat3 rotation = Mat3::Identity();
                         if (set != 0) {
                           const BodyFrame& f = at[moving_[set - 1].body];
                           rotation = f.rotation;
                           xs = f.rotation.transpose() * (xi - f.pose.position);
                         }
                         Vec3 gs = Vec3::Zero(), es = Vec3::Zero(), ss = Vec3::Zero();
                         Mat3 bs = Mat3::Zero();
                         for (std::uint32_t t = 0; t < count; ++t) {
                           const std::uint32_t k = near[t];
                           const Vec3 d = xs - samples.position[k];  // x_a - x_k
                           const double dist = d.norm();
                           if (!(dist < support) || dist == 0.0) continue;
                           const double w = kernel_.derivativeOverR(dist);  // grad_a W_ak = w d
                           const double v = samples.volume[k];
                           const double rk2 = pk[k] > 0.0 ? pr2[k] / pk[k] : rest2;
                           ref = std::min(ref, pk[k]);
                           gs += (v * (pk[k] - pa) * w) * d;
                           if (moments) bs.noalias() -= (v * w) * d * d.transpose();
                           es += (rho0 * v * (ra2 + rk2) * w) * d;
                           ss += (rho0 * v * (pa2 + pr2[k]) * w) * d;
                         }
                         g += rotation * gs;
                         e += rotation * es;
                         sym -= rotation * ss;
                         if (moments) b += rotation * bs * rotation.transpose();
                       });
  sums.reference[i] = ref;
  sums.difference[i] += g;
  sums.spread[i] += e;
  sums.symmetric[i] += sym;
  if (!moments) return;  // kept from the last evaluation on these positions
  std::array<double, 6>& m = sums.moment[i];
  m[0] += b(0, 0);
  m[1] += b(1, 1);
  m[2] += b(2, 2);
  m[3] += b(0, 1);
  m[4] += b(0, 2);
  m[5] += b(1, 2);
}

void Boundaries::addBodyPressure(const BodyPlacement& at, const SamplePressure& pressure,
                                 std::vector<Wrench>& reaction, bool touching_only) const {
  for (std::size_t m = 0; m < moving_.size(); ++m) {
    const MovingBody& mb = moving_[m];
    if (!bodies_[mb.body].settings.twoWay()) continue;
    const SampleSet& set = mb.samples;
    const std::vector<double>& force = pressure.surface_force[m + 1];
    if (force.size() != set.position.size())
      throw std::logic_error("Boundaries::addBodyPressure before computeSamplePressure");
    // In body space, in the samples' (fixed) order: the same bits on any number of threads.
    Vec3 f = Vec3::Zero(), torque = Vec3::Zero();
    for (std::size_t k = 0; k < set.position.size(); ++k) {
      if (force[k] == 0.0) continue;  // dry: no fluid near, no contact
      if (touching_only && !pressure.touching[m + 1][k]) continue;  // the solver's share
      const Vec3& n = set.normal[k];
      const Vec3 df = -force[k] * n;
      f += df;
      torque += (set.position[k] + radius_ * n).cross(df);
    }
    const BodyFrame& frame = at[mb.body];
    reaction[mb.body].force += frame.rotation * f;
    reaction[mb.body].torque += frame.rotation * torque;
  }
}

void Boundaries::transposePairs(WallPairs& pairs) const {
  const std::size_t sets = moving_.size() + 1, n = pairs.particles;
  pairs.offset.resize(sets);
  pairs.particle.resize(sets);
  for (std::size_t s = 0; s < sets; ++s)
    pairs.offset[s].assign((s == 0 ? static_ : moving_[s - 1].samples).position.size() + 1, 0u);
  // Visits every pair in particle order.
  auto for_each_pair = [&](auto&& f) {
    for (std::size_t i = 0; i < n; ++i)
      pairs.forEachSegment(i, i / kChunk, i / kChunk * kChunk,
                           [&](std::uint32_t set, const std::uint32_t* near, std::uint32_t count) {
                             for (std::uint32_t t = 0; t < count; ++t)
                               f(set, near[t], static_cast<std::uint32_t>(i));
                           });
  };
  for_each_pair([&](std::uint32_t s, std::uint32_t k, std::uint32_t) { ++pairs.offset[s][k + 1]; });
  for (std::size_t s = 0; s < sets; ++s) {
    std::vector<std::uint32_t>& off = pairs.offset[s];
    for (std::size_t k = 1; k < off.size(); ++k)
      off[k] += off[k - 1];
    pairs.particle[s].resize(off.back());
  }
  // offset[k] serves as sample k's cursor, then is restored.
  for_each_pair([&](std::uint32_t s, std::uint32_t k, std::uint32_t i) {
    pairs.particle[s][pairs.offset[s][k]++] = i;
  });
  for (std::size_t s = 0; s < sets; ++s) {
    std::vector<std::uint32_t>& off = pairs.offset[s];
    for (std::size_t k = off.size() - 1; k > 0; --k)
      off[k] = off[k - 1];
    off[0] = 0;
  }
}

void Boundaries::computeSamplePressure(const Fluid& fluid, const BodyPlacement& at,
                                       const Vec3& gravity, WallPairs& pairs, SamplePressure& out,
                                       bool two_way_only) const {
  if (pairs.particles != fluid.state().size())
    throw std::logic_error("Boundaries::computeSamplePressure before addWallTerms");
  transposePairs(pairs);
  const FluidState& st = fluid.state();
  const std::vector<double>& pressure =
      two_way_only && st.keepsPressureMean() ? st.pressure_mean : st.pressure;
  out.p_rho2.resize(moving_.size() + 1);
  out.pressure.resize(moving_.size() + 1);
  out.surface_force.resize(moving_.size() + 1);
  out.wet.resize(moving_.size() + 1);
  if (two_way_only) {
    out.p_rho2[0].clear();
    out.pressure[0].clear();
    out.surface_force[0].clear();
    out.wet[0].clear();
  } else {
    samplePressure(fluid, pressure, static_, Mat3::Identity(), Vec3::Zero(), gravity, false,
                   pairs.offset[0], pairs.particle[0], out.p_rho2[0], out.pressure[0],
                   out.surface_force[0], out.wet[0]);
  }
  for (std::size_t m = 0; m < moving_.size(); ++m) {
    const BodyFrame& f = at[moving_[m].body];
    const bool two_way = bodies_[moving_[m].body].settings.twoWay();
    if (two_way_only && !two_way) {
      out.p_rho2[m + 1].clear();
      out.pressure[m + 1].clear();
      out.surface_force[m + 1].clear();
      out.wet[m + 1].clear();
      continue;
    }
    samplePressure(fluid, pressure, moving_[m].samples, f.rotation, f.pose.position, gravity,
                   two_way, pairs.offset[m + 1], pairs.particle[m + 1], out.p_rho2[m + 1],
                   out.pressure[m + 1], out.surface_force[m + 1], out.wet[m + 1]);
  }
}

void Boundaries::samplePressure(const Fluid& fluid, const std::vector<double>& pressure,
                                const SampleSet& set, const Mat3& rotation, const Vec3& origin,
                                const Vec3& gravity, bool two_way,
                                const std::vector<std::uint32_t>& offset,
                                const std::vector<std::uint32_t>& particle,
                                std::vector<double>& p_rho2, std::vector<double>& p_out,
                                std::vector<double>& force, std::vector<std::uint8_t>& wet) const {
  const std::size_t n = set.position.size();
  p_rho2.assign(n, 0.0);
  p_out.assign(n, 0.0);
  force.assign(two_way ? n : 0, 0.0);
  wet.assign(two_way ? n : 0, 0);
  const FluidState& st = fluid.state();
  if (st.size() == 0 || n == 0) return;
  const double* pressure_of = pressure.data();
  const double support_sq = kernel_.supportRadius() * kernel_.supportRadius();
  const std::int64_t count = static_cast<std::int64_t>(n);
  auto terms = sampleTerms2;
#if defined(WAKE_HAS_LANES4)
  if (wide_lanes_) terms = sampleTerms4;
#endif
#pragma omp parallel
  {
    std::vector<std::uint32_t> front;  // a two-way sample's particles in front of its face
#pragma omp for schedule(static)
    for (std::int64_t k = 0; k < count; ++k) {
      if (offset[k] == offset[k + 1]) continue;  // no fluid near: no pressure
      const Vec3 xk = rotation * set.position[k] + origin;
      const std::uint32_t* near = particle.data() + offset[k];
      const std::size_t near_count = offset[k + 1] - offset[k];
      // sum_a W_ka, sum_a P_a W_ka and sum_a rho_a (x_k - x_a) W_ka
      const SampleSums sums = terms(st, pressure_of, kernel_, support_sq, xk, near, near_count);
      const double w_sum = sums.w;
      if (w_sum == 0.0) continue;
      const double p = std::max(0.0, (sums.p + gravity.dot(sums.rise)) / w_sum);
      if (p > 0.0) {
        const double rho = fluid_.densityAt(p);
        p_rho2[k] = p / (rho * rho);
        p_out[k] = p;
      }
      if (!two_way) continue;
      // The surface element force P^s_k A_k (addBodyPressure): the same estimate from the
      // fluid in front of the face only, as a thin wall's sample has the fluid of the other
      // side within its support too. The sample lies r_b below the surface, so the fluid on
      // its side is at d.n > r_b on a flat face and a little less beside a convex one; what
      // lies more than r_b behind it is the other side's. Then carried from the sample up
      // to the surface point.
      // Where every particle is in front (all but thin walls), those are the sums above.
      const Vec3 normal = rotation * set.normal[k];
      front.clear();
      for (std::size_t t = 0; t < near_count; ++t)
        if ((st.position[near[t]] - xk).dot(normal) > -radius_) front.push_back(near[t]);
      const SampleSums face =
          front.size() == near_count
              ? sums
              : terms(st, pressure_of, kernel_, support_sq, xk, front.data(), front.size());
      if (!(face.w > 0.0)) continue;
      wet[k] = 1;
      const double ps = (face.p + gravity.dot(face.rise)) / face.w +
                        fluid_.rest_density * radius_ * gravity.dot(normal);
      force[k] = std::max(0.0, ps) * set.area[k];
    }
  }
}

}  // namespace wake
