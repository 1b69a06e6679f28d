// Scene-level description of rigid bodies (plain data, no Bullet types): what a scene file
// says about a body and its shape. bullet_bridge/ turns it into btCollisionShape +
// btRigidBody; io/ fills it from JSON (io/SCENE_FORMAT.md).
#pragma once

#include "coupling/rigid_body.hpp"

#include <string>
#include <vector>

namespace wake {

struct ShapeChild;

/// One collision shape. `type` picks which fields are used (all lengths in m):
///   box {half_extents}, sphere {radius}, capsule {radius, height: between the two sphere
///   centres, along y}, cylinder {radius, height, along y}, cone {radius, height, along y,
///   apex up}, convex_hull {points}, plane {normal, offset}, tank {min, max,
///   wall_thickness}, mesh {file, scale}, compound {children}.
struct ShapeSpec {
  std::string type;
  Vec3 half_extents = Vec3::Zero();
  double radius = 0.0;
  double height = 0.0;
  std::vector<Vec3> points;     ///< convex_hull vertices, body space
  Vec3 normal = Vec3::UnitY();  ///< plane: solid is {x : normal . x < offset}
  double offset = 0.0;
  Vec3 min = Vec3::Zero(), max = Vec3::Zero();  ///< tank cavity
  double wall_thickness = 0.0;                  ///< tank; 0 = automatic (4 particle radii)
  std::string file;                             ///< mesh: absolute path of the OBJ file
  Vec3 scale = Vec3::Ones();                    ///< mesh
  std::vector<ShapeChild> children;             ///< compound
  /// Bullet collision margin (m); < 0 = automatic (the fluid's particle radius). Bullet
  /// collides convex shapes (cylinder, cone, convex hull) on their surface grown or rounded
  /// by the margin; the fluid is sampled on that same surface.
  double margin = -1.0;
};

struct ShapeChild {
  ShapeSpec shape;
  Pose pose;  ///< child -> parent
};

/// One rigid body of a scene: how it meets the fluid (name, slip, restitution, coupling:
/// BodyFluidSettings), its kind, shape, start state, mass and Bullet friction.
struct BodySpec : BodyFluidSettings {
  BodyKind kind = BodyKind::Static;
  ShapeSpec shape;
  /// Pose of the shape's frame (the frame its fields are given in). For a compound the
  /// centre of mass may differ from this origin; the body's reported position is always
  /// its centre of mass.
  Pose pose;
  Vec3 linear_velocity = Vec3::Zero();   ///< m/s
  Vec3 angular_velocity = Vec3::Zero();  ///< rad/s
  double mass = 0.0;                     ///< kg; dynamic bodies give mass or density (> 0)
  double density = 0.0;                  ///< kg/m^3
  double friction = 0.5;                 ///< Bullet's body-body friction coefficient, >= 0
};

}  // namespace wake
