#include "sph/fluid.hpp"

#include "sph/pair_loops.hpp"

#include <omp.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace wake {

namespace {
template <class T>
void gather(const std::vector<T>& src, const std::uint32_t* order, T* dst) {
  const std::int64_t n = static_cast<std::int64_t>(src.size());
#pragma omp parallel for schedule(static)
  for (std::int64_t k = 0; k < n; ++k)
    dst[k] = src[order[k]];
}

template <class T>
void gather(const std::vector<T>& src, const std::uint32_t* order, std::vector<T>& dst) {
  dst.resize(src.size());
  gather(src, order, dst.data());
}

template <class T>
void compact(std::vector<T>& v, const std::vector<std::uint8_t>& remove) {
  std::size_t w = 0;
  for (std::size_t i = 0; i < v.size(); ++i)
    if (!remove[i]) v[w++] = v[i];
  v.resize(w);
}
}  // namespace

void FluidState::resize(std::size_t n) {
  forEachArray([&](auto& v) { v.resize(n); });
}

void FluidState::permute(const std::uint32_t* order, std::uint32_t* id_scratch) {
  // Persistent fields move with their particle, each gathered into the array of a field
  // derived each step after the sort (acceleration, density), which takes the old one's
  // storage in exchange: no second copy of the state is kept.
  gather(position, order, acceleration);
  position.swap(acceleration);
  gather(velocity, order, acceleration);
  velocity.swap(acceleration);
  gather(kinematic_viscosity, order, density);
  kinematic_viscosity.swap(density);
  gather(pressure, order, density);
  pressure.swap(density);
  if (keep_pressure_mean_) {
    gather(pressure_mean, order, density);
    pressure_mean.swap(density);
  }
  gather(id, order, id_scratch);
  std::copy(id_scratch, id_scratch + id.size(), id.begin());
}

void FluidState::removeIf(const std::vector<std::uint8_t>& remove) {
  forEachArray([&](auto& v) { compact(v, remove); });
}

void FluidState::append(const Vec3& x, const Vec3& v, std::uint32_t particle_id, double nu) {
  position.push_back(x);
  velocity.push_back(v);
  acceleration.push_back(Vec3::Zero());
  density.push_back(0.0);
  pressure.push_back(0.0);
  id.push_back(particle_id);
  kinematic_viscosity.push_back(nu);
  if (keep_pressure_mean_) pressure_mean.push_back(0.0);
}

void FluidState::keepPressureMean() {
  if (keep_pressure_mean_) return;
  keep_pressure_mean_ = true;
  pressure_mean = pressure;
}

void FluidState::reserve(std::size_t n) {
  forEachArray([&](auto& v) { v.reserve(n); });
}

void FluidState::shrinkToFit() {
  forEachArray([](auto& v) { v.shrink_to_fit(); });
}

Fluid::Fluid(const FluidParams& params, const Aabb& domain, FluidState* state)
    : params_(params),
      kernel_(params.smoothingLength()),
      domain_(domain),
      mass_(params.particleMass()),
      state_(state ? *state : own_) {
  // The grid is fitted to the particles when the lists are built; a domain-sized grid
  // (the fallback) must be possible. Not built here: its memory would stay with the grid.
  UniformGrid::check(domain, params.supportRadius());
  if (!(params.speed_of_sound > 0.0) || !std::isfinite(params.speed_of_sound))
    throw std::invalid_argument("fluid.speed_of_sound must be finite and > 0");
}

void Fluid::fitGrid(const Vec3* x, std::size_t count, double radius) {
  // Fit the grid to the particles' current bounds, cells of the search radius (27 cells
  // per query, of which a point's sphere reaches only some). Cells of half the radius (125
  // per query, fewer candidates) cost more: a cell then holds about one particle, so a
  // query is mostly the overhead of its ~25 rows of cells, not the distance tests, which
  // go four at a time along a row's run of points (SPHERIC-2 at 0.2 / 0.5 s, 105k
  // particles, one thread: 184 / 228 ns per particle for the lists with half-radius cells,
  // 118 / 133 with these; the sorted order reads neighbours no worse).
  const std::int64_t n = static_cast<std::int64_t>(count);
  double lo[3] = {domain_.max.x(), domain_.max.y(), domain_.max.z()};
  double hi[3] = {domain_.min.x(), domain_.min.y(), domain_.min.z()};
#pragma omp parallel for schedule(static) reduction(min : lo[:3]) reduction(max : hi[:3])
  for (std::int64_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], x[i][k]);
      hi[k] = std::max(hi[k], x[i][k]);
    }
  Aabb box{Vec3(lo[0], lo[1], lo[2]), Vec3(hi[0], hi[1], hi[2])};
  bounds_ = box;
  // Within the domain, whose grid of these cells was checked at construction.
  grid_.reset(box.empty() ? domain_ : box, radius, 1);
}

void Fluid::setNeighborSkin(double skin) {
  if (!(skin >= 0.0) || !std::isfinite(skin))
    throw std::invalid_argument("neighbour skin must be finite and >= 0");
  skin_ = skin;
  ++generation_;
  candidates_ready_ = false;
  reference_.clear();
}

void Fluid::restoreNeighborReference(const std::vector<Vec3>& position,
                                     const std::vector<std::uint32_t>& id) {
  reference_.resize(position.size());
  for (std::size_t i = 0; i < position.size(); ++i)
    reference_[i] = position[i].cast<float>();
  // Ids that are not one per position fit no particles: the next call builds.
  if (id.size() != position.size()) reference_.clear();
  reference_ids_ = idDigest(id);
  ++generation_;
  candidates_ready_ = false;
}

std::vector<std::uint32_t> Fluid::neighborReferenceIds() const {
  if (reference_.size() != state_.size() || idDigest(state_.id) != reference_ids_) return {};
  return state_.id;
}

namespace {
/// Slot i's share of Fluid::idDigest: splitmix64's finaliser (a bijection of 64-bit words
/// that mixes every bit) of (i, id).
std::uint64_t slotDigest(std::uint64_t i, std::uint32_t id) {
  std::uint64_t z = (i << 32) | id;
  z += 0x9e3779b97f4a7c15u;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9u;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebu;
  return z ^ (z >> 31);
}
}  // namespace

std::uint64_t Fluid::idDigest(const std::vector<std::uint32_t>& id) {
  std::uint64_t sum = 0;
  const std::int64_t n = static_cast<std::int64_t>(id.size());
#pragma omp parallel for schedule(static) reduction(+ : sum)
  for (std::int64_t i = 0; i < n; ++i)
    sum += slotDigest(static_cast<std::uint64_t>(i), id[i]);
  return sum;
}

bool Fluid::buildCandidates() {
  const double radius = kernel_.supportRadius() + skin_;
  // The reference in double precision after the sort's order and cells.
  const std::size_t n = reference_.size();
  Vec3* rounded = sortScratchRounded(n);
  std::uint32_t* order = sortScratchOrder(n);
  const std::int64_t sn = static_cast<std::int64_t>(n);
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < sn; ++i)
    rounded[i] = reference_[i].cast<double>();
  fitGrid(rounded, n, radius);
  grid_.sort(rounded, n, order, order + n);
  for (std::size_t k = 0; k < n; ++k)
    if (order[k] != k) return false;
  buildPairLists(grid_, rounded, n, radius, neighbors_, wide_lanes_);
  return true;
}

double Fluid::skinLimitSq() const {
  // Two particles each skin / 2 closer than at the build: a pair within the support that
  // was not a candidate. (A hair less than skin / 2: rounding in the distances.)
  const double limit = 0.5 * skin_ * (1.0 - 1e-9);
  return limit * limit;
}

