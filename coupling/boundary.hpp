// Boundary particles of all bodies (DESIGN.md §3-4): sampling, the walls' part of the
// fluid's sums (density share, viscous shear, pressure), contacts and penetration counts.
//
// Every body's surface is sampled once in body space (geometry/shape.hpp). Static bodies'
// samples are placed in the world once, in flat arrays sorted by grid cell. A moving
// (kinematic or dynamic) body keeps its samples in body space, sorted in its own grid;
// a query transforms the fluid position into the body's frame, so moving a body costs
// nothing but its new pose. Boundaries hold no pose that changes: the rigid-body side owns
// the bodies' states, and every query takes them as a BodyPlacement (place()). Boundary particles
// take part in the fluid's density (their share of the kernel support, so fluid at a wall has no
// density deficit) but exert no pressure force: direct forcing (velocity control, then position
// correction) keeps fluid out of the bodies.
#pragma once

#include "coupling/rigid_body.hpp"
#include "geometry/shape.hpp"
#include "sph/dfsph.hpp"
#include "sph/fluid.hpp"

#include <array>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace wake {

/// One rigid body as the coupling sees it: how it meets the fluid (name, slip,
/// restitution, coupling: BodyFluidSettings), its shape, start state and mass properties.
struct BodySettings : BodyFluidSettings {
  BodyKind kind = BodyKind::Static;
  std::shared_ptr<const Shape> shape;    ///< exact shape, body space (origin = centre of mass)
  Pose pose;                             ///< body -> world; position = centre of mass
  Vec3 linear_velocity = Vec3::Zero();   ///< m/s, world
  Vec3 angular_velocity = Vec3::Zero();  ///< rad/s, world
  double mass = 0.0;                     ///< kg, dynamic bodies (SimpleRigidBodies)
  Vec3 inertia = Vec3::Zero();           ///< kg m^2, principal moments, body space

  bool moves() const { return kind != BodyKind::Static; }
  /// True when the fluid's forces act on the body.
  bool twoWay() const { return kind == BodyKind::Dynamic && coupling == CouplingMode::TwoWay; }
};

/// Where one body is at one instant, as the boundaries' queries need it: its pose and
/// velocities (as the rigid-body side reports them) and what follows from them.
struct BodyFrame {
  Pose pose;                             ///< body -> world; position = centre of mass
  Mat3 rotation = Mat3::Identity();      ///< the pose's rotation as a matrix
  Vec3 linear_velocity = Vec3::Zero();   ///< m/s, of the centre of mass
  Vec3 angular_velocity = Vec3::Zero();  ///< rad/s, world
  Aabb world_bounds;                     ///< the exact shape's bounds in the world (clipped)
  Aabb contact_bounds;                   ///< world_bounds grown by the fluid radius
  Aabb world_reach;  ///< moving bodies: their samples' grid box in the world (kernel reach)
};

/// Every body's frame at one instant: how the boundaries' queries learn where the bodies
/// are. Made by Boundaries::place() from the rigid-body side's states for one stage of a
/// step (the bodies now, predicted, or at the step's end); a value, not a second owner of
/// the bodies' poses. Static bodies' frames never change.
struct BodyPlacement {
  std::vector<BodyFrame> frames;  ///< (bodies)
  Aabb moving_reach;              ///< union of the moving bodies' world_reach

  const BodyFrame& operator[](std::size_t b) const { return frames[b]; }

  /// Calls f(m) for each moving body m (Boundaries' moving order) whose world_reach may
  /// hold x, ascending, until f returns false: every m whose world_reach holds x, and
  /// maybe others (the caller tests the box); none outside moving_reach. A particle tests
  /// the few bodies near it, not each body's box.
  template <class F>
  void forEachMovingNear(const Vec3& x, F&& f) const {
    if (!moving_reach.contains(x)) return;
    const std::uint64_t* mask = bins.mask.data() + bins.cellOf(x) * bins.words;
    for (std::size_t w = 0; w < bins.words; ++w)
      for (std::uint64_t bits = mask[w]; bits != 0; bits &= bits - 1)
        if (!f(w * 64 + static_cast<std::size_t>(__builtin_ctzll(bits)))) return;
  }

  /// A coarse grid over moving_reach: per cell, a bit per moving body whose world_reach
  /// overlaps the cell (Boundaries::place fills it).
  struct MovingBins {
    static constexpr int kMaxCellsPerAxis = 16;
    Vec3 origin = Vec3::Zero();
    Vec3 inv_cell = Vec3::Zero();  ///< 1/m per axis
    Eigen::Vector3i dims = Eigen::Vector3i::Ones();
    std::size_t words = 0;            ///< 64-bit words per cell: ceil(moving bodies / 64)
    std::vector<std::uint64_t> mask;  ///< (cells * words)
    /// The cell of x along axis k, clamped into the bins (monotone in x[k]: a box's cells
    /// hold every point of the box).
    int coord(const Vec3& x, int k) const {
      const double t = (x[k] - origin[k]) * inv_cell[k];
      return static_cast<int>(clampToCells(t, static_cast<double>(dims[k] - 1)));
    }
    std::size_t cellOf(const Vec3& x) const {
      return (std::size_t(coord(x, 2)) * dims[1] + coord(x, 1)) * dims[0] + coord(x, 0);
    }
  } bins;
};

