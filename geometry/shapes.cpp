// Analytic shapes: box, sphere, half space (plane) and open-top tank (DESIGN.md §3).
//
// Every distance and position here is in metres, in body space; areas in m^2.
#include "geometry/shape.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

namespace wake {

namespace {

constexpr double kPi = 3.14159265358979323846;

bool isFinite(const Vec3& v) {
  return v.allFinite();
}

std::string str(const Vec3& v) {
  return "(" + std::to_string(v.x()) + ", " + std::to_string(v.y()) + ", " + std::to_string(v.z()) +
         ")";
}

/// Exact signed distance (m) to the box [lo, hi]; an infinite bound opens that side.
double boxSignedDistance(const Vec3& p, const Vec3& lo, const Vec3& hi) {
  // Per axis: > 0 outside the slab, < 0 inside it (depth to the nearer side).
  const Vec3 q = (lo - p).cwiseMax(p - hi);
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

/// Number of cells (>= 1) of about `spacing` (m) along a length (m).
int cellCount(double length, double spacing) {
  return std::max(1, static_cast<int>(std::lround(length / spacing)));
}

/// The flat rectangle {corner + a u + b v : a in [0, len_u], b in [0, len_v]} (u, v unit
/// and orthogonal, lengths in m) with outward unit normal `normal`: a face of a box, a tank
/// or a clipped plane.
struct Rectangle {
  Vec3 corner, u;
  double len_u;
  Vec3 v;
  double len_v;
  Vec3 normal;
};

/// Samples a rectangle: one sample per cell centre of an nu x nv grid of about `spacing`,
/// placed `radius` below the surface.
void sampleRectangle(const Rectangle& r, double spacing, double radius, SurfaceSamples& out) {
  if (!(r.len_u > 0.0) || !(r.len_v > 0.0)) return;
  const int nu = cellCount(r.len_u, spacing);
  const int nv = cellCount(r.len_v, spacing);
  const double du = r.len_u / nu;  // m, cell size along u
  const double dv = r.len_v / nv;  // m, cell size along v
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      const Vec3 surface_point = r.corner + ((i + 0.5) * du) * r.u + ((j + 0.5) * dv) * r.v;
      out.position.push_back(surface_point - radius * r.normal);
      out.normal.push_back(r.normal);
      out.area.push_back(du * dv);
    }
  }
}

/// Appends a rectangle as two triangles, counter-clockwise seen from its normal's side.
void meshRectangle(const Rectangle& r, SurfaceMesh& out) {
  if (!(r.len_u > 0.0) || !(r.len_v > 0.0)) return;
  Vec3 a = r.len_u * r.u, b = r.len_v * r.v;
  if (a.cross(b).dot(r.normal) < 0.0) std::swap(a, b);
  out.addQuad(r.corner, r.corner + a, r.corner + a + b, r.corner + b);
}

/// The face of the box [lo, hi] whose outward normal is `sign` * e_axis.
Rectangle boxFace(const Vec3& lo, const Vec3& hi, int axis, double sign) {
  const int a = (axis + 1) % 3;
  const int b = (axis + 2) % 3;
  Vec3 corner = lo;
  corner[axis] = sign > 0.0 ? hi[axis] : lo[axis];
  return Rectangle{corner,        Vec3::Unit(a), hi[a] - lo[a],
                   Vec3::Unit(b), hi[b] - lo[b], sign * Vec3::Unit(axis)};
}

/// All six faces of the box [lo, hi] (outward normals).
std::vector<Rectangle> boxFaces(const Vec3& lo, const Vec3& hi) {
  std::vector<Rectangle> faces;
  for (int axis = 0; axis < 3; ++axis) {
    faces.push_back(boxFace(lo, hi, axis, -1.0));
    faces.push_back(boxFace(lo, hi, axis, +1.0));
  }
  return faces;
}

void sampleRectangles(const std::vector<Rectangle>& faces, double spacing, double radius,
                      SurfaceSamples& out) {
  for (const Rectangle& r : faces)
    sampleRectangle(r, spacing, radius, out);
}

void meshRectangles(const std::vector<Rectangle>& faces, SurfaceMesh& out) {
  for (const Rectangle& r : faces)
    meshRectangle(r, out);
}

// ---------------------------------------------------------------------------------------

class BoxShape final : public Shape {
 public:
  explicit BoxShape(const Vec3& half_extents) : half_(half_extents) {}

  const char* typeName() const override { return "box"; }

  double signedDistance(const Vec3& p) const override {
    return boxSignedDistance(p, -half_, half_);
  }

  Aabb bounds(const Aabb&) const override { return Aabb{-half_, half_}; }

  void sample(double spacing, double radius, const Aabb&, SurfaceSamples& out) const override {
    checkSampling(spacing, radius);
    sampleRectangles(boxFaces(-half_, half_), spacing, radius, out);
  }

