// Cubic spline kernel: normalisation, gradient antisymmetry and consistency, compact support.
#include "sph/kernel.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using wake::CubicSplineKernel;
using wake::Vec3;

TEST(Kernel, IntegratesToOne) {
  for (double h : {0.01, 0.02, 1.0}) {
    CubicSplineKernel k(h);
    // Midpoint rule over a cube covering the support.
    const int n = 80;
    const double d = 2.0 * k.supportRadius() / n;
    double sum = 0.0;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        for (int l = 0; l < n; ++l) {
          const Vec3 x = Vec3(i + 0.5, j + 0.5, l + 0.5) * d - Vec3::Constant(k.supportRadius());
          sum += k.value(x.norm());
        }
    EXPECT_NEAR(sum * d * d * d, 1.0, 2e-3) << "h = " << h;
  }
}

TEST(Kernel, LatticeSumIsNearOneOverCellVolume) {
  // At H = spacing the lattice sum approximates the integral: the basis of rest density.
  const double s = 0.02;
  CubicSplineKernel k(s);
  double sum = 0.0;
  for (int i = -3; i <= 3; ++i)
    for (int j = -3; j <= 3; ++j)
      for (int l = -3; l <= 3; ++l)
        sum += k.value(s * std::sqrt(double(i * i + j * j + l * l)));
  EXPECT_NEAR(sum * s * s * s, 1.0, 0.01);
}

TEST(Kernel, CompactSupport) {
  CubicSplineKernel k(0.5);
  EXPECT_GT(k.value(0.999), 0.0);
  EXPECT_EQ(k.value(1.0), 0.0);
  EXPECT_EQ(k.value(1.7), 0.0);
  EXPECT_EQ(k.gradient(Vec3(1.0, 0, 0)).norm(), 0.0);
  EXPECT_EQ(k.gradient(Vec3(0.8, 0.9, 0)).norm(), 0.0);
  EXPECT_GT(k.gradient(Vec3(0.6, 0.3, 0.1)).norm(), 0.0);
}

TEST(Kernel, GradientIsAntisymmetricAndMatchesFiniteDifferences) {
  CubicSplineKernel k(0.1);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.2, 0.2);
  for (int t = 0; t < 200; ++t) {
    const Vec3 x(u(rng), u(rng), u(rng));
    EXPECT_EQ(k.gradient(x), -k.gradient(-x));
    const double e = 1e-7;
    for (int a = 0; a < 3; ++a) {
      Vec3 dx = Vec3::Zero();
      dx[a] = e;
      const double fd = (k.value((x + dx).norm()) - k.value((x - dx).norm())) / (2 * e);
      EXPECT_NEAR(k.gradient(x)[a], fd, 1e-4 * (1.0 + std::abs(fd)));
    }
  }
  EXPECT_EQ(k.gradient(Vec3::Zero()).norm(), 0.0);
}

TEST(Kernel, GradientsSumToZeroInALattice) {
  // sum_b grad W_ab = 0 for a particle inside a symmetric lattice.
  const double s = 0.01;
  CubicSplineKernel k(s);
  Vec3 sum = Vec3::Zero();
  for (int i = -3; i <= 3; ++i)
    for (int j = -3; j <= 3; ++j)
      for (int l = -3; l <= 3; ++l)
        sum += k.gradient(s * Vec3(i, j, l));
  EXPECT_LT(sum.norm(), 1e-9 * k.gradient(Vec3(s, 0, 0)).norm());
}