std::uint32_t* Fluid::sortScratchOrder(std::size_t n) {
  return step_.view<std::uint32_t>(0, 3 * n);
}

Vec3* Fluid::sortScratchRounded(std::size_t n) {
  // After the order, the cells and the ids' gather (3 n uint32), at a double's alignment.
  return step_.view<Vec3>((12 * n + 7) / 8 * 8, n);
}

bool Fluid::movedFromReference() const {
  const std::size_t n = state_.size();
  if (reference_.size() != n) return true;
  const double limit_sq = skinLimitSq();
  int moved = 0;
  std::uint64_t ids = 0;  // idDigest(state_.id), in the same pass
  const std::int64_t sn = static_cast<std::int64_t>(n);
#pragma omp parallel for schedule(static) reduction(max : moved) reduction(+ : ids)
  for (std::int64_t i = 0; i < sn; ++i) {
    const bool far =
        !((state_.position[i] - reference_[i].cast<double>()).squaredNorm() < limit_sq);
    moved = std::max(moved, int(far));
    ids += slotDigest(static_cast<std::uint64_t>(i), state_.id[i]);
  }
  return moved != 0 || ids != reference_ids_;
}

bool Fluid::skinPays(double dt) const {
  if (!(skin_ > 0.0)) return false;
  double v_sq = 0.0;
  const std::int64_t sn = static_cast<std::int64_t>(state_.size());
#pragma omp parallel for schedule(static) reduction(max : v_sq)
  for (std::int64_t i = 0; i < sn; ++i)
    v_sq = std::max(v_sq, state_.velocity[i].squaredNorm());
  // NaN speeds compare false: skinned, and the health check reports them as before.
  return !(std::sqrt(v_sq) * dt * 2.0 * kMinSkinSteps > skin_);
}

void Fluid::updateNeighbors(double dt) {
  if (!(dt >= 0.0) || !std::isfinite(dt))
    throw std::invalid_argument("updateNeighbors: dt must be finite and >= 0");
  const double support = kernel_.supportRadius();
  if (skin_ > 0.0 && !reference_.empty()) {
    if (!candidates_ready_ && reference_.size() == state_.size())
      candidates_ready_ = buildCandidates();
    if (candidates_ready_ && !movedFromReference()) {
      keepPairsWithin(neighbors_, state_.position, support);
      return;
    }
  }
  ++builds_;
  ++generation_;
  // In the step's scratch: the sort's order, the points' cells, the ids' gather space, and
  // with a skin the positions rounded to float (the reference's: what the candidates are
  // listed of).
  const std::size_t n = state_.size();
  bool skinned = skinPays(dt);
  Vec3* rounded = skinned ? sortScratchRounded(n) : nullptr;
  std::uint32_t* order = sortScratchOrder(n);
  if (skinned) skinned = roundedWithinSkin(rounded);
  const Vec3* keys = skinned ? rounded : state_.position.data();
  fitGrid(keys, n, support + (skinned ? skin_ : 0.0));
  grid_.sort(keys, n, order, order + n);
  state_.permute(order, order + 2 * n);
  if (!skinned) {
    // No reference: the next call builds again.
    reference_.clear();
    candidates_ready_ = false;
    buildPairLists(grid_, state_.position, support, neighbors_, wide_lanes_);
    return;
  }
  ++skinned_builds_;
  reference_.resize(n);
  const std::int64_t sn = static_cast<std::int64_t>(n);
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < sn; ++i) {
    reference_[i] = state_.position[i].cast<float>();
    rounded[i] = reference_[i].cast<double>();  // in the sorted order now
  }
  reference_ids_ = idDigest(state_.id);
  buildPairLists(grid_, rounded, n, support + skin_, neighbors_, wide_lanes_);
  candidates_ready_ = true;
  keepPairsWithin(neighbors_, state_.position, support);
}

bool Fluid::roundedWithinSkin(Vec3* rounded) const {
  // As movedFromReference: every particle must be within skin / 2 of where the candidates
  // are listed from, from the start.
  const double limit_sq = skinLimitSq();
  int far = 0;
  const std::int64_t sn = static_cast<std::int64_t>(state_.size());
#pragma omp parallel for schedule(static) reduction(max : far)
  for (std::int64_t i = 0; i < sn; ++i) {
    rounded[i] = state_.position[i].cast<float>().cast<double>();
    far = std::max(far, int(!((state_.position[i] - rounded[i]).squaredNorm() < limit_sq)));
  }
  return far == 0;
}

