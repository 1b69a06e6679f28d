// Exact shapes and their surface sampling (geometry/shape.hpp).
#include "geometry/geometry_test_support.hpp"
#include "geometry/shape.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>
#include <string>

namespace wake {
namespace {

using test::rawGradient;
using test::totalArea;

using test::kPi;

std::string dataPath(const std::string& name) {
  return std::string(WAKE_TEST_DATA_DIR) + "/" + name;
}

Aabb box(const Vec3& lo, const Vec3& hi) {
  return Aabb{lo, hi};
}

/// Uniform random points in [lo, hi], fixed seed.
std::vector<Vec3> randomPoints(const Vec3& lo, const Vec3& hi, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Vec3> points;
  for (int i = 0; i < n; ++i) {
    const Vec3 t(u(rng), u(rng), u(rng));
    points.push_back(lo + t.cwiseProduct(hi - lo));
  }
  return points;
}

/// Checks every sample: arrays consistent, unit normal, positive area, the sample lifted by
/// `radius` along its normal lies on the exact surface, and the normal points outward.
void expectSamplesOnSurface(const Shape& shape, const SurfaceSamples& s, double radius,
                            double surface_tol) {
  ASSERT_EQ(s.normal.size(), s.size());
  ASSERT_EQ(s.area.size(), s.size());
  const double eps = 1e-4;  // m, step off the surface to test the normal's direction
  for (std::size_t i = 0; i < s.size(); ++i) {
    const Vec3 surface_point = s.position[i] + radius * s.normal[i];
    ASSERT_NEAR(s.normal[i].norm(), 1.0, 1e-12) << "sample " << i;
    ASSERT_GT(s.area[i], 0.0) << "sample " << i;
    ASSERT_LT(std::abs(shape.signedDistance(surface_point)), surface_tol)
        << "sample " << i << " at " << s.position[i].transpose();
    ASSERT_GT(shape.signedDistance(surface_point + eps * s.normal[i]), 0.0) << "sample " << i;
    ASSERT_LT(shape.signedDistance(surface_point - eps * s.normal[i]), 0.0) << "sample " << i;
  }
}

// --- signed distances at chosen points --------------------------------------------------

TEST(Shapes, BoxSignedDistanceIsExact) {
  const auto b = makeBox(Vec3(1.0, 0.5, 0.25));
  EXPECT_STREQ(b->typeName(), "box");
  EXPECT_DOUBLE_EQ(b->signedDistance(Vec3::Zero()), -0.25);
  EXPECT_DOUBLE_EQ(b->signedDistance(Vec3(0.9, 0.0, 0.0)), -0.1);
  EXPECT_DOUBLE_EQ(b->signedDistance(Vec3(1.0, 0.2, 0.1)), 0.0);
  EXPECT_DOUBLE_EQ(b->signedDistance(Vec3(2.0, 0.0, 0.0)), 1.0);
  EXPECT_DOUBLE_EQ(b->signedDistance(Vec3(1.5, 1.0, 0.0)), std::sqrt(0.5));
  EXPECT_DOUBLE_EQ(b->signedDistance(Vec3(-2.0, -1.5, -1.25)), std::sqrt(3.0));
  EXPECT_TRUE(b->contains(Vec3(0.99, -0.49, 0.24)));
  EXPECT_FALSE(b->contains(Vec3(1.0, 0.0, 0.0)));  // on the surface: not strictly inside
  EXPECT_FALSE(b->contains(Vec3(0.0, 0.0, 0.3)));
  const Aabb bb = b->bounds(Aabb());
  EXPECT_EQ(bb.min, Vec3(-1.0, -0.5, -0.25));
  EXPECT_EQ(bb.max, Vec3(1.0, 0.5, 0.25));
}

TEST(Shapes, SphereSignedDistanceIsExact) {
  const auto s = makeSphere(0.5);
  EXPECT_STREQ(s->typeName(), "sphere");
  EXPECT_DOUBLE_EQ(s->signedDistance(Vec3::Zero()), -0.5);
  EXPECT_DOUBLE_EQ(s->signedDistance(Vec3(0.3, 0.4, 0.0)), 0.0);
  EXPECT_DOUBLE_EQ(s->signedDistance(Vec3(0.0, 0.0, -2.0)), 1.5);
  EXPECT_TRUE(s->contains(Vec3(0.2, 0.2, 0.2)));
  EXPECT_FALSE(s->contains(Vec3(0.3, 0.3, 0.3)));
  EXPECT_EQ(s->bounds(Aabb()).max, Vec3::Constant(0.5));
}

TEST(Shapes, PlaneNormalIsNormalisedAndSolidIsBelow) {
  const auto floor = makePlane(Vec3(0.0, 2.0, 0.0), 0.5);  // solid y < 0.5
  EXPECT_STREQ(floor->typeName(), "plane");
  EXPECT_DOUBLE_EQ(floor->signedDistance(Vec3(3.0, 1.5, -7.0)), 1.0);
  EXPECT_DOUBLE_EQ(floor->signedDistance(Vec3(0.0, 0.5, 0.0)), 0.0);
  EXPECT_DOUBLE_EQ(floor->signedDistance(Vec3(0.0, -0.5, 0.0)), -1.0);
  EXPECT_TRUE(floor->contains(Vec3(100.0, 0.4, 100.0)));
  EXPECT_FALSE(floor->contains(Vec3(0.0, 0.6, 0.0)));

  const auto tilted = makePlane(Vec3(1.0, 1.0, 0.0), 0.0);
  EXPECT_NEAR(tilted->signedDistance(Vec3(1.0, 0.0, 0.0)), 1.0 / std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(tilted->signedDistance(Vec3(-1.0, 0.0, 5.0)), -1.0 / std::sqrt(2.0), 1e-15);

  const Aabb clip = box(Vec3(-1, -2, -3), Vec3(1, 2, 3));
  EXPECT_EQ(floor->bounds(clip).min, clip.min);
  EXPECT_EQ(floor->bounds(clip).max, clip.max);
}

// Cavity [0,1] x [0,0.8] x [0,0.6], walls and floor 0.1 thick.
class TankTest : public ::testing::Test {
 protected:
  const Vec3 lo{0.0, 0.0, 0.0};
  const Vec3 hi{1.0, 0.8, 0.6};
  const double t = 0.1;
  std::unique_ptr<Shape> tank = makeTank(lo, hi, t);
};

TEST_F(TankTest, SignedDistanceAtChosenPoints) {
  EXPECT_STREQ(tank->typeName(), "tank");
  // Fluid side: nearest of floor and walls.
  EXPECT_DOUBLE_EQ(tank->signedDistance(Vec3(0.5, 0.4, 0.3)), 0.3);
  EXPECT_DOUBLE_EQ(tank->signedDistance(Vec3(0.5, 0.05, 0.3)), 0.05);
  EXPECT_FALSE(tank->contains(Vec3(0.5, 0.4, 0.3)));
  EXPECT_FALSE(tank->contains(Vec3(0.01, 0.01, 0.01)));
  // In a wall and in the floor.
  EXPECT_DOUBLE_EQ(tank->signedDistance(Vec3(-0.05, 0.4, 0.3)), -0.05);
  EXPECT_DOUBLE_EQ(tank->signedDistance(Vec3(0.5, -0.03, 0.3)), -0.03);
  EXPECT_NEAR(tank->signedDistance(Vec3(1.02, 0.79, 0.3)), -0.01, 1e-15);  // under the rim
  EXPECT_TRUE(tank->contains(Vec3(-0.05, 0.4, 0.3)));
  EXPECT_TRUE(tank->contains(Vec3(0.5, -0.03, 0.3)));
  EXPECT_TRUE(tank->contains(Vec3(0.5, 0.4, 0.65)));
  EXPECT_TRUE(tank->contains(Vec3(-0.05, -0.05, -0.05)));  // bottom corner
  // Above the open top: nearest point is the rim's inner edge, or the floor.
  EXPECT_FALSE(tank->contains(Vec3(0.5, 1.0, 0.3)));
  EXPECT_DOUBLE_EQ(tank->signedDistance(Vec3(0.5, 1.0, 0.3)), std::hypot(0.3, 0.2));
  EXPECT_DOUBLE_EQ(tank->signedDistance(Vec3(0.02, 0.9, 0.3)), std::hypot(0.02, 0.1));
  // Above the rim and outside.
  EXPECT_NEAR(tank->signedDistance(Vec3(-0.05, 1.0, 0.3)), 0.2, 1e-15);
  EXPECT_NEAR(tank->signedDistance(Vec3(-0.3, 0.4, 0.3)), 0.2, 1e-15);
  EXPECT_NEAR(tank->signedDistance(Vec3(0.5, -0.5, 0.3)), 0.4, 1e-15);
  // Surface points.
  EXPECT_DOUBLE_EQ(tank->signedDistance(Vec3(0.0, 0.4, 0.3)), 0.0);
  EXPECT_DOUBLE_EQ(tank->signedDistance(Vec3(-0.05, 0.8, 0.3)), 0.0);

  const Aabb bb = tank->bounds(Aabb());
  EXPECT_TRUE(bb.min.isApprox(Vec3(-0.1, -0.1, -0.1)));
  EXPECT_TRUE(bb.max.isApprox(Vec3(1.1, 0.8, 0.7)));
}

TEST(Shapes, WideShallowTankSeesItsFloorFromAboveTheOpening) {
  const auto tank = makeTank(Vec3::Zero(), Vec3(10.0, 0.5, 10.0), 0.2);
  EXPECT_DOUBLE_EQ(tank->signedDistance(Vec3(5.0, 0.6, 5.0)), 0.6);
}

// Outside the solid, the tank is the union of five boxes (floor, four walls): the distance
// to the union is the least box distance, an independent exact reference.
TEST_F(TankTest, SignedDistanceOutsideEqualsDistanceToUnionOfWallBoxes) {
  const Vec3 olo = lo - Vec3::Constant(t), ohi = hi + Vec3(t, 0.0, t);
  struct Piece {  // a box centred at `centre`
    std::unique_ptr<Shape> shape;
    Vec3 centre;
  };
  std::vector<std::pair<Vec3, Vec3>> boxes = {{olo, Vec3(ohi.x(), lo.y(), ohi.z())},   // floor
                                              {olo, Vec3(lo.x(), ohi.y(), ohi.z())},   // -x wall
                                              {Vec3(hi.x(), olo.y(), olo.z()), ohi},   // +x wall
                                              {olo, Vec3(ohi.x(), ohi.y(), lo.z())},   // -z wall
                                              {Vec3(olo.x(), olo.y(), hi.z()), ohi}};  // +z wall
  std::vector<Piece> pieces;
  for (const auto& [a, b] : boxes)
    pieces.push_back({makeBox(0.5 * (b - a)), 0.5 * (a + b)});

  int outside = 0;
  for (const Vec3& p : randomPoints(Vec3(-0.5, -0.5, -0.5), Vec3(1.5, 1.5, 1.1), 4000, 7)) {
    double reference = std::numeric_limits<double>::infinity();
    for (const Piece& piece : pieces)
      reference = std::min(reference, piece.shape->signedDistance(p - piece.centre));
    if (reference <= 0.0) {
      EXPECT_LE(tank->signedDistance(p), 0.0) << p.transpose();
      continue;
    }
    ++outside;
    EXPECT_NEAR(tank->signedDistance(p), reference, 1e-12) << p.transpose();
  }
  EXPECT_GT(outside, 3000);
}

// Inside the walls, -sd is the distance to the nearest surface point: compare with a dense
// sampling of the surface (the sampling's own resolution bounds the difference).
TEST_F(TankTest, SignedDistanceInsideMatchesDenseSurface) {
  const double spacing = 0.01;
  SurfaceSamples s;
  tank->sample(spacing, 0.0, Aabb(), s);
  int inside = 0;
  for (const Vec3& p : randomPoints(Vec3(-0.1, -0.1, -0.1), Vec3(1.1, 0.8, 0.7), 1000, 11)) {
    const double sd = tank->signedDistance(p);
    if (sd >= 0.0) continue;
    ++inside;
    double nearest = std::numeric_limits<double>::infinity();
    for (const Vec3& q : s.position)
      nearest = std::min(nearest, (q - p).norm());
    EXPECT_LE(-sd, nearest + 1e-12) << p.transpose();
    EXPECT_GE(-sd, nearest - spacing) << p.transpose();
  }
  EXPECT_GT(inside, 200);
}

// --- sampling ---------------------------------------------------------------------------

TEST(Shapes, BoxSamplesCoverEveryFaceOnTheSurface) {
  const Vec3 half(0.5, 0.25, 0.15);
  const auto b = makeBox(half);
  const double spacing = 0.05, radius = 0.01;
  SurfaceSamples s;
  b->sample(spacing, radius, Aabb(), s);

  // Faces 1.0 x 0.5, 1.0 x 0.3, 0.5 x 0.3 at 0.05: 20x10, 20x6, 10x6 cells, twice each.
  EXPECT_EQ(s.size(), 2u * (200 + 120 + 60));
  EXPECT_NEAR(totalArea(s), 2.0 * (1.0 * 0.5 + 1.0 * 0.3 + 0.5 * 0.3), 1e-12);
  expectSamplesOnSurface(*b, s, radius, 1e-9);
  for (std::size_t i = 0; i < s.size(); ++i) {
    // Flat faces, radius below half a cell: exactly `radius` deep.
    EXPECT_NEAR(b->signedDistance(s.position[i]), -radius, 1e-12);
    EXPECT_TRUE(b->contains(s.position[i]));
    // Normal = direction of the distance gradient just outside the face.
    const Vec3 outside = s.position[i] + (radius + 1e-3) * s.normal[i];
    EXPECT_LT((rawGradient(*b, outside, 1e-6) - s.normal[i]).norm(), 1e-6);
  }
}

TEST(Shapes, BoxSamplesRoundCellCountsAndKeepTheArea) {
  const auto b = makeBox(Vec3(0.33, 0.01, 0.2));
  SurfaceSamples s;
  s.position.push_back(Vec3::Zero());  // sample() appends
  s.normal.push_back(Vec3::UnitX());
  s.area.push_back(0.0);
  b->sample(0.1, 0.0, Aabb(), s);
  // Faces 0.66 x 0.02 -> 7 x 1, 0.66 x 0.4 -> 7 x 4, 0.02 x 0.4 -> 1 x 4.
  EXPECT_EQ(s.size(), 1u + 2u * (7 + 28 + 4));
  EXPECT_NEAR(totalArea(s), 2.0 * (0.66 * 0.02 + 0.66 * 0.4 + 0.02 * 0.4), 1e-12);
}

TEST(Shapes, SphereSamplesAreFibonacciPointsOnTheSurface) {
  const double R = 0.3, spacing = 0.02, radius = 0.005;
  const auto sphere = makeSphere(R);
  SurfaceSamples s;
  sphere->sample(spacing, radius, Aabb(), s);
  const double area = 4.0 * kPi * R * R;
  EXPECT_EQ(static_cast<long>(s.size()), std::lround(area / (spacing * spacing)));
  EXPECT_NEAR(totalArea(s), area, 1e-12 * area);
  expectSamplesOnSurface(*sphere, s, radius, 1e-12);
  Vec3 centroid = Vec3::Zero();
  for (std::size_t i = 0; i < s.size(); ++i) {
    EXPECT_NEAR(sphere->signedDistance(s.position[i]), -radius, 1e-12);
    EXPECT_LT((s.normal[i] - s.position[i].normalized()).norm(), 1e-12);
    centroid += s.normal[i];
  }
  // Nearly uniform: the normals average to about zero.
  EXPECT_LT(centroid.norm() / s.size(), 1e-2);

  // Each octant holds about an eighth of the samples (within a few %).
  int octant_count = 0;
  for (const Vec3& n : s.normal)
    octant_count += (n.array() > 0.0).all();
  EXPECT_NEAR(octant_count, s.size() / 8.0, 0.05 * s.size() / 8.0);
}

TEST(Shapes, PlaneSamplesCoverTheClipProjection) {
  const auto floor = makePlane(Vec3(0.0, 1.0, 0.0), 0.2);
  const Aabb clip = box(Vec3(-0.5, -1.0, 0.0), Vec3(0.5, 1.0, 0.3));
  const double spacing = 0.1, radius = 0.02;
  SurfaceSamples s;
  floor->sample(spacing, radius, clip, s);
  EXPECT_EQ(s.size(), 10u * 3u);
  EXPECT_NEAR(totalArea(s), 1.0 * 0.3, 1e-12);
  expectSamplesOnSurface(*floor, s, radius, 1e-12);
  for (std::size_t i = 0; i < s.size(); ++i) {
    EXPECT_NEAR(s.position[i].y(), 0.2 - radius, 1e-12);
    EXPECT_EQ(s.normal[i], Vec3::UnitY());
    EXPECT_GT(s.position[i].x(), clip.min.x());
    EXPECT_LT(s.position[i].x(), clip.max.x());
    EXPECT_GT(s.position[i].z(), clip.min.z());
    EXPECT_LT(s.position[i].z(), clip.max.z());
  }

  // A tilted plane: samples still on the plane, covering the projection of the clip box.
  const auto tilted = makePlane(Vec3(1.0, 2.0, -0.5), 0.1);
  SurfaceSamples st;
  tilted->sample(0.05, radius, clip, st);
  ASSERT_GT(st.size(), 0u);
  expectSamplesOnSurface(*tilted, st, radius, 1e-9);
  // Every clip corner projects into the sampled region: some sample within a cell diagonal.
  for (int c = 0; c < 8; ++c) {
    const Vec3 corner((c & 1) ? clip.max.x() : clip.min.x(), (c & 2) ? clip.max.y() : clip.min.y(),
                      (c & 4) ? clip.max.z() : clip.min.z());
    const Vec3 n = st.normal[0];
    const Vec3 projected = corner - tilted->signedDistance(corner) * n;
    double nearest = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < st.size(); ++i)
      nearest = std::min(nearest, (st.position[i] + radius * n - projected).norm());
    EXPECT_LT(nearest, 0.05 * std::sqrt(2.0));
  }

  // No clip, no samples.
  SurfaceSamples none;
  floor->sample(spacing, radius, Aabb(), none);
  EXPECT_EQ(none.size(), 0u);
}

TEST_F(TankTest, SamplesCoverInnerOuterAndRimFaces) {
  const double spacing = 0.05, radius = 0.02;
  SurfaceSamples s;
  tank->sample(spacing, radius, Aabb(), s);

  const Vec3 L = hi - lo;                        // cavity 1.0 x 0.8 x 0.6
  const Vec3 O = L + Vec3(2.0 * t, t, 2.0 * t);  // outer 1.2 x 0.9 x 0.8
  const double inner = L.x() * L.z() + 2.0 * L.y() * (L.x() + L.z());
  const double outer = O.x() * O.z() + 2.0 * O.y() * (O.x() + O.z());
  const double rim = O.x() * O.z() - L.x() * L.z();
  EXPECT_NEAR(totalArea(s), inner + outer + rim, 1e-12);
  // Every length is a multiple of the spacing, so every cell is spacing^2.
  EXPECT_EQ(static_cast<long>(s.size()), std::lround((inner + outer + rim) / (spacing * spacing)));

  expectSamplesOnSurface(*tank, s, radius, 1e-9);
  int facing_fluid = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    // Flat faces, radius below half a cell and the wall thickness: exactly `radius` deep.
    EXPECT_NEAR(tank->signedDistance(s.position[i]), -radius, 1e-12) << s.position[i];
    EXPECT_TRUE(tank->contains(s.position[i]));
    const Vec3 lifted = s.position[i] + (radius + 1e-3) * s.normal[i];
    facing_fluid += (lifted.array() > lo.array()).all() && (lifted.array() < hi.array()).all();
  }
  // Samples facing the fluid = the 5 inner faces.
  EXPECT_EQ(static_cast<long>(facing_fluid), std::lround(inner / (spacing * spacing)));
}

// --- meshes -----------------------------------------------------------------------------

TEST(Shapes, ScaledUnitCubeMeshMatchesTheBox) {
  const Vec3 scale(2.0, 1.0, 0.5);
  const auto mesh = makeMesh(dataPath("unit_cube.obj"), scale);
  const auto b = makeBox(0.5 * scale);
  EXPECT_STREQ(mesh->typeName(), "mesh");
  const Aabb bb = mesh->bounds(Aabb());
  EXPECT_TRUE(bb.min.isApprox(-0.5 * scale));
  EXPECT_TRUE(bb.max.isApprox(0.5 * scale));

  int inside = 0;
  for (const Vec3& p : randomPoints(Vec3(-1.5, -1.0, -0.6), Vec3(1.5, 1.0, 0.6), 3000, 3)) {
    ASSERT_EQ(mesh->contains(p), b->contains(p)) << p.transpose();
    ASSERT_NEAR(mesh->signedDistance(p), b->signedDistance(p), 1e-6) << p.transpose();
    inside += b->contains(p);
  }
  EXPECT_GT(inside, 300);
  EXPECT_NEAR(mesh->signedDistance(Vec3::Zero()), -0.25, 1e-6);
  EXPECT_FALSE(mesh->contains(Vec3(5.0, 0.0, 0.0)));  // outside the bounds
}

TEST(Shapes, MeshSamplesSubdivideTrianglesOnTheSurface) {
  const auto mesh = makeMesh(dataPath("unit_cube.obj"), Vec3::Constant(0.4));
  const double spacing = 0.1, radius = 0.01;
  SurfaceSamples s;
  mesh->sample(spacing, radius, Aabb(), s);
  // 12 triangles, longest edge 0.4 sqrt(2) -> n = 6 -> 36 sub-triangles each.
  EXPECT_EQ(s.size(), 12u * 36u);
  EXPECT_NEAR(totalArea(s), 6.0 * 0.4 * 0.4, 1e-6);
  expectSamplesOnSurface(*mesh, s, radius, 1e-6);
  const auto b = makeBox(Vec3::Constant(0.2));
  for (std::size_t i = 0; i < s.size(); ++i) {
    EXPECT_TRUE(mesh->contains(s.position[i]));
    EXPECT_LT(
        (rawGradient(*b, s.position[i] + (radius + 1e-3) * s.normal[i], 1e-6) - s.normal[i]).norm(),
        1e-6);
  }
}

TEST(Shapes, InwardWoundMeshIsTurnedOver) {
  const auto tetra = makeMesh(dataPath("tetra_inward.obj"), Vec3::Ones());
  const Vec3 centroid = Vec3::Constant(0.25);
  EXPECT_TRUE(tetra->contains(centroid));
  EXPECT_NEAR(tetra->signedDistance(centroid), -0.25 / std::sqrt(3.0), 1e-6);
  EXPECT_NEAR(tetra->signedDistance(Vec3(1.0, 1.0, 1.0)), 2.0 / std::sqrt(3.0), 1e-6);
  EXPECT_NEAR(tetra->signedDistance(Vec3(-1.0, 0.1, 0.1)), 1.0, 1e-6);
  EXPECT_FALSE(tetra->contains(Vec3(0.4, 0.4, 0.4)));

  SurfaceSamples s;
  tetra->sample(0.05, 0.0, Aabb(), s);
  EXPECT_NEAR(totalArea(s), 1.5 + std::sqrt(3.0) / 2.0, 1e-6);
  expectSamplesOnSurface(*tetra, s, 0.0, 1e-6);
  for (std::size_t i = 0; i < s.size(); ++i)
    EXPECT_GT(s.normal[i].dot(s.position[i] - centroid), 0.0);  // outward
}

TEST(Shapes, MirroredMeshStaysOutward) {
  const auto mesh = makeMesh(dataPath("unit_cube.obj"), Vec3(-1.0, 1.0, 1.0));
  EXPECT_TRUE(mesh->contains(Vec3(0.1, 0.2, 0.3)));
  SurfaceSamples s;
  mesh->sample(0.5, 0.0, Aabb(), s);
  expectSamplesOnSurface(*mesh, s, 0.0, 1e-6);
}

TEST(Shapes, MeshErrorsNameTheFile) {
  const std::string missing = dataPath("does_not_exist.obj");
  try {
    makeMesh(missing, Vec3::Ones());
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
  const std::string empty = dataPath("no_faces.obj");
  try {
    makeMesh(empty, Vec3::Ones());
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(empty), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no triangles"), std::string::npos) << e.what();
  }
}

TEST(Shapes, InvalidParametersAreRejected) {
  EXPECT_THROW(makeBox(Vec3(1.0, 0.0, 1.0)), std::invalid_argument);
  EXPECT_THROW(makeSphere(-1.0), std::invalid_argument);
  EXPECT_THROW(makeSphere(std::nan("")), std::invalid_argument);
  EXPECT_THROW(makePlane(Vec3::Zero(), 0.0), std::invalid_argument);
  EXPECT_THROW(makeTank(Vec3::Zero(), Vec3(1.0, -1.0, 1.0), 0.1), std::invalid_argument);
  EXPECT_THROW(makeTank(Vec3::Zero(), Vec3::Ones(), 0.0), std::invalid_argument);
  EXPECT_THROW(makeMesh(dataPath("unit_cube.obj"), Vec3(1.0, 0.0, 1.0)), std::invalid_argument);
  SurfaceSamples s;
  EXPECT_THROW(makeBox(Vec3::Ones())->sample(0.0, 0.0, Aabb(), s), std::invalid_argument);
}

}  // namespace
}  // namespace wake
