// Uniform grid over a box. Points are counting-sorted by cell (x fastest), so the cells of
// one x-row of the block around a point form one contiguous range of sorted points. With
// `reach` r, a query visits the (2r+1)^3 cells around a point as (2r+1)^2 ranges: cell size
// = support radius with r = 1 (27 cells), or support / 2 with r = 2 (125 smaller cells,
// about 40% fewer candidates to test).
#pragma once

#include "sph/lanes.hpp"
#include "sph/types.hpp"

#include <cmath>
#include <cstdint>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace wake {

/// t clamped into [0, last] (NaN: 0), without a branch.
inline double clampToCells(double t, double last) {
#if defined(__SSE2__)
  // maxsd gives its second operand when one is NaN.
  return _mm_cvtsd_f64(_mm_min_sd(_mm_max_sd(_mm_set_sd(t), _mm_setzero_pd()), _mm_set_sd(last)));
#else
  const double above = 0.0 < t ? t : 0.0;
  return above < last ? above : last;
#endif
}

class UniformGrid {
 public:
  UniformGrid() = default;
  /// domain: box covering every point of interest (m); cell_size > 0 (m); reach >= 1 cells.
  /// Throws std::invalid_argument when the grid would need more than `max_cells` cells.
  UniformGrid(const Aabb& domain, double cell_size, std::size_t max_cells = kMaxCells,
              int reach = 1);
  /// The constructor's checks without building the grid (nothing allocated).
  static void check(const Aabb& domain, double cell_size, std::size_t max_cells = kMaxCells,
                    int reach = 1);

  static constexpr std::size_t kMaxCells = std::size_t(1) << 27;

  /// Re-fits the grid to a new box, cell size and reach, reusing its memory (no checks
  /// beyond the constructor's: the caller keeps the cell count bounded).
  void reset(const Aabb& box, double cell_size, int reach);

  /// Number of cells a grid over `box` with `cell_size` has (as a double: may be huge).
  static double cellsFor(const Aabb& box, double cell_size);

  double cellSize() const { return cell_size_; }
  int reach() const { return reach_; }
  const Eigen::Vector3i& dims() const { return dims_; }
  std::size_t cellCount() const { return static_cast<std::size_t>(dims_.prod()); }

  /// Integer cell coordinates of p, clamped into the grid (NaN: cell 0).
  Eigen::Vector3i cellCoord(const Vec3& p) const {
    Eigen::Vector3i c;
    for (int k = 0; k < 3; ++k) {
      // Clamped first, then truncated: truncation is floor from 0 up, and no floor (a
      // branch per axis in the code GCC makes without SSE4.1) is needed.
      const double t = (p[k] - origin_[k]) * inv_cell_;
      const double last = static_cast<double>(dims_[k] - 1);
      c[k] = static_cast<int>(clampToCells(t, last));
    }
    return c;
  }
  std::uint32_t cellIndex(const Eigen::Vector3i& c) const {
    return static_cast<std::uint32_t>((c[2] * dims_[1] + c[1]) * dims_[0] + c[0]);
  }
  std::uint32_t cellIndex(const Vec3& p) const { return cellIndex(cellCoord(p)); }
  /// Centre of cell c.
  Vec3 cellCenter(const Eigen::Vector3i& c) const {
    return origin_ + cell_size_ * (c.cast<double>().array() + 0.5).matrix();
  }

  /// Counting sort of `points` by cell. Afterwards `order[k]` is the input index of the
  /// k-th sorted point, and sorted points of cell c are [cellStart(c), cellStart(c + 1)).
  /// Stable: points of one cell keep their input order. Keeps a start per cell (4 bytes
  /// each).
  void sort(const std::vector<Vec3>& points, std::vector<std::uint32_t>& order);
  /// As sort, for the n points from `points` on, in the caller's memory: the order (n) and
  /// the points' cells (n, scratch).
  void sort(const Vec3* points, std::size_t n, std::uint32_t* order, std::uint32_t* cell_of);
  /// As sort, the same order and ranges, for few points in many cells: the starts are kept
  /// only along the stretches of each row that hold points (RowStretch); memory in
  /// proportion to the points and the rows, not the cells.
  void sortSparse(const std::vector<Vec3>& points, std::vector<std::uint32_t>& order);
  /// Bytes the grid keeps for its cells' starts (the memory sort or sortSparse chose).
  std::size_t startBytes() const;

