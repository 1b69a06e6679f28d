// The front of the fluid on a slip ramp (scenes/slip_ramp.json): one definition for
// the scene test (tests/scenes) and the plot's tool (demos/slip_fronts.cpp).
#pragma once

#include "sph/types.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace wake {

/// The front on a ramp: the 90th percentile of the downhill coordinate (the ramp's own x,
/// m) of the fluid centres in its lane (within 6 cm of the ramp's centre z: lanes are
/// 12 cm wide) and on it (0 to 8 cm above its centre plane, within its 1 m length). A
/// percentile, so that one stray particle is not the front. 0 when none is on the ramp;
/// `on_ramp` (optional) receives their number.
inline double slipFront(const std::vector<Vec3>& position, const Pose& ramp,
                        std::size_t* on_ramp = nullptr) {
  std::vector<double> downhill;
  for (const Vec3& x : position) {
    if (std::abs(x.z() - ramp.position.z()) > 0.06) continue;
    const Vec3 p = ramp.toBody(x);
    if (p.y() > 0.0 && p.y() < 0.08 && std::abs(p.x()) < 0.5) downhill.push_back(p.x());
  }
  if (on_ramp) *on_ramp = downhill.size();
  if (downhill.empty()) return 0.0;
  std::sort(downhill.begin(), downhill.end());
  return downhill[downhill.size() * 9 / 10];
}

}  // namespace wake
