// Exact rigid shapes and their surface sampling with boundary particles (DESIGN.md §3).
//
// A Shape lives in body space. It answers exact geometric questions (inside? how far
// from the surface?) which Wake uses to remove fluid placed inside a body and to measure
// penetration against the true surface, never against its sampling; and it samples its
// surface with boundary particles: each sample sits `radius` below the surface along the
// outward normal, so that sample + radius * normal is a point of the exact surface.
#pragma once

#include "sph/types.hpp"

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
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

/// A triangle mesh of a shape's surface (body space): triangles counter-clockwise seen from
/// outside (the solid's side is behind each triangle's front).
struct SurfaceMesh {
  std::vector<Vec3> vertices;                           ///< m
  std::vector<std::array<std::uint32_t, 3>> triangles;  ///< indices into vertices

  void addTriangle(const Vec3& a, const Vec3& b, const Vec3& c);
  /// Two triangles (a, b, c), (a, c, d) of the quad a b c d (counter-clockwise).
  void addQuad(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);
  /// Appends `other` with its vertices placed by `pose`.
  void append(const SurfaceMesh& other, const Pose& pose);
};

/// Steiner data of a convex body K: for r >= 0 the body K grown by a ball of radius r
/// (Minkowski sum) has volume V + area r + mean_curvature r^2 + 4/3 pi r^3 and surface area
/// area + 2 mean_curvature r + 4 pi r^2 (V = K's volume()).
struct ConvexMeasures {
  double area = 0.0;            ///< m^2, surface area of K
  double mean_curvature = 0.0;  ///< m, integral of the mean curvature over K's surface; for a
                                ///< polyhedron 1/2 sum over edges of length x exterior angle
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

  /// Volume of the solid (m^3); +infinity for unbounded shapes (plane).
  virtual double volume() const = 0;

  /// Steiner data for convex shapes that know it exactly (used by makeRounded for an exact
  /// volume and area); std::nullopt (the default) for non-convex shapes or when unknown.
  virtual std::optional<ConvexMeasures> convexMeasures() const { return std::nullopt; }

  /// Appends the exact surface as triangles (for infinite shapes, the part covering
  /// `clip`) and returns true; returns false, appending nothing, for curved shapes, which
  /// only a tessellation approximates (surface/shape_mesh.hpp meshes those from the signed
  /// distance). Exact: box, plane, tank, mesh, compounds of these.
  virtual bool triangulate(const Aabb& clip, SurfaceMesh& out) const {
    (void)clip;
    (void)out;
    return false;
  }
};

/// Throws std::invalid_argument unless `spacing` is finite and > 0 and `radius` finite and
/// >= 0: the checks of every Shape::sample.
void checkSampling(double spacing, double radius);

/// Unit gradient of shape's signed distance at p by central differences of step `step`
/// (m); the zero vector where it vanishes (on a medial point).
Vec3 sdfGradient(const Shape& shape, const Vec3& p, double step);

/// Solid box centred at the origin.  half_extents > 0 (m).
std::unique_ptr<Shape> makeBox(const Vec3& half_extents);
/// Solid sphere centred at the origin.  radius > 0 (m).
std::unique_ptr<Shape> makeSphere(double radius);
/// Half space {p : normal . p < offset} is solid; normal is normalised here.
std::unique_ptr<Shape> makePlane(const Vec3& normal, double offset);
/// Open-top container: the cavity [min, max] holds the fluid; floor and four walls of
/// `wall_thickness` (m) surround it; the cavity is open above max.y. "Up" is +y.
std::unique_ptr<Shape> makeTank(const Vec3& min, const Vec3& max, double wall_thickness);
/// Closed triangle mesh read from an OBJ file, vertices multiplied by `scale` (see
/// makeTriangleMesh).  Throws std::runtime_error naming the file when it cannot be read or
/// has no triangles.
std::unique_ptr<Shape> makeMesh(const std::string& obj_path, const Vec3& scale);

