// DIR/summary.json (DESIGN.md §7): the run's outcome in one small JSON file for scripts.
//
// Contract fields (never renamed): scene, fluid_particles, boundary_particles, steps,
// sim_time (s), wall_seconds (s), max_density_ratio, max_penetrating, lost_particles,
// bodies [{name, position (m), orientation (x, y, z, w), linear_velocity (m/s),
// angular_velocity (rad/s)}] at the end of the run.
// Extensions: wake_version, removed_at_start, speed_of_sound (m/s), particle_radius (m),
// rest_density (kg/m^3), method, frames, threads, mean_dt (s), end_time (s), output
// (the .h5 file name), state_hash (16 hex digits: FNV-1a of the final fluid positions and
// velocities in id order; equal for runs that end in the same state bit for bit),
// timings {neighbors, density, forces, boundary, integration, total} (wall-clock s).
#pragma once

#include "coupling/simulation.hpp"

#include <nlohmann/json.hpp>

#include <string>

namespace wake {

struct SceneFile;

/// What the runner measured besides the simulation's own counters.
struct RunStats {
  std::size_t frames = 0;     ///< output frames written (frame 0 included)
  double wall_seconds = 0.0;  ///< s, wall-clock time of the whole run
  int threads = 1;            ///< OpenMP threads used
  std::string output;         ///< file name of the .h5 output (no folder)
};

/// The summary of a finished run; fields in the order listed above.
nlohmann::ordered_json makeSummary(const SceneFile& scene, const Simulation& sim,
                                   const RunStats& stats);

/// Writes `summary` to `path` (via a temporary file and a rename). Throws
/// std::runtime_error naming the file.
void writeSummary(const std::string& path, const nlohmann::ordered_json& summary);

}  // namespace wake
