// Shapes of the Bullet bridge (geometry/shape.hpp): capsule, rounded cylinder, cone with
// margin, rounded convex shapes, compounds, volumes, and the quality of their sampling.
#include "geometry/geometry_test_support.hpp"
#include "geometry/shape.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
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

// Under AddressSanitizer the signed-distance sampler runs ~10x slower (57 s for the sharp
// hull alone): there, the sharp hull and the tetrahedron-and-sphere sampling checks are
// left to the main build, and the rounded hull with a small margin (the same triangle-mesh
// path), the rounded box and the compound still run the sampler under the sanitizers.
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif

/// Points spread over the surface: uniform random points of the bounds (grown by `band`)
/// within `band` of the surface, projected onto it by Newton steps on the signed distance.
/// A thin band stands for the surface area, so they are about uniform on the surface.
std::vector<Vec3> surfacePoints(const Shape& shape, double band, int n, unsigned seed) {
  const Aabb b = shape.bounds(Aabb());
  const Vec3 lo = b.min - Vec3::Constant(band), hi = b.max + Vec3::Constant(band);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Vec3> points;
  for (int attempt = 0; attempt < 1000 * n && static_cast<int>(points.size()) < n; ++attempt) {
    Vec3 p = lo + Vec3(u(rng), u(rng), u(rng)).cwiseProduct(hi - lo);
    if (std::abs(shape.signedDistance(p)) > band) continue;
    for (int k = 0; k < 20; ++k) {
      const double d = shape.signedDistance(p);
      if (std::abs(d) < 1e-13) break;
      p -= d * rawGradient(shape, p, 1e-7).normalized();
    }
    points.push_back(p);
  }
  return points;
}

/// Requirements on a sampling, each checked:
///  (a) deterministic: two calls give the same samples;
///  (b) one sample per spacing^2: areas add up to the exact area within 5%, count within 25%;
///  (c) no holes: every point of the surface within 0.8 spacing of a sample's surface point;
///  (d) surface points on the exact surface (|sd| < 1e-6 scale), normals = the SDF gradient
///      (just outside the surface, where it is well defined) and outward;
///  (e) no two samples' surface points closer than 0.5 spacing.
void expectGoodSampling(const Shape& shape, double spacing, double radius, double exact_area,
                        double scale) {
  SurfaceSamples s, again;
  shape.sample(spacing, radius, Aabb(), s);
  shape.sample(spacing, radius, Aabb(), again);
  ASSERT_GT(s.size(), 0u);
  ASSERT_EQ(s.normal.size(), s.size());
  ASSERT_EQ(s.area.size(), s.size());
  // (a)
  ASSERT_EQ(again.size(), s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    ASSERT_EQ(again.position[i], s.position[i]) << i;
    ASSERT_EQ(again.normal[i], s.normal[i]) << i;
    ASSERT_EQ(again.area[i], s.area[i]) << i;
  }
  // (b)
  const double expected_count = exact_area / (spacing * spacing);
  EXPECT_NEAR(totalArea(s), exact_area, 0.05 * exact_area);
  EXPECT_NEAR(static_cast<double>(s.size()), expected_count, 0.25 * expected_count);
  // (d)
  std::vector<Vec3> surface(s.size());
  const double eps = 1e-4 * scale;
  double worst_sd = 0.0, worst_normal = 0.0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    surface[i] = s.position[i] + radius * s.normal[i];
    ASSERT_NEAR(s.normal[i].norm(), 1.0, 1e-12) << i;
    ASSERT_GT(s.area[i], 0.0) << i;
    worst_sd = std::max(worst_sd, std::abs(shape.signedDistance(surface[i])));
    const Vec3 outside = surface[i] + eps * s.normal[i];
    worst_normal = std::max(worst_normal, (rawGradient(shape, outside, 1e-7) - s.normal[i]).norm());
    ASSERT_GT(shape.signedDistance(outside), 0.0) << i;
    ASSERT_LT(shape.signedDistance(surface[i] - eps * s.normal[i]), 0.0) << i;
  }
  EXPECT_LT(worst_sd, 1e-6 * scale);
  EXPECT_LT(worst_normal, 1e-5);
  // (c)
  double worst_gap = 0.0;
  Vec3 worst_point = Vec3::Zero();
  for (const Vec3& p : surfacePoints(shape, 2.0 * spacing, 4000, 17)) {
    double nearest_sq = std::numeric_limits<double>::infinity();
    for (const Vec3& q : surface)
      nearest_sq = std::min(nearest_sq, (q - p).squaredNorm());
    if (std::sqrt(nearest_sq) > worst_gap) {
      worst_gap = std::sqrt(nearest_sq);
      worst_point = p;
    }
  }
  EXPECT_LT(worst_gap, 0.8 * spacing) << "hole at " << worst_point.transpose();
  // (e)
  double closest = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < surface.size(); ++i)
    for (std::size_t j = i + 1; j < surface.size(); ++j)
      closest = std::min(closest, (surface[i] - surface[j]).squaredNorm());
  closest = std::sqrt(closest);
  EXPECT_GT(closest, 0.5 * spacing);
  std::cout << "  [" << shape.typeName() << "] n " << s.size() << " (A/s^2 " << expected_count
            << ")  area " << totalArea(s) / exact_area << "  gap " << worst_gap / spacing
            << "  closest " << closest / spacing << "  |sd| " << worst_sd << "  normal "
            << worst_normal << " worst at " << worst_point.transpose() << "\n";
}