  bool triangulate(const Aabb&, SurfaceMesh& out) const override {
    meshRectangles(boxFaces(-half_, half_), out);
    return true;
  }

  double volume() const override { return 8.0 * half_.prod(); }

  /// Faces 8 (ab + bc + ca); 12 edges of exterior angle pi/2: M = 2 pi (a + b + c).
  std::optional<ConvexMeasures> convexMeasures() const override {
    const double a = half_.x(), b = half_.y(), c = half_.z();
    return ConvexMeasures{8.0 * (a * b + b * c + c * a), 2.0 * kPi * (a + b + c)};
  }

 private:
  Vec3 half_;  ///< m, half extents, > 0
};

class SphereShape final : public Shape {
 public:
  explicit SphereShape(double radius) : radius_(radius) {}

  const char* typeName() const override { return "sphere"; }

  double signedDistance(const Vec3& p) const override { return p.norm() - radius_; }

  Aabb bounds(const Aabb&) const override {
    return Aabb{Vec3::Constant(-radius_), Vec3::Constant(radius_)};
  }

  /// Fibonacci sphere: N nearly uniform directions, each standing for 4 pi R^2 / N.
  void sample(double spacing, double radius, const Aabb&, SurfaceSamples& out) const override {
    checkSampling(spacing, radius);
    const double total_area = 4.0 * kPi * radius_ * radius_;  // m^2
    const long n = std::max(1L, std::lround(total_area / (spacing * spacing)));
    const double golden_angle = kPi * (3.0 - std::sqrt(5.0));  // rad
    for (long i = 0; i < n; ++i) {
      const double y = 1.0 - 2.0 * (static_cast<double>(i) + 0.5) / static_cast<double>(n);
      const double ring = std::sqrt(std::max(0.0, 1.0 - y * y));
      const double phi = golden_angle * static_cast<double>(i);
      const Vec3 normal(ring * std::cos(phi), y, ring * std::sin(phi));
      out.position.push_back((radius_ - radius) * normal);
      out.normal.push_back(normal);
      out.area.push_back(total_area / static_cast<double>(n));
    }
  }

  double volume() const override { return 4.0 / 3.0 * kPi * radius_ * radius_ * radius_; }

  std::optional<ConvexMeasures> convexMeasures() const override {
    return ConvexMeasures{4.0 * kPi * radius_ * radius_, 4.0 * kPi * radius_};
  }

 private:
  double radius_;  ///< m, > 0
};

class PlaneShape final : public Shape {
 public:
  PlaneShape(const Vec3& normal, double offset) : normal_(normal.normalized()), offset_(offset) {
    // Tangent basis: cross with the axis least aligned with the normal, so that an
    // axis-aligned plane gets axis-aligned tangents.
    Eigen::Index least = 0;
    normal_.cwiseAbs().minCoeff(&least);
    tangent_u_ = normal_.cross(Vec3::Unit(least)).normalized();
    tangent_v_ = normal_.cross(tangent_u_);
  }

  const char* typeName() const override { return "plane"; }

  double signedDistance(const Vec3& p) const override { return normal_.dot(p) - offset_; }

  /// The half space is unbounded: the caller's box is a valid (if loose) bound.
  Aabb bounds(const Aabb& clip) const override { return clip; }

  /// Samples the rectangle of the plane covering the orthogonal projection of `clip`.
  void sample(double spacing, double radius, const Aabb& clip, SurfaceSamples& out) const override {
    checkSampling(spacing, radius);
    if (const auto r = rectangle(clip)) sampleRectangle(*r, spacing, radius, out);
  }

  /// The same rectangle as two triangles.
  bool triangulate(const Aabb& clip, SurfaceMesh& out) const override {
    if (const auto r = rectangle(clip)) meshRectangle(*r, out);
    return true;
  }

  double volume() const override { return std::numeric_limits<double>::infinity(); }

 private:
  Vec3 normal_;     ///< unit outward normal (points out of the solid)
  double offset_;   ///< m, solid is normal . p < offset
  Vec3 tangent_u_;  ///< unit, orthogonal to normal_
  Vec3 tangent_v_;  ///< unit, normal_ x tangent_u_

