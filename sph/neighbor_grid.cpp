#include "sph/neighbor_grid.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

namespace wake {

double UniformGrid::cellsFor(const Aabb& box, double cell_size) {
  double cells = 1.0;
  for (int k = 0; k < 3; ++k)
    cells *= std::max(1.0, std::ceil((box.max[k] - box.min[k]) / cell_size));
  return cells;
}

UniformGrid::UniformGrid(const Aabb& domain, double cell_size, std::size_t max_cells, int reach) {
  check(domain, cell_size, max_cells, reach);
  reset(domain, cell_size, reach);
}

void UniformGrid::check(const Aabb& domain, double cell_size, std::size_t max_cells, int reach) {
  if (!(cell_size > 0.0)) throw std::invalid_argument("grid cell size must be > 0");
  if (reach < 1) throw std::invalid_argument("grid reach must be >= 1");
  if (domain.empty()) throw std::invalid_argument("grid domain is empty");
  const double cells = cellsFor(domain, cell_size);
  if (!(cells <= static_cast<double>(max_cells)))
    throw std::invalid_argument("domain too large for the kernel support: " +
                                std::to_string(static_cast<long long>(cells)) +
                                " grid cells (limit " + std::to_string(max_cells) +
                                "); shrink the domain or increase the particle radius");
}

void UniformGrid::reset(const Aabb& box, double cell_size, int reach) {
  origin_ = box.min;
  cell_size_ = cell_size;
  inv_cell_ = 1.0 / cell_size;
  reach_ = reach;
  for (int k = 0; k < 3; ++k)
    dims_[k] = static_cast<int>(std::max(1.0, std::ceil((box.max[k] - box.min[k]) * inv_cell_)));
  // No points until a sort: every start 0 (sparse, nothing kept).
  sparse_ = true;
  cell_start_.clear();
  row_start_.clear();
  row_stretches_.clear();
  stretches_.clear();
}

std::size_t UniformGrid::startBytes() const {
  return cell_start_.capacity() * sizeof(std::uint32_t) +
         (row_start_.capacity() + row_stretches_.capacity()) * sizeof(std::uint32_t) +
         stretches_.capacity() * sizeof(RowStretch);
}

void UniformGrid::sortSparse(const std::vector<Vec3>& points, std::vector<std::uint32_t>& order) {
  const std::size_t n = points.size();
  cell_of_.resize(n);
  order.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    cell_of_[i] = cellIndex(points[i]);
    order[i] = static_cast<std::uint32_t>(i);
  }
  // The counting sort's order: by cell, stable.
  std::stable_sort(order.begin(), order.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return cell_of_[a] < cell_of_[b]; });
  sparse_ = true;
  const std::uint32_t nx = static_cast<std::uint32_t>(dims_[0]);
  const std::size_t rows = cellCount() / nx;
  std::vector<std::uint32_t>().swap(cell_start_);
  row_start_.assign(rows + 1, 0);
  row_stretches_.assign(rows + 1, 0);
  stretches_.clear();
  // Walk the occupied cells in order: k is the first sorted point of cell c.
  std::size_t k = 0;
  std::uint32_t last_row = 0;  // the row of stretches_.back()
  while (k < n) {
    const std::uint32_t c = cell_of_[order[k]];
    const std::uint32_t row = c / nx;
    const int x = static_cast<int>(c % nx);
    std::size_t end = k;
    while (end < n && cell_of_[order[end]] == c)
      ++end;
    if (!stretches_.empty() && row == last_row && x - stretches_.back().x1 <= kStretchGap) {
      // Grow the stretch to cell x: the cells between start where x does.
      for (int e = stretches_.back().x1 + 1; e <= x; ++e)
        cell_start_.push_back(static_cast<std::uint32_t>(k));
      stretches_.back().x1 = x;
    } else {
      RowStretch s;
      s.x0 = s.x1 = x;
      s.starts = static_cast<std::uint32_t>(cell_start_.size());
      cell_start_.push_back(static_cast<std::uint32_t>(k));
      stretches_.push_back(s);
      last_row = row;
      row_stretches_[row + 1] = static_cast<std::uint32_t>(stretches_.size());
    }
    row_start_[row + 1] = static_cast<std::uint32_t>(end);
    k = end;
  }
  // Rows without points: their stretches' end and their start carried over.
  for (std::size_t r = 1; r <= rows; ++r) {
    row_stretches_[r] = std::max(row_stretches_[r], row_stretches_[r - 1]);
    row_start_[r] = std::max(row_start_[r], row_start_[r - 1]);
  }
  cell_start_.shrink_to_fit();
  stretches_.shrink_to_fit();
  std::vector<std::uint32_t>().swap(cell_of_);
}

