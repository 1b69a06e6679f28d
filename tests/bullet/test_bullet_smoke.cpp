// Smoke test: the imported Bullet target compiles, links and steps a world.
#include "bullet_bridge/bullet_info.hpp"

#include <gtest/gtest.h>

TEST(BulletSmoke, FreeFallMatchesClosedForm) {
  EXPECT_GE(wake::bullet::version(), 280);
  const double t = 0.5, dt = 1.0 / 240.0;
  const double drop = wake::bullet::freeFallDrop(t, dt);
  // Semi-implicit Euler falls slightly further than g t^2 / 2: within 2% of it.
  EXPECT_NEAR(-drop, 0.5 * 9.81 * t * t, 0.02 * 0.5 * 9.81 * t * t);
}

TEST(BulletSmoke, PrecisionMatchesBuildOption) {
#ifdef BT_USE_DOUBLE_PRECISION
  EXPECT_TRUE(wake::bullet::doublePrecision());
#else
  EXPECT_FALSE(wake::bullet::doublePrecision());
#endif
}