  /// The rectangle of the plane covering the orthogonal projection of `clip` (none for an
  /// empty or infinite clip).
  std::optional<Rectangle> rectangle(const Aabb& clip) const {
    if (clip.empty() || !isFinite(clip.min) || !isFinite(clip.max)) return std::nullopt;
    const Vec3 origin = offset_ * normal_;  // m, foot of the plane from the body origin
    double u_lo = std::numeric_limits<double>::infinity(), u_hi = -u_lo;
    double v_lo = u_lo, v_hi = -u_lo;
    for (int c = 0; c < 8; ++c) {
      const Vec3 corner((c & 1) ? clip.max.x() : clip.min.x(),
                        (c & 2) ? clip.max.y() : clip.min.y(),
                        (c & 4) ? clip.max.z() : clip.min.z());
      const double u = tangent_u_.dot(corner - origin);
      const double v = tangent_v_.dot(corner - origin);
      u_lo = std::min(u_lo, u);
      u_hi = std::max(u_hi, u);
      v_lo = std::min(v_lo, v);
      v_hi = std::max(v_hi, v);
    }
    return Rectangle{origin + u_lo * tangent_u_ + v_lo * tangent_v_,
                     tangent_u_,
                     u_hi - u_lo,
                     tangent_v_,
                     v_hi - v_lo,
                     normal_};
  }
};

/// Open-top tank.  The solid is the outer box
///   [min.x - t, max.x + t] x [min.y - t, max.y] x [min.z - t, max.z + t]
/// minus the open cavity C = [min.x, max.x] x [min.y, +inf) x [min.z, max.z].
///
/// Its signed distance is exact everywhere:
/// - outside C: max(sd_outer, -sd_C).  Inside the solid, the complement of the solid is
///   (outside outer) U C, whose distance is min(-sd_outer, sd_C).  Outside both the outer box
///   and C, the point of the outer box nearest to p is never in C's interior, so sd_outer is
///   the exact distance.
/// - inside C (fluid side, sd >= 0): the nearer of the floor (straight down) and the walls;
///   above the rim the nearest wall point is the rim's inner edge.
class TankShape final : public Shape {
 public:
  TankShape(const Vec3& min, const Vec3& max, double wall_thickness)
      : min_(min), max_(max), t_(wall_thickness) {
    outer_min_ = min_ - Vec3(t_, t_, t_);
    outer_max_ = max_ + Vec3(t_, 0.0, t_);
    cavity_max_ = Vec3(max_.x(), std::numeric_limits<double>::infinity(), max_.z());
  }

  const char* typeName() const override { return "tank"; }

  double signedDistance(const Vec3& p) const override {
    const bool in_cavity = p.x() >= min_.x() && p.x() <= max_.x() && p.z() >= min_.z() &&
                           p.z() <= max_.z() && p.y() >= min_.y();
    if (!in_cavity) {
      return std::max(boxSignedDistance(p, outer_min_, outer_max_),
                      -boxSignedDistance(p, min_, cavity_max_));
    }
    const double to_floor = p.y() - min_.y();
    const double to_wall_plane =
        std::min({p.x() - min_.x(), max_.x() - p.x(), p.z() - min_.z(), max_.z() - p.z()});
    const double above_rim = std::max(0.0, p.y() - max_.y());
    // hypot(a, 0) is a exactly: below the rim (where the fluid is) no hypot call.
    return std::min(to_floor,
                    above_rim > 0.0 ? std::hypot(to_wall_plane, above_rim) : to_wall_plane);
  }

  Aabb bounds(const Aabb&) const override { return Aabb{outer_min_, outer_max_}; }

  void sample(double spacing, double radius, const Aabb&, SurfaceSamples& out) const override {
    checkSampling(spacing, radius);
    sampleRectangles(faces(), spacing, radius, out);
  }

  bool triangulate(const Aabb&, SurfaceMesh& out) const override {
    meshRectangles(faces(), out);
    return true;
  }

  /// Walls and floor: the outer box less the cavity below the rim.
  double volume() const override { return (outer_max_ - outer_min_).prod() - (max_ - min_).prod(); }

 private:
  Vec3 min_, max_;  ///< m, cavity corners
  double t_;        ///< m, wall and floor thickness, > 0
  Vec3 outer_min_;  ///< m, outer box corners
  Vec3 outer_max_;
  Vec3 cavity_max_;  ///< m, max_ with y = +inf (the cavity is open above)