void UniformGrid::sort(const std::vector<Vec3>& points, std::vector<std::uint32_t>& order) {
  cell_of_.resize(points.size());
  order.resize(points.size());
  sort(points.data(), points.size(), order.data(), cell_of_.data());
}

void UniformGrid::sort(const Vec3* points, std::size_t n, std::uint32_t* order,
                       std::uint32_t* cell_of) {
  sparse_ = false;
  row_start_.clear();
  row_stretches_.clear();
  stretches_.clear();
  cell_start_.assign(cellCount() + 1, 0u);
  const std::int64_t sn = static_cast<std::int64_t>(n);
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < sn; ++i)
    cell_of[i] = cellIndex(points[i]);
  // Histogram shifted by one, prefix sum gives the start of each cell.
  for (std::size_t i = 0; i < n; ++i)
    ++cell_start_[cell_of[i] + 1];
  for (std::size_t c = 1; c < cell_start_.size(); ++c)
    cell_start_[c] += cell_start_[c - 1];
  // Scatter; cell_start_[c] is used as the running cursor of cell c, then restored.
  for (std::size_t i = 0; i < n; ++i)
    order[cell_start_[cell_of[i]]++] = static_cast<std::uint32_t>(i);
  for (std::size_t c = cell_start_.size() - 1; c > 0; --c)
    cell_start_[c] = cell_start_[c - 1];
  cell_start_[0] = 0;
}

namespace {
[[noreturn]] void throwListsTooLong() {
  throw std::length_error("neighbour lists: over 2^32 entries in one block of points");
}
}  // namespace

void ListStarts::set(std::size_t i, std::uint64_t start) {
  if (!trySet(i, start)) throwListsTooLong();
}

std::uint64_t ListStarts::startsFromCounts() {
  std::uint64_t total = 0;
  for (std::size_t i = 0; i < low_.size(); ++i) {
    const std::uint32_t count = low_[i];
    set(i, total);
    total += count;
  }
  return total;
}

std::size_t PairLists::rangeOf(std::size_t i) const {
  return static_cast<std::size_t>(std::upper_bound(range.begin(), range.end(), i) - range.begin()) -
         1;
}