/// The samples' pressure term P_k / rho_k^2 of one step (m^5 / (kg s^2)), per sample set
/// (the static set first, then each moving body's): Boundaries::computeSamplePressure
/// fills it, addWallPressure reads it. Scratch of the step.
struct SamplePressure {
  std::vector<std::vector<double>> p_rho2;
  std::vector<std::vector<double>> pressure;  ///< P_k (Pa, >= 0), as p_rho2
  /// Two-way bodies' sets only (empty for the others): each sample's surface element force
  /// P^s_k A_k (N, >= 0; addBodyPressure).
  std::vector<std::vector<double>> surface_force;
  /// Two-way bodies' sets only: 1 where fluid lies in front of the sample's face (its
  /// surface_force is the fluid's), 0 where none does (dry: addContactPressure).
  std::vector<std::vector<std::uint8_t>> wet;
  /// Two-way bodies' sets, filled by addContactPressure(..., wet_too = true) only: 1 where
  /// the sample's surface point lies within 2 r of another body or a wall, wet or dry.
  std::vector<std::vector<std::uint8_t>> touching;
};

/// The (fluid particle, sample) pairs within the kernel support of one step: found once by
/// Boundaries::addWallTerms, read by computeSamplePressure and addWallPressure, so the
/// walls' three sums search the samples once. Scratch of the step.
struct WallPairs {
  /// Per chunk of Boundaries::kChunk particles, for each particle in order and each
  /// sample set it has samples of within the support (the static set first, then the
  /// moving bodies in order): the set's number (0 static, m + 1 moving body m), the count
  /// c, then the c sample indices, ascending.
  std::vector<std::vector<std::uint32_t>> chunk;
  std::vector<std::uint32_t> end;  ///< (n) where each particle's part of its chunk ends
  /// Per set, the particles within the support of each sample, ascending: those of
  /// sample k are particle[set][offset[set][k] .. offset[set][k + 1]).
  std::vector<std::vector<std::uint32_t>> offset, particle;
  std::size_t particles = 0;  ///< n when found

  /// Calls f(set, samples, count) for each segment of particle i, in order (c: its chunk,
  /// first: the chunk's first particle).
  template <class F>
  void forEachSegment(std::size_t i, std::size_t c, std::size_t first, F&& f) const {
    const std::uint32_t* record = chunk[c].data();
    for (std::size_t pos = i == first ? 0 : end[i - 1]; pos < end[i]; pos += 2 + record[pos + 1])
      f(record[pos], record + pos + 2, record[pos + 1]);
  }
};

/// Contact of one fluid particle with one body: its centre is closer than the fluid
/// radius to the body's exact surface.
struct Contact {
  std::uint32_t body = 0;      ///< body index
  double distance = 0;         ///< m, signed distance of the fluid centre to the surface
  Vec3 point = Vec3::Zero();   ///< contact point x_cp on the exact surface, world
  Vec3 normal = Vec3::Zero();  ///< outward unit normal n of the exact surface, world
};

class Boundaries {
 public:
  /// Samples are placed at the fluid's lattice spacing with the fluid's particle radius.
  /// contact_fraction: the contact distance over the fluid radius, in (0, 1]
  /// (contactDistance()).
  Boundaries(const FluidParams& fluid, const Aabb& domain,
             double contact_fraction = kContactFraction);

  /// Adds a body and samples its surface (infinite shapes within the domain).
  /// Returns its index. Call finalize() after the last body.
  std::size_t addBody(const BodySettings& body);
  /// Sorts the static samples and computes every sample's volume. Call once.
  void finalize();
  /// The bodies' frames with every moving (kinematic or dynamic) body at `states[b]` (one
  /// per body; static bodies' entries are not read: they stay where they were added).
  /// Cheap: a moving body's samples stay in body space; per body, not per sample.
  void place(const std::vector<RigidState>& states, BodyPlacement& out) const;
  /// The bodies' frames at the poses and velocities they were added with.
  BodyPlacement placeAtStart() const;

  std::size_t bodyCount() const { return bodies_.size(); }
  /// A body as it was added (its pose and velocities are the start's).
  const BodySettings& body(std::size_t b) const { return bodies_[b].settings; }
  std::size_t sampleCount() const;
  /// Cells of the static samples' grid (their bounds grown by kStaticMargin supports, not
  /// the whole domain); 0 without static samples.
  std::size_t staticGridCells() const {
    return static_.position.empty() ? 0 : static_.grid.cellCount();
  }
  std::size_t bodySampleCount(std::size_t b) const { return bodies_[b].sample_count; }
  /// Largest distance of a body's samples from its origin (m): bounds surface speeds.
  double bodyExtent(std::size_t b) const { return bodies_[b].extent; }

