// Weakly compressible SPH fluid (DESIGN.md §2): particle state, parameters, and the
// per-step kernels (neighbours, density, pressure, accelerations). Knows nothing about
// rigid bodies: boundaries enter only through the density share and velocity/position
// control applied by the coupling module.
#pragma once

#include "sph/kernel.hpp"
#include "sph/neighbor_grid.hpp"
#include "sph/step_scratch.hpp"
#include "sph/types.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

namespace wake {

/// How the weakly compressible fluid's pressure force is discretised (docs/forces.md, "The
/// pressure force").
enum class PressureGradient {
  /// The default: the corrected difference form B_a^-1 sum_b V_b (P_b - P_a) grad W_ab
  /// (exact for a linear pressure, walls' samples included), a repulsion of the size of
  /// the pressure's variation over one support, and the free surface's pressure taken to
  /// vanish r beyond the top particles. Bodies feel Archimedes' force and slow flows past
  /// them are not held back; linear momentum is conserved only to the discretisation's
  /// error.
  Consistent,
  /// The usual symmetric form sum_b m_b (P_a / rho_a^2 + P_b / rho_b^2) grad W_ab: conserves
  /// linear momentum exactly, but its zero-order error times the pressure's level makes
  /// the fluid a soft solid under a few centimetres of head (a body a little denser than
  /// the fluid stops sinking) and reads the free surface about r low.
  Symmetric,
};

/// Constant parameters of the fluid.
struct FluidParams {
  double particle_radius = 0.01;  ///< m, > 0; lattice spacing is 2 * particle_radius
  double rest_density = 1000.0;   ///< kg/m^3, > 0
  double speed_of_sound = 0.0;    ///< m/s, > 0 (the scene's "auto" is resolved before)
  double viscosity = 0.1;         ///< Monaghan's artificial alpha, dimensionless, >= 0
  /// m^2/s, >= 0: physical (laminar) kinematic viscosity nu, Morris et al. 1997; water
  /// 1e-6. Per particle in FluidState::kinematic_viscosity; this is the fluid's default.
  double kinematic_viscosity = 1e-6;
  double gamma = 7.0;            ///< Tait exponent, > 0
  double smoothing_ratio = 1.0;  ///< smoothing length H / spacing, in [0.8, 2]
  /// The pressure force's form (computePressure, computeAccelerations; a pressure solver,
  /// DivergenceFreeSolver, makes its own and ignores it).
  PressureGradient pressure_gradient = PressureGradient::Consistent;

  double spacing() const { return 2.0 * particle_radius; }
  /// Tait's equation of state, clamped at zero (no tensile pull at free surfaces):
  /// P(rho) = max(0, B ((rho / rho0)^gamma - 1)), B = rho0 c^2 / gamma (Pa). The fluid's
  /// particles and the wall samples that stand for fluid (coupling) share this one.
  double pressure(double rho) const {
    const double ratio = rho * (1.0 / rest_density);
    double pw;
    if (gamma == 7.0) {  // the usual exponent: three multiplications instead of pow
      const double r2 = ratio * ratio, r4 = r2 * r2;
      pw = r4 * r2 * ratio;
    } else {
      pw = std::pow(ratio, gamma);
    }
    const double b = rest_density * speed_of_sound * speed_of_sound / gamma;
    return std::max(0.0, b * (pw - 1.0));
  }
  /// The density at which Tait's equation gives pressure p >= 0 (its inverse):
  /// rho0 (1 + p / B)^(1 / gamma).
  double densityAt(double p) const {
    const double b = rest_density * speed_of_sound * speed_of_sound / gamma;
    return rest_density * std::pow(1.0 + p / b, 1.0 / gamma);
  }
  double smoothingLength() const { return smoothing_ratio * spacing(); }
  double supportRadius() const { return 2.0 * smoothingLength(); }
  /// Mass of one particle (kg): rest density times the lattice cell volume.
  double particleMass() const {
    double s = spacing();
    return rest_density * s * s * s;
  }
};

/// Changing state of the fluid: structure of arrays, all of length size(), kept in
/// grid-cell order. `id` maps a slot to the particle's permanent number.
struct FluidState {
  std::vector<Vec3> position;               ///< (n) m
  std::vector<Vec3> velocity;               ///< (n) m/s
  std::vector<Vec3> acceleration;           ///< (n) m/s^2, fluid forces + gravity of this step
  std::vector<double> density;              ///< (n) kg/m^3
  std::vector<double> pressure;             ///< (n) Pa, >= 0
  std::vector<std::uint32_t> id;            ///< (n) permanent particle number
  std::vector<double> kinematic_viscosity;  ///< (n) m^2/s, nu of the particle's fluid
  /// (n, or empty) Pa: the pressure's running mean over the last steps, kept only once a
  /// solver asks for it (keepPressureMean: DivergenceFreeSolver, whose pressure is noisy
  /// from step to step), empty otherwise. Persistent, like the pressure.
  std::vector<double> pressure_mean;

