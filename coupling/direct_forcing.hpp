// Velocity control by direct forcing (DESIGN.md §4; Becker et al. 2009, eq. 8-18).
//
// Each fluid particle in contact with a body gets the normal velocity change psi that takes
// its relative normal velocity to the target of eq. 8-9's normal part (restitution delta;
// a separating contact is left alone). The tangential part of eq. 8 (slip eps) is not a
// per-step target here: it is the walls' viscous shear (Boundaries::addWallTerms), a force
// that does not depend on the step. For a one-way body (static, kinematic, or dynamic
// marked one-way) the body does not react. For a two-way body the control impulse (along
// the normal) has its reaction in the body's wrench:
//   local:  each contact alone, with the effective mass 1 / (n^T K n) of particle and body;
//   global: all contacts of one body at once, a 6x6 SPD system for the body's velocity
//           change, so that every contact ends exactly on its normal target.
// A particle touching several bodies (the paper leaves this open) shares its mass among
// its contacts in the global system, and a few normal-only passes afterwards remove any
// approach velocity left towards one of them.
#pragma once

#include "coupling/boundary.hpp"
#include "coupling/rigid_body.hpp"

#include <Eigen/Core>

#include <vector>

namespace wake {

enum class CouplingMethod { Local, Global, Penalty };

using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

/// The change of the normal relative velocity at a contact per unit impulse along its
/// normal n on the particle (and its reaction on the body at lever r): n^T K n with
/// K = (1/m_i + 1/m_c) E - [r]x I^-1 [r]x, i.e. 1/m_i + 1/m_c + (r x n) . I^-1 (r x n)
/// (1/kg).
double normalCompliance(double particle_inverse_mass, double body_inverse_mass,
                        const Mat3& inverse_inertia, const Vec3& lever, const Vec3& normal);

/// One contact of the global system: the particle's mass share, lever, normal and the
/// normal velocity change it needs.
struct GlobalContact {
  double mass = 0;             ///< kg, the particle's mass (shared among its contacts)
  Vec3 lever = Vec3::Zero();   ///< r = x_cp - x_c
  Vec3 normal = Vec3::Zero();  ///< n, outward unit normal of the body's surface
  double psi = 0;              ///< m/s, change of the normal relative velocity, body at rest
};

/// Global approach for one body, normal form: every contact i takes an impulse j_i n_i
/// along its normal only (the tangential part is the walls' viscous shear), the body the
/// opposite, and every contact's normal relative velocity changes by exactly psi_i. With
/// g_i = [n_i; r_i x n_i] the body's velocity change [dV; dW] solves the 6x6 symmetric
/// positive definite system
///   (diag(m_c E, I) + sum m_i g_i g_i^T) [dV; dW] = -sum m_i psi_i g_i
/// (the Woodbury form of the k x k contact system), and each particle gets
/// v_i += (psi_i + n_i . (dV + dW x r_i)) n_i.
class GlobalSystem {
 public:
  GlobalSystem() { clear(); }
  void clear() {
    a_.setZero();
    b_.setZero();
  }
  void add(const GlobalContact& c);
  void add(const GlobalSystem& other) {
    a_ += other.a_;
    b_ += other.b_;
  }
  /// Full matrix with the body's mass m_c (1 / inverse_mass) and world inertia I added.
  Mat6 matrix(double inverse_mass, const Mat3& inverse_inertia) const;
  const Vec6& rhs() const { return b_; }
  /// Solves for [dV; dW] with an LDLT.
  Vec6 solve(double inverse_mass, const Mat3& inverse_inertia) const;

