// An incompressible pressure solver for the fluid: Divergence-Free SPH (Bender & Koschier,
// SCA 2015 / TVCG 2017), with the boundary's share of the density (DESIGN.md §5b). Two
// Jacobi-style solves per step, each a pressure impulse that changes velocities only:
// - the divergence solve makes the velocity field at the step's start free of compression
//   (d rho / dt <= 0);
// - the density solve makes the predicted velocities v* (every non-pressure force in them)
//   carry each particle to the rest density at the step's end: rho + dt d rho / dt <= rho0.
//
// With g_ab = m grad_a W_ab (a fluid pair), the boundary's G_a = sum_k rho0 V_k grad_a W_ak
// and B_a = sum_k rho0 V_k v_k . grad_a W_ak (the samples k of the walls and bodies, moving at
// v_k), the rate of change of particle a's density is
//   D_a = sum_b (v_a - v_b) . g_ab + v_a . G_a - B_a.
// A pressure term s (= dt p / rho^2, m^5 / (kg s)) changes velocities by
//   dv_a = -sum_b (s_a + s_b) g_ab - (s_a + s^w_a) G_a,
// the symmetric SPH pressure force over one step (for a pressure level s it also pushes
// -2 s (sum_b g_ab + G_a), zero only where a particle's own density is level: it holds the
// particles' arrangement with a stiffness in proportion to the pressure, and a slowly moving
// body under a few centimetres of fluid feels twice its drag; docs/forces.md, "DFSPH's
// excess drag is the pressure level"), with the walls' samples at the pressure
// of the fluid around them (as the weakly compressible walls, Boundaries::addWallPressure):
// s^w_a = (s_a + sum_b w_ab s_b / sum_b w_ab) / 2, w_ab = |g_ab|^2. A sample that mirrored
// the particle's own pressure alone (s^w_a = s_a) left a particle pressed against a wall
// by its neighbours with no push back whenever its own density was low (a wall layer, a
// tank's edges): the fluid's pressure drove it into the wall each step, the velocity
// control stopped it there, and a column at rest kept moving at 0.03-0.05 m/s. The mean
// is taken over at least |G_a| max|g_ab| (s_a making up what is missing): over a's own
// weight alone, one fluid neighbour beside a wall fed its increment through a's walls back
// into its own rate, and the solve diverged (DivergenceFreeSolver::computeFactors).
// Its own s_a changes D_a by about -s_a / a_a, with the factor
//   a_a = 1 / ((sum_b g_ab + G_a) . (C sum_b g_ab + 3/2 G_a) + tr(C) / 3 sum_b |g_ab|^2)
// (C the gradient correction below; I without it), at walls its denominator at least 0.35
// of the bulk's (DivergenceFreeSolver::kFactorFloor: fluid trapped between walls).
// Each iteration raises s_a by what removes particle a's own compression (never lowers it:
// no pull) and applies all of them at once. The density solve starts from 0.6 of the last
// step's pressure where the fluid is compressed (warm start; SPlisHSPlasH takes half), so
// a column at rest needs few iterations and a pressure no longer needed fades
// (DivergenceFreeSolver::kWarmStart).
//
// Under gravity the samples' pressure also has the fluid's weight between them and the fluid
// around the particle (the hydrostatic part of the walls' pressure, as
// Boundaries::computeSamplePressure): once per density solve,
//   dv_a = -dt (H_a + l_a G_a / rho0),
// H_a = sum_k V_k chi g . (x_k - x_a) grad_a W_ak (SolverBoundary::hydrostatic): a sample
// below a (chi = 1) has more pressure than a by the weight between, one above (a floating
// body's underside, a lid; chi = chi_a) less. l_a = -g . c_a with c_a the centre of the fluid
// around a (relative to a, with the weights of s^w_a), times chi_a where negative (the
// fluid around a lies below it). chi_a in [0, 1] (SolverBoundary::above_share) is a's mean
// pressure P_a (the state's pressure_mean, an exponential mean over kPressureMeanTime) over
// the weight of a support's height of fluid: deep in the fluid the samples above a have
// all of the difference, near the free surface less, never a pull (towards a lid or a
// body's underside that the fluid barely touches). Without the samples above, a box of half
// the water's density floated 8 % too high. The mean pressure, not the last step's: under
// a light floating body the pressure comes in kicks (3 kPa for a step, then near 0 for
// several, around a mean of 0.3 kPa under a box of 0.3 the water's density), and chi_a of
// each step's pressure fell below 1 between kicks: the box floated 5 % high.
//
// The walls' and bodies' side of the impulse is the fluid's pressure force on them:
// wallImpulse() and wallLift() give it per particle for the coupling
// (Boundaries::addSolverReaction, with SolverBoundary::above_share).
//
// The bodies that push moves (dynamic two-way bodies) move in the solves as it pushes them.
// With J_a = (G^b_a; rho0 sum_k V_k r_k x grad_a W_ak) over body b's samples (BodyLink), a
// change (u, omega) of b's velocity changes B_a by J_a . (u; omega), and the solves' push on
// b so far is I_b = sum_a m (wall impulse of a) J_a (plus the hydrostatic part in the
// density solve). The rates see b moving at its velocity plus M_b^-1 (I_b - dt F_b), F_b the
// density solve's push in the last step (SolverBody::last_force): the body's other forces
// (gravity, its contacts) are taken to balance what the fluid last pushed with; the
// divergence solve's push counts whole. Held at its velocity, a light body boxed in by
// walls (a box jammed across a narrow tank) rocked: the pressure that stopped it in one
// step threw it back in the next, each push the opposite of the last and larger (the
// added mass of the fluid it must move, several times its own, in an explicit coupling).
// Each iteration takes out of the increments what the body's answer to them does: the
// body's change d_b is the one for which the increments ds'_a = max(ds_a - a_a J_a . d_b,
// -s_a) push it by M_b d_b (their push taken as 2 m ds' J_a: a's own 3/2 and half the mean
// of its neighbours'); piecewise linear and monotone in d_b, found by Newton's steps with
// S_b = sum 2 m a_a J_a J_a^T over the particles not held at -s_a (shareWithBodies). Where
// nothing is held this is the Jacobi step preconditioned by the diagonal plus the body's
// rank-6 part (Woodbury). Left to the rates alone, a light body overshoots each iteration
// (all the fluid around it pushes as if it were held: S_b many times its mass) and the
// solve diverges; with Woodbury's step but the increments cut at -s_a after it, the
// push was more than the step allowed for, and the divergence solve, which starts from s
// = 0, diverged beside a sphere of 0.10 the water's density. In a linear model of added
// mass mu times the body's mass, a push answered only in the next step grows by 1 - mu a
// step (unstable beyond mu = 2); seen within the solve against the last step's push it
// decays by sqrt(mu / (1 + mu)) a step at any mu.
//
// The fluid pairs' impulse goes through a correction of SPH's gradient (DfsphParams::
// correct_gradient): -(s_a + s_b) C g_ab, C = M^-1 with M the mean over the bulk of each
// particle's second moment M_a = sum_b V_b x_ba (x) grad_a W_ab (V_b = m / rho0; the
// integral's is I). The pressure that holds a column at rest is the one whose SPH gradient
// carries its weight, so it is off by as much as M is from I on the arrangement the
// particles settle in: 1.020 on the cubic lattice, 0.988 (vertical) in a column settled at
// r = 4 or 5 mm, 1.008 at 5.5 mm; the column's pressure was +0.44..+0.91 / +1.31..+1.90 /
// +0.05..+0.85 / -0.55..+0.15 / +1.20..+2.00 % of the weight above at r = 4 / 4.5 / 5 /
// 5.5 / 6 mm, and with C -0.89..-0.22 / +0.00..+0.76 / -0.80..-0.17 / +0.09..+0.58 /
// +0.32..+0.92 % (the frames' running mean, over the tank's section and 0.25 s:
// tests/physics, Solvers.HydrostaticPressureIsTheWeightAbove...). One matrix for the fluid: the
// pair sums stay antisymmetric (C sum_ab = 0: no momentum made), it costs a 3 x 3 product
// per particle and impulse, and a pass over the lists for the moments. A correction per
// particle (Bonet & Lok's L_a, with L_ab = (L_a + L_b) / 2 to keep momentum) also corrects
// where the arrangement varies, but needs L_b per pair in every impulse (or a second set
// of stored gradients) and a fallback where the support is cut (free surfaces, walls).
// The walls' and bodies' terms keep the plain gradient (their samples' volumes are
// calibrated on the density, not on M).
//
// prepareLists() stores each particle's whole neighbour list with its pairs' g_ab (floats;
// a pair is computed once and stored in both lists), summing the fluid's densities in the
// same pass and keeping each pair's W'(r) / r for the viscous forces, so that the
// iterations only read: each particle's sums over its own list, four pairs at a time in
// four partial sums fixed by the list (AVX where the CPU has it, two SSE2 lanes twice where
// not: the same bits), the error norms in fixed chunks: the same bits on any number of
// threads. The step's first rates also sum each particle's g_ab and |g_ab|^2 (the factors'
// inputs), and an iteration's impulse is applied to each particle as the pass reaches it.
#pragma once

