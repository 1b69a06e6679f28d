// The walls' and bodies' part of the divergence-free solver (Boundaries, coupling/boundary.hpp;
// sph/dfsph.hpp): the samples' share of each particle's density gradient and of its rate of
// change of density, and the solver's pressure force on two-way bodies.
#include "coupling/boundary.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace wake {

Vec3 Boundaries::gradientSum(const SampleSet& set, const Vec3& p, const std::uint32_t* near,
                             std::size_t count, const Vec3& u, const Vec3& omega,
                             const GradientExtras& extras) const {
  Vec3 sum = Vec3::Zero();
  forEachSampleInSupport(set, p, near, count, [&](std::uint32_t k, const Vec3& d, double dwr) {
    const Vec3 g = (set.volume[k] * dwr) * d;
    sum += g;
    if (extras.within) ++*extras.within;
    if (extras.flux) *extras.flux += (u + omega.cross(set.position[k])).dot(g);
    if (extras.moment) *extras.moment += set.position[k].cross(g);
    if (!extras.gravity) return;
    // g . (x_k - p) = -g . d: the weight of the fluid between p and the sample; above p
    // (negative) its share above_share.
    const double up = -extras.gravity->dot(d);
    const double rise = up > 0.0 ? up : extras.above_share * up;
    *extras.hydrostatic += rise * g;
    if (extras.hydrostatic_moment) *extras.hydrostatic_moment += rise * set.position[k].cross(g);
  });
  return sum;
}

void Boundaries::solverTerms(const Fluid& fluid, const BodyPlacement& at, const WallPairs& pairs,
                             const Vec3& gravity, SolverBoundary& out) const {
  const FluidState& st = fluid.state();
  const std::size_t n = st.size();
  if (pairs.particles != n) throw std::logic_error("Boundaries::solverTerms before addWallTerms");
  out.gradient.assign(n, Vec3::Zero());
  out.flux.assign(n, 0.0);
  out.neighbors.assign(n, 0u);
  out.hydrostatic.assign(n, Vec3::Zero());
  out.above_share.assign(n, 0.0);
  const double rho0 = fluid_.rest_density;
  const std::vector<double>& mean = st.keepsPressureMean() ? st.pressure_mean : st.pressure;
  const double deep = rho0 * gravity.norm() * kernel_.supportRadius();
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  const Vec3 zero = Vec3::Zero();
  // The links to the bodies the pressure moves, per chunk, then in chunk order.
  std::vector<std::vector<BodyLink>> chunk_links(chunks);
#pragma omp parallel for schedule(static)
  for (std::int64_t c = 0; c < static_cast<std::int64_t>(chunks); ++c) {
    const std::size_t end = std::min(n, (c + 1) * kChunk);
    for (std::size_t i = c * kChunk; i < end; ++i) {
      const Vec3 xi = st.position[i];
      const double chi = deep > 0.0 ? std::clamp(mean[i] / deep, 0.0, 1.0) : 0.0;
      Vec3 g = Vec3::Zero(), h = Vec3::Zero();
      double b = 0.0;
      std::uint32_t within = 0;
      pairs.forEachSegment(
          i, c, c * kChunk, [&](std::uint32_t set, const std::uint32_t* near, std::uint32_t count) {
            GradientExtras extras;
            extras.within = &within;
            extras.above_share = chi;
            if (set == 0) {
              extras.gravity = &gravity;
              extras.hydrostatic = &h;
              g += gradientSum(static_, xi, near, count, zero, zero, extras);
              return;
            }
            const MovingBody& m = moving_[set - 1];
            const BodyFrame& f = at[m.body];
            const Mat3 rt = f.rotation.transpose();
            const Vec3 p = rt * (xi - f.pose.position);
            // The samples' velocity in the set's frame: v_c + omega x x_k, both turned.
            const Vec3 g_set = rt * gravity;
            Vec3 h_set = Vec3::Zero(), moment = Vec3::Zero(), h_moment = Vec3::Zero();
            const bool moved = bodies_[m.body].settings.twoWay();
            extras.flux = &b;
            extras.gravity = &g_set;
            extras.hydrostatic = &h_set;
            if (moved) {
              extras.moment = &moment;
              extras.hydrostatic_moment = &h_moment;
            }
            const Vec3 g_body =
                f.rotation * gradientSum(m.samples, p, near, count, rt * f.linear_velocity,
                                         rt * f.angular_velocity, extras);
            g += g_body;
            h += f.rotation * h_set;
            if (!moved) return;
            BodyLink link;
            link.particle = static_cast<std::uint32_t>(i);
            link.body = static_cast<std::uint32_t>(m.body);
            const Vec3 gw = rho0 * g_body, mw = rho0 * (f.rotation * moment);
            const Vec3 hw = f.rotation * h_set, hm = f.rotation * h_moment;
            for (int k = 0; k < 3; ++k) {
              link.flux[k] = gw[k];
              link.flux[3 + k] = mw[k];
              link.hydrostatic[k] = hw[k];
              link.hydrostatic[3 + k] = hm[k];
            }
            chunk_links[c].push_back(link);
          });
      out.gradient[i] = rho0 * g;
      out.flux[i] = rho0 * b;
      out.neighbors[i] = within;
      out.hydrostatic[i] = h;
      out.above_share[i] = chi;
    }
  }
  out.links.clear();
  for (const std::vector<BodyLink>& links : chunk_links)
    out.links.insert(out.links.end(), links.begin(), links.end());
}

