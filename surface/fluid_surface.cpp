// Particles -> level set -> mesh with OpenVDB; see fluid_surface.hpp.
#include "surface/fluid_surface.hpp"

#include "surface/vdb_mesh.hpp"

#include <openvdb/tools/LevelSetFilter.h>
#include <openvdb/tools/ParticlesToLevelSet.h>

#include <cmath>
#include <stdexcept>
#include <string>

namespace wake {
namespace {

/// The particle list ParticlesToLevelSet reads (positions only: one radius for all).
class ParticleList {
 public:
  using PosType = openvdb::Vec3R;
  explicit ParticleList(const std::vector<Vec3>& p) : p_(p) {}
  std::size_t size() const { return p_.size(); }
  void getPos(std::size_t n, openvdb::Vec3R& xyz) const {
    xyz = openvdb::Vec3R(p_[n].x(), p_[n].y(), p_[n].z());
  }

 private:
  const std::vector<Vec3>& p_;
};

void checkRange(const char* name, double value, double lo, double hi) {
  if (!(value >= lo && value <= hi))
    throw std::invalid_argument("surface." + std::string(name) + " must be in [" +
                                std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
                                std::to_string(value));
}

/// The mean height above a square lattice (spacing 2 r) of particles of the union of their
/// spheres of radius `sphere` (>= sqrt(2) r, so every point of a lattice cell is under the
/// sphere of its own particle): (1 / 4 r^2) * integral over [-r, r]^2 of
/// sqrt(sphere^2 - x^2 - y^2), by the midpoint rule (64 x 64 points; error ~1e-5 r).
double meanCapHeight(double sphere, double r) {
  constexpr int kN = 64;
  double sum = 0.0;
  for (int i = 0; i < kN; ++i)
    for (int j = 0; j < kN; ++j) {
      const double x = r * (-1.0 + (2.0 * i + 1.0) / kN);
      const double y = r * (-1.0 + (2.0 * j + 1.0) / kN);
      sum += std::sqrt(std::max(0.0, sphere * sphere - x * x - y * y));
    }
  return sum / (kN * kN);
}

}  // namespace

void SurfaceSettings::check() const {
  checkRange("radius_factor", radius_factor, 1.5, 4.0);
  checkRange("voxel_factor", voxel_factor, 0.1, radius_factor / 1.5);
  checkRange("smoothing", smoothing, 0, 20);
  checkRange("adaptivity", adaptivity, 0.0, 1.0);
}

Aabb TriangleMeshF::bounds() const {
  Aabb b;
  for (const auto& v : vertices)
    b.extend(Vec3(v[0], v[1], v[2]));
  return b;
}

FluidSurface fluidSurface(const std::vector<Vec3>& positions, double particle_radius,
                          const SurfaceSettings& settings) {
  settings.check();
  if (!(particle_radius > 0.0) || !std::isfinite(particle_radius))
    throw std::invalid_argument("particle radius must be > 0, got " +
                                std::to_string(particle_radius));
  const double voxel = settings.voxel_factor * particle_radius;        // m
  const double sphere = settings.radius_factor * particle_radius;      // m
  // The offset that puts a flat face of fluid at rest (particles 2r apart) where the fluid
  // it stands for ends, r beyond the outer centres: the union of the spheres reaches
  // meanCapHeight beyond them on average (its bumps are smoothed to that mean).
  const double erode = std::max(0.0, meanCapHeight(sphere, particle_radius) - particle_radius);
  // The band holds the erosion and the filter's stencil with room to spare.
  const double half_width = std::max(3.0, std::ceil(erode / voxel) + 3.0);  // voxels
  FluidSurface out;
  out.level_set = openvdb::createLevelSet<openvdb::FloatGrid>(voxel, half_width);
  out.level_set->setName("fluid");
  if (positions.empty()) return out;

  openvdb::tools::ParticlesToLevelSet<openvdb::FloatGrid> raster(*out.level_set);
  raster.rasterizeSpheres(ParticleList(positions), sphere);
  raster.finalize(/*prune=*/true);
  if (raster.getMinCount() > 0 || raster.getMaxCount() > 0)
    throw std::logic_error("fluidSurface: OpenVDB skipped particles (sphere radius " +
                           std::to_string(sphere / voxel) + " voxels)");

  openvdb::tools::LevelSetFilter<openvdb::FloatGrid> filter(*out.level_set);
  for (int i = 0; i < settings.smoothing; ++i)
    filter.gaussian(1);
  if (erode > 0.0) filter.offset(static_cast<float>(erode));
  out.mesh = meshLevelSet(*out.level_set, settings.adaptivity);
  return out;
}

}  // namespace wake