#include "sph/fluid.hpp"

#include <cstdint>
#include <vector>

namespace wake {

/// The divergence-free solver's settings (the scene's fluid.dfsph).
struct DfsphParams {
  /// Average predicted compression max(0, rho* / rho0 - 1) over the particles at which the
  /// density solve stops, in (0, 0.1]. A tighter tolerance is not a more accurate pressure
  /// at rest: a column's rho g h came out within +0.7..+2.3 / +0.7..+3.0 / -2.8..+1.0 % at r
  /// = 4 / 5 / 6 mm with 3e-4 and +1.7..+2.5 / -0.9..+1.4 / +2.4..+4.2 % with 1e-4
  /// (SPlisHSPlasH's 0.01 %; WCSPH +0.9..+2.5 / +0.3..+1.8 / -1.7..+2.2 %): the error goes
  /// with the arrangement the particles settle in, not with the solve's last residual; 1e-4
  /// costs twice the iterations (SPHERIC-2: 7.5 per step against 3.8).
  double max_density_error = 3e-4;
  /// Average compression rate dt max(0, d rho / dt) / rho0 (over the particles with
  /// enough neighbours for a rate: not splashes) at which the divergence solve stops, in
  /// (0, 1].
  double max_divergence_error = 1e-3;
  int max_iterations = 100;             ///< density solve, >= 2 (it runs at least 2)
  int max_divergence_iterations = 100;  ///< divergence solve, >= 0 (0: no divergence solve)
  /// The fluid pairs' pressure impulse through the gradient correction C
  /// (DivergenceFreeSolver::gradientCorrection): SPH's pressure gradient on the arrangement
  /// the particles settle in is off by a few per cent (a column at rest: M_yy 0.988 at r = 4
  /// and 5 mm, 1.008 at 5.5 mm), and so is the pressure that holds the fluid up.
  bool correct_gradient = true;
  /// The pressure force the density solve finds the pressure for. Symmetric: DFSPH's own
  /// impulses (this file), with the divergence solve and the bodies moving within the solves.
  /// Consistent (experimental): the weakly compressible fluid's consistent pressure force
  /// with the pressure from a projected Jacobi solve for the density its equation of state
  /// gives (rho0 + p / c^2; coupling/consistent_solve.hpp), no divergence solve, the bodies
  /// pushed by their samples' pressure after it: a slowly moving body's drag within 4 % of
  /// the law at r = 1.5 mm where the symmetric form gives two to three times it, at about
  /// 5 times the cost per step (docs/forces.md, "DFSPH with the consistent pressure force").
  enum class PressureForce { Symmetric, Consistent };
  PressureForce pressure_force = PressureForce::Symmetric;
};

/// Iterations and errors of one step's solves.
struct DfsphStats {
  int density_iterations = 0;
  int divergence_iterations = 0;
  double density_error = 0;     ///< the density solve's last average error (fraction)
  double divergence_error = 0;  ///< the divergence solve's last average error (fraction)
};

/// A particle's link to a body that the fluid's pressure moves (a dynamic two-way body),
/// for the density solve's view of that body (see SolverBoundary::links).
struct BodyLink {
  std::uint32_t particle = 0;
  std::uint32_t body = 0;  ///< index into SolverBoundary::bodies
  /// (G^b_a; rho0 sum_k V_k r_k x grad_a W_ak) over the body's samples k (r_k from its centre
  /// of mass, world): the change of B_a for a change (u, omega) of the body's velocity is
  /// the dot product with (u; omega); the body's push from particle a's walls' pressure s^w
  /// is m s^w times it.
  double flux[6] = {0, 0, 0, 0, 0, 0};
  /// The body's part of H_a with its moment (m/s^2, m^2/s^2).
  double hydrostatic[6] = {0, 0, 0, 0, 0, 0};
};

/// A body the fluid's pressure moves, as the density solve sees it.
struct SolverBody {
  /// The inverse of its 6 x 6 mass matrix (1/kg, then the world inverse inertia).
  double inverse_mass = 0.0;
  Eigen::Matrix3d inverse_inertia = Eigen::Matrix3d::Zero();
  /// The density solve's pressure force and torque on it in the last step (N, N m):
  /// what the other forces on it are taken to balance in this one.
  Vec3 last_force = Vec3::Zero(), last_torque = Vec3::Zero();
};

/// The walls' and bodies' part of the solves, per fluid particle (all empty: no boundary;
/// Boundaries::solverTerms fills them).
struct SolverBoundary {
  std::vector<Vec3> gradient;  ///< (n) G_a = rho0 sum_k V_k grad_a W_ak (kg/m^4)
  std::vector<double> flux;    ///< (n) B_a = rho0 sum_k V_k v_k . grad_a W_ak (kg/(m^3 s))
  std::vector<std::uint32_t> neighbors;  ///< (n) samples within the kernel support
  /// (n) H_a = sum_k V_k chi g . (x_k - x_a) grad_a W_ak (m/s^2): the weight of the fluid
  /// between a and the samples below it (chi = 1), less chi_a that between a and those above.
  std::vector<Vec3> hydrostatic;
  /// (n) chi_a in [0, 1]: a's mean pressure (the state's pressure_mean; its pressure before
  /// the first solve keeps one) over the weight of a support's height of fluid.
  std::vector<double> above_share;
  /// The links of the particles near bodies the pressure moves, in particle order (empty:
  /// the bodies are held at their velocities in B_a through the solves).
  std::vector<BodyLink> links;
  std::vector<SolverBody> bodies;  ///< those bodies (BodyLink::body)
};

class DivergenceFreeSolver {
 public:
  /// s: the time over which the state's pressure_mean follows the pressure (each step
  /// moves it dt / (kPressureMeanTime + dt) of the way): several times the kicks' period
  /// under a light floating body (about 5 ms).
  static constexpr double kPressureMeanTime = 0.02;
  /// The share of the last step's pressure the density solve starts from where the fluid
  /// would be compressed (its iterations only add pressure: what is not needed fades by
  /// this factor a step). SPHERIC-2 (1 s, 4 ms, one thread): 4,886 / 3,745 / 3,452 / 3,199
  /// density iterations at 0.5 / 0.6 / 0.65 / 0.7; a column at rest (r = 4 / 5 / 5.5 mm)
  /// moves at 0.0083 / 0.0073 / 0.0100 m/s rms with 0.6, 0.012-0.013 with 0.7 and 0.75,
  /// 0.006-0.009 with 0.5.
  static constexpr double kWarmStart = 0.6;
  /// Fluid trapped where it cannot get out of the way: a layer of particles between a
  /// plate coming down and a box on the floor, in a gap narrower than a particle. The
  /// walls on either side of such a particle cancel in G_a and few fluid neighbours are
  /// left, so its own pressure barely changes its density (a_a's denominator near 0), and
  /// its compression cannot be removed in one step at all. The Jacobi step then asked for
  /// pressures of 1e5 -> 1e10 Pa within 5 ms and threw the fluid out of the tank
  /// (scenes/squeeze.json: 2,277 of 2,308 particles lost; with max_dt from 0.1 to 4 ms,
  /// and beside a static box too). Two bounds keep each step's answer to what it can do:
  /// - at walls, a_a's denominator is at least kFactorFloor of the bulk's, sum_b |g_ab|^2
  ///   on the cubic lattice: a particle whose own pressure acts on it much less than on
  ///   one with a neighbourhood is not pushed as if it acted more (away from walls a
  ///   particle keeps its factor: the free surface's, a drop's);
  /// - where that floor holds, the density solve counts the particle's compression up to
  ///   kMaxCorrection of rho0 (what a step removes of a larger one; the rest is left to
  ///   the next steps).
  /// Either alone still diverged in the squeeze (the floor from 0.19 s at 0.5 or 1 of the
  /// bulk's value; the cap at 1 % on every particle from 0.185 s). Capping every particle
  /// also let the dam break's most compressed particle reach 1.147 rho0 (test bound 1.1),
  /// so the cap is for the held particles only. The floor's share, measured: with 0.25 the
  /// squeeze at twice the resolution (--resolution 1.5) lost a particle; with 0.5 a wall
  /// particle at the surface of a column at rest (r = 4 mm) jumped at 0.116 m/s (bound
  /// 0.111); 0.35 passes both, and the squeeze with the plate at twice the speed, with
  /// time.cfl 0.6 and 4 ms steps, with 0.25 ms steps and with global control (no particle
  /// lost, none in a body, largest density ratio 1.27-1.59), and leaves the 5 mm column's
  /// figures as they were.
  static constexpr double kFactorFloor = 0.35;
  static constexpr double kMaxCorrection = 0.01;

