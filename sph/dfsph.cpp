#include "sph/dfsph.hpp"

#include "sph/lanes.hpp"
#include "sph/pair_loops.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <type_traits>

namespace wake {

namespace {

/// Calls f(d) for each point of the fluid's lattice (spacing s) closer to a particle than
/// the support, d its distance; the particle itself left out.
template <class F>
void forEachLatticeNeighbor(const FluidParams& p, F&& f) {
  const double reach = p.supportRadius() / p.spacing();
  const int k = static_cast<int>(std::ceil(reach));
  for (int x = -k; x <= k; ++x)
    for (int y = -k; y <= k; ++y)
      for (int z = -k; z <= k; ++z) {
        const int d2 = x * x + y * y + z * z;
        if (d2 > 0 && d2 < reach * reach) f(p.spacing() * std::sqrt(double(d2)));
      }
}

/// Neighbours of a particle inside a fluid at rest on the lattice (spacing s, support 2H).
int latticeNeighbors(const FluidParams& p) {
  int count = 0;
  forEachLatticeNeighbor(p, [&](double) { ++count; });
  return count;
}

/// sum_b |g_ab|^2 over such a particle's neighbours on the lattice.
double latticeWeight(const FluidParams& p, const CubicSplineKernel& kernel, double mass) {
  double sum = 0.0;
  forEachLatticeNeighbor(p, [&](double r) {
    const double g = mass * kernel.derivativeOverR(r) * r;
    sum += g * g;
  });
  return sum;
}

/// The largest |g_ab| = m |grad W| of any pair (m times the kernel's steepest slope).
double largestGradient(const CubicSplineKernel& kernel, double mass) {
  double most = 0.0;
  const int samples = 2000;
  for (int k = 1; k < samples; ++k) {
    const double r = kernel.supportRadius() * k / samples;
    most = std::max(most, std::abs(kernel.derivativeOverR(r)) * r);
  }
  return mass * most;
}

/// g_ab = m grad_a W(x_a - x_b) of a's neighbours nb[0 .. count) into g[3 t + c], several
/// at a time in L (Lanes2, Lanes4: per lane the scalar operations, the same bits), and
/// W'(r) / r into d[t]; where w is not null, W(|x_a - x_b|) into w[t] (the distance as
/// Fluid::computeFluidDensity and computeAccelerations form it: the same bits).
template <class L>
inline void rowGradients(const Vec3& xa, const Vec3* x, const std::uint32_t* nb,
                         std::uint32_t count, const CubicSplineKernel& kernel, double mass,
                         double* g, double* d, double* w) {
  constexpr int W = L::kWidth;
  alignas(32) double out[5][W];
  for (std::uint32_t k = 0; k < count; k += W) {
    const double* p[W];
    for (int t = 0; t < W; ++t)
      p[t] = x[nb[k + t < count ? k + t : count - 1]].data();
    L xb, yb, zb;
    gather3Lanes(p, xb, yb, zb);
    const L dx = L::all(xa.x()) - xb, dy = L::all(xa.y()) - yb, dz = L::all(xa.z()) - zb;
    const L r = sqrt(dx * dx + dy * dy + dz * dz);
    const L dwr = kernel.derivativeOverR(r);
    const L f = L::all(mass) * dwr;
    (f * dx).store(out[0]);
    (f * dy).store(out[1]);
    (f * dz).store(out[2]);
    dwr.store(out[3]);
    if (w) kernel.value(r).store(out[4]);
    for (int t = 0; t < W && k + t < count; ++t) {
      for (int c = 0; c < 3; ++c)
        g[3 * (k + t) + c] = out[c][t];
      d[k + t] = out[3][t];
      if (w) w[k + t] = out[4][t];
    }
  }
}

/// sum_b |g_ab|^2 (x_b - x_a) of particle a's row (padded to groups of four; the padding adds
/// zeros) in four partial sums of Q (Quad2, Lanes4: the same bits).
template <class Q>
inline Vec3 rowOffsets(const std::uint32_t* index, const float* gx, const float* gy,
                       const float* gz, std::uint32_t k, std::uint32_t e, const Vec3* x,
                       std::size_t a) {
  Q ox = Q::all(0.0), oy = ox, oz = ox;
  const Q xa = Q::all(x[a].x()), ya = Q::all(x[a].y()), za = Q::all(x[a].z());
  for (std::uint32_t t = k; t < e; t += 4) {
    const Q u = Q::loadFloats(gx + t), v = Q::loadFloats(gy + t), w = Q::loadFloats(gz + t);
    const Q s = (u * u + v * v) + w * w;
    const std::uint32_t* j = index + t;
    const double* p[4] = {x[j[0]].data(), x[j[1]].data(), x[j[2]].data(), x[j[3]].data()};
    Q xb, yb, zb;
    Q::gather3(p, xb, yb, zb);
    ox = ox + s * (xb - xa);
    oy = oy + s * (yb - ya);
    oz = oz + s * (zb - za);
  }
  return Vec3(ox.total(), oy.total(), oz.total());
}

/// sum_b g_ab (x) (x_b - x_a) of particle a's row (xx, yy, zz, xy, xz, yz; the padding adds
/// zeros) into m, in four partial sums of Q (Quad2, Lanes4: the same bits).
template <class Q>
inline void rowMoments(const std::uint32_t* index, const float* gx, const float* gy,
                       const float* gz, std::uint32_t k, std::uint32_t e, const Vec3* x,
                       std::size_t a, double* m) {
  Q xx = Q::all(0.0), yy = xx, zz = xx, xy = xx, xz = xx, yz = xx;
  const Q xa = Q::all(x[a].x()), ya = Q::all(x[a].y()), za = Q::all(x[a].z());
  for (std::uint32_t t = k; t < e; t += 4) {
    const Q u = Q::loadFloats(gx + t), v = Q::loadFloats(gy + t), w = Q::loadFloats(gz + t);
    const std::uint32_t* j = index + t;
    const double* p[4] = {x[j[0]].data(), x[j[1]].data(), x[j[2]].data(), x[j[3]].data()};
    Q xb, yb, zb;
    Q::gather3(p, xb, yb, zb);
    const Q dx = xb - xa, dy = yb - ya, dz = zb - za;
    xx = xx + u * dx;
    yy = yy + v * dy;
    zz = zz + w * dz;
    xy = xy + u * dy;
    xz = xz + u * dz;
    yz = yz + v * dz;
  }
  m[0] = xx.total();
  m[1] = yy.total();
  m[2] = zz.total();
  m[3] = xy.total();
  m[4] = xz.total();
  m[5] = yz.total();
}

#if defined(WAKE_HAS_LANES4)
WAKE_TARGET_AVX void rowMoments4(const std::uint32_t* index, const float* gx, const float* gy,
                                 const float* gz, std::uint32_t k, std::uint32_t e, const Vec3* x,
                                 std::size_t a, double* m) {
  rowMoments<Lanes4>(index, gx, gy, gz, k, e, x, a, m);
}
WAKE_TARGET_AVX void rowGradients4(const Vec3& xa, const Vec3* x, const std::uint32_t* nb,
                                   std::uint32_t count, const CubicSplineKernel& kernel,
                                   double mass, double* g, double* d, double* w) {
  rowGradients<Lanes4>(xa, x, nb, count, kernel, mass, g, d, w);
}
WAKE_TARGET_AVX Vec3 rowOffsets4(const std::uint32_t* index, const float* gx, const float* gy,
                                 const float* gz, std::uint32_t k, std::uint32_t e, const Vec3* x,
                                 std::size_t a) {
  return rowOffsets<Lanes4>(index, gx, gy, gz, k, e, x, a);
}
#endif

}  // namespace

void DivergenceFreeSolver::buildLists(const PairLists& pairs, std::size_t r, const Vec3* x,
                                      const CubicSplineKernel& kernel, double mass, bool wide,
                                      double* density) {
  Lists& L = lists_[r];
  const std::size_t i0 = pairs.range[r], i1 = pairs.range[r + 1], rows = i1 - i0;
  const std::vector<std::uint32_t>& before_offset = pairs.before_offset[r];
  const std::uint32_t* before = pairs.before[r].data();
  const std::uint32_t* later = pairs.later[r].data();
  auto earlier = [&](std::size_t q, std::uint32_t& k, std::uint32_t& e) {
    k = q + 1 < before_offset.size() ? before_offset[q] : 0;
    e = q + 1 < before_offset.size() ? before_offset[q + 1] : 0;
  };
  // Row sizes: the earlier neighbours before the range, those in it (each in the later
  // list of a lower row), the later ones.
  L.size.assign(rows, 0);
  for (std::size_t q = 0; q < rows; ++q) {
    const std::size_t i = i0 + q;
    std::uint32_t k, e;
    earlier(q, k, e);
    L.size[q] += (e - k) + pairs.count[i];
    for (std::uint64_t t = pairs.begin[i], te = t + pairs.count[i]; t < te; ++t)
      if (later[t] < i1) ++L.size[later[t] - i0];
  }
  // Rows padded to groups of four (the passes read four pairs at a time).
  L.offset.resize(rows + 1);
  L.offset[0] = 0;
  for (std::size_t q = 0; q < rows; ++q)
    L.offset[q + 1] = L.offset[q] + ((L.size[q] + 3) & ~std::uint32_t(3));
  const std::size_t total = L.offset[rows];
  L.index.resize(total);
  L.gx.resize(total);
  L.gy.resize(total);
  L.gz.resize(total);
  L.cursor.resize(rows);
  for (std::size_t q = 0; q < rows; ++q) {
    std::uint32_t k, e;
    earlier(q, k, e);
    L.cursor[q] = L.offset[q] + (e - k);
  }
  auto put = [&L](std::uint32_t slot, std::uint32_t j, const double* g, float sign) {
    L.index[slot] = j;
    L.gx[slot] = sign * static_cast<float>(g[0]);
    L.gy[slot] = sign * static_cast<float>(g[1]);
    L.gz[slot] = sign * static_cast<float>(g[2]);
  };
  // g_ab = m grad_a W(x_a - x_b); g_ba = -g_ab bit for bit (x_b - x_a is -(x_a - x_b)
  // exactly), so a pair in one range is computed once.
  auto gradients = rowGradients<Lanes2>;
#if defined(WAKE_HAS_LANES4)
  if (wide) gradients = rowGradients4;
#endif
  std::vector<double>& g = L.scratch;
  std::vector<double>& w = L.kernel;
  // Each pair's W'(r) / r where the fluid's pair lists have it (Fluid::computeAccelerations).
  std::vector<double>& d_later = derivatives_.later[r];
  std::vector<double>& d_before = derivatives_.before[r];
  d_later.resize(pairs.end[r]);
  d_before.resize(pairs.before[r].size());
  double* wp = nullptr;
  // The density, where asked for, in Fluid::computeFluidDensity's order (the same bits):
  // each particle's pairs before the range first, then those in it as the rows reach them
  // (a lower row adds its term to the higher one's partial sum), then its later ones.
  for (std::size_t q = 0; q < rows; ++q) {
    const std::size_t i = i0 + q;
    std::uint32_t k, e;
    earlier(q, k, e);
    double partial = 0.0;
    if (e > k) {
      g.resize(3 * std::size_t(e - k));
      w.resize(e - k);
      wp = density ? w.data() : nullptr;
      gradients(x[i], x, before + k, e - k, kernel, mass, g.data(), d_before.data() + k, wp);
      std::uint32_t slot = L.offset[q];
      for (std::uint32_t t = k; t < e; ++t) {
        put(slot++, before[t], &g[3 * (t - k)], 1.0f);
        if (wp) partial = partial + wp[t - k];
      }
    }
    if (density) density[i] = partial;
  }
  const double self = mass * kernel.value(0.0);
  for (std::size_t q = 0; q < rows; ++q) {
    const std::size_t i = i0 + q;
    std::uint32_t slot = L.offset[q] + L.size[q] - pairs.count[i];
    const std::uint32_t* nb = later + pairs.begin[i];
    g.resize(3 * std::size_t(pairs.count[i]));
    w.resize(pairs.count[i]);
    wp = density ? w.data() : nullptr;
    gradients(x[i], x, nb, pairs.count[i], kernel, mass, g.data(), d_later.data() + pairs.begin[i],
              wp);
    double sum = density ? density[i] : 0.0;
    for (std::uint32_t t = 0; t < pairs.count[i]; ++t) {
      const std::uint32_t j = nb[t];
      put(slot++, j, &g[3 * t], 1.0f);
      const bool inside = j < i1;
      if (inside) put(L.cursor[j - i0]++, static_cast<std::uint32_t>(i), &g[3 * t], -1.0f);
      if (!wp) continue;
      sum = sum + wp[t];
      if (inside) density[j] += wp[t];
    }
    if (density) density[i] = self + mass * sum;
    // The padding: the particle itself with g = 0 (adds zeros).
    const double zero[3] = {0.0, 0.0, 0.0};
    for (; slot < L.offset[q + 1]; ++slot)
      put(slot, static_cast<std::uint32_t>(i), zero, 1.0f);
  }
}

template <class F>
auto DivergenceFreeSolver::chunkedSum(std::size_t n, F&& f) {
  using T = std::decay_t<decltype(f(std::size_t(0)))>;
  T zero;
  if constexpr (std::is_arithmetic_v<T>)
    zero = T(0);
  else
    zero = T::Zero();
  constexpr std::size_t kChunk = 4096;
  const std::int64_t chunks = static_cast<std::int64_t>((n + kChunk - 1) / kChunk);
  std::vector<T> part(static_cast<std::size_t>(chunks), zero);
#pragma omp parallel for schedule(static)
  for (std::int64_t c = 0; c < chunks; ++c) {
    T s = zero;
    const std::size_t end = std::min(n, (c + 1) * kChunk);
    for (std::size_t i = c * kChunk; i < end; ++i)
      s += f(i);
    part[c] = s;
  }
  T total = zero;
  for (const T& s : part)
    total += s;
  return total;
}

void DivergenceFreeSolver::findCorrection(double rest_density) {
  correction_.setIdentity();
  bulk_ = 0;
  const std::size_t n = moment_.size() / 6;
  if (!params_.correct_gradient || n == 0) return;
  // The sum of M over the bulk (entries 0-5) and its particles (6).
  using Sum = Eigen::Matrix<double, 7, 1>;
  const double scale = 1.0 / rest_density;
  const Sum total = chunkedSum(n, [&](std::size_t i) {
    Sum m;
    for (int k = 0; k < 6; ++k)
      m[k] = scale * moment_[6 * i + k];
    m[6] = 1.0;
    bool bulk = true;
    for (int k = 0; k < 3; ++k)
      bulk = bulk && std::abs(m[k] - 1.0) <= 0.1 && std::abs(m[3 + k]) <= 0.05;
    return bulk ? m : Sum(Sum::Zero());
  });
  if (!(total[6] > 0.0)) return;
  bulk_ = static_cast<std::size_t>(total[6]);
  const double inv = 1.0 / total[6];
  Eigen::Matrix3d mean;
  mean << total[0], total[3], total[4], total[3], total[1], total[5], total[4], total[5], total[2];
  correction_ = (inv * mean).inverse();
}

template <class RowF>
void DivergenceFreeSolver::forEachListRow(const PairLists& pairs, RowF&& row) const {
  forEachRange(pairs, [&](std::int64_t i0, std::int64_t i1, std::size_t r) {
    const Lists& L = lists_[r];
    for (std::int64_t i = i0; i < i1; ++i) {
      const std::size_t q = static_cast<std::size_t>(i - i0);
      row(static_cast<std::size_t>(i), L, L.offset[q], L.offset[q + 1]);
    }
  });
}

void DivergenceFreeSolver::buildAllLists(const Fluid& fluid, double* density) {
  const FluidState& st = fluid.state();
  const PairLists& pairs = fluid.neighbors();
  const std::size_t n = st.size();
  if (pairs.size() != n)
    throw std::logic_error("DivergenceFreeSolver: lists before updateNeighbors");
  const Vec3* x = st.position.data();
  lists_.resize(pairs.ranges());
  derivatives_.later.resize(pairs.ranges());
  derivatives_.before.resize(pairs.ranges());
  forEachRange(pairs, [&](std::int64_t, std::int64_t, std::size_t r) {
    buildLists(pairs, r, x, fluid.kernel(), fluid.particleMass(), fluid.wideLanes(), density);
  });
  lists_particles_ = n;
}

void DivergenceFreeSolver::prepareLists(Fluid& fluid) {
  buildAllLists(fluid, fluid.state().density.data());
}

void DivergenceFreeSolver::prepare(const Fluid& fluid, const SolverBoundary& boundary) {
  const FluidState& st = fluid.state();
  const PairLists& pairs = fluid.neighbors();
  const std::size_t n = st.size();
  if (pairs.size() != n)
    throw std::logic_error("DivergenceFreeSolver::prepare before updateNeighbors");
  const bool walls = !boundary.gradient.empty();
  if (walls && (boundary.gradient.size() != n || boundary.flux.size() != n ||
                boundary.neighbors.size() != n || boundary.hydrostatic.size() != n ||
                boundary.above_share.size() != n))
    throw std::logic_error("DivergenceFreeSolver::prepare: boundary terms of another size");
  if (lists_particles_ != n) buildAllLists(fluid, nullptr);
  lists_particles_ = kNoLists;  // the next step's lists are built again
  boundary_ = walls ? &boundary : nullptr;
  // The particles with samples in their support: the walls' terms are theirs alone.
  near_wall_.assign(n, 0);
  if (walls)
    for (std::size_t i = 0; i < n; ++i)
      near_wall_[i] = boundary.gradient[i].squaredNorm() > 0.0 ? 1 : 0;
  offset_.assign(n, Vec3::Zero());
  if (walls) {
    // Their fluid's centre: sum_b |g_ab|^2 (x_b - x_a).
    auto offsets = rowOffsets<Quad2>;
#if defined(WAKE_HAS_LANES4)
    if (fluid.wideLanes()) offsets = rowOffsets4;
#endif
    const Vec3* x = st.position.data();
    forEachListRow(pairs, [&](std::size_t i, const Lists& L, std::uint32_t k, std::uint32_t e) {
      if (near_wall_[i])
        offset_[i] = offsets(L.index.data(), L.gx.data(), L.gy.data(), L.gz.data(), k, e, x, i);
    });
  }
  // The gradient sums and the factors come with the first pass over the lists (the step's
  // first rates, then computeFactors), which reads each pair's g_ab anyway.
  factors_ready_ = false;
  factor_.resize(n);
  grad_sum_.resize(n);
  sparse_.resize(n);
  held_.resize(n);
  weight_.resize(n);
  centre_.resize(n);
  count_.resize(n);
  weight_floor_.resize(n);
  const CubicSplineKernel& kernel = fluid.kernel();
  const double h = kernel.smoothingLength();
  const double scale = fluid.particleMass() * std::abs(kernel.derivativeOverR(h)) * h;
  factor_floor_ = 1e-6 * scale * scale;
  // Fewer than 3/4 of a resting particle's neighbours (fluid and wall samples): a splash,
  // whose rate of compression says little (SPlisHSPlasH's 20 of ~26 at this support).
  enough_neighbors_ =
      static_cast<std::uint32_t>(std::ceil(0.75 * latticeNeighbors(fluid.params())));
  largest_gradient_ = largestGradient(kernel, fluid.particleMass());
  denominator_floor_ = kFactorFloor * latticeWeight(fluid.params(), kernel, fluid.particleMass());
  if (params_.correct_gradient) {
    moment_.resize(6 * n);
    // The particles' second moments: a pass over their rows (a gather of the neighbours'
    // positions, as the offsets near walls).
    auto moments = rowMoments<Quad2>;
#if defined(WAKE_HAS_LANES4)
    if (fluid.wideLanes()) moments = rowMoments4;
#endif
    // Of about kMomentSamples particles, chosen by their permanent number (the same ones on
    // any number of threads and after a restart); the others' first entry 0: not bulk.
    const std::uint32_t stride =
        static_cast<std::uint32_t>(std::max<std::size_t>(1, n / kMomentSamples));
    const Vec3* x = st.position.data();
    const std::uint32_t* id = st.id.data();
    forEachListRow(pairs, [&](std::size_t i, const Lists& L, std::uint32_t k, std::uint32_t e) {
      double* m = moment_.data() + 6 * i;
      if (id[i] % stride != 0)
        m[0] = 0.0;
      else
        moments(L.index.data(), L.gx.data(), L.gy.data(), L.gz.data(), k, e, x, i, m);
    });
  }
  findCorrection(fluid.params().rest_density);
  wall_impulse_.assign(n, 0.0);  // a new step
  bodies_ready_ = false;
  lift_.assign(n, 0.0);
  rates_fresh_ = false;
}

namespace {

/// One range's lists as the passes read them.
struct RowView {
  const std::uint32_t *offset, *index;
  const float *gx, *gy, *gz;
  const std::uint32_t* size;  ///< each row's pairs (without the padding)
};

/// What the step's first rates also find, row by row: sum_b g_ab, sum_b |g_ab|^2 and the
/// fluid neighbours of each particle.
struct RowSums {
  Vec3* gradient;
  double* square;
  std::uint32_t* count;
};

/// The density rates D_a of the particles [i0, i1) (one range), four pairs at a time in
/// Q (Quad2 or Lanes4: the same bits): D_a = v_a . sum_b g_ab - sum_b v_b . g_ab, plus the
/// walls' v_a . G_a - B_a where `wall_gradient` is not null. kSums: the step's first rates,
/// which also sum each row's g_ab and |g_ab|^2 (four partial sums fixed by the list, as the
/// rates) into `sums` (sum_b g_ab is then read from there).
template <class Q, bool kSums>
inline void ratesRange(std::int64_t i0, std::int64_t i1, const RowView& L, const Vec3* v,
                       const float* vf, const Vec3* grad_sum, const Vec3* wall_gradient,
                       const double* flux, double* rate, const RowSums& sums) {
  for (std::int64_t i = i0; i < i1; ++i) {
    const std::size_t q = static_cast<std::size_t>(i - i0);
    Q sum = Q::all(0.0), sx = sum, sy = sum, sz = sum, sq = sum;
    for (std::uint32_t t = L.offset[q]; t < L.offset[q + 1]; t += 4) {
      const std::uint32_t* j = L.index + t;
      const float* p[4] = {vf + 4 * std::size_t(j[0]), vf + 4 * std::size_t(j[1]),
                           vf + 4 * std::size_t(j[2]), vf + 4 * std::size_t(j[3])};
      Q vx, vy, vz;
      Q::gather3Floats(p, vx, vy, vz);
      const Q gx = Q::loadFloats(L.gx + t), gy = Q::loadFloats(L.gy + t),
              gz = Q::loadFloats(L.gz + t);
      sum = sum + ((vx * gx + vy * gy) + vz * gz);
      if (!kSums) continue;
      sx = sx + gx;
      sy = sy + gy;
      sz = sz + gz;
      sq = sq + ((gx * gx + gy * gy) + gz * gz);
    }
    if (kSums) {
      sums.gradient[i] = Vec3(sx.total(), sy.total(), sz.total());
      sums.square[i] = sq.total();
      sums.count[i] = L.size[q];
    }
    const Vec3& g = kSums ? sums.gradient[i] : grad_sum[i];
    double d = v[i].dot(g) - sum.total();
    if (wall_gradient) d += v[i].dot(wall_gradient[i]) - flux[i];
    rate[i] = d;
  }
}

/// Where an iteration's impulse goes, particle by particle: the velocities (and their float
/// copy that the rates read), s and, near walls, the walls' share (s^w_a, from the
/// neighbours' increments weighted by |g_ab|^2).
struct ImpulseTargets {
  Vec3* velocity;
  float* velocity_f;  ///< (4 n)
  double* s;
  double* wall_impulse;
  const double* weight;       ///< sum_b |g_ab|^2
  const Vec3* wall_gradient;  ///< G_a (read where near[a])
  /// (n) The least weight the mean around a is taken over (near walls): a particle with
  /// less fluid around it makes up the rest with its own increment.
  const double* weight_floor;
  Eigen::Matrix3d correction;  ///< C (DivergenceFreeSolver::gradientCorrection)
};

/// The velocity change of the particles [i0, i1) for the increments ds, applied as each
/// row is done (the pass reads only the increments of the others): dv_a = -ds_a sum_b g_ab
/// - sum_b ds_b g_ab, and where near[a] the walls' -(s_a + s^w_a) G_a with the mean
/// sum_b |g_ab|^2 ds_b / sum_b |g_ab|^2 of the fluid around a (no branch on the pairs'
/// values: s is zero at random where the fluid is not compressed, and a mispredicted branch
/// costs more than the terms).
template <class Q>
inline void impulseRange(std::int64_t i0, std::int64_t i1, const RowView& L, const double* ds,
                         const Vec3* grad_sum, const std::uint8_t* near, const ImpulseTargets& to) {
  // C in locals: the rows' stores to the velocities may not be taken to leave it alone.
  const double c[3][3] = {{to.correction(0, 0), to.correction(0, 1), to.correction(0, 2)},
                          {to.correction(1, 0), to.correction(1, 1), to.correction(1, 2)},
                          {to.correction(2, 0), to.correction(2, 1), to.correction(2, 2)}};
  for (std::int64_t i = i0; i < i1; ++i) {
    const std::size_t q = static_cast<std::size_t>(i - i0);
    Q sx = Q::all(0.0), sy = sx, sz = sx, sw = sx;
    const std::uint32_t e = L.offset[q + 1];
    if (near[i]) {
      for (std::uint32_t t = L.offset[q]; t < e; t += 4) {
        const Q s = Q::gather(ds, L.index + t);
        const Q gx = Q::loadFloats(L.gx + t), gy = Q::loadFloats(L.gy + t),
                gz = Q::loadFloats(L.gz + t);
        sx = sx + s * gx;
        sy = sy + s * gy;
        sz = sz + s * gz;
        sw = sw + ((gx * gx + gy * gy) + gz * gz) * s;
      }
    } else {
      for (std::uint32_t t = L.offset[q]; t < e; t += 4) {
        const Q s = Q::gather(ds, L.index + t);
        sx = sx + s * Q::loadFloats(L.gx + t);
        sy = sy + s * Q::loadFloats(L.gy + t);
        sz = sz + s * Q::loadFloats(L.gz + t);
      }
    }
    const Vec3 pairs = ds[i] * grad_sum[i] + Vec3(sx.total(), sy.total(), sz.total());
    Vec3 change;
    for (int r = 0; r < 3; ++r)
      change[r] = -((c[r][0] * pairs[0] + c[r][1] * pairs[1]) + c[r][2] * pairs[2]);
    if (near[i]) {
      // s_a + s^w_a: a's own and the mean of the fluid's around it, over at least
      // weight_floor (see DivergenceFreeSolver::computeFactors).
      const double w = to.weight[i], floor = to.weight_floor[i];
      const double around =
          w >= floor && w > 0.0 ? sw.total() / w : (sw.total() + (floor - w) * ds[i]) / floor;
      const double wall = 1.5 * ds[i] + 0.5 * around;
      change -= wall * to.wall_gradient[i];
      to.wall_impulse[i] += wall;
    }
    Vec3& v = to.velocity[i];
    v += change;
    to.s[i] += ds[i];
    float* vf = to.velocity_f + 4 * i;
    for (int axis = 0; axis < 3; ++axis)
      vf[axis] = static_cast<float>(v[axis]);
  }
}

#if defined(WAKE_HAS_LANES4)
template <bool kSums>
WAKE_TARGET_AVX void ratesRange4(std::int64_t i0, std::int64_t i1, const RowView& L, const Vec3* v,
                                 const float* vf, const Vec3* grad_sum, const Vec3* wall_gradient,
                                 const double* flux, double* rate, const RowSums& sums) {
  ratesRange<Lanes4, kSums>(i0, i1, L, v, vf, grad_sum, wall_gradient, flux, rate, sums);
}
WAKE_TARGET_AVX void impulseRange4(std::int64_t i0, std::int64_t i1, const RowView& L,
                                   const double* ds, const Vec3* grad_sum, const std::uint8_t* near,
                                   const ImpulseTargets& to) {
  impulseRange<Lanes4>(i0, i1, L, ds, grad_sum, near, to);
}
#endif

}  // namespace

template <class RangeF>
void DivergenceFreeSolver::forEachRow(const PairLists& pairs, RangeF&& range) {
  forEachRange(pairs, [&](std::int64_t i0, std::int64_t i1, std::size_t r) {
    const Lists& L = lists_[r];
    range(i0, i1,
          RowView{L.offset.data(), L.index.data(), L.gx.data(), L.gy.data(), L.gz.data(),
                  L.size.data()});
  });
}

void DivergenceFreeSolver::densityRates(const Fluid& fluid) {
  const FluidState& st = fluid.state();
  const Vec3* v = st.velocity.data();
  const Vec3* wall = boundary_ ? boundary_->gradient.data() : nullptr;
  const double* flux = boundary_ ? boundary_->flux.data() : nullptr;
  const std::int64_t n = static_cast<std::int64_t>(st.size());
  rate_.resize(st.size());
  // The neighbours' velocities as floats, four per particle (one load each); the solves'
  // impulses keep them up to date.
  velocity_f_.resize(4 * st.size());
  float* vf = velocity_f_.data();
  if (!floats_fresh_) {
#pragma omp parallel for schedule(static)
    for (std::int64_t i = 0; i < n; ++i)
      for (int c = 0; c < 4; ++c)
        vf[4 * i + c] = c < 3 ? static_cast<float>(v[i][c]) : 0.0f;
    floats_fresh_ = true;
  }
  const bool first = !factors_ready_;
  auto range = first ? ratesRange<Quad2, true> : ratesRange<Quad2, false>;
#if defined(WAKE_HAS_LANES4)
  if (fluid.wideLanes()) range = first ? ratesRange4<true> : ratesRange4<false>;
#endif
  const RowSums sums{grad_sum_.data(), weight_.data(), count_.data()};
  forEachRow(fluid.neighbors(), [&](std::int64_t i0, std::int64_t i1, const RowView& L) {
    range(i0, i1, L, v, vf, grad_sum_.data(), wall, flux, rate_.data(), sums);
  });
  if (first) computeFactors();
}

void DivergenceFreeSolver::computeFactors() {
  const std::int64_t n = static_cast<std::int64_t>(factor_.size());
  const SolverBoundary* b = boundary_;
  const double mean_scale = correction_.trace() / 3.0;
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    // s_a's own push: -s_a (C sum_b g_ab + 3/2 G_a) (its own half of s^w_a), and its
    // neighbours' s_a C g_ab; the change of D_a it makes: -s_a [(sum_b g_ab + G_a) .
    // (C sum_b g_ab + 3/2 G_a) + sum_b g_ab . C g_ab], the last taken as tr(C) / 3 times
    // sum_b |g_ab|^2.
    const Vec3 wall = b ? b->gradient[i] : Vec3(Vec3::Zero());
    const Vec3 g = grad_sum_[i] + wall;
    const double denominator =
        std::max(g.dot(correction_ * grad_sum_[i] + 1.5 * wall), 0.0) + mean_scale * weight_[i];
    // A particle with (almost) no neighbours has no pressure to find; one at walls whose
    // own pressure barely acts on it (walls on opposite sides) is held at the floor
    // (kFactorFloor). A lone particle away from walls keeps its factor: a drop's or the
    // free surface's (the floor there let a surface particle of a column at rest at r =
    // 4 mm jump at 0.12 m/s).
    const bool walled = b && b->neighbors[i] > 0;
    held_[i] = walled && denominator < denominator_floor_;
    factor_[i] = denominator <= factor_floor_ ? 0.0
                 : held_[i]                   ? 1.0 / denominator_floor_
                                              : 1.0 / denominator;
    const std::uint32_t around = count_[i] + (b ? b->neighbors[i] : 0u);
    sparse_[i] = around < enough_neighbors_;
    // The fluid around a, a itself weighing as much as its neighbours together.
    centre_[i] = weight_[i] > 0.0 ? Vec3(0.5 / weight_[i] * offset_[i]) : Vec3(Vec3::Zero());
    // The walls' pressure s^w_a takes the mean increment of the fluid around a over at
    // least |G_a| max|g_ab|, a's own increment making up what is missing. Over a's own
    // weight alone, a particle with one or two fluid neighbours beside a wall passed their
    // whole increment to its walls' push, and that push, through a large G_a, fed the
    // neighbour's rate back: with a neighbour held by little else (a large a_b), the gain
    // of that loop, up to 0.5 |G_a| |g_ab| w_ab / (weight |g_ab|^2), exceeded one and the
    // divergence solve diverged (1e35 m/s in 100 iterations: boxes jammed in a narrow
    // tank under a plate, time.cfl 0.6, max_dt 4 ms). With the floor the gain stays under
    // 1/2; a particle with half a support of fluid around it, at a wall, is well above it
    // (a water column at rest: the same bits).
    weight_floor_[i] = b ? b->gradient[i].norm() * largest_gradient_ : 0.0;
  }
  factors_ready_ = true;
}