namespace {

/// The pair loop's sums per particle: acc (3), lap (3) and two unused (rows of 4).
constexpr std::size_t kAccelerationSums = 8;
/// The consistent pressure force's sums per particle: G (3), B (6: xx yy zz xy xz yz),
/// E (3), S (3) and one unused, so that they load and store two at a time.
constexpr std::size_t kGradientSums = 16;
/// The sums of those that change with the pressure alone (Fluid::computePressureAccelerations
/// on the same positions): G (3), one unused, S (3), one unused.
constexpr std::size_t kPressureSums = 8;

/// x_a - x_b of point a = i and the group's neighbours j (a lane each).
template <class M>
inline void pairOffsets(const Vec3* x, std::int64_t i, const std::uint32_t* j, M& dx, M& dy,
                        M& dz) {
  const double* p[M::kWidth];
  for (int t = 0; t < M::kWidth; ++t)
    p[t] = x[j[t]].data();
  M xj, yj, zj;
  gather3Lanes(p, xj, yj, zj);
  dx = M::all(x[i].x()) - xj;
  dy = M::all(x[i].y()) - yj;
  dz = M::all(x[i].z()) - zj;
}

/// A group's W'(r) / r (a lane per neighbour): the `used` values stored at the lists'
/// position `at` of `known` (an unused lane repeats the first pair, as its index does), or,
/// without stored values, found from the squared distances.
template <class M>
inline M groupDerivatives(const double* known, std::uint64_t at, int used, const M& r_sq,
                          const CubicSplineKernel& kernel) {
  if (!known) return kernel.derivativeOverR(sqrt(r_sq));
  if (used == M::kWidth) return M::load(known + at);
  double d[M::kWidth];
  for (int t = 0; t < M::kWidth; ++t)
    d[t] = known[at + (t < used ? t : 0)];
  return M::load(d);
}

/// A group's per-pair terms (u: N sums, one vector per sum, a lane per neighbour) as
/// rows: row[t][k] holds the sums [k W, k W + W) of neighbour t (W = the row's width; N a
/// multiple of 4). A transpose per group instead of a shuffle per sum and neighbour.
template <int N>
inline void pairRows(const Lanes2* u, Lanes2 (*row)[N / 2]) {
  for (int k = 0; k < N / 2; ++k)
    transpose2(u[2 * k], u[2 * k + 1], row[0][k], row[1][k]);
}
#if defined(WAKE_HAS_LANES4)
template <int N>
WAKE_LANES4_FN void pairRows(const Lanes4* u, Lanes4 (*row)[N / 4]) {
  for (int k = 0; k < N / 4; ++k) {
    Lanes4 r[4];
    transpose4(u[4 * k], u[4 * k + 1], u[4 * k + 2], u[4 * k + 3], r);
    for (int t = 0; t < 4; ++t)
      row[t][k] = r[t];
  }
}
template <int N>
WAKE_LANES4_FN void pairRows(const Lanes2* u, Lanes4 (*row)[N / 4]) {
  for (int k = 0; k < N / 4; ++k) {
    Lanes2 lo[2], hi[2];
    transpose2(u[4 * k], u[4 * k + 1], lo[0], lo[1]);
    transpose2(u[4 * k + 2], u[4 * k + 3], hi[0], hi[1]);
    for (int t = 0; t < 2; ++t)
      row[t][k] = join(lo[t], hi[t]);
  }
}
#endif

/// A group's N per-pair terms u (per sum, a lane per neighbour) taken from a's sums
/// `own` one neighbour after the other (the list's order) and, where to[t] is not null,
/// added to neighbour t's (N doubles at to[t]): the terms odd in x_ab.
template <int N, class Acc, class M>
inline void subtractPairTerms(const M* u, int used, Acc* own, double* const* to) {
  constexpr int kW = Acc::kWidth;
  Acc row[M::kWidth][N / kW];
  pairRows<N>(u, row);
  for (int t = 0; t < used; ++t) {
    for (int k = 0; k < N / kW; ++k)
      own[k] = own[k] - row[t][k];
    if (to[t])
      for (int k = 0; k < N / kW; ++k)
        (Acc::load(to[t] + k * kW) + row[t][k]).store(to[t] + k * kW);
  }
}

/// Summation density of the particles [i0, i1) (range r of the pair lists), several
/// neighbours at a time (the kernel without branches). Each pair's kernel value is
/// computed once, from its lower index, and added to both particles' sums; a pair with a
/// particle before i0 is computed from inside the range. Each particle's terms are still
/// added in the order of its whole neighbour list (the earlier neighbours before i0, then
/// those in the range as the loop reaches them, then its later ones), so the sums are the
/// bits of one neighbour at a time, on any number of threads. `density` holds the partial
/// sums.
template <class L>
inline void densityRange(std::int64_t i0, std::int64_t i1, std::size_t r, const Vec3* x,
                         const PairLists& pairs, const CubicSplineKernel& kernel, double mass,
                         double self, double* density) {
  const std::uint32_t end = static_cast<std::uint32_t>(i1);
  auto sums = [&](std::int64_t i, const std::uint32_t* nb, std::uint64_t k, std::uint64_t e,
                  double start, bool both) {
    Lanes2 sum = Lanes2::all(start);  // lane 0: the sum (lane 1 the same)
    forEachNeighborGroup<L>(nb, k, e, [&](auto lanes, const std::uint32_t* j, int used) {
      using M = decltype(lanes);
      M dx, dy, dz;
      pairOffsets(x, i, j, dx, dy, dz);
      const M w = kernel.value(sqrt(dx * dx + dy * dy + dz * dz));
      sum = subtractInOrder(sum, -w, -w, used);  // sum - (-w) is sum + w, bit for bit
      if (!both) return;
      double* other[M::kWidth];
      for (int t = 0; t < M::kWidth; ++t)
        other[t] = j[t] < end ? density + j[t] : nullptr;
      addToOne(other, w, used);
    });
    return sum.lane0();
  };
  forEachListOfRange(
      pairs, r, i0, i1,
      [&](std::int64_t i, const std::uint32_t* nb, std::uint64_t k, std::uint64_t e, bool later) {
        density[i] = later ? self + mass * sums(i, nb, k, e, density[i], true)
                           : sums(i, nb, k, e, 0.0, false);
      });
}

void densityRange2(std::int64_t i0, std::int64_t i1, std::size_t r, const Vec3* x,
                   const PairLists& pairs, const CubicSplineKernel& kernel, double mass,
                   double self, double* density) {
  densityRange<Lanes2>(i0, i1, r, x, pairs, kernel, mass, self, density);
}
#if defined(WAKE_HAS_LANES4)
WAKE_TARGET_AVX void densityRange4(std::int64_t i0, std::int64_t i1, std::size_t r, const Vec3* x,
                                   const PairLists& pairs, const CubicSplineKernel& kernel,
                                   double mass, double self, double* density) {
  densityRange<Lanes4>(i0, i1, r, x, pairs, kernel, mass, self, density);
}
#endif

/// The colour gradient sum_b V_b grad W_ab (V_b = m / rho_b) of the particles [i0, i1),
/// into `colour` (4 per particle: x, y, z, unused; the partial sums), as densityRange:
/// each pair once, from its lower index, its terms added to both sides in the order of
/// each particle's list (a group's terms turned into rows: pairRows).
template <class L>
inline void colourRange(std::int64_t i0, std::int64_t i1, std::size_t r, const Vec3* x,
                        const PairLists& pairs, const CubicSplineKernel& kernel, double mass,
                        const double* inv_rho, double* colour) {
  const std::uint32_t end = static_cast<std::uint32_t>(i1);
  auto sums = [&](std::int64_t i, const std::uint32_t* nb, std::uint64_t k, std::uint64_t e,
                  bool both) {
    constexpr int kBlocks = 4 / L::kWidth;
    double* own = colour + 4 * i;
    L sum[kBlocks];
    for (int c = 0; c < kBlocks; ++c)
      sum[c] = both ? L::load(own + c * L::kWidth) : L::all(0.0);
    const L va = L::all(mass * inv_rho[i]);
    forEachNeighborGroup<L>(nb, k, e, [&](auto lanes, const std::uint32_t* j, int used) {
      using M = decltype(lanes);
      const M zero = M::all(0.0);
      M dx, dy, dz;
      pairOffsets(x, i, j, dx, dy, dz);
      const M dwr = kernel.derivativeOverR(sqrt(dx * dx + dy * dy + dz * dz));
      const M grad[4] = {dwr * dx, dwr * dy, dwr * dz, zero};  // grad_a W_ab
      L row[M::kWidth][kBlocks];
      pairRows<4>(grad, row);
      for (int t = 0; t < used; ++t) {
        const L vb = L::all(mass * inv_rho[j[t]]);
        for (int c = 0; c < kBlocks; ++c)
          sum[c] = sum[c] + row[t][c] * vb;
        if (!both || j[t] >= end) continue;
        double* to = colour + 4 * std::size_t(j[t]);
        for (int c = 0; c < kBlocks; ++c)
          (L::load(to + c * L::kWidth) - row[t][c] * va).store(to + c * L::kWidth);
      }
    });
    for (int c = 0; c < kBlocks; ++c)
      sum[c].store(own + c * L::kWidth);
  };
  forEachListOfRange(pairs, r, i0, i1, sums);
}

void colourRange2(std::int64_t i0, std::int64_t i1, std::size_t r, const Vec3* x,
                  const PairLists& pairs, const CubicSplineKernel& kernel, double mass,
                  const double* inv_rho, double* colour) {
  colourRange<Lanes2>(i0, i1, r, x, pairs, kernel, mass, inv_rho, colour);
}
#if defined(WAKE_HAS_LANES4)
WAKE_TARGET_AVX void colourRange4(std::int64_t i0, std::int64_t i1, std::size_t r, const Vec3* x,
                                  const PairLists& pairs, const CubicSplineKernel& kernel,
                                  double mass, const double* inv_rho, double* colour) {
  colourRange<Lanes4>(i0, i1, r, x, pairs, kernel, mass, inv_rho, colour);
}
#endif

}  // namespace

void Fluid::computeFluidDensity() {
  if (neighbors_.size() != state_.size())
    throw std::logic_error("Fluid::computeFluidDensity before updateNeighbors");
  const double self = mass_ * kernel_.value(0.0);
  auto range = densityRange2;
#if defined(WAKE_HAS_LANES4)
  if (wide_lanes_) range = densityRange4;
#endif
  forEachRange(neighbors_, [&](std::int64_t i0, std::int64_t i1, std::size_t r) {
    range(i0, i1, r, state_.position.data(), neighbors_, kernel_, mass_, self,
          state_.density.data());
  });
}