void Boundaries::addSolverReaction(const Fluid& fluid, const BodyPlacement& at,
                                   const WallPairs& pairs, const std::vector<double>& wall_impulse,
                                   const std::vector<double>& lift,
                                   const std::vector<double>& above_share, const Vec3& gravity,
                                   double dt, std::vector<Wrench>& reaction) const {
  const FluidState& st = fluid.state();
  const std::size_t n = st.size(), nb = bodies_.size();
  if (n == 0 || nb == 0) return;
  if (pairs.particles != n || wall_impulse.size() != n || lift.size() != n ||
      above_share.size() != n)
    throw std::logic_error("Boundaries::addSolverReaction before addWallTerms or the solve");
  bool two_way = false;
  for (const MovingBody& m : moving_)
    two_way = two_way || bodies_[m.body].settings.twoWay();
  if (!two_way) return;
  const double mass = fluid.particleMass();
  const double scale = mass * fluid_.rest_density / dt;
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  chunk_reaction_.assign(chunks * nb, Wrench{});
  const Vec3 zero = Vec3::Zero();
#pragma omp parallel for schedule(static)
  for (std::int64_t c = 0; c < static_cast<std::int64_t>(chunks); ++c) {
    const std::size_t end = std::min(n, (c + 1) * kChunk);
    for (std::size_t i = c * kChunk; i < end; ++i) {
      const Vec3 xi = st.position[i];
      pairs.forEachSegment(
          i, c, c * kChunk, [&](std::uint32_t set, const std::uint32_t* near, std::uint32_t count) {
            if (set == 0) return;
            const MovingBody& m = moving_[set - 1];
            if (!bodies_[m.body].settings.twoWay()) return;
            const BodyFrame& f = at[m.body];
            const Mat3 rt = f.rotation.transpose();
            const Vec3 p = rt * (xi - f.pose.position);
            const Vec3 g_set = rt * gravity;
            Vec3 moment = Vec3::Zero(), h = Vec3::Zero(), h_moment = Vec3::Zero();
            GradientExtras extras;
            extras.moment = &moment;
            extras.gravity = &g_set;
            extras.above_share = above_share[i];
            extras.hydrostatic = &h;
            extras.hydrostatic_moment = &h_moment;
            const Vec3 g = gradientSum(m.samples, p, near, count, zero, zero, extras);
            const double pressure = scale * wall_impulse[i] + mass * lift[i];
            Wrench& w = chunk_reaction_[c * nb + m.body];
            w.force += f.rotation * (pressure * g + mass * h);
            w.torque += f.rotation * (pressure * moment + mass * h_moment);
          });
    }
  }
  for (std::size_t c = 0; c < chunks; ++c)
    for (std::size_t b = 0; b < nb; ++b) {
      reaction[b].force += chunk_reaction_[c * nb + b].force;
      reaction[b].torque += chunk_reaction_[c * nb + b].torque;
    }
}