  std::size_t size() const { return position.size(); }
  /// From now on pressure_mean is kept with the other arrays (resize, removeIf, append,
  /// permute, ...); starts as the pressure.
  void keepPressureMean();
  bool keepsPressureMean() const { return keep_pressure_mean_; }
  void resize(std::size_t n);
  /// Applies `order` (n; new slot k takes old slot order[k]) to the persistent
  /// per-particle arrays (position, velocity, id, kinematic_viscosity, and pressure and
  /// pressure_mean: the pressure solver starts from the last step's). acceleration and density,
  /// derived each step after the sort, serve as the gather space and are left undefined (sized n);
  /// `id_scratch` (n) that of the ids. The one place that permutes particles: a new
  /// persistent field must be added here.
  void permute(const std::uint32_t* order, std::uint32_t* id_scratch);
  /// Removes the particles whose `remove` flag is set, keeping the others' order.
  void removeIf(const std::vector<std::uint8_t>& remove);
  void append(const Vec3& x, const Vec3& v, std::uint32_t particle_id, double nu);
  /// Room for n particles in every array (append does not reallocate below it).
  void reserve(std::size_t n);
  /// Every array's memory cut to its size.
  void shrinkToFit();

 private:
  /// Calls f(array) for each per-particle array (resize, removeIf, reserve, shrinkToFit: a
  /// new field is added here, and to append and permute).
  template <class F>
  void forEachArray(F&& f) {
    f(position);
    f(velocity);
    f(acceleration);
    f(density);
    f(pressure);
    f(id);
    f(kinematic_viscosity);
    if (keep_pressure_mean_) f(pressure_mean);
  }
  bool keep_pressure_mean_ = false;
};

/// W'(r) / r (1/m^5) of each pair of a fluid's pair lists (PairLists), laid out as they
/// are: later[r][t] of the pair at lists.later[r][t] (t < lists.end[r]), before[r][k] of the
/// one at lists.before[r][k]. Entries of candidates that are not pairs are not read.
struct PairDerivatives {
  std::vector<std::vector<double>> later, before;  ///< (ranges)
};

/// What the walls add to the consistent pressure gradient of each fluid particle a
/// (PressureGradient::Consistent): sums over the wall samples k within its support, with
/// V_k the sample's volume, P_k its pressure and rho_k the density Tait's equation gives
/// for it. Fluid::computePressure sizes and clears it and sets the reference; the
/// boundaries add to it (Boundaries::addWallPressure); computeAccelerations reads it.
/// Scratch of the step.
struct WallPressureSums {
  std::vector<Vec3> difference;  ///< (n) sum_k V_k (P_k - P_a) grad W_ak (Pa / m)
  /// (n) sum_k V_k grad W_ak (x_k - x_a)^T, symmetric: xx, yy, zz, xy, xz, yz
  std::vector<std::array<double, 6>> moment;
  /// Whether the walls are to add their moments: false when the positions are those of the
  /// last evaluation (Fluid::computePressureFromState's same_positions), whose moments are
  /// kept as they are.
  bool moments = true;
  /// (n) sum_k rho0 V_k (1 / rho_a^2 + 1 / rho_k^2) grad W_ak (m^4 / kg): the walls' share
  /// of the symmetric form's zero-order error E_a
  std::vector<Vec3> spread;
  /// (n) -sum_k rho0 V_k (P_a / rho_a^2 + P_k / rho_k^2) grad W_ak (m/s^2): the symmetric
  /// form's walls' term, which the spray takes (Fluid::computeAccelerations)
  std::vector<Vec3> symmetric;
  /// (n) Pa: the pressure reference R_a, the lowest pressure of the particle, its
  /// neighbours and the samples within its support (the walls lower it to theirs)
  std::vector<double> reference;
};

/// The fluid solver: its parameters (the model), the neighbour grid and scratch space, and
/// the state it steps. The state is the caller's (`state`: Simulation keeps it with the
/// rest of a run's data, coupling/simulation.hpp) or, without one, the solver's own.
class Fluid {
 public:
  Fluid(const FluidParams& params, const Aabb& domain, FluidState* state = nullptr);
  Fluid(const Fluid&) = delete;
  Fluid& operator=(const Fluid&) = delete;

