// The walls' part of the fluid's sums (Boundaries, coupling/boundary.hpp): the density
// share, the viscous shear (Morris et al. 1997 with the wall's velocity) and the pressure
// force from the samples' extrapolated pressure (Adami, Hu & Adams 2012), each with its
// reaction on two-way bodies, summed in fixed particle chunks (the same bits on any
// number of threads).
#include "coupling/boundary.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace wake {

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
  const double support_sq = kernel_.supportRadius() * kernel_.supportRadius();
  const double rb = radius_;
  const double two_nu = 2.0 * nu;
  double sum = 0.0;
  // One sample's terms.
  const auto one = [&](std::uint32_t k) {
    const Vec3 d = p - set.position[k];
    const double d_sq = d.squaredNorm();
    if (d_sq >= support_sq) return;
    if (record) record->push_back(k);
    const double r = std::sqrt(d_sq);
    sum += set.volume[k] * kernel_.value(r);
    if (!(nu > 0.0)) return;
    const double factor = shear_factor_[set.body[k]];
    if (factor <= 0.0) return;
    // Morris's ghost velocity: the sample lies rb behind the surface, the particle
    // `beyond` in front of it; 1 + rb / beyond, at most 2 (a particle at or inside its
    // radius).
    const double beyond = d.dot(set.normal[k]) - rb;
    const double beta = beyond > rb ? 1.0 + rb / beyond : 2.0;
    const double w = -factor * two_nu * set.volume[k] * beta * kernel_.derivativeOverR(r);
    const Vec3 rel = u - omega.cross(set.position[k]);
    shear += w * rel;
    if (moment) *moment += w * set.position[k].cross(rel);
  };
  if (candidates) {
    for (std::size_t t = 0; t < count; ++t)
      one(candidates[t]);
    return sum;
  }
  // The cells the support's sphere reaches (the same samples pass, in the same order).
  set.grid.forEachRangeInSphere(p, set.density_reach, kernel_.supportRadius(), false,
                                [&](std::uint32_t lo, std::uint32_t hi) {
                                  for (std::uint32_t k = lo; k < hi; ++k)
                                    one(k);
                                });
  return sum;
}

