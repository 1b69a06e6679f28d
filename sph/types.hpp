// Basic types shared by every Wake module. All quantities are SI (m, kg, s).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <limits>

namespace wake {

using Vec3 = Eigen::Vector3d;
/// Single precision: where a position is kept only to compare with (Fluid's neighbour
/// reference).
using Vec3f = Eigen::Vector3f;
using Quat = Eigen::Quaterniond;

/// Axis-aligned box, in metres.
struct Aabb {
  Vec3 min = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 max = Vec3::Constant(-std::numeric_limits<double>::infinity());

  bool empty() const { return (min.array() > max.array()).any(); }
  void extend(const Vec3& p) {
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  }
  void extend(const Aabb& b) {
    if (b.empty()) return;
    min = min.cwiseMin(b.min);
    max = max.cwiseMax(b.max);
  }
  /// Corner k in [0, 8): bit 0 picks max.x, bit 1 max.y, bit 2 max.z.
  Vec3 corner(int k) const {
    return Vec3((k & 1) ? max.x() : min.x(), (k & 2) ? max.y() : min.y(),
                (k & 4) ? max.z() : min.z());
  }
  bool contains(const Vec3& p) const {
    return (p.array() >= min.array()).all() && (p.array() <= max.array()).all();
  }
  /// This box grown by `by` (m) on every side.
  Aabb grown(double by) const {
    Aabb b = *this;
    b.min.array() -= by;
    b.max.array() += by;
    return b;
  }
};

/// Rigid transform body -> world: x_world = orientation * x_body + position.
struct Pose {
  Vec3 position = Vec3::Zero();         ///< m
  Quat orientation = Quat::Identity();  ///< unit quaternion

  Vec3 toWorld(const Vec3& p) const { return orientation * p + position; }
  Vec3 toBody(const Vec3& p) const { return orientation.conjugate() * (p - position); }
  Vec3 rotate(const Vec3& d) const { return orientation * d; }
};

/// Bounds of box `b` carried by `pose` to the world (to_world) or from it into the body.
inline Aabb transformBounds(const Aabb& b, const Pose& pose, bool to_world) {
  Aabb out;
  if (b.empty()) return out;
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3 p = b.corner(corner);
    out.extend(to_world ? pose.toWorld(p) : pose.toBody(p));
  }
  return out;
}

}  // namespace wake