  explicit DivergenceFreeSolver(const DfsphParams& params) : params_(params) {}

  const DfsphParams& params() const { return params_; }

  /// After the neighbour lists of this step, in place of Fluid::computeFluidDensity: each
  /// pair's mass-weighted kernel gradient g_ab into the solver's lists, each particle's
  /// sums of them, and the fluid's summation density into the state (the bits of
  /// computeFluidDensity: one pass over the pairs for both, each pair's distance found
  /// once). prepare() then takes these lists (the same neighbour lists and positions).
  void prepareLists(Fluid& fluid);

  /// After the neighbour lists and the densities (with the boundary's share) of this step:
  /// each pair's mass-weighted kernel gradient g_ab (prepareLists' when it ran for these
  /// lists, else built here) and each particle's factor a_a. `boundary` must outlive the
  /// step's solves.
  void prepare(const Fluid& fluid, const SolverBoundary& boundary);

  /// The divergence solve on the fluid's velocities; `dt` (s) only scales the error measure
  /// (the step's size is not yet known: the last one). Returns the iterations taken.
  int solveDivergence(Fluid& fluid, double dt);

  /// The density solve on the predicted velocities v* (the fluid's velocities) for a step
  /// of `dt` under `gravity`, starting from the state's pressure (the last step's); writes
  /// the pressure it found, p = rho^2 s / dt, to the state and moves the state's
  /// pressure_mean towards it (kept from the first solve on). Returns the iterations taken.
  int solveDensity(Fluid& fluid, const Vec3& gravity, double dt);