void Boundaries::matchBodyShapes() {
  const double support = kernel_.supportRadius(), s = spacing_;
  // The kernel's quadrature over a support: points h apart, each counting the share of its
  // cell that lies inside the shape, from the signed distance d there (1/2 - d / h, within
  // [0, 1]: the exact share for a face across the cell).
  const double h = 0.5 * radius_;
  const int reach = static_cast<int>(std::ceil(support / h));
  std::vector<Vec3> offset;
  std::vector<double> weight;
  for (int i = -reach; i <= reach; ++i)
    for (int j = -reach; j <= reach; ++j)
      for (int k = -reach; k <= reach; ++k) {
        const Vec3 q = h * Vec3(i, j, k);
        if (q.norm() >= support) continue;
        offset.push_back(q);
        weight.push_back(kernel_.value(q.norm()));
      }
  auto inside = [h](double d) { return std::clamp(0.5 - d / h, 0.0, 1.0); };
  // What a flat face's samples give a spacing from their plane (a fluid particle's radius
  // outside the face): the lattice's missing layer, each sample s^3 (buildSet's volumes).
  const double flat = s * s * s * flatLatticeKernelSum(kernel_, s, s);
  const double support_sq = support * support;
  for (MovingBody& m : moving_) {
    SampleSet& set = m.samples;
    const Shape& shape = *bodies_[m.body].settings.shape;
    const std::int64_t count = static_cast<std::int64_t>(set.position.size());
    // Each sample's probe lies where the first fluid layer does, a radius outside the
    // surface along its normal (the samples lie a radius inside). There the samples should
    // give what a flat face's give, times the shape's kernel integral over a half-space's.
    auto probe = [&](std::int64_t k) { return set.position[k] + 2.0 * radius_ * set.normal[k]; };
    std::vector<double> target(count), actual(count);
#pragma omp parallel for schedule(dynamic, 16)
    for (std::int64_t k = 0; k < count; ++k) {
      const Vec3 p = probe(k), n = set.normal[k];
      double body = 0.0, half = 0.0;
      for (std::size_t t = 0; t < offset.size(); ++t) {
        body += weight[t] * inside(shape.signedDistance(p + offset[t]));
        half += weight[t] * inside(offset[t].dot(n) + radius_);
      }
      target[k] = half > 0.0 ? flat * body / half : 0.0;
    }
    // Each sample's volume scaled by what its own probe lacks, a few rounds (a probe also
    // reads the samples beside its own).
    for (int round = 0; round < kShapeRounds; ++round) {
#pragma omp parallel for schedule(static)
      for (std::int64_t k = 0; k < count; ++k) {
        const Vec3 p = probe(k);
        double sum = 0.0;
        set.grid.forEachRangeWithin(p, set.density_reach + 1,
                                    [&](std::uint32_t lo, std::uint32_t hi) {
                                      for (std::uint32_t l = lo; l < hi; ++l) {
                                        const double d_sq = (p - set.position[l]).squaredNorm();
                                        if (d_sq < support_sq)
                                          sum += set.volume[l] * kernel_.value(std::sqrt(d_sq));
                                      }
                                    });
        actual[k] = sum;
      }
      for (std::int64_t k = 0; k < count; ++k)
        if (actual[k] > 0.0 && target[k] > 0.0)
          set.volume[k] *= std::clamp(target[k] / actual[k], 0.5, 2.0);
    }
  }
}

void Boundaries::calibrateVolumes(const Fluid& fluid, const BodyPlacement& at) {
  const FluidState& st = fluid.state();
  const std::size_t n = st.size();
  if (n == 0 || bodies_.empty()) return;
  const double rho0 = fluid_.rest_density;
  const double support_sq = kernel_.supportRadius() * kernel_.supportRadius();
  matchBodyShapes();
  std::vector<double> wall(n), scale(n);
  WallPairs pairs;
  for (int round = 0; round < 4; ++round) {
    std::fill(wall.begin(), wall.end(), 0.0);
    wallPass(fluid, at, wall, nullptr, nullptr, &pairs);
    // The scale of its wall share each particle asks for: what removes its excess.
    for (std::size_t a = 0; a < n; ++a) {
      const double excess = st.density[a] + wall[a] - rho0;
      scale[a] = wall[a] > 0.0 && excess > 0.0 ? std::max(0.25, 1.0 - excess / wall[a]) : 1.0;
    }
    transposePairs(pairs);
    auto rescale = [&](SampleSet& set, std::size_t s, const Mat3& rotation, const Vec3& origin) {
      const std::vector<std::uint32_t>& offset = pairs.offset[s];
      const std::vector<std::uint32_t>& particle = pairs.particle[s];
      const std::int64_t count = static_cast<std::int64_t>(set.position.size());
#pragma omp parallel for schedule(static)
      for (std::int64_t k = 0; k < count; ++k) {
        double weighted = 0.0, weight = 0.0;
        for (std::uint32_t t = offset[k]; t < offset[k + 1]; ++t) {
          const std::uint32_t a = particle[t];
          const Vec3 p = rotation.transpose() * (st.position[a] - origin);
          const double d_sq = (p - set.position[k]).squaredNorm();
          if (d_sq >= support_sq) continue;
          const double w = kernel_.value(std::sqrt(d_sq));
          weighted += w * scale[a];
          weight += w;
        }
        if (weight > 0.0) set.volume[k] *= weighted / weight;
      }
    };
    rescale(static_, 0, Mat3::Identity(), Vec3::Zero());
    for (std::size_t m = 0; m < moving_.size(); ++m) {
      const BodyFrame& f = at[moving_[m].body];
      rescale(moving_[m].samples, m + 1, f.rotation, f.pose.position);
    }
  }
}

}  // namespace wake