void DivergenceFreeSolver::applyImpulse(Fluid& fluid) {
  FluidState& st = fluid.state();
  auto range = impulseRange<Quad2>;
#if defined(WAKE_HAS_LANES4)
  if (fluid.wideLanes()) range = impulseRange4;
#endif
  const ImpulseTargets to{
      st.velocity.data(),   velocity_f_.data(), s_.data(),
      wall_impulse_.data(), weight_.data(),     boundary_ ? boundary_->gradient.data() : nullptr,
      weight_floor_.data(), correction_};
  forEachRow(fluid.neighbors(), [&](std::int64_t i0, std::int64_t i1, const RowView& L) {
    range(i0, i1, L, ds_.data(), grad_sum_.data(), near_wall_.data(), to);
  });
  floats_fresh_ = true;  // every row wrote its velocity's floats
}

void DivergenceFreeSolver::applyHydrostatic(Fluid& fluid, const Vec3& gravity, double dt) {
  if (!boundary_) return;
  FluidState& st = fluid.state();
  const SolverBoundary& b = *boundary_;
  const double inv_rho0 = 1.0 / fluid.params().rest_density;
  const std::int64_t n = static_cast<std::int64_t>(st.size());
  // The fluid around a lies below it (l < 0: under a lid or a floating body): the mean of
  // its pressure is more than a's by the weight between, all of it deep in the fluid, less
  // near the free surface (chi_a, as the samples above a).
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    const double l = -gravity.dot(centre_[i]);
    lift_[i] = l > 0.0 ? l : b.above_share[i] * l;
    st.velocity[i] -= dt * (b.hydrostatic[i] + (lift_[i] * inv_rho0) * b.gradient[i]);
  }
  floats_fresh_ = false;
}

