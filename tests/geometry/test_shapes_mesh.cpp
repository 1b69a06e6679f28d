// Triangle meshes from memory (makeTriangleMesh): the BVH answers equal brute force.
#include "geometry/geometry_test_support.hpp"
#include "geometry/shape.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <iostream>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

namespace wake {
namespace {

using test::kPi;

struct Mesh {
  std::vector<Vec3> vertices;
  std::vector<std::array<int, 3>> triangles;
};

/// Icosahedron subdivided `levels` times, vertices on the sphere of radius r: 20 4^levels
/// triangles, outward.
Mesh icosphere(double r, int levels) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  Mesh m;
  for (const Vec3& v : {Vec3(-1, t, 0), Vec3(1, t, 0), Vec3(-1, -t, 0), Vec3(1, -t, 0),
                        Vec3(0, -1, t), Vec3(0, 1, t), Vec3(0, -1, -t), Vec3(0, 1, -t),
                        Vec3(t, 0, -1), Vec3(t, 0, 1), Vec3(-t, 0, -1), Vec3(-t, 0, 1)})
    m.vertices.push_back(r * v.normalized());
  m.triangles = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                 {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                 {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                 {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<int, int>, int> middle;
    const auto mid = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      const auto it = middle.find(key);
      if (it != middle.end()) return it->second;
      m.vertices.push_back(r * (m.vertices[a] + m.vertices[b]).normalized());
      return middle[key] = static_cast<int>(m.vertices.size()) - 1;
    };
    std::vector<std::array<int, 3>> finer;
    for (const auto& [a, b, c] : m.triangles) {
      const int ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
      finer.push_back({a, ab, ca});
      finer.push_back({b, bc, ab});
      finer.push_back({c, ca, bc});
      finer.push_back({ab, bc, ca});
    }
    m.triangles = std::move(finer);
  }
  return m;
}

/// Torus about the y axis (radii R > r), nu x nv quads cut in two: not convex.
Mesh torus(double R, double r, int nu, int nv) {
  Mesh m;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const double u = 2.0 * kPi * i / nu, v = 2.0 * kPi * j / nv;
      m.vertices.emplace_back((R + r * std::cos(v)) * std::cos(u), r * std::sin(v),
                              (R + r * std::cos(v)) * std::sin(u));
    }
  const auto id = [&](int i, int j) { return (i % nu) * nv + (j % nv); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      m.triangles.push_back({id(i, j), id(i, j + 1), id(i + 1, j)});
      m.triangles.push_back({id(i + 1, j), id(i, j + 1), id(i + 1, j + 1)});
    }
  return m;
}

/// Brute-force reference: distance to the nearest triangle by projection onto each plane
/// (inside the triangle) or else onto each edge segment.
double bruteDistance(const Mesh& m, const Vec3& p) {
  double best = std::numeric_limits<double>::infinity();
  const auto segment = [&](const Vec3& a, const Vec3& b) {
    const double t = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
    return (p - a - t * (b - a)).norm();
  };
  for (const auto& [ia, ib, ic] : m.triangles) {
    const Vec3 &a = m.vertices[ia], &b = m.vertices[ib], &c = m.vertices[ic];
    const Vec3 n = (b - a).cross(c - a).normalized();
    const Vec3 q = p - n.dot(p - a) * n;  // foot on the plane
    const bool inside = (b - a).cross(q - a).dot(n) >= 0.0 && (c - b).cross(q - b).dot(n) >= 0.0 &&
                        (a - c).cross(q - c).dot(n) >= 0.0;
    const double d =
        inside ? std::abs(n.dot(p - a)) : std::min({segment(a, b), segment(b, c), segment(c, a)});
    best = std::min(best, d);
  }
  return best;
}

/// Brute-force generalized winding number (sum of solid angles / 4 pi), outward mesh.
double bruteWinding(const Mesh& m, const Vec3& p) {
  double total = 0.0;
  for (const auto& [ia, ib, ic] : m.triangles) {
    const Vec3 a = m.vertices[ia] - p, b = m.vertices[ib] - p, c = m.vertices[ic] - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    total += 2.0 * std::atan2(a.dot(b.cross(c)),
                              la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb);
  }
  return total / (4.0 * kPi);
}

/// Query points: uniform in the grown bounds, and close to the surface (both sides).
std::vector<Vec3> queryPoints(const Mesh& m, int n, unsigned seed) {
  Aabb b;
  for (const Vec3& v : m.vertices)
    b.extend(v);
  const Vec3 grow = 0.3 * (b.max - b.min);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Vec3> points;
  for (int i = 0; i < n; ++i) {
    points.push_back(b.min - grow +
                     Vec3(u(rng), u(rng), u(rng)).cwiseProduct(b.max - b.min + 2.0 * grow));
    // A point of a random triangle, moved off it by up to 1 % of the size, either way.
    const auto& [ia, ib, ic] = m.triangles[rng() % m.triangles.size()];
    double x = u(rng), y = u(rng);
    if (x + y > 1.0) {
      x = 1.0 - x;
      y = 1.0 - y;
    }
    const Vec3 &a = m.vertices[ia], &bv = m.vertices[ib], &c = m.vertices[ic];
    const Vec3 normal = (bv - a).cross(c - a).normalized();
    const double offset = (2.0 * u(rng) - 1.0) * 0.01 * (b.max - b.min).norm();
    points.push_back(a + x * (bv - a) + y * (c - a) + offset * normal);
  }
  return points;
}

void expectEqualsBruteForce(const Mesh& m, int n, unsigned seed) {
  const auto shape = makeTriangleMesh(m.vertices, m.triangles);
  int inside = 0;
  for (const Vec3& p : queryPoints(m, n, seed)) {
    const bool brute_inside = bruteWinding(m, p) > 0.5;
    ASSERT_EQ(shape->contains(p), brute_inside) << p.transpose();
    const double d = bruteDistance(m, p);
    ASSERT_NEAR(shape->signedDistance(p), brute_inside ? -d : d, 1e-12) << p.transpose();
    inside += brute_inside;
  }
  EXPECT_GT(inside, n / 10);
}

TEST(TriangleMesh, BvhDistanceAndInsideEqualBruteForceOnASphere) {
  expectEqualsBruteForce(icosphere(0.3, 3), 2000, 1);  // 1280 triangles
}

TEST(TriangleMesh, BvhDistanceAndInsideEqualBruteForceOnATorus) {
  expectEqualsBruteForce(torus(0.3, 0.1, 48, 24), 2000, 2);  // 2304 triangles, not convex
}

TEST(TriangleMesh, CrackedMeshStillHasAnInside) {
  // One triangle missing: the winding number is still about 1 inside, away from the crack,
  // and the fast sum agrees with the exact one.
  Mesh m = icosphere(0.3, 2);
  m.triangles.erase(m.triangles.begin() + 17);
  expectEqualsBruteForce(m, 1000, 3);
  const auto shape = makeTriangleMesh(m.vertices, m.triangles);
  EXPECT_TRUE(shape->contains(Vec3::Zero()));
  EXPECT_FALSE(shape->convexMeasures());  // not closed
}

TEST(TriangleMesh, VolumeOrientationAndMeasures) {
  const Mesh sphere = icosphere(0.3, 3);
  // Volume of the polyhedron: a cone from the centre on each face.
  double volume = 0.0, area = 0.0;
  for (const auto& [a, b, c] : sphere.triangles) {
    const Vec3 &va = sphere.vertices[a], &vb = sphere.vertices[b], &vc = sphere.vertices[c];
    volume += va.dot(vb.cross(vc)) / 6.0;
    area += 0.5 * (vb - va).cross(vc - va).norm();
  }
  const auto outward = makeTriangleMesh(sphere.vertices, sphere.triangles);
  EXPECT_NEAR(outward->volume(), volume, 1e-13 * volume);
  EXPECT_NEAR(volume, 4.0 / 3.0 * kPi * 0.027, 0.01 * volume);
  ASSERT_TRUE(outward->convexMeasures());
  EXPECT_NEAR(outward->convexMeasures()->area, area, 1e-14);
  // M of a fine polyhedral sphere is close to the sphere's 4 pi r.
  EXPECT_NEAR(outward->convexMeasures()->mean_curvature, 4.0 * kPi * 0.3, 0.01 * 4.0 * kPi * 0.3);

  // Wound inward: turned over, same shape.
  Mesh inward = sphere;
  for (auto& t : inward.triangles)
    std::swap(t[1], t[2]);
  const auto turned = makeTriangleMesh(inward.vertices, inward.triangles);
  EXPECT_NEAR(turned->volume(), volume, 1e-13 * volume);
  EXPECT_TRUE(turned->contains(Vec3(0.1, 0.1, 0.1)));
  EXPECT_NEAR(turned->signedDistance(Vec3(0.0, 1.0, 0.0)), 0.7, 1e-12);  // a vertex at y = r
  SurfaceSamples s;
  turned->sample(0.02, 0.0, Aabb(), s);
  for (std::size_t i = 0; i < s.size(); ++i)
    ASSERT_GT(s.normal[i].dot(s.position[i]), 0.0);

  const Mesh ring = torus(0.3, 0.1, 24, 12);
  const auto t = makeTriangleMesh(ring.vertices, ring.triangles);
  EXPECT_FALSE(t->convexMeasures());  // concave edges
  EXPECT_FALSE(t->contains(Vec3::Zero()));
  EXPECT_TRUE(t->contains(Vec3(0.3, 0.0, 0.0)));
  // The polyhedron is a little smaller than the torus 2 pi^2 R r^2 (coarse 24 x 12 faces).
  EXPECT_NEAR(t->volume(), 2.0 * kPi * kPi * 0.3 * 0.01, 0.1 * 2.0 * kPi * kPi * 0.3 * 0.01);
}

TEST(TriangleMesh, InvalidInputIsRejected) {
  const Mesh m = icosphere(1.0, 0);
  EXPECT_THROW(makeTriangleMesh(m.vertices, {}), std::invalid_argument);
  EXPECT_THROW(makeTriangleMesh(m.vertices, {{0, 1, 12}}), std::invalid_argument);
  EXPECT_THROW(makeTriangleMesh(m.vertices, {{0, -1, 2}}), std::invalid_argument);
  std::vector<Vec3> bad = m.vertices;
  bad[3].x() = std::nan("");
  EXPECT_THROW(makeTriangleMesh(bad, m.triangles), std::invalid_argument);
}

TEST(TriangleMesh, ManyQueriesOnAFineMeshAreFast) {
  // 5120 triangles, 100k queries of each kind: the BVH makes this about a second or less
  // (brute force would take minutes); printed, not asserted (sanitizer builds are slow).
  const Mesh m = icosphere(0.3, 4);
  const auto shape = makeTriangleMesh(m.vertices, m.triangles);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  std::vector<Vec3> points;
  for (int i = 0; i < 100000; ++i)
    points.emplace_back(u(rng), u(rng), u(rng));
  const auto start = std::chrono::steady_clock::now();
  int inside = 0;
  double sum = 0.0;
  for (const Vec3& p : points) {
    inside += shape->contains(p);
    sum += shape->signedDistance(p);
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cout << "  100k contains + signedDistance on 5120 triangles: " << seconds << " s\n";
  // Inside fraction ~ sphere / cube volume.
  EXPECT_NEAR(inside / 1e5, 4.0 / 3.0 * kPi * 0.027 / 0.512, 0.01);
  EXPECT_TRUE(std::isfinite(sum));
}

}  // namespace
}  // namespace wake
