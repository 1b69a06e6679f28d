// The paper's experiments (Sec. VI) as demo scenes: checks of what each one claims, on
// the output that `wake run` wrote for scenes/<name>.json (tests/CMakeLists.txt
// runs every scene first, as the test scene_<name>), and the same checks with the
// divergence-free solver (<name>_dfsph: the copy that tests/CMakeLists.txt makes).
#include "scene_output.hpp"

#include "demos/slip_front.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <vector>

namespace wake {
namespace {

using test::Frame;
using test::SceneOutput;

double particleRadius(const SceneOutput& out) {
  return out.scene().sim.fluid.particle_radius;
}

// --- Stone skipping (Figs. 1, 11) -------------------------------------------------------

void checkStoneSkips(const std::string& scene) {
  const SceneOutput out(scene);
  const test::BodyTrack& stone = out.body("stone");
  const double surface = 0.12;  // m, the basin's water level
  std::size_t bounces = 0;
  for (std::size_t k = 1; k < stone.pose.size(); ++k) {
    const bool at_surface = std::abs(stone.pose[k].position.y() - surface) < 0.05;
    if (at_surface && stone.velocity[k - 1].y() < 0.0 && stone.velocity[k].y() > 0.2) {
      ++bounces;
      std::printf("[ %s ] bounce at t=%.3f s: y=%.3f m, vy %.3f -> %.3f m/s, vx %.2f m/s\n",
                  scene.c_str(), stone.time[k], stone.pose[k].position.y(),
                  stone.velocity[k - 1].y(), stone.velocity[k].y(), stone.velocity[k].x());
    }
  }
  const Vec3 x_end = stone.pose.back().position;
  const Vec3 v_end = stone.velocity.back();
  std::printf("[ %s ] end: y=%.3f m, speed %.3f m/s, max_penetrating %d\n", scene.c_str(),
              x_end.y(), v_end.norm(), out.summary()["max_penetrating"].get<int>());
  EXPECT_GE(bounces, 1u) << "the stone never turned upward at the surface";
  EXPECT_LT(x_end.y(), surface - 0.03) << "the stone did not sink";
  EXPECT_LT(v_end.norm(), 0.3 * stone.velocity.front().norm()) << "the stone did not slow";
  EXPECT_EQ(out.summary()["max_penetrating"].get<int>(), 0);
}

TEST(StoneSkipping, GlobalBouncesThenSinks) {
  checkStoneSkips("stone_skipping");
}
TEST(StoneSkipping, LocalBouncesThenSinks) {
  checkStoneSkips("stone_skipping_local");
}
TEST(StoneSkipping, DivergenceFreeBouncesThenSinks) {
  checkStoneSkips("stone_skipping_dfsph");
}

// --- Impact (Fig. 8) --------------------------------------------------------------------

void checkImpact(const std::string& scene) {
  const SceneOutput out(scene);
  const double r = particleRadius(out);
  const double ratio = out.summary()["max_density_ratio"].get<double>();
  // The impact on the water (the paper's claim) is over when the rock closes on the floor:
  // its centre below 12 cm, its underside (about 5.5 cm below the centre) within 3 lattice
  // spacings of the floor. From then on the one-way rock, which the fluid cannot slow,
  // squeezes the fluid caught under it against the floor (and grinds along it), and that
  // fluid has nowhere to go.
  const test::BodyTrack& rock = out.body("asteroid");
  const std::vector<double>& time = out.series("time");
  const std::vector<double>& frame_ratio = out.series("max_density_ratio");
  double t_floor = time.back(), entry_ratio = 0.0;
  for (std::size_t k = 0; k < rock.pose.size(); ++k)
    if (rock.pose[k].position.y() < 0.12) {
      t_floor = rock.time[k];
      break;
    }
  for (std::size_t k = 1; k < time.size() && time[k] < t_floor; ++k)
    entry_ratio = std::max(entry_ratio, frame_ratio[k]);
  std::printf(
      "[ impact ] max density ratio %.3f while the rock enters the water (until it "
      "closes on the floor at t=%.3f s), %.3f over the run (c = %.0f m/s); lost %d, "
      "max_penetrating %d\n",
      entry_ratio, t_floor, ratio, out.summary()["speed_of_sound"].get<double>(),
      out.summary()["lost_particles"].get<int>(), out.summary()["max_penetrating"].get<int>());
  EXPECT_GT(t_floor, 0.03);
  EXPECT_LT(entry_ratio, 1.2);
  EXPECT_LT(ratio, 2.5);
  EXPECT_EQ(out.summary()["lost_particles"].get<int>(), 0);
  EXPECT_EQ(out.summary()["max_penetrating"].get<int>(), 0);
  // Below the basin's rim (y = 1 m) every particle is inside the cavity [0, 0.8] x [0, 0.3]:
  // fluid outside it came over the rim, none through a wall.
  std::size_t splashed = 0;
  for (std::size_t k = 0; k < out.frames(); ++k) {
    const Frame f = out.frame(k);
    for (const Vec3& x : f.position) {
      const bool in_cavity =
          x.x() > -r && x.x() < 0.8 + r && x.z() > -r && x.z() < 0.3 + r && x.y() > -r;
      if (x.y() >= 1.0 && !in_cavity) ++splashed;
      ASSERT_TRUE(in_cavity || x.y() >= 1.0)
          << "frame " << k << ": fluid at (" << x.transpose() << ") outside the basin";
    }
  }
  std::printf("[ impact ] particle-frames above the rim outside the basin: %zu\n", splashed);
}

TEST(Impact, DensityBoundedAndNoLeak) {
  checkImpact("impact");
}
TEST(Impact, DivergenceFreeDensityBoundedAndNoLeak) {
  checkImpact("impact_dfsph");
}

// --- Slip ramp (Fig. 7) -----------------------------------------------------------------

void checkSlipFronts(const std::string& scene) {
  const SceneOutput out(scene);
  const Frame f0 = out.frame(0), f = out.frame(out.frames() - 1);
  const char* lanes[] = {"ramp_no_slip", "ramp_half_slip", "ramp_free_slip"};
  double front[3];
  for (int lane = 0; lane < 3; ++lane) {
    const Pose& ramp = out.body(lanes[lane]).pose[0];
    auto frontOf = [&](const Frame& fr) {
      std::size_t on_ramp = 0;
      const double x = slipFront(fr.position, ramp, &on_ramp);
      EXPECT_GT(on_ramp, 50u) << lanes[lane];
      return x;
    };
    front[lane] = frontOf(f) - frontOf(f0);
    std::printf("[ slip ramp ] %s (eps %.1f): front moved %.4f m in %.2f s\n", lanes[lane],
                0.5 * lane, front[lane], f.time);
  }
  EXPECT_LT(front[0], front[1]);
  EXPECT_LT(front[1], front[2]);
  // eps = 0.5 is a wall property between the two, not no-slip in disguise.
  EXPECT_GT(front[1] - front[0], (front[2] - front[0]) / 3.0);
  EXPECT_EQ(out.summary()["max_penetrating"].get<int>(), 0);
}

TEST(SlipRamp, FrontTravelsFurtherWithMoreSlip) {
  checkSlipFronts("slip_ramp");
}
TEST(SlipRamp, DivergenceFreeFrontTravelsFurtherWithMoreSlip) {
  checkSlipFronts("slip_ramp_dfsph");
}

// --- Buoyancy (Fig. 9) ------------------------------------------------------------------

void checkCubes(const std::string& scene) {
  const SceneOutput out(scene);
  const double light = out.body("light").pose.back().position.y();
  const double medium = out.body("medium").pose.back().position.y();
  const double heavy = out.body("heavy").pose.back().position.y();
  // Time each cube first reaches 0.2 m (its centre half a cube below the water line).
  auto reach = [&](const char* name) {
    const test::BodyTrack& t = out.body(name);
    for (std::size_t k = 0; k < t.pose.size(); ++k)
      if (t.pose[k].position.y() < 0.2) return t.time[k];
    return std::numeric_limits<double>::infinity();
  };
  std::printf(
      "[ buoyancy ] final heights: light %.3f, medium %.3f, heavy %.3f m; "
      "below 0.2 m at: medium %.3f s, heavy %.3f s\n",
      light, medium, heavy, reach("medium"), reach("heavy"));
  EXPECT_GT(light, medium);
  EXPECT_GT(medium, heavy);
  EXPECT_GT(light + 0.05, 0.30) << "the light cube's top is under water: it does not float";
  EXPECT_LT(reach("heavy"), reach("medium"));
  EXPECT_EQ(out.summary()["max_penetrating"].get<int>(), 0);
}

TEST(Buoyancy, LightFloatsMediumSinksSlowlyHeavySinksFast) {
  checkCubes("buoyancy");
}
TEST(Buoyancy, DivergenceFreeLightFloatsMediumSinksSlowlyHeavySinksFast) {
  checkCubes("buoyancy_dfsph");
}

// --- Viscous drag (Fig. 10) -------------------------------------------------------------

/// `solver`: "" (the scenes as they are) or "_dfsph" (their divergence-free copies).
void checkDrag(const std::string& solver) {
  const SceneOutput low("drag_low" + solver), high("drag_high" + solver);
  const double y_low = low.body("sphere").pose.back().position.y();
  const double y_high = high.body("sphere").pose.back().position.y();
  std::printf("[ drag ] sphere height at t=%.2f s: viscosity 0.1 %.4f m, 3.0 %.4f m\n",
              low.body("sphere").time.back(), y_low, y_high);
  EXPECT_GT(y_high, y_low + 0.05);
  EXPECT_EQ(low.summary()["max_penetrating"].get<int>(), 0);
  EXPECT_EQ(high.summary()["max_penetrating"].get<int>(), 0);
}

TEST(ViscousDrag, SphereSinksLessInTheMoreViscousFluid) {
  checkDrag("");
}
TEST(ViscousDrag, DivergenceFreeSphereSinksLessInTheMoreViscousFluid) {
  checkDrag("_dfsph");
}

// --- Sinking ship (Fig. 5) and vessel (Fig. 6): single-layer walls ----------------------

void checkShipFillsThroughItsSlot(const std::string& scene) {
  const SceneOutput out(scene);
  const test::BodyTrack& ship = out.body("ship");
  const std::size_t last = out.frames() - 1;
  // The hull in the frame of its scene position (its centre of mass lies 1.5 cm lower):
  // end walls at |x| in [0.16, 0.18], side walls at |z| in [0.08, 0.10], rim y = 0.06,
  // bottom plates y in [-0.06, -0.04] for |x| in [0.06, 0.18]; the slot is |x| < 0.06.
  const Vec3 c = Vec3(0.4, 0.31, 0.14) - ship.pose[0].position;
  auto local = [&](std::size_t k, const Vec3& x) { return Vec3(ship.pose[k].toBody(x) - c); };
  auto inHull = [](const Vec3& p) {
    return std::abs(p.x()) < 0.16 && std::abs(p.z()) < 0.08 && p.y() > -0.04 && p.y() < 0.06;
  };
  // Every particle that enters the hull between two frames came in through the slot or
  // over the rim: before, it was below the slot (|x| < 0.06 + 3 cm, the most a particle
  // moves in a frame here; |z| < 0.08, or up to 3 cm more when it was below the side
  // walls' lower edge, y < -0.06, and went round it) or above the rim, never beside a wall
  // or under a plate.
  std::size_t through_slot = 0, over_rim = 0, through_walls = 0;
  Frame before = out.frame(0);
  std::map<std::uint32_t, Vec3> was;  // id -> position at the previous frame (ship frame)
  for (std::size_t i = 0; i < before.id.size(); ++i)
    was[before.id[i]] = local(0, before.position[i]);
  for (std::size_t k = 1; k <= last; ++k) {
    const Frame f = out.frame(k);
    for (std::size_t i = 0; i < f.id.size(); ++i) {
      const Vec3 p = local(k, f.position[i]);
      Vec3& q = was[f.id[i]];
      if (inHull(p) && !inHull(q)) {
        if (q.y() >= 0.06) {
          ++over_rim;
        } else if (std::abs(q.x()) < 0.09 &&
                   (std::abs(q.z()) < 0.08 || (q.y() < -0.06 && std::abs(q.z()) < 0.11))) {
          ++through_slot;
        } else {
          ++through_walls;
          ADD_FAILURE() << "frame " << k << ": particle " << f.id[i] << " entered the hull "
                        << "through a wall, from (" << q.transpose() << ") to (" << p.transpose()
                        << ")";
        }
      }
      q = p;
    }
  }
  const Frame end = out.frame(last);
  std::size_t inside = 0;
  for (const Vec3& x : end.position)
    inside += inHull(local(last, x));
  const double sunk = ship.pose[0].position.y() - ship.pose[last].position.y();
  std::printf(
      "[ %s ] sank %.3f m; %zu fluid particles inside the hull at the end; "
      "entries: %zu through the slot, %zu over the rim, %zu through the walls; "
      "max_penetrating %d\n",
      scene.c_str(), sunk, inside, through_slot, over_rim, through_walls,
      out.summary()["max_penetrating"].get<int>());
  EXPECT_EQ(out.summary()["max_penetrating"].get<int>(), 0);
  EXPECT_EQ(through_walls, 0u);
  EXPECT_GT(through_slot, 200u);
  EXPECT_GT(inside, 200u);
  EXPECT_GT(sunk, 0.1);
}

TEST(SinkingShip, FillsAndSinksWithoutLeaks) {
  checkShipFillsThroughItsSlot("sinking_ship");
}
TEST(SinkingShip, DivergenceFreeFillsAndSinksWithoutLeaks) {
  checkShipFillsThroughItsSlot("sinking_ship_dfsph");
}

void checkVesselKeepsItsWater(const std::string& scene) {
  const SceneOutput out(scene);
  const test::BodyTrack& vessel = out.body("vessel");
  // The cavity in the vessel's frame: inner wall faces at |x|, |z| = 0.08 m, floor at
  // y = -0.05 m, rim at y = 0.07 m (relative to the vessel's scene position).
  const Vec3 c = Vec3(0.3, 0.36, 0.25) - vessel.pose[0].position;
  const double rim = 0.07;
  auto local = [&](std::size_t k, const Vec3& x) { return Vec3(vessel.pose[k].toBody(x) - c); };
  auto inCavity = [&](const Vec3& p) {
    return std::abs(p.x()) < 0.08 && std::abs(p.z()) < 0.08 && p.y() > -0.05 && p.y() < rim;
  };
  // Follow the water that starts inside: each particle that leaves the cavity between two
  // frames must leave over the rim (splashing out), never through a wall or the floor.
  std::map<std::uint32_t, Vec3> inside;  // id -> position in the vessel's frame
  const Frame f0 = out.frame(0);
  for (std::size_t i = 0; i < f0.id.size(); ++i)
    if (inCavity(local(0, f0.position[i]))) inside[f0.id[i]] = local(0, f0.position[i]);
  const std::size_t at_start = inside.size();
  std::size_t over_rim = 0, through_walls = 0;
  for (std::size_t k = 1; k < out.frames(); ++k) {
    const Frame f = out.frame(k);
    for (std::size_t i = 0; i < f.id.size(); ++i) {
      const auto it = inside.find(f.id[i]);
      if (it == inside.end()) continue;
      const Vec3 p = local(k, f.position[i]);
      if (inCavity(p)) {
        it->second = p;
        continue;
      }
      if (p.y() >= rim) {
        ++over_rim;
      } else {
        ++through_walls;
        ADD_FAILURE() << "frame " << k << ": particle " << f.id[i] << " left the vessel below the "
                      << "rim, from (" << it->second.transpose() << ") to (" << p.transpose()
                      << ")";
      }
      inside.erase(it);
    }
  }
  std::printf(
      "[ vessel ] water inside: %zu at the start, %zu at the end; %zu splashed over the "
      "rim, %zu through the walls; vessel y %.3f m, max_penetrating %d\n",
      at_start, inside.size(), over_rim, through_walls, vessel.pose.back().position.y(),
      out.summary()["max_penetrating"].get<int>());
  EXPECT_EQ(out.summary()["max_penetrating"].get<int>(), 0);
  EXPECT_EQ(through_walls, 0u);
  EXPECT_GT(at_start, 80u);
  EXPECT_GT(inside.size(), at_start / 4) << "fluid present inside the hull at the end";
  EXPECT_GT(vessel.pose.back().position.y(), 0.1) << "the vessel sank";
}

TEST(Vessel, FloatsKeepingItsWaterWithoutLeaks) {
  checkVesselKeepsItsWater("vessel");
}
TEST(Vessel, DivergenceFreeFloatsKeepingItsWaterWithoutLeaks) {
  checkVesselKeepsItsWater("vessel_dfsph");
}

// --- Penalty baseline vs direct forcing on the sinking ship (Sec. VI-A) ------------------

struct WallDistance {
  double mean = 0, spread = 0;  ///< m, over particles near the hull and frames
  std::size_t samples = 0, inside = 0;
};

/// Signed distances of the fluid near the ship's hull (closer than 2 r) over the frames
/// after the first 0.2 s: their mean and standard deviation, and how many were inside.
WallDistance wallDistance(const SceneOutput& out) {
  const double r = particleRadius(out);
  double sum = 0, sum_sq = 0;
  WallDistance w;
  for (std::size_t k = 0; k < out.frames(); ++k) {
    const Frame f = out.frame(k);
    if (f.time < 0.2) continue;
    for (const Vec3& x : f.position) {
      const double d = out.signedDistance("ship", k, x);
      if (d >= 2.0 * r) continue;
      sum += d;
      sum_sq += d * d;
      ++w.samples;
      w.inside += d < 0.0;
    }
  }
  w.mean = sum / static_cast<double>(w.samples);
  w.spread = std::sqrt(std::max(0.0, sum_sq / static_cast<double>(w.samples) - w.mean * w.mean));
  return w;
}

TEST(PenaltyBaseline, DirectForcingKeepsFluidOutAndAtASteadyDistance) {
  const SceneOutput direct("sinking_ship"), penalty("sinking_ship_penalty");
  const WallDistance d = wallDistance(direct), p = wallDistance(penalty);
  const double r = particleRadius(direct);
  std::printf("[ penalty vs direct forcing ] max_penetrating: direct %d, penalty %d\n",
              direct.summary()["max_penetrating"].get<int>(),
              penalty.summary()["max_penetrating"].get<int>());
  std::printf(
      "[ penalty vs direct forcing ] fluid-to-hull distance (near the hull, after "
      "0.2 s): direct %.2f r +- %.2f r (%zu samples, %zu inside), "
      "penalty %.2f r +- %.2f r (%zu samples, %zu inside)\n",
      d.mean / r, d.spread / r, d.samples, d.inside, p.mean / r, p.spread / r, p.samples, p.inside);
  std::printf(
      "[ penalty vs direct forcing ] max density ratio: direct %.3f, penalty %.3f; "
      "lost: direct %d, penalty %d\n",
      direct.summary()["max_density_ratio"].get<double>(),
      penalty.summary()["max_density_ratio"].get<double>(),
      direct.summary()["lost_particles"].get<int>(),
      penalty.summary()["lost_particles"].get<int>());
  EXPECT_EQ(direct.summary()["max_penetrating"].get<int>(), 0);
  EXPECT_EQ(d.inside, 0u);
  EXPECT_LT(d.spread, p.spread);
}

// --- Flotsam (Fig. 12) ------------------------------------------------------------------

/// `scene`: "flotsam" or its divergence-free copy.
void checkFlotsamRidesTheWave(const std::string& scene) {
  const SceneOutput out(scene);
  EXPECT_EQ(out.summary()["max_penetrating"].get<int>(), 0);
  for (const char* name : {"ring_buoy", "barrel", "rock", "boat"}) {
    const test::BodyTrack& t = out.body(name);
    const Vec3 x0 = t.pose.front().position, x1 = t.pose.back().position;
    // Carried: the furthest the wave took it up the beach (the backwash then draws it
    // back some way).
    double furthest = x0.x();
    for (const Pose& p : t.pose)
      furthest = std::max(furthest, p.position.x());
    std::printf("[ %s ] %s: x %.3f -> furthest %.3f -> %.3f m, y %.3f -> %.3f m\n", scene.c_str(),
                name, x0.x(), furthest, x1.x(), x0.y(), x1.y());
    EXPECT_GT(furthest, x0.x() + 0.2) << name << " was not carried by the wave";
    EXPECT_GT(x1.y(), 0.09) << name << " is not afloat";
  }
}

TEST(Flotsam, MeshesRideTheWaveAndFloat) {
  checkFlotsamRidesTheWave("flotsam");
}
TEST(Flotsam, DivergenceFreeMeshesRideTheWaveAndFloat) {
  checkFlotsamRidesTheWave("flotsam_dfsph");
}

}  // namespace
}  // namespace wake
