// Shapes of revolution about the y axis for the Bullet bridge: capsule, cylinder with rounded
// rims, cone grown by a margin (DESIGN.md §3; Bullet's conventions, y is the long axis).
//
// Each solid is the revolution of a convex profile region of the half plane (r, y), r >= 0,
// r the distance to the axis.  The nearest point of a solid of revolution lies in the
// meridian half plane of the query point, so the exact 3D signed distance is the 2D signed
// distance of (r, y) to the profile region.  Volumes and areas come from Steiner's formula
// for the Minkowski sum with a ball; the surface is sampled ring by ring along the profile
// curve (see sampleRevolution).  Lengths in m, areas in m^2, volumes in m^3.
#include "geometry/shape.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace wake {

namespace {

using Vec2 = Eigen::Vector2d;  // (r, y): distance to the y axis, height

constexpr double kPi = 3.14159265358979323846;

/// Volume, area and integral of mean curvature of a convex body.
struct Steiner {
  double volume = 0.0;          ///< m^3
  double area = 0.0;            ///< m^2
  double mean_curvature = 0.0;  ///< m

  /// The body grown by a ball of radius r (Steiner's formula).
  Steiner grown(double r) const {
    return {volume + area * r + mean_curvature * r * r + 4.0 / 3.0 * kPi * r * r * r,
            area + 2.0 * mean_curvature * r + 4.0 * kPi * r * r, mean_curvature + 4.0 * kPi * r};
  }
  ConvexMeasures measures() const { return {area, mean_curvature}; }
};

/// Distance (m) from p to the segment [a, b] in the (r, y) plane.
double segmentDistance(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (p - a - t * ab).norm();
}

/// One piece of a profile curve in the (r, y) half plane, parametrised by arc length t in
/// [0, length]: a straight segment from `a` to `b`, or a circular arc about `centre` of
/// radius `rho` from angle theta0 down to theta1 (clockwise).  The profile runs clockwise
/// (from the top of the axis down to its bottom), so the outward normal of a segment is its
/// direction turned by +90 degrees and that of an arc the radial direction.
struct ProfilePiece {
  bool is_arc = false;
  Vec2 a, b;            ///< segment ends
  Vec2 centre;          ///< arc centre
  double rho = 0.0;     ///< arc radius
  double theta0 = 0.0;  ///< rad, arc start angle from the +r axis
  double length = 0.0;  ///< arc length

  static ProfilePiece segment(const Vec2& from, const Vec2& to) {
    ProfilePiece p;
    p.a = from;
    p.b = to;
    p.length = (to - from).norm();
    return p;
  }
  static ProfilePiece arc(const Vec2& centre, double rho, double theta0, double theta1) {
    ProfilePiece p;
    p.is_arc = true;
    p.centre = centre;
    p.rho = rho;
    p.theta0 = theta0;
    p.length = rho * (theta0 - theta1);
    return p;
  }

  Vec2 point(double t) const {
    if (is_arc) return centre + rho * normal(t);
    return a + (t / length) * (b - a);
  }
  Vec2 normal(double t) const {
    if (is_arc) {
      const double theta = theta0 - t / rho;
      return Vec2(std::cos(theta), std::sin(theta));
    }
    const Vec2 d = (b - a) / length;
    return Vec2(-d.y(), d.x());
  }
  /// Integral of r over arc length on [t0, t1] (m^2).
  double integralR(double t0, double t1) const {
    if (is_arc) {
      const double s0 = std::sin(theta0 - t0 / rho), s1 = std::sin(theta0 - t1 / rho);
      return centre.x() * (t1 - t0) + rho * rho * (s0 - s1);
    }
    return 0.5 * (point(t0).x() + point(t1).x()) * (t1 - t0);
  }
};

/// A closed profile curve from the top of the axis to its bottom.
class Profile {
 public:
  void add(const ProfilePiece& piece) {
    if (piece.length > 0.0) pieces_.push_back(piece);  // a zero rounding adds nothing
  }
  double length() const {
    double total = 0.0;
    for (const ProfilePiece& p : pieces_)
      total += p.length;
    return total;
  }
  /// The point and outward normal at arc length t from the start.
  void at(double t, Vec2& point, Vec2& normal) const {
    for (std::size_t i = 0; i < pieces_.size(); ++i) {
      if (t <= pieces_[i].length || i + 1 == pieces_.size()) {
        const double local = std::min(t, pieces_[i].length);
        point = pieces_[i].point(local);
        normal = pieces_[i].normal(local);
        return;
      }
      t -= pieces_[i].length;
    }
  }
  /// Integral of r over arc length on [t0, t1] of the whole curve (m^2).
  double integralR(double t0, double t1) const {
    double sum = 0.0, start = 0.0;
    for (const ProfilePiece& p : pieces_) {
      const double lo = std::max(t0, start), hi = std::min(t1, start + p.length);
      if (hi > lo) sum += p.integralR(lo - start, hi - start);
      start += p.length;
    }
    return sum;
  }

