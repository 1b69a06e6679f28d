// The fluid's health, checked after every step (STYLE.md, practice 10): a non-finite
// position or velocity, or a density far above rest density, means the step has become
// unstable. The check names the first such particle; what to do about it (stop the run,
// say what to change) is the caller's.
#pragma once

#include "sph/types.hpp"

#include <cstddef>
#include <string>

namespace wake {

struct FluidState;

/// What one health check found.
struct FluidHealth {
  enum class Problem { None, NonFinitePosition, NonFiniteVelocity, DensityRatio };
  double max_density_ratio = 0.0;  ///< largest density / rest density (NaN: a NaN density)
  Problem problem = Problem::None;
  /// The particle named when problem != None (a slot of the state): the lowest slot with a
  /// non-finite position or velocity, else the densest particle.
  std::size_t slot = 0;

  bool ok() const { return problem == Problem::None; }
};

/// Checks every particle: finite position and velocity, density <= density_limit *
/// rest_density (a NaN density fails it too). Parallel; the result does not depend on the
/// number of threads.
FluidHealth checkFluidHealth(const FluidState& state, double rest_density, double density_limit);

/// "a non-finite velocity", "a density of 5.01 x rest density", ... for messages.
std::string describeProblem(const FluidHealth& health, const FluidState& state,
                            double rest_density);

}  // namespace wake
