// Mesh and point files that renderers and DCC tools read (README "Output"): binary PLY
// (little endian) of triangle meshes and of particle caches, and Wavefront OBJ. Each
// returns the file's bytes; writeFileAtomically (io/files.hpp) puts them on disk.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace wake {

struct RunFrame;

using FloatVertices = std::vector<std::array<float, 3>>;
using Triangles = std::vector<std::array<std::uint32_t, 3>>;

/// Binary PLY: `element vertex` (float x, y, z), `element face` (list uchar int
/// vertex_indices), triangles counter-clockwise seen from outside.
std::string plyMesh(const FloatVertices& vertices, const Triangles& triangles);

/// Wavefront OBJ: `v x y z` lines, then `f a b c` (1-based).
std::string objMesh(const FloatVertices& vertices, const Triangles& triangles);

/// Binary PLY point cloud of a frame's particles: `element vertex` with float x, y, z,
/// float vx, vy, vz, float density, uint id (the frame's position, velocity, density, id).
std::string plyParticles(const RunFrame& frame);

}  // namespace wake