  /// c in [0, cellCount()]: cellCount() gives the number of points.
  std::uint32_t cellStart(std::uint32_t c) const {
    // A row's first cell starts where the row before ends: (row - 1, nx), always in range.
    const std::uint32_t nx = static_cast<std::uint32_t>(dims_[0]);
    if (c == 0) return startOf(0, 0);
    return startOf((c - 1) / nx, static_cast<int>((c - 1) % nx) + 1);
  }

  /// Calls f(lo, hi) for the <= (2 reach + 1)^2 ranges [lo, hi) of sorted points in the
  /// cells within `reach` of p's cell (valid after sort(); indices into the sorted order).
  template <class F>
  void forEachNeighborRange(const Vec3& p, F&& f) const {
    forEachRangeWithin(p, reach_, f);
  }

  /// As forEachRangeWithin(p, reach, f), without the cells that lie `radius` or farther
  /// from p: rows the sphere misses are left out and each row's x-range is cut to the cells
  /// it reaches. Every point within `radius` of p in those cells is still in a range, the
  /// ranges in the same order (a loop that tests the distance sees the same points pass,
  /// in the same order). The radius is taken a little larger (rounding in the cells' bounds);
  /// a cell's gap to p is to its bounds nearest p (an outer cell's points clamped into it lie
  /// farther, unless p's own cell, whose gap is 0). `from_own_row`: only p's row and the
  /// rows after it (the points sorted after p's cell's start lie there: a search for the
  /// later neighbours of a sorted point).
  template <class F>
  void forEachRangeInSphere(const Vec3& p, int reach, double radius, bool from_own_row,
                            F&& f) const {
    constexpr int kMaxReach = 4;
    if (reach > kMaxReach) return forEachRangeWithin(p, reach, f);
    // Squared gaps, in cells, from p to the cells at offsets -reach..reach along each axis.
    double gap_sq[3][2 * kMaxReach + 1];
    const Eigen::Vector3i c = cellCoord(p);
    for (int k = 0; k < 3; ++k) {
      const double frac = (p[k] - origin_[k]) * inv_cell_ - c[k];
      gap_sq[k][reach] = 0.0;
      for (int o = 1; o <= reach; ++o) {
        const double below = frac + (o - 1), above = o - frac;
        gap_sq[k][reach - o] = below * below;
        gap_sq[k][reach + o] = above * above;
      }
    }
    const double r = radius * inv_cell_ * (1.0 + 1e-9) + 1e-9;
    const double r_sq = r * r;
    const int x0 = firstCell(c[0], reach), x1 = lastCell(0, c[0], reach);
    const int y0 = firstCell(c[1], reach), y1 = lastCell(1, c[1], reach);
    const int z0 = from_own_row ? c[2] : firstCell(c[2], reach), z1 = lastCell(2, c[2], reach);
    for (int z = z0; z <= z1; ++z) {
      const double gz_sq = gap_sq[2][z - c[2] + reach];
      if (gz_sq >= r_sq) continue;
      for (int y = (from_own_row && z == c[2]) ? c[1] : y0; y <= y1; ++y) {
        const double d_sq = gz_sq + gap_sq[1][y - c[1] + reach];
        if (d_sq >= r_sq) continue;
        int xa = c[0], xb = c[0];
        for (int o = 1; o <= reach; ++o) {
          xa -= gap_sq[0][reach - o] + d_sq < r_sq;
          xb += gap_sq[0][reach + o] + d_sq < r_sq;
        }
        visitRow(y, z, xa > x0 ? xa : x0, xb < x1 ? xb : x1, f);
      }
    }
  }

  /// As forEachNeighborRange, with the cells within `reach` (>= 0) of p's cell.
  template <class F>
  void forEachRangeWithin(const Vec3& p, int reach, F&& f) const {
    const Eigen::Vector3i c = cellCoord(p);
    const int x0 = firstCell(c[0], reach), x1 = lastCell(0, c[0], reach);
    const int y0 = firstCell(c[1], reach), y1 = lastCell(1, c[1], reach);
    const int z0 = firstCell(c[2], reach), z1 = lastCell(2, c[2], reach);
    for (int z = z0; z <= z1; ++z)
      for (int y = y0; y <= y1; ++y)
        visitRow(y, z, x0, x1, f);
  }

