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

  /// value() of two distances at once: per lane the same operations, so the same bits.
  Lanes2 value(Lanes2 r) const {
    const Lanes2 q = r * Lanes2::all(inv_h_);
    const Lanes2 inner = Lanes2::all(sigma_) * (Lanes2::all(1.0) - Lanes2::all(1.5) * q * q +
                                                Lanes2::all(0.75) * q * q * q);
    const Lanes2 t = Lanes2::all(2.0) - q;
    const Lanes2 outer = Lanes2::all(sigma_) * Lanes2::all(0.25) * t * t * t;
    return select(q < Lanes2::all(1.0), inner,
                  select(q >= Lanes2::all(2.0), Lanes2::all(0.0), outer));
  }

  /// derivativeOverR() of two distances at once (the same bits per lane). r = 0 takes the
  /// inner piece, as in the scalar form.
  Lanes2 derivativeOverR(Lanes2 r) const {
    const Lanes2 q = r * Lanes2::all(inv_h_);
    const Lanes2 inner = Lanes2::all(sigma_) * Lanes2::all(inv_h_) * Lanes2::all(inv_h_) *
                         (Lanes2::all(-3.0) + Lanes2::all(2.25) * q);
    const Lanes2 t = Lanes2::all(2.0) - q;
    const Lanes2 outer = Lanes2::all(-sigma_) * Lanes2::all(0.75) * t * t * Lanes2::all(inv_h_) / r;
    return select(q < Lanes2::all(1.0), inner,
                  select(q >= Lanes2::all(2.0), Lanes2::all(0.0), outer));
  }

  /// grad_a W(x_a - x_b) for x = x_a - x_b (1/m^4).
  Vec3 gradient(const Vec3& x) const { return x * derivativeOverR(x.norm()); }

 private:
  double h_, inv_h_, sigma_;
};

}  // namespace wake
