// Outside use of wake::surface and wake::io: the surface of a small block of particles,
// written as binary PLY bytes (checked, not written to disk).
#include "io/mesh_files.hpp"
#include "surface/fluid_surface.hpp"

#include <cstdio>

int main() {
  std::vector<wake::Vec3> particles;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 4; ++k)
        particles.emplace_back(0.02 * i, 0.02 * j, 0.02 * k);
  const wake::FluidSurface s = wake::fluidSurface(particles, 0.01, wake::SurfaceSettings{});
  const std::string ply = wake::plyMesh(s.mesh.vertices, s.mesh.triangles);
  std::printf("surface of %zu particles: %zu triangles, %zu PLY bytes\n", particles.size(),
              s.mesh.triangles.size(), ply.size());
  return s.mesh.triangles.empty() || ply.size() < 13 * s.mesh.triangles.size() ? 1 : 0;
}