void DivergenceFreeSolver::prepareBodies() {
  const SolverBoundary& b = *boundary_;
  const std::size_t nb = b.bodies.size(), nl = b.links.size();
  for (std::size_t l = 0; l < nl; ++l) {
    const BodyLink& link = b.links[l];
    if (link.body >= nb || link.particle >= factor_.size())
      throw std::logic_error("DivergenceFreeSolver: a body link out of range");
  }
  inverse_mass_.resize(nb);
  impulse_.assign(nb, Vec6::Zero());
  divergence_impulse_.assign(nb, Vec6::Zero());
  seen_.assign(nb, Vec6::Zero());
  answer_.resize(nb);
  residual_.resize(nb);
  stiffness_.resize(nb);
  for (std::size_t k = 0; k < nb; ++k) {
    Mat6& inverse = inverse_mass_[k];
    inverse.setZero();
    inverse.topLeftCorner<3, 3>() = b.bodies[k].inverse_mass * Eigen::Matrix3d::Identity();
    inverse.bottomRightCorner<3, 3>() = b.bodies[k].inverse_inertia;
  }
  bodies_ready_ = true;
}

void DivergenceFreeSolver::seeBodies(const Fluid& fluid, double dt, bool density) {
  const SolverBoundary& b = *boundary_;
  const std::size_t nb = b.bodies.size(), nl = b.links.size();
  const double mass = fluid.particleMass();
  const double inv_rho0 = 1.0 / fluid.params().rest_density;
  for (Vec6& i : impulse_)
    i.setZero();
  // In link order: the same bits on any number of threads.
  for (std::size_t l = 0; l < nl; ++l) {
    const BodyLink& link = b.links[l];
    const std::uint32_t a = link.particle;
    const Eigen::Map<const Vec6> j(link.flux), h(link.hydrostatic);
    if (density)
      impulse_[link.body] +=
          (mass * (wall_impulse_[a] + dt * lift_[a] * inv_rho0)) * j + (mass * dt) * h;
    else
      impulse_[link.body] += (mass * wall_impulse_[a]) * j;
  }
  // The density solve's push is taken against the last step's: the body's other forces
  // (gravity, contacts) are taken to balance that one.
  const double last = density ? dt : 0.0;
  for (std::size_t k = 0; k < nb; ++k) {
    const SolverBody& body = b.bodies[k];
    Vec6 push = impulse_[k];
    push.head<3>() -= last * body.last_force;
    push.tail<3>() -= last * body.last_torque;
    seen_[k] = inverse_mass_[k] * push;
  }
}