void Fluid::computePressure() {
  pressureTerms(true);
}

void Fluid::computePressureFromState(bool same_positions) {
  pressureTerms(false, same_positions);
}

void Fluid::pressureTerms(bool from_density, bool same_positions) {
  const std::int64_t n = static_cast<std::int64_t>(state_.size());
  inv_rho_.resize(state_.size());
  pressure_term_ = true;
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    if (from_density) state_.pressure[i] = params_.pressure(state_.density[i]);
    inv_rho_[i] = 1.0 / state_.density[i];
  }
  if (params_.pressure_gradient != PressureGradient::Consistent) {
    wall_sums_ = WallPressureSums{};
    return;
  }
  const std::size_t un = state_.size();
  wall_sums_.difference.assign(un, Vec3::Zero());
  wall_sums_.moments = !same_positions || wall_sums_.moment.size() != un;
  if (wall_sums_.moments) wall_sums_.moment.assign(un, std::array<double, 6>{});
  wall_sums_.spread.assign(un, Vec3::Zero());
  wall_sums_.symmetric.assign(un, Vec3::Zero());
  if (neighbors_.size() != un) {  // no lists yet: each particle's own pressure
    surface_.clear();
    surface_count_ = 0;
    wall_sums_.reference = state_.pressure;
    return;
  }
  raiseSurfacePressure(same_positions && surface_.size() == un);
  // The lowest pressure of each particle and its neighbours: a symmetric pair loop as the
  // others (each pair once, both sides; a minimum does not depend on the order).
  wall_sums_.reference = state_.pressure;
  const double* p = state_.pressure.data();
  double* low = wall_sums_.reference.data();
  forEachPairOnce(neighbors_, [&](std::size_t i, std::uint32_t j, bool both) {
    low[i] = std::min(low[i], p[j]);
    if (both) low[j] = std::min(low[j], p[i]);
  });
}

void Fluid::findSurface() {
  const std::size_t n = state_.size();
  surface_.assign(n, 0);
  const Vec3* x = state_.position.data();
  const double* inv_rho = inv_rho_.data();
  // The colour gradient sum_b V_b grad W_ab over the fluid's neighbours (it points into
  // the fluid at a free surface; the walls' samples are left out, so it points away from
  // a wall too, but there the walls' share fills the density up).
  // Into the force loop's scratch for G, B, E, S (4 of its 16 per particle), free until
  // computeAccelerations.
  gradient_sums_.resize(kGradientSums * n);
  double* colour_sums = gradient_sums_.data();
  auto range = colourRange2;
#if defined(WAKE_HAS_LANES4)
  if (wide_lanes_) range = colourRange4;
#endif
  forEachRange(neighbors_, [&](std::int64_t i0, std::int64_t i1, std::size_t rg) {
    range(i0, i1, rg, x, neighbors_, kernel_, mass_, inv_rho, colour_sums);
  });
  colour_.resize(n);
  surface_count_ = 0;
  const double h = kernel_.smoothingLength();
  for (std::size_t i = 0; i < n; ++i) {
    colour_[i] = Vec3(colour_sums[4 * i], colour_sums[4 * i + 1], colour_sums[4 * i + 2]);
    if (state_.density[i] < kSurfaceDensity * params_.rest_density &&
        colour_[i].norm() * h > kSurfaceColour) {
      surface_[i] = 1;
      colour_[i] = -colour_[i].normalized();  // the outward normal from here on
      ++surface_count_;
    }
  }
  if (surface_count_ == 0) return;
  // The terms of raiseSurfacePressure's sums: each surface particle a's neighbours b at
  // least r/2 below it (depth d_b = (x_a - x_b) . n_a) that are not at the surface, with
  // W_ab r / (r + d_b), listed per range of the pair lists in the symmetric loop's order
  // (the same terms in the same order on any number of threads), and sum_b W_ab.
  const double support = kernel_.supportRadius();
  const double r = params_.particle_radius;
  const std::uint8_t* surface = surface_.data();
  const Vec3* normal = colour_.data();
  surface_weight_.assign(n, 0.0);
  double* weight = surface_weight_.data();
  surface_terms_.resize(neighbors_.ranges());
  forEachRange(neighbors_, [&](std::int64_t i0, std::int64_t i1, std::size_t rg) {
    std::vector<SurfaceTerm>& terms = surface_terms_[rg];
    terms.clear();
    auto add = [&](std::uint32_t a, std::uint32_t b, const Vec3& d_ab, double w) {
      const double depth = d_ab.dot(normal[a]);
      if (depth < 0.5 * r) return;
      terms.push_back({a, b, w * r / (r + depth)});
      weight[a] += w;
    };
    const std::uint32_t end = static_cast<std::uint32_t>(i1);
    forEachListOfRange(
        neighbors_, rg, i0, i1,
        [&](std::int64_t i, const std::uint32_t* nb, std::uint64_t k, std::uint64_t e, bool later) {
          for (std::uint64_t q = k; q < e; ++q) {
            const std::uint32_t j = nb[q];
            const bool own = surface[i] && !surface[j];
            const bool other = later && j < end && surface[j] && !surface[i];
            if (!own && !other) continue;
            const Vec3 d = x[i] - x[j];
            const double dist = d.norm();
            if (dist >= support) continue;
            const double w = kernel_.value(dist);
            const std::uint32_t ia = static_cast<std::uint32_t>(i);
            if (own) add(ia, j, d, w);
            if (other) add(j, ia, -d, w);
          }
        });
  });
}

void Fluid::raiseSurfacePressure(bool same_surface) {
  if (!same_surface) findSurface();
  if (surface_count_ == 0) return;
  const std::size_t n = state_.size();
  // sum_b W_ab P_b r / (r + d_b) over the terms findSurface listed, per range in its order.
  surface_sums_.assign(n, 0.0);
  double* sums = surface_sums_.data();
  const double* p = state_.pressure.data();
  forEachRange(neighbors_, [&](std::int64_t, std::int64_t, std::size_t rg) {
    for (const SurfaceTerm& t : surface_terms_[rg])
      sums[t.a] += t.coefficient * p[t.b];
  });
  const std::uint8_t* surface = surface_.data();
  const double* weight = surface_weight_.data();
  const std::int64_t sn = static_cast<std::int64_t>(n);
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < sn; ++i)
    if (surface[i] && weight[i] > 0.0)
      state_.pressure[i] = std::max(state_.pressure[i], sums[i] / weight[i]);
}

void Fluid::computeWithoutPressure() {
  const std::int64_t n = static_cast<std::int64_t>(state_.size());
  inv_rho_.resize(state_.size());
  pressure_term_ = false;
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i)
    inv_rho_[i] = 1.0 / state_.density[i];
}