/// |grad sd| = 1 at random points away from the surface: the signed distance is a true
/// distance, not just a bound.
void expectUnitGradient(const Shape& shape, int n, unsigned seed) {
  const Aabb b = shape.bounds(Aabb());
  const Vec3 lo = b.min - 0.5 * (b.max - b.min), hi = b.max + 0.5 * (b.max - b.min);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < n; ++i) {
    const Vec3 p = lo + Vec3(u(rng), u(rng), u(rng)).cwiseProduct(hi - lo);
    if (std::abs(shape.signedDistance(p)) < 1e-3) continue;
    const double g = rawGradient(shape, p, 1e-6).norm();
    if (std::abs(g - 1.0) > 1e-4) {
      // The medial axis (inside) has no gradient: a kink where two nearest points meet.
      EXPECT_LT(shape.signedDistance(p), 0.0) << p.transpose() << " |grad| " << g;
    }
  }
}

/// Volume of a solid of revolution about y from its meridian: Pappus, 2 pi int r dA over
/// {(r, y) : sd(r, y, 0) < 0}, midpoint rule on an n x n grid of [0, r_max] x [y0, y1].
double revolutionVolume(const Shape& shape, double r_max, double y0, double y1, int n) {
  const double dr = r_max / n, dy = (y1 - y0) / n;
  double sum = 0.0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double r = (i + 0.5) * dr;
      if (shape.signedDistance(Vec3(r, y0 + (j + 0.5) * dy, 0.0)) < 0.0) sum += r;
    }
  return 2.0 * kPi * sum * dr * dy;
}

/// Closed triangle mesh of the box [-h, h] (12 triangles, outward).
std::unique_ptr<Shape> boxMesh(const Vec3& h) {
  std::vector<Vec3> v;
  for (int k = 0; k < 8; ++k)
    v.emplace_back((k & 1) ? h.x() : -h.x(), (k & 2) ? h.y() : -h.y(), (k & 4) ? h.z() : -h.z());
  std::vector<std::array<int, 3>> t = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6},
                                       {0, 1, 4}, {1, 5, 4}, {2, 6, 3}, {3, 6, 7},
                                       {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  return makeTriangleMesh(v, t);
}

/// Regular tetrahedron with edge length a, centred at the origin.
std::unique_ptr<Shape> tetraMesh(double a) {
  const double s = a / (2.0 * std::sqrt(2.0));
  std::vector<Vec3> v = {Vec3(s, s, s), Vec3(s, -s, -s), Vec3(-s, s, -s), Vec3(-s, -s, s)};
  // Any winding: makeTriangleMesh turns an inward mesh over.
  return makeTriangleMesh(v, {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}});
}

/// Volume of the box of half extents (a, b, c) rounded by r.
double roundedBoxVolume(double a, double b, double c, double r) {
  return 8.0 * a * b * c + 8.0 * (a * b + b * c + c * a) * r + 2.0 * kPi * (a + b + c) * r * r +
         4.0 / 3.0 * kPi * r * r * r;
}
double roundedBoxArea(double a, double b, double c, double r) {
  return 8.0 * (a * b + b * c + c * a) + 4.0 * kPi * (a + b + c) * r + 4.0 * kPi * r * r;
}

// --- capsule ------------------------------------------------------------------------------

TEST(BulletShapes, CapsuleSignedDistanceAtPolesAndEquator) {
  const auto c = makeCapsule(0.1, 0.2);
  EXPECT_STREQ(c->typeName(), "capsule");
  EXPECT_NEAR(c->signedDistance(Vec3(0.0, 0.3, 0.0)), 0.0, 1e-15);   // north pole
  EXPECT_NEAR(c->signedDistance(Vec3(0.0, -0.3, 0.0)), 0.0, 1e-15);  // south pole
  EXPECT_NEAR(c->signedDistance(Vec3(0.0, 0.4, 0.0)), 0.1, 1e-15);
  EXPECT_NEAR(c->signedDistance(Vec3(0.1, 0.0, 0.0)), 0.0, 1e-15);   // equator
  EXPECT_NEAR(c->signedDistance(Vec3(0.0, 0.1, -0.1)), 0.0, 1e-15);  // side
  EXPECT_NEAR(c->signedDistance(Vec3(0.3, 0.1, 0.0)), 0.2, 1e-15);
  EXPECT_NEAR(c->signedDistance(Vec3::Zero()), -0.1, 1e-15);
  EXPECT_NEAR(c->signedDistance(Vec3(0.0, 0.25, 0.0)), -0.05, 1e-15);
  EXPECT_NEAR(c->signedDistance(Vec3(0.1, 0.3, 0.0)), std::sqrt(0.02) - 0.1, 1e-15);
  EXPECT_TRUE(c->contains(Vec3(0.0, 0.29, 0.0)));
  EXPECT_FALSE(c->contains(Vec3(0.08, 0.28, 0.0)));  // outside the cap's corner
  EXPECT_TRUE(c->bounds(Aabb()).max.isApprox(Vec3(0.1, 0.3, 0.1)));
  EXPECT_TRUE(c->bounds(Aabb()).min.isApprox(Vec3(-0.1, -0.3, -0.1)));
  expectUnitGradient(*c, 2000, 1);

  // Zero half height: a sphere.
  const auto s = makeCapsule(0.1, 0.0);
  EXPECT_NEAR(s->signedDistance(Vec3(0.3, 0.4, 0.0)), 0.4, 1e-15);
  EXPECT_NEAR(s->volume(), 4.0 / 3.0 * kPi * 1e-3, 1e-15);
}

