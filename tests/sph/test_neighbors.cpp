// Neighbour search on the uniform grid equals brute force.
#include "sph/neighbor_grid.hpp"

#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>
#include <set>
#include <string>

using namespace wake;

namespace {

std::vector<std::set<std::uint32_t>> bruteForce(const std::vector<Vec3>& x, double r) {
  std::vector<std::set<std::uint32_t>> out(x.size());
  for (std::size_t i = 0; i < x.size(); ++i)
    for (std::size_t j = 0; j < x.size(); ++j)
      if (i != j && (x[i] - x[j]).squaredNorm() < r * r) out[i].insert(std::uint32_t(j));
  return out;
}

/// n points uniform in the cube [lo, hi]^3.
std::vector<Vec3> randomPoints(std::size_t n, double lo, double hi, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(lo, hi);
  std::vector<Vec3> x(n);
  for (Vec3& p : x)
    p = Vec3(u(rng), u(rng), u(rng));
  return x;
}

/// Sorts `x` by the grid's cells: the sorted points, and in `order` the input index of each.
std::vector<Vec3> sortedByCell(UniformGrid& grid, const std::vector<Vec3>& x,
                               std::vector<std::uint32_t>& order) {
  grid.sort(x, order);
  std::vector<Vec3> sorted(x.size());
  for (std::size_t k = 0; k < x.size(); ++k)
    sorted[k] = x[order[k]];
  return sorted;
}

/// `pairs` holds, for each point i, its later neighbours (j > i, ascending) and its
/// earlier ones before its range's start, as `expected` (each point's neighbours) says.
void expectPairLists(const PairLists& pairs, const std::vector<std::set<std::uint32_t>>& expected,
                     const std::string& what) {
  ASSERT_EQ(pairs.size(), expected.size()) << what;
  ASSERT_EQ(pairs.range.front(), 0u) << what;
  ASSERT_EQ(pairs.range.back(), expected.size()) << what;
  for (std::size_t rg = 0; rg < pairs.ranges(); ++rg) {
    const std::size_t lo = pairs.range[rg];
    const std::vector<std::uint32_t>& off = pairs.before_offset[rg];
    for (std::size_t i = lo; i < pairs.range[rg + 1]; ++i) {
      ASSERT_EQ(pairs.rangeOf(i), rg) << what;
      const std::uint32_t* later = pairs.later[rg].data() + pairs.begin[i];
      const std::vector<std::uint32_t> got_later(later, later + pairs.count[i]);
      std::vector<std::uint32_t> want_later, want_before;
      for (std::uint32_t j : expected[i]) {  // ascending
        if (j > i) want_later.push_back(j);
        if (j < lo) want_before.push_back(j);
      }
      EXPECT_EQ(got_later, want_later) << "point " << i << ", " << what;
      std::vector<std::uint32_t> got_before;
      if (i - lo + 1 < off.size())
        got_before.assign(pairs.before[rg].begin() + off[i - lo],
                          pairs.before[rg].begin() + off[i - lo + 1]);
      EXPECT_EQ(got_before, want_before) << "point " << i << ", " << what;
    }
  }
}

/// Sorts the points by cell, builds lists, and compares with brute force on sorted points:
/// with cells of the radius (reach 1) and of half of it (reach 2), on 1, 2, 3 and 7 threads
/// (more threads than points included). Each list must ascend and be the same on any
/// number of threads; so must the pair lists' later and before-the-range lists.
void expectMatchesBruteForce(std::vector<Vec3> x, const Aabb& domain, double r) {
  for (int reach : {1, 2}) {
    UniformGrid grid(domain, r / reach, UniformGrid::kMaxCells, reach);
    std::vector<std::uint32_t> order;
    const std::vector<Vec3> sorted = sortedByCell(grid, x, order);
    ASSERT_EQ(order.size(), x.size());
    // order is a permutation
    std::vector<std::uint32_t> check = order;
    std::sort(check.begin(), check.end());
    for (std::size_t k = 0; k < check.size(); ++k)
      ASSERT_EQ(check[k], k);

    const auto expected = bruteForce(sorted, r);
    NeighborList first;
    const int threads_before = omp_get_max_threads();
    for (int threads : {1, 2, 3, 7}) {
      omp_set_num_threads(threads);
      NeighborList list;
      buildNeighborList(grid, sorted, r, list);
      ASSERT_EQ(list.size(), sorted.size());
      for (std::size_t i = 0; i < sorted.size(); ++i) {
        const std::vector<std::uint32_t> got(list.index.begin() + list.begin(i),
                                             list.index.begin() + list.end(i));
        EXPECT_TRUE(std::adjacent_find(got.begin(), got.end(), std::greater_equal<>()) == got.end())
            << "list of " << i << " does not strictly ascend (reach " << reach << ", " << threads
            << " threads)";
        EXPECT_EQ(std::set<std::uint32_t>(got.begin(), got.end()), expected[i])
            << "particle " << i << ", reach " << reach << ", " << threads << " threads";
      }
      // The pair lists: each point's later neighbours, and those of its earlier ones
      // that lie before its range's start (one range per thread); candidates tested one
      // at a time and, where the CPU has AVX, four at a time.
      for (bool wide : {false, true}) {
        if (wide && !hasWideLanes()) continue;
        PairLists pairs;
        buildPairLists(grid, sorted, r, pairs, wide);
        ASSERT_EQ(pairs.ranges(), std::size_t(threads));
        expectPairLists(pairs, expected,
                        "reach " + std::to_string(reach) + ", " + std::to_string(threads) +
                            " threads" + (wide ? ", four at a time" : ""));
      }
      if (threads == 1) {
        first = list;
      } else {
        EXPECT_EQ(list.offset, first.offset) << threads << " threads";
        EXPECT_EQ(list.index, first.index) << threads << " threads";
      }
    }
    omp_set_num_threads(threads_before);
  }
}

const Aabb kCube{Vec3(-1, -1, -1), Vec3(1, 1, 1)};

}  // namespace

