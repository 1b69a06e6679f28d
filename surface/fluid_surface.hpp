// The fluid's surface from its particles, for renderers (DESIGN.md §7 "Surfaces"): every
// particle becomes a sphere of radius radius_factor x r (r the particle radius) in a
// narrow-band level set (OpenVDB's ParticlesToLevelSet) of voxel size voxel_factor x r;
// the union is smoothed (`smoothing` Gaussian filter passes, OpenVDB's LevelSetFilter)
// and offset inward so that a flat face of fluid at rest (particles 2r apart) lies r
// beyond its outer particles' centres, where the fluid they stand for ends (the offset is
// the union's mean height over the centres less r: 0.71 r for radius_factor 2); the zero
// isosurface is meshed (OpenVDB's volumeToMesh, `adaptivity` merging flat regions into
// fewer, larger polygons). OpenVDB runs in parallel on TBB's threads.
#pragma once

#include "sph/types.hpp"

#include <openvdb/openvdb.h>

#include <array>
#include <cstdint>
#include <vector>

namespace wake {

/// How the fluid's surface is built (defaults and ranges in README "Output").
struct SurfaceSettings {
  double radius_factor = 2.0;  ///< sphere radius / particle radius, [1.5, 4]
  double voxel_factor = 0.8;   ///< voxel size / particle radius, [0.1, radius_factor / 1.5]
  int smoothing = 3;           ///< Gaussian filter passes (width 1 voxel), [0, 20]
  double adaptivity = 0.0;     ///< volumeToMesh adaptivity, [0, 1]: 0 = uniform mesh

  /// Throws std::invalid_argument naming the first setting out of its range (a sphere
  /// must span at least 1.5 voxels, or OpenVDB would skip its particle).
  void check() const;
};

/// A triangle mesh in world space, single precision (what renderers read).
struct TriangleMeshF {
  std::vector<std::array<float, 3>> vertices;              ///< m
  std::vector<std::array<std::uint32_t, 3>> triangles;     ///< counter-clockwise from outside

  /// Bounds of the vertices (empty for an empty mesh).
  Aabb bounds() const;
};

struct FluidSurface {
  openvdb::FloatGrid::Ptr level_set;  ///< narrow band, world units (m), < 0 inside
  TriangleMeshF mesh;
};

/// The surface of fluid particles of radius `particle_radius` (m) at `positions`. An
/// empty list gives an empty level set and mesh. Throws std::invalid_argument on bad
/// settings or a non-positive radius.
FluidSurface fluidSurface(const std::vector<Vec3>& positions, double particle_radius,
                          const SurfaceSettings& settings);

}  // namespace wake