  /// 5 outer faces (bottom, 4 outer walls), 5 inner faces (floor top, 4 inner walls) and
  /// the top rim as 4 strips of width t.
  std::vector<Rectangle> faces() const {
    const Vec3 ex = Vec3::UnitX(), ey = Vec3::UnitY(), ez = Vec3::UnitZ();
    const Vec3 size = max_ - min_;               // m, cavity size
    const Vec3 outer = outer_max_ - outer_min_;  // m, outer box size
    std::vector<Rectangle> f;
    // Outer faces: the outer box's bottom and four sides (its top is rim + opening).
    for (int axis = 0; axis < 3; ++axis) {
      f.push_back(boxFace(outer_min_, outer_max_, axis, -1.0));
      if (axis != 1) f.push_back(boxFace(outer_min_, outer_max_, axis, +1.0));
    }
    // Inner faces: floor top (normal +y) and the 4 inner walls (normals into the cavity).
    f.push_back(Rectangle{min_, ez, size.z(), ex, size.x(), ey});
    f.push_back(Rectangle{min_, ey, size.y(), ez, size.z(), ex});
    f.push_back(Rectangle{Vec3(max_.x(), min_.y(), min_.z()), ez, size.z(), ey, size.y(), -ex});
    f.push_back(Rectangle{min_, ex, size.x(), ey, size.y(), ez});
    f.push_back(Rectangle{Vec3(min_.x(), min_.y(), max_.z()), ey, size.y(), ex, size.x(), -ez});
    // Top rim (y = max.y, normal +y): two full-length strips along x at the -z and +z sides,
    // two short strips along z at the -x and +x sides.
    const double top = max_.y();
    f.push_back(Rectangle{Vec3(outer_min_.x(), top, outer_min_.z()), ez, t_, ex, outer.x(), ey});
    f.push_back(Rectangle{Vec3(outer_min_.x(), top, max_.z()), ez, t_, ex, outer.x(), ey});
    f.push_back(Rectangle{Vec3(outer_min_.x(), top, min_.z()), ez, size.z(), ex, t_, ey});
    f.push_back(Rectangle{Vec3(max_.x(), top, min_.z()), ez, size.z(), ex, t_, ey});
    return f;
  }
};

}  // namespace

void SurfaceMesh::addTriangle(const Vec3& a, const Vec3& b, const Vec3& c) {
  const auto first = static_cast<std::uint32_t>(vertices.size());
  vertices.insert(vertices.end(), {a, b, c});
  triangles.push_back({first, first + 1, first + 2});
}

void SurfaceMesh::addQuad(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const auto first = static_cast<std::uint32_t>(vertices.size());
  vertices.insert(vertices.end(), {a, b, c, d});
  triangles.push_back({first, first + 1, first + 2});
  triangles.push_back({first, first + 2, first + 3});
}

void SurfaceMesh::append(const SurfaceMesh& other, const Pose& pose) {
  const auto first = static_cast<std::uint32_t>(vertices.size());
  for (const Vec3& v : other.vertices)
    vertices.push_back(pose.toWorld(v));
  for (const auto& t : other.triangles)
    triangles.push_back({first + t[0], first + t[1], first + t[2]});
}

std::unique_ptr<Shape> makeBox(const Vec3& half_extents) {
  if (!isFinite(half_extents) || (half_extents.array() <= 0.0).any())
    throw std::invalid_argument("box: half_extents must be finite and > 0, got " +
                                str(half_extents));
  return std::make_unique<BoxShape>(half_extents);
}

std::unique_ptr<Shape> makeSphere(double radius) {
  if (!std::isfinite(radius) || !(radius > 0.0))
    throw std::invalid_argument("sphere: radius must be finite and > 0, got " +
                                std::to_string(radius));
  return std::make_unique<SphereShape>(radius);
}

std::unique_ptr<Shape> makePlane(const Vec3& normal, double offset) {
  if (!isFinite(normal) || !(normal.norm() > 0.0))
    throw std::invalid_argument("plane: normal must be finite and non-zero, got " + str(normal));
  if (!std::isfinite(offset))
    throw std::invalid_argument("plane: offset must be finite, got " + std::to_string(offset));
  return std::make_unique<PlaneShape>(normal, offset);
}

std::unique_ptr<Shape> makeTank(const Vec3& min, const Vec3& max, double wall_thickness) {
  if (!isFinite(min) || !isFinite(max) || (max.array() <= min.array()).any())
    throw std::invalid_argument("tank: need finite min < max, got min " + str(min) + " max " +
                                str(max));
  if (!std::isfinite(wall_thickness) || !(wall_thickness > 0.0))
    throw std::invalid_argument("tank: wall_thickness must be finite and > 0, got " +
                                std::to_string(wall_thickness));
  return std::make_unique<TankShape>(min, max, wall_thickness);
}

void checkSampling(double spacing, double radius) {
  if (!(spacing > 0.0) || !std::isfinite(spacing))
    throw std::invalid_argument("shape sampling: spacing must be finite and > 0, got " +
                                std::to_string(spacing));
  if (!(radius >= 0.0) || !std::isfinite(radius))
    throw std::invalid_argument("shape sampling: radius must be finite and >= 0, got " +
                                std::to_string(radius));
}

Vec3 sdfGradient(const Shape& shape, const Vec3& p, double step) {
  Vec3 g;
  for (int a = 0; a < 3; ++a) {
    Vec3 d = Vec3::Zero();
    d[a] = step;
    g[a] = (shape.signedDistance(p + d) - shape.signedDistance(p - d)) / (2.0 * step);
  }
  const double norm = g.norm();
  return norm > 0.0 ? Vec3(g / norm) : Vec3::Zero();
}

}  // namespace wake
