// Triangle meshes of body shapes, for renderers: exact for flat-faced shapes (box, plane,
// tank, triangle mesh and their compounds: Shape::triangulate); curved shapes (sphere,
// capsule, cylinder, cone, rounded hulls) are meshed from their signed distance sampled
// on a narrow-band OpenVDB grid (voxel = the shape's largest extent / 64, at most a 16th
// of its smallest), within about a hundredth of the shape's size of the exact surface.
#pragma once

#include "geometry/shape.hpp"

namespace wake {

/// The surface of `shape` in body space (infinite shapes: the part covering `clip`, a box
/// in body space). Throws std::invalid_argument for an unbounded curved shape.
SurfaceMesh shapeMesh(const Shape& shape, const Aabb& clip);

}  // namespace wake