void DivergenceFreeSolver::shareWithBodies(double mass) {
  // Find each body's change d_b with the increments ds'_a = max(ds_a - a_a sum J_a . d_b,
  // -s_a) pushing it by exactly M_b d_b (their push taken as 2 m ds' J): piecewise linear
  // and monotone in d, so Newton's steps with the particles not held at -s_a converge in a
  // few (at most kShareSteps), in link order (the same bits on any number of threads).
  const std::vector<BodyLink>& links = boundary_->links;
  const std::size_t nb = answer_.size(), nl = links.size();
  for (Vec6& d : answer_)
    d.setZero();
  // sum J_a . d_b over the links [l, e) of l's particle (consecutive); sets e.
  auto change = [&](std::size_t l, std::size_t& e) {
    double sum = 0.0;
    for (e = l; e < nl && links[e].particle == links[l].particle; ++e)
      sum += Eigen::Map<const Vec6>(links[e].flux).dot(answer_[links[e].body]);
    return sum;
  };
  for (int step = 0; step < kShareSteps; ++step) {
    for (std::size_t k = 0; k < nb; ++k) {
      residual_[k].setZero();
      stiffness_[k].setZero();
    }
    for (std::size_t l = 0, e = 0; l < nl; l = e) {
      const std::uint32_t a = links[l].particle;
      const double free_ds = ds_[a] - factor_[a] * change(l, e);
      const bool held = free_ds < -s_[a];
      const double share = held ? -s_[a] : free_ds;
      for (std::size_t t = l; t < e; ++t) {
        const Eigen::Map<const Vec6> j(links[t].flux);
        residual_[links[t].body] += (2.0 * mass * share) * j;
        if (!held) stiffness_[links[t].body] += (2.0 * mass * factor_[a]) * (j * j.transpose());
      }
    }
    double worst = 0.0;
    for (std::size_t k = 0; k < nb; ++k) {
      // g = M^-1 push(ds') - d; dg/dd = -(I + M^-1 S_free).
      const Vec6 g = inverse_mass_[k] * residual_[k] - answer_[k];
      const Mat6 jacobian = Mat6::Identity() + inverse_mass_[k] * stiffness_[k];
      const Vec6 step_d = jacobian.partialPivLu().solve(g);
      answer_[k] += step_d;
      worst = std::max(worst, step_d.norm() / std::max(answer_[k].norm(), 1e-12));
    }
    if (worst < 1e-6) break;
  }
  for (std::size_t l = 0, e = 0; l < nl; l = e) {
    const std::uint32_t a = links[l].particle;
    ds_[a] = std::max(ds_[a] - factor_[a] * change(l, e), -s_[a]);
  }
}

