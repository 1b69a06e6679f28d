#include "bullet_bridge/bullet_shapes.hpp"
#include "bullet_bridge/convert.hpp"

#include "geometry/obj_reader.hpp"

#include <BulletCollision/Gimpact/btGImpactShape.h>
#include <LinearMath/btConvexHullComputer.h>
#include <btBulletDynamicsCommon.h>

#include <cmath>
#include <stdexcept>
#include <string>

namespace wake::bullet {

namespace {

/// Rotation taking Bullet's y-up convention to up axis `axis` (0 x, 1 y, 2 z).
std::shared_ptr<const Shape> alongAxis(std::shared_ptr<const Shape> y_up, int axis) {
  if (axis == 1) return y_up;
  Pose pose;
  // y -> x: rotate -90 deg about z; y -> z: rotate +90 deg about x.
  pose.orientation = axis == 0 ? Quat(Eigen::AngleAxisd(-M_PI / 2, Vec3::UnitZ()))
                               : Quat(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitX()));
  return makeCompound({{std::move(y_up), pose}});
}

/// Triangles of a Bullet mesh interface, scaled by its scaling.
std::shared_ptr<const Shape> meshFromInterface(const btStridingMeshInterface& mesh,
                                               const btVector3& scaling) {
  std::vector<Vec3> vertices;
  std::vector<std::array<int, 3>> triangles;
  for (int part = 0; part < mesh.getNumSubParts(); ++part) {
    const unsigned char* vbase = nullptr;
    const unsigned char* ibase = nullptr;
    int nverts = 0, vstride = 0, istride = 0, nfaces = 0;
    PHY_ScalarType vtype, itype;
    mesh.getLockedReadOnlyVertexIndexBase(&vbase, nverts, vtype, vstride, &ibase, istride, nfaces,
                                          itype, part);
    const int first = static_cast<int>(vertices.size());
    for (int v = 0; v < nverts; ++v) {
      const unsigned char* p = vbase + std::size_t(v) * vstride;
      Vec3 x;
      if (vtype == PHY_DOUBLE) {
        const double* d = reinterpret_cast<const double*>(p);
        x = Vec3(d[0], d[1], d[2]);
      } else {
        const float* f = reinterpret_cast<const float*>(p);
        x = Vec3(f[0], f[1], f[2]);
      }
      vertices.push_back(x.cwiseProduct(toVec(scaling)));
    }
    for (int t = 0; t < nfaces; ++t) {
      const unsigned char* p = ibase + std::size_t(t) * istride;
      std::array<int, 3> tri{};
      for (int k = 0; k < 3; ++k) {
        switch (itype) {
          case PHY_SHORT:
            tri[k] = reinterpret_cast<const unsigned short*>(p)[k];
            break;
          case PHY_UCHAR:
            tri[k] = reinterpret_cast<const unsigned char*>(p)[k];
            break;
          default:
            tri[k] = reinterpret_cast<const int*>(p)[k];
            break;
        }
        tri[k] += first;
      }
      triangles.push_back(tri);
    }
    mesh.unLockReadOnlyVertexBase(part);
  }
  return makeTriangleMesh(std::move(vertices), std::move(triangles));
}

/// Convex hull of points as a closed triangle mesh (Bullet's hull computer).
std::shared_ptr<const Shape> hullMesh(const std::vector<Vec3>& points) {
  btConvexHullComputer hull;
  std::vector<double> coords;
  for (const Vec3& p : points)
    coords.insert(coords.end(), {p.x(), p.y(), p.z()});
  hull.compute(coords.data(), 3 * sizeof(double), static_cast<int>(points.size()), 0, 0);
  std::vector<Vec3> vertices;
  for (int v = 0; v < hull.vertices.size(); ++v)
    vertices.push_back(toVec(hull.vertices[v]));
  std::vector<std::array<int, 3>> triangles;
  for (int f = 0; f < hull.faces.size(); ++f) {
    // Fan-triangulate the face polygon (counter-clockwise seen from outside).
    const btConvexHullComputer::Edge* first = &hull.edges[hull.faces[f]];
    const int v0 = first->getSourceVertex();
    const btConvexHullComputer::Edge* e = first->getNextEdgeOfFace();
    while (e->getTargetVertex() != v0) {
      triangles.push_back({v0, e->getSourceVertex(), e->getTargetVertex()});
      e = e->getNextEdgeOfFace();
    }
  }
  if (triangles.empty()) throw std::invalid_argument("convex hull is flat (no volume)");
  return makeTriangleMesh(std::move(vertices), std::move(triangles));
}

std::shared_ptr<const Shape> grownBy(std::shared_ptr<const Shape> shape, double margin) {
  return margin > 0 ? std::shared_ptr<const Shape>(makeRounded(std::move(shape), margin)) : shape;
}

}  // namespace

