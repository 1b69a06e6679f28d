// The settings of the fluid's surface (surface/fluid_surface.hpp), apart so that code
// that only passes them on (the command line, io/surfaces.hpp) needs no OpenVDB headers.
#pragma once

namespace wake {

/// How the fluid's surface is built (defaults and ranges in README "Output").
struct SurfaceSettings {
  double radius_factor = 1.0;  ///< surface distance beyond the outer centres / r, [0.5, 3]
  double voxel_factor = 1.0;   ///< voxel size / particle radius, [0.25, 2]
  int smoothing = 2;           ///< smoothing passes of topologyToLevelSet, [0, 10]
  double adaptivity = 0.0;     ///< volumeToMesh adaptivity, [0, 1]: 0 = uniform mesh

  /// Throws std::invalid_argument naming the first setting out of its range.
  void check() const;
};

}  // namespace wake
