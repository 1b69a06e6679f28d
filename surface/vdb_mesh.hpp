// The zero isosurface of a level set as triangles (OpenVDB's volumeToMesh; its quads
// split in two), counter-clockwise seen from outside. Internal to surface/.
#pragma once

#include "surface/fluid_surface.hpp"

namespace wake {

TriangleMeshF meshLevelSet(const openvdb::FloatGrid& grid, double adaptivity);

}  // namespace wake
