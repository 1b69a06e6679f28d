// Small helpers shared by the geometry tests.
#pragma once

#include "geometry/shape.hpp"

namespace wake::test {

inline constexpr double kPi = 3.14159265358979323846;

/// Total surface area of a sampling (m^2).
inline double totalArea(const SurfaceSamples& s) {
  double sum = 0.0;
  for (double a : s.area)
    sum += a;
  return sum;
}

/// Central-difference gradient of the signed distance, not normalised: an independent
/// check of shapes' distances (|grad| = 1) and normals.
inline Vec3 rawGradient(const Shape& shape, const Vec3& p, double step) {
  Vec3 g;
  for (int a = 0; a < 3; ++a) {
    const Vec3 d = step * Vec3::Unit(a);
    g[a] = (shape.signedDistance(p + d) - shape.signedDistance(p - d)) / (2.0 * step);
  }
  return g;
}

}  // namespace wake::test