  /// Body `b`'s samples in its own frame (origin = centre of mass): a moving body's as
  /// they are kept, a static body's from the world at its fixed pose. Allocates.
  void bodySamples(std::size_t b, std::vector<Vec3>& position, std::vector<Vec3>& normal) const;
  /// World positions, normals and volumes of all samples (static ones in cell order,
  /// then each moving body's at its pose in `at`). For output and tests; allocates.
  void worldSamples(const BodyPlacement& at, std::vector<Vec3>& position, std::vector<Vec3>& normal,
                    std::vector<double>& volume, std::vector<std::uint32_t>& body) const;

  /// Adds the boundary's share rho0 * sum_k V_k W(x_a - x_k) to each fluid density.
  void addDensity(const Fluid& fluid, const BodyPlacement& at, std::vector<double>& density) const;

  /// The walls' part of the fluid's sums, in one pass over the samples within the kernel
  /// support of each fluid particle (positions and velocities now, bodies at their states
  /// now):
  /// - `density` (n): adds the boundary's share, as addDensity();
  /// - `shear` (n, m/s^2): the walls' viscous shear, written (left empty when no wall
  ///   exerts any: all free slip, or an inviscid fluid). The samples take part in
  ///   the fluid's laminar viscosity (Morris et al. 1997) as a layer of fluid moving with
  ///   the wall: a_a = -sum_k (1 - eps_k) 2 nu_a V_k beta_ak (-x_ak . grad W_ak) /
  ///   |x_ak|^2 (v_a - v_k), the fluid's own form (Fluid::computeAccelerations).
  ///   beta_ak = min(2, 1 + r / d_a) (Morris's extrapolation: d_a is the particle's
  ///   distance beyond the sample's surface plane and the sample lies r behind it) puts
  ///   the no-slip condition on the wall's surface, not on the sample layer. A force,
  ///   integrated with the step: slip eps (the body's) is a property of the wall, not of
  ///   dt, and a wall never holds fluid against gravity.
  /// - `reaction` (bodies): the shear's force and torque (about the centre of mass) on
  ///   each two-way body; zero for the others. Summed in fixed particle chunks: the same
  ///   bits on any number of threads.
  /// - `pairs`: the pairs it visited, for computeSamplePressure and addWallPressure.
  void addWallTerms(const Fluid& fluid, const BodyPlacement& at, std::vector<double>& density,
                    std::vector<Vec3>& shear, std::vector<Wrench>& reaction,
                    WallPairs& pairs) const;
  /// For a fluid whose neighbour lists have a skin (Fluid::setNeighborSkin): lists, per
  /// particle, the static samples within support + skin / 2 of where the particle was at
  /// the lists' last build (Fluid::neighborReference), again whenever that changed
  /// (Fluid::neighborGeneration: a build, a restored reference). While the fluid's lists stand, no
  /// particle is skin / 2 from there, so these hold every static sample within its support: the
  /// walls' pass (addDensity, addWallTerms) then reads them instead of searching the static grid,
  /// the same samples in the same (ascending) order. Without a skin it does nothing and the pass
  /// searches.
  void prepareWallCandidates(const Fluid& fluid);

  /// Each sample's pressure, extrapolated from the fluid near it (Adami, Hu & Adams 2012,
  /// "A generalized wall boundary condition for SPH"): the samples stand for fluid
  /// particles that move with their wall, at the pressure the fluid has there,
  ///   P_k = max(0, [sum_a P_a W_ka + g . sum_a rho_a (x_k - x_a) W_ka] / sum_a W_ka),
  /// the second term the hydrostatic rise from the fluid to the sample (the wall's own
  /// acceleration is neglected). It needs no estimate of how much fluid the wall's shape
  /// leaves room for, so concave corners and edges, thin gaps and free surfaces give the
  /// fluid's own pressure: a tank of fluid at rest stays at rest. rho_k = the fluid's
  /// equation of state inverted at P_k. Call after the fluid's pressure is known (this
  /// step's densities with the walls' share) and before addWallPressure; written to `out`.
  /// `pairs`: this step's, from addWallTerms. `two_way_only`: the two-way bodies' sets
  /// alone (the others left empty), from the pressure's running mean where the fluid keeps
  /// one: what addContactPressure needs under the divergence-free solver.
  void computeSamplePressure(const Fluid& fluid, const BodyPlacement& at, const Vec3& gravity,
                             WallPairs& pairs, SamplePressure& out,
                             bool two_way_only = false) const;