namespace {

/// What the pair loop of Fluid::computeAccelerations reads and writes.
struct AccelerationInputs {
  const Vec3 *x, *v;
  const double *rho, *inv_rho, *nu;
  const double* p;  ///< (n) the pressure, or null: no pressure term
  const PairLists* neighbors;
  const CubicSplineKernel* kernel;
  double eps_sq, visc, m;
  Vec3 gravity;
  const Vec3* add;  ///< (n) or null
  Vec3* out;
  double* sums;                        ///< (kAccelerationSums n) scratch: partial sums
  const PairDerivatives* derivatives;  ///< each pair's W'(r) / r, or null: computed here
  /// PressureGradient::Consistent: the pressure and its sums (kGradientSums per particle:
  /// G, B, E, S of Fluid::computeAccelerations), or null.
  const double* gradient_p = nullptr;
  double* gradient_sums = nullptr;
};

/// The pair loop of Fluid::computeAccelerations for the particles [i0, i1) (one thread's
/// range). kUniformNu: every particle has the same kinematic viscosity nu0 (one fluid: the
/// usual case), so Morris's coefficient is nu0 (1 / rho_a + 1 / rho_b) and the
/// per-neighbour viscosity is not read.
///
/// Several neighbours at a time: the kernel and the artificial viscosity's branch become
/// masks. Each pair is computed once, from its lower index, and its terms go to both
/// particles (negated for the other: every term is odd in x_ab and v_ab, and its factors
/// are symmetric sums, the same bits from either side), as in densityRange: each
/// particle's terms are added in its list's order, so the result is the bits of one
/// neighbour at a time over the whole list, on any number of threads:
///   acc -= m (P_a / rho_a^2 + P_b / rho_b^2 + Pi_ab) W'(r) / r x_ab,
///   Pi_ab = -visc / (rho_a + rho_b) (v_ab . x_ab) / (r^2 + eps^2) where v_ab . x_ab < 0,
///   lap += mu_ab W'(r) / r v_ab.
/// `sums` (kAccelerationSums per particle: acc, lap) holds the partial sums, each group's
/// terms turned into rows (pairRows) to be added neighbour by neighbour.
///
/// kConsistent: also each particle's sums of the consistent pressure force
/// (Fluid::computeAccelerations), from the same W'(r) / r (w'), in the same order:
///   G_a += V_b (P_b - P_a) w' x_ab,    G_b += V_a (P_b - P_a) w' x_ab,
///   B_a += -V_b w' x_ab x_ab^T,        B_b += -V_a w' x_ab x_ab^T,
///   E_a += m (1/rho_a^2 + 1/rho_b^2) w' x_ab,             E_b -= the same,
///   S_a += m (P_a/rho_a^2 + P_b/rho_b^2) w' x_ab,          S_b -= the same,
/// with V = m / rho; every term is the same bits from either side of its pair.
/// Adds a group's terms of the consistent pressure force to a's sums `own` (one
/// neighbour after the other: the list's order) and, where to[t] is not null, to
/// neighbour t's sums. `mine`: a's kSums terms (per sum, a lane per neighbour); `theirs`:
/// the neighbours' first kTheirSums terms (the full sums: G and B, the first 12; the
/// pressure's sums alone: G, the first 4), the rest of theirs a's negated.
template <int kSums, int kTheirSums, class Acc, class M>
inline void addGradientTerms(const M* mine, const M* theirs, int used, Acc* own,
                             double* const* to) {
  constexpr int kW = Acc::kWidth, kBlocks = kSums / kW, kTheirs = kTheirSums / kW;
  Acc row[M::kWidth][kBlocks], their_row[M::kWidth][kTheirs];
  pairRows<kSums>(mine, row);
  pairRows<kTheirSums>(theirs, their_row);
  for (int t = 0; t < used; ++t) {
    for (int k = 0; k < kBlocks; ++k)
      own[k] = own[k] + row[t][k];
    if (!to[t]) continue;
    for (int k = 0; k < kBlocks; ++k)
      (Acc::load(to[t] + k * kW) + (k < kTheirs ? their_row[t][k] : -row[t][k]))
          .store(to[t] + k * kW);
  }
}

template <class L, bool kUniformNu, bool kConsistent, bool kPressureOnly = false>
inline void accelerationRange(std::int64_t i0, std::int64_t i1, std::size_t r,
                              const AccelerationInputs& in) {
  static_assert(kConsistent || !kPressureOnly, "the pressure alone: the consistent sums");
  const PairLists& pairs = *in.neighbors;
  const CubicSplineKernel& kernel = *in.kernel;
  const Vec3 *x = in.x, *v = in.v;
  double* sums = in.sums;
  const double* p = in.p;
  const std::uint32_t end = static_cast<std::uint32_t>(i1);
  const double* dwr_later = in.derivatives ? in.derivatives->later[r].data() : nullptr;
  const double* dwr_before = in.derivatives ? in.derivatives->before[r].data() : nullptr;
  auto add = [&](std::int64_t i, const std::uint32_t* nb, std::uint64_t k, std::uint64_t e,
                 bool both) {
    // The stored W'(r) / r of these pairs (at the lists' positions k ..), if any.
    const double* known = in.derivatives ? (both ? dwr_later : dwr_before) : nullptr;
    std::uint64_t at = k;  // the position of the group's first pair
    double* own = kPressureOnly ? nullptr : sums + kAccelerationSums * i;
    const double pr2_i = p ? p[i] * in.inv_rho[i] * in.inv_rho[i] : 0.0;
    // (acc.x, acc.y, acc.z, lap.x, lap.y, lap.z, unused, unused), L::kWidth to a register.
    constexpr int kAccBlocks = int(kAccelerationSums) / L::kWidth;
    L acc_lap[kAccBlocks];
    if constexpr (!kPressureOnly)
      for (int c = 0; c < kAccBlocks; ++c)
        acc_lap[c] = both ? L::load(own + c * L::kWidth) : L::all(0.0);
    // kConsistent: the sums G, B, E, S (kGradientSums), L::kWidth to a register.
    double* own_g = kConsistent ? in.gradient_sums + kGradientSums * i : nullptr;
    constexpr int kBlocks = int(kGradientSums) / L::kWidth;
    L gs[kBlocks];
    double ri2 = 0, gp_i = 0, gpr2_i = 0;
    if constexpr (kConsistent) {
      for (int c = 0; c < kBlocks; ++c)
        gs[c] = both ? L::load(own_g + c * L::kWidth) : L::all(0.0);
      ri2 = in.inv_rho[i] * in.inv_rho[i];
      gp_i = in.gradient_p[i];
      gpr2_i = gp_i * ri2;
    }
    forEachNeighborGroup<L>(nb, k, e, [&](auto lanes, const std::uint32_t* j, int used) {
      using M = decltype(lanes);
      const M zero = M::all(0.0);
      const double* px[M::kWidth];
      for (int t = 0; t < M::kWidth; ++t)
        px[t] = x[j[t]].data();
      M xj, yj, zj;
      gather3Lanes(px, xj, yj, zj);
      const M dx = M::all(x[i].x()) - xj, dy = M::all(x[i].y()) - yj, dz = M::all(x[i].z()) - zj;
      const M r_sq = dx * dx + dy * dy + dz * dz;
      const M dwr = groupDerivatives(known, at, used, r_sq, kernel);
      at += static_cast<std::uint64_t>(used);
      const M inv_rho_j = gatherLanes(zero, in.inv_rho, j);
      // The viscous terms and the symmetric pressure term (none with kPressureOnly).
      if constexpr (!kPressureOnly) {
        const double* pv[M::kWidth];
        for (int t = 0; t < M::kWidth; ++t)
          pv[t] = v[j[t]].data();
        M uj, vj, wj;
        gather3Lanes(pv, uj, vj, wj);
        const M du = M::all(v[i].x()) - uj, dv = M::all(v[i].y()) - vj, dw = M::all(v[i].z()) - wj;
        // P / rho^2 of each side, (P rho^-1) rho^-1 (one neighbour at a time: the same bits).
        M coeff = zero;
        if (p) coeff = M::all(pr2_i) + gatherLanes(zero, p, j) * inv_rho_j * inv_rho_j;
        const M vx = du * dx + dv * dy + dw * dz;
        coeff =
            select(vx < zero,
                   coeff + M::all(-in.visc) / (M::all(in.rho[i]) + gatherLanes(zero, in.rho, j)) *
                               vx / (r_sq + M::all(in.eps_sq)),
                   coeff);
        const M f = M::all(in.m) * coeff * dwr;
        // Morris: x . grad W / |x|^2 = dW/dr / r (< 0), so v_a is drawn towards v_b.
        const M mu = kUniformNu ? M::all(in.nu[0]) * (inv_rho_j + M::all(in.inv_rho[i]))
                                : M::all(in.nu[i]) * inv_rho_j +
                                      gatherLanes(zero, in.nu, j) * M::all(in.inv_rho[i]);
        const M g = mu * dwr;
        // lap += g v_ab, written as lap -= -(g v_ab) (the same bits).
        const M terms[kAccelerationSums] = {f * dx,    f * dy,    f * dz, -(g * du),
                                            -(g * dv), -(g * dw), zero,   zero};
        double* other[M::kWidth];
        for (int t = 0; t < M::kWidth; ++t)
          other[t] = both && j[t] < end ? sums + kAccelerationSums * std::size_t(j[t]) : nullptr;
        subtractPairTerms<int(kAccelerationSums)>(terms, used, acc_lap, other);
      }
      if constexpr (kConsistent) {
        const M pj = gatherLanes(zero, in.gradient_p, j);
        const M rj2 = inv_rho_j * inv_rho_j;
        const M dp = (pj - M::all(gp_i)) * dwr;  // (P_b - P_a) w'
        const M ew = M::all(in.m) * (M::all(ri2) + rj2) * dwr;
        const M sym = M::all(in.m) * (M::all(gpr2_i) + pj * rj2) * dwr;
        // G's and B's terms of each side, with the other side's volume V.
        auto difference = [&](M volume, M* u) {
          const M gv = volume * dp, b = -volume * dwr;
          const M gb[9] = {gv * dx,     gv * dy,     gv * dz,     b * dx * dx, b * dy * dy,
                           b * dz * dz, b * dx * dy, b * dx * dz, b * dy * dz};
          std::copy(gb, gb + 9, u);
        };
        M mine[kGradientSums], theirs[12];
        difference(M::all(in.m) * inv_rho_j, mine);
        const M e_s[7] = {ew * dx, ew * dy, ew * dz, sym * dx, sym * dy, sym * dz, zero};
        std::copy(e_s, e_s + 7, mine + 9);
        difference(M::all(in.m * in.inv_rho[i]), theirs);
        for (int c = 9; c < 12; ++c)
          theirs[c] = -mine[c];
        double* to[M::kWidth];
        for (int t = 0; t < M::kWidth; ++t)
          to[t] =
              both && j[t] < end ? in.gradient_sums + kGradientSums * std::size_t(j[t]) : nullptr;
        addGradientTerms<int(kGradientSums), 12>(mine, theirs, used, gs, to);
      }
    });
    if constexpr (kConsistent) {
      for (int c = 0; c < kBlocks; ++c)
        gs[c].store(own_g + c * L::kWidth);
    }
    if constexpr (kPressureOnly) return;  // the accelerations: addConsistentPressure
    for (int c = 0; c < kAccBlocks; ++c)
      acc_lap[c].store(own + c * L::kWidth);
    if (!both) return;
    Vec3 acc(own[0], own[1], own[2]);
    const Vec3 lap(own[3], own[4], own[5]);
    acc += in.m * lap + in.gravity;
    if (in.add) acc += in.add[i];
    in.out[i] = acc;
  };
  forEachListOfRange(pairs, r, i0, i1, add);
}

template <bool kUniformNu, bool kConsistent, bool kPressureOnly = false>
void accelerationRange2(std::int64_t i0, std::int64_t i1, std::size_t r,
                        const AccelerationInputs& in) {
  accelerationRange<Lanes2, kUniformNu, kConsistent, kPressureOnly>(i0, i1, r, in);
}
#if defined(WAKE_HAS_LANES4)
template <bool kUniformNu, bool kConsistent, bool kPressureOnly = false>
WAKE_TARGET_AVX void accelerationRange4(std::int64_t i0, std::int64_t i1, std::size_t r,
                                        const AccelerationInputs& in) {
  accelerationRange<Lanes4, kUniformNu, kConsistent, kPressureOnly>(i0, i1, r, in);
}
#endif

/// The consistent pressure force's sums that change with the pressure, G and S
/// (kPressureSums per particle), of the particles [i0, i1): accelerationRange's terms of
/// them, from the same W'(r) / r in the same order (the same bits), without the moment B
/// and E, which depend on the positions and densities alone.
template <class L>
inline void pressureSumsRange(std::int64_t i0, std::int64_t i1, std::size_t r,
                              const AccelerationInputs& in) {
  const PairLists& pairs = *in.neighbors;
  const CubicSplineKernel& kernel = *in.kernel;
  const Vec3* x = in.x;
  const std::uint32_t end = static_cast<std::uint32_t>(i1);
  const double* dwr_later = in.derivatives ? in.derivatives->later[r].data() : nullptr;
  const double* dwr_before = in.derivatives ? in.derivatives->before[r].data() : nullptr;
  auto add = [&](std::int64_t i, const std::uint32_t* nb, std::uint64_t k, std::uint64_t e,
                 bool both) {
    const double* known = in.derivatives ? (both ? dwr_later : dwr_before) : nullptr;
    std::uint64_t at = k;
    double* own_g = in.gradient_sums + kPressureSums * i;
    constexpr int kBlocks = int(kPressureSums) / L::kWidth;
    L gs[kBlocks];
    for (int c = 0; c < kBlocks; ++c)
      gs[c] = both ? L::load(own_g + c * L::kWidth) : L::all(0.0);
    const double ri2 = in.inv_rho[i] * in.inv_rho[i];
    const double gp_i = in.gradient_p[i];
    const double gpr2_i = gp_i * ri2;
    forEachNeighborGroup<L>(nb, k, e, [&](auto lanes, const std::uint32_t* j, int used) {
      using M = decltype(lanes);
      const M zero = M::all(0.0);
      M dx, dy, dz;
      pairOffsets(x, i, j, dx, dy, dz);
      const M dwr = groupDerivatives(known, at, used, dx * dx + dy * dy + dz * dz, kernel);
      at += static_cast<std::uint64_t>(used);
      const M inv_rho_j = gatherLanes(zero, in.inv_rho, j);
      const M pj = gatherLanes(zero, in.gradient_p, j);
      const M rj2 = inv_rho_j * inv_rho_j;
      const M dp = (pj - M::all(gp_i)) * dwr;  // (P_b - P_a) w'
      const M sym = M::all(in.m) * (M::all(gpr2_i) + pj * rj2) * dwr;
      const M gv = (M::all(in.m) * inv_rho_j) * dp, gu = M::all(in.m * in.inv_rho[i]) * dp;
      const M mine[kPressureSums] = {gv * dx,  gv * dy,  gv * dz,  zero,
                                     sym * dx, sym * dy, sym * dz, zero};
      const M theirs[4] = {gu * dx, gu * dy, gu * dz, zero};
      double* to[M::kWidth];
      for (int t = 0; t < M::kWidth; ++t)
        to[t] = both && j[t] < end ? in.gradient_sums + kPressureSums * std::size_t(j[t]) : nullptr;
      addGradientTerms<int(kPressureSums), 4>(mine, theirs, used, gs, to);
    });
    for (int c = 0; c < kBlocks; ++c)
      gs[c].store(own_g + c * L::kWidth);
  };
  forEachListOfRange(pairs, r, i0, i1, add);
}

void pressureSumsRange2(std::int64_t i0, std::int64_t i1, std::size_t r,
                        const AccelerationInputs& in) {
  pressureSumsRange<Lanes2>(i0, i1, r, in);
}
#if defined(WAKE_HAS_LANES4)
WAKE_TARGET_AVX void pressureSumsRange4(std::int64_t i0, std::int64_t i1, std::size_t r,
                                        const AccelerationInputs& in) {
  pressureSumsRange<Lanes4>(i0, i1, r, in);
}
#endif

}  // namespace

