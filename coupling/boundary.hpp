// Boundary particles of all bodies and static/one-way direct forcing (DESIGN.md §3-4).
//
// Every body's surface is sampled once in body space (coupling/shape.hpp); the samples'
// world positions, normals and volumes live here in flat arrays sorted by grid cell.
// Boundary particles take part in the fluid's density (their share of the kernel support,
// so fluid at a wall has no density deficit) but exert no pressure force: direct forcing
// (velocity control, then position correction) keeps fluid out of the bodies.
#pragma once

#include "coupling/shape.hpp"
#include "sph/fluid.hpp"

#include <array>
#include <memory>
#include <string>
#include <vector>

namespace wake {

enum class BodyKind { Static, Kinematic, Dynamic };

/// One rigid body as the scene describes it.
struct BodySettings {
  std::string name;
  BodyKind kind = BodyKind::Static;
  std::shared_ptr<const Shape> shape;    ///< exact shape, body space
  Pose pose;                             ///< body -> world; position = centre of mass
  Vec3 linear_velocity = Vec3::Zero();   ///< m/s, world
  Vec3 angular_velocity = Vec3::Zero();  ///< rad/s, world
  double slip = 0.0;                     ///< eps in [0, 1]: 0 no-slip, 1 free slip
  double restitution = 0.0;              ///< delta in [0, 1]: 0 inelastic
};

/// Contact of one fluid particle with one body: the body's nearest overlapping sample.
struct Contact {
  std::uint32_t body = 0;    ///< body index
  std::uint32_t sample = 0;  ///< index into the world sample arrays
  double dist_sq = 0;        ///< m^2, squared distance fluid centre - sample centre
};

class Boundaries {
 public:
  /// Samples are placed at the fluid's lattice spacing with the fluid's particle radius.
  Boundaries(const FluidParams& fluid, const Aabb& domain);

  /// Adds a body and samples its surface (infinite shapes within the domain).
  /// Returns its index. Call updateWorld() after the last body.
  std::size_t addBody(const BodySettings& body);
  /// Moves a body (its pose and velocities at the current time).
  void setBodyState(std::size_t body, const Pose& pose, const Vec3& linear_velocity,
                    const Vec3& angular_velocity);
  /// Recomputes world samples from body poses, re-sorts them by cell and updates volumes.
  void updateWorld();

  std::size_t bodyCount() const { return bodies_.size(); }
  const BodySettings& body(std::size_t b) const { return bodies_[b].settings; }
  std::size_t sampleCount() const { return position_.size(); }
  std::size_t bodySampleCount(std::size_t b) const { return bodies_[b].local.size(); }
  double sampleRadius() const { return radius_; }

  /// World sample arrays, sorted by grid cell.
  const std::vector<Vec3>& samplePositions() const { return position_; }  ///< (k) m
  const std::vector<Vec3>& sampleNormals() const { return normal_; }      ///< (k) unit
  const std::vector<double>& sampleVolumes() const { return volume_; }    ///< (k) m^3

  /// Adds the boundary's share rho0 * sum_k V_k W(x_a - x_k) to each fluid density.
  void addDensity(const Fluid& fluid, std::vector<double>& density) const;

  /// Velocity control for one-way boundaries (eq. 8-9 with m_c -> inf):
  /// x_pred: positions predicted with v (= v*); v_old: velocities at the start of the step;
  /// v: predicted velocities v*, replaced by the controlled velocities where in contact.
  /// in_contact: (n) set to 1 for particles with a contact, else 0.
  /// Returns the number of particles in contact.
  std::size_t controlVelocities(const std::vector<Vec3>& x_pred, const std::vector<Vec3>& v_old,
                                std::vector<Vec3>& v, std::vector<std::uint8_t>& in_contact) const;

  /// Position correction (eq. 19-20): moves fluid centres out to at least their radius
  /// from the tangent plane of their nearest overlapping sample, a few passes so that a
  /// particle in a corner or between bodies ends outside all of them.
  /// Only particles flagged in `candidates` are looked at: with bodies that did not move
  /// since the velocity control, a particle without a contact at its predicted position
  /// x* has none at its final one (uncontrolled particles end exactly at x*).
  void correctPositions(std::vector<Vec3>& x, const std::vector<std::uint8_t>& candidates) const;

  /// Number of fluid centres strictly inside some body's exact shape.
  std::size_t countInside(const std::vector<Vec3>& x) const;
  /// Signed distance (m) from x to the nearest body surface (< 0 inside); +inf if none.
  double signedDistance(const Vec3& x) const;

  /// Most bodies one fluid particle is in contact with at once (the nearest are kept).
  static constexpr std::size_t kMaxContacts = 8;
  /// Contacts of a fluid centre x with every body: the nearest overlapping sample per
  /// body (|x - x_b| < r_f + r_b), nearest first. Returns how many were written.
  std::size_t findContacts(const Vec3& x, std::array<Contact, kMaxContacts>& out) const;

 private:
  struct Body {
    BodySettings settings;
    SurfaceSamples local;     ///< body-space samples
    Aabb world_bounds;        ///< bounds of the exact shape in world space (clipped)
    std::uint32_t first = 0;  ///< first of its samples in the unsorted world arrays
  };
  /// Bit 1: a sample within the kernel support may exist; bit 2: within contact reach.
  static constexpr std::uint8_t kNearDensity = 1, kNearContact = 2;
  bool near(const Vec3& x, std::uint8_t what) const {
    return (near_[grid_.cellIndex(x)] & what) != 0;
  }
  static UniformGrid makeGrid(const Aabb& domain, double support);

  FluidParams fluid_;
  CubicSplineKernel kernel_;
  Aabb domain_;
  double spacing_, radius_;
  double volume_scale_;  ///< s^3 * sum of W over a flat sample lattice: V_k numerator
  UniformGrid grid_;
  std::vector<Body> bodies_;
  // World samples, sorted by cell: (k) each.
  std::vector<Vec3> position_, normal_;
  std::vector<double> volume_;
  std::vector<std::uint32_t> body_of_;
  int density_reach_ = 1;             ///< cells to search for the kernel support
  int contact_reach_ = 1;             ///< cells to search for contacts (r_f + r_b)
  std::vector<std::uint8_t> near_;    ///< (cells) kNear* bits: samples within reach
  std::vector<std::uint32_t> order_;  ///< scratch
};

}  // namespace wake