TEST(BulletShapes, CapsuleVolumeAndSampling) {
  const double r = 0.1, h = 0.15;
  const auto c = makeCapsule(r, h);
  EXPECT_NEAR(c->volume(), kPi * r * r * 2.0 * h + 4.0 / 3.0 * kPi * r * r * r, 1e-15);
  const double area = 4.0 * kPi * r * r + 2.0 * kPi * r * 2.0 * h;
  ASSERT_TRUE(c->convexMeasures());
  EXPECT_NEAR(c->convexMeasures()->area, area, 1e-14);
  SurfaceSamples s;
  c->sample(0.01, 0.0, Aabb(), s);
  EXPECT_NEAR(totalArea(s), area, 1e-12);  // band areas are exact
  expectGoodSampling(*c, 0.01, 0.002, area, 0.5);
  expectGoodSampling(*makeCapsule(0.05, 0.0), 0.01, 0.0, 4.0 * kPi * 0.0025, 0.1);
  expectGoodSampling(*makeCapsule(0.02, 0.3), 0.012, 0.004,
                     4.0 * kPi * 0.0004 + 2.0 * kPi * 0.02 * 0.6, 0.5);
}

// --- cylinder -----------------------------------------------------------------------------

TEST(BulletShapes, RoundedCylinderSignedDistance) {
  const double R = 0.1, h = 0.2, rho = 0.02;
  const auto c = makeCylinder(R, h, rho);
  EXPECT_STREQ(c->typeName(), "cylinder");
  EXPECT_NEAR(c->signedDistance(Vec3(0.1, 0.0, 0.0)), 0.0, 1e-15);  // side
  EXPECT_NEAR(c->signedDistance(Vec3(0.06, 0.1, 0.08)), 0.0, 1e-15);
  EXPECT_NEAR(c->signedDistance(Vec3(0.0, 0.2, 0.0)), 0.0, 1e-15);  // top
  EXPECT_NEAR(c->signedDistance(Vec3(0.05, -0.2, 0.0)), 0.0, 1e-15);
  EXPECT_NEAR(c->signedDistance(Vec3::Zero()), -0.1, 1e-15);
  EXPECT_NEAR(c->signedDistance(Vec3(0.0, 0.15, 0.0)), -0.05, 1e-15);
  // The sharp corner is cut off: the rounded edge is the torus about (0.08, 0.18).
  EXPECT_NEAR(c->signedDistance(Vec3(0.1, 0.2, 0.0)), rho * (std::sqrt(2.0) - 1.0), 1e-15);
  EXPECT_FALSE(c->contains(Vec3(0.099, 0.199, 0.0)));
  const double d = rho / std::sqrt(2.0);
  EXPECT_NEAR(c->signedDistance(Vec3(0.08 + d, 0.18 + d, 0.0)), 0.0, 1e-15);
  EXPECT_NEAR(c->signedDistance(Vec3(0.0, -(0.18 + d), 0.08 + d)), 0.0, 1e-15);
  EXPECT_NEAR(c->signedDistance(Vec3(0.08 + 2 * d, 0.18 + 2 * d, 0.0)), rho, 1e-15);
  EXPECT_EQ(c->bounds(Aabb()).max, Vec3(R, h, R));
  expectUnitGradient(*c, 2000, 2);

  const auto sharp = makeCylinder(R, h, 0.0);
  EXPECT_NEAR(sharp->signedDistance(Vec3(0.1, 0.2, 0.0)), 0.0, 1e-15);
  EXPECT_NEAR(sharp->signedDistance(Vec3(0.13, 0.24, 0.0)), 0.05, 1e-15);
  EXPECT_TRUE(sharp->contains(Vec3(0.099, 0.199, 0.0)));
}