TEST(Neighbors, RandomPoints) {
  expectMatchesBruteForce(randomPoints(1500, -1, 1, 1), kCube, 0.15);
}

TEST(Neighbors, ClusteredPoints) {
  std::mt19937 rng(2);
  std::normal_distribution<double> g(0.0, 0.03);
  std::vector<Vec3> x;
  for (const Vec3& c : {Vec3(0.5, 0.5, 0.5), Vec3(-0.3, 0.1, -0.7)})
    for (int i = 0; i < 600; ++i)
      x.push_back(c + Vec3(g(rng), g(rng), g(rng)));
  expectMatchesBruteForce(x, kCube, 0.05);
}

TEST(Neighbors, PointsOnCellBorders) {
  // Points exactly on cell faces, and pairs exactly `r` apart (not neighbours: strict).
  const double r = 0.25;
  std::vector<Vec3> x;
  for (int i = -4; i <= 4; ++i)
    for (int j = -4; j <= 4; ++j)
      x.push_back(Vec3(i * r, j * r, 0.0));
  x.push_back(Vec3(0.1, 0.1, 0.25));
  expectMatchesBruteForce(x, kCube, r);
}

TEST(Neighbors, OutsideDomainIsClampedNotLost) {
  std::vector<Vec3> x = {Vec3(1.2, 0, 0), Vec3(0.98, 0, 0), Vec3(-1.0, -1.0, -1.0)};
  expectMatchesBruteForce(x, kCube, 0.3);
}

TEST(Neighbors, ListStartsKeepSixtyFourBitStartsInFourBytesAPoint) {
  // Starts far beyond 2^32 (a block's own start), lists of every length up to 2^32 - 1
  // entries in a block; one entry more throws.
  ListStarts starts;
  const std::size_t n = 3 * ListStarts::kBlock + 5;
  starts.resize(n);
  std::vector<std::uint64_t> expected(n);
  std::uint64_t at = (std::uint64_t(1) << 40) + 3;
  for (std::size_t i = 0; i < n; ++i) {
    expected[i] = at;
    starts.set(i, at);
    at += (i % 7 == 3) ? 0x07ffffffu : i;  // a few long lists
  }
  for (std::size_t i = 0; i < n; ++i)
    EXPECT_EQ(starts[i], expected[i]) << i;
  EXPECT_LE(starts.bytes(), 4 * n + 8 * (n / ListStarts::kBlock + 1) + 64);
  // From counts: the same as setting the running sums.
  ListStarts from;
  from.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    from.counts()[i] = static_cast<std::uint32_t>(i + 1 < n ? expected[i + 1] - expected[i] : 9);
  EXPECT_EQ(from.startsFromCounts(), expected[n - 1] - expected[0] + 9);
  for (std::size_t i = 0; i < n; ++i)
    EXPECT_EQ(from[i], expected[i] - expected[0]) << i;
  // 2^32 - 1 past the block's start fits; 2^32 does not.
  ListStarts edge;
  edge.resize(ListStarts::kBlock);
  const std::uint64_t most = 0xffffffffu;
  edge.set(0, 100);
  edge.set(1, 100 + most);
  EXPECT_EQ(edge[1], 100 + most);
  EXPECT_THROW(edge.set(2, 100 + most + 1), std::length_error);
}