 private:
  std::vector<ProfilePiece> pieces_;
};

/// Number of samples on a ring of radius r (m): about one per spacing of circumference, but
/// never two closer than 0.6 spacing (only rings within about a spacing of the axis, where
/// fewer samples are enough).
int ringCount(double r, double spacing) {
  int n = std::max(1, static_cast<int>(std::lround(2.0 * kPi * r / spacing)));
  while (n >= 2 && 2.0 * r * std::sin(kPi / n) < 0.6 * spacing)
    --n;
  return n;
}

/// Samples the surface of revolution of `profile`: the curve is cut into m = round(L /
/// spacing) bands of equal arc length; each band gets one ring of samples at its middle,
/// ringCount samples evenly spaced in angle, rotated from ring to ring by the golden angle
/// so that neighbouring rings interleave.  Every sample of a ring stands for an equal share
/// of its band's area 2 pi int r dt (exact, so the areas add up to the exact surface area).
/// Samples are exact surface points with exact normals.  Neighbouring samples are about a
/// spacing apart and every surface point lies within ~0.7 spacing of one; only where the
/// profile has a sharp corner of interior angle alpha (a cone or cylinder without margin)
/// can the samples on its two sides come as close as spacing sin(alpha / 2).
void sampleRevolution(const Profile& profile, double spacing, double radius, SurfaceSamples& out) {
  const double length = profile.length();
  const int bands = std::max(1, static_cast<int>(std::lround(length / spacing)));
  const double width = length / bands;                       // m, band arc length
  const double golden_angle = kPi * (3.0 - std::sqrt(5.0));  // rad
  for (int j = 0; j < bands; ++j) {
    Vec2 point = Vec2::Zero(), normal = Vec2::UnitY();
    profile.at((j + 0.5) * width, point, normal);
    const double band_area = 2.0 * kPi * profile.integralR(j * width, (j + 1) * width);
    const int n = ringCount(point.x(), spacing);
    for (int k = 0; k < n; ++k) {
      const double phi = golden_angle * j + 2.0 * kPi * k / n;
      const double c = std::cos(phi), s = std::sin(phi);
      const Vec3 surface(point.x() * c, point.y(), point.x() * s);
      const Vec3 n3(normal.x() * c, normal.y(), normal.x() * s);
      out.position.push_back(surface - radius * n3);
      out.normal.push_back(n3);
      out.area.push_back(band_area / n);
    }
  }
}

// ---------------------------------------------------------------------------------------

/// A solid of revolution about y whose surface is sampled from its (r, y) profile and
/// whose volume and Steiner measures are known exactly; subclasses fill both.
class RevolutionShape : public Shape {
 public:
  void sample(double spacing, double radius, const Aabb&, SurfaceSamples& out) const override {
    checkSampling(spacing, radius);
    sampleRevolution(profile_, spacing, radius, out);
  }

  double volume() const override { return steiner_.volume; }
  std::optional<ConvexMeasures> convexMeasures() const override { return steiner_.measures(); }

