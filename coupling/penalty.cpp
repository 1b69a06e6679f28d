#include "coupling/penalty.hpp"

#include <algorithm>
#include <array>

namespace wake {

PenaltyBoundary::PenaltyBoundary(const FluidParams& fluid, double strength)
    : particle_mass_(fluid.particleMass()), strength_(strength) {}

std::size_t PenaltyBoundary::apply(const Boundaries& boundaries, const std::vector<Vec3>& x,
                                   std::vector<Vec3>& accel, std::vector<std::uint8_t>& in_contact,
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
    std::array<Boundaries::PenaltyTerm, Boundaries::kMaxContacts> terms;
    const std::size_t end = std::min(n, static_cast<std::size_t>(c + 1) * kChunk);
    for (std::size_t i = static_cast<std::size_t>(c) * kChunk; i < end; ++i) {
      const std::size_t count = boundaries.penaltyTerms(x[i], strength_, terms);
      if (count == 0) continue;
      in_contact[i] = 1;
      chunk.pairs += count;
      for (std::size_t t = 0; t < count; ++t) {
        accel[i] += terms[t].accel;
        chunk.accel[terms[t].body] += terms[t].accel;
        chunk.moment[terms[t].body] += terms[t].moment;
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
      const Vec3 c = boundaries.bodyState(b).pose.position;
      wrench[b].force -= particle_mass_ * chunk.accel[b];
      wrench[b].torque -= particle_mass_ * (chunk.moment[b] - c.cross(chunk.accel[b]));
    }
  }
  return pairs;
}

}  // namespace wake