  /// The walls' pressure force on the fluid, once the samples' pressure is known: the
  /// samples are neighbours in the fluid's pressure term, with the fluid's form
  /// (FluidParams::pressure_gradient). PressureGradient::Symmetric:
  ///   a_a -= sum_k rho0 V_k (P_a / rho_a^2 + P_k / rho_k^2) grad W_ak,
  /// which at rest holds the layer at a wall at the fluid's own spacing and pressure, added
  /// to `extra` (sized n when empty). PressureGradient::Consistent: the samples' share of
  /// the gradient's sums, added to `sums` (Fluid::wallPressureSums, this step's: sized by
  /// Fluid::computePressure), and each particle's reference lowered to the lowest
  /// pressure of the samples within its support; `extra` is left as it is. The bodies'
  /// side is addBodyPressure's.
  void addWallPressure(const Fluid& fluid, const BodyPlacement& at, const WallPairs& pairs,
                       const SamplePressure& pressure, std::vector<Vec3>& extra,
                       WallPressureSums& sums) const;
  /// The fluid's pressure force and torque (about the centre of mass) on each two-way body,
  /// added to `reaction`: the surface integral -sum_k P^s_k A_k n_k over its samples, each
  /// standing for the area A_k of the exact surface (geometry's sampling) with its normal
  /// n_k, at the pressure of computeSamplePressure carried from the sample up to the
  /// surface point (P^s_k = P_k + rho0 g . (r_b n_k), r_b below it; zero where no fluid is
  /// near). A pressure acts along the surface's normals, so a body at rest in fluid at rest
  /// feels the integral of the fluid's pressure over its wetted surface (Archimedes) however
  /// the particles beside it are arranged. The reaction of addWallPressure's pair terms
  /// depends on that arrangement: a sphere five spacings across held at rest felt 0.88-0.93
  /// of its buoyancy from it, 0.958 from the surface integral (docs/forces.md). The fluid
  /// keeps the pair terms (they hold it at the wall), so fluid and body exchange momentum
  /// to within the difference of the two, a discretisation error that the spacing shrinks. The
  /// closed surface's areas are balanced at finalize() so that a uniform pressure pushes it nowhere
  /// (sum_k A_k n_k = 0).
  /// With `touching_only`, only the samples that touch another body or a wall
  /// (SamplePressure::touching): under the divergence-free solver the solves' impulses are
  /// the body's pressure where fluid is near, but at a contact face, and along its rim where
  /// the fluid beside it pushes sideways, they give none.
  void addBodyPressure(const BodyPlacement& at, const SamplePressure& pressure,
                       std::vector<Wrench>& reaction, bool touching_only = false) const;
  /// The pressure on a two-way body's contact faces, into `pressure.surface_force` before
  /// addBodyPressure: where the body touches another body or a wall, no particle fits
  /// between the two faces, yet real water reaches any real gap. A sample whose surface
  /// point lies within 2 r of another body's exact surface is a contact sample when it is
  /// dry (no fluid in front of its face) or faces that surface (its distance falls along
  /// the sample's normal: a film thinner than a particle's diameter, such as the last
  /// water under a body settling on the floor, whose few squeezed particles are no
  /// measure of its pressure and would hold the body up); each gets the pressure of the
  /// other wetted samples next to it
  /// carried hydrostatically, P_k = mean_j (P^s_j + rho0 g . (s_k - s_j)) (s the surface
  /// points, j its neighbours within 2 r already known), level by level inwards from the
  /// contact's wetted rim, clamped at 0 (above the water) and 0 where no wetted sample
  /// leads to it (a contact out of the water). Without it a light body resting on a heavy
  /// one or on the floor under water is held down like a suction cup: the water's full
  /// load on its top and nothing under it.
  /// `wet_too`: also mark the wetted samples within that reach (SamplePressure::touching).
  void addContactPressure(const BodyPlacement& at, const Vec3& gravity, SamplePressure& pressure,
                          bool wet_too = false) const;