/// Closed triangle mesh from memory: vertices (m) and triangles (indices into vertices).
/// Triangles are taken as counter-clockwise seen from outside; when the enclosed signed
/// volume is negative every triangle is turned over.  Inside/outside is the generalized
/// winding number > 1/2 (robust to small cracks), the distance the exact distance to the
/// nearest triangle; both use a bounding volume hierarchy over the triangles (the winding
/// number with far-field dipoles, exact near the query point and whenever the result is
/// close to 1/2).  Volume by the divergence theorem.  Throws std::invalid_argument on
/// non-finite vertices, bad indices or no triangles.
std::unique_ptr<Shape> makeTriangleMesh(std::vector<Vec3> vertices,
                                        std::vector<std::array<int, 3>> triangles);

// --- shapes of the Bullet bridge (Bullet's conventions: y is the long axis) --------------

/// Capsule: the segment (0, -half_height, 0) - (0, half_height, 0) swept by a sphere of
/// `radius` (Bullet's btCapsuleShape(radius, 2 half_height)).  radius > 0, half_height >= 0.
std::unique_ptr<Shape> makeCapsule(double radius, double half_height);

/// Cylinder along y, |y| <= half_height, distance to the axis <= radius, with its two rim
/// edges rounded with radius `rounding`: the cylinder (radius - rounding, half_height -
/// rounding) grown by a sphere of `rounding` (what Bullet's btCylinderShape collides with:
/// its margin rounds the edges, the dimensions stay).  0 <= rounding < min(radius,
/// half_height); rounding = 0 is a sharp cylinder.
std::unique_ptr<Shape> makeCylinder(double radius, double half_height, double rounding);

/// Bullet's btConeShape grown by its margin: the cone with apex (0, height/2, 0) and base
/// disc of `radius` at y = -height/2, Minkowski sum with a sphere of radius `margin`.
/// radius > 0, height > 0, margin >= 0.  Volume and area are exact (Steiner's formula).
/// Capsules, cylinders and cones are sampled ring by ring along their profile (exact
/// surface points, normals and areas; see shapes_convex.cpp).
std::unique_ptr<Shape> makeCone(double radius, double height, double margin);

/// A convex shape grown by a sphere of radius `margin` >= 0 (Minkowski sum; Bullet's
/// btConvexHullShape is makeRounded(makeTriangleMesh(hull), margin)).  The signed distance
/// is convex->signedDistance(p) - margin, exact because `convex` must be convex (not
/// checked) and bounded.  Volume and area are exact by Steiner's formula when
/// convex->convexMeasures() is known (box, sphere, capsule, cylinder, cone, convex closed
/// mesh, rounded), otherwise the volume is a grid estimate (relative error ~1e-3).  Sampled
/// by sampleSurfaceBySdf.
std::unique_ptr<Shape> makeRounded(std::shared_ptr<const Shape> convex, double margin);

/// One part of a compound: `shape` placed by `pose` (child frame -> compound frame).
struct CompoundChild {
  std::shared_ptr<const Shape> shape;
  Pose pose;
};

/// Union of the children.  Signed distance = min over the children (exact outside the
/// solid; inside, the usual union approximation: its sign is exact).  Samples are the
/// children's samples placed by their poses, less those whose surface point is inside
/// another child or on a face shared with a touching child.  Volume: sum of the children
/// when their bounding boxes do not overlap, otherwise the sum less a grid estimate of the
/// overlaps (see shapes_composite.cpp).  Throws std::invalid_argument on no children, a
/// null shape or a non-finite pose.
std::unique_ptr<Shape> makeCompound(std::vector<CompoundChild> children);

/// Generic sampler for a closed, bounded surface known only by its signed distance (used by
/// makeRounded; works for any shape whose signed distance is exact near its surface).
/// Appends samples `radius` below the surface, about 1.1 per spacing^2 of surface and nearly
/// uniform: surface points are found where lattice lines (step spacing/6) cross the
/// surface, each weighted by the area it stands for; a deterministic Poisson-disc thinning
/// seeds the samples and weighted Lloyd iterations on the surface even them out; each
/// sample gets the area of its cluster (the areas add up to the surface area within ~1 %).
/// Every surface point ends within ~0.75 spacing of a sample, no two samples closer than
/// ~0.6 spacing (except across walls thinner than that).  Deterministic.  Normals are the
/// normalised central-difference gradient of the signed distance.  Features thinner than
/// about spacing/12 may be missed.  Throws std::invalid_argument for an unbounded shape.
void sampleSurfaceBySdf(const Shape& shape, double spacing, double radius, SurfaceSamples& out);

}  // namespace wake