namespace {

/// Calls f(j, i) for each pair j < i with i in [lo, hi) and j in [first, last), in
/// ascending j (and i for one j): the earlier neighbours of the points [lo, hi) from
/// `first` on (last = hi: all of them; last = lo: those before lo), read from the later
/// lists.
template <class F>
void forEachEarlier(const PairLists& pairs, std::size_t first, std::size_t last, std::size_t lo,
                    std::size_t hi, F&& f) {
  last = std::min(last, hi);
  if (first >= last) return;
  std::size_t r = pairs.rangeOf(first);
  for (std::size_t j = first; j < last; ++j) {
    while (pairs.range[r + 1] <= j)
      ++r;
    const std::uint32_t* later = pairs.later[r].data() + pairs.begin[j];
    for (std::uint32_t k = 0, m = pairs.count[j]; k < m; ++k) {
      const std::uint32_t i = later[k];
      if (i >= hi) break;  // ascending
      if (i >= lo) f(static_cast<std::uint32_t>(j), i);
    }
  }
}

/// Whether p_j is closer than sqrt(radius_sq) to (xi, yi, zi): every pair test of the lists.
inline bool isWithin(const Vec3& pj, double xi, double yi, double zi, double radius_sq) {
  const double dx = xi - pj[0];
  const double dy = yi - pj[1];
  const double dz = zi - pj[2];
  return dx * dx + dy * dy + dz * dz < radius_sq;
}

/// Writes j at dst[used] and returns used + 1 when p_j is closer than sqrt(radius_sq) to
/// (xi, yi, zi), else used: a list's branch-free append (every candidate written, the
/// cursor moved only for neighbours).
inline std::size_t appendIfWithin(const Vec3& pj, std::uint32_t j, double xi, double yi, double zi,
                                  double radius_sq, std::uint32_t* dst, std::size_t used) {
  dst[used] = j;
  return used + static_cast<std::size_t>(isWithin(pj, xi, yi, zi, radius_sq));
}

/// appendIfWithin for the points [b, e) (consecutive in the sorted order), one after another.
inline std::size_t appendRangeWithin(const Vec3* points, std::uint32_t b, std::uint32_t e,
                                     double xi, double yi, double zi, double radius_sq,
                                     std::uint32_t* dst, std::size_t used) {
  for (std::uint32_t j = b; j < e; ++j)
    used = appendIfWithin(points[j], j, xi, yi, zi, radius_sq, dst, used);
  return used;
}

#if defined(WAKE_HAS_LANES4)
/// As appendRangeWithin, four points at a time (AVX): each lane's distance the scalar
/// operations (the same bits, the same list); the neighbours among four written at once
/// (their indices' offsets from a table by the comparison's mask), so dst needs room for
/// three entries more than the range's.
WAKE_TARGET_AVX std::size_t appendRangeWithin4(const Vec3* points, std::uint32_t b, std::uint32_t e,
                                               double xi, double yi, double zi, double radius_sq,
                                               std::uint32_t* dst, std::size_t used) {
  // The positions of the set bits of each 4-bit mask, ascending.
  alignas(16) static const std::uint32_t kOffsets[16][4] = {
      {0, 0, 0, 0}, {0, 0, 0, 0}, {1, 0, 0, 0}, {0, 1, 0, 0}, {2, 0, 0, 0}, {0, 2, 0, 0},
      {1, 2, 0, 0}, {0, 1, 2, 0}, {3, 0, 0, 0}, {0, 3, 0, 0}, {1, 3, 0, 0}, {0, 1, 3, 0},
      {2, 3, 0, 0}, {0, 2, 3, 0}, {1, 2, 3, 0}, {0, 1, 2, 3}};
  const __m256d px = _mm256_set1_pd(xi), py = _mm256_set1_pd(yi), pz = _mm256_set1_pd(zi);
  const __m256d limit = _mm256_set1_pd(radius_sq);
  std::uint32_t j = b;
  for (; j + 4 <= e; j += 4) {
    // Four points' 12 doubles: (x0 y0 z0 x1) (y1 z1 x2 y2) (z2 x3 y3 z3).
    const double* p = points[j].data();
    const __m256d a = _mm256_loadu_pd(p), c = _mm256_loadu_pd(p + 4), d = _mm256_loadu_pd(p + 8);
    const __m256d xy02 = _mm256_permute2f128_pd(a, c, 0x30);  // x0 y0 x2 y2
    const __m256d zx13 = _mm256_permute2f128_pd(a, d, 0x21);  // z0 x1 z2 x3
    const __m256d yz13 = _mm256_permute2f128_pd(c, d, 0x30);  // y1 z1 y3 z3
    const __m256d x = _mm256_blend_pd(xy02, zx13, 0xA);
    const __m256d y = _mm256_shuffle_pd(xy02, yz13, 0x5);
    const __m256d z = _mm256_blend_pd(zx13, yz13, 0xA);
    const __m256d dx = _mm256_sub_pd(px, x), dy = _mm256_sub_pd(py, y), dz = _mm256_sub_pd(pz, z);
    const __m256d d2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)),
                                     _mm256_mul_pd(dz, dz));
    const int mask = _mm256_movemask_pd(_mm256_cmp_pd(d2, limit, _CMP_LT_OQ));
    const __m128i offsets = _mm_load_si128(reinterpret_cast<const __m128i*>(kOffsets[mask]));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(dst + used),
                     _mm_add_epi32(_mm_set1_epi32(static_cast<int>(j)), offsets));
    used += static_cast<std::size_t>(__builtin_popcount(static_cast<unsigned>(mask)));
  }
  return appendRangeWithin(points, j, e, xi, yi, zi, radius_sq, dst, used);
}
#endif