  /// The walls' and bodies' terms of the divergence-free solver (sph/dfsph.hpp), from this
  /// step's pairs (addWallTerms) with the bodies at `at`, into `out` (SolverBoundary):
  /// G_a = rho0 sum_k V_k grad_a W_ak (world); B_a = rho0 sum_k V_k v_k . grad_a W_ak, v_k
  /// the sample's velocity (its body's at `at`; zero for static bodies); the samples within
  /// the kernel support; H_a = sum_k V_k chi_a g . (x_k - x_a) grad_a W_ak under `gravity`,
  /// chi_a = 1 for the samples below x_a, for those above a's mean pressure (the state's
  /// pressure_mean, or its pressure before one is kept) over the weight of a support's
  /// height of fluid, within [0, 1]; and chi_a (SolverBoundary::above_share).
  void solverTerms(const Fluid& fluid, const BodyPlacement& at, const WallPairs& pairs,
                   const Vec3& gravity, SolverBoundary& out) const;
  /// Makes the walls' share of the density agree with a fluid that starts at rest on the
  /// lattice (the divergence-free solver's start; sph/dfsph.hpp). Single layers of samples
  /// over-count the share at concave edges and corners (a tank filled on the lattice: +1.6 %
  /// and +3.8 % above the rest density there, flat walls +0.1 %); a solver that holds the
  /// fluid at the rest density would push that fluid away in its first step. For each
  /// particle of `fluid` (its density: the fluid's own share, summed) compressed beyond the
  /// rest density, the samples near it take the share of its excess their part of its wall
  /// share is: each sample's volume scales by the average, weighted by its kernel values,
  /// of the scales its particles ask for (1 where nothing is compressed). A few rounds;
  /// volumes only shrink. Before that, the moving bodies' samples are made to stand for
  /// their shapes (matchBodyShapes). Call before the first step, with the bodies at `at`.
  void calibrateVolumes(const Fluid& fluid, const BodyPlacement& at);
  /// The solver's pressure force on each two-way body, the opposite of the share of its
  /// samples k in each particle's velocity change over the step (sph/dfsph.hpp): particle a
  /// pushes them with m wall_impulse_a rho0 V_k grad_a W_ak / dt plus the hydrostatic part
  /// m V_k (chi g . (x_k - x_a) + lift_a) grad_a W_ak, chi = 1 for the samples below x_a and
  /// above_share_a for those above (DivergenceFreeSolver::wallLift; SolverBoundary::above_share
  /// of the step's solverTerms).
  /// Adds the force and its torque about the centre of mass to `reaction`, summed in fixed
  /// particle chunks: the same bits on any number of threads.
  void addSolverReaction(const Fluid& fluid, const BodyPlacement& at, const WallPairs& pairs,
                         const std::vector<double>& wall_impulse, const std::vector<double>& lift,
                         const std::vector<double>& above_share, const Vec3& gravity, double dt,
                         std::vector<Wrench>& reaction) const;

  /// Most bodies one fluid particle is in contact with at once (the nearest are kept).
  static constexpr std::size_t kMaxContacts = 8;
  /// Contacts of a fluid centre x with every body whose exact surface is closer than the
  /// contact distance s_c (signed distance < s_c: the same test as the position
  /// correction), nearest first. The contact's normal is the gradient of
  /// the exact shape's signed distance at x and its point the nearest surface point
  /// (DESIGN.md §3: normals from the exact shape), so corners and edges push fluid out
  /// along the shortest way. The samples only tell where a surface may be near.
  /// Returns how many were written.
  std::size_t findContacts(const Vec3& x, const BodyPlacement& at,
                           std::array<Contact, kMaxContacts>& out) const;
  /// Calls f(body, x_k, p, d_sq, rotation, origin) for each boundary sample k within
  /// contact reach (r_f + r_b) of the world point x (bodies placed at `at`), over the static
  /// bodies and every
  /// moving one. x_k and p (that is x) are in the frame of the sample's set: the world for
  /// static bodies (rotation and origin null), the body's frame for moving ones (world =
  /// *rotation * v + *origin). d_sq = |p - x_k|^2. Used by the penalty force.
  template <class F>
  void forEachSampleNear(const Vec3& x, const BodyPlacement& at, F&& f) const;
  /// True when x may be within contact reach of a moving body placed at `at`.
  static bool nearMovingBody(const Vec3& x, const BodyPlacement& at) {
    return at.moving_reach.contains(x);
  }
  bool hasMovingBodies() const { return !moving_.empty(); }
  bool hasTwoWayBodies() const {
    for (const MovingBody& m : moving_)
      if (bodies_[m.body].settings.twoWay()) return true;
    return false;
  }

  /// How far x is from the bodies' exact surfaces, capped at the fluid radius r_f:
  /// min(r_f, signed distance of x to the nearest surface within contact reach), over
  /// all bodies and over the static ones only (position correction, direct_forcing).
  struct Clearance {
    double all, walls;
  };
  Clearance clearance(const Vec3& x, const BodyPlacement& at) const;
  /// The fluid particles' radius r_f (m), also the samples' radius r_b.
  double fluidRadius() const { return radius_; }
  /// A fluid centre closer than this to a body's exact surface is in contact (velocity
  /// control) and is moved out to it (position correction): kContactFraction r_f (m).
  double contactDistance() const { return contact_distance_; }
  /// The contact distance over the fluid radius with the weakly compressible fluid. Fluid
  /// at rest beside a wall sits one radius from it (its lattice's half spacing), held there
  /// by the walls' pressure (addWallPressure); the control and the correction act only
  /// where the fluid comes closer by half a radius. At a full radius they acted on about
  /// half of the resting layer at every step: each contact stopped an approach and left a
  /// recession alone, a one-sided push that carried 5-7 % of a floating box's weight and
  /// held a sphere 15 % denser than the fluid up for good (the control's share 0.4-0.45 of
  /// its buoyancy).
  static constexpr double kContactFraction = 0.5;
  /// The same with the divergence-free solver, whose walls lean on the correction (it also
  /// takes the velocity into the wall of a particle it moves out): at half a radius a
  /// column at rest stirred (0.13 m/s), a sheet rebounded with 0.74 of its speed at
  /// restitution 1, and fluid squeezed under a plate left the tank. It keeps the full
  /// radius (and the control's share at rest) until its walls hold the fluid alone.
  static constexpr double kDfsphContactFraction = 1.0;