  const FluidParams& params() const { return params_; }
  const CubicSplineKernel& kernel() const { return kernel_; }
  const UniformGrid& grid() const { return grid_; }
  const Aabb& domain() const { return domain_; }
  double particleMass() const { return mass_; }

  FluidState& state() { return state_; }
  const FluidState& state() const { return state_; }
  /// The pairs within the support radius, each once (buildPairLists).
  const PairLists& neighbors() const { return neighbors_; }
  /// Bounds of the particles' positions at the last sort (updateNeighbors; empty: none;
  /// with a skin, of the positions rounded to float the candidates were listed of).
  const Aabb& particleBounds() const { return bounds_; }

  /// The pairs within the support radius of the particles now (neighbors()). Without a
  /// skin: sorts the particles by grid cell (permuting every array) and builds them. With a
  /// skin (setNeighborSkin): sorts and builds the candidate pairs within support + skin
  /// only when some particle has moved skin / 2 or more since the last build or the
  /// particles changed (their number or a slot's id), and otherwise keeps the particles'
  /// order and takes the pairs from the candidates (keepPairsWithin): the same pairs in
  /// the same order as a build in that order would give. Particles outside the domain must
  /// have been removed before.
  /// `dt` (s, finite, >= 0): the step the particles move by between calls (the last one
  /// taken: a guess of the next). A build lists candidates only when the skin pays: when
  /// the fastest particle, at its speed now, needs kMinSkinSteps such steps or more to
  /// cross half the skin (v_max dt <= skin / (2 kMinSkinSteps); always with dt = 0). In a
  /// flow too fast for that (the lists would be built again a step or two later, each time
  /// a search over the larger radius and a filter) the build searches the support alone,
  /// as without a skin, and the next call builds again. The choice depends only on the
  /// state and dt, so a run continued from a saved state chooses as the uninterrupted one.
  /// Throws std::invalid_argument for a negative or non-finite dt.
  void updateNeighbors(double dt = 0.0);
  /// See updateNeighbors: how many steps a skin must last to be built.
  static constexpr double kMinSkinSteps = 2.5;
  /// The neighbour lists' skin (m, finite, >= 0; 0, the default: sorted and built every
  /// call). Takes effect at the next build. Throws std::invalid_argument otherwise.
  void setNeighborSkin(double skin);
  double neighborSkin() const { return skin_; }
  /// How many times updateNeighbors sorted and built (every call without a skin), and how
  /// many of those builds listed candidates within the skin.
  std::uint64_t neighborBuilds() const { return builds_; }
  std::uint64_t neighborSkinnedBuilds() const { return skinned_builds_; }
  /// Changes whenever the lists' reference does (a build, restoreNeighborReference,
  /// setNeighborSkin): what lists kept beside them (Boundaries' wall candidates) check.
  std::uint64_t neighborGeneration() const { return generation_; }
  /// The particles' positions and ids at the last build with a skin (empty without one,
  /// or when the last build did not list candidates):
  /// what decides the next build. restoreNeighborReference sets them again (a saved run's),
  /// so that a continued run builds where the uninterrupted one would (a reference that
  /// does not fit the particles, or is not in their grid order, means a build).
  ///
  /// The positions are kept in single precision (12 bytes a particle, not 24): a build with
  /// a skin sorts and lists the candidates of the positions rounded to float, so the lists
  /// are exactly those of the reference as kept (and as saved: a float is a double), and a
  /// particle counts as moved when it is skin / 2 from its rounded position. A skin narrower
  /// than twice the rounding (coordinates beyond ~2^23 skins from the origin) is not built.
  const std::vector<Vec3f>& neighborReference() const { return reference_; }
  ///
  /// The ids are kept as a 64-bit digest of (slot, id) over the slots (idDigest): a change
  /// of one slot's id always changes it, of several a change goes unseen with odds of
  /// 2^-64. neighborReferenceIds gives the ids when the particles are still those of the
  /// reference (the state's ids), else none (the next call builds either way).
  std::vector<std::uint32_t> neighborReferenceIds() const;
  void restoreNeighborReference(const std::vector<Vec3>& position,
                                const std::vector<std::uint32_t>& id);
  /// The sum over slots i of a bijective 64-bit mix of (i, id[i]) (not depending on the
  /// number of threads).
  static std::uint64_t idDigest(const std::vector<std::uint32_t>& id);
  /// Summation density over fluid neighbours (no boundary share; the coupling adds it).
  void computeFluidDensity();
  /// Tait pressure from density, clamped at zero (no tensile pull at free surfaces). With
  /// PressureGradient::Consistent also: a free-surface particle's pressure raised to the
  /// one that vanishes r beyond it (see raiseSurfacePressure), the pressure references, and
  /// the walls' sums cleared (wallPressureSums).
  void computePressure();
  /// computePressure with the state's pressure as it is instead of Tait's (a pressure
  /// solver's, coupling/consistent_solve.hpp): the free surface's raise, the references and
  /// the walls' sums cleared, the densities' 1 / rho; the pressure term on.
  /// `same_positions`: the positions and densities are those of the last call, so the free
  /// surface's particles and normals it found (a pass over the pairs) and the walls'
  /// moments (WallPressureSums::moments) are taken as they are (a solver's iterations on
  /// one step); the result is the same bits.
  void computePressureFromState(bool same_positions = false);
  /// PressureGradient::Consistent's constants (computeAccelerations, raiseSurfacePressure;
  /// docs/forces.md has the measurements that chose them).
  static constexpr double kRepulsion = 0.3;
  /// det B_a below [0]: G_a uncorrected; above [1]: B_a^-1 G_a; linear between.
  static constexpr double kMomentDeterminant[2] = {0.2, 0.4};
  /// The fluid's own B_a's smallest eigenvalue below [0]: the symmetric form (spray);
  /// above [1]: the consistent form; linear between.
  static constexpr double kSprayMoment[2] = {0.1, 0.3};
  static constexpr double kSurfaceDensity = 0.99;
  static constexpr double kSurfaceColour = 0.2;
  /// The walls' share of this step's consistent pressure gradient (sized and cleared by
  /// computePressure with PressureGradient::Consistent, empty otherwise).
  WallPressureSums& wallPressureSums() { return wall_sums_; }
  const WallPressureSums& wallPressureSums() const { return wall_sums_; }
  /// What computeAccelerations needs of the densities when a pressure solver
  /// (DivergenceFreeSolver) makes the pressure force instead: 1 / rho, and no pressure term
  /// in the accelerations. The state's pressure is left as it is.
  void computeWithoutPressure();
  /// Pressure + artificial viscosity + physical viscosity + gravity accelerations, plus
  /// `extra` (n, m/s^2; e.g. the walls' viscous shear) when it is not empty, into the
  /// state's acceleration (sized n). `extra` may be the state's acceleration array itself
  /// (each particle's entry is read before it is written): the walls' terms need no
  /// array of their own. The pressure term reads the state's pressure as it is
  /// (computePressure's; none after computeWithoutPressure) and the 1 / rho of either.
  ///
  /// The pressure term (FluidParams::pressure_gradient): PressureGradient::Symmetric is
  ///   dv_a/dt -= sum_b m_b (P_a / rho_a^2 + P_b / rho_b^2) grad W_ab;
  /// PressureGradient::Consistent is
  ///   dv_a/dt -= B_a^-1 G_a / rho_a + s (P_a - R_a) E_a,
  ///   G_a = sum_b V_b (P_b - P_a) grad W_ab,  B_a = sum_b V_b grad W_ab (x_b - x_a)^T,
  ///   E_a = sum_b m_b (1 / rho_a^2 + 1 / rho_b^2) grad W_ab,  V_b = m_b / rho_b,
  /// the sums over the fluid neighbours plus the walls' (wallPressureSums), R_a the
  /// pressure reference and s = kRepulsion. B_a^-1 G_a is exact for a linear pressure;
  /// where B_a is nearly singular (det B_a below kMomentDeterminant: a particle with few
  /// neighbours) G_a is taken as it is. The second term is the symmetric form's zero-order
  /// error for the pressure's variation over the neighbourhood only: it keeps the
  /// particles from pairing up and clumping, with a stiffness that does not grow with the
  /// depth. A particle whose fluid neighbours alone give a moment sum_b V_b grad W_ab
  /// (x_b - x_a)^T with a small eigenvalue (kSprayMoment: spray, a sheet or a film one
  /// particle thick, no neighbours on either side in some direction) takes the symmetric
  /// form instead, walls' included, so that it is pushed off what it meets as the body is
  /// pushed by the pressure (momentum is kept in impacts of thin sheets). Both switches
  /// blend linearly, so the force is continuous in the particles' arrangement.
  ///
  /// Physical viscosity is Morris et al. (1997)'s SPH Laplacian, symmetric in a and b:
  ///   dv_a/dt += sum_b m_b (nu_a / rho_b + nu_b / rho_a) (x_ab . grad W_ab) / |x_ab|^2 v_ab,
  /// which conserves linear momentum and is exact for linear velocity fields. The factor
  /// (x . grad W) / |x|^2 is W'(r) / r, which stays finite as r -> 0 for the cubic
  /// spline, so Morris's regulariser (+0.01 H^2 in the denominator) is not needed: it
  /// would change the factor by 1 % at r = H (about the spacing particles keep) and by
  /// 4 % at r = H / 2.
  ///
  /// `derivatives`: W'(r) / r of each pair of the current lists where a pass over them
  /// already found it (DivergenceFreeSolver::prepareLists), read instead of computed again
  /// (the same bits: no square root and kernel per pair).
  void computeAccelerations(const Vec3& gravity, const std::vector<Vec3>& extra = {},
                            const PairDerivatives* derivatives = nullptr);
  /// The pressure term of computeAccelerations alone, into the state's acceleration (sized
  /// n): PressureGradient::Consistent only, after computePressure or
  /// computePressureFromState and the walls' sums. No viscosity, no gravity, no extra: for
  /// a solver that evaluates the pressure's accelerations for many pressures on the same
  /// positions (DFSPH's consistent density solve), one pair loop of the consistent sums
  /// alone. Leaves the step's scratch (stepStartVelocities, predictedPositions) as it is.
  /// `same_positions`: the positions, densities and walls' samples are those of the last
  /// call (a solver's iterations on one step), so what of the force depends on them alone
  /// (each particle's moment B_a with the walls', its inverse and blends, E_a's fluid sum)
  /// is taken as that call left it, and the pair loop finds G_a and S_a alone; the same
  /// bits.
  void computePressureAccelerations(const PairDerivatives* derivatives = nullptr,
                                    bool same_positions = false);

