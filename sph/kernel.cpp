#include "sph/kernel.hpp"

#include <cmath>
#include <stdexcept>

namespace wake {

CubicSplineKernel::CubicSplineKernel(double smoothing_length)
    : h_(smoothing_length), inv_h_(1.0 / smoothing_length) {
  if (!(smoothing_length > 0.0) || !std::isfinite(smoothing_length))
    throw std::invalid_argument("kernel smoothing length must be finite and > 0");
  sigma_ = 1.0 / (M_PI * h_ * h_ * h_);
  outer_value_ = sigma_ * 0.25;
  inner_gradient_ = sigma_ * inv_h_ * inv_h_;
  outer_gradient_ = -sigma_ * 0.75;
}

}  // namespace wake
