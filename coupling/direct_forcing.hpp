// Velocity control by direct forcing (DESIGN.md §4; Becker et al. 2009, eq. 8-18).
//
// Each fluid particle in contact with a body gets the velocity change psi that takes its
// relative velocity to the target of eq. 8-9 (slip eps, restitution delta). For a one-way
// body (static, kinematic, or dynamic marked one-way) the body does not react. For a
// two-way body the control force's reaction goes into the body's wrench:
//   local:  each contact alone, with the 3x3 effective mass K of particle and body;
//   global: all contacts of one body at once, a 6x6 SPD system for the body's velocity
//           change, so that every contact ends exactly on its target.
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

/// Cross-product matrix [r]x: [r]x a = r x a.
Mat3 crossMatrix(const Vec3& r);

/// Effective-mass matrix of one contact: the change of the relative velocity at the
/// contact per unit impulse on the particle (and its reaction on the body),
/// K = (1/m_i + 1/m_c) E - [r]x I^-1 [r]x. Symmetric positive definite for m_i > 0.
Mat3 contactMatrix(double particle_mass, double body_inverse_mass, const Mat3& inverse_inertia,
                   const Vec3& lever);

/// Local approach: impulse J (N s) on the particle that changes the relative velocity at
/// the contact by exactly psi; the body receives -J at the lever.
Vec3 localImpulse(double particle_mass, double body_inverse_mass, const Mat3& inverse_inertia,
                  const Vec3& lever, const Vec3& psi);

/// One contact of the global system: the particle's mass share, lever and psi.
struct GlobalContact {
  double mass = 0;            ///< kg, the particle's mass (shared among its contacts)
  Vec3 lever = Vec3::Zero();  ///< r = x_cp - x_c
  Vec3 psi = Vec3::Zero();    ///< velocity change the contact needs, body at rest
};

/// Global approach for one body: accumulates the 6x6 matrix A and right-hand side b of
/// A [dV; dW] = b (DESIGN.md §4), starting from the body's own mass and inertia.
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
  Mat6 a_;  ///< contact part: [M E, S^T; S, sum m R^T R]
  Vec6 b_;
};

/// The world inertia I from its inverse; a locked axis (zero inverse) becomes very stiff.
Mat3 inertiaFromInverse(const Mat3& inverse_inertia);

/// Result of one velocity control.
struct ControlResult {
  std::size_t particles = 0;  ///< fluid particles in contact
  std::size_t contacts = 0;   ///< particle-body contacts
};

class DirectForcing {
 public:
  explicit DirectForcing(const FluidParams& fluid) : particle_mass_(fluid.particleMass()) {}

  /// Velocity control at the predicted positions. The boundaries must show the bodies at
  /// their predicted poses (`predicted`); `now` are the body states at the step's start.
  /// x_pred: x*; v_old: velocities at the step's start; v: v* in, controlled out.
  /// in_contact: (n) 1 where the particle had a contact. wrench: (bodies) the fluid's
  /// force and torque on each two-way body for this step (zero for one-way bodies).
  ControlResult control(const Boundaries& boundaries, CouplingMethod method, double dt,
                        const std::vector<Vec3>& x_pred, const std::vector<Vec3>& v_old,
                        const std::vector<RigidState>& now,
                        const std::vector<RigidPrediction>& predicted, std::vector<Vec3>& v,
                        std::vector<std::uint8_t>& in_contact, std::vector<Wrench>& wrench);

 private:
  struct Record {
    std::uint32_t particle = 0;
    std::uint32_t body = 0;
    std::uint32_t count = 1;  ///< contacts of this particle
    double bounce = 0;        ///< normal speed restitution asks for, -delta min(0, v_r(t).n)
    Vec3 lever = Vec3::Zero();
    Vec3 v_cp = Vec3::Zero();  ///< contact-point velocity of the predicted body
    Vec3 normal = Vec3::Zero();
    Vec3 psi = Vec3::Zero();  ///< velocity change to the target, body unmoved
  };
  struct Chunk {
    std::vector<Record> records;
    std::vector<Vec3> impulse, angular;  ///< (bodies) impulse of the fluid on each body
    std::vector<GlobalSystem> system;    ///< (bodies) global approach
  };
  static constexpr std::size_t kChunk = 2048;  ///< particles per chunk (fixed: determinism)

  double particle_mass_;
  std::vector<Chunk> chunks_;
};

}  // namespace wake