  /// (n) The sum of s_a + s^w_a over this step's solves (prepare() clears it): the walls'
  /// and bodies' pressure share of particle a's velocity change was -wallImpulse[a] G_a.
  const std::vector<double>& wallImpulse() const { return wall_impulse_; }
  /// (n) l_a of this step's density solve (m^2/s^2; zero without one, faded by chi_a where
  /// negative): the hydrostatic share of a's velocity change was
  /// -dt (H_a + wallLift[a] G_a / rho0).
  const std::vector<double>& wallLift() const { return lift_; }

  /// (bodies of the step's SolverBoundary) The density solve's pressure force and torque on
  /// each body it moves (N, N m: the push of its walls' pressure and their hydrostatic part
  /// over the step, divided by dt): the next step's SolverBody::last_force / last_torque.
  const std::vector<Vec3>& bodyForces() const { return body_force_; }
  const std::vector<Vec3>& bodyTorques() const { return body_torque_; }

  const DfsphStats& stats() const { return stats_; }

  /// The step's correction C of the fluid's pressure gradient (prepare(); the identity
  /// before, or with DfsphParams::correct_gradient off): the inverse of the mean second
  /// moment M = sum_b V_b x_ba (x) grad_a W_ab (V_b = m / rho0) over the particles whose
  /// own M is within 0.1 of the identity on the diagonal and 0.05 off it (the bulk: a full
  /// support of fluid; of a fluid of more than 2 kMomentSamples particles, those of a
  /// fixed sample of about kMomentSamples). The fluid pairs' pressure impulse is
  /// -(s_a + s_b) C g_ab.
  const Eigen::Matrix3d& gradientCorrection() const { return correction_; }
  /// How many particles the step's C was averaged over (0: C is the identity).
  std::size_t bulkParticles() const { return bulk_; }

