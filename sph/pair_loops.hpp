// The walk over the pair lists (sph/neighbor_grid.hpp) that every symmetric pair loop
// shares: ranges in parallel, and within a range each point's earlier neighbours before
// the range, then its later ones. A loop that adds each pair's terms to both points (the
// other point only when it lies in the same range) sums every point's terms in the order of
// its whole neighbour list, so the sums are the same bits on any number of threads.
#pragma once

#include "sph/neighbor_grid.hpp"

#include <omp.h>

#include <cstdint>
#include <vector>

namespace wake {

/// Calls f(lo, hi, r) for each range r = [lo, hi) of the pair lists, in parallel: the
/// ranges of the symmetric pair loops below (each writes only its own points).
template <class F>
void forEachRange(const PairLists& pairs, F&& f) {
  const std::int64_t ranges = static_cast<std::int64_t>(pairs.ranges());
#pragma omp parallel for schedule(static, 1)
  for (std::int64_t r = 0; r < ranges; ++r)
    f(static_cast<std::int64_t>(pairs.range[r]), static_cast<std::int64_t>(pairs.range[r + 1]),
      static_cast<std::size_t>(r));
}

/// The two passes of a symmetric pair loop over range r = [i0, i1) of the pair lists:
/// f(i, nb, k, e, false) with each point's earlier neighbours before i0, nb[k .. e)
/// (maybe none), then f(i, nb, k, e, true) with its later neighbours, point after point.
template <class F>
inline void forEachListOfRange(const PairLists& pairs, std::size_t r, std::int64_t i0,
                               std::int64_t i1, F&& f) {
  const std::vector<std::uint32_t>& off = pairs.before_offset[r];
  const std::uint32_t* before = pairs.before[r].data();
  for (std::int64_t i = i0; i < i1; ++i) {
    const std::size_t q = static_cast<std::size_t>(i - i0);
    if (q + 1 < off.size())
      f(i, before, off[q], off[q + 1], false);
    else
      f(i, before, 0, 0, false);
  }
  const std::uint32_t* later = pairs.later[r].data();
  for (std::int64_t i = i0; i < i1; ++i)
    f(i, later, pairs.begin[i], pairs.begin[i] + pairs.count[i], true);
}

/// A scalar symmetric pair loop over all the lists: f(i, j, both) for each entry j of
/// each point i's lists, in parallel over the ranges, in the order of forEachListOfRange.
/// `both`: j lies later in i's own range, the pair comes up only here, and f does j's side
/// too; otherwise j's side comes up in j's own call (from its earlier neighbours). Each
/// point's terms are then taken in the order of its whole list on any number of threads.
template <class F>
void forEachPairOnce(const PairLists& pairs, F&& f) {
  forEachRange(pairs, [&](std::int64_t i0, std::int64_t i1, std::size_t r) {
    const std::uint32_t end = static_cast<std::uint32_t>(i1);
    forEachListOfRange(
        pairs, r, i0, i1,
        [&](std::int64_t i, const std::uint32_t* nb, std::uint64_t k, std::uint64_t e, bool later) {
          for (std::uint64_t q = k; q < e; ++q)
            f(static_cast<std::size_t>(i), nb[q], later && nb[q] < end);
        });
  });
}

/// forEachPairOnce with each pair's stored value: f(i, j, both, value), value the entry
/// of `later` (of `before`) at the pair's place in the lists (per range, laid out as
/// pairs.later and pairs.before: e.g. PairDerivatives, sph/fluid.hpp).
template <class F>
void forEachPairOnceWith(const PairLists& pairs, const std::vector<std::vector<double>>& later,
                         const std::vector<std::vector<double>>& before, F&& f) {
  forEachRange(pairs, [&](std::int64_t i0, std::int64_t i1, std::size_t r) {
    const std::uint32_t end = static_cast<std::uint32_t>(i1);
    const double* value_later = later[r].data();
    const double* value_before = before[r].data();
    forEachListOfRange(pairs, r, i0, i1,
                       [&](std::int64_t i, const std::uint32_t* nb, std::uint64_t k,
                           std::uint64_t e, bool in_later) {
                         const double* value = in_later ? value_later : value_before;
                         for (std::uint64_t q = k; q < e; ++q)
                           f(static_cast<std::size_t>(i), nb[q], in_later && nb[q] < end, value[q]);
                       });
  });
}

}  // namespace wake
