// Triangles of an OBJ file (tinyobjloader), for mesh shapes and Bullet's mesh shapes.
#pragma once

#include "sph/types.hpp"

#include <array>
#include <string>
#include <vector>

namespace wake {

/// Reads the triangles of `path` (polygons are triangulated), vertices multiplied by
/// `scale`. Throws std::runtime_error naming the file when it cannot be read, a face
/// refers to a missing vertex, or there are no triangles.
void readObj(const std::string& path, const Vec3& scale, std::vector<Vec3>& vertices,
             std::vector<std::array<int, 3>>& triangles);

}  // namespace wake