 private:
  /// The first and last of the cells c - reach .. c + reach along axis k in the grid.
  static int firstCell(int c, int reach) { return c - reach > 0 ? c - reach : 0; }
  int lastCell(int k, int c, int reach) const {
    return c + reach < dims_[k] ? c + reach : dims_[k] - 1;
  }
  /// f(lo, hi) with the sorted points of cells xa..xb of row (y, z), when it has any.
  template <class F>
  void visitRow(int y, int z, int xa, int xb, F& f) const {
    const std::uint32_t row = static_cast<std::uint32_t>(z * dims_[1] + y);
    std::uint32_t lo, hi;
    if (!sparse_) {
      const std::uint32_t first = row * static_cast<std::uint32_t>(dims_[0]);
      lo = cell_start_[first + xa];
      hi = cell_start_[first + xb + 1];
    } else {
      lo = startOf(row, xa);
      hi = startOf(row, xb + 1);
    }
    if (lo < hi) f(lo, hi);
  }
  /// The start of cell x (0 .. dims.x: x = dims.x is the row's end) of row `row`.
  std::uint32_t startOf(std::uint32_t row, int x) const {
    if (!sparse_) return cell_start_[row * static_cast<std::uint32_t>(dims_[0]) + x];
    if (row_start_.empty()) return 0;  // not sorted yet: no points
    for (std::uint32_t s = row_stretches_[row], e = row_stretches_[row + 1]; s < e; ++s) {
      const RowStretch& g = stretches_[s];
      if (x <= g.x0) return cell_start_[g.starts];
      if (x <= g.x1) return cell_start_[g.starts + (x - g.x0)];
    }
    return row_start_[row + 1];  // after the row's last stretch: where the row ends
  }

  /// Cells x0..x1 of a row hold every point of a stretch of it; their starts are
  /// cell_start_[starts ..]. A point-less cell before the stretch starts where cell x0
  /// does; one after it, where the next stretch (or the row's end) does.
  struct RowStretch {
    int x0 = 0, x1 = 0;
    std::uint32_t starts = 0;
  };
  /// Cells this many or fewer apart along a row, both with points, share a stretch.
  static constexpr int kStretchGap = 4;

  Vec3 origin_ = Vec3::Zero();
  double cell_size_ = 1.0, inv_cell_ = 1.0;
  int reach_ = 1;
  Eigen::Vector3i dims_ = Eigen::Vector3i::Ones();
  /// Dense (sort): (cells + 1) starts. Sparse (sortSparse, and before any sort): the
  /// stretches' starts.
  std::vector<std::uint32_t> cell_start_;
  std::vector<std::uint32_t> cell_of_;  // (points) scratch of the vector sorts
  bool sparse_ = true;
  std::vector<std::uint32_t> row_start_;      // sparse: (rows + 1) start of each row
  std::vector<std::uint32_t> row_stretches_;  // sparse: (rows + 1) into stretches_
  std::vector<RowStretch> stretches_;
};

/// Where each point's list starts in a buffer of lists laid one after another (4 bytes a
/// point, not 8): a 64-bit start per block of kBlock points, and each point's start as 32
/// bits from its block's. A block's points are set in ascending order (its first one
/// first); set throws std::length_error where a point's start lies 2^32 entries or more
/// past its block's (over 67 million entries a point).
class ListStarts {
 public:
  static constexpr unsigned kBlockBits = 6;
  static constexpr std::size_t kBlock = std::size_t(1) << kBlockBits;

  std::uint64_t operator[](std::size_t i) const { return block_[i >> kBlockBits] + low_[i]; }
  std::size_t size() const { return low_.size(); }
  void resize(std::size_t n) {
    low_.resize(n);
    block_.resize((n + kBlock - 1) >> kBlockBits);
  }
  /// Whether start could be set for point i (within 2^32 of its block's start; always
  /// for a block's first point), and then sets it.
  bool trySet(std::size_t i, std::uint64_t start) {
    if ((i & (kBlock - 1)) == 0) block_[i >> kBlockBits] = start;
    const std::uint64_t d = start - block_[i >> kBlockBits];
    if (d > 0xffffffffu) return false;
    low_[i] = static_cast<std::uint32_t>(d);
    return true;
  }
  void set(std::size_t i, std::uint64_t start);
  /// Starts from counts: fill counts() (n) with each point's entries, then
  /// startsFromCounts() lays the lists one after another from 0 and returns their total
  /// (throws as set).
  std::uint32_t* counts() { return low_.data(); }
  std::uint64_t startsFromCounts();
  /// Bytes held.
  std::size_t bytes() const { return low_.capacity() * 4 + block_.capacity() * 8; }

 private:
  std::vector<std::uint32_t> low_;    ///< (n) start - block start
  std::vector<std::uint64_t> block_;  ///< (blocks) the start of each block's first point
};

