#include "coupling/penalty.hpp"

#include <algorithm>
#include <array>

namespace wake {

PenaltyBoundary::PenaltyBoundary(const FluidParams& fluid, double strength)
    : particle_mass_(fluid.particleMass()), strength_(strength) {}

std::size_t PenaltyBoundary::apply(const Boundaries& boundaries, const BodyPlacement& at,
                                   const std::vector<Vec3>& x, std::vector<Vec3>& accel,
                                   std::vector<std::uint8_t>& in_contact,
                                   std::vector<Wrench>& wrench) {
  const std::size_t n = x.size();
  const std::size_t nb = boundaries.bodyCount();
  const std::size_t chunk_count = (n + kChunk - 1) / kChunk;
  chunks_.resize(chunk_count);
  in_contact.assign(n, 0);
#pragma omp parallel for schedule(dynamic, 1)
  for (std::int64_t c = 0; c < static_cast<std::int64_t>(chunk_count); ++c) {
    Chunk& chunk = chunks_[static_cast<std::size_t>(c)];
    chunk.accel.assign(nb, Vec3::Zero());
    chunk.moment.assign(nb, Vec3::Zero());
    chunk.pairs = 0;
    Terms found;
    const std::size_t end = std::min(n, static_cast<std::size_t>(c + 1) * kChunk);
    for (std::size_t i = static_cast<std::size_t>(c) * kChunk; i < end; ++i) {
      const std::size_t count = terms(boundaries, at, x[i], found);
      if (count == 0) continue;
      in_contact[i] = 1;
      chunk.pairs += count;
      for (std::size_t t = 0; t < count; ++t) {
        accel[i] += found[t].accel;
        chunk.accel[found[t].body] += found[t].accel;
        chunk.moment[found[t].body] += found[t].moment;
      }
    }
  }
  std::size_t pairs = 0;
  wrench.assign(nb, Wrench{});
  for (const Chunk& chunk : chunks_) {
    pairs += chunk.pairs;
    for (std::size_t b = 0; b < nb; ++b) {
      if (!boundaries.body(b).twoWay()) continue;
      // The body feels -m a_k at each sample x_k: F = -m sum a_k,
      // tau about the centre of mass c = -m (sum x_k x a_k - c x sum a_k).
      const Vec3 c = at[b].pose.position;
      wrench[b].force -= particle_mass_ * chunk.accel[b];
      wrench[b].torque -= particle_mass_ * (chunk.moment[b] - c.cross(chunk.accel[b]));
    }
  }
  return pairs;
}

std::size_t PenaltyBoundary::terms(const Boundaries& boundaries, const BodyPlacement& at,
                                   const Vec3& x, Terms& out) const {
  const double r0 = 2.0 * boundaries.fluidRadius();
  const double strength = strength_;
  std::size_t count = 0;
  // x_k and a_k in the set's frame; `to_world` rotates (moving bodies) into the world.
  auto add = [&](std::uint32_t body, const Vec3& xk_world, const Vec3& a_world) {
    std::size_t c = 0;
    while (c < count && out[c].body != body)
      ++c;
    if (c == count) {
      if (count == out.size()) return;  // more bodies than slots: the rest are ignored
      out[count++] = Term{body, Vec3::Zero(), Vec3::Zero()};
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
  boundaries.forEachSampleNear(x, at,
                               [&](std::uint32_t body, const Vec3& xk, const Vec3& p, double d_sq,
                                   const Mat3* rotation, const Vec3* origin) {
                                 if (!rotation)
                                   add(body, xk, term(p, xk, d_sq));
                                 else
                                   add(body, *rotation * xk + *origin,
                                       *rotation * term(p, xk, d_sq));
                               });
  return count;
}

}  // namespace wake
