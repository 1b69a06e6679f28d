// Exact rigid shapes and their surface sampling with boundary particles (DESIGN.md §3).
//
// A Shape lives in body space. It answers exact geometric questions (inside? how far
// from the surface?) which Wake uses to remove fluid placed inside a body and to measure
// penetration against the true surface, never against its sampling; and it samples its
// surface with boundary particles: each sample sits `radius` below the surface along the
// outward normal, so that sample + radius * normal is a point of the exact surface.
#pragma once

#include "sph/types.hpp"

#include <memory>
#include <string>
#include <vector>

namespace wake {

/// Boundary particles of one body, in body space.
struct SurfaceSamples {
  std::vector<Vec3> position;  ///< (n) m, sample centres, `radius` below the surface
  std::vector<Vec3> normal;    ///< (n) unit outward normals of the exact surface
  std::vector<double> area;    ///< (n) m^2, surface area each sample stands for

  std::size_t size() const { return position.size(); }
  void clear() {
    position.clear();
    normal.clear();
    area.clear();
  }
};

class Shape {
 public:
  virtual ~Shape() = default;

  /// Short type name as in the scene file ("box", "tank", ...).
  virtual const char* typeName() const = 0;

  /// Signed distance to the exact surface in body space (m): < 0 inside the solid.
  virtual double signedDistance(const Vec3& p) const = 0;

  /// True when p lies strictly inside the solid (signedDistance(p) < 0).
  virtual bool contains(const Vec3& p) const { return signedDistance(p) < 0.0; }

  /// Bounds of the solid in body space; infinite shapes (plane) return the
  /// part inside `clip` (a world/body-space box the caller cares about).
  virtual Aabb bounds(const Aabb& clip) const = 0;

  /// Appends boundary particles covering the whole surface (inside `clip` for
  /// infinite shapes), at about `spacing` apart, each `radius` below the surface.
  virtual void sample(double spacing, double radius, const Aabb& clip,
                      SurfaceSamples& out) const = 0;
};

/// Solid box centred at the origin.  half_extents > 0 (m).
std::unique_ptr<Shape> makeBox(const Vec3& half_extents);
/// Solid sphere centred at the origin.  radius > 0 (m).
std::unique_ptr<Shape> makeSphere(double radius);
/// Half space {p : normal . p < offset} is solid; normal is normalised here.
std::unique_ptr<Shape> makePlane(const Vec3& normal, double offset);
/// Open-top container: the cavity [min, max] holds the fluid; floor and four walls of
/// `wall_thickness` (m) surround it; the cavity is open above max.y. "Up" is +y.
std::unique_ptr<Shape> makeTank(const Vec3& min, const Vec3& max, double wall_thickness);
/// Closed triangle mesh read from an OBJ file, vertices multiplied by `scale`.
/// Throws std::runtime_error naming the file when it cannot be read or has no triangles.
std::unique_ptr<Shape> makeMesh(const std::string& obj_path, const Vec3& scale);

}  // namespace wake
