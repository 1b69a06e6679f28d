// The fluid's surface from particles and body meshes (surface/): real geometry checked
// against exact answers (volumes, heights, distances to the exact shapes).
#include "surface/fluid_surface.hpp"
#include "surface/shape_mesh.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>

namespace wake {
namespace {

/// Volume enclosed by a closed mesh (divergence theorem): > 0 when its triangles are
/// counter-clockwise seen from outside.
template <typename Vertices, typename Triangles>
double enclosedVolume(const Vertices& v, const Triangles& t) {
  double six = 0.0;
  for (const auto& tri : t) {
    const Vec3 a(v[tri[0]][0], v[tri[0]][1], v[tri[0]][2]);
    const Vec3 b(v[tri[1]][0], v[tri[1]][1], v[tri[1]][2]);
    const Vec3 c(v[tri[2]][0], v[tri[2]][1], v[tri[2]][2]);
    six += a.dot(b.cross(c));
  }
  return six / 6.0;
}

/// A block of particles on a cubic lattice of spacing 2r: nx x ny x nz, min corner at
/// `origin` (the block of fluid they stand for spans origin - r .. origin + (n-1) 2r + r).
std::vector<Vec3> block(const Vec3& origin, int nx, int ny, int nz, double r) {
  std::vector<Vec3> p;
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
      for (int k = 0; k < nz; ++k)
        p.push_back(origin + 2.0 * r * Vec3(i, j, k));
  return p;
}

/// Mean coordinate `axis` of the vertices of `mesh` on the face of the block [lo, hi]
/// with outward normal sign * e_axis (those over the middle half of the face).
double faceMean(const TriangleMeshF& mesh, const Vec3& lo, const Vec3& hi, int axis, double sign) {
  const Vec3 mid = 0.5 * (lo + hi), quarter = 0.25 * (hi - lo);
  double sum = 0.0;
  int count = 0;
  for (const auto& v : mesh.vertices) {
    const Vec3 p(v[0], v[1], v[2]);
    bool central = (p[axis] - mid[axis]) * sign > 0.0;
    for (int a = 0; a < 3; ++a)
      if (a != axis) central = central && std::abs(p[a] - mid[a]) < quarter[a];
    if (!central) continue;
    sum += p[axis];
    ++count;
  }
  return count ? sum / count : std::nan("");
}

TEST(FluidSurface, ABlockOfParticlesGivesTheBlockOfFluidTheyStandFor) {
  // Several particle sizes, block sizes, offsets and voxel sizes: every face lies where the
  // fluid the particles stand for ends (r beyond the outer centres) within the voxel
  // quantization (particles are placed in voxels: half a voxel, plus smoothing), the
  // triangles face outward, and the volume is the block's within what that allows.
  struct Case {
    double r;
    int n;
    double voxel_factor;
    Vec3 origin;
  };
  for (const Case& c :
       {Case{0.01, 16, 1.0, Vec3(0.31, -0.2, 1.7)}, Case{0.0137, 16, 1.0, Vec3(0.31, -0.2, 1.7)},
        Case{0.025, 12, 1.0, Vec3(-1.013, 0.4441, 0.0)},
        Case{0.01, 16, 0.5, Vec3(0.3177, -0.2, 1.7)}}) {
    SurfaceSettings settings;
    settings.voxel_factor = c.voxel_factor;
    const double r = c.r, voxel = c.voxel_factor * r;
    const FluidSurface s = fluidSurface(block(c.origin, c.n, c.n, c.n, r), r, settings);
    ASSERT_FALSE(s.mesh.triangles.empty());
    const Vec3 lo = c.origin - Vec3::Constant(r);
    const Vec3 hi = lo + Vec3::Constant(2.0 * r * c.n);
    for (int axis = 0; axis < 3; ++axis) {
      EXPECT_NEAR(faceMean(s.mesh, lo, hi, axis, -1.0), lo[axis], 0.6 * voxel) << "r " << r;
      EXPECT_NEAR(faceMean(s.mesh, lo, hi, axis, +1.0), hi[axis], 0.6 * voxel) << "r " << r;
    }
    const double volume = enclosedVolume(s.mesh.vertices, s.mesh.triangles);
    EXPECT_GT(volume, 0.0) << "triangles must face outward";
    const double side = 2.0 * r * c.n;
    EXPECT_NEAR(volume / (hi - lo).prod(), 1.0, 3.0 * 2.0 * 0.6 * voxel / side) << "r " << r;
    EXPECT_EQ(s.level_set->getGridClass(), openvdb::GRID_LEVEL_SET);
    EXPECT_NEAR(s.level_set->voxelSize()[0], voxel, 1e-12);
  }
}

TEST(FluidSurface, ALoneParticleIsADropAroundIt) {
  // Spray: a lone particle's voxels make a small closed drop around it (its centre within
  // a voxel: the half-voxel correction of flat faces moves it by half a voxel diagonal),
  // between r / 2 and 2 r from it everywhere.
  const double r = 0.02;
  const Vec3 at(1.0, 2.0, 3.0);
  const FluidSurface s = fluidSurface({at}, r, SurfaceSettings{});
  ASSERT_FALSE(s.mesh.vertices.empty());
  Vec3 centre = Vec3::Zero();
  for (const auto& v : s.mesh.vertices) {
    const double d = (Vec3(v[0], v[1], v[2]) - at).norm();
    EXPECT_GT(d, 0.5 * r);
    EXPECT_LT(d, 2.0 * r);
    centre += Vec3(v[0], v[1], v[2]) / s.mesh.vertices.size();
  }
  EXPECT_LT((centre - at).norm(), 0.9 * SurfaceSettings{}.voxel_factor * r);
  EXPECT_GT(enclosedVolume(s.mesh.vertices, s.mesh.triangles), 0.0);
}

TEST(FluidSurface, AdaptivityMakesFewerTrianglesOfTheSameSurface) {
  const double r = 0.01;
  const std::vector<Vec3> p = block(Vec3::Zero(), 20, 10, 20, r);
  SurfaceSettings uniform, adaptive;
  adaptive.adaptivity = 0.5;
  const FluidSurface a = fluidSurface(p, r, uniform);
  const FluidSurface b = fluidSurface(p, r, adaptive);
  EXPECT_LT(b.mesh.triangles.size(), a.mesh.triangles.size() / 2);
  EXPECT_NEAR(enclosedVolume(b.mesh.vertices, b.mesh.triangles),
              enclosedVolume(a.mesh.vertices, a.mesh.triangles),
              0.05 * enclosedVolume(a.mesh.vertices, a.mesh.triangles));
}

TEST(FluidSurface, NoParticlesNoSurface) {
  const FluidSurface s = fluidSurface({}, 0.01, SurfaceSettings{});
  EXPECT_TRUE(s.mesh.vertices.empty());
  EXPECT_TRUE(s.mesh.triangles.empty());
  ASSERT_TRUE(s.level_set);
}

TEST(FluidSurface, BadSettingsNameTheField) {
  auto message = [](SurfaceSettings s, double r = 0.01) {
    try {
      fluidSurface({Vec3::Zero()}, r, s);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  SurfaceSettings s;
  s.radius_factor = 0.2;
  EXPECT_NE(message(s).find("surface.radius_factor"), std::string::npos) << message(s);
  s = SurfaceSettings{};
  s.voxel_factor = 3.0;
  EXPECT_NE(message(s).find("surface.voxel_factor"), std::string::npos) << message(s);
  s = SurfaceSettings{};
  s.smoothing = -1;
  EXPECT_NE(message(s).find("surface.smoothing"), std::string::npos) << message(s);
  s = SurfaceSettings{};
  s.adaptivity = std::nan("");
  EXPECT_NE(message(s).find("surface.adaptivity"), std::string::npos) << message(s);
  EXPECT_NE(message(SurfaceSettings{}, -1.0).find("radius"), std::string::npos);
}

/// Every vertex of `mesh` lies on the exact surface of `shape` within `tol`, and the mesh
/// encloses the shape's volume within `rel`.
void expectOnSurface(const Shape& shape, const SurfaceMesh& mesh, double tol, double rel) {
  ASSERT_FALSE(mesh.triangles.empty()) << shape.typeName();
  double worst = 0.0;
  for (const Vec3& v : mesh.vertices)
    worst = std::max(worst, std::abs(shape.signedDistance(v)));
  EXPECT_LT(worst, tol) << shape.typeName();
  if (std::isfinite(shape.volume())) {
    EXPECT_NEAR(enclosedVolume(mesh.vertices, mesh.triangles) / shape.volume(), 1.0, rel)
        << shape.typeName();
  }
}

TEST(ShapeMesh, FlatShapesAreExactAndCurvedOnesCloseToTheirSurface) {
  const Aabb none;
  expectOnSurface(*makeBox(Vec3(0.3, 0.1, 0.05)), shapeMesh(*makeBox(Vec3(0.3, 0.1, 0.05)), none),
                  1e-12, 1e-12);
  const auto tank = makeTank(Vec3(-1, 0, -0.5), Vec3(1, 0.8, 0.5), 0.05);
  expectOnSurface(*tank, shapeMesh(*tank, none), 1e-12, 1e-12);
  const auto mesh = makeMesh(std::string(WAKE_TEST_DATA_DIR) + "/unit_cube.obj", Vec3(2, 1, 1));
  expectOnSurface(*mesh, shapeMesh(*mesh, none), 1e-12, 1e-12);
  // Curved: within a voxel's fraction (voxel = size / 64), volume within 1 %.
  const auto sphere = makeSphere(0.25);
  expectOnSurface(*sphere, shapeMesh(*sphere, none), 0.5 * 0.5 / 64, 0.01);
  const auto capsule = makeCapsule(0.05, 0.2);
  expectOnSurface(*capsule, shapeMesh(*capsule, none), 0.5 * 0.5 / 64, 0.01);
  const auto cylinder = makeCylinder(0.1, 0.3, 0.01);
  expectOnSurface(*cylinder, shapeMesh(*cylinder, none), 0.5 * 0.6 / 64, 0.01);
  const auto cone = makeCone(0.2, 0.4, 0.01);
  expectOnSurface(*cone, shapeMesh(*cone, none), 0.5 * 0.42 / 64, 0.01);
  // A compound of a box and a sphere: curved, so meshed whole from its distance.
  std::vector<CompoundChild> parts;
  parts.push_back({std::shared_ptr<const Shape>(makeBox(Vec3(0.2, 0.05, 0.05))), Pose()});
  parts.push_back({std::shared_ptr<const Shape>(makeSphere(0.08)),
                   Pose{Vec3(0.2, 0.0, 0.0), Quat::Identity()}});
  const auto compound = makeCompound(std::move(parts));
  expectOnSurface(*compound, shapeMesh(*compound, none), 0.5 * 0.48 / 64, 0.02);
}

TEST(ShapeMesh, APlaneIsTheRectangleOverTheClip) {
  const auto plane = makePlane(Vec3(0, 1, 0), 0.1);
  Aabb clip;
  clip.extend(Vec3(-1, -1, -2));
  clip.extend(Vec3(3, 1, 2));
  const SurfaceMesh m = shapeMesh(*plane, clip);
  ASSERT_EQ(m.triangles.size(), 2u);
  Aabb b;
  for (const Vec3& v : m.vertices) {
    EXPECT_NEAR(v.y(), 0.1, 1e-12);
    b.extend(v);
  }
  EXPECT_NEAR(b.min.x(), -1, 1e-12);
  EXPECT_NEAR(b.max.z(), 2, 1e-12);
  // Faces up: the normal of the first triangle is +y.
  const auto& t = m.triangles[0];
  const Vec3 n = (m.vertices[t[1]] - m.vertices[t[0]]).cross(m.vertices[t[2]] - m.vertices[t[0]]);
  EXPECT_GT(n.y(), 0.0);
}

}  // namespace
}  // namespace wake