void Fluid::computeAccelerations(const Vec3& gravity, const std::vector<Vec3>& extra,
                                 const PairDerivatives* derivatives) {
  accelerationPass(gravity, extra, derivatives, false);
}

void Fluid::computePressureAccelerations(const PairDerivatives* derivatives, bool same_positions) {
  if (!pressure_term_ || params_.pressure_gradient != PressureGradient::Consistent)
    throw std::logic_error(
        "Fluid::computePressureAccelerations: the consistent pressure gradient's pressure only");
  const std::size_t un = state_.size();
  if (!same_positions || pressure_geometry_.size() != kPressureGeometry * un) {
    accelerationPass(Vec3::Zero(), {}, derivatives, true);  // keeps the geometry
    return;
  }
  if (neighbors_.size() != un)
    throw std::logic_error("Fluid::computePressureAccelerations before updateNeighbors");
  const WallPressureSums& walls = wall_sums_;
  if (walls.difference.size() != un || walls.spread.size() != un || walls.symmetric.size() != un ||
      walls.reference.size() != un)
    throw std::logic_error(
        "Fluid::computePressureAccelerations: the walls' pressure sums are not this step's");
  if (derivatives && (derivatives->later.size() != neighbors_.ranges() ||
                      derivatives->before.size() != neighbors_.ranges()))
    throw std::invalid_argument("computePressureAccelerations: derivatives of other pair lists");
  AccelerationInputs in{};
  in.x = state_.position.data();
  in.inv_rho = inv_rho_.data();
  in.neighbors = &neighbors_;
  in.kernel = &kernel_;
  in.m = mass_;
  in.derivatives = derivatives;
  in.gradient_p = state_.pressure.data();
  gradient_sums_.resize(kGradientSums * un);  // the first kPressureSums n of it
  in.gradient_sums = gradient_sums_.data();
  auto range = pressureSumsRange2;
#if defined(WAKE_HAS_LANES4)
  if (wide_lanes_) range = pressureSumsRange4;
#endif
  forEachRange(neighbors_,
               [&](std::int64_t i0, std::int64_t i1, std::size_t r) { range(i0, i1, r, in); });
  state_.acceleration.assign(un, Vec3::Zero());
  addKeptGeometryPressure();
}