/// Appends to dst[w..) the entries of the ascending runs a[0, na) and b[0, nb) whose flag
/// (fa, fb) is `want`, merged in ascending order; returns the new w.
inline std::size_t mergeWhere(const std::uint32_t* a, const std::uint8_t* fa, std::size_t na,
                              const std::uint32_t* b, const std::uint8_t* fb, std::size_t nb,
                              std::uint8_t want, std::uint32_t* dst, std::size_t w) {
  std::size_t p = 0, q = 0;
  while (p < na && fa[p] != want)
    ++p;
  while (q < nb && fb[q] != want)
    ++q;
  while (p < na || q < nb) {
    if (q >= nb || (p < na && a[p] < b[q])) {
      dst[w++] = a[p++];
      while (p < na && fa[p] != want)
        ++p;
    } else {
      dst[w++] = b[q++];
      while (q < nb && fb[q] != want)
        ++q;
    }
  }
  return w;
}

/// The before lists of `out` from its later lists and span (buildPairLists' second part).
void buildBeforeLists(PairLists& out) {
  const std::size_t ranges = out.ranges();
  // The earlier neighbours before each range's start: pairs (j, i) with j < lo <= i have
  // i - j <= span, so only the range's first `span` points have any.
#pragma omp parallel for schedule(static, 1) num_threads(static_cast <int>(ranges))
  for (std::int64_t sr = 0; sr < static_cast<std::int64_t>(ranges); ++sr) {
    const std::size_t r = static_cast<std::size_t>(sr);
    const std::size_t lo = out.range[r], hi = std::min(out.range[r + 1], lo + out.span);
    const std::size_t first = lo > out.span ? lo - out.span : 0;
    std::vector<std::uint32_t>& off = out.before_offset[r];
    std::vector<std::uint32_t>& list = out.before[r];
    off.assign(hi - lo + 1, 0);
    forEachEarlier(out, first, lo, lo, hi,
                   [&](std::uint32_t, std::uint32_t i) { ++off[i - lo + 1]; });
    for (std::size_t q = 1; q < off.size(); ++q)
      off[q] += off[q - 1];
    list.resize(off.back());
    // off[q] serves as point q's cursor, then is restored.
    forEachEarlier(out, first, lo, lo, hi,
                   [&](std::uint32_t j, std::uint32_t i) { list[off[i - lo]++] = j; });
    for (std::size_t q = off.size() - 1; q > 0; --q)
      off[q] = off[q - 1];
    off[0] = 0;
  }
}

