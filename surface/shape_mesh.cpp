// Body shapes as triangles; see shape_mesh.hpp.
#include "surface/shape_mesh.hpp"

#include "surface/vdb_mesh.hpp"

#include <openvdb/tools/SignedFloodFill.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace wake {
namespace {

/// The signed distance of a bounded shape in a narrow band (3 voxels) of a level set
/// grid. Blocks of 8^3 voxels whose centre lies farther from the surface than the block's
/// reach are skipped; a signed flood fill then gives the inside its sign.
openvdb::FloatGrid::Ptr sampleSignedDistance(const Shape& shape, const Aabb& box, double voxel) {
  constexpr double kHalfWidth = 3.0;  // voxels
  auto grid = openvdb::createLevelSet<openvdb::FloatGrid>(voxel, kHalfWidth);
  const float band = static_cast<float>(kHalfWidth * voxel);
  auto acc = grid->getAccessor();
  const openvdb::Coord lo(static_cast<int>(std::floor(box.min.x() / voxel)) - 4,
                          static_cast<int>(std::floor(box.min.y() / voxel)) - 4,
                          static_cast<int>(std::floor(box.min.z() / voxel)) - 4);
  const openvdb::Coord hi(static_cast<int>(std::ceil(box.max.x() / voxel)) + 4,
                          static_cast<int>(std::ceil(box.max.y() / voxel)) + 4,
                          static_cast<int>(std::ceil(box.max.z() / voxel)) + 4);
  constexpr int kBlock = 8;
  const double reach = (0.5 * std::sqrt(3.0) * kBlock + kHalfWidth) * voxel;  // m
  auto at = [voxel](int i, int j, int k) { return Vec3(i * voxel, j * voxel, k * voxel); };
  for (int bi = lo.x(); bi <= hi.x(); bi += kBlock)
    for (int bj = lo.y(); bj <= hi.y(); bj += kBlock)
      for (int bk = lo.z(); bk <= hi.z(); bk += kBlock) {
        const double half = 0.5 * (kBlock - 1);
        if (std::abs(shape.signedDistance(at(bi, bj, bk) + Vec3::Constant(half * voxel))) > reach)
          continue;
        for (int i = bi; i < std::min(bi + kBlock, hi.x() + 1); ++i)
          for (int j = bj; j < std::min(bj + kBlock, hi.y() + 1); ++j)
            for (int k = bk; k < std::min(bk + kBlock, hi.z() + 1); ++k) {
              const double d = shape.signedDistance(at(i, j, k));
              if (std::abs(d) < band) acc.setValue(openvdb::Coord(i, j, k), static_cast<float>(d));
            }
      }
  openvdb::tools::signedFloodFill(grid->tree());
  return grid;
}

}  // namespace

SurfaceMesh shapeMesh(const Shape& shape, const Aabb& clip) {
  SurfaceMesh mesh;
  if (shape.triangulate(clip, mesh)) return mesh;
  const Aabb box = shape.bounds(clip);
  if (box.empty() || !box.min.allFinite() || !box.max.allFinite())
    throw std::invalid_argument(std::string("shapeMesh: a ") + shape.typeName() +
                                " without bounds cannot be meshed");
  const Vec3 size = box.max - box.min;
  const double voxel = std::min(size.maxCoeff() / 64.0, size.minCoeff() / 16.0);  // m
  openvdb::initialize();
  const TriangleMeshF f = meshLevelSet(*sampleSignedDistance(shape, box, voxel), 0.0);
  mesh.vertices.reserve(f.vertices.size());
  for (const auto& v : f.vertices)
    mesh.vertices.emplace_back(v[0], v[1], v[2]);
  mesh.triangles = f.triangles;
  return mesh;
}

}  // namespace wake