TEST(Neighbors, RangesStartAtBlocksOfListStarts) {
  // Lists built on 1 to 3 threads for point counts around a block: every range starts at a
  // multiple of ListStarts::kBlock, and the lists are the brute force's.
  const int threads_before = omp_get_max_threads();
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(0.0, 0.3);
  for (std::size_t count :
       {std::size_t(5), ListStarts::kBlock - 1, ListStarts::kBlock + 1, std::size_t(1000)}) {
    std::vector<Vec3> x(count);
    for (Vec3& p : x)
      p = Vec3(u(rng), u(rng), u(rng));
    const double r = 0.08;
    UniformGrid grid(Aabb{Vec3::Zero(), Vec3::Constant(0.3)}, r);
    std::vector<std::uint32_t> order;
    grid.sort(x, order);
    std::vector<Vec3> sorted(count);
    for (std::size_t k = 0; k < count; ++k)
      sorted[k] = x[order[k]];
    for (int threads = 1; threads <= 3; ++threads) {
      omp_set_num_threads(threads);
      PairLists lists;
      buildPairLists(grid, sorted, r, lists);
      ASSERT_EQ(lists.ranges(), std::size_t(threads));
      for (std::size_t q = 0; q < lists.ranges(); ++q)
        EXPECT_EQ(lists.range[q] % ListStarts::kBlock, 0u) << count << " points, range " << q;
      EXPECT_EQ(lists.range.back(), count);
      expectPairLists(lists, bruteForce(sorted, r),
                      std::to_string(count) + " points, " + std::to_string(threads) + " threads");
    }
  }
  omp_set_num_threads(threads_before);
}

TEST(Neighbors, SparseStartsAreTheDenseOnes) {
  // Few points in many cells, as boundary samples: a plane's samples (a row full of
  // points), two walls across every row (the tank's ends), points a cell or two apart
  // and farther (stretches joined and not), some beyond the grid (clamped into its edge
  // cells), clusters in one cell. sortSparse gives the dense sort's order, every cell's
  // start, and the same ranges to the queries; and keeps less than a tenth of the bytes.
  const Aabb box{Vec3(-1, -1, -1), Vec3(1, 1, 1)};
  std::mt19937 rng(51);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Vec3> x;
  for (int k = 0; k < 900; ++k)
    x.push_back(Vec3(u(rng), u(rng), -0.93));  // floor
  for (int k = 0; k < 600; ++k)
    x.push_back(Vec3(k % 2 ? -0.95 : 0.91, u(rng), u(rng)));  // ends
  for (int k = 0; k < 300; ++k) {                             // along a row, gaps of 1 to 7 cells
    const double cell = 0.04;
    x.push_back(Vec3(-1 + cell * (0.5 + (k * 7) % 50), 0.1 + 0.001 * (k % 3), 0.2));
  }
  for (int k = 0; k < 200; ++k)
    x.push_back(Vec3(u(rng), u(rng), u(rng)));
  for (int k = 0; k < 50; ++k)
    x.push_back(Vec3(3 * u(rng), 2.5, u(rng)));  // beyond the grid
  for (int k = 0; k < 40; ++k)
    x.push_back(Vec3(0.301, -0.299, 0.5));  // one cell
  std::shuffle(x.begin(), x.end(), rng);
  for (int reach : {1, 2}) {
    UniformGrid dense(box, 0.04, UniformGrid::kMaxCells, reach), sparse = dense;
    std::vector<std::uint32_t> order_dense, order_sparse;
    dense.sort(x, order_dense);
    sparse.sortSparse(x, order_sparse);
    ASSERT_EQ(order_sparse, order_dense) << "reach " << reach;
    const std::uint32_t cells = static_cast<std::uint32_t>(dense.cellCount());
    std::size_t mismatches = 0;
    for (std::uint32_t c = 0; c <= cells; ++c)
      mismatches += sparse.cellStart(c) != dense.cellStart(c);
    EXPECT_EQ(mismatches, 0u) << "reach " << reach;
    EXPECT_LT(sparse.startBytes(), dense.startBytes() / 10) << "reach " << reach;
    std::vector<Vec3> sorted(x.size());
    for (std::size_t k = 0; k < x.size(); ++k)
      sorted[k] = x[order_dense[k]];
    using Ranges = std::vector<std::pair<std::uint32_t, std::uint32_t>>;
    auto ranges = [&](const UniformGrid& g, const Vec3& p, int mode) {
      Ranges out;
      auto f = [&](std::uint32_t lo, std::uint32_t hi) { out.emplace_back(lo, hi); };
      if (mode == 0) g.forEachRangeWithin(p, reach, f);
      if (mode == 1) g.forEachRangeInSphere(p, reach, 0.07, false, f);
      if (mode == 2) g.forEachNeighborRange(p, f);
      return out;
    };
    std::size_t visited = 0;
    for (int q = 0; q < 3000; ++q) {
      const Vec3 p =
          q < 1500 ? sorted[q % sorted.size()] : Vec3(1.2 * u(rng), 1.2 * u(rng), 1.2 * u(rng));
      for (int mode = 0; mode < 3; ++mode) {
        const Ranges want = ranges(dense, p, mode);
        ASSERT_EQ(ranges(sparse, p, mode), want) << "query " << q << ", mode " << mode;
        visited += want.size();
      }
    }
    EXPECT_GT(visited, 10000u);
  }
  // Before any sort a grid has no points: every start 0.
  const UniformGrid empty(box, 0.04);
  EXPECT_EQ(empty.cellStart(17), 0u);
}

