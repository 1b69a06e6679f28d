// Checkpoints (DIR/checkpoint.h5): a run's whole changing state (SimulationState), so that
// a stopped run continues bit for bit (`wake run --resume DIR`), and what is needed to
// build the run again (the scene as it was, the command line's overrides, the output
// frames complete when it was written).
//
// HDF5 layout (one version; `format` says which):
//   /            attributes format ("wake checkpoint 1"), wake_version, scene_path,
//                end_time (s), resolution, checkpoint_every (s), frames; dataset
//                scene_text (bytes of the scene file)
//   /state       attributes time (s), last_dt (s), max_density_ratio,
//                window_density_ratio; uint64 steps, removed_at_start, lost,
//                max_penetrating, window_penetrating, last_contacts; datasets position,
//                velocity, acceleration (n x 3), density, pressure, kinematic_viscosity,
//                id (n) in the simulation's slot order, pressure_mean (n; only with the
//                divergence-free solver: FluidState::pressure_mean), neighbor_reference
//                (n x 3) and neighbor_reference_id (n; where the lists were last built),
//                wrenches (bodies x 6: force, torque), rigid (the rigid-body integrator's
//                numbers)
//   /output      (`wake run`'s checkpoints) datasets frame_address (frames, uint64: each
//                output frame group's address in <scene>.h5.partial) and body_rows
//                (frames * bodies x 14): the OutputIndex the resumed run rebuilds its
//                output from (io/output.hpp)
//
// The file is written as DIR/checkpoint.h5.tmp, synced to disk and renamed over the last
// one, so a run killed at any moment leaves the previous checkpoint whole.
#pragma once

#include "coupling/simulation.hpp"
#include "io/output.hpp"

#include <cstdint>
#include <string>

namespace wake {

/// How to build the run of a checkpoint again. Empty for a checkpoint of the C++ API.
struct CheckpointInfo {
  std::string scene_path;       ///< the scene file as `wake run` was given it
  std::string scene_text;       ///< its contents when the run started
  double end_time = 0;          ///< s, the run's end (after --end)
  double resolution = 1;        ///< --resolution factor
  double checkpoint_every = 0;  ///< s of simulated time between checkpoints
  std::uint64_t frames = 0;     ///< output frames complete when the checkpoint was written
  OutputIndex output;           ///< those frames (empty for a checkpoint of the C++ API)
};

/// Writes `state` and `info` to `path` atomically (path.tmp, fsync, rename). Throws
/// std::runtime_error naming the file.
void writeCheckpoint(const std::string& path, const SimulationState& state,
                     const CheckpointInfo& info = {});

/// Reads a checkpoint written by writeCheckpoint. Throws std::runtime_error naming the file
/// when it is missing, unreadable or not a Wake checkpoint.
SimulationState readCheckpoint(const std::string& path, CheckpointInfo* info = nullptr);

}  // namespace wake
