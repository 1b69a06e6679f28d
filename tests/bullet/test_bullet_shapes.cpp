// Bullet shapes -> exact Wake shapes: the surface Bullet collides with, margins included.
// Convex shapes are checked against Bullet's own support mapping (margin included).
#include "bullet_bridge/bullet_shapes.hpp"

#include <BulletCollision/Gimpact/btGImpactShape.h>
#include <btBulletDynamicsCommon.h>
#include <gtest/gtest.h>

#include <random>

namespace wake::bullet {
namespace {

/// Largest |SDF| of the exact shape at Bullet's support points (the farthest points of the
/// surface Bullet collides with, margin included) over many directions: zero when the exact
/// shape's surface passes through every one of them.
double compareWithSupport(const btConvexShape& shape, const Shape& exact) {
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  double worst = 0;
  for (int k = 0; k < 2000; ++k) {
    const btVector3 dir(btScalar(n(rng)), btScalar(n(rng)), btScalar(n(rng)));
    const btVector3 s = shape.localGetSupportingVertex(dir.normalized());
    worst = std::max(worst, std::abs(exact.signedDistance(Vec3(s.x(), s.y(), s.z()))));
  }
  return worst;
}

constexpr double kFloatTol = 2e-5;  // m: Bullet works in single precision

TEST(BulletShapes, BoxUsesItsFullHalfExtents) {
  btBoxShape box(btVector3(0.2f, 0.1f, 0.05f));
  box.setMargin(0.01f);
  auto exact = exactShape(box);
  EXPECT_NEAR(exact->signedDistance(Vec3(0.3, 0, 0)), 0.1, 1e-6);
  EXPECT_NEAR(exact->signedDistance(Vec3(0, 0, 0.05)), 0.0, 1e-6);
  EXPECT_NEAR(exact->volume(), 0.4 * 0.2 * 0.1, 1e-6);
}

TEST(BulletShapes, SphereAndCapsulesMatchGjk) {
  btSphereShape sphere(0.1f);
  EXPECT_LT(compareWithSupport(sphere, *exactShape(sphere)), kFloatTol);
  btCapsuleShape capsule(0.05f, 0.2f);  // y up
  auto exact = exactShape(capsule);
  EXPECT_NEAR(exact->signedDistance(Vec3(0, 0.15, 0)), 0.0, 1e-6);
  EXPECT_LT(compareWithSupport(capsule, *exact), kFloatTol);
  btCapsuleShapeX capsule_x(0.05f, 0.2f);
  auto exact_x = exactShape(capsule_x);
  EXPECT_NEAR(exact_x->signedDistance(Vec3(0.15, 0, 0)), 0.0, 1e-6);
  EXPECT_LT(compareWithSupport(capsule_x, *exact_x), kFloatTol);
}

TEST(BulletShapes, CylinderHasEdgesRoundedByTheMargin) {
  btCylinderShape cylinder(btVector3(0.1f, 0.2f, 0.1f));
  cylinder.setMargin(0.02f);
  auto exact = exactShape(cylinder);
  EXPECT_NEAR(exact->signedDistance(Vec3(0.1, 0, 0)), 0.0, 1e-6);  // side
  EXPECT_NEAR(exact->signedDistance(Vec3(0, 0.2, 0)), 0.0, 1e-6);  // cap
  EXPECT_GT(exact->signedDistance(Vec3(0.0999, 0.1999, 0)), 0.0);  // the rim is rounded off
  EXPECT_LT(compareWithSupport(cylinder, *exact), kFloatTol);
  btCylinderShapeZ cylinder_z(btVector3(0.1f, 0.1f, 0.2f));
  cylinder_z.setMargin(0.02f);
  auto exact_z = exactShape(cylinder_z);
  EXPECT_NEAR(exact_z->signedDistance(Vec3(0, 0, 0.2)), 0.0, 1e-6);
  EXPECT_LT(compareWithSupport(cylinder_z, *exact_z), kFloatTol);
}

TEST(BulletShapes, ConeIsGrownByTheMargin) {
  btConeShape cone(0.1f, 0.3f);
  cone.setMargin(0.02f);
  auto exact = exactShape(cone);
  EXPECT_NEAR(exact->signedDistance(Vec3(0, 0.15 + 0.02, 0)), 0.0, 1e-6);  // apex + margin
  EXPECT_LT(compareWithSupport(cone, *exact), kFloatTol);
}

TEST(BulletShapes, ConvexHullIsGrownByTheMargin) {
  btConvexHullShape hull;
  for (int k = 0; k < 8; ++k)
    hull.addPoint(btVector3(k & 1 ? 0.1f : -0.1f, k & 2 ? 0.05f : -0.05f, k & 4 ? 0.2f : -0.1f),
                  false);
  hull.addPoint(btVector3(0, 0.15f, 0), true);  // a roof
  hull.setMargin(0.01f);
  auto exact = exactShape(hull);
  EXPECT_NEAR(exact->signedDistance(Vec3(0, -0.06, 0)), 0.0, 1e-6);  // bottom face + margin
  EXPECT_LT(compareWithSupport(hull, *exact), kFloatTol);
}

TEST(BulletShapes, StaticPlane) {
  btStaticPlaneShape plane(btVector3(0, 1, 0), 0.25f);
  auto exact = exactShape(plane);
  EXPECT_NEAR(exact->signedDistance(Vec3(3, 1.25, -2)), 1.0, 1e-6);
  EXPECT_TRUE(exact->contains(Vec3(0, 0.2, 0)));
}

/// Unit cube [-0.5, 0.5]^3 as 12 triangles.
void addCube(btTriangleMesh& mesh, double half) {
  const btScalar h = btScalar(half);
  auto v = [&](int k) { return btVector3(k & 1 ? h : -h, k & 2 ? h : -h, k & 4 ? h : -h); };
  const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) {
    mesh.addTriangle(v(f[0]), v(f[1]), v(f[2]));
    mesh.addTriangle(v(f[0]), v(f[2]), v(f[3]));
  }
}

TEST(BulletShapes, TriangleMeshesBothKinds) {
  btTriangleMesh mesh;
  addCube(mesh, 0.1);
  btBvhTriangleMeshShape bvh(&mesh, true);
  auto exact = exactShape(bvh);
  EXPECT_TRUE(exact->contains(Vec3(0.05, 0.05, 0.05)));
  EXPECT_NEAR(exact->signedDistance(Vec3(0.3, 0, 0)), 0.2, 1e-6);
  EXPECT_NEAR(exact->volume(), 0.008, 1e-6);
  btGImpactMeshShape gimpact(&mesh);
  gimpact.setMargin(0.0f);
  gimpact.updateBound();
  auto exact_g = exactShape(gimpact);
  EXPECT_NEAR(exact_g->signedDistance(Vec3(0, -0.3, 0)), 0.2, 1e-6);
}

TEST(BulletShapes, CompoundPlacesChildrenByTheirTransforms) {
  btBoxShape box(btVector3(0.1f, 0.1f, 0.1f));
  btSphereShape sphere(0.05f);
  btCompoundShape compound;
  btTransform t;
  t.setIdentity();
  t.setOrigin(btVector3(0.3f, 0, 0));
  compound.addChildShape(t, &box);
  t.setOrigin(btVector3(-0.2f, 0.1f, 0));
  t.setRotation(btQuaternion(btVector3(0, 0, 1), btScalar(0.5)));
  compound.addChildShape(t, &sphere);
  auto exact = exactShape(compound);
  EXPECT_TRUE(exact->contains(Vec3(0.35, 0.05, 0)));
  EXPECT_FALSE(exact->contains(Vec3(0, 0, 0)));  // the origin is between the children
  EXPECT_NEAR(exact->signedDistance(Vec3(-0.2, 0.2, 0)), 0.05, 1e-6);
  // Samples lie on the children's surfaces, none near the empty origin.
  SurfaceSamples s;
  exact->sample(0.01, 0.005, Aabb(), s);
  ASSERT_GT(s.size(), 100u);
  for (std::size_t k = 0; k < s.size(); ++k) {
    const Vec3 surface = s.position[k] + 0.005 * s.normal[k];
    EXPECT_NEAR(exact->signedDistance(surface), 0.0, 1e-3);
  }
}

TEST(BulletShapes, UnsupportedShapeIsRefusedByName) {
  btEmptyShape empty;
  try {
    exactShape(empty);
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("not supported"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace wake::bullet