TEST(Neighbors, CellCoordinatesAreTheFloorClampedIntoTheGrid) {
  // floor((p - origin) / cell) clamped to [0, dims - 1] on each axis: points inside, on
  // cell faces, just below zero (-0.5 cell: floor -1, clamped to 0), beyond either side,
  // -0.0, and NaN (cell 0).
  const UniformGrid grid(kCube, 0.3);
  const Eigen::Vector3i dims = grid.dims();
  const double cell = grid.cellSize();
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  std::vector<Vec3> points;
  for (int t = 0; t < 2000; ++t)
    points.push_back(Vec3(u(rng), u(rng), u(rng)));
  for (int k = -3; k <= dims.maxCoeff() + 3; ++k)
    points.push_back(Vec3::Constant(-1.0 + k * cell));
  points.push_back(Vec3::Constant(-1.0 - 0.5 * cell));
  points.push_back(Vec3(-0.0, 1e300, -1e300));
  for (const Vec3& p : points) {
    const Eigen::Vector3i c = grid.cellCoord(p);
    for (int k = 0; k < 3; ++k) {
      const double f = std::floor((p[k] - -1.0) * (1.0 / cell));
      const int expect = f < 0 ? 0 : (f > dims[k] - 1 ? dims[k] - 1 : int(f));
      EXPECT_EQ(c[k], expect) << p.transpose() << " axis " << k;
    }
  }
  const Eigen::Vector3i nan = grid.cellCoord(Vec3::Constant(std::nan("")));
  EXPECT_EQ(nan, Eigen::Vector3i::Zero());
  EXPECT_EQ(grid.cellCoord(Vec3::Constant(1e300)), (dims - Eigen::Vector3i::Ones()).eval());
  EXPECT_EQ(grid.cellCoord(Vec3::Constant(-1e300)), Eigen::Vector3i::Zero());
}

TEST(Neighbors, EmptyAndSingle) {
  expectMatchesBruteForce({}, kCube, 0.1);
  expectMatchesBruteForce({Vec3(0.3, 0.2, 0.1)}, kCube, 0.1);
}

TEST(Neighbors, SameListsWithOneAndTwoThreads) {
  UniformGrid grid(kCube, 0.12);
  std::vector<std::uint32_t> order;
  const std::vector<Vec3> sorted = sortedByCell(grid, randomPoints(3000, -1, 1, 3), order);
  NeighborList one, two;
  omp_set_num_threads(1);
  buildNeighborList(grid, sorted, 0.12, one);
  omp_set_num_threads(2);
  buildNeighborList(grid, sorted, 0.12, two);
  EXPECT_EQ(one.offset, two.offset);
  EXPECT_EQ(one.index, two.index);
}

TEST(Neighbors, RejectsHugeGrids) {
  EXPECT_THROW(UniformGrid(Aabb{Vec3(0, 0, 0), Vec3(1000, 1000, 1000)}, 0.01),
               std::invalid_argument);
}

