// Closed triangle mesh read from a Wavefront OBJ file (DESIGN.md §3).
//
// Inside/outside comes from the generalized winding number (robust to small cracks), the
// distance from the exact point-triangle distance to every triangle (brute force: used when
// bodies are set up and fluid is placed, not every step).  Lengths in m, areas in m^2.
#include "coupling/shape.hpp"

#include <tiny_obj_loader.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace wake {

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Triangle {
  std::array<Vec3, 3> v;  ///< m, vertices, counter-clockwise seen from outside
  Vec3 normal;            ///< unit outward normal
  double area;            ///< m^2
};

/// Squared distance (m^2) from p to the triangle (a, b, c): the closest point is found by
/// the Voronoi region of p (vertex, edge or face), as in Ericson, Real-Time Collision
/// Detection, 5.1.5.
double pointTriangleDistanceSq(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return ap.squaredNorm();  // vertex a

  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return bp.squaredNorm();  // vertex b

  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0)  // edge ab
    return (ap - (d1 / (d1 - d3)) * ab).squaredNorm();

  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return cp.squaredNorm();  // vertex c

  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0)  // edge ac
    return (ap - (d2 / (d2 - d6)) * ac).squaredNorm();

  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0)  // edge bc
    return (bp - ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b)).squaredNorm();

  const double denom = 1.0 / (va + vb + vc);  // face interior
  return (ap - (vb * denom) * ab - (vc * denom) * ac).squaredNorm();
}

/// Signed solid angle (sr) subtended at p by the triangle (a, b, c), positive when p sees
/// its back (p on the inner side of an outward triangle); Van Oosterom & Strackee (1983).
double solidAngle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ra = a - p, rb = b - p, rc = c - p;
  const double la = ra.norm(), lb = rb.norm(), lc = rc.norm();
  const double numerator = ra.dot(rb.cross(rc));
  const double denominator = la * lb * lc + ra.dot(rb) * lc + rb.dot(rc) * la + rc.dot(ra) * lb;
  return 2.0 * std::atan2(numerator, denominator);
}

class MeshShape final : public Shape {
 public:
  explicit MeshShape(std::vector<Triangle> triangles) : triangles_(std::move(triangles)) {
    for (const Triangle& t : triangles_)
      for (const Vec3& v : t.v)
        bounds_.extend(v);
  }

  const char* typeName() const override { return "mesh"; }

  double signedDistance(const Vec3& p) const override {
    double distance_sq = std::numeric_limits<double>::infinity();
    for (const Triangle& t : triangles_)
      distance_sq = std::min(distance_sq, pointTriangleDistanceSq(p, t.v[0], t.v[1], t.v[2]));
    const double distance = std::sqrt(distance_sq);
    return inside(p) ? -distance : distance;
  }

  bool contains(const Vec3& p) const override { return inside(p); }

  Aabb bounds(const Aabb&) const override { return bounds_; }

  /// Each triangle is cut into n^2 congruent sub-triangles, n = ceil(longest edge / spacing);
  /// one sample per sub-triangle centroid, with the face normal and area / n^2.
  void sample(double spacing, double radius, const Aabb&, SurfaceSamples& out) const override {
    if (!(spacing > 0.0) || !std::isfinite(spacing))
      throw std::invalid_argument("mesh sampling: spacing must be finite and > 0, got " +
                                  std::to_string(spacing));
    for (const Triangle& t : triangles_) {
      if (!(t.area > 0.0)) continue;  // degenerate: no surface to cover
      const Vec3 e1 = t.v[1] - t.v[0], e2 = t.v[2] - t.v[0];
      const double longest = std::max({e1.norm(), e2.norm(), (t.v[2] - t.v[1]).norm()});
      const int n = std::max(1, static_cast<int>(std::ceil(longest / spacing)));
      const double sub_area = t.area / (static_cast<double>(n) * n);
      const auto emit = [&](double i, double j) {  // barycentric grid coordinates
        out.position.push_back(t.v[0] + (i / n) * e1 + (j / n) * e2 - radius * t.normal);
        out.normal.push_back(t.normal);
        out.area.push_back(sub_area);
      };
      for (int i = 0; i < n; ++i) {
        for (int j = 0; i + j < n; ++j) {
          emit(i + 1.0 / 3.0, j + 1.0 / 3.0);                     // upright sub-triangle
          if (i + j < n - 1) emit(i + 2.0 / 3.0, j + 2.0 / 3.0);  // inverted sub-triangle
        }
      }
    }
  }

 private:
  /// Generalized winding number > 1/2; 0 outside the bounding box without any sum.
  bool inside(const Vec3& p) const {
    if (!bounds_.contains(p)) return false;
    double total = 0.0;  // sr
    for (const Triangle& t : triangles_)
      total += solidAngle(p, t.v[0], t.v[1], t.v[2]);
    return total / (4.0 * kPi) > 0.5;
  }

  std::vector<Triangle> triangles_;
  Aabb bounds_;  ///< m, bounds of the vertices
};

}  // namespace

std::unique_ptr<Shape> makeMesh(const std::string& obj_path, const Vec3& scale) {
  if (!scale.allFinite() || (scale.array() == 0.0).any())
    throw std::invalid_argument("mesh '" + obj_path + "': scale must be finite and non-zero");

  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  if (!reader.ParseFromFile(obj_path, config))
    throw std::runtime_error("mesh '" + obj_path + "': cannot read OBJ file: " + reader.Error());

  const std::vector<tinyobj::real_t>& xyz = reader.GetAttrib().vertices;  // 3 per vertex
  const auto vertex = [&](int index) -> Vec3 {
    if (index < 0 || 3 * static_cast<std::size_t>(index) + 2 >= xyz.size())
      throw std::runtime_error("mesh '" + obj_path + "': face refers to missing vertex " +
                               std::to_string(index));
    const std::size_t k = 3 * static_cast<std::size_t>(index);
    return Vec3(xyz[k], xyz[k + 1], xyz[k + 2]).cwiseProduct(scale);
  };

  std::vector<std::array<Vec3, 3>> corners;  // m, per triangle, in file order
  double volume6 = 0.0;                      // m^3, six times the signed volume enclosed
  for (const tinyobj::shape_t& shape : reader.GetShapes()) {
    const auto& indices = shape.mesh.indices;
    std::size_t offset = 0;
    for (const unsigned char face_size : shape.mesh.num_face_vertices) {
      if (face_size == 3) {
        const std::array<Vec3, 3> c = {vertex(indices[offset].vertex_index),
                                       vertex(indices[offset + 1].vertex_index),
                                       vertex(indices[offset + 2].vertex_index)};
        volume6 += c[0].dot(c[1].cross(c[2]));
        corners.push_back(c);
      }
      offset += face_size;
    }
  }
  if (corners.empty())
    throw std::runtime_error("mesh '" + obj_path + "': no triangles in OBJ file");

  // Faces are taken as counter-clockwise seen from outside; a negative enclosed volume
  // means the file winds them the other way, so turn every triangle over.
  const bool flip = volume6 < 0.0;
  std::vector<Triangle> triangles;
  triangles.reserve(corners.size());
  for (std::array<Vec3, 3>& c : corners) {
    if (flip) std::swap(c[1], c[2]);
    const Vec3 cross = (c[1] - c[0]).cross(c[2] - c[0]);
    const double area = 0.5 * cross.norm();
    triangles.push_back({c, area > 0.0 ? Vec3(cross / cross.norm()) : Vec3::Zero(), area});
  }
  return std::make_unique<MeshShape>(std::move(triangles));
}

}  // namespace wake