 protected:
  Profile profile_;
  Steiner steiner_;
};

/// Segment (0, -h, 0) - (0, h, 0) grown by a ball of radius r.
class CapsuleShape final : public RevolutionShape {
 public:
  CapsuleShape(double radius, double half_height) : r_(radius), h_(half_height) {
    profile_.add(ProfilePiece::arc(Vec2(0.0, h_), r_, 0.5 * kPi, 0.0));
    profile_.add(ProfilePiece::segment(Vec2(r_, h_), Vec2(r_, -h_)));
    profile_.add(ProfilePiece::arc(Vec2(0.0, -h_), r_, 0.0, -0.5 * kPi));
    // The segment: no area, M = pi x length.
    steiner_ = Steiner{0.0, 0.0, kPi * 2.0 * h_}.grown(r_);
  }

  const char* typeName() const override { return "capsule"; }

  double signedDistance(const Vec3& p) const override {
    return Vec3(p.x(), p.y() - std::clamp(p.y(), -h_, h_), p.z()).norm() - r_;
  }

  Aabb bounds(const Aabb&) const override {
    return Aabb{Vec3(-r_, -h_ - r_, -r_), Vec3(r_, h_ + r_, r_)};
  }

 private:
  double r_;  ///< m, radius, > 0
  double h_;  ///< m, half the distance between the sphere centres, >= 0
};

/// The cylinder (a, b) = (radius - rounding, half_height - rounding) grown by a ball of
/// `rounding`.  Its signed distance is the exact 2D distance to the rectangle [0, a] x [-b, b]
/// of the (r, y) plane less the rounding (exact: the inner cylinder is convex).
class CylinderShape final : public RevolutionShape {
 public:
  CylinderShape(double radius, double half_height, double rounding)
      : radius_(radius), half_(half_height), rho_(rounding) {
    const double a = radius_ - rho_, b = half_ - rho_;
    profile_.add(ProfilePiece::segment(Vec2(0.0, half_), Vec2(a, half_)));
    profile_.add(ProfilePiece::arc(Vec2(a, b), rho_, 0.5 * kPi, 0.0));
    profile_.add(ProfilePiece::segment(Vec2(radius_, b), Vec2(radius_, -b)));
    profile_.add(ProfilePiece::arc(Vec2(a, -b), rho_, 0.0, -0.5 * kPi));
    profile_.add(ProfilePiece::segment(Vec2(a, -half_), Vec2(0.0, -half_)));
    // Inner cylinder: two discs and the side; M = side (2 pi b) + two rims of exterior angle
    // pi/2 (1/2 x 2 x 2 pi a x pi/2).
    steiner_ = Steiner{2.0 * kPi * a * a * b, 2.0 * kPi * a * a + 4.0 * kPi * a * b,
                       2.0 * kPi * b + kPi * kPi * a}
                   .grown(rho_);
  }

  const char* typeName() const override { return "cylinder"; }

  double signedDistance(const Vec3& p) const override {
    const Vec2 q(std::hypot(p.x(), p.z()) - (radius_ - rho_), std::abs(p.y()) - (half_ - rho_));
    return std::min(q.maxCoeff(), 0.0) + q.cwiseMax(0.0).norm() - rho_;
  }

  Aabb bounds(const Aabb&) const override {
    return Aabb{Vec3(-radius_, -half_, -radius_), Vec3(radius_, half_, radius_)};
  }