void Fluid::accelerationPass(const Vec3& gravity, const std::vector<Vec3>& extra,
                             const PairDerivatives* derivatives, bool pressure_only) {
  if (neighbors_.size() != state_.size())
    throw std::logic_error("Fluid::computeAccelerations before updateNeighbors");
  const std::size_t un = state_.size();
  const std::int64_t n = static_cast<std::int64_t>(un);
  const double* nu = state_.kinematic_viscosity.data();
  bool uniform = true;
  for (std::int64_t i = 1; i < n && uniform; ++i)
    uniform = nu[i] == nu[0];
  const double h = kernel_.smoothingLength();
  AccelerationInputs in;
  in.x = state_.position.data();
  in.v = state_.velocity.data();
  in.rho = state_.density.data();
  in.inv_rho = inv_rho_.data();
  in.nu = nu;
  in.p = pressure_term_ ? state_.pressure.data() : nullptr;
  const bool consistent =
      pressure_term_ && params_.pressure_gradient == PressureGradient::Consistent;
  if (consistent) {
    // The pair loop takes the consistent form's sums instead of the symmetric pressure
    // term; addConsistentPressure turns them into the force after it.
    const WallPressureSums& walls = wall_sums_;
    if (walls.difference.size() != un || walls.moment.size() != un || walls.spread.size() != un ||
        walls.symmetric.size() != un || walls.reference.size() != un)
      throw std::logic_error(
          "Fluid::computeAccelerations: the walls' pressure sums are not this step's");
    gradient_sums_.resize(kGradientSums * un);
    in.gradient_p = in.p;
    in.gradient_sums = gradient_sums_.data();
    in.p = nullptr;
  }
  in.neighbors = &neighbors_;
  in.kernel = &kernel_;
  in.eps_sq = 0.01 * h * h;
  // nu = 2 alpha H c / (rho_a + rho_b): the numerator is constant.
  in.visc = 2.0 * params_.viscosity * h * params_.speed_of_sound;
  in.m = mass_;
  in.gravity = gravity;
  in.add = extra.empty() ? nullptr : extra.data();  // before the resize: extra may be it
  if (in.add && extra.size() != un)
    throw std::invalid_argument("computeAccelerations: extra is not one per particle");
  // Consistent: `extra` joins the pressure term (addConsistentPressure), after the loop
  // has written the accelerations (a copy if they are the same array).
  std::vector<Vec3> extra_copy;
  const Vec3* pressure_extra = nullptr;
  if (consistent && in.add) {
    if (extra.data() == state_.acceleration.data()) extra_copy = extra;
    pressure_extra = extra_copy.empty() ? in.add : extra_copy.data();
    in.add = nullptr;
  }
  if (pressure_only)  // the pair loop writes no accelerations: addConsistentPressure adds
    state_.acceleration.assign(un, Vec3::Zero());
  else
    state_.acceleration.resize(un);
  in.out = state_.acceleration.data();
  using Range = void (*)(std::int64_t, std::int64_t, std::size_t, const AccelerationInputs&);
  // [uniform][consistent]
  Range range[2][2] = {{accelerationRange2<false, false>, accelerationRange2<false, true>},
                       {accelerationRange2<true, false>, accelerationRange2<true, true>}};
  Range pressure_loop = accelerationRange2<true, true, true>;
#if defined(WAKE_HAS_LANES4)
  if (wide_lanes_) {
    range[0][0] = accelerationRange4<false, false>;
    range[0][1] = accelerationRange4<false, true>;
    range[1][0] = accelerationRange4<true, false>;
    range[1][1] = accelerationRange4<true, true>;
    pressure_loop = accelerationRange4<true, true, true>;
  }
#endif
  const Range loop = pressure_only ? pressure_loop : range[uniform][consistent];
  // The viscous and symmetric terms' partial sums (none for the pressure alone: the step's
  // scratch is left as it is).
  in.sums = pressure_only ? nullptr : step_.view<double>(0, kAccelerationSums * un);
  in.derivatives = derivatives;
  if (derivatives && (derivatives->later.size() != neighbors_.ranges() ||
                      derivatives->before.size() != neighbors_.ranges()))
    throw std::invalid_argument("computeAccelerations: derivatives of other pair lists");
  forEachRange(neighbors_,
               [&](std::int64_t i0, std::int64_t i1, std::size_t r) { loop(i0, i1, r, in); });
  if (consistent) addConsistentPressure(pressure_extra, /*keep_geometry=*/pressure_only);
}

namespace {

/// The smallest eigenvalue of a symmetric 3x3 matrix (Eigen's closed form).
double smallestEigenvalue(const Eigen::Matrix3d& m) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(m, Eigen::EigenvaluesOnly);
  return solver.eigenvalues()(0);
}

}  // namespace