std::shared_ptr<const Shape> exactShape(const btCollisionShape& shape) {
  const double margin = double(shape.getMargin());
  switch (shape.getShapeType()) {
    case BOX_SHAPE_PROXYTYPE:
      return makeBox(toVec(static_cast<const btBoxShape&>(shape).getHalfExtentsWithMargin()));
    case SPHERE_SHAPE_PROXYTYPE:
      return makeSphere(double(static_cast<const btSphereShape&>(shape).getRadius()));
    case CAPSULE_SHAPE_PROXYTYPE: {
      const auto& c = static_cast<const btCapsuleShape&>(shape);
      return alongAxis(makeCapsule(double(c.getRadius()), double(c.getHalfHeight())),
                       c.getUpAxis());
    }
    case CYLINDER_SHAPE_PROXYTYPE: {
      const auto& c = static_cast<const btCylinderShape&>(shape);
      const int up = c.getUpAxis();
      const Vec3 half = toVec(c.getHalfExtentsWithMargin());
      const double radius = half[(up + 1) % 3];
      if (!(margin < std::min(radius, half[up])))
        throw std::invalid_argument("btCylinderShape: margin " + std::to_string(margin) +
                                    " is not smaller than its radius and half height");
      return alongAxis(makeCylinder(radius, half[up], margin), up);
    }
    case CONE_SHAPE_PROXYTYPE: {
      const auto& c = static_cast<const btConeShape&>(shape);
      return alongAxis(makeCone(double(c.getRadius()), double(c.getHeight()), margin),
                       c.getConeUpIndex());
    }
    case CONVEX_HULL_SHAPE_PROXYTYPE: {
      const auto& h = static_cast<const btConvexHullShape&>(shape);
      std::vector<Vec3> points;
      const Vec3 scaling = toVec(h.getLocalScaling());
      for (int k = 0; k < h.getNumPoints(); ++k)
        points.push_back(toVec(h.getUnscaledPoints()[k]).cwiseProduct(scaling));
      return makeRounded(hullMesh(points), margin);
    }
    case STATIC_PLANE_PROXYTYPE: {
      const auto& p = static_cast<const btStaticPlaneShape&>(shape);
      return makePlane(toVec(p.getPlaneNormal()), double(p.getPlaneConstant()));
    }
    case TRIANGLE_MESH_SHAPE_PROXYTYPE: {
      const auto& m = static_cast<const btBvhTriangleMeshShape&>(shape);
      return grownBy(meshFromInterface(*m.getMeshInterface(), m.getLocalScaling()), margin);
    }
    case GIMPACT_SHAPE_PROXYTYPE: {
      const auto& g = static_cast<const btGImpactShapeInterface&>(shape);
      if (g.getGImpactShapeType() != CONST_GIMPACT_TRIMESH_SHAPE)
        throw std::invalid_argument("btGImpact shapes other than btGImpactMeshShape");
      const auto& m = static_cast<const btGImpactMeshShape&>(shape);
      return grownBy(meshFromInterface(*m.getMeshInterface(), m.getLocalScaling()), margin);
    }
    case COMPOUND_SHAPE_PROXYTYPE: {
      const auto& c = static_cast<const btCompoundShape&>(shape);
      std::vector<CompoundChild> children;
      for (int k = 0; k < c.getNumChildShapes(); ++k)
        children.push_back({exactShape(*c.getChildShape(k)), toPose(c.getChildTransform(k))});
      return makeCompound(std::move(children));
    }
    default:
      throw std::invalid_argument(std::string("Bullet shape type '") + shape.getName() +
                                  "' is not supported by Wake");
  }
}

ShapeStore::ShapeStore() = default;
ShapeStore::~ShapeStore() = default;
ShapeStore::ShapeStore(ShapeStore&&) noexcept = default;
ShapeStore& ShapeStore::operator=(ShapeStore&&) noexcept = default;