  /// Number of fluid centres strictly inside some body's exact shape (bodies at `at`).
  std::size_t countInside(const std::vector<Vec3>& x, const BodyPlacement& at) const;
  /// Signed distance (m) from x to the nearest body surface (< 0 inside; bodies at `at`);
  /// +inf if none.
  double signedDistance(const Vec3& x, const BodyPlacement& at) const;

  /// Whether the walls' sums take four samples at a time (AVX, where the CPU has it: the
  /// default) or two: the same bits either way (Fluid::setWideLanes).
  bool wideLanes() const { return wide_lanes_; }
  void setWideLanes(bool on) { wide_lanes_ = on && hasWideLanes(); }

 private:
  /// Scales each moving body's sample volumes so that, where the first fluid layer lies (a
  /// radius outside the surface, along the sample's normal), the samples give the share a
  /// flat face's samples give times the shape's kernel integral there over a half-space's
  /// (a quadrature of the kernel on the shape's signed distance). One layer of samples
  /// stands for a flat face's missing fluid exactly, not a curved one: a sphere 5 spacings
  /// across it under-counts by 10 % (its samples' volumes grow by 1.10); a box's samples
  /// change by 0.70-1.18 at its edges and corners. kShapeRounds rounds (a probe also reads
  /// its neighbours' samples), each scale within [0.5, 2].
  void matchBodyShapes();
  static constexpr int kShapeRounds = 3;
  /// Sum of W over a flat square lattice of spacing s at `height` from its plane, at the
  /// foot of a lattice point: at 0, what one boundary sample sees of a flat wall sampled at
  /// the fluid spacing; at s, what the first fluid layer sees of it.
  static double flatLatticeKernelSum(const CubicSplineKernel& kernel, double s, double height);
  /// Samples of one body in a grid: the static set (world space) or one moving body
  /// (body space). Sorted by cell.
  struct SampleSet {
    UniformGrid grid;
    Aabb reach_box;  ///< where a query can find a sample within the kernel support
    std::vector<Vec3> position, normal;
    std::vector<double> volume;
    std::vector<double> area;         ///< m^2, the surface each sample stands for
    std::vector<std::uint32_t> body;  ///< owning body (static set)
    std::vector<std::uint8_t> near;   ///< (cells) kNear* bits
    int density_reach = 1;            ///< cells to search for the kernel support
    int sample_reach = 1;             ///< cells to search for samples within r_f + r_b
    int contact_reach = 1;            ///< cells around a sample where a contact may be
  };
  struct Body {
    BodySettings settings;
    SurfaceSamples local;  ///< body-space samples (cleared after finalize)
    std::size_t sample_count = 0;
    double extent = 0.0;       ///< max |sample| in body space
    std::int32_t moving = -1;  ///< index into moving_, or -1 (static)
    BodyFrame start;           ///< the frame it was added with (static bodies: always)
  };
  struct MovingBody {
    std::uint32_t body = 0;
    SampleSet samples;
  };
  /// Bit 1: a sample within the kernel support may exist; bit 2: within contact reach;
  /// bit 4: the cell lies inside the body (the static set: inside some static body),
  /// beyond contact reach of its surface; bit 8 (the static set): within the walls'
  /// candidate radius (WallCandidates::reach cells).
  static constexpr std::uint8_t kNearDensity = 1, kNearContact = 2, kInterior = 4,
                                kNearCandidates = 8;
  /// The static set's grid covers its samples' bounds grown by this many kernel supports
  /// (and buildSet's one more), within the domain grown as much.
  static constexpr double kStaticMargin = 2.0;
  /// A sample set's grid with more cells per sample than this keeps its cells' starts
  /// sparse (UniformGrid::sortSparse).
  static constexpr double kSparseCellsPerSample = 8.0;
  /// The flags of x's cell in the static set's grid, or `outside` beyond its box (with
  /// static samples only).
  std::uint8_t staticFlags(const Vec3& x, std::uint8_t outside) const {
    return static_.reach_box.contains(x) ? static_.near[static_.grid.cellIndex(x)] : outside;
  }
  /// Whether static samples may lie within the reach `bit` flags of x (false without
  /// static samples, or outside their grid's box).
  bool nearStatic(const Vec3& x, std::uint8_t bit) const {
    return !static_.position.empty() && (staticFlags(x, 0) & bit);
  }
  /// Sets `bit` in near[cell] (near: one byte per cell of set.grid) for every cell within
  /// `reach` cells of a sample's cell: from anywhere else no sample is within reach x the
  /// cell size.
  static void markNear(const SampleSet& set, int reach, std::uint8_t bit,
                       std::vector<std::uint8_t>& near);
  /// Balances a closed surface's sample areas (sum_k A_k n_k = 0; addBodyPressure).
  static void balanceAreas(SurfaceSamples& samples);
  /// Sets kInterior on the cells of a moving body's `set` (body space) that are not near
  /// its samples and whose centre is inside the body.
  void markInterior(SampleSet& set, const Body& body);
  /// Sets kInterior on the static set's cells beyond contact reach of every sample that
  /// lie inside a static body (countInside reads it).
  void markStaticInterior();
  /// Sets kInterior on the cells of `set` beyond contact reach of its samples where
  /// inside(cell centre) holds, one query per run of such cells along x.
  template <class Inside>
  static void markInteriorRuns(SampleSet& set, Inside&& inside);
  /// Calls f(body, is_static, signed distance of x to its exact surface) for every body
  /// whose surface may be within contact reach of x (or, moving bodies, that x may be
  /// deep inside): what findContacts and clearance look at.
  template <class F>
  void forEachBodyDistance(const Vec3& x, const BodyPlacement& at, F&& f) const;
  /// Sorts samples into `set` over `box` and computes their volumes.
  void buildSet(SampleSet& set, const Aabb& box, const std::vector<Vec3>& pos,
                const std::vector<Vec3>& nrm, const std::vector<std::uint32_t>& body, bool flags,
                const std::vector<double>* area = nullptr);
  /// The frame of body `b` at `state`.
  BodyFrame frameAt(const Body& b, const RigidState& state) const;
  /// Calls f(k, dist_sq) for each sample k of `set` within contact reach of p (set space).
  template <class F>
  void forEachContactCandidate(const SampleSet& set, const Vec3& p, F&& f) const;
  /// Contact point and normal of a fluid centre x from the body's exact shape (its
  /// distance already in ct). False when neither the shape nor a sample gives a normal.
  bool contactGeometry(const Vec3& x, const BodyPlacement& at, Contact& ct) const;
  /// The sums of one set at p (set space) for a fluid particle of viscosity nu whose
  /// velocity relative to the set's frame is u (the set turns with omega, set space).
  /// Returns the density sum sum_k V_k W(p - x_k). When nu > 0 it also adds
  /// sum_k w_k (u - omega x x_k) to `shear` and, when `moment` is given,
  /// sum_k w_k x_k x (u - omega x x_k) to it (w_k of addWallTerms, 1/s).
  /// addDensity and addWallTerms: shear and reaction may be null (density only).
  /// `pairs` (may be null): records the pairs visited.
  void wallPass(const Fluid& fluid, const BodyPlacement& at, std::vector<double>& density,
                std::vector<Vec3>* shear, std::vector<Wrench>* reaction, WallPairs* pairs) const;
  /// `record` (may be null): the samples within the support are appended to it.
  /// `candidates` (may be null): the samples to look at, ascending, instead of searching
  /// the set's grid.
  double wallSums(const SampleSet& set, const Vec3& p, double nu, const Vec3& u, const Vec3& omega,
                  Vec3& shear, Vec3* moment, std::vector<std::uint32_t>* record,
                  const std::uint32_t* candidates = nullptr, std::size_t count = 0) const;
  /// addWallPressure's PressureGradient::Consistent part for particle i: its samples'
  /// terms added to entry i of `sums`.
  void consistentWallSums(const Fluid& fluid, const BodyPlacement& at, const WallPairs& pairs,
                          const SamplePressure& pressure, std::size_t i,
                          WallPressureSums& sums) const;
  /// sum_k V_k (pr2 + P_k / rho_k^2) grad W_ak over the `count` samples `near` of one set at
  /// p (set space).
  Vec3 pressureSum(const SampleSet& set, const std::vector<double>& p_rho2, const Vec3& p,
                   double pr2, const std::uint32_t* near, std::size_t count) const;
  /// What gradientSum adds up besides sum_k V_k grad W_ak (each may be null).
  struct GradientExtras {
    double* flux = nullptr;           ///< += sum_k V_k (u + omega x x_k) . grad W_ak
    Vec3* moment = nullptr;           ///< += sum_k x_k x V_k grad W_ak
    std::uint32_t* within = nullptr;  ///< += the samples within the support
    /// With `gravity` (set space): V_k g . (x_k - p) grad W_ak is added to `hydrostatic`,
    /// times above_share for the samples above p (g . (x_k - p) < 0), and its moment to
    /// `hydrostatic_moment` when that is given.
    const Vec3* gravity = nullptr;
    double above_share = 1.0;
    Vec3* hydrostatic = nullptr;
    Vec3* hydrostatic_moment = nullptr;
  };
  /// sum_k V_k grad W_ak over the `count` samples `near` of one set at p (set space), and
  /// the `extras` asked for (u, omega: the set's velocity, set space).
  Vec3 gradientSum(const SampleSet& set, const Vec3& p, const std::uint32_t* near,
                   std::size_t count, const Vec3& u, const Vec3& omega,
                   const GradientExtras& extras) const;
  /// Calls f(k, d, dwr) for each of the `count` samples `near` of one set that lie within
  /// the kernel support of p (set space): d = p - x_k, dwr = W'(|d|) / |d|.
  template <class F>
  void forEachSampleInSupport(const SampleSet& set, const Vec3& p, const std::uint32_t* near,
                              std::size_t count, F&& f) const {
    const double support_sq = kernel_.supportRadius() * kernel_.supportRadius();
    for (std::size_t t = 0; t < count; ++t) {
      const std::uint32_t k = near[t];
      const Vec3 d = p - set.position[k];
      const double d_sq = d.squaredNorm();
      if (d_sq >= support_sq) continue;
      f(k, d, kernel_.derivativeOverR(std::sqrt(d_sq)));
    }
  }
  /// The sample lists of `pairs` (sample -> particles) from its particle lists.
  void transposePairs(WallPairs& pairs) const;
  /// Each sample's P_k / rho_k^2 (computeSamplePressure) and, for a two-way body's set,
  /// its surface element force (SamplePressure).
  void samplePressure(const Fluid& fluid, const std::vector<double>& pressure, const SampleSet& set,
                      const Mat3& rotation, const Vec3& origin, const Vec3& gravity, bool two_way,
                      const std::vector<std::uint32_t>& offset,
                      const std::vector<std::uint32_t>& particle, std::vector<double>& p_rho2,
                      std::vector<double>& p_out, std::vector<double>& force,
                      std::vector<std::uint8_t>& wet) const;