  /// The step's prediction with every force but the boundaries' control: v* = v + dt a
  /// (in the state), x* = x + dt v* (predictedPositions), the velocities before kept
  /// (stepStartVelocities).
  void predict(double dt);
  /// x* = x + dt v (predictedPositions) with the velocities as they are now.
  void predictPositions(double dt);
  /// (n) The velocities before the last predict(), and the positions it (or
  /// predictPositions) predicted: valid until the next computeAccelerations, whose scratch
  /// holds them.
  const Vec3* stepStartVelocities() const { return step_.at<Vec3>(0); }
  const Vec3* predictedPositions() const { return step_.at<Vec3>(0) + state_.size(); }
  /// x += dt v: the step's integration with the final velocities.
  void integratePositions(double dt);

  /// Largest |v| and |a| over the particles (0 when empty).
  double maxSpeed() const;
  /// Largest kinematic viscosity of any particle (m^2/s).
  double maxKinematicViscosity() const;
  double maxAcceleration() const;

  /// Whether the pair loops take four neighbours at a time (AVX, where the CPU has it:
  /// the default) or two: the same results, bit for bit.
  bool wideLanes() const { return wide_lanes_; }
  void setWideLanes(bool on) { wide_lanes_ = on && hasWideLanes(); }

 private:
  FluidParams params_;
  CubicSplineKernel kernel_;
  Aabb domain_;
  double mass_;
  UniformGrid grid_;
  Aabb bounds_;
  FluidState own_;     ///< the state when the caller gave none
  FluidState& state_;  ///< the state stepped: the caller's or own_
  /// With a skin, also the candidates: the pairs within support + skin at the last build
  /// (of reference_), those within the support first (keepPairsWithin).
  PairLists neighbors_;
  bool candidates_ready_ = false;     ///< neighbors_ holds the candidates of reference_
  double skin_ = 0;                   ///< m
  std::uint64_t builds_ = 0;          ///< sorts and builds so far
  std::uint64_t skinned_builds_ = 0;  ///< of those, with candidates in the skin
  std::uint64_t generation_ = 0;      ///< neighborGeneration()
  std::vector<Vec3f> reference_;      ///< (n) m, positions at the last build (skin)
  std::uint64_t reference_ids_ = 0;   ///< idDigest of the ids at the last build
  std::vector<double> inv_rho_;       ///< (n) 1 / rho (m^3/kg), this step
  bool pressure_term_ = true;         ///< computePressure (true) or computeWithoutPressure
  WallPressureSums wall_sums_;        ///< wallPressureSums()
  /// PressureGradient::Consistent's scratch: the fluid's sums (16 n: G, B, E, S, one
  /// unused), the surface test's colour gradients and flags, the surface pressure's sums
  /// (2 n).
  std::vector<double> gradient_sums_;
  std::vector<Vec3> colour_;
  std::vector<std::uint8_t> surface_;
  std::size_t surface_count_ = 0;  ///< particles with surface_ set
  /// A term of a surface particle a's raised pressure: W_ab r / (r + d_b) P_b.
  struct SurfaceTerm {
    std::uint32_t a, b;
    double coefficient;
  };
  std::vector<std::vector<SurfaceTerm>> surface_terms_;  ///< per range of the pair lists
  std::vector<double> surface_weight_;                   ///< (n) sum_b W_ab of a's terms
  std::vector<double> surface_sums_;                     ///< (n) sum of a's terms
  /// Per particle, what its consistent pressure term takes from the positions alone
  /// (addConsistentPressure with keep_geometry): B_a^-1 (9, with the walls' moment; the
  /// identity where not used), the determinant's blend, the spray's blend, E_a's fluid sum
  /// (3), two unused.
  static constexpr std::size_t kPressureGeometry = 16;
  std::vector<double> pressure_geometry_;
  /// The step's scratch, in turn: the sort's order, cells and id gather (3 n uint32,
  /// updateNeighbors); the force loop's partial sums (8 n doubles); from predict() on, the
  /// step's start velocities and the predicted positions (2 n Vec3).
  StepScratch step_;

