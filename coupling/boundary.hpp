// Boundary particles of all bodies (DESIGN.md §3-4): sampling, the fluid's density share,
// contacts, position correction and penetration counts.
//
// Every body's surface is sampled once in body space (coupling/shape.hpp). Static bodies'
// samples are placed in the world once, in flat arrays sorted by grid cell. A moving
// (kinematic or dynamic) body keeps its samples in body space, sorted in its own grid;
// a query transforms the fluid position into the body's frame, so moving a body costs
// nothing but its new pose. Boundary particles take part in the fluid's density (their
// share of the kernel support, so fluid at a wall has no density deficit) but exert no
// pressure force: direct forcing (velocity control, then position correction) keeps fluid
// out of the bodies.
#pragma once

#include "coupling/rigid_body.hpp"
#include "coupling/shape.hpp"
#include "sph/fluid.hpp"

#include <array>
#include <memory>
#include <string>
#include <vector>

namespace wake {

/// One rigid body as the coupling sees it.
struct BodySettings {
  std::string name;
  BodyKind kind = BodyKind::Static;
  CouplingMode coupling = CouplingMode::TwoWay;  ///< dynamic bodies only
  std::shared_ptr<const Shape> shape;    ///< exact shape, body space (origin = centre of mass)
  Pose pose;                             ///< body -> world; position = centre of mass
  Vec3 linear_velocity = Vec3::Zero();   ///< m/s, world
  Vec3 angular_velocity = Vec3::Zero();  ///< rad/s, world
  double mass = 0.0;                     ///< kg, dynamic bodies (SimpleRigidBodies)
  Vec3 inertia = Vec3::Zero();           ///< kg m^2, principal moments, body space
  double slip = 0.0;                     ///< eps in [0, 1]: 0 no-slip, 1 free slip
  double restitution = 0.0;              ///< delta in [0, 1]: 0 inelastic

  bool moves() const { return kind != BodyKind::Static; }
  /// True when the fluid's forces act on the body.
  bool twoWay() const { return kind == BodyKind::Dynamic && coupling == CouplingMode::TwoWay; }
};

/// Contact of one fluid particle with one body: the body's nearest overlapping sample.
struct Contact {
  std::uint32_t body = 0;      ///< body index
  std::uint32_t sample = 0;    ///< the body's sample (index into its sorted samples)
  double dist_sq = 0;          ///< m^2, squared distance fluid centre - sample centre
  Vec3 point = Vec3::Zero();   ///< contact point x_cp on the exact surface, world
  Vec3 normal = Vec3::Zero();  ///< outward unit normal n of the exact surface, world
};

class Boundaries {
 public:
  /// Samples are placed at the fluid's lattice spacing with the fluid's particle radius.
  Boundaries(const FluidParams& fluid, const Aabb& domain);

  /// Adds a body and samples its surface (infinite shapes within the domain).
  /// Returns its index. Call finalize() after the last body.
  std::size_t addBody(const BodySettings& body);
  /// Sorts the static samples and computes every sample's volume. Call once.
  void finalize();
  /// Moves a kinematic or dynamic body (its pose and velocities now). Cheap: a moving
  /// body's samples stay in body space. Static bodies cannot be moved.
  void setBodyState(std::size_t body, const RigidState& state);

  std::size_t bodyCount() const { return bodies_.size(); }
  const BodySettings& body(std::size_t b) const { return bodies_[b].settings; }
  RigidState bodyState(std::size_t b) const;
  std::size_t sampleCount() const;
  std::size_t bodySampleCount(std::size_t b) const { return bodies_[b].sample_count; }
  double sampleRadius() const { return radius_; }
  /// Largest distance of a body's samples from its origin (m): bounds surface speeds.
  double bodyExtent(std::size_t b) const { return bodies_[b].extent; }

  /// World positions, normals and volumes of all samples (static ones in cell order,
  /// then each moving body's at its current pose). For output and tests; allocates.
  void worldSamples(std::vector<Vec3>& position, std::vector<Vec3>& normal,
                    std::vector<double>& volume, std::vector<std::uint32_t>& body) const;

  /// Adds the boundary's share rho0 * sum_k V_k W(x_a - x_k) to each fluid density.
  void addDensity(const Fluid& fluid, std::vector<double>& density) const;

