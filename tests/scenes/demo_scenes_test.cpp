// Checks of the demo scenes that are not the paper's experiments, on the output that
// `wake run` wrote for demos/scenes/<name>.json.
#include "scene_output.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <vector>

namespace wake {
namespace {

using test::Frame;
using test::SceneOutput;

TEST(DamBreakDemo, NoWaterHangsOnTheNoSlipWalls) {
  // The default demo: no-slip walls, water. At the end (t = 1.5 s) the water has settled
  // to about 0.1 m; none of it may be held at rest on the walls above that.
  const SceneOutput out("dam_break");
  const Frame f = out.frame(out.frames() - 1);
  std::size_t hanging = 0;
  for (std::size_t i = 0; i < f.position.size(); ++i)
    if (f.velocity[i].norm() < 0.05 && f.position[i].y() > 0.12) ++hanging;
  const double share = double(hanging) / double(f.position.size());
  std::printf(
      "[ dam break ] t %.2f s: %zu of %zu particles at rest above 0.12 m (%.2f%%), "
      "lost %d\n",
      f.time, hanging, f.position.size(), 100 * share, out.summary()["lost_particles"].get<int>());
  EXPECT_LT(share, 0.005);
  EXPECT_EQ(out.summary()["lost_particles"].get<int>(), 0);
  EXPECT_EQ(out.summary()["max_penetrating"].get<int>(), 0);
}

TEST(HoneyAndWater, TheViscousFluidSpreadsSlower) {
  // Two dam breaks side by side: honey (z < 0.08) and water. The water reaches the far
  // wall (0.4 m) within 0.3 s; the honey is still far from it.
  const SceneOutput out("honey_and_water");
  auto front = [](const Frame& f, bool honey) {
    std::vector<double> x;
    for (const Vec3& p : f.position)
      if ((p.z() < 0.08) == honey) x.push_back(p.x());
    std::sort(x.begin(), x.end());
    return x[x.size() * 95 / 100];
  };
  const std::size_t k = 9;  // t = 0.3 s at 30 frames/s
  const Frame f = out.frame(k);
  const double honey = front(f, true), water = front(f, false);
  std::printf("[ honey and water ] t %.2f s: fronts honey %.3f m, water %.3f m\n", f.time, honey,
              water);
  EXPECT_GT(water, 0.38);
  EXPECT_LT(honey, 0.25);
  EXPECT_EQ(out.summary()["max_penetrating"].get<int>(), 0);
}

}  // namespace
}  // namespace wake