Vec3 Boundaries::pressureSum(const SampleSet& set, const std::vector<double>& p_rho2, const Vec3& p,
                             double pr2, const std::uint32_t* near, std::size_t count,
                             Vec3* moment) const {
  Vec3 sum = Vec3::Zero();
  forEachSampleInSupport(set, p, near, count, [&](std::uint32_t k, const Vec3& d, double dwr) {
    const Vec3 g = ((pr2 + p_rho2[k]) * set.volume[k] * dwr) * d;
    sum += g;
    if (moment) *moment += set.position[k].cross(g);
  });
  return sum;
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
                                 std::vector<Vec3>& extra, std::vector<Wrench>& reaction) const {
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
  if (extra.empty()) extra.assign(n, Vec3::Zero());
  const double rho0 = fluid_.rest_density;
  const double mass = fluid.particleMass();
  bool two_way = false;
  for (const MovingBody& m : moving_)
    two_way = two_way || bodies_[m.body].settings.twoWay();
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  if (two_way) chunk_reaction_.assign(chunks * nb, Wrench{});
#pragma omp parallel for schedule(static)
  for (std::int64_t c = 0; c < static_cast<std::int64_t>(chunks); ++c) {
    const std::size_t end = std::min(n, (c + 1) * kChunk);
    for (std::size_t i = c * kChunk; i < end; ++i) {
      const Vec3 xi = st.position[i];
      const double pr2 = st.pressure[i] / (st.density[i] * st.density[i]);
      Vec3 a = Vec3::Zero();
      // The segments of addWallTerms: the static set first, then the moving bodies.
      pairs.forEachSegment(
          i, c, c * kChunk, [&](std::uint32_t set, const std::uint32_t* near, std::uint32_t count) {
            if (set == 0) {
              a -= pressureSum(static_, p_rho2[0], xi, pr2, near, count, nullptr);
              return;
            }
            const MovingBody& m = moving_[set - 1];
            const BodyFrame& f = at[m.body];
            const Vec3 p = f.rotation.transpose() * (xi - f.pose.position);
            const bool react = bodies_[m.body].settings.twoWay();
            Vec3 moment = Vec3::Zero();
            const Vec3 sum = f.rotation * pressureSum(m.samples, p_rho2[set], p, pr2, near, count,
                                                      react ? &moment : nullptr);
            a -= sum;
            if (react) {
              Wrench& w = chunk_reaction_[c * nb + m.body];
              w.force += (mass * rho0) * sum;
              w.torque += (mass * rho0) * (f.rotation * moment);
            }
          });
      extra[i] += rho0 * a;
    }
  }
  if (!two_way) return;
  // Fixed order (chunks): the same bits on any number of threads.
  for (std::size_t c = 0; c < chunks; ++c)
    for (std::size_t b = 0; b < nb; ++b) {
      reaction[b].force += chunk_reaction_[c * nb + b].force;
      reaction[b].torque += chunk_reaction_[c * nb + b].torque;
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
                                       const Vec3& gravity, WallPairs& pairs,
                                       SamplePressure& out) const {
  if (pairs.particles != fluid.state().size())
    throw std::logic_error("Boundaries::computeSamplePressure before addWallTerms");
  transposePairs(pairs);
  out.p_rho2.resize(moving_.size() + 1);
  samplePressure(fluid, static_, Mat3::Identity(), Vec3::Zero(), gravity, pairs.offset[0],
                 pairs.particle[0], out.p_rho2[0]);
  for (std::size_t m = 0; m < moving_.size(); ++m) {
    const BodyFrame& f = at[moving_[m].body];
    samplePressure(fluid, moving_[m].samples, f.rotation, f.pose.position, gravity,
                   pairs.offset[m + 1], pairs.particle[m + 1], out.p_rho2[m + 1]);
  }
}

void Boundaries::samplePressure(const Fluid& fluid, const SampleSet& set, const Mat3& rotation,
                                const Vec3& origin, const Vec3& gravity,
                                const std::vector<std::uint32_t>& offset,
                                const std::vector<std::uint32_t>& particle,
                                std::vector<double>& p_rho2) const {
  const std::size_t n = set.position.size();
  p_rho2.assign(n, 0.0);
  const FluidState& st = fluid.state();
  if (st.size() == 0 || n == 0) return;
  const double support_sq = kernel_.supportRadius() * kernel_.supportRadius();
  const std::int64_t count = static_cast<std::int64_t>(n);
#pragma omp parallel for schedule(static)
  for (std::int64_t k = 0; k < count; ++k) {
    if (offset[k] == offset[k + 1]) continue;  // no fluid near: no pressure
    const Vec3 xk = rotation * set.position[k] + origin;
    double w_sum = 0.0, p_sum = 0.0;
    Vec3 rise = Vec3::Zero();  // sum_a rho_a (x_k - x_a) W_ka
    for (std::uint32_t t = offset[k]; t < offset[k + 1]; ++t) {
      const std::uint32_t a = particle[t];
      const Vec3 d = xk - st.position[a];
      const double d_sq = d.squaredNorm();
      if (d_sq >= support_sq) continue;
      const double w = kernel_.value(std::sqrt(d_sq));
      w_sum += w;
      p_sum += st.pressure[a] * w;
      rise += (st.density[a] * w) * d;
    }
    if (w_sum == 0.0) continue;
    const double p = std::max(0.0, (p_sum + gravity.dot(rise)) / w_sum);
    if (p == 0.0) continue;
    const double rho = fluid_.densityAt(p);
    p_rho2[k] = p / (rho * rho);
  }
}

}  // namespace wake