TEST(BulletShapes, CylinderVolumeAndSampling) {
  const double R = 0.1, h = 0.12;
  const auto sharp = makeCylinder(R, h, 0.0);
  EXPECT_NEAR(sharp->volume(), kPi * R * R * 2.0 * h, 1e-15);
  const double sharp_area = 2.0 * kPi * R * R + 2.0 * kPi * R * 2.0 * h;
  expectGoodSampling(*sharp, 0.01, 0.002, sharp_area, 0.3);

  // Rounded: inner cylinder (a, b) plus its shell: side, two discs, two quarter tori.
  const double rho = 0.02, a = R - rho, b = h - rho;
  const auto c = makeCylinder(R, h, rho);
  const double volume = kPi * a * a * 2.0 * b                              // inner cylinder
                        + kPi * ((a + rho) * (a + rho) - a * a) * 2.0 * b  // side shell
                        + 2.0 * kPi * a * a * rho                          // top and bottom slabs
                        + 2.0 * (kPi * rho * rho / 4.0) * 2.0 * kPi *
                              (a + 4.0 * rho / (3.0 * kPi));  // quarter tori (Pappus)
  EXPECT_NEAR(c->volume(), volume, 1e-14);
  EXPECT_NEAR(revolutionVolume(*c, R, -h, h, 1000), volume, 1e-3 * volume);
  const double area = 2.0 * kPi * a * a + 2.0 * kPi * R * 2.0 * b +
                      2.0 * (kPi * rho / 2.0) * 2.0 * kPi * (a + 2.0 * rho / kPi);
  ASSERT_TRUE(c->convexMeasures());
  EXPECT_NEAR(c->convexMeasures()->area, area, 1e-14);
  expectGoodSampling(*c, 0.01, 0.002, area, 0.3);
  // Rounding below the spacing.
  const double small = 0.003, as = R - small, bs = h - small;
  expectGoodSampling(*makeCylinder(R, h, small), 0.01, 0.002,
                     2.0 * kPi * as * as + 2.0 * kPi * R * 2.0 * bs +
                         2.0 * (kPi * small / 2.0) * 2.0 * kPi * (as + 2.0 * small / kPi),
                     0.3);
}

// --- cone ---------------------------------------------------------------------------------

TEST(BulletShapes, ConeSignedDistanceAtApexBaseAndSlant) {
  const double R = 0.1, H = 0.2, m = 0.01;
  const auto c = makeCone(R, H, m);
  EXPECT_STREQ(c->typeName(), "cone");
  EXPECT_NEAR(c->signedDistance(Vec3(0.0, 0.1, 0.0)), -m, 1e-15);  // apex, under the margin
  EXPECT_NEAR(c->signedDistance(Vec3(0.0, 0.11, 0.0)), 0.0, 1e-15);
  EXPECT_NEAR(c->signedDistance(Vec3(0.0, 0.2, 0.0)), 0.09, 1e-15);
  EXPECT_NEAR(c->signedDistance(Vec3(0.0, -0.11, 0.0)), 0.0, 1e-15);  // base, grown
  EXPECT_NEAR(c->signedDistance(Vec3(0.05, -0.1, 0.0)), -m, 1e-15);
  // Inside: nearer to the base (0.05) than to the slant (0.15 x 0.1 / |(0.2, 0.1)|).
  EXPECT_NEAR(c->signedDistance(Vec3(0.0, -0.05, 0.0)), -0.05 - m, 1e-15);
  EXPECT_NEAR(c->signedDistance(Vec3(0.0, 0.05, 0.0)), -0.05 * 0.1 / std::hypot(0.2, 0.1) - m,
              1e-15);
  // Off the slant along its outward normal (2, 1)/sqrt(5), from the slant's midpoint.
  const Vec3 n = Vec3(2.0, 1.0, 0.0).normalized();
  EXPECT_NEAR(c->signedDistance(Vec3(0.05, 0.0, 0.0) + 0.03 * n), 0.03 - m, 1e-15);
  const Vec3 nz(0.0, n.y(), n.x());  // the same, in the z meridian
  EXPECT_NEAR(c->signedDistance(Vec3(0.0, 0.0, 0.05) + m * nz), 0.0, 1e-15);
  // Around the rim (0.1, -0.1): a torus of radius m.
  EXPECT_NEAR(c->signedDistance(Vec3(0.1 + m, -0.1, 0.0)), 0.0, 1e-15);
  EXPECT_NEAR(c->signedDistance(Vec3(0.13, -0.14, 0.0)), 0.05 - m, 1e-15);
  EXPECT_TRUE(c->contains(Vec3(0.0, 0.105, 0.0)));
  EXPECT_FALSE(c->contains(Vec3(0.0, -0.115, 0.0)));
  EXPECT_TRUE(c->bounds(Aabb()).max.isApprox(Vec3(0.11, 0.11, 0.11)));
  EXPECT_TRUE(c->bounds(Aabb()).min.isApprox(Vec3(-0.11, -0.11, -0.11)));
  expectUnitGradient(*c, 2000, 3);

  const auto sharp = makeCone(R, H, 0.0);
  EXPECT_NEAR(sharp->signedDistance(Vec3(0.0, 0.1, 0.0)), 0.0, 1e-15);  // apex
  EXPECT_NEAR(sharp->signedDistance(Vec3(0.0, 0.15, 0.0)), 0.05, 1e-15);
  EXPECT_NEAR(sharp->signedDistance(Vec3(0.1, -0.1, 0.0)), 0.0, 1e-15);  // rim
  EXPECT_TRUE(sharp->contains(Vec3(0.0, 0.099, 0.0)));
  EXPECT_FALSE(sharp->contains(Vec3(0.02, 0.099, 0.0)));
}

