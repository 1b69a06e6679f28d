#include "coupling/position_correction.hpp"

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace wake {

bool projectOut(const Boundaries& boundaries, const BodyPlacement& at, Vec3& y, double s,
                int passes, Vec3* velocity) {
  const double tolerance = 1e-6 * boundaries.fluidRadius();
  std::array<Contact, Boundaries::kMaxContacts> contacts;
  for (int pass = 0; pass < passes; ++pass) {
    const std::size_t count = boundaries.findContacts(y, at, contacts);
    bool moved = false;
    for (std::size_t c = 0; c < count; ++c) {
      const double d = s - (y - contacts[c].point).dot(contacts[c].normal);
      if (d > tolerance) {
        y += d * contacts[c].normal;
        moved = true;
        if (velocity) {
          const BodyFrame& f = at[contacts[c].body];
          const Vec3 vb =
              f.linear_velocity + f.angular_velocity.cross(contacts[c].point - f.pose.position);
          const double vn = (*velocity - vb).dot(contacts[c].normal);
          if (vn < 0.0) *velocity -= vn * contacts[c].normal;
        }
      }
    }
    if (!moved) return true;
  }
  return boundaries.clearance(y, at).all >= s - tolerance;
}

namespace {

/// The 26 directions from a cube's centre to its faces, edges and corners (unit).
const std::array<Vec3, 26>& cubeDirections() {
  static const std::array<Vec3, 26> dirs = [] {
    std::array<Vec3, 26> d;
    std::size_t k = 0;
    for (int z = -1; z <= 1; ++z)
      for (int y = -1; y <= 1; ++y)
        for (int x = -1; x <= 1; ++x)
          if (x != 0 || y != 0 || z != 0) d[k++] = Vec3(x, y, z).normalized();
    return d;
  }();
  return dirs;
}

}  // namespace

bool escape(const Boundaries& boundaries, const BodyPlacement& at, Vec3& x) {
  // Rings half a radius apart out to eight spacings; on each, the 26 directions. The
  // nearest ring with a point where the particle can have half its radius from every
  // body wins (its point of most clearance); the straight path to it must not go deeper
  // into a body than the particle is now (less half a radius), nor into a static body at
  // all: fluid leaves a closed or too thin gap sideways, never through a wall or a body.
  const double sc = boundaries.contactDistance();
  const Boundaries::Clearance start = boundaries.clearance(x, at);
  const double now = start.all;
  const double depth_limit = std::min(now, 0.0) - 0.5 * sc;
  const double static_limit = std::min(start.walls, 0.0) - 0.5 * sc;
  const double step = 0.5 * boundaries.fluidRadius();
  const int rings = 32;   // 16 r_f = 8 spacings
  double progress = now;  // most clearance reached on an open path (if none has room)
  Vec3 farthest = x;
  for (int ring = 1; ring <= rings; ++ring) {
    double best = -std::numeric_limits<double>::infinity();
    Vec3 chosen = x;
    for (const Vec3& u : cubeDirections()) {
      const Vec3 y = x + (ring * step) * u;
      const Boundaries::Clearance there = boundaries.clearance(y, at);
      if (there.walls < static_limit) continue;
      // A point in a static wall (not beyond static_limit) and in nothing deeper (beside a
      // box resting on the floor, the particle pressed into the floor under it) is a way
      // out once lifted out of the wall. Not a point inside a body: lifted, the particles
      // inside a body moved onto them would all land on its nearest face.
      Vec3 lifted = y;
      const bool lifts = there.all < sc / 16.0 && there.all >= there.walls &&
                         projectOut(boundaries, at, lifted, 0.5 * sc, 3);
      const double c = lifts ? boundaries.clearance(lifted, at).all : there.all;
      if (c <= now) continue;
      bool open = true;
      for (int k = 1; k < ring && open; ++k) {
        const Boundaries::Clearance q = boundaries.clearance(x + (k * step) * u, at);
        open = q.all >= depth_limit && q.walls >= static_limit;
      }
      if (!open) continue;
      if (c > progress) progress = c, farthest = lifts ? lifted : y;
      if (c < sc / 16.0 || c <= best) continue;
      Vec3 room = lifts ? lifted : y;  // half a radius from every body there?
      if (!lifts && !projectOut(boundaries, at, room, 0.5 * sc, 3)) continue;
      best = c;
      chosen = room;
    }
    if (best > -std::numeric_limits<double>::infinity()) {
      Vec3 full = chosen;
      x = projectOut(boundaries, at, full, sc, 4) ? full : chosen;
      return true;
    }
  }
  x = farthest;  // deep inside a large body, or no way out near: as far out as found
  return false;
}

std::size_t correctPositions(const Boundaries& boundaries, const BodyPlacement& at,
                             std::vector<Vec3>& x, const std::vector<std::uint8_t>& candidates,
                             std::vector<Vec3>* v) {
  if (boundaries.bodyCount() == 0) return 0;
  const std::int64_t n = static_cast<std::int64_t>(x.size());
  const double sc = boundaries.contactDistance();
  std::size_t stuck = 0;
#pragma omp parallel for schedule(dynamic, 256) reduction(+ : stuck)
  for (std::int64_t i = 0; i < n; ++i) {
    if (!candidates[i] && !Boundaries::nearMovingBody(x[i], at)) continue;
    // Full clearance s_c from every body (the usual case: one pass, or a few in corners).
    Vec3 xi = x[i];
    Vec3 vi = v ? (*v)[i] : Vec3::Zero();
    if (projectOut(boundaries, at, xi, sc, 4, v ? &vi : nullptr)) {
      x[i] = xi;
      if (v) (*v)[i] = vi;
      continue;
    }
    // Squeezed: bodies closer than a diameter. The largest clearance they all allow
    // (s_c / 2 ... s_c / 16), between them at a raised density.
    bool placed = false;
    for (double s = 0.5 * sc; s >= sc / 16.0 && !placed; s *= 0.5) {
      xi = x[i];
      placed = projectOut(boundaries, at, xi, s, 4);
    }
    if (placed) {
      x[i] = xi;
      continue;
    }
    // No room between them (the gap is closed): out of it, sideways.
    xi = x[i];
    if (!escape(boundaries, at, xi)) ++stuck;
    x[i] = xi;
  }
  return stuck;
}

}  // namespace wake
