// Penalty boundaries (Monaghan 1994), the paper's baseline (Becker et al. 2009, Sec. VI-A).
//
// Every boundary sample closer than r0 = r_f + r_b to a fluid centre pushes it away with
// a Lennard-Jones-like acceleration a = D [(r0/d)^12 - (r0/d)^4] (x - x_k) / d^2, added
// to the fluid's forces before the step's integration; a two-way body gets the reaction.
// There is no velocity control and no position correction: the force only reacts after
// the fluid has come close, which is what direct forcing improves on. It is kept to
// compare against (`coupling.method: "penalty"`), not for production use.
#pragma once

#include "coupling/boundary.hpp"
#include "coupling/rigid_body.hpp"

#include <array>
#include <vector>

namespace wake {

/// Monaghan's choice D = 5 g H with H the fluid depth is 2.5 v_max^2 for v_max^2 = 2 g H;
/// with c = 10 v_max (speed_of_sound "auto") that is 0.025 c^2.
inline double defaultPenaltyStrength(double speed_of_sound) {
  return 0.025 * speed_of_sound * speed_of_sound;
}

class PenaltyBoundary {
 public:
  /// strength: D in m^2/s^2, > 0.
  PenaltyBoundary(const FluidParams& fluid, double strength);
  double strength() const { return strength_; }

  /// Adds the penalty accelerations at the positions x (bodies placed at `at`) to `accel`. `wrench`
  /// (bodies): the reaction on each two-way body (zero for the others). in_contact (n): 1 where a
  /// sample pushed. Returns the number of particle-body pairs that interacted. Per-body sums are
  /// reduced in a fixed order, so the result does not depend on the number of threads.
  std::size_t apply(const Boundaries& boundaries, const BodyPlacement& at,
                    const std::vector<Vec3>& x, std::vector<Vec3>& accel,
                    std::vector<std::uint8_t>& in_contact, std::vector<Wrench>& wrench);

  /// The penalty force on a fluid centre x, per unit fluid mass, from every sample closer
  /// than r0 = r_f + r_b: a = D [(r0/d)^12 - (r0/d)^4] (x - x_k) / d^2. Per body it writes
  /// the acceleration sum and the sum of x_k x a_k (moment about the world origin, for the
  /// reaction torque). Returns the number of bodies written (at most kMaxContacts).
  struct Term {
    std::uint32_t body = 0;
    Vec3 accel = Vec3::Zero();   ///< m/s^2
    Vec3 moment = Vec3::Zero();  ///< m^2/s^2, sum of x_k x a_k (world)
  };
  using Terms = std::array<Term, Boundaries::kMaxContacts>;
  std::size_t terms(const Boundaries& boundaries, const BodyPlacement& at, const Vec3& x,
                    Terms& out) const;

 private:
  struct Chunk {
    std::vector<Vec3> accel, moment;  ///< (bodies) sums of a_k and x_k x a_k
    std::size_t pairs = 0;
  };
  static constexpr std::size_t kChunk = 2048;  ///< particles per chunk (fixed: determinism)

  double particle_mass_, strength_;
  std::vector<Chunk> chunks_;
};

}  // namespace wake