  /// W'(r) / r of each pair of the fluid's pair lists as the last lists were built (for
  /// Fluid::computeAccelerations in the same step: the viscous forces without a square root
  /// and kernel per pair).
  const PairDerivatives& pairDerivatives() const { return derivatives_; }

 private:
  /// Each particle's whole neighbour list with the pairs' g_ab, per range of the pair lists
  /// (a range's particles [i0, i1) are its rows q = i - i0): the neighbours of row q,
  /// ascending, are index[offset[q] .. offset[q] + size[q]), g_ab the floats (gx, gy, gz)
  /// there; rows are padded to multiples of four with the particle itself and g = 0. A pair
  /// in one range is computed once and stored in both rows (g_ba = -g_ab; cursor: where
  /// the next earlier neighbour of a row goes while they are built).
  struct Lists {
    std::vector<std::uint32_t> offset, index, size, cursor;
    std::vector<float> gx, gy, gz;
    std::vector<double> scratch;  ///< one row's gradients as they are computed
    std::vector<double> kernel;   ///< one row's kernel values (with the density)
  };
  /// Builds range r's lists; with `density` not null, the fluid's summation density of the
  /// range's particles into it.
  void buildLists(const PairLists& pairs, std::size_t r, const Vec3* x,
                  const CubicSplineKernel& kernel, double mass, bool wide, double* density);
  /// Every range's lists, and the density where not null.
  void buildAllLists(const Fluid& fluid, double* density);
  /// The moments are summed for about this many particles (all of a fluid up to twice as
  /// many; else those whose permanent number is a multiple of n / kMomentSamples): in
  /// SPHERIC-2's dam break (105k particles, 84-90k of them bulk) C from the ~3,400 bulk
  /// particles of the sample was within 0.0004 of C from all of them (every 25th step
  /// over the first 0.3 s), and the pass costs a twenty-fifth of the whole one (with the
  /// whole pass: 3.07x / 2.98x less wall time than WCSPH in two runs, against 3.08-3.23x in
  /// six runs before the correction).
  static constexpr std::size_t kMomentSamples = 4096;
  /// correction_ and bulk_ from moment_ (the step's lists).
  void findCorrection(double rest_density);
  /// factor_, sparse_ and centre_ from the gradient sums of the step's first rates.
  void computeFactors();
  /// row(i, lists, k, e) for every particle i, its row being [k, e) of its range's lists
  /// (ranges in parallel).
  template <class RowF>
  void forEachListRow(const PairLists& pairs, RowF&& row) const;
  /// range(i0, i1, view) for every range of particles [i0, i1) and its lists, in parallel.
  template <class RangeF>
  void forEachRow(const PairLists& pairs, RangeF&& range);
  /// D_a (rate of change of density) of every particle into rate_; the step's first also
  /// sums each particle's g_ab and |g_ab|^2 (grad_sum_, weight_) and finds the factors.
  void densityRates(const Fluid& fluid);
  /// Applies the increments ds_ (s per particle) to the velocities (and velocity_f_) and to
  /// s_, wall_impulse_.
  void applyImpulse(Fluid& fluid);
  /// The hydrostatic part of the walls' pressure (see above) on the velocities, into lift_.
  void applyHydrostatic(Fluid& fluid, const Vec3& gravity, double dt);
  using Vec6 = Eigen::Matrix<double, 6, 1>;
  using Mat6 = Eigen::Matrix<double, 6, 6>;
  /// Each body's push in this density solve so far (impulse_), and the change of its
  /// velocity that the fluid sees (seen_): that push less the last step's, over its mass.
  void seeBodies(const Fluid& fluid, double dt, bool density);
  /// impulse_, seen_, inverse_mass_ and response_ for the step's solves (after the factors).
  void prepareBodies();
  /// The bodies' seen velocities in the rates: D_a -= J^b_a . seen_b.
  void ratesWithBodies();
  /// The increments ds with each body's answer to them taken out (see above).
  void shareWithBodies(double mass);
  static constexpr int kShareSteps = 8;  ///< Newton steps of shareWithBodies at most
  /// sum over i of f(i) (a number or an Eigen vector), in fixed chunks (the same bits on any
  /// number of threads).
  template <class F>
  static auto chunkedSum(std::size_t n, F&& f);

