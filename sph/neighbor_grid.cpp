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
  if (!(cell_size > 0.0)) throw std::invalid_argument("grid cell size must be > 0");
  if (reach < 1) throw std::invalid_argument("grid reach must be >= 1");
  if (domain.empty()) throw std::invalid_argument("grid domain is empty");
  const double cells = cellsFor(domain, cell_size);
  if (!(cells <= static_cast<double>(max_cells)))
    throw std::invalid_argument("domain too large for the kernel support: " +
                                std::to_string(static_cast<long long>(cells)) +
                                " grid cells (limit " + std::to_string(max_cells) +
                                "); shrink the domain or increase the particle radius");
  reset(domain, cell_size, reach);
}

void UniformGrid::reset(const Aabb& box, double cell_size, int reach) {
  origin_ = box.min;
  cell_size_ = cell_size;
  inv_cell_ = 1.0 / cell_size;
  reach_ = reach;
  for (int k = 0; k < 3; ++k)
    dims_[k] = static_cast<int>(std::max(1.0, std::ceil((box.max[k] - box.min[k]) * inv_cell_)));
  cell_start_.assign(cellCount() + 1, 0);
}

void UniformGrid::sort(const std::vector<Vec3>& points, std::vector<std::uint32_t>& order) {
  const std::size_t n = points.size();
  cell_of_.resize(n);
  order.resize(n);
  std::fill(cell_start_.begin(), cell_start_.end(), 0u);
  const std::int64_t sn = static_cast<std::int64_t>(n);
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < sn; ++i)
    cell_of_[i] = cellIndex(points[i]);
  // Histogram shifted by one, prefix sum gives the start of each cell.
  for (std::size_t i = 0; i < n; ++i)
    ++cell_start_[cell_of_[i] + 1];
  for (std::size_t c = 1; c < cell_start_.size(); ++c)
    cell_start_[c] += cell_start_[c - 1];
  // Scatter; cell_start_[c] is used as the running cursor of cell c, then restored.
  for (std::size_t i = 0; i < n; ++i)
    order[cell_start_[cell_of_[i]]++] = static_cast<std::uint32_t>(i);
  for (std::size_t c = cell_start_.size() - 1; c > 0; --c)
    cell_start_[c] = cell_start_[c - 1];
  cell_start_[0] = 0;
}

void buildNeighborList(const UniformGrid& grid, const std::vector<Vec3>& points, double radius,
                       NeighborList& out) {
  const std::size_t n = points.size();
  const double radius_sq = radius * radius;
  out.offset.assign(n + 1, 0);
  out.upper_start.resize(n);
  out.upper_count.resize(n);
  out.lower_count.resize(n);
  const int threads = omp_get_max_threads();
  if (out.chunks.size() < static_cast<std::size_t>(threads))
    out.chunks.resize(static_cast<std::size_t>(threads));
  // Largest j - i of a pair i < j: how far back the earlier neighbours of a point lie.
  std::vector<std::size_t> spans(static_cast<std::size_t>(threads), 0);
#pragma omp parallel num_threads(threads)
  {
    const std::size_t t = static_cast<std::size_t>(omp_get_thread_num());
    const std::size_t nt = static_cast<std::size_t>(omp_get_num_threads());
    auto chunk_begin = [&](std::size_t k) { return n * k / nt; };
    const std::size_t lo = chunk_begin(t), hi = chunk_begin(t + 1);

    // 1. Each thread lists the later neighbours of its points (every pair tested once).
    //    Branch-free append: write every candidate, advance the cursor only for neighbours.
    std::vector<std::uint32_t>& local = out.chunks[t];
    std::size_t used = 0, span = 0;
    for (std::size_t i = lo; i < hi; ++i) {
      const double xi = points[i][0], yi = points[i][1], zi = points[i][2];
      const std::size_t before = used;
      grid.forEachNeighborRange(points[i], [&](std::uint32_t b, std::uint32_t e) {
        if (b <= i) b = static_cast<std::uint32_t>(i + 1);  // the ranges ascend: j > i only
        if (b >= e) return;
        // Grown by a quarter (the buffer stays for the next steps, beside the list it is
        // copied into: doubling left up to twice the list's size unused).
        if (local.size() < used + (e - b))
          local.resize(used + (e - b) + std::max<std::size_t>(used / 4, 4096));
        std::uint32_t* dst = local.data();
        for (std::uint32_t j = b; j < e; ++j) {
          const double dx = xi - points[j][0];
          const double dy = yi - points[j][1];
          const double dz = zi - points[j][2];
          dst[used] = j;
          used += static_cast<std::size_t>(dx * dx + dy * dy + dz * dz < radius_sq);
        }
      });
      out.upper_start[i] = before;
      out.upper_count[i] = static_cast<std::uint32_t>(used - before);
      out.lower_count[i] = 0;
      if (used > before) span = std::max<std::size_t>(span, local[used - 1] - i);
    }
    spans[t] = span;
#pragma omp barrier
    // 2. The earlier neighbours of point i are the j < i whose later lists hold i: scan
    //    the lists of j in [lo - span, hi) in ascending j, keeping the entries in [lo, hi).
    const std::size_t reach = *std::max_element(spans.begin(), spans.end());
    auto for_each_earlier = [&](auto&& f) {
      const std::size_t first = lo > reach ? lo - reach : 0;
      if (first >= hi) return;
      std::size_t c = 0;
      while (chunk_begin(c + 1) <= first)
        ++c;
      for (std::size_t j = first; j < hi; ++j) {
        while (chunk_begin(c + 1) <= j)
          ++c;
        const std::uint32_t* later = out.chunks[c].data() + out.upper_start[j];
        for (std::uint32_t k = 0, m = out.upper_count[j]; k < m; ++k) {
          const std::uint32_t i = later[k];
          if (i >= hi) break;  // ascending
          if (i >= lo) f(static_cast<std::uint32_t>(j), i);
        }
      }
    };
    for_each_earlier([&](std::uint32_t, std::uint32_t i) { ++out.lower_count[i]; });
    for (std::size_t i = lo; i < hi; ++i)
      out.offset[i + 1] = out.lower_count[i] + out.upper_count[i];
#pragma omp barrier
#pragma omp single
    {
      for (std::size_t i = 0; i < n; ++i)
        out.offset[i + 1] += out.offset[i];
      out.index.resize(out.offset[n]);
    }
    // 3. Each list: its earlier neighbours (ascending j), then its later ones.
    for (std::size_t i = lo; i < hi; ++i)
      out.lower_count[i] = 0;
    std::uint32_t* index = out.index.data();
    for_each_earlier(
        [&](std::uint32_t j, std::uint32_t i) { index[out.offset[i] + out.lower_count[i]++] = j; });
    for (std::size_t i = lo; i < hi; ++i)
      if (out.upper_count[i] > 0)
        std::memcpy(index + out.offset[i] + out.lower_count[i], local.data() + out.upper_start[i],
                    out.upper_count[i] * sizeof(std::uint32_t));
  }
}

}  // namespace wake