TEST(Neighbors, SphereQueryFindsWhatTheWholeBlockFinds) {
  // forEachRangeInSphere cuts the block of cells to those the sphere reaches: the points
  // within the radius, found in its ranges, are those found in the whole block's, in the
  // same order, from far fewer candidates. Points and queries partly outside the grid's
  // box (clamped into its outer cells), on cell borders, with reach 1, 2 and 3.
  std::vector<Vec3> x = randomPoints(3000, -0.3, 1.3, 21);
  const std::vector<Vec3> queries = randomPoints(3000, -0.3, 1.3, 22);
  for (int k = 0; k < 200; ++k)  // on the borders of cells of 0.1
    x[k] = Vec3(0.1 * (k % 10), 0.1 * ((k / 10) % 10), 0.05 * (k % 7));
  const Aabb box{Vec3::Zero(), Vec3::Ones()};
  for (int reach : {1, 2, 3}) {
    const double radius = 0.3;
    UniformGrid grid(box, radius / reach, UniformGrid::kMaxCells, reach);
    std::vector<std::uint32_t> order;
    const std::vector<Vec3> sorted = sortedByCell(grid, x, order);
    std::size_t block_candidates = 0, sphere_candidates = 0;
    for (std::size_t q = 0; q < sorted.size(); q += 3) {
      const Vec3 p = q % 2 ? sorted[q] : queries[q];
      for (bool from_own_row : {false, true}) {
        // The points within the radius (after q with from_own_row) among a visit's ranges.
        auto collect = [&](std::vector<std::uint32_t>* found, std::size_t* candidates) {
          return [&p, &sorted, found, candidates, from_own_row, q, radius](std::uint32_t lo,
                                                                           std::uint32_t hi) {
            for (std::uint32_t j = lo; j < hi; ++j) {
              ++*candidates;
              if ((!from_own_row || j > q) && (p - sorted[j]).squaredNorm() < radius * radius)
                found->push_back(j);
            }
          };
        };
        std::vector<std::uint32_t> block, sphere;
        grid.forEachRangeWithin(p, reach, collect(&block, &block_candidates));
        grid.forEachRangeInSphere(p, reach, radius, from_own_row,
                                  collect(&sphere, &sphere_candidates));
        if (from_own_row && q % 2 == 0) continue;  // only a sorted point's own rows
        ASSERT_EQ(sphere, block) << "reach " << reach << " query " << p.transpose();
      }
    }
    std::printf("[ sphere ] reach %d: %.2f of the block's candidates\n", reach,
                double(sphere_candidates) / double(block_candidates));
    EXPECT_LT(sphere_candidates, 0.8 * block_candidates) << "reach " << reach;
  }
}

TEST(Neighbors, FilteredCandidatesAreThePairsOfPointsMovedLessThanHalfTheSkin) {
  // Candidates within r + skin of sorted points; then every point moves (random
  // directions, up to just under skin / 2) without being sorted again: the candidates'
  // pairs now closer than r are every pair closer than r (brute force on the moved
  // points), in order, on any number of threads. Clustered points and points on a
  // lattice (many pairs at exactly r) as well as uniform ones.
  const double r = 0.15, skin = 0.03;
  std::vector<Vec3> x = randomPoints(1500, -1, 1, 31);
  for (int k = 0; k < 300; ++k)  // a lattice of spacing r / 2
    x[k] = Vec3(0.075 * (k % 7), 0.075 * ((k / 7) % 7), 0.075 * (k / 49));
  std::mt19937 rng(32);
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  UniformGrid grid(kCube, 0.5 * (r + skin), UniformGrid::kMaxCells, 2);
  std::vector<std::uint32_t> order;
  const std::vector<Vec3> sorted = sortedByCell(grid, x, order);
  std::vector<Vec3> moved = sorted;
  for (std::size_t i = 0; i < moved.size(); ++i) {
    if (i % 5 == 0) continue;  // some stay: pairs at exactly r on the lattice
    const Vec3 direction = Vec3(g(rng), g(rng), g(rng)).normalized();
    moved[i] += 0.4999 * skin * std::cbrt(u(rng)) * direction;
  }
  const auto expected = bruteForce(moved, r);
  std::size_t lost = 0;  // pairs the unmoved points' lists within r alone would miss
  for (std::size_t i = 0; i < moved.size(); ++i)
    for (std::uint32_t j : expected[i])
      lost += (sorted[i] - sorted[j]).squaredNorm() >= r * r;
  EXPECT_GT(lost, 50u) << "the points did not move enough to test the skin";
  const int threads_before = omp_get_max_threads();
  for (int threads : {1, 2, 3}) {
    omp_set_num_threads(threads);
    PairLists candidates, pairs;
    buildPairLists(grid, sorted, r + skin, candidates);
    filterPairLists(candidates, moved, r, pairs);
    expectPairLists(pairs, expected, std::to_string(threads) + " threads");
    // The same lists when nothing moved: a build within r.
    PairLists built, filtered;
    buildPairLists(grid, sorted, r, built);
    filterPairLists(candidates, sorted, r, filtered);
    EXPECT_EQ(filtered.count, built.count) << threads << " threads";
    EXPECT_EQ(filtered.span, built.span) << threads << " threads";
  }
  omp_set_num_threads(threads_before);
  PairLists none, out;
  EXPECT_THROW(filterPairLists(none, moved, r, out), std::logic_error);
  EXPECT_THROW(keepPairsWithin(none, moved, r), std::logic_error);
}