  DfsphParams params_;
  DfsphStats stats_;
  std::vector<Lists> lists_;     ///< (ranges)
  PairDerivatives derivatives_;  ///< of the fluid's pair lists
  static constexpr std::size_t kNoLists = ~std::size_t(0);
  /// The particles prepareLists built lists for, not yet taken by prepare (kNoLists: none).
  std::size_t lists_particles_ = kNoLists;
  const SolverBoundary* boundary_ = nullptr;  ///< null: no boundary
  std::vector<double> factor_;                ///< (n) a_a (m^8 / kg^2)
  /// (6 n) sum_b g_ab (x) (x_b - x_a) of each particle (xx, yy, zz, xy, xz, yz; kg/m^3):
  /// rho0 times its fluid's second moment M_a (empty without correct_gradient).
  std::vector<double> moment_;
  Eigen::Matrix3d correction_ = Eigen::Matrix3d::Identity();  ///< C, see gradientCorrection
  std::size_t bulk_ = 0;                                      ///< see bulkParticles
  std::vector<Vec3> grad_sum_;                                ///< (n) sum_b g_ab (kg/m^4)
  std::vector<std::uint8_t> sparse_;     ///< (n) too few neighbours for the divergence solve
  std::vector<std::uint8_t> held_;       ///< (n) a_a's denominator raised to the floor
  std::vector<std::uint8_t> near_wall_;  ///< (n) G_a != 0: samples in a's support
  std::vector<double> weight_;           ///< (n) sum_b w_ab = sum_b |g_ab|^2
  std::vector<std::uint32_t> count_;     ///< (n) fluid neighbours
  std::vector<Vec3> offset_;             ///< (n) sum_b w_ab (x_b - x_a) (near walls)
  std::vector<Vec3> centre_;             ///< (n) c_a (m, with a boundary)
  bool factors_ready_ = false;           ///< the step's first rates found the factors
  double factor_floor_ = 0.0;            ///< a_a's denominator below this: no pressure
  double denominator_floor_ = 0.0;       ///< kFactorFloor of the lattice's sum |g_ab|^2
  std::uint32_t enough_neighbors_ = 0;   ///< fewer (fluid and walls): sparse_
  std::vector<double> weight_floor_;     ///< (n) the least weight of s^w_a's mean
  double largest_gradient_ = 0.0;        ///< max |g_ab| (kg/m^4)
  std::vector<double> rate_;             ///< (n) D_a
  std::vector<float> velocity_f_;        ///< (4 n) the velocities as floats
  bool floats_fresh_ = false;            ///< velocity_f_ is of the velocities as they are
  bool rates_fresh_ = false;             ///< rate_ is of the velocities as they are
  std::vector<double> s_;                ///< (n) this solve's s so far
  std::vector<double> ds_;               ///< (n) this iteration's increment of s
  std::vector<double> wall_impulse_;     ///< (n) sum of s_a + s^w_a over the step's solves
  std::vector<double> lift_;             ///< (n) l_a of the density solve
  // The bodies the density solve moves (SolverBoundary::links, bodies).
  bool bodies_ready_ = false;             ///< prepareBodies ran for this step
  std::vector<Vec6> impulse_;             ///< (bodies) the step's push so far (N s, N m s)
  std::vector<Vec6> divergence_impulse_;  ///< (bodies) the divergence solve's part of it
  std::vector<Vec6> seen_;                ///< (bodies) velocity change seen (m/s, rad/s)
  std::vector<Mat6> inverse_mass_;        ///< (bodies) M^-1
  std::vector<Vec6> answer_, residual_;   ///< (bodies) shareWithBodies' d and push
  std::vector<Mat6> stiffness_;           ///< (bodies) shareWithBodies' S of the free links
  std::vector<Vec3> body_force_, body_torque_;
};

}  // namespace wake
