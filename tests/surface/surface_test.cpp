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
  // Several particle sizes and block sizes, off the origin: every face lies where the
  // fluid the particles stand for ends (r beyond the outer centres), the triangles face
  // outward, and the volume is the block's but for its edges and corners, rounded over a
  // few r by the smoothing (so the loss shrinks as 1/n).
  std::vector<double> loss;
  for (const auto& [r, n] : {std::pair{0.01, 16}, std::pair{0.0137, 16}, std::pair{0.025, 12},
                             std::pair{0.01, 32}}) {
    const Vec3 origin(0.31, -0.2, 1.7);
    const FluidSurface s = fluidSurface(block(origin, n, n, n, r), r, SurfaceSettings{});
    ASSERT_FALSE(s.mesh.triangles.empty());
    const Vec3 lo = origin - Vec3::Constant(r);
    const Vec3 hi = lo + Vec3::Constant(2.0 * r * n);
    for (int axis = 0; axis < 3; ++axis) {
      EXPECT_NEAR(faceMean(s.mesh, lo, hi, axis, -1.0), lo[axis], 0.1 * r) << "r " << r;
      EXPECT_NEAR(faceMean(s.mesh, lo, hi, axis, +1.0), hi[axis], 0.1 * r) << "r " << r;
    }
    const double volume = enclosedVolume(s.mesh.vertices, s.mesh.triangles);
    EXPECT_GT(volume, 0.0) << "triangles must face outward";
    loss.push_back(1.0 - volume / (hi - lo).prod());
    EXPECT_GT(loss.back(), 0.0) << "r " << r << " n " << n;
    EXPECT_LT(loss.back(), 1.0 / n) << "r " << r << " n " << n;
    EXPECT_EQ(s.level_set->getGridClass(), openvdb::GRID_LEVEL_SET);
    EXPECT_NEAR(s.level_set->voxelSize()[0], SurfaceSettings{}.voxel_factor * r, 1e-12);
  }
  EXPECT_LT(loss[3], 0.6 * loss[0]) << "the loss is at the edges, not the faces";
}

TEST(FluidSurface, ALoneParticleIsARoundDropOfAboutItsSize) {
  const double r = 0.02;
  SurfaceSettings settings;
  settings.voxel_factor = 0.2;
  const FluidSurface s = fluidSurface({Vec3(1.0, 2.0, 3.0)}, r, settings);
  ASSERT_FALSE(s.mesh.vertices.empty());
  double lo = 1e9, hi = 0.0;
  for (const auto& v : s.mesh.vertices) {
    const double d = (Vec3(v[0], v[1], v[2]) - Vec3(1.0, 2.0, 3.0)).norm();
    lo = std::min(lo, d);
    hi = std::max(hi, d);
  }
  EXPECT_GT(lo, 0.9 * r);  // smoothing shrinks a drop a little
  EXPECT_LT(hi, settings.radius_factor * r);
  EXPECT_LT(hi - lo, 0.05 * r) << "round";
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
  s.radius_factor = 0.5;
  EXPECT_NE(message(s).find("surface.radius_factor"), std::string::npos) << message(s);
  s = SurfaceSettings{};
  s.voxel_factor = 2.0;  // a sphere of 1 voxel: OpenVDB would drop every particle
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
  if (std::isfinite(shape.volume()))
    EXPECT_NEAR(enclosedVolume(mesh.vertices, mesh.triangles) / shape.volume(), 1.0, rel)
        << shape.typeName();
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
