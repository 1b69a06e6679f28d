// Bullet collision shapes <-> Wake's exact shapes.
//
// exactShape() reads a btCollisionShape and returns the surface Bullet actually collides
// with, margins included, as a Wake Shape (geometry/shape.hpp) that is sampled with
// boundary particles and used to count penetration:
//   btBoxShape                 box of getHalfExtentsWithMargin() (the margin is inside)
//   btSphereShape, btCapsule*  exact (the radius is the margin)
//   btCylinderShape*           cylinder of the given size, edges rounded by the margin
//   btConeShape*               cone grown by the margin (Bullet adds it outside)
//   btConvexHullShape          hull of the scaled points grown by the margin
//   btStaticPlaneShape         half space below the plane
//   btBvhTriangleMeshShape,
//   btGImpactMeshShape         the triangle mesh (grown by its margin when > 0)
//   btCompoundShape            union of the children at their child transforms
// Other shape types are refused with std::invalid_argument.
#pragma once

#include "bullet_bridge/body_spec.hpp"
#include "geometry/shape.hpp"

#include <memory>
#include <vector>

class btCollisionShape;
class btStridingMeshInterface;

namespace wake::bullet {

/// The exact surface Bullet collides with, in the shape's frame (see above).
std::shared_ptr<const Shape> exactShape(const btCollisionShape& shape);

/// Bullet objects built from a scene's ShapeSpec; they must outlive the bodies using them.
struct ShapeStore {
  std::vector<std::unique_ptr<btCollisionShape>> shapes;
  std::vector<std::unique_ptr<btStridingMeshInterface>> meshes;
  ShapeStore();
  ~ShapeStore();
  ShapeStore(ShapeStore&&) noexcept;
  ShapeStore& operator=(ShapeStore&&) noexcept;
};

/// A scene shape as a Bullet collision shape (owned by `store`) and its exact surface.
/// `dynamic` picks btGImpactMeshShape over btBvhTriangleMeshShape for meshes. The fluid's
/// particle radius (m) is the margin where spec.margin < 0, and a quarter of a tank's
/// automatic wall thickness. Throws std::invalid_argument
/// naming `field` when the shape cannot be built (e.g. a margin larger than the shape).
struct BuiltShape {
  btCollisionShape* collision = nullptr;
  std::shared_ptr<const Shape> exact;
};
BuiltShape buildShape(const ShapeSpec& spec, bool dynamic, double particle_radius,
                      ShapeStore& store, const std::string& field);

}  // namespace wake::bullet