void DivergenceFreeSolver::ratesWithBodies() {
  for (const BodyLink& link : boundary_->links)
    rate_[link.particle] -= Eigen::Map<const Vec6>(link.flux).dot(seen_[link.body]);
}

int DivergenceFreeSolver::solveDivergence(Fluid& fluid, double dt) {
  floats_fresh_ = false;  // the velocities changed since the last solve
  const std::size_t n = fluid.state().size();
  stats_.divergence_iterations = 0;
  stats_.divergence_error = 0.0;
  if (n == 0 || params_.max_divergence_iterations <= 0) return 0;
  if (factor_.size() != n) throw std::logic_error("DivergenceFreeSolver: solve before prepare");
  densityRates(fluid);  // the step's first: also the factors, sparse_ among them
  rates_fresh_ = true;  // rate_: of the velocities the solve leaves
  // The error is averaged over the particles the solve takes part in.
  std::size_t dense = 0;
  for (std::size_t i = 0; i < n; ++i)
    dense += sparse_[i] ? 0 : 1;
  if (dense == 0) return 0;
  const double scale = dt / (double(dense) * fluid.params().rest_density);
  s_.assign(n, 0.0);
  ds_.resize(n);
  const bool bodies = boundary_ && !boundary_->links.empty();
  if (bodies) prepareBodies();
  int iterations = 0;
  for (bool first = true;; first = false) {
    if (!first) densityRates(fluid);
    if (bodies) ratesWithBodies();
    // Each particle's pressure grows by what removes its own compression rate; a particle
    // with too few neighbours for a reliable rate (a splash) is left alone.
    const double error = scale * chunkedSum(n, [&](std::size_t i) {
                           const double rate = sparse_[i] ? 0.0 : std::max(0.0, rate_[i]);
                           ds_[i] = rate * factor_[i];
                           return rate;
                         });
    stats_.divergence_error = error;
    if (error <= params_.max_divergence_error || iterations >= params_.max_divergence_iterations)
      break;
    if (bodies) shareWithBodies(fluid.particleMass());
    applyImpulse(fluid);
    if (bodies) seeBodies(fluid, dt, false);
    ++iterations;
  }
  if (bodies) divergence_impulse_ = impulse_;
  stats_.divergence_iterations = iterations;
  return iterations;
}