  FluidParams fluid_;
  CubicSplineKernel kernel_;
  Aabb domain_;
  double spacing_, radius_;
  double contact_distance_;
  double volume_scale_;  ///< s^3 * sum of W over a flat sample lattice: V_k numerator
  std::vector<Body> bodies_;
  std::vector<double> shear_factor_;          ///< (bodies) 1 - slip
  std::vector<std::uint32_t> static_bodies_;  ///< indices of the static bodies
  SampleSet static_;
  std::vector<MovingBody> moving_;
  bool finalized_ = false;
  bool any_shear_ = false;  ///< some body has slip < 1
  bool wide_lanes_ = hasWideLanes();
  /// Particles per chunk of addWallTerms' reaction sums (fixed: determinism).
  static constexpr std::size_t kChunk = 2048;
  mutable std::vector<Wrench> chunk_reaction_;  ///< scratch: (chunks x bodies)
  /// prepareWallCandidates' lists: particle i's static samples are
  /// index[offset[i] .. offset[i + 1]), for `fluid` at its neighborGeneration() `build`.
  struct WallCandidates {
    const Fluid* fluid = nullptr;
    std::uint64_t build = 0;
    ListStarts offset;  ///< (n + 1)
    std::vector<std::uint32_t> index;
    int reach = 0;  ///< cells of kNearCandidates in the static set's flags (0: none yet)
  };
  WallCandidates wall_candidates_;
  /// The static samples of particle i from wall_candidates_ ({nullptr, 0}: search them).
  std::pair<const std::uint32_t*, std::size_t> staticCandidates(const Fluid& fluid,
                                                                std::size_t i) const;
};

