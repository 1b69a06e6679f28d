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
  const int threads = omp_get_max_threads();
  // Each thread gathers the lists of one contiguous chunk of points into its own buffer;
  // the buffers are then concatenated in chunk order (independent of the thread count).
  std::vector<std::uint64_t> chunk_size(static_cast<std::size_t>(threads) + 1, 0);
  if (out.chunks.size() < static_cast<std::size_t>(threads))
    out.chunks.resize(static_cast<std::size_t>(threads));
#pragma omp parallel num_threads(threads)
  {
    const int t = omp_get_thread_num();
    std::vector<std::uint32_t>& local = out.chunks[static_cast<std::size_t>(t)];
    const std::size_t nt = static_cast<std::size_t>(omp_get_num_threads());
    const std::size_t lo = n * static_cast<std::size_t>(t) / nt;
    const std::size_t hi = n * static_cast<std::size_t>(t + 1) / nt;
    // Branch-free append: write every candidate, advance the cursor only for neighbours.
    std::size_t used = 0;
    for (std::size_t i = lo; i < hi; ++i) {
      const double xi = points[i][0], yi = points[i][1], zi = points[i][2];
      const std::size_t before = used;
      grid.forEachNeighborRange(points[i], [&](std::uint32_t b, std::uint32_t e) {
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
          used += static_cast<std::size_t>((dx * dx + dy * dy + dz * dz < radius_sq) & (j != i));
        }
      });
      out.offset[i + 1] = used - before;
    }
    chunk_size[static_cast<std::size_t>(t) + 1] = used;
#pragma omp barrier
#pragma omp single
    {
      for (std::size_t i = 0; i < n; ++i)
        out.offset[i + 1] += out.offset[i];
      for (std::size_t k = 0; k < nt; ++k)
        chunk_size[k + 1] += chunk_size[k];
      out.index.resize(out.offset[n]);
    }
    if (used > 0)
      std::memcpy(out.index.data() + chunk_size[static_cast<std::size_t>(t)], local.data(),
                  used * sizeof(std::uint32_t));
  }
}

}  // namespace wake
