// Direct forcing's position correction (eq. 19-20, Becker et al. 2009): after the step's
// integration, no fluid centre may lie closer than the contact distance s_c
// (Boundaries::contactDistance, half the fluid radius) to a body's exact surface. With the velocity
// control (coupling/direct_forcing.hpp) it is the second half of the method; the boundaries
// (coupling/boundary.hpp) answer where the surfaces are.
#pragma once

#include "coupling/boundary.hpp"

#include <cstdint>
#include <vector>

namespace wake {

/// Position correction (eq. 19-20), for every body at once: moves each fluid centre to
/// the nearest point at least s_c from every body's exact surface (Gauss-Seidel
/// projections on the bodies' tangent planes, contacts found again after each pass, so
/// corners and several bodies are handled together). A particle squeezed between bodies
/// closer than 2 s_c cannot have s_c from all of them: it is treated as one chain
/// with all its boundaries and placed where the clearance is largest that all of them
/// allow (s_c / 2, s_c / 4, ... s_c / 16), between them at a raised density, never pushed
/// out of one body into another or through a wall. Where the bodies touch (a gap closed,
/// a body moved onto fluid by user code) there is no room between them: the particle
/// moves to the nearest point with s_c / 2 from every body, found by a search over 26
/// directions out to eight spacings along paths that neither cross a static body nor go
/// deeper into any body: squeezed fluid goes sideways, out of the gap, never through a
/// wall.
/// Particles flagged in `candidates` and particles near a moving body are looked at:
/// with static bodies, a particle without a contact at its predicted position x* has
/// none at its final one (uncontrolled particles end exactly at x*). Returns the number
/// of particles that no move could free (0 unless bodies enclose fluid entirely).
/// With `v` (the divergence-free solver's steps), a particle moved out of a body in the
/// usual case also loses its velocity into that body, relative to the body's surface
/// there (the body has stepped already: the change is not given to it); otherwise a
/// particle in a concave corner, whose single contact normal is the corner's diagonal,
/// kept moving into the walls step after step and stirred the fluid around it.
std::size_t correctPositions(const Boundaries& boundaries, const BodyPlacement& at,
                             std::vector<Vec3>& x, const std::vector<std::uint8_t>& candidates,
                             std::vector<Vec3>* v = nullptr);

/// Gauss-Seidel projections of y to clearance s from every body in contact (contacts found
/// again after each pass), at most `passes` passes. True when y ends with clearance >= s
/// (to a tolerance). With `velocity`, each projection also removes its approach speed
/// towards the body it projects from (relative to the body's surface velocity).
bool projectOut(const Boundaries& boundaries, const BodyPlacement& at, Vec3& y, double s,
                int passes, Vec3* velocity = nullptr);

/// Moves x to the nearest point where it can have s_c / 2 from every body, reachable
/// without crossing a body (see correctPositions). False when there is none within eight
/// spacings: then x moves to the point of most clearance found, if more than it has now.
bool escape(const Boundaries& boundaries, const BodyPlacement& at, Vec3& x);

}  // namespace wake
