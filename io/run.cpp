#include "io/run.hpp"

#include "bullet_bridge/scene_world.hpp"
#include "io/checkpoint.hpp"
#include "io/output.hpp"
#include "io/progress.hpp"
#include "io/series.hpp"
#include "io/summary.hpp"

#include <omp.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <sstream>

namespace wake {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

/// Progress of a run: frame, simulated time, steps per second, time left.
class Progress {
 public:
  Progress(const RunOptions& options, std::size_t last_frame, double end_time)
      : line_(options.quiet ? nullptr
              : options.log ? options.log
                            : &std::cerr,
              options.interactive),
        last_frame_(last_frame),
        end_time_(end_time) {}

  void message(const std::string& text) { line_.message(text); }

  void frame(std::size_t k, const Simulation& sim) {
    if (line_.silent()) return;
    const double elapsed = line_.elapsed();
    const double t = sim.time();
    if (k == first_frame_) {
      first_steps_ = sim.steps();
      first_time_ = t;
    }
    const double steps_per_second = elapsed > 0 ? (sim.steps() - first_steps_) / elapsed : 0.0;
    const double eta = t > first_time_ ? elapsed * (end_time_ - t) / (t - first_time_) : NAN;
    char buf[160];
    std::snprintf(buf, sizeof(buf), "[wake] frame %zu/%zu  t=%.3f/%.3f s  %.0f steps/s  ETA %s", k,
                  last_frame_, t, end_time_, steps_per_second, formatDuration(eta).c_str());
    line_.update(buf, k == last_frame_);
  }

  /// Ends an unfinished updating line (before an error message is printed).
  void abandon() { line_.abandon(); }

  void startAt(std::size_t frame) { first_frame_ = frame; }

 private:
  ProgressLine line_;
  std::size_t last_frame_;
  double end_time_;
  std::size_t first_frame_ = 0;    // the first frame this process writes (resumed runs: later)
  std::uint64_t first_steps_ = 0;  // the steps taken before it
  double first_time_ = 0;          // s, its time
};

/// Creates the output folder; an existing file of that name is bad input.
void prepareOutputFolder(const std::string& dir) {
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    throw SceneError("--out: " + dir + " exists and is not a folder");
  fs::create_directories(dir, ec);
  if (ec) throw SceneError("--out: cannot create the folder " + dir + ": " + ec.message());
}

}  // namespace

