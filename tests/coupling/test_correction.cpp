// Position correction with several bodies at once (correctPositions,
// coupling/position_correction.hpp): fluid squeezed between a moving body and a wall stays between
// them at a reduced clearance, fluid caught in a closed gap leaves it sideways, and fluid inside a
// body that was moved onto it is expelled to the nearest free side, never through the floor.
#include "coupling/boundary.hpp"
#include "coupling/position_correction.hpp"
#include "test_support.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

namespace wake::test {
namespace {

constexpr double kR = 0.005;  // fluid particle radius (m)

FluidParams fluidParams() {
  FluidParams f;
  f.particle_radius = kR;
  f.speed_of_sound = 20.0;
  return f;
}

/// A static floor (top face at y = 0, 4 cm thick) and a kinematic box of half extents
/// `half`, turned by `angle` about y, whose bottom face is `gap` above the floor (< 0:
/// it overlaps the floor, as Bullet's contacts allow).
std::unique_ptr<Boundaries> floorAndBox(double gap, const Vec3& half, double angle = 0.0) {
  auto b = std::make_unique<Boundaries>(fluidParams(),
                                        Aabb{Vec3(-0.3, -0.3, -0.3), Vec3(0.3, 0.3, 0.3)});
  b->addBody(staticBody("floor", makeBox(Vec3(0.2, 0.02, 0.2)), 0, 0,
                        Pose{Vec3(0, -0.02, 0), Quat::Identity()}));
  BodySettings box = staticBody("box", makeBox(half));
  box.kind = BodyKind::Kinematic;
  box.pose.position = Vec3(0, gap + half.y(), 0);
  box.pose.orientation = Quat(Eigen::AngleAxisd(angle, Vec3::UnitY()));
  b->addBody(box);
  b->finalize();
  return b;
}

/// Distance from p (world) to the box's exact surface (< 0 inside).
double boxDistance(const Boundaries& b, const Vec3& p) {
  return b.body(1).shape->signedDistance(b.body(1).pose.toBody(p));
}
double floorDistance(const Boundaries& b, const Vec3& p) {
  return b.body(0).shape->signedDistance(b.body(0).pose.toBody(p));
}

TEST(Correction, SqueezedParticleStaysInTheGapClearOfBoth) {
  // A gap of one radius (half a diameter): no point has r from both, so the particle
  // goes where it has the most clearance both allow, still between them.
  const Vec3 half(0.03, 0.02, 0.03);
  for (const double gap : {1.0 * kR, 0.6 * kR, 0.3 * kR}) {
    const auto b = floorAndBox(gap, half);
    std::vector<Vec3> x;
    for (double y : {0.05 * gap, 0.5 * gap, 0.95 * gap, gap + 0.5 * kR, -0.4 * kR})
      for (double px = -0.02; px <= 0.02 + 1e-12; px += 0.01)
        x.emplace_back(px, y, 0.013 * px / 0.02);
    const std::vector<std::uint8_t> all(x.size(), 1);
    EXPECT_EQ(correctPositions(*b, b->placeAtStart(), x, all), 0u);
    EXPECT_EQ(b->countInside(x, b->placeAtStart()), 0u) << "gap " << gap;
    for (const Vec3& p : x) {
      EXPECT_GE(floorDistance(*b, p), 0.24 * gap) << "gap " << gap << " at " << p.transpose();
      EXPECT_GE(boxDistance(*b, p), 0.24 * gap) << "gap " << gap << " at " << p.transpose();
      EXPECT_LT(p.y(), gap) << "left the gap: " << p.transpose();
      EXPECT_LT(std::abs(p.x()), half.x()) << "left the gap: " << p.transpose();
    }
  }
}

TEST(Correction, FluidInAClosedGapLeavesSidewaysNeverThroughTheFloor) {
  // The box rests on the floor (gap 0) or is pressed into it: no room between them, so
  // the fluid caught there goes out under the box's nearest side.
  const Vec3 half(0.03, 0.02, 0.025);
  for (const double gap : {0.0, -0.3 * kR}) {
    for (const double angle : {0.0, 0.4}) {
      const auto b = floorAndBox(gap, half, angle);
      std::vector<Vec3> start;
      for (double u = -0.025; u <= 0.025 + 1e-12; u += 0.005)
        for (double w = -0.02; w <= 0.02 + 1e-12; w += 0.008)
          start.push_back(Vec3(u, 0.3 * kR, w));
      std::vector<Vec3> x = start;
      const std::vector<std::uint8_t> all(x.size(), 1);
      EXPECT_EQ(correctPositions(*b, b->placeAtStart(), x, all), 0u);
      EXPECT_EQ(b->countInside(x, b->placeAtStart()), 0u) << "gap " << gap << " angle " << angle;
      for (std::size_t i = 0; i < x.size(); ++i) {
        const Vec3 local = b->body(1).pose.toBody(start[i]);
        // The way out under the box: its nearest side (in the box's frame), plus the
        // half radius of clearance, on a search ring half a radius wide, diagonal
        // included.
        const double side =
            std::min(half.x() - std::abs(local.x()), half.z() - std::abs(local.z()));
        EXPECT_GT(x[i].y(), -kR) << "through the floor: " << x[i].transpose();
        EXPECT_GE(floorDistance(*b, x[i]), 0.5 * kR - 1e-9);
        EXPECT_GE(boxDistance(*b, x[i]), 0.5 * kR - 1e-9);
        EXPECT_LT((x[i] - start[i]).norm(), std::sqrt(2.0) * (side + 1.5 * kR))
            << "from " << start[i].transpose() << " to " << x[i].transpose();
      }
    }
  }
}

TEST(Correction, FluidPressedIntoTheFloorUnderARestingBoxLeavesSideways) {
  // A heavy box settling on the floor presses the fluid under it a little into the floor
  // (0.2 mm at r = 5 mm in a random scene): every point beside the box at that depth is as
  // deep in the floor as the particle, and above it the box; the way out is beside the box,
  // lifted out of the floor.
  const Vec3 half(0.03, 0.02, 0.025);
  for (const double gap : {0.0, -0.3 * kR})
    for (const double depth : {0.04 * kR, 0.2 * kR, 0.45 * kR}) {
      const auto b = floorAndBox(gap, half, 0.3);
      std::vector<Vec3> start;
      for (double u = -0.025; u <= 0.025 + 1e-12; u += 0.01)
        for (double w = -0.02; w <= 0.02 + 1e-12; w += 0.01)
          start.push_back(Vec3(u, -depth, w));
      std::vector<Vec3> x = start;
      const std::vector<std::uint8_t> all(x.size(), 1);
      EXPECT_EQ(correctPositions(*b, b->placeAtStart(), x, all), 0u);
      EXPECT_EQ(b->countInside(x, b->placeAtStart()), 0u) << "gap " << gap << " depth " << depth;
      for (std::size_t i = 0; i < x.size(); ++i) {
        const Vec3 local = b->body(1).pose.toBody(start[i]);
        const double side =
            std::min(half.x() - std::abs(local.x()), half.z() - std::abs(local.z()));
        EXPECT_GE(floorDistance(*b, x[i]), 0.5 * kR - 1e-9) << x[i].transpose();
        EXPECT_GE(boxDistance(*b, x[i]), 0.5 * kR - 1e-9) << x[i].transpose();
        EXPECT_LT((x[i] - start[i]).norm(), std::sqrt(2.0) * (side + 1.5 * kR) + depth)
            << "from " << start[i].transpose() << " to " << x[i].transpose();
      }
    }
}

TEST(Correction, FluidInsideABodyMovedOntoItGoesToTheNearestFreeSide) {
  // A large box put down on fluid (user code moving a body): every centre inside it is
  // expelled to the box's nearest face that is not against the floor.
  const Vec3 half(0.06, 0.04, 0.05);
  const auto b = floorAndBox(0.0, half);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> ux(-0.058, 0.058), uy(0.001, 0.079), uz(-0.048, 0.048);
  std::vector<Vec3> start;
  for (int k = 0; k < 300; ++k)
    start.emplace_back(ux(rng), uy(rng), uz(rng));
  std::vector<Vec3> x = start;
  const std::vector<std::uint8_t> all(x.size(), 1);
  const std::size_t stuck = correctPositions(*b, b->placeAtStart(), x, all);
  EXPECT_EQ(stuck, 0u);
  EXPECT_EQ(b->countInside(x, b->placeAtStart()), 0u);
  for (std::size_t i = 0; i < x.size(); ++i) {
    const Vec3 p = start[i] - b->body(1).pose.position;
    // Free faces: the four sides and the top.
    const double free_side =
        std::min({half.x() - std::abs(p.x()), half.z() - std::abs(p.z()), half.y() - p.y()});
    EXPECT_GT(x[i].y(), -kR) << "through the floor: " << x[i].transpose();
    EXPECT_GE(boxDistance(*b, x[i]), 0.0);
    EXPECT_LT((x[i] - start[i]).norm(), std::sqrt(2.0) * (free_side + 1.5 * kR))
        << "from " << start[i].transpose() << " to " << x[i].transpose();
  }
}

TEST(Correction, WithVelocitiesAMovedParticleStopsMovingIntoTheWallsItWasMovedFrom) {
  // A tank's floor edge along z (walls x = 0 and y = 0): a particle closer than its
  // radius to both walls, moving into them and along the edge, ends r from both, moving
  // only along the edge; one moving away from the wall it was moved from keeps its speed;
  // one clear of the walls keeps position and velocity. Without velocities (WCSPH's
  // correction) nothing but the positions changes. The walls as the divergence-free solver
  // has them (its contact distance: the full radius).
  auto b =
      std::make_unique<Boundaries>(fluidParams(), Aabb{Vec3(-0.1, -0.1, -0.1), Vec3(0.2, 0.2, 0.2)},
                                   Boundaries::kDfsphContactFraction);
  ASSERT_EQ(b->contactDistance(), kR);
  b->addBody(staticBody("tank", makeTank(Vec3::Zero(), Vec3(0.1, 0.1, 0.1), 4 * kR)));
  b->finalize();
  const BodyPlacement at = b->placeAtStart();
  const std::vector<Vec3> x0 = {Vec3(0.002, 0.003, 0.05), Vec3(0.003, 0.05, 0.05),
                                Vec3(0.05, 0.05, 0.05)};
  const std::vector<Vec3> v0 = {Vec3(-0.1, -0.2, 0.3), Vec3(0.1, -0.2, 0.0), Vec3(-0.1, -0.2, 0.3)};
  const std::vector<std::uint8_t> all(x0.size(), 1);
  std::vector<Vec3> x = x0, v = v0;
  EXPECT_EQ(correctPositions(*b, at, x, all, &v), 0u);
  EXPECT_NEAR(x[0].x(), kR, 1e-9);
  EXPECT_NEAR(x[0].y(), kR, 1e-9);
  EXPECT_NEAR(v[0].x(), 0.0, 1e-12);
  EXPECT_NEAR(v[0].y(), 0.0, 1e-12);
  EXPECT_EQ(v[0].z(), 0.3);
  EXPECT_NEAR(x[1].x(), kR, 1e-9);
  EXPECT_EQ(v[1], v0[1]);
  EXPECT_EQ(x[2], x0[2]);
  EXPECT_EQ(v[2], v0[2]);
  std::vector<Vec3> y = x0;
  EXPECT_EQ(correctPositions(*b, at, y, all), 0u);
  for (std::size_t i = 0; i < x.size(); ++i)
    EXPECT_EQ(y[i], x[i]);
}

TEST(Correction, ParticlesAwayFromBodiesDoNotMove) {
  const auto b = floorAndBox(0.02, Vec3(0.03, 0.02, 0.03));
  std::vector<Vec3> x = {Vec3(0.1, 0.05, 0), Vec3(0, 0.066, 0), Vec3(0.0, 1.0 * kR, 0.1)};
  const std::vector<Vec3> start = x;
  const std::vector<std::uint8_t> all(x.size(), 1);
  EXPECT_EQ(correctPositions(*b, b->placeAtStart(), x, all), 0u);
  for (std::size_t i = 0; i < x.size(); ++i)
    EXPECT_EQ(x[i], start[i]);
}

/// Whether p lies inside some body's exact shape, and its least signed distance to them.
std::pair<bool, double> exactShapes(const Boundaries& b, const BodyPlacement& at, const Vec3& p) {
  double sd = std::numeric_limits<double>::infinity();
  bool inside = false;
  for (std::size_t i = 0; i < b.bodyCount(); ++i) {
    const Vec3 q = at[i].pose.toBody(p);
    inside = inside || b.body(i).shape->contains(q);
    sd = std::min(sd, b.body(i).shape->signedDistance(q));
  }
  return {inside, sd};
}

/// countInside reads the cells beyond contact reach of every sample from flags (inside a
/// body or outside all) and asks the exact shapes only near a surface: at random points
/// everywhere (deep inside thick static bodies and a moving one, in the tank's walls, near
/// the surfaces, in the open), one at a time, the count is what the exact shapes give.
TEST(CountInside, EqualsTheExactShapesEverywhere) {
  const Aabb domain{Vec3(-0.1, -0.1, -0.1), Vec3(0.7, 0.5, 0.4)};
  Boundaries b(fluidParams(), domain);
  b.addBody(staticBody("tank", makeTank(Vec3::Zero(), Vec3(0.6, 0.4, 0.3), 0.04)));
  b.addBody(staticBody("block", makeBox(Vec3(0.1, 0.08, 0.06)), 0, 0,
                       Pose{Vec3(0.2, 0.08, 0.15), Quat(Eigen::AngleAxisd(0.3, Vec3::UnitY()))}));
  b.addBody(
      staticBody("ball", makeSphere(0.07), 0, 0, Pose{Vec3(0.45, 0.2, 0.15), Quat::Identity()}));
  BodySettings moving = staticBody("moving", makeBox(Vec3(0.06, 0.05, 0.08)));
  moving.kind = BodyKind::Dynamic;
  moving.pose.position = Vec3(0.3, 0.3, 0.15);
  b.addBody(moving);
  b.finalize();
  // The moving box elsewhere and turned, as a step places it.
  std::vector<RigidState> states(b.bodyCount());
  for (std::size_t i = 0; i < states.size(); ++i)
    states[i].pose = b.body(i).pose;
  states[3].pose.position = Vec3(0.32, 0.27, 0.14);
  states[3].pose.orientation = Quat(Eigen::AngleAxisd(0.5, Vec3(1, 2, 3).normalized()));
  BodyPlacement at;
  b.place(states, at);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::size_t deep = 0, counted = 0;
  for (int k = 0; k < 20000; ++k) {
    const Vec3 p = domain.min + Vec3(u(rng), u(rng), u(rng)).cwiseProduct(domain.max - domain.min);
    const auto [exact, sd] = exactShapes(b, at, p);
    deep += sd < -4.0 * kR;
    counted += exact;
    ASSERT_EQ(b.countInside({p}, at), exact ? 1u : 0u) << p.transpose() << ", distance " << sd;
  }
  EXPECT_GT(deep, 200u);  // the flags were read: points far inside a body
  EXPECT_GT(counted, deep);
}

/// Many moving bodies (more than 64: the bins' masks take two words), at random poses, some
/// overlapping, some near the tank's walls: at random points, BodyPlacement's bins offer
/// every moving body whose reach box holds the point, in ascending order, and none outside
/// the union of those boxes; and the penetration count, which reads the bins, is the exact
/// shapes'.
TEST(CountInside, ManyMovingBodiesThroughTheBins) {
  const Aabb domain{Vec3(-0.1, -0.1, -0.1), Vec3(0.7, 0.5, 0.4)};
  Boundaries b(fluidParams(), domain);
  b.addBody(staticBody("tank", makeTank(Vec3::Zero(), Vec3(0.6, 0.4, 0.3), 0.04)));
  std::mt19937 rng(71);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<std::size_t> moving;  // body index of each moving body, in Boundaries' order
  for (int k = 0; k < 70; ++k) {
    BodySettings s =
        staticBody("b" + std::to_string(k), k % 2 ? makeBox(Vec3(0.01 + 0.03 * u(rng), 0.015, 0.02))
                                                  : makeSphere(0.012 + 0.02 * u(rng)));
    s.kind = BodyKind::Dynamic;
    s.pose.position = Vec3(0.6 * u(rng), 0.4 * u(rng), 0.3 * u(rng));
    moving.push_back(b.addBody(s));
  }
  b.finalize();
  std::vector<RigidState> states(b.bodyCount());
  for (std::size_t i = 0; i < states.size(); ++i) {
    states[i].pose = b.body(i).pose;
    states[i].pose.orientation =
        Quat(Eigen::AngleAxisd(3.0 * u(rng), Vec3(u(rng), u(rng), 1.0).normalized()));
  }
  BodyPlacement at;
  b.place(states, at);
  std::size_t offered = 0, holding = 0, inside = 0;
  for (int k = 0; k < 20000; ++k) {
    const Vec3 p = domain.min + Vec3(u(rng), u(rng), u(rng)).cwiseProduct(domain.max - domain.min);
    std::vector<std::size_t> got;
    at.forEachMovingNear(p, [&](std::size_t m) {
      got.push_back(m);
      return true;
    });
    ASSERT_TRUE(std::is_sorted(got.begin(), got.end()));
    ASSERT_TRUE(std::adjacent_find(got.begin(), got.end()) == got.end());
    if (!at.moving_reach.contains(p)) {
      ASSERT_TRUE(got.empty()) << p.transpose();
    }
    for (std::size_t m = 0; m < moving.size(); ++m)
      if (at[moving[m]].world_reach.contains(p)) {
        ++holding;
        ASSERT_TRUE(std::binary_search(got.begin(), got.end(), m))
            << "body " << m << " at " << p.transpose();
      }
    offered += got.size();
    const bool exact = exactShapes(b, at, p).first;
    inside += exact;
    ASSERT_EQ(b.countInside({p}, at), exact ? 1u : 0u) << p.transpose();
  }
  EXPECT_GT(holding, 5000u);
  EXPECT_GT(inside, 500u);
  EXPECT_LT(offered, 4 * holding) << "the bins offer far more bodies than hold the point";
  // Stopping: f returning false ends the walk.
  std::size_t calls = 0;
  at.forEachMovingNear(at[moving[0]].pose.position, [&](std::size_t) {
    ++calls;
    return false;
  });
  EXPECT_EQ(calls, 1u);
}

/// The static samples' grid covers their bounds grown by a few supports, not the domain:
/// far from every static sample (outside that box) a point has no static contact and no
/// flags to read. In a domain much larger than its bodies (a small block, and a tilted
/// ground plane whose inside reaches far below its samples), at random points everywhere
/// the penetration count is the exact shapes', and the clearance min(r_f, distance) is the
/// exact distance's (near a surface and outside every body).
TEST(CountInside, AndContactsBeyondTheStaticSamplesGrid) {
  const Vec3 kGroundNormal = Vec3(0.05, 1.0, 0.03).normalized();  // y = -0.52 .. -0.68
  const Aabb domain{Vec3(-1, -1, -1), Vec3(1, 1, 1)};
  Boundaries b(fluidParams(), domain);
  b.addBody(staticBody("block", makeBox(Vec3(0.05, 0.04, 0.06)), 0, 0,
                       Pose{Vec3(0.6, -0.45, 0.6), Quat(Eigen::AngleAxisd(0.4, Vec3::UnitY()))}));
  b.addBody(staticBody("ground", makePlane(kGroundNormal, -0.6)));
  b.finalize();
  const double support = 4.0 * kR;
  const double domain_cells = 8.0 / std::pow(0.5 * support, 3);
  EXPECT_LT(double(b.staticGridCells()), 0.5 * domain_cells);
  const BodyPlacement at = b.placeAtStart();
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1.0, 1.0), near(-3.0 * kR, 3.0 * kR);
  std::size_t inside = 0, deep = 0, contacts = 0, open = 0;
  for (int k = 0; k < 40000; ++k) {
    Vec3 p(u(rng), u(rng), u(rng));
    if (k % 2) {  // half of them close to a surface
      const int body = (k / 2) % 2;
      const double sd = b.body(body).shape->signedDistance(at[body].pose.toBody(p));
      if (body == 1)
        p -= (sd - near(rng)) * kGroundNormal;
      else
        p = at[0].pose.toWorld(Vec3(0.05 + near(rng), 0.8 * 0.04 * u(rng), 0.8 * 0.06 * u(rng)));
      if (!domain.contains(p)) continue;  // fluid outside the domain is removed
    }
    const auto [exact, sd] = exactShapes(b, at, p);
    inside += exact;
    deep += exact && p.y() < -0.8;  // beyond the samples' grid
    contacts += sd < kR;
    open += sd > 10.0 * support;
    ASSERT_EQ(b.countInside({p}, at), exact ? 1u : 0u) << p.transpose() << ", distance " << sd;
    // Near a surface: the exact distance (or r_f); elsewhere outside every body r_f (deep
    // inside a static body the clearance does not look).
    if (std::abs(sd) < 4.0 * kR || sd > 0.0) {
      ASSERT_EQ(b.clearance(p, at).all, std::min(kR, sd)) << p.transpose();
    }
  }
  EXPECT_GT(inside, 5000u);    // inside the ground
  EXPECT_GT(deep, 1000u);      // ... far below its samples
  EXPECT_GT(contacts, 5000u);  // within r_f of a surface
  EXPECT_GT(open, 5000u);      // far from both
}

}  // namespace
}  // namespace wake::test