/// Sizes `out` for n points in the ranges out.range holds and fills each range's later
/// lists point by point: `row(r, i, local, used)` appends point i's later neighbours to
/// `local` (range r's list, room made by `row`) from `used` and returns the new end. Then
/// the span and the before lists (buildBeforeLists).
template <class Row>
void fillPairLists(std::size_t n, PairLists& out, Row row) {
  const std::size_t ranges = out.ranges();
  out.later.resize(ranges);
  out.before_offset.resize(ranges);
  out.before.resize(ranges);
  out.begin.resize(n);
  out.count.resize(n);
  out.end.assign(ranges, 0);
  std::vector<std::size_t> spans(ranges, 0);
  int too_long = 0;
  const int threads = static_cast<int>(ranges);
#pragma omp parallel for schedule(static, 1) num_threads(threads) reduction(max : too_long)
  for (std::int64_t sr = 0; sr < static_cast<std::int64_t>(ranges); ++sr) {
    const std::size_t r = static_cast<std::size_t>(sr);
    std::vector<std::uint32_t>& local = out.later[r];
    std::size_t used = 0, span = 0;
    for (std::size_t i = out.range[r]; i < out.range[r + 1]; ++i) {
      const std::size_t before = used;
      used = row(r, i, local, used);
      too_long = std::max(too_long, int(!out.begin.trySet(i, before)));
      out.count[i] = static_cast<std::uint32_t>(used - before);
      if (used > before) span = std::max<std::size_t>(span, local[used - 1] - i);
    }
    out.end[r] = used;
    spans[r] = span;
  }
  if (too_long) throwListsTooLong();
  out.span = ranges ? *std::max_element(spans.begin(), spans.end()) : 0;
  buildBeforeLists(out);
}

}  // namespace

void buildPairLists(const UniformGrid& grid, const std::vector<Vec3>& points, double radius,
                    PairLists& out, bool wide) {
  buildPairLists(grid, points.data(), points.size(), radius, out, wide);
}

void buildPairLists(const UniformGrid& grid, const Vec3* points, std::size_t n, double radius,
                    PairLists& out, bool wide) {
  auto append = appendRangeWithin;
#if defined(WAKE_HAS_LANES4)
  if (wide) append = appendRangeWithin4;
#else
  (void)wide;
#endif
  const double radius_sq = radius * radius;
  const std::size_t ranges = static_cast<std::size_t>(omp_get_max_threads());
  out.range.resize(ranges + 1);
  for (std::size_t r = 0; r < ranges; ++r)  // at multiples of a block of list starts
    out.range[r] = n * r / ranges / ListStarts::kBlock * ListStarts::kBlock;
  out.range[ranges] = n;
  // The later neighbours of each point (every pair tested once). Branch-free append: write
  // every candidate, advance the cursor only for neighbours.
  fillPairLists(
      n, out, [&](std::size_t, std::size_t i, std::vector<std::uint32_t>& local, std::size_t used) {
        const double xi = points[i][0], yi = points[i][1], zi = points[i][2];
        grid.forEachRangeInSphere(
            points[i], grid.reach(), radius, true, [&](std::uint32_t b, std::uint32_t e) {
              if (b <= i) b = static_cast<std::uint32_t>(i + 1);  // j > i only
              if (b >= e) return;
              // Grown by a quarter (the buffer stays for the next steps: doubling
              // left up to twice the lists' size unused); room for the four-at-a-time
              // append's last write.
              if (local.size() < used + (e - b) + 3)
                local.resize(used + (e - b) + 3 + std::max<std::size_t>(used / 4, 4096));
              used = append(points, b, e, xi, yi, zi, radius_sq, local.data(), used);
            });
        return used;
      });
}

