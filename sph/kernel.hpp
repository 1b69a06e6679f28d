// Cubic spline kernel (Monaghan 1992) in 3D, smoothing length H, support radius 2H.
#pragma once

#include "sph/lanes.hpp"
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
    return outer_value_ * t * t * t;
  }

  /// dW/dr divided by r (1/m^5), so that grad W(x) = x * derivativeOverR(|x|).
  /// Finite at r = 0 (the gradient itself vanishes there).
  double derivativeOverR(double r) const {
    const double q = r * inv_h_;
    if (q >= 2.0) return 0.0;
    if (q < 1.0) return inner_gradient_ * (-3.0 + 2.25 * q);
    if (r <= 0.0) return 0.0;
    const double t = 2.0 - q;
    return outer_gradient_ * t * t * inv_h_ / r;
  }

  /// value() of several distances at once (Lanes2, Lanes4): per lane the same operations,
  /// so the same bits.
  template <class L>
  L value(L r) const {
    const L q = r * L::all(inv_h_);
    const L inner = L::all(sigma_) * (L::all(1.0) - L::all(1.5) * q * q + L::all(0.75) * q * q * q);
    const L t = L::all(2.0) - q;
    const L outer = L::all(outer_value_) * t * t * t;
    return select(q < L::all(1.0), inner, select(q >= L::all(2.0), L::all(0.0), outer));
  }

  /// derivativeOverR() of several distances at once (the same bits per lane). r = 0 takes
  /// the inner piece, as in the scalar form.
  template <class L>
  L derivativeOverR(L r) const {
    const L q = r * L::all(inv_h_);
    const L inner = L::all(inner_gradient_) * (L::all(-3.0) + L::all(2.25) * q);
    const L t = L::all(2.0) - q;
    const L outer = L::all(outer_gradient_) * t * t * L::all(inv_h_) / r;
    return select(q < L::all(1.0), inner, select(q >= L::all(2.0), L::all(0.0), outer));
  }

  /// grad_a W(x_a - x_b) for x = x_a - x_b (1/m^4).
  Vec3 gradient(const Vec3& x) const { return x * derivativeOverR(x.norm()); }

 private:
  double h_, inv_h_, sigma_;
  double outer_value_;     ///< 0.25 sigma
  double inner_gradient_;  ///< sigma / H^2 (as sigma * (1 / H) * (1 / H))
  double outer_gradient_;  ///< -0.75 sigma
};

}  // namespace wake
