// A Bullet world built from a scene's bodies (bullet_bridge/body_spec.hpp), coupled with
// the scene's fluid: what `wake run` plays. Owns every Bullet object it creates.
#pragma once

#include "bullet_bridge/body_spec.hpp"
#include "bullet_bridge/coupled_world.hpp"

#include <memory>
#include <vector>

namespace wake {

/// Mass properties Wake gives a scene body in Bullet.
struct BodyMass {
  double mass = 0;              ///< kg (0: static or kinematic)
  Vec3 inertia = Vec3::Zero();  ///< kg m^2, principal moments
  Pose com;                     ///< centre-of-mass frame in the shape's frame
};

class SceneWorld {
 public:
  /// `sim` gives gravity, fluid, blocks, method, cfl, max_dt and domain (its `bodies`
  /// must be empty: the bodies are `bodies`). Throws std::invalid_argument naming the
  /// field ("bodies[2].shape.margin: ...") when a body cannot be built.
  SceneWorld(const SimulationSettings& sim, const std::vector<BodySpec>& bodies);
  ~SceneWorld();

  CoupledWorld& coupled() { return *coupled_; }
  const Simulation& simulation() const { return coupled_->simulation(); }
  /// Mass properties of body k as built (kg, kg m^2, centre of mass).
  const BodyMass& bodyMass(std::size_t k) const { return masses_[k]; }

 private:
  struct BulletParts;
  std::unique_ptr<BulletParts> bullet_;
  std::unique_ptr<CoupledWorld> coupled_;
  std::vector<BodyMass> masses_;
};

}  // namespace wake