void Fluid::addConsistentPressure(const Vec3* extra, bool keep_geometry) {
  const WallPressureSums& walls = wall_sums_;
  const double* sums = gradient_sums_.data();
  const double* inv_rho = inv_rho_.data();
  const double* p = state_.pressure.data();
  Vec3* out = state_.acceleration.data();
  const std::int64_t n = static_cast<std::int64_t>(state_.size());
  if (keep_geometry) pressure_geometry_.assign(kPressureGeometry * state_.size(), 0.0);
  double* geometry = keep_geometry ? pressure_geometry_.data() : nullptr;
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    const double* s = sums + kGradientSums * i;
    Eigen::Matrix3d b;
    b(0, 0) = s[3];
    b(1, 1) = s[4];
    b(2, 2) = s[5];
    b(0, 1) = b(1, 0) = s[6];
    b(0, 2) = b(2, 0) = s[7];
    b(1, 2) = b(2, 1) = s[8];
    // Spray, a sheet or a film one particle thick: the fluid's own neighbours do not
    // surround it in some direction, and the corrected gradient, whose walls' samples
    // stand at the fluid's pressure, would not push it off what it meets. The symmetric
    // form, walls' included, does, as the pressure integral pushes the body. Between the
    // two by the moment's smallest eigenvalue, so that the force is continuous in the
    // particles' arrangement.
    // Gershgorin's bound first: in the bulk (B near I) no eigenvalue needs solving for.
    const double bound = std::min({b(0, 0) - std::abs(b(0, 1)) - std::abs(b(0, 2)),
                                   b(1, 1) - std::abs(b(0, 1)) - std::abs(b(1, 2)),
                                   b(2, 2) - std::abs(b(0, 2)) - std::abs(b(1, 2))});
    const double w_spray = bound >= kSprayMoment[1]
                               ? 1.0
                               : std::clamp((smallestEigenvalue(b) - kSprayMoment[0]) /
                                                (kSprayMoment[1] - kSprayMoment[0]),
                                            0.0, 1.0);
    double* kept = geometry ? geometry + kPressureGeometry * i : nullptr;
    if (kept) {
      kept[10] = w_spray;
      for (int c = 0; c < 3; ++c)
        kept[11 + c] = s[9 + c];  // E
    }
    const Vec3 own = extra ? extra[i] : Vec3::Zero();
    const Vec3 symmetric = own - Vec3(s[12], s[13], s[14]) + walls.symmetric[i];
    if (w_spray == 0.0) {
      out[i] += symmetric;
      continue;
    }
    const std::array<double, 6>& bw = walls.moment[i];
    b(0, 0) += bw[0];
    b(1, 1) += bw[1];
    b(2, 2) += bw[2];
    b(0, 1) = b(1, 0) = s[6] + bw[3];
    b(0, 2) = b(2, 0) = s[7] + bw[4];
    b(1, 2) = b(2, 1) = s[8] + bw[5];
    const Vec3 g = Vec3(s[0], s[1], s[2]) + walls.difference[i];
    const Vec3 spread = Vec3(s[9], s[10], s[11]) + walls.spread[i];
    const double det = b.determinant();
    // Nearly singular (few neighbours): the sum uncorrected, between the two by det B.
    const double w_det = std::clamp(
        (det - kMomentDeterminant[0]) / (kMomentDeterminant[1] - kMomentDeterminant[0]), 0.0, 1.0);
    Eigen::Matrix3d inverse = Eigen::Matrix3d::Identity();
    if (w_det > 0.0) inverse = b.inverse();
    if (kept) {
      kept[9] = w_det;
      Eigen::Map<Eigen::Matrix3d> kept_inverse(kept);
      kept_inverse = inverse;
    }
    out[i] += pressureTerm(g, spread, symmetric, own, inverse, w_det, w_spray, inv_rho[i],
                           p[i] - walls.reference[i]);
  }
}

Vec3 Fluid::pressureTerm(const Vec3& g, const Vec3& spread, const Vec3& symmetric, const Vec3& own,
                         const Eigen::Matrix3d& inverse, double w_det, double w_spray,
                         double inv_rho, double above_reference) {
  const Vec3 grad_p = w_det > 0.0 ? Vec3(w_det * (inverse * g) + (1.0 - w_det) * g) : g;
  const Vec3 consistent = own - inv_rho * grad_p - kRepulsion * above_reference * spread;
  return w_spray == 1.0 ? consistent : Vec3(w_spray * consistent + (1.0 - w_spray) * symmetric);
}

void Fluid::addKeptGeometryPressure() {
  const WallPressureSums& walls = wall_sums_;
  const double* sums = gradient_sums_.data();
  const double* geometry = pressure_geometry_.data();
  const double* inv_rho = inv_rho_.data();
  const double* p = state_.pressure.data();
  Vec3* out = state_.acceleration.data();
  const std::int64_t n = static_cast<std::int64_t>(state_.size());
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    const double* s = sums + kPressureSums * i;  // G, unused, S, unused
    const double* kept = geometry + kPressureGeometry * i;
    const Vec3 own = Vec3::Zero();
    const Vec3 symmetric = own - Vec3(s[4], s[5], s[6]) + walls.symmetric[i];
    const double w_spray = kept[10];
    if (w_spray == 0.0) {
      out[i] += symmetric;
      continue;
    }
    const Vec3 g = Vec3(s[0], s[1], s[2]) + walls.difference[i];
    const Vec3 spread = Vec3(kept[11], kept[12], kept[13]) + walls.spread[i];
    const Eigen::Matrix3d inverse = Eigen::Map<const Eigen::Matrix3d>(kept);
    out[i] += pressureTerm(g, spread, symmetric, own, inverse, kept[9], w_spray, inv_rho[i],
                           p[i] - walls.reference[i]);
  }
}

double Fluid::maxSpeed() const {
  double m = 0.0;
  const std::int64_t n = static_cast<std::int64_t>(state_.size());
#pragma omp parallel for reduction(max : m) schedule(static)
  for (std::int64_t i = 0; i < n; ++i)
    m = std::max(m, state_.velocity[i].squaredNorm());
  return std::sqrt(m);
}

double Fluid::maxKinematicViscosity() const {
  double m = 0.0;
  const std::int64_t n = static_cast<std::int64_t>(state_.size());
#pragma omp parallel for reduction(max : m) schedule(static)
  for (std::int64_t i = 0; i < n; ++i)
    m = std::max(m, state_.kinematic_viscosity[i]);
  return m;
}

double Fluid::maxAcceleration() const {
  double m = 0.0;
  const std::int64_t n = static_cast<std::int64_t>(state_.size());
#pragma omp parallel for reduction(max : m) schedule(static)
  for (std::int64_t i = 0; i < n; ++i)
    m = std::max(m, state_.acceleration[i].squaredNorm());
  return std::sqrt(m);
}

void Fluid::predict(double dt) {
  FluidState& st = state_;
  const std::int64_t n = static_cast<std::int64_t>(st.size());
  Vec3* v_old = step_.view<Vec3>(0, 2 * st.size());
  Vec3* x_pred = v_old + n;
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    v_old[i] = st.velocity[i];
    st.velocity[i] += dt * st.acceleration[i];
    x_pred[i] = st.position[i] + dt * st.velocity[i];
  }
}

void Fluid::predictPositions(double dt) {
  const FluidState& st = state_;
  const std::int64_t n = static_cast<std::int64_t>(st.size());
  Vec3* x_pred = step_.view<Vec3>(0, 2 * st.size()) + n;
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i)
    x_pred[i] = st.position[i] + dt * st.velocity[i];
}

void Fluid::integratePositions(double dt) {
  FluidState& st = state_;
  const std::int64_t n = static_cast<std::int64_t>(st.size());
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i)
    st.position[i] += dt * st.velocity[i];
}

}  // namespace wake