int DivergenceFreeSolver::solveDensity(Fluid& fluid, const Vec3& gravity, double dt) {
  floats_fresh_ = false;  // the velocities changed since the last solve
  FluidState& st = fluid.state();
  const std::size_t n = st.size();
  stats_.density_iterations = 0;
  stats_.density_error = 0.0;
  if (n == 0) return 0;
  if (factor_.size() != n) throw std::logic_error("DivergenceFreeSolver: solve before prepare");
  const double rho0 = fluid.params().rest_density;
  const double inv_dt = 1.0 / dt;
  st.keepPressureMean();
  s_.assign(n, 0.0);
  ds_.resize(n);
  // Warm start: kWarmStart of the last step's pressure (s = dt p / rho^2) where the fluid
  // would be compressed at the step's end with the velocities of its start (the divergence
  // solve's rates); the iterations only add pressure, so this is how it falls.
  if (!rates_fresh_) densityRates(fluid);
  rates_fresh_ = false;
  const bool bodies = boundary_ && !boundary_->links.empty();
  if (bodies && !bodies_ready_) prepareBodies();
  const double any = chunkedSum(n, [&](std::size_t i) {
    const double rho = st.density[i];
    const bool compressed = rho + dt * rate_[i] > rho0;
    ds_[i] =
        compressed && st.pressure[i] > 0.0 ? kWarmStart * dt * st.pressure[i] / (rho * rho) : 0.0;
    return ds_[i] > 0.0 ? 1.0 : 0.0;
  });
  if (any > 0.0) applyImpulse(fluid);
  applyHydrostatic(fluid, gravity, dt);
  if (bodies) seeBodies(fluid, dt, true);
  const double scale = 1.0 / (double(n) * rho0);
  const double most = kMaxCorrection * rho0;  // compression counted per particle and step
  int iterations = 0;
  for (;;) {
    densityRates(fluid);
    if (bodies) ratesWithBodies();
    // Each particle's pressure grows by what removes its own compression at the step's end.
    const double error = scale * chunkedSum(n, [&](std::size_t i) {
                           const double over = std::max(0.0, st.density[i] + dt * rate_[i] - rho0);
                           const double excess = held_[i] ? std::min(over, most) : over;
                           ds_[i] = excess * factor_[i] * inv_dt;
                           return excess;
                         });
    stats_.density_error = error;
    if ((error <= params_.max_density_error && iterations >= 2) ||
        iterations >= params_.max_iterations)
      break;
    if (bodies) shareWithBodies(fluid.particleMass());
    applyImpulse(fluid);
    if (bodies) seeBodies(fluid, dt, true);
    ++iterations;
  }
  const std::size_t nb = bodies ? boundary_->bodies.size() : 0;
  body_force_.assign(nb, Vec3::Zero());
  body_torque_.assign(nb, Vec3::Zero());
  for (std::size_t b = 0; b < nb; ++b) {
    const Vec6 push = impulse_[b] - divergence_impulse_[b];
    body_force_[b] = push.head<3>() * inv_dt;
    body_torque_[b] = push.tail<3>() * inv_dt;
  }
  const std::int64_t sn = static_cast<std::int64_t>(n);
  const double follow = dt / (kPressureMeanTime + dt);
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < sn; ++i) {
    st.pressure[i] = s_[i] * st.density[i] * st.density[i] * inv_dt;
    st.pressure_mean[i] += follow * (st.pressure[i] - st.pressure_mean[i]);
  }
  stats_.density_iterations = iterations;
  return iterations;
}

}  // namespace wake
