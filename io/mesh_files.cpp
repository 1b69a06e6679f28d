#include "io/mesh_files.hpp"

#include "io/run_file.hpp"

#include <cstring>
#include <sstream>
#include <stdexcept>

namespace wake {
namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "PLY files are written little endian");

template <class T>
void put(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out.append(bytes, sizeof(T));
}

}  // namespace

std::string plyMesh(const FloatVertices& vertices, const Triangles& triangles) {
  std::string out = "ply\nformat binary_little_endian 1.0\ncomment written by Wake\n";
  out += "element vertex " + std::to_string(vertices.size()) +
         "\nproperty float x\nproperty float y\nproperty float z\n";
  out += "element face " + std::to_string(triangles.size()) +
         "\nproperty list uchar int vertex_indices\nend_header\n";
  out.reserve(out.size() + 12 * vertices.size() + 13 * triangles.size());
  for (const auto& v : vertices)
    out.append(reinterpret_cast<const char*>(v.data()), 12);
  for (const auto& t : triangles) {
    put<std::uint8_t>(out, 3);
    for (const std::uint32_t i : t)
      put<std::int32_t>(out, static_cast<std::int32_t>(i));
  }
  return out;
}

std::string objMesh(const FloatVertices& vertices, const Triangles& triangles) {
  std::ostringstream o;
  o << "# written by Wake\n";
  char line[96];
  for (const auto& v : vertices) {
    std::snprintf(line, sizeof(line), "v %.7g %.7g %.7g\n", v[0], v[1], v[2]);
    o << line;
  }
  for (const auto& t : triangles)
    o << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
  return o.str();
}

std::string plyParticles(const RunFrame& frame) {
  const std::size_t n = frame.position.size();
  if (frame.velocity.size() != n || frame.density.size() != n || frame.id.size() != n)
    throw std::logic_error("plyParticles: the frame's arrays differ in length");
  std::string out = "ply\nformat binary_little_endian 1.0\ncomment written by Wake\n";
  out += "comment time " + std::to_string(frame.time) + "\n";
  out += "element vertex " + std::to_string(n) +
         "\nproperty float x\nproperty float y\nproperty float z\n"
         "property float vx\nproperty float vy\nproperty float vz\n"
         "property float density\nproperty uint id\nend_header\n";
  out.reserve(out.size() + 32 * n);
  for (std::size_t i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a)
      put<float>(out, static_cast<float>(frame.position[i][a]));
    for (int a = 0; a < 3; ++a)
      put<float>(out, static_cast<float>(frame.velocity[i][a]));
    put<float>(out, static_cast<float>(frame.density[i]));
    put<std::uint32_t>(out, frame.id[i]);
  }
  return out;
}

}  // namespace wake