TEST(BulletShapes, ConeVolumeAndSampling) {
  const double R = 0.1, H = 0.25;
  const double slant = std::hypot(R, H);
  const auto sharp = makeCone(R, H, 0.0);
  EXPECT_NEAR(sharp->volume(), kPi * R * R * H / 3.0, 1e-15);
  const double sharp_area = kPi * R * R + kPi * R * slant;
  // (Samples on both sides of the sharp rim may come as close as sin(34 deg) = 0.56 spacing.)
  expectGoodSampling(*sharp, 0.01, 0.002, sharp_area, 0.3);

  const double m = 0.015;
  const auto c = makeCone(R, H, m);
  const double volume = c->volume();
  // Independent: Pappus on the meridian.
  EXPECT_NEAR(revolutionVolume(*c, R + m, -H / 2 - m, H / 2 + m, 1200), volume, 1e-3 * volume);
  // By hand: the triangle's offset region of the meridian, revolved (Pappus): the triangle,
  // the strip along the slant, the strip under the base, the disc sectors at the apex and
  // the rim; 2 pi times the first moment about the axis.
  const double beta = std::atan2(H, R);  // base-slant angle
  const Vec3 n(H / slant, R / slant, 0.0);
  double moment = R * R * H / 6.0;                         // triangle: int r dA
  moment += m * slant * (0.5 * R + m * n.x() / 2.0);       // slant strip
  moment += m * R * (R / 2.0);                             // base strip
  const double apex_angle = 0.5 * kPi - std::atan2(R, H);  // apex sector, about r = 0
  moment += m * m * m / 3.0 * (std::sin(0.5 * kPi) - std::sin(0.5 * kPi - apex_angle));
  const double rim_angle = kPi - beta;     // rim sector, about r = R
  const double theta0 = std::atan2(R, H);  // from n down to -pi/2
  moment +=
      R * 0.5 * m * m * rim_angle + m * m * m / 3.0 * (std::sin(theta0) - std::sin(-0.5 * kPi));
  EXPECT_NEAR(volume, 2.0 * kPi * moment, 1e-12);

  // Area: Steiner, and the same by hand (Pappus on the profile curve).
  double curve = 0.0;                                             // int r ds over the profile
  curve += m * m * (1.0 - std::cos(apex_angle));                  // apex cap
  curve += slant * (R / 2.0 + m * n.x());                         // slant
  curve += R * m * rim_angle + m * m * (std::sin(theta0) + 1.0);  // rim torus
  curve += R * R / 2.0;                                           // base
  const double area = 2.0 * kPi * curve;
  ASSERT_TRUE(c->convexMeasures());
  EXPECT_NEAR(c->convexMeasures()->area, area, 1e-12);
  expectGoodSampling(*c, 0.01, 0.002, area, 0.3);
}

// --- rounded convex shapes -------------------------------------------------------------------

TEST(BulletShapes, RoundedBoxAndHullSignedDistance) {
  const double m = 0.02;
  const auto r = makeRounded(makeBox(Vec3(0.1, 0.05, 0.08)), m);
  EXPECT_STREQ(r->typeName(), "rounded");
  EXPECT_NEAR(r->signedDistance(Vec3(0.12, 0.0, 0.0)), 0.0, 1e-15);
  EXPECT_NEAR(r->signedDistance(Vec3::Zero()), -0.07, 1e-15);
  EXPECT_NEAR(r->signedDistance(Vec3(0.1, 0.05, 0.08) + m * Vec3::Ones().normalized()), 0.0, 1e-15);
  EXPECT_NEAR(r->signedDistance(Vec3(0.2, 0.05, 0.0)), 0.08, 1e-15);
  EXPECT_TRUE(r->bounds(Aabb()).max.isApprox(Vec3(0.12, 0.07, 0.1)));
  expectUnitGradient(*r, 2000, 4);

  // The same as a rounded hull mesh.
  const auto hull = makeRounded(boxMesh(Vec3(0.1, 0.05, 0.08)), m);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.15, 0.15);
  for (int i = 0; i < 500; ++i) {
    const Vec3 p(u(rng), u(rng), u(rng));
    ASSERT_NEAR(hull->signedDistance(p), r->signedDistance(p), 1e-12) << p.transpose();
    ASSERT_EQ(hull->contains(p), r->contains(p)) << p.transpose();
  }
  // Margin 0 is the shape itself.
  const auto same = makeRounded(makeSphere(0.1), 0.0);
  EXPECT_NEAR(same->signedDistance(Vec3(0.3, 0.0, 0.0)), 0.2, 1e-15);
}