// Template definitions (the penalty force visits samples from coupling/penalty.cpp).

template <class F>
inline void Boundaries::forEachContactCandidate(const SampleSet& set, const Vec3& p, F&& f) const {
  const double reach = radius_ + radius_;  // r_f + r_b
  const double reach_sq = reach * reach;
  set.grid.forEachRangeInSphere(p, set.sample_reach, reach, false,
                                [&](std::uint32_t lo, std::uint32_t hi) {
                                  for (std::uint32_t k = lo; k < hi; ++k) {
                                    const double d_sq = (p - set.position[k]).squaredNorm();
                                    if (d_sq < reach_sq) f(k, d_sq);
                                  }
                                });
}

template <class F>
inline void Boundaries::forEachSampleNear(const Vec3& x, const BodyPlacement& at, F&& f) const {
  if (nearStatic(x, kNearContact)) {
    forEachContactCandidate(static_, x, [&](std::uint32_t k, double d_sq) {
      f(static_.body[k], static_.position[k], x, d_sq, static_cast<const Mat3*>(nullptr),
        static_cast<const Vec3*>(nullptr));
    });
  }
  at.forEachMovingNear(x, [&](std::size_t mi) {
    const MovingBody& m = moving_[mi];
    const BodyFrame& frame = at[m.body];
    if (!frame.world_reach.contains(x)) return true;
    const Vec3 p = frame.rotation.transpose() * (x - frame.pose.position);
    if (!m.samples.reach_box.contains(p)) return true;
    forEachContactCandidate(m.samples, p, [&](std::uint32_t k, double d_sq) {
      f(m.body, m.samples.position[k], p, d_sq, &frame.rotation, &frame.pose.position);
    });
    return true;
  });
}

}  // namespace wake
