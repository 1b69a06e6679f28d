// Headless runner behind `wake run` (DESIGN.md §7): builds the simulation, advances it
// frame by frame, writes HDF5 + XDMF output and DIR/summary.json, reports progress, writes
// checkpoints and resumes from them, and stops with a clear message when the fluid blows up.
#pragma once

#include "io/scene.hpp"

#include <nlohmann/json.hpp>

#include <iosfwd>
#include <stdexcept>
#include <string>

namespace wake {

/// A run that started but could not finish (unstable fluid, output not writable).
class RunError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct RunOptions {
  std::string out_dir;          ///< output folder, created when missing
  bool quiet = false;           ///< no progress output at all
  bool interactive = false;     ///< one updating progress line (a terminal) instead of log lines
  std::ostream* log = nullptr;  ///< where progress goes; nullptr = std::cerr
  /// s of simulated time, >= 0: write DIR/checkpoint.h5 after the first output frame at or
  /// past every multiple of it (0: no checkpoints). `wake run --resume DIR` continues from
  /// the last one.
  double checkpoint_every = 0;
};

struct RunResult {
  nlohmann::ordered_json summary;  ///< as written to summary.json
  std::string h5_path;             ///< DIR/<name>.h5
  std::string xdmf_path;           ///< DIR/<name>.xdmf
  std::string summary_path;        ///< DIR/summary.json
};

/// Runs `scene` to its end time, writing frames at t = k / frame_rate (frame 0 at t = 0,
/// the last at end_time). Throws SceneError when the settings or the output folder are
/// unusable (before anything in the folder is touched), RunError when the run fails.
RunResult runScene(const SceneFile& scene, const RunOptions& options);

/// Continues the stopped run in options.out_dir from DIR/checkpoint.h5 (the scene, its
/// overrides and the checkpoint interval come from there; options.checkpoint_every is
/// ignored) and completes the same output files: the result is bit for bit the output of
/// the run had it not stopped. Throws SceneError when DIR holds no checkpoint or no
/// unfinished run, RunError when the run fails.
RunResult resumeRun(const RunOptions& options);

}  // namespace wake