TEST(BulletShapes, RoundedVolumesFollowSteiner) {
  const double a = 0.1, b = 0.05, c = 0.08, m = 0.02;
  EXPECT_NEAR(makeRounded(makeBox(Vec3(a, b, c)), m)->volume(), roundedBoxVolume(a, b, c, m),
              1e-15);
  EXPECT_NEAR(makeRounded(boxMesh(Vec3(a, b, c)), m)->volume(), roundedBoxVolume(a, b, c, m),
              1e-15);
  EXPECT_NEAR(makeRounded(boxMesh(Vec3(a, b, c)), 0.0)->volume(), 8.0 * a * b * c, 1e-15);
  EXPECT_NEAR(makeRounded(makeSphere(0.1), m)->volume(), 4.0 / 3.0 * kPi * std::pow(0.12, 3),
              1e-15);
  // Capsule = rounded segment; rounding a capsule grows its radius.
  EXPECT_NEAR(makeRounded(makeCapsule(0.05, 0.1), m)->volume(), makeCapsule(0.07, 0.1)->volume(),
              1e-15);
  // Rounded rounded box = box rounded by the sum.
  EXPECT_NEAR(makeRounded(makeRounded(makeBox(Vec3(a, b, c)), m), 0.01)->volume(),
              roundedBoxVolume(a, b, c, m + 0.01), 1e-15);
  // Regular tetrahedron (edge e): V = e^3 / (6 sqrt 2), A = sqrt(3) e^2, six edges of
  // exterior angle pi - acos(1/3).
  const double e = 0.2;
  const double tetra_volume = e * e * e / (6.0 * std::sqrt(2.0));
  const double tetra_area = std::sqrt(3.0) * e * e;
  const double tetra_m = 0.5 * 6.0 * e * (kPi - std::acos(1.0 / 3.0));
  const auto tetra = makeRounded(tetraMesh(e), m);
  EXPECT_NEAR(tetra->volume(),
              tetra_volume + tetra_area * m + tetra_m * m * m + 4.0 / 3.0 * kPi * m * m * m, 1e-15);
  ASSERT_TRUE(tetra->convexMeasures());
  EXPECT_NEAR(tetra->convexMeasures()->area, tetra_area + 2.0 * tetra_m * m + 4.0 * kPi * m * m,
              1e-15);

  // No Steiner data (a compound, convex here): a grid estimate.
  std::vector<CompoundChild> one = {{makeBox(Vec3(a, b, c)), Pose{}}};
  const auto estimated = makeRounded(makeCompound(one), m);
  EXPECT_FALSE(estimated->convexMeasures());
  EXPECT_NEAR(estimated->volume(), roundedBoxVolume(a, b, c, m),
              2e-3 * roundedBoxVolume(a, b, c, m));
}

// The generic sampler (sampleSurfaceBySdf) behind every rounded shape.
constexpr double kA = 0.1, kB = 0.06, kC = 0.08;  // m, half extents of the boxes below

TEST(BulletShapes, RoundedBoxSamplesWell) {
  expectGoodSampling(*makeRounded(makeBox(Vec3(kA, kB, kC)), 0.02), 0.01, 0.002,
                     roundedBoxArea(kA, kB, kC, 0.02), 0.3);
}

TEST(BulletShapes, RoundedHullWithASmallMarginSamplesWell) {
  // Margin below the spacing: nearly sharp edges.
  expectGoodSampling(*makeRounded(boxMesh(Vec3(kA, kB, kC)), 0.004), 0.01, 0.002,
                     roundedBoxArea(kA, kB, kC, 0.004), 0.3);
}

TEST(BulletShapes, SharpHullSamplesWell) {
  if (kSanitized) GTEST_SKIP() << "sampling quality: checked in the main build";
  // Margin 0: sharp edges; normals on an edge lie in its normal cone.
  expectGoodSampling(*makeRounded(boxMesh(Vec3(kA, kB, kC)), 0.0), 0.01, 0.002,
                     roundedBoxArea(kA, kB, kC, 0.0), 0.3);
}

TEST(BulletShapes, RoundedTetrahedronAndSphereSampleWell) {
  if (kSanitized) GTEST_SKIP() << "sampling quality: checked in the main build";
  const double e = 0.25, m = 0.02;
  const double tetra_area = std::sqrt(3.0) * e * e;
  const double tetra_m = 0.5 * 6.0 * e * (kPi - std::acos(1.0 / 3.0));
  expectGoodSampling(*makeRounded(tetraMesh(e), m), 0.01, 0.002,
                     tetra_area + 2.0 * tetra_m * m + 4.0 * kPi * m * m, 0.3);
  expectGoodSampling(*makeRounded(makeSphere(0.08), 0.01), 0.01, 0.0, 4.0 * kPi * 0.0081, 0.2);
}

TEST(BulletShapes, RoundedShapeWithoutSteinerDataSamplesWell) {
  // A compound (turned) has no Steiner data: the areas are the sampler's own estimate.
  Pose turned;
  turned.position = Vec3(0.02, -0.01, 0.03);
  turned.orientation = Quat(Eigen::AngleAxisd(0.7, Vec3(1.0, 2.0, 3.0).normalized()));
  const auto rounded = makeRounded(makeCompound({{makeBox(Vec3(kA, kB, kC)), turned}}), 0.02);
  ASSERT_FALSE(rounded->convexMeasures());
  expectGoodSampling(*rounded, 0.01, 0.002, roundedBoxArea(kA, kB, kC, 0.02), 0.3);
  SurfaceSamples s;
  rounded->sample(0.01, 0.0, Aabb(), s);
  EXPECT_NEAR(totalArea(s), roundedBoxArea(kA, kB, kC, 0.02),
              0.01 * roundedBoxArea(kA, kB, kC, 0.02));
}

// --- compound -----------------------------------------------------------------------------