  /// Most bodies one fluid particle is in contact with at once (the nearest are kept).
  static constexpr std::size_t kMaxContacts = 8;
  /// Contacts of a fluid centre x with every body: the nearest overlapping sample per
  /// body (|x - x_b| < r_f + r_b), nearest first. The contact's normal is the gradient of
  /// the exact shape's signed distance at x and its point the nearest surface point
  /// (DESIGN.md §3: normals from the exact shape), so corners and edges push fluid out
  /// along the shortest way. Returns how many were written.
  std::size_t findContacts(const Vec3& x, std::array<Contact, kMaxContacts>& out) const;
  /// Monaghan's penalty force (the paper's baseline, coupling/penalty.hpp) on a fluid
  /// centre x, per unit fluid mass, from every sample closer than r0 = r_f + r_b:
  /// a = D [(r0/d)^12 - (r0/d)^4] (x - x_k) / d^2. Per body it writes the acceleration
  /// sum and the sum of x_k x a_k (moment about the world origin, for the reaction
  /// torque). Returns the number of bodies written (at most kMaxContacts).
  struct PenaltyTerm {
    std::uint32_t body = 0;
    Vec3 accel = Vec3::Zero();   ///< m/s^2
    Vec3 moment = Vec3::Zero();  ///< m^2/s^2, sum of x_k x a_k (world)
  };
  std::size_t penaltyTerms(const Vec3& x, double strength,
                           std::array<PenaltyTerm, kMaxContacts>& out) const;
  /// True when x may be within contact reach of a moving body.
  bool nearMovingBody(const Vec3& x) const { return moving_reach_.contains(x); }
  bool hasMovingBodies() const { return !moving_.empty(); }

  /// Position correction (eq. 19-20): moves fluid centres out to at least their radius
  /// from the tangent plane of their nearest overlapping sample, a few passes so that a
  /// particle in a corner or between bodies ends outside all of them.
  /// Particles flagged in `candidates` and particles near a moving body are looked at:
  /// with static bodies, a particle without a contact at its predicted position x* has
  /// none at its final one (uncontrolled particles end exactly at x*).
  void correctPositions(std::vector<Vec3>& x, const std::vector<std::uint8_t>& candidates) const;

  /// Number of fluid centres strictly inside some body's exact shape.
  std::size_t countInside(const std::vector<Vec3>& x) const;
  /// Signed distance (m) from x to the nearest body surface (< 0 inside); +inf if none.
  double signedDistance(const Vec3& x) const;

 private:
  /// Samples of one body in a grid: the static set (world space) or one moving body
  /// (body space). Sorted by cell.
  struct SampleSet {
    UniformGrid grid;
    Aabb reach_box;  ///< where a query can find a sample within the kernel support
    std::vector<Vec3> position, normal;
    std::vector<double> volume;
    std::vector<std::uint32_t> body;  ///< owning body (static set)
    std::vector<std::uint8_t> near;   ///< (cells) kNear* bits (static set)
    int density_reach = 1;            ///< cells to search for the kernel support
    int contact_reach = 1;            ///< cells to search for contacts (r_f + r_b)
  };
  struct Body {
    BodySettings settings;
    SurfaceSamples local;  ///< body-space samples (cleared after finalize)
    std::size_t sample_count = 0;
    Aabb world_bounds;                 ///< bounds of the exact shape in world space (clipped)
    double extent = 0.0;               ///< max |sample| in body space
    std::int32_t moving = -1;          ///< index into moving_, or -1 (static)
    Mat3 rotation = Mat3::Identity();  ///< body -> world
  };
  struct MovingBody {
    std::uint32_t body = 0;
    SampleSet samples;
    Aabb world_reach;  ///< samples' bounds at the current pose, grown by the support
  };
  /// Bit 1: a sample within the kernel support may exist; bit 2: within contact reach.
  static constexpr std::uint8_t kNearDensity = 1, kNearContact = 2;

  /// Sorts samples into `set` over `box` and computes their volumes.
  void buildSet(SampleSet& set, const Aabb& box, const std::vector<Vec3>& pos,
                const std::vector<Vec3>& nrm, const std::vector<std::uint32_t>& body, bool flags);
  void updateWorldBounds(Body& b);
  /// Calls f(k, dist_sq) for each sample k of `set` within contact reach of p (set space).
  template <class F>
  void forEachContactCandidate(const SampleSet& set, const Vec3& p, F&& f) const;
  /// Calls f(body, moving, set, k, p, dist_sq) for each sample k within contact reach of
  /// the world point x, over the static set and every moving body. p is x in the set's
  /// space (world, or the moving body's frame); `moving` is that body (nullptr: static).
  template <class F>
  void forEachSampleNear(const Vec3& x, F&& f) const;
  /// Contact point and normal of a fluid centre x from the body's exact shape.
  void contactGeometry(const Vec3& x, Contact& ct) const;
  /// Boundary density sum sum_k V_k W(p - x_k) over `set` (p in the set's space).
  double densitySum(const SampleSet& set, const Vec3& p) const;

  FluidParams fluid_;
  CubicSplineKernel kernel_;
  Aabb domain_;
  double spacing_, radius_;
  double volume_scale_;  ///< s^3 * sum of W over a flat sample lattice: V_k numerator
  std::vector<Body> bodies_;
  SampleSet static_;
  std::vector<MovingBody> moving_;
  Aabb moving_reach_;  ///< union of the moving bodies' world_reach
  bool finalized_ = false;
};

}  // namespace wake
