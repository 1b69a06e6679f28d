// The fluid's surface from its particles, for renderers (README "Output"), with OpenVDB:
// each particle marks its voxel (voxel size voxel_factor x r, r the particle radius); the
// marked voxels, dilated by ceil(1 / voxel_factor) voxels (26 neighbours) so that particles
// at rest spacing 2r join, become a narrow-band level set (OpenVDB's topologyToLevelSet, with one
// morphological closing and `smoothing` smoothing passes); its zero crossing is moved so
// that a flat face of fluid lies radius_factor x r beyond its outer particles' centres
// (radius_factor 1: where the fluid the particles stand for ends), and it is meshed
// (OpenVDB's volumeToMesh; `adaptivity` merges flat regions into fewer, larger polygons).
// The cost grows with the fluid's volume in voxels, not with its particles' neighbours:
// a million particles take a few seconds (bench/surface.cpp). OpenVDB runs in parallel
// on TBB's threads.
#pragma once

#include "sph/types.hpp"
#include "surface/surface_settings.hpp"

#include <openvdb/openvdb.h>

#include <array>
#include <cstdint>
#include <vector>

namespace wake {

/// A triangle mesh in world space, single precision (what renderers read).
struct TriangleMeshF {
  std::vector<std::array<float, 3>> vertices;           ///< m
  std::vector<std::array<std::uint32_t, 3>> triangles;  ///< counter-clockwise from outside

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
