#include "surface/vdb_mesh.hpp"

#include <openvdb/tools/VolumeToMesh.h>

namespace wake {

TriangleMeshF meshLevelSet(const openvdb::FloatGrid& grid, double adaptivity) {
  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec3I> triangles;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(grid, points, triangles, quads, 0.0, adaptivity);
  TriangleMeshF mesh;
  mesh.vertices.resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    mesh.vertices[i] = {points[i].x(), points[i].y(), points[i].z()};
  // volumeToMesh winds its polygons clockwise seen from outside (the level set's < 0
  // side is inside): reversed here.
  mesh.triangles.reserve(triangles.size() + 2 * quads.size());
  for (const openvdb::Vec3I& t : triangles)
    mesh.triangles.push_back({t[2], t[1], t[0]});
  for (const openvdb::Vec4I& q : quads) {
    mesh.triangles.push_back({q[2], q[1], q[0]});
    mesh.triangles.push_back({q[3], q[2], q[0]});
  }
  return mesh;
}

}  // namespace wake
