// Facts about the Bullet build Wake links against.
#pragma once

namespace wake::bullet {

/// Bullet's version number as compiled (e.g. 324 for 3.24).
int version();
/// True when Bullet was built with BT_USE_DOUBLE_PRECISION.
bool doublePrecision();
/// Drops a sphere in an empty Bullet world for `seconds`; returns its height change (m).
/// Used by the smoke test to prove the library links and steps.
double freeFallDrop(double seconds, double dt);

}  // namespace wake::bullet