  bool wide_lanes_ = hasWideLanes();

  /// computeAccelerations, or with `pressure_only` computePressureAccelerations.
  void accelerationPass(const Vec3& gravity, const std::vector<Vec3>& extra,
                        const PairDerivatives* derivatives, bool pressure_only);
  /// computePressure and computePressureFromState: the pressure from Tait's equation or as
  /// it is; `same_positions` as computePressureFromState's.
  void pressureTerms(bool from_density, bool same_positions = false);
  /// PressureGradient::Consistent, after the equation of state: a particle at the free
  /// surface (density < kSurfaceDensity rho0 and |sum_b V_b grad W_ab| H > kSurfaceColour)
  /// gets at least the pressure that vanishes r beyond it along its outward normal n (minus
  /// that sum's direction), extrapolated from the neighbours b at least r/2 below it
  /// (depth d_b = (x_a - x_b) . n) that are not at the surface themselves:
  ///   P_a = max(P_a, sum_b W_ab P_b r / (r + d_b) / sum_b W_ab).
  /// Tait's pressure is zero there (density < rho0): without this the pressure would vanish
  /// at the top particles' centres, r below the fluid's surface by volume, and a body would
  /// feel the head of a column r lower than its own. `same_surface`: surface_ and colour_
  /// as the last call left them (the same positions and densities).
  void raiseSurfacePressure(bool same_surface);
  /// raiseSurfacePressure's surface test: surface_, colour_ (the outward normals there),
  /// surface_count_ and the raise's terms (surface_terms_, surface_weight_) from the
  /// positions and densities.
  void findSurface();
  /// PressureGradient::Consistent, after computeAccelerations' pair loop has left the
  /// fluid's sums G, B, E, S in gradient_sums_: adds each particle's pressure term (see
  /// computeAccelerations), with the walls' sums, plus extra[i] (when not null) to its
  /// acceleration.
  /// `keep_geometry`: also keeps what of each particle's term depends on the positions
  /// alone in pressure_geometry_ (computePressureAccelerations' same_positions).
  void addConsistentPressure(const Vec3* extra, bool keep_geometry = false);
  /// addConsistentPressure with pressure_geometry_ and the pressure's sums alone
  /// (kPressureSums per particle in gradient_sums_: G, S).
  void addKeptGeometryPressure();
  /// One particle's consistent pressure term from its sums (addConsistentPressure).
  static Vec3 pressureTerm(const Vec3& g, const Vec3& spread, const Vec3& symmetric,
                           const Vec3& own, const Eigen::Matrix3d& inverse, double w_det,
                           double w_spray, double inv_rho, double above_reference);