namespace {

/// Where a run starts: from t = 0, or from a checkpoint with `frames` frames written.
struct Start {
  const SimulationState* state = nullptr;
  const OutputIndex* output = nullptr;  ///< resuming: the frames written before
  std::size_t frames = 0;
  double checkpoint_every = 0;
};

std::string checkpointPath(const std::string& dir) {
  return dir + "/checkpoint.h5";
}

/// The first multiple of `every` after t.
double nextCheckpoint(double t, double every) {
  return every * (std::floor(t / every * (1.0 + 1e-12)) + 1.0);
}

/// The scene's world, at its start or at the restored state. Everything that can reject
/// the input happens here, before the output folder is touched.
std::unique_ptr<SceneWorld> buildWorld(const SceneFile& scene, const Start& from) {
  try {
    auto world = std::make_unique<SceneWorld>(scene.sim, scene.bodies);
    world->coupled().start();
    if (from.state) world->coupled().simulation().restoreState(*from.state);
    return world;
  } catch (const std::invalid_argument& e) {
    throw SceneError(scene.path + ": " + e.what());
  } catch (const std::bad_alloc&) {
    throw SceneError(scene.path + ": fluid.particle_radius: not enough memory for " +
                     "this many particles; use a larger particle_radius or smaller blocks");
  }
}

/// The run's first progress line: what is simulated, on how many threads.
std::string startLine(const SceneFile& scene, const Simulation& sim, int threads,
                      std::size_t last_frame, const Start& from) {
  std::ostringstream m;
  m << "scene " << scene.name << ": " << sim.fluidParticles() << " fluid + "
    << sim.boundaryParticles() << " boundary particles, c = " << sim.fluid().params().speed_of_sound
    << " m/s, " << threads << " thread" << (threads == 1 ? "" : "s") << ", " << last_frame + 1
    << " frames";
  if (sim.removedAtStart() > 0)
    m << " (" << sim.removedAtStart() << " fluid particles inside bodies removed)";
  if (from.state) m << "; resumed at t = " << sim.time() << " s after frame " << from.frames - 1;
  return m.str();
}

/// The run's output files: new ones, or (resuming) the stopped run's, trimmed to the
/// checkpoint's frames.
struct Writers {
  std::unique_ptr<FrameWriter> frames;
  std::unique_ptr<SeriesWriter> series;
};

Writers openWriters(const SceneFile& scene, const RunOptions& options, const Simulation& sim,
                    const Start& from) {
  Writers w;
  try {
    if (from.state) {
      w.frames = std::make_unique<FrameWriter>(options.out_dir, scene, sim, *from.output);
      w.series = std::make_unique<SeriesWriter>(options.out_dir, sim, from.frames);
    } else {
      w.frames = std::make_unique<FrameWriter>(options.out_dir, scene, sim);
      w.series = std::make_unique<SeriesWriter>(options.out_dir, sim);
    }
  } catch (const std::exception& e) {
    throw RunError(e.what());
  }
  return w;
}

/// Advances the world frame by frame from the start's frame to the last, writing every
/// frame and, every checkpoint_every seconds, the checkpoint (after the frames it counts
/// are on disk). A stopped run becomes one RunError naming where and why.
void writeFrames(SceneWorld& world, const SceneFile& scene, const Start& from, Writers& out,
                 Progress& progress, const std::string& checkpoint, std::size_t last_frame) {
  Simulation& sim = world.coupled().simulation();
  CheckpointInfo info;
  info.scene_path = scene.path;
  info.scene_text = scene.text;
  info.end_time = scene.end_time;
  info.resolution = scene.resolution;
  info.checkpoint_every = from.checkpoint_every;
  double next_checkpoint = from.checkpoint_every > 0
                               ? nextCheckpoint(sim.time(), from.checkpoint_every)
                               : std::numeric_limits<double>::infinity();
  FluidSnapshot fluid;
  try {
    for (std::size_t k = from.frames; k <= last_frame; ++k) {
      if (k > 0) world.coupled().advanceTo(frameTime(scene, k));
      sim.snapshot(fluid);
      out.frames->writeFrame(sim, fluid);
      out.series->writeFrame(sim, k == 0);
      sim.resetWindow();
      progress.frame(k, sim);
      if (sim.time() >= next_checkpoint && k < last_frame) {
        out.frames->sync();
        out.series->sync();
        info.frames = k + 1;
        info.output = out.frames->index();
        writeCheckpoint(checkpoint, sim.saveState(), info);
        next_checkpoint = nextCheckpoint(sim.time(), from.checkpoint_every);
      }
    }
    out.frames->finish();
    out.series->finish();
  } catch (const HealthError& e) {
    // The simulation checked itself after every step and says what to change.
    progress.abandon();
    throw RunError(scene.path + ": the run stopped at " + e.what() + "; the " +
                   std::to_string(out.frames->frames()) + " frames before are in " +
                   out.frames->h5Path() + ".partial");
  } catch (const std::exception& e) {
    progress.abandon();
    std::ostringstream m;
    m << scene.path << ": run stopped at t=" << sim.time() << " s (step " << sim.steps()
      << "): " << e.what();
    throw RunError(m.str());
  }
}

RunResult run(const SceneFile& scene, const RunOptions& options, const Start& from) {
  const Clock::time_point start = Clock::now();
  if (options.out_dir.empty()) throw SceneError("--out: an output folder is required");
  if (!std::isfinite(from.checkpoint_every) || from.checkpoint_every < 0)
    throw SceneError("--checkpoint-every: must be a finite number >= 0");
  const std::unique_ptr<SceneWorld> world = buildWorld(scene, from);
  const Simulation& sim = world->coupled().simulation();
  prepareOutputFolder(options.out_dir);
  const std::string checkpoint = checkpointPath(options.out_dir);
  if (!from.state) std::remove(checkpoint.c_str());  // an earlier run's: not this run's

  const std::size_t last_frame = frameCount(scene);
  Progress progress(options, last_frame, scene.end_time);
  progress.startAt(from.frames);
  const int threads = omp_get_max_threads();
  progress.message(startLine(scene, sim, threads, last_frame, from));
  Writers out = openWriters(scene, options, sim, from);
  const std::string summary_path = options.out_dir + "/summary.json";
  // Resuming a run stopped while it finished (files renamed, checkpoint not yet removed):
  // its summary, if written, is written again at the end.
  if (from.state) std::remove(summary_path.c_str());
  writeFrames(*world, scene, from, out, progress, checkpoint, last_frame);

  RunStats stats;
  stats.frames = out.frames->frames();
  stats.threads = threads;
  stats.output = fs::path(out.frames->h5Path()).filename().string();
  stats.wall_seconds = secondsSince(start);
  RunResult result;
  result.summary = makeSummary(scene, sim, stats);
  result.h5_path = out.frames->h5Path();
  result.xdmf_path = out.frames->xdmfPath();
  result.summary_path = summary_path;
  try {
    writeSummary(result.summary_path, result.summary);
  } catch (const std::exception& e) {
    throw RunError(e.what());
  }
  std::remove(checkpoint.c_str());  // the run is complete: nothing to resume
  std::ostringstream m;
  m << "done: " << stats.frames << " frames, " << sim.steps() << " steps in " << std::fixed
    << std::setprecision(2) << stats.wall_seconds << " s -> " << result.h5_path;
  progress.message(m.str());
  return result;
}

}  // namespace

RunResult runScene(const SceneFile& scene, const RunOptions& options) {
  Start from;
  from.checkpoint_every = options.checkpoint_every;
  return run(scene, options, from);
}

RunResult resumeRun(const RunOptions& options) {
  const std::string dir = options.out_dir;
  const std::string path = checkpointPath(dir);
  std::error_code ec;
  if (!fs::exists(path, ec)) {
    if (fs::exists(dir + "/summary.json", ec))
      throw SceneError("--resume: the run in " + dir + " is complete (no checkpoint to resume)");
    throw SceneError("--resume: no checkpoint in " + dir +
                     " (wake run SCENE --out DIR --checkpoint-every T writes them)");
  }
  CheckpointInfo info;
  SimulationState state;
  try {
    state = readCheckpoint(path, &info);
  } catch (const std::exception& e) {
    throw SceneError(std::string("--resume: ") + e.what());
  }
  // The scene as it was when the run started (the file may have changed since).
  SceneFile scene = parseScene(info.scene_text, info.scene_path);
  overrideEndTime(scene, info.end_time, "checkpoint end_time");
  if (info.resolution != 1) overrideResolution(scene, info.resolution, "checkpoint resolution");
  Start from;
  from.state = &state;
  from.frames = static_cast<std::size_t>(info.frames);
  if (info.output.frames() != from.frames)
    throw SceneError("--resume: " + path + " indexes " + std::to_string(info.output.frames()) +
                     " output frames, not the " + std::to_string(from.frames) + " it counts");
  from.output = &info.output;
  from.checkpoint_every = info.checkpoint_every;
  return run(scene, options, from);
}

}  // namespace wake