TEST(BulletShapes, CompoundFollowsChildPoses) {
  Pose pose;
  pose.position = Vec3(0.5, 0.2, -0.3);
  pose.orientation = Quat(Eigen::AngleAxisd(0.5 * kPi, Vec3::UnitZ()));  // y axis -> -x
  std::shared_ptr<const Shape> capsule = makeCapsule(0.05, 0.1);
  const auto compound = makeCompound({{capsule, pose}});
  EXPECT_STREQ(compound->typeName(), "compound");
  // The capsule's axis now runs along x through the child's origin.
  EXPECT_NEAR(compound->signedDistance(Vec3(0.5, 0.2, -0.3)), -0.05, 1e-15);
  EXPECT_NEAR(compound->signedDistance(Vec3(0.35, 0.2, -0.3)), 0.0, 1e-15);
  EXPECT_NEAR(compound->signedDistance(Vec3(0.5, 0.25, -0.3)), 0.0, 1e-15);
  EXPECT_FALSE(compound->contains(Vec3::Zero()));
  EXPECT_TRUE(compound->contains(Vec3(0.64, 0.2, -0.3)));
  const Aabb bb = compound->bounds(Aabb());
  EXPECT_TRUE(bb.min.isApprox(Vec3(0.35, 0.15, -0.35)));
  EXPECT_TRUE(bb.max.isApprox(Vec3(0.65, 0.25, -0.25)));
  EXPECT_NEAR(compound->volume(), capsule->volume(), 1e-15);

  const double spacing = 0.01, radius = 0.002;
  SurfaceSamples own, placed;
  capsule->sample(spacing, radius, Aabb(), own);
  compound->sample(spacing, radius, Aabb(), placed);
  ASSERT_EQ(placed.size(), own.size());
  for (std::size_t i = 0; i < own.size(); ++i) {
    EXPECT_TRUE(placed.position[i].isApprox(pose.toWorld(own.position[i]), 1e-14));
    EXPECT_TRUE(placed.normal[i].isApprox(pose.rotate(own.normal[i]), 1e-14));
    EXPECT_EQ(placed.area[i], own.area[i]);
    EXPECT_NEAR(compound->signedDistance(placed.position[i] + radius * placed.normal[i]), 0.0,
                1e-12);
  }
}

TEST(BulletShapes, CompoundDropsSamplesInsideOtherChildren) {
  // A box and an off-centre sphere that overlap, and a cylinder standing on the box's top
  // face (touching: its bottom disc lies on the box's face).
  Pose sphere_pose, cylinder_pose;
  sphere_pose.position = Vec3(0.12, 0.03, 0.02);
  cylinder_pose.position = Vec3(-0.05, 0.05 + 0.08, 0.0);
  const std::shared_ptr<const Shape> box = makeBox(Vec3(0.1, 0.05, 0.06));
  const std::shared_ptr<const Shape> sphere = makeSphere(0.06);
  const std::shared_ptr<const Shape> cylinder = makeCylinder(0.03, 0.08, 0.0);
  const std::vector<CompoundChild> children = {
      {box, Pose{}}, {sphere, sphere_pose}, {cylinder, cylinder_pose}};
  const auto compound = makeCompound(children);

  const double spacing = 0.005, radius = 0.001;
  SurfaceSamples s;
  compound->sample(spacing, radius, Aabb(), s);
  std::size_t all = 0;
  for (const CompoundChild& c : children) {
    SurfaceSamples own;
    c.shape->sample(spacing, radius, Aabb(), own);
    all += own.size();
  }
  EXPECT_LT(s.size(), all);
  ASSERT_GT(s.size(), all / 2);
  for (std::size_t i = 0; i < s.size(); ++i) {
    const Vec3 surface = s.position[i] + radius * s.normal[i];
    // On the surface of the union, and strictly inside no child.
    EXPECT_NEAR(compound->signedDistance(surface), 0.0, 1e-12) << surface.transpose();
    for (const CompoundChild& c : children)
      EXPECT_GE(c.shape->signedDistance(c.pose.toBody(surface)), -1e-9) << surface.transpose();
    // None on the part of the box top covered by the cylinder's bottom disc.
    const Vec3 q = surface - cylinder_pose.position;
    EXPECT_FALSE(std::abs(surface.y() - 0.05) < 1e-9 && std::hypot(q.x(), q.z()) < 0.03 - 1e-9)
        << surface.transpose();
    // Just outside along the normal is outside the union (closer than the sampling's
    // tolerance 1e-3 spacing: near a concave crease the other child is close).
    EXPECT_FALSE(compound->contains(surface + 1e-3 * spacing * s.normal[i])) << surface.transpose();
  }
  // The union has samples where each child is exposed.
  int on_sphere = 0, on_cylinder_top = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const Vec3 surface = s.position[i] + radius * s.normal[i];
    on_sphere += surface.x() > 0.1 + 1e-6;
    on_cylinder_top += std::abs(surface.y() - 0.21) < 1e-9;
  }
  EXPECT_GT(on_sphere, 100);
  EXPECT_GT(on_cylinder_top, 80);  // pi 0.03^2 / 0.005^2 = 113

  // Union semantics.
  EXPECT_TRUE(compound->contains(Vec3(0.17, 0.03, 0.02)));  // sphere only
  EXPECT_TRUE(compound->contains(Vec3(-0.05, 0.2, 0.0)));   // cylinder only
  EXPECT_FALSE(compound->contains(Vec3(0.05, 0.2, 0.05)));
  EXPECT_NEAR(compound->signedDistance(Vec3(0.0, -0.1, 0.0)), 0.05, 1e-15);
  const Aabb bb = compound->bounds(Aabb());
  EXPECT_TRUE(bb.min.isApprox(Vec3(-0.1, -0.05, -0.06)));
  EXPECT_TRUE(bb.max.isApprox(Vec3(0.18, 0.21, 0.08)));
}