void keepPairsWithin(PairLists& lists, const std::vector<Vec3>& points, double radius) {
  const std::size_t n = points.size();
  if (lists.size() != n || lists.ranges() == 0)
    throw std::logic_error("keepPairsWithin: the lists are for another number of points");
  const double radius_sq = radius * radius;
  const std::size_t ranges = lists.ranges();
  std::vector<std::size_t> spans(ranges, 0);
  // Each point's list is [pairs at the last call | the other candidates], both ascending.
  // Most points keep the same pairs from one call to the next (a test of each candidate,
  // nothing written); the others' two runs are merged again: the pairs now, then the rest.
#pragma omp parallel for schedule(static, 1) num_threads(static_cast <int>(ranges))
  for (std::int64_t sr = 0; sr < static_cast<std::int64_t>(ranges); ++sr) {
    const std::size_t r = static_cast<std::size_t>(sr);
    std::vector<std::uint8_t> within;
    std::vector<std::uint32_t> copy;
    std::size_t span = 0;
    for (std::size_t i = lists.range[r]; i < lists.range[r + 1]; ++i) {
      const std::uint32_t kept = lists.count[i];
      const std::uint32_t all = static_cast<std::uint32_t>(lists.candidates(i, r));
      std::uint32_t* list = lists.later[r].data() + lists.begin[i];
      if (within.size() < all) within.resize(all);
      const double xi = points[i][0], yi = points[i][1], zi = points[i][2];
      bool changed = false;
      for (std::uint32_t k = 0; k < all; ++k) {
        within[k] = isWithin(points[list[k]], xi, yi, zi, radius_sq);
        changed |= bool(within[k]) != (k < kept);
      }
      if (changed) {
        copy.assign(list, list + all);
        const std::uint32_t* a = copy.data();
        const std::uint8_t* fa = within.data();
        const std::size_t now =
            mergeWhere(a, fa, kept, a + kept, fa + kept, all - kept, 1, list, 0);
        mergeWhere(a, fa, kept, a + kept, fa + kept, all - kept, 0, list, now);
        lists.count[i] = static_cast<std::uint32_t>(now);
      }
      if (lists.count[i] > 0) span = std::max<std::size_t>(span, list[lists.count[i] - 1] - i);
    }
    spans[r] = span;
  }
  lists.span = *std::max_element(spans.begin(), spans.end());
  buildBeforeLists(lists);
}

void filterPairLists(const PairLists& candidates, const std::vector<Vec3>& points, double radius,
                     PairLists& out) {
  if (candidates.size() != points.size() || candidates.ranges() == 0)
    throw std::logic_error("filterPairLists: the candidates are for another number of points");
  out = candidates;
  keepPairsWithin(out, points, radius);
}

void buildNeighborList(const UniformGrid& grid, const std::vector<Vec3>& points, double radius,
                       NeighborList& out) {
  const std::size_t n = points.size();
  buildPairLists(grid, points, radius, out.pairs);
  const PairLists& pairs = out.pairs;
  out.offset.assign(n + 1, 0);
  out.lower_count.resize(n);
  const std::int64_t ranges = static_cast<std::int64_t>(pairs.ranges());
  // The earlier neighbours of point i are the j < i whose later lists hold i: each range
  // scans the lists of j in [lo - span, hi).
  auto first_of = [&](std::size_t lo) { return lo > pairs.span ? lo - pairs.span : 0; };
#pragma omp parallel for schedule(static, 1)
  for (std::int64_t r = 0; r < ranges; ++r) {
    const std::size_t lo = pairs.range[r], hi = pairs.range[r + 1];
    for (std::size_t i = lo; i < hi; ++i)
      out.lower_count[i] = 0;
    forEachEarlier(pairs, first_of(lo), hi, lo, hi,
                   [&](std::uint32_t, std::uint32_t i) { ++out.lower_count[i]; });
    for (std::size_t i = lo; i < hi; ++i)
      out.offset[i + 1] = out.lower_count[i] + pairs.count[i];
  }
  for (std::size_t i = 0; i < n; ++i)
    out.offset[i + 1] += out.offset[i];
  out.index.resize(out.offset[n]);
  // Each list: its earlier neighbours (ascending j), then its later ones.
  std::uint32_t* index = out.index.data();
#pragma omp parallel for schedule(static, 1)
  for (std::int64_t r = 0; r < ranges; ++r) {
    const std::size_t lo = pairs.range[r], hi = pairs.range[r + 1];
    for (std::size_t i = lo; i < hi; ++i)
      out.lower_count[i] = 0;
    forEachEarlier(pairs, first_of(lo), hi, lo, hi, [&](std::uint32_t j, std::uint32_t i) {
      index[out.offset[i] + out.lower_count[i]++] = j;
    });
    for (std::size_t i = lo; i < hi; ++i)
      if (pairs.count[i] > 0)
        std::memcpy(index + out.offset[i] + out.lower_count[i],
                    pairs.later[r].data() + pairs.begin[i], pairs.count[i] * sizeof(std::uint32_t));
  }
}

}  // namespace wake