TEST(Neighbors, PairsKeptInPlaceStepAfterStepAreThePairsOfEachStep) {
  // The candidates within r + skin, filtered in their own memory step after step while the
  // points wander (each stays within skin / 2 of where the candidates were listed, and
  // pairs come and go many times): after every step, each point's list holds exactly its
  // pairs now, ascending (brute force), then its other candidates, ascending; the pairs
  // listed and the candidates' set never change otherwise; on 1, 2 and 3 threads.
  const double r = 0.15, skin = 0.04;
  std::vector<Vec3> x = randomPoints(1200, -1, 1, 41);
  for (int k = 0; k < 216; ++k)  // a lattice of spacing r / 2: pairs at exactly r
    x[k] = Vec3(0.075 * (k % 6), 0.075 * ((k / 6) % 6), 0.075 * (k / 36));
  UniformGrid grid(kCube, 0.5 * (r + skin), UniformGrid::kMaxCells, 2);
  std::vector<std::uint32_t> order;
  const std::vector<Vec3> sorted = sortedByCell(grid, x, order);
  const int threads_before = omp_get_max_threads();
  for (int threads : {1, 2, 3}) {
    omp_set_num_threads(threads);
    PairLists lists, built;
    buildPairLists(grid, sorted, r + skin, lists);
    buildPairLists(grid, sorted, r + skin, built);  // the candidates, untouched
    std::mt19937 rng(42 + threads);
    std::normal_distribution<double> g(0.0, 1.0);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::size_t changes = 0;
    std::vector<std::uint32_t> last_count;
    for (int step = 0; step < 12; ++step) {
      std::vector<Vec3> now = sorted;
      for (std::size_t i = 0; i < now.size(); ++i) {
        if ((i + step) % 4 == 0) continue;  // some at the lattice: pairs at exactly r
        const Vec3 direction = Vec3(g(rng), g(rng), g(rng)).normalized();
        now[i] += 0.4999 * skin * std::cbrt(u(rng)) * direction;
      }
      keepPairsWithin(lists, now, r);
      const std::string what = std::to_string(threads) + " threads, step " + std::to_string(step);
      expectPairLists(lists, bruteForce(now, r), what);
      PairLists fresh;  // the same from the untouched candidates
      filterPairLists(built, now, r, fresh);
      EXPECT_EQ(fresh.count, lists.count) << what;
      EXPECT_EQ(fresh.span, lists.span) << what;
      for (std::size_t i = 0; i < sorted.size(); ++i) {
        const std::size_t rg = lists.rangeOf(i);
        ASSERT_EQ(lists.candidates(i, rg), built.count[i]) << "point " << i << ", " << what;
        const std::uint32_t* list = lists.later[rg].data() + lists.begin[i];
        const std::uint32_t kept = lists.count[i];
        const std::uint32_t all = static_cast<std::uint32_t>(lists.candidates(i, rg));
        ASSERT_TRUE(std::is_sorted(list + kept, list + all)) << "point " << i << ", " << what;
        std::vector<std::uint32_t> set(list, list + all);
        std::sort(set.begin(), set.end());
        const std::uint32_t* cand = built.later[rg].data() + built.begin[i];
        ASSERT_EQ(set, std::vector<std::uint32_t>(cand, cand + all))
            << "point " << i << ", " << what;
      }
      if (!last_count.empty())
        for (std::size_t i = 0; i < sorted.size(); ++i)
          changes += lists.count[i] != last_count[i];
      last_count = lists.count;
    }
    EXPECT_GT(changes, 1000u) << "too few pairs came and went to test the merges";
  }
  omp_set_num_threads(threads_before);
}