 private:
  double radius_;  ///< m, > 0
  double half_;    ///< m, half height, > 0
  double rho_;     ///< m, edge rounding, in [0, min(radius, half))
};

/// Cone with apex A = (0, H/2), base rim B = (R, -H/2) in the (r, y) plane, grown by a ball
/// of `margin`.  The profile triangle is the half of the isosceles triangle A, B, (-R, -H/2);
/// from r >= 0 the nearer of its slant AB and base CB (C = (0, -H/2)) is the nearest point
/// of the boundary, inside or out.
class ConeShape final : public RevolutionShape {
 public:
  ConeShape(double radius, double height, double margin)
      : radius_(radius), height_(height), margin_(margin) {
    const double half = 0.5 * height_;
    const double slant = std::hypot(radius_, height_);
    const Vec2 n_slant(height_ / slant, radius_ / slant);  // outward normal of the slant
    const double theta_slant = std::atan2(n_slant.y(), n_slant.x());
    const Vec2 apex(0.0, half), rim(radius_, -half);
    profile_.add(ProfilePiece::arc(apex, margin_, 0.5 * kPi, theta_slant));
    profile_.add(ProfilePiece::segment(apex + margin_ * n_slant, rim + margin_ * n_slant));
    profile_.add(ProfilePiece::arc(rim, margin_, theta_slant, -0.5 * kPi));
    profile_.add(ProfilePiece::segment(Vec2(radius_, -half - margin_), Vec2(0.0, -half - margin_)));
    // Cone: base disc + lateral area; M = lateral pi H (mean curvature cos(alpha) / 2r over
    // the lateral surface) + rim of exterior angle pi - beta, beta = atan(H / R) the angle
    // between base and slant.  The apex adds nothing to M.
    const double beta = std::atan2(height_, radius_);
    steiner_ = Steiner{kPi * radius_ * radius_ * height_ / 3.0,
                       kPi * radius_ * radius_ + kPi * radius_ * slant,
                       kPi * height_ + kPi * radius_ * (kPi - beta)}
                   .grown(margin_);
  }

  const char* typeName() const override { return "cone"; }

  double signedDistance(const Vec3& p) const override {
    const double half = 0.5 * height_;
    const Vec2 q(std::hypot(p.x(), p.z()), p.y());
    const Vec2 apex(0.0, half), rim(radius_, -half), base_centre(0.0, -half);
    const double distance =
        std::min(segmentDistance(q, apex, rim), segmentDistance(q, base_centre, rim));
    const bool inside = q.y() > -half && q.x() * height_ < radius_ * (half - q.y());
    return (inside ? -distance : distance) - margin_;
  }

  Aabb bounds(const Aabb&) const override {
    const double half = 0.5 * height_, r = radius_ + margin_;
    return Aabb{Vec3(-r, -half - margin_, -r), Vec3(r, half + margin_, r)};
  }

 private:
  double radius_;  ///< m, base radius, > 0
  double height_;  ///< m, apex to base, > 0
  double margin_;  ///< m, >= 0
};

bool positive(double x) {
  return std::isfinite(x) && x > 0.0;
}
bool nonNegative(double x) {
  return std::isfinite(x) && x >= 0.0;
}

}  // namespace

std::unique_ptr<Shape> makeCapsule(double radius, double half_height) {
  if (!positive(radius) || !nonNegative(half_height))
    throw std::invalid_argument("capsule: need finite radius > 0 and half_height >= 0, got " +
                                std::to_string(radius) + ", " + std::to_string(half_height));
  return std::make_unique<CapsuleShape>(radius, half_height);
}

std::unique_ptr<Shape> makeCylinder(double radius, double half_height, double rounding) {
  if (!positive(radius) || !positive(half_height))
    throw std::invalid_argument("cylinder: need finite radius > 0 and half_height > 0, got " +
                                std::to_string(radius) + ", " + std::to_string(half_height));
  if (!nonNegative(rounding) || !(rounding < std::min(radius, half_height)))
    throw std::invalid_argument(
        "cylinder: rounding must be >= 0 and < min(radius, half_height), got " +
        std::to_string(rounding));
  return std::make_unique<CylinderShape>(radius, half_height, rounding);
}

std::unique_ptr<Shape> makeCone(double radius, double height, double margin) {
  if (!positive(radius) || !positive(height) || !nonNegative(margin))
    throw std::invalid_argument("cone: need finite radius > 0, height > 0 and margin >= 0, got " +
                                std::to_string(radius) + ", " + std::to_string(height) + ", " +
                                std::to_string(margin));
  return std::make_unique<ConeShape>(radius, height, margin);
}

}  // namespace wake
