// Surfacing one large frame (README "Output": 1M particles in <= 10 s on 2 cores, <= 2 GB):
// a dam-break-like frame, a column of fluid on a lattice (spacing 2r, jittered by 0.2 r)
// with a thin sheet running up a wall and 3 % of the particles as spray above it, meshed
// with the default settings; then the files `wake surface` writes (.vdb, .ply). Prints
// the time of each stage, the mesh size, and the process's peak resident memory.
//   wake_bench_surface [--particles N] [--threads 1,2]
#include "io/mesh_files.hpp"
#include "surface/fluid_surface.hpp"

#include <openvdb/io/File.h>
#include <sys/resource.h>
#include <tbb/global_control.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <string>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

std::vector<wake::Vec3> frame(long n, double r) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> jitter(-0.2 * r, 0.2 * r), unit(0.0, 1.0);
  const long spray = n * 3 / 100, sheet = n * 7 / 100, column = n - spray - sheet;
  // Column 2:1:1 (x:y:z) in particles.
  const int nz = static_cast<int>(std::cbrt(column / 2.0));
  const int ny = nz, nx = static_cast<int>(column / (double(ny) * nz));
  std::vector<wake::Vec3> p;
  p.reserve(n);
  const double h = 2.0 * r;
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
      for (int k = 0; k < nz; ++k)
        p.emplace_back(i * h + jitter(rng), j * h + jitter(rng), k * h + jitter(rng));
  const double wall = (nx + 20) * h;  // the sheet: 3 particles thick, up the far wall
  const long per_layer = sheet / 3;
  const int sz = nz, sy = static_cast<int>(per_layer / sz);
  for (int l = 0; l < 3; ++l)
    for (int j = 0; j < sy; ++j)
      for (int k = 0; k < sz; ++k)
        p.emplace_back(wall - l * h + jitter(rng), j * h + jitter(rng), k * h + jitter(rng));
  while (static_cast<long>(p.size()) < n)  // spray: scattered above the column's front
    p.emplace_back((nx + 20 * unit(rng)) * h, (ny + 30 * unit(rng)) * h, nz * h * unit(rng));
  return p;
}

long peakKiB() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;
}

}  // namespace

int main(int argc, char** argv) {
  long particles = 1000000;
  std::vector<int> threads = {1, 2};
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--particles") && i + 1 < argc) {
      particles = std::stol(argv[++i]);
    } else if (!std::strcmp(argv[i], "--threads") && i + 1 < argc) {
      threads.clear();
      for (char* t = std::strtok(argv[++i], ","); t; t = std::strtok(nullptr, ","))
        threads.push_back(std::atoi(t));
    } else {
      std::fprintf(stderr, "usage: %s [--particles N] [--threads 1,2]\n", argv[0]);
      return 2;
    }
  }
  openvdb::initialize();
  const double r = 0.005;
  const std::vector<wake::Vec3> p = frame(particles, r);
  std::printf("surface of one frame: %zu particles, r = %g m, default settings\n", p.size(), r);
  std::printf(
      "threads  level set+mesh s  .vdb s  .ply s  total s  vertices  triangles  peak MiB\n");
  for (const int t : threads) {
    tbb::global_control control(tbb::global_control::max_allowed_parallelism, t);
    const auto t0 = Clock::now();
    const wake::FluidSurface s = wake::fluidSurface(p, r, wake::SurfaceSettings{});
    const double mesh_s = since(t0);
    const auto t1 = Clock::now();
    {
      openvdb::io::File file("/tmp/wake_bench_surface.vdb");
      file.write({s.level_set});
      file.close();
    }
    const double vdb_s = since(t1);
    const auto t2 = Clock::now();
    {
      std::ofstream(("/tmp/wake_bench_surface.ply"), std::ios::binary)
          << wake::plyMesh(s.mesh.vertices, s.mesh.triangles);
    }
    const double ply_s = since(t2);
    std::printf("%7d  %16.2f  %6.2f  %6.2f  %7.2f  %8zu  %9zu  %8.0f\n", t, mesh_s, vdb_s, ply_s,
                since(t0), s.mesh.vertices.size(), s.mesh.triangles.size(), peakKiB() / 1024.0);
  }
  std::remove("/tmp/wake_bench_surface.vdb");
  std::remove("/tmp/wake_bench_surface.ply");
  return 0;
}
