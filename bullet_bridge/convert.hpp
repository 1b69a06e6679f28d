// Conversions between Bullet's and Wake's math types (internal to bullet_bridge/).
#pragma once

#include "coupling/rigid_body.hpp"

#include <LinearMath/btMatrix3x3.h>
#include <LinearMath/btTransform.h>

namespace wake::bullet {

inline Vec3 toVec(const btVector3& v) {
  return Vec3(double(v.x()), double(v.y()), double(v.z()));
}

inline btVector3 toBt(const Vec3& v) {
  return btVector3(btScalar(v.x()), btScalar(v.y()), btScalar(v.z()));
}

inline Pose toPose(const btTransform& t) {
  const btQuaternion q = t.getRotation();
  Pose p;
  p.position = toVec(t.getOrigin());
  p.orientation = Quat(double(q.w()), double(q.x()), double(q.y()), double(q.z())).normalized();
  return p;
}

inline btTransform toBt(const Pose& p) {
  const Quat& q = p.orientation;
  return btTransform(
      btQuaternion(btScalar(q.x()), btScalar(q.y()), btScalar(q.z()), btScalar(q.w())),
      toBt(p.position));
}

inline Mat3 toMat(const btMatrix3x3& m) {
  Mat3 out;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      out(r, c) = double(m[r][c]);
  return out;
}

}  // namespace wake::bullet