  /// Fits the grid to the bounds of the n points from `x` on for pairs within `radius`.
  void fitGrid(const Vec3* x, std::size_t n, double radius);
  /// Builds the candidates (into neighbors_) from reference_ (sorted positions); false
  /// when reference_ is not in the grid's order. Uses the step's scratch.
  bool buildCandidates();
  /// Whether some particle moved skin / 2 or more from reference_, or the particles
  /// are not those of reference_.
  bool movedFromReference() const;
  /// The square of the distance from its reference at which a particle counts as moved
  /// (a hair under skin / 2).
  double skinLimitSq() const;
  /// A build's views of the step's scratch: the sort's order, then the points' cells and
  /// the ids' gather space (3 n uint32); the positions rounded to float, as doubles (n),
  /// after them. Take the rounded view first: the order's lies within it.
  std::uint32_t* sortScratchOrder(std::size_t n);
  Vec3* sortScratchRounded(std::size_t n);
  /// The particles' positions rounded to float (n, into `rounded`), and whether each is
  /// less than skin / 2 from its own (else the skin is too thin for them: no candidates).
  bool roundedWithinSkin(Vec3* rounded) const;
  /// Whether a build now should list candidates: a skin, and the fastest particle needs
  /// kMinSkinSteps steps of dt to cross half of it.
  bool skinPays(double dt) const;
};

}  // namespace wake