 private:
  Mat6 a_;  ///< contact part: sum m g g^T
  Vec6 b_;  ///< -sum m psi g
};

/// The world inertia I from its inverse; a locked axis (zero inverse) becomes very stiff.
Mat3 inertiaFromInverse(const Mat3& inverse_inertia);

/// Result of one velocity control.
struct ControlResult {
  std::size_t particles = 0;  ///< fluid particles in contact
  std::size_t contacts = 0;   ///< particle-body contacts
};

/// The bodies as the velocity control sees them in one step.
struct ControlBodies {
  const BodyPlacement& at;                        ///< placed at their predicted poses
  const std::vector<RigidState>& now;             ///< (bodies) states at the step's start
  const std::vector<RigidPrediction>& predicted;  ///< (bodies) predicted without fluid forces
};

/// The fluid as the velocity control sees it in one step (n particles each).
struct ControlFluid {
  const Vec3* x_pred;                     ///< predicted positions x*
  const Vec3* v_old;                      ///< velocities at the step's start
  std::vector<Vec3>& v;                   ///< v* in, controlled out
  std::vector<std::uint8_t>& in_contact;  ///< out: 1 where the particle had a contact
};

class DirectForcing {
 public:
  explicit DirectForcing(const FluidParams& fluid) : particle_mass_(fluid.particleMass()) {}

  /// Velocity control at the predicted positions, in two stages: the contacts and each
  /// one's normal velocity change psi (findContacts), then the impulses of the local or
  /// global approach (solveLocal, solveGlobal). A particle between a two-way body and a
  /// wall (a film under a body settling on the floor) meets the body with its own mass: it
  /// does not carry the body; the position correction moves it out of a closing gap, and
  /// Bullet's contact carries the body. wrench: (bodies) the fluid's force and torque on
  /// each two-way body for this step (zero for one-way bodies).
  ControlResult control(const Boundaries& boundaries, const ControlBodies& bodies,
                        const ControlFluid& fluid, CouplingMethod method, double dt,
                        std::vector<Wrench>& wrench);

 private:
  struct Record {
    std::uint32_t particle = 0;
    std::uint32_t body = 0;
    std::uint32_t count = 1;  ///< contacts of this particle
    double bounce = 0;        ///< normal speed restitution asks for, -delta min(0, v_r(t).n)
    Vec3 lever = Vec3::Zero();
    Vec3 v_cp = Vec3::Zero();  ///< contact-point velocity of the predicted body
    Vec3 normal = Vec3::Zero();
    double psi = 0;  ///< normal velocity change to the target, body unmoved (m/s)
  };
  struct Chunk {
    std::vector<Record> records;         ///< a particle's contacts are consecutive
    std::vector<Vec3> impulse, angular;  ///< (bodies) impulse of the fluid on each body
    std::vector<GlobalSystem> system;    ///< (bodies) global approach
  };
  static constexpr std::size_t kChunk = 2048;  ///< particles per chunk (fixed: determinism)

  /// Every particle's contacts at x*, as records with their psi (eq. 8-9's normal part:
  /// restitution, no sticking), in particle order per chunk.
  ControlResult findContacts(const Boundaries& boundaries, const ControlBodies& bodies,
                             const ControlFluid& fluid, std::size_t chunk_count);
  /// Local: each contact alone, its effective mass from particle and body.
  void solveLocal(const std::vector<RigidPrediction>& predicted, std::size_t chunk_count,
                  std::vector<Vec3>& v);
  /// Global: each two-way body's contacts at once (GlobalSystem); sets its wrench.
  void solveGlobal(const std::vector<RigidPrediction>& predicted, double dt,
                   std::size_t chunk_count, std::vector<Vec3>& v, std::vector<Wrench>& wrench);
  /// Calls f(first record, contact count) for each particle's run of records in `records`.
  template <class F>
  static void forEachParticle(const std::vector<Record>& records, F&& f);
  /// Effective mass 1 / (n^T K n) of a normal impulse at a contact.
  double normalMass(const Record& rec, const std::vector<RigidPrediction>& predicted) const;
  /// Impulse j on the particle (velocity vi); its reaction into the chunk's body sums.
  void applyImpulse(Chunk& ch, const Record& rec, const Vec3& j, Vec3& vi) const;
  /// Passes over one particle's contacts that only remove approach velocity towards one
  /// of them, whose contact points move with v_cp + extra(rec).
  template <class Extra>
  void normalPasses(Chunk& ch, const Record* rec, std::size_t count, Vec3& vi,
                    const std::vector<RigidPrediction>& predicted, Extra&& extra, int passes) const;

  double particle_mass_;
  std::vector<Chunk> chunks_;
  std::vector<std::uint8_t> two_way_;  ///< scratch: (bodies) 1 where the body reacts
};

}  // namespace wake