/// Each pair of points within a radius once, in the list of its lower index: what the
/// symmetric pair loops (sph/fluid.cpp) read. The points are cut into ranges, one per
/// thread of the build (a loop over the pairs runs range by range, each range writing only
/// its own points):
/// - the later neighbours (j > i) of point i, ascending, are
///   later[r][begin[i] .. begin[i] + count[i]) (r: i's range); the ranges start at
///   multiples of ListStarts::kBlock (a block of starts lies in one range's buffer);
/// - the earlier neighbours of point i that lie before its range's start (the pairs a
///   range computes from its own side), ascending, are before[r][before_offset[r][q] ..
///   before_offset[r][q + 1]) with q = i - range[r], for q < before_offset[r].size() - 1;
///   the range's later points have none.
struct PairLists {
  std::vector<std::size_t> range;  ///< (ranges + 1): range r is [range[r], range[r + 1])
  std::vector<std::vector<std::uint32_t>> later;                  ///< (ranges)
  ListStarts begin;                                               ///< (n) into later[r]
  std::vector<std::uint32_t> count;                               ///< (n)
  std::vector<std::vector<std::uint32_t>> before_offset, before;  ///< (ranges)
  std::size_t span = 0;                                           ///< largest j - i of a pair
  /// (ranges) The end of range r's last list in later[r]: the lists lie one after another,
  /// each point's from begin[i] to the next one's start. Lists filtered in place
  /// (keepPairsWithin) hold point i's candidates there (candidates(i, r)), its count[i]
  /// pairs first; after a build every entry is a pair.
  std::vector<std::uint64_t> end;

  std::size_t size() const { return count.size(); }
  std::size_t ranges() const { return range.empty() ? 0 : range.size() - 1; }
  /// The entries of point i's list (its candidates; r: i's range).
  std::uint64_t candidates(std::size_t i, std::size_t r) const {
    return (i + 1 < range[r + 1] ? begin[i + 1] : end[r]) - begin[i];
  }
  /// The range of point i.
  std::size_t rangeOf(std::size_t i) const;
};

/// Builds the pair lists of the sorted points within `radius` (strictly closer), one range
/// per OpenMP thread. `points` must be in the grid's sorted order. The lists do not depend
/// on the number of threads; only where the ranges are cut does. `wide`: candidates tested
/// four at a time where the CPU has AVX (hasWideLanes(); the same lists).
void buildPairLists(const UniformGrid& grid, const std::vector<Vec3>& points, double radius,
                    PairLists& out, bool wide = hasWideLanes());
/// As buildPairLists, for the n points from `points` on.
void buildPairLists(const UniformGrid& grid, const Vec3* points, std::size_t n, double radius,
                    PairLists& out, bool wide = hasWideLanes());

/// Keeps of the pairs `lists` holds (pair lists of the same points, e.g. built with a larger
/// radius when they were elsewhere: every pair listed, or the candidates of a call before)
/// those now closer than `radius`: what buildPairLists would give for these points in this
/// order (each list ascending), when every such pair is listed. In place, in the lists'
/// own memory: each point's list becomes its pairs now (count[i]) followed by its other
/// candidates (both ascending), so the next call filters all of them again
/// (PairLists::candidates). Throws std::logic_error when the lists are for another number
/// of points.
void keepPairsWithin(PairLists& lists, const std::vector<Vec3>& points, double radius);

/// As keepPairsWithin, into `out`, leaving `candidates` as they are.
void filterPairLists(const PairLists& candidates, const std::vector<Vec3>& points, double radius,
                     PairLists& out);

/// Flat neighbour lists: neighbours of point i are index[offset[i] .. offset[i + 1]).
struct NeighborList {
  std::vector<std::uint64_t> offset;  ///< (n + 1)
  std::vector<std::uint32_t> index;   ///< (total pairs), never contains i itself
  /// The number of earlier neighbours (j < i) of each point: its later ones start at
  /// offset[i] + lower_count[i].
  std::vector<std::uint32_t> lower_count;  ///< (n)
  PairLists pairs;                         ///< scratch of buildNeighborList: each pair once

  std::size_t size() const { return offset.empty() ? 0 : offset.size() - 1; }
  std::uint64_t begin(std::size_t i) const { return offset[i]; }
  std::uint64_t end(std::size_t i) const { return offset[i + 1]; }
};

/// Builds the lists of all sorted points within `radius` (strictly closer) of each point,
/// each list in ascending order: the pair lists (buildPairLists), each point's earlier
/// neighbours then read from the others' lists. `points` must be in the grid's sorted
/// order. OpenMP; the result does not depend on the number of threads.
void buildNeighborList(const UniformGrid& grid, const std::vector<Vec3>& points, double radius,
                       NeighborList& out);

}  // namespace wake
