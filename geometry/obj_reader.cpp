#include "geometry/obj_reader.hpp"

#include <tiny_obj_loader.h>

#include <stdexcept>

namespace wake {

void readObj(const std::string& path, const Vec3& scale, std::vector<Vec3>& vertices,
             std::vector<std::array<int, 3>>& triangles) {
  if (!scale.allFinite() || (scale.array() == 0.0).any())
    throw std::invalid_argument("mesh '" + path + "': scale must be finite and non-zero");
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  if (!reader.ParseFromFile(path, config))
    throw std::runtime_error("mesh '" + path + "': cannot read OBJ file: " + reader.Error());

  const std::vector<tinyobj::real_t>& xyz = reader.GetAttrib().vertices;  // 3 per vertex
  const std::size_t vertex_count = xyz.size() / 3;
  vertices.resize(vertex_count);
  for (std::size_t k = 0; k < vertex_count; ++k)
    vertices[k] = Vec3(xyz[3 * k], xyz[3 * k + 1], xyz[3 * k + 2]).cwiseProduct(scale);
  const auto vertex = [&](int index) -> int {
    if (index < 0 || static_cast<std::size_t>(index) >= vertex_count)
      throw std::runtime_error("mesh '" + path + "': face refers to missing vertex " +
                               std::to_string(index));
    return index;
  };
  triangles.clear();  // in file order
  for (const tinyobj::shape_t& shape : reader.GetShapes()) {
    const auto& indices = shape.mesh.indices;
    std::size_t offset = 0;
    for (const unsigned char face_size : shape.mesh.num_face_vertices) {
      if (face_size == 3)
        triangles.push_back({vertex(indices[offset].vertex_index),
                             vertex(indices[offset + 1].vertex_index),
                             vertex(indices[offset + 2].vertex_index)});
      offset += face_size;
    }
  }
  if (triangles.empty()) throw std::runtime_error("mesh '" + path + "': no triangles in OBJ file");
}

}  // namespace wake