TEST(BulletShapes, CompoundVolume) {
  // Apart: the exact sum.
  Pose left, right;
  left.position = Vec3(-0.3, 0.0, 0.0);
  right.position = Vec3(0.3, 0.1, 0.0);
  right.orientation = Quat(Eigen::AngleAxisd(0.3, Vec3(1.0, 2.0, 3.0).normalized()));
  const auto apart =
      makeCompound({{makeBox(Vec3(0.1, 0.2, 0.1)), left}, {makeCone(0.1, 0.2, 0.01), right}});
  EXPECT_NEAR(apart->volume(), 0.016 + makeCone(0.1, 0.2, 0.01)->volume(), 1e-15);
  // Touching face to face: still the sum.
  Pose above;
  above.position = Vec3(0.0, 0.3, 0.0);
  const auto touching =
      makeCompound({{makeBox(Vec3(0.1, 0.1, 0.1)), Pose{}}, {makeBox(Vec3(0.1, 0.2, 0.1)), above}});
  EXPECT_NEAR(touching->volume(), 0.008 + 0.016, 1e-15);
  // Overlapping spheres (radius r, centres d apart): two balls less the lens.
  const double r = 0.1, d = 0.12;
  Pose shifted;
  shifted.position = Vec3(0.0, d, 0.0);
  const auto lens = makeCompound({{makeSphere(r), Pose{}}, {makeSphere(r), shifted}});
  const double exact = 2.0 * 4.0 / 3.0 * kPi * r * r * r -
                       kPi * (4.0 * r + d) * (2.0 * r - d) * (2.0 * r - d) / 12.0;
  EXPECT_NEAR(lens->volume(), exact, 1e-3 * exact);
}

TEST(BulletShapes, InvalidParametersAreRejected) {
  EXPECT_THROW(makeCapsule(0.0, 1.0), std::invalid_argument);
  EXPECT_THROW(makeCapsule(1.0, -0.1), std::invalid_argument);
  EXPECT_THROW(makeCylinder(0.1, 0.2, 0.1), std::invalid_argument);  // rounding = radius
  EXPECT_THROW(makeCylinder(0.3, 0.2, 0.2), std::invalid_argument);  // = half height
  EXPECT_THROW(makeCylinder(0.1, 0.2, -0.01), std::invalid_argument);
  EXPECT_THROW(makeCylinder(0.1, 0.0, 0.0), std::invalid_argument);
  EXPECT_THROW(makeCone(0.1, 0.0, 0.0), std::invalid_argument);
  EXPECT_THROW(makeCone(0.1, 0.1, -1e-3), std::invalid_argument);
  EXPECT_THROW(makeCone(std::nan(""), 0.1, 0.0), std::invalid_argument);
  EXPECT_THROW(makeRounded(nullptr, 0.1), std::invalid_argument);
  EXPECT_THROW(makeRounded(makeSphere(1.0), -0.1), std::invalid_argument);
  EXPECT_THROW(makeRounded(makePlane(Vec3::UnitY(), 0.0), 0.1), std::invalid_argument);
  EXPECT_THROW(makeCompound({}), std::invalid_argument);
  EXPECT_THROW(makeCompound({{nullptr, Pose{}}}), std::invalid_argument);
  Pose bad;
  bad.orientation = Quat(0.0, 0.0, 0.0, 0.0);
  EXPECT_THROW(makeCompound({{makeSphere(1.0), bad}}), std::invalid_argument);
}

TEST(BulletShapes, VolumesOfTheOtherShapes) {
  EXPECT_NEAR(makeBox(Vec3(1.0, 0.5, 0.25))->volume(), 1.0, 1e-15);
  EXPECT_NEAR(makeSphere(0.5)->volume(), kPi / 6.0, 1e-15);
  EXPECT_EQ(makePlane(Vec3::UnitY(), 0.0)->volume(), std::numeric_limits<double>::infinity());
  // Tank: outer 1.2 x 0.9 x 0.8 less the cavity 1.0 x 0.8 x 0.6.
  EXPECT_NEAR(makeTank(Vec3::Zero(), Vec3(1.0, 0.8, 0.6), 0.1)->volume(),
              1.2 * 0.9 * 0.8 - 1.0 * 0.8 * 0.6, 1e-14);
  EXPECT_NEAR(boxMesh(Vec3(1.0, 0.5, 0.25))->volume(), 1.0, 1e-15);
  EXPECT_NEAR(tetraMesh(0.3)->volume(), 0.027 / (6.0 * std::sqrt(2.0)), 1e-15);
}

}  // namespace
}  // namespace wake
