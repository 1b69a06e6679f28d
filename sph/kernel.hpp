// Cubic spline kernel (Monaghan 1992) in 3D, smoothing length H, support radius 2H.
#pragma once

#include "sph/types.hpp"

namespace wake {

class CubicSplineKernel {
 public:
  /// smoothing_length: H (m), > 0. The kernel vanishes for r >= 2H.
  explicit CubicSplineKernel(double smoothing_length);

  double smoothingLength() const { return h_; }
  double supportRadius() const { return 2.0 * h_; }

  /// W(r) (1/m^3).
  double value(double r) const {
    const double q = r * inv_h_;
    if (q >= 2.0) return 0.0;
    if (q < 1.0) return sigma_ * (1.0 - 1.5 * q * q + 0.75 * q * q * q);
    const double t = 2.0 - q;
    return sigma_ * 0.25 * t * t * t;
  }

  /// dW/dr divided by r (1/m^5), so that grad W(x) = x * derivativeOverR(|x|).
  /// Finite at r = 0 (the gradient itself vanishes there).
  double derivativeOverR(double r) const {
    const double q = r * inv_h_;
    if (q >= 2.0) return 0.0;
    if (q < 1.0) return sigma_ * inv_h_ * inv_h_ * (-3.0 + 2.25 * q);
    if (r <= 0.0) return 0.0;
    const double t = 2.0 - q;
    return -sigma_ * 0.75 * t * t * inv_h_ / r;
  }

  /// grad_a W(x_a - x_b) for x = x_a - x_b (1/m^4).
  Vec3 gradient(const Vec3& x) const { return x * derivativeOverR(x.norm()); }

 private:
  double h_, inv_h_, sigma_;
};

}  // namespace wake