namespace {

template <class T>
T* keep(ShapeStore& store, std::unique_ptr<T> shape) {
  T* raw = shape.get();
  store.shapes.push_back(std::move(shape));
  return raw;
}

void requireMargin(bool ok, const std::string& field, double margin, const char* what) {
  if (!ok)
    throw std::invalid_argument(field + ".margin: " + std::to_string(margin) +
                                " m must be smaller than the shape's " + what);
}

btCollisionShape* buildCollision(const ShapeSpec& spec, bool dynamic, double margin,
                                 ShapeStore& store, const std::string& field) {
  const std::string& t = spec.type;
  if (t == "box") {
    requireMargin(margin < spec.half_extents.minCoeff(), field, margin, "half extents");
    auto box = std::make_unique<btBoxShape>(toBt(spec.half_extents));
    box->setMargin(btScalar(margin));
    return keep(store, std::move(box));
  }
  if (t == "sphere") return keep(store, std::make_unique<btSphereShape>(btScalar(spec.radius)));
  if (t == "capsule")
    return keep(store,
                std::make_unique<btCapsuleShape>(btScalar(spec.radius), btScalar(spec.height)));
  if (t == "cylinder") {
    requireMargin(margin < std::min(spec.radius, 0.5 * spec.height), field, margin,
                  "radius and half height");
    auto c = std::make_unique<btCylinderShape>(
        btVector3(btScalar(spec.radius), btScalar(0.5 * spec.height), btScalar(spec.radius)));
    c->setMargin(btScalar(margin));
    return keep(store, std::move(c));
  }
  if (t == "cone") {
    auto c = std::make_unique<btConeShape>(btScalar(spec.radius), btScalar(spec.height));
    c->setMargin(btScalar(margin));
    return keep(store, std::move(c));
  }
  if (t == "convex_hull") {
    auto h = std::make_unique<btConvexHullShape>();
    for (const Vec3& p : spec.points)
      h->addPoint(toBt(p), false);
    h->recalcLocalAabb();
    h->setMargin(btScalar(margin));
    return keep(store, std::move(h));
  }
  if (t == "plane")
    return keep(store, std::make_unique<btStaticPlaneShape>(toBt(spec.normal.normalized()),
                                                            btScalar(spec.offset)));
  if (t == "mesh") {
    std::vector<Vec3> vertices;
    std::vector<std::array<int, 3>> triangles;
    readObj(spec.file, spec.scale, vertices, triangles);
    auto mesh = std::make_unique<btTriangleMesh>(/*32-bit indices=*/true, /*4 components=*/false);
    for (const auto& tri : triangles)
      mesh->addTriangle(toBt(vertices[tri[0]]), toBt(vertices[tri[1]]), toBt(vertices[tri[2]]));
    btTriangleMesh* raw = mesh.get();
    store.meshes.push_back(std::move(mesh));
    if (dynamic) {
      auto g = std::make_unique<btGImpactMeshShape>(raw);
      g->setMargin(btScalar(margin));
      g->updateBound();
      return keep(store, std::move(g));
    }
    auto bvh = std::make_unique<btBvhTriangleMeshShape>(raw, true);
    return keep(store, std::move(bvh));
  }
  if (t == "compound") {
    auto c = std::make_unique<btCompoundShape>();
    for (std::size_t k = 0; k < spec.children.size(); ++k) {
      const ShapeChild& child = spec.children[k];
      const double m = child.shape.margin >= 0 ? child.shape.margin : margin;
      c->addChildShape(toBt(child.pose),
                       buildCollision(child.shape, dynamic, m, store,
                                      field + ".children[" + std::to_string(k) + "].shape"));
    }
    return keep(store, std::move(c));
  }
  if (t == "tank") {
    // Floor and four walls around the cavity [min, max], open at the top.
    const Vec3 lo = spec.min, hi = spec.max;
    const double w = spec.wall_thickness;
    auto c = std::make_unique<btCompoundShape>();
    auto addBox = [&](const Vec3& a, const Vec3& b) {
      auto box = std::make_unique<btBoxShape>(toBt(0.5 * (b - a)));
      box->setMargin(btScalar(std::min(margin, 0.25 * (b - a).minCoeff())));
      Pose pose;
      pose.position = 0.5 * (a + b);
      c->addChildShape(toBt(pose), keep(store, std::move(box)));
    };
    addBox(Vec3(lo.x() - w, lo.y() - w, lo.z() - w), Vec3(hi.x() + w, lo.y(), hi.z() + w));
    addBox(Vec3(lo.x() - w, lo.y(), lo.z() - w), Vec3(lo.x(), hi.y(), hi.z() + w));
    addBox(Vec3(hi.x(), lo.y(), lo.z() - w), Vec3(hi.x() + w, hi.y(), hi.z() + w));
    addBox(Vec3(lo.x(), lo.y(), lo.z() - w), Vec3(hi.x(), hi.y(), lo.z()));
    addBox(Vec3(lo.x(), lo.y(), hi.z()), Vec3(hi.x(), hi.y(), hi.z() + w));
    return keep(store, std::move(c));
  }
  throw std::invalid_argument(field + ".type: unknown shape type '" + t + "'");
}

}  // namespace

BuiltShape buildShape(const ShapeSpec& spec, bool dynamic, double particle_radius,
                      ShapeStore& store, const std::string& field) {
  const double margin = spec.margin >= 0 ? spec.margin : particle_radius;
  ShapeSpec resolved = spec;
  if (resolved.type == "tank" && !(resolved.wall_thickness > 0))
    resolved.wall_thickness = 4.0 * particle_radius;
  BuiltShape out;
  out.collision = buildCollision(resolved, dynamic, margin, store, field);
  // The tank's exact shape is the container itself (its compound has the same union).
  out.exact = resolved.type == "tank" ? std::shared_ptr<const Shape>(makeTank(
                                            resolved.min, resolved.max, resolved.wall_thickness))
                                      : exactShape(*out.collision);
  return out;
}

}  // namespace wake::bullet
