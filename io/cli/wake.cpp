// `wake`: the headless command line (DESIGN.md §7).
//
//   wake run SCENE.json --out DIR [--quiet] [--threads N] [--end T] [--resolution F]
//            [--checkpoint-every T]
//   wake run --resume DIR [--quiet] [--threads N]
//   wake render DIR [--out FRAMES_DIR] [--scene NAME] [--color speed|depth] [--width W]
//               [--height H] [--view iso|front|side|top] [--frames A:B|K] [--every N]
//               [--max-speed V] [--video] [--quiet] [--threads N]
//
// Exit status: 0 success, 2 bad input (scene, options), 1 a run that failed.
// Every error is one line on stderr: "wake: error: <message>".
#include "io/files.hpp"
#include "io/run.hpp"
#include "io/scene.hpp"
#include "render/render.hpp"

#include <omp.h>
#include <unistd.h>
#include <CLI/CLI.hpp>

#include <cmath>
#include <iostream>
#include <optional>
#include <string>

namespace {

constexpr int kExitRunFailed = 1;
constexpr int kExitBadInput = 2;

int fail(int status, const std::string& message) {
  std::cerr << "wake: error: " << message << std::endl;
  return status;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("Wake: a weakly compressible SPH fluid coupled to rigid bodies by direct forcing.",
               "wake");
  app.set_version_flag("--version", std::string("wake ") + wake::wakeVersion());
  app.require_subcommand(0, 1);  // none: an error below, naming what to type

  std::string scene_path, out_dir;
  bool quiet = false;
  int threads = 0;
  double end_time = 0.0, resolution = 1.0;
  CLI::App* run = app.add_subcommand(
      "run", "Run a scene headless; write DIR/<scene>.h5, DIR/<scene>.xdmf, DIR/summary.json");
  std::string resume_dir;
  double checkpoint_every = 0.0;
  CLI::Option* scene_option =
      run->add_option("scene", scene_path, "Scene file (JSON, see io/SCENE_FORMAT.md)");
  CLI::Option* out_option =
      run->add_option("--out,-o", out_dir, "Output folder (created when missing)");
  CLI::Option* resume_option = run->add_option(
      "--resume", resume_dir,
      "Continue the stopped run in DIR from its last checkpoint (no scene, --out, --end, "
      "--resolution or --checkpoint-every with it)");
  CLI::Option* checkpoint_option = run->add_option(
      "--checkpoint-every", checkpoint_every,
      "Write DIR/checkpoint.h5 every T s of simulated time (at the first frame at or past it)");
  run->add_flag("--quiet,-q", quiet, "No progress output");
  CLI::Option* threads_option =
      run->add_option("--threads,-j", threads, "OpenMP threads (>= 1; default: all cores)");
  CLI::Option* end_option =
      run->add_option("--end", end_time, "End time in s, overrides the scene's time.end");
  CLI::Option* resolution_option = run->add_option(
      "--resolution", resolution,
      "Refinement factor F > 0: particle_radius / F, about F^3 times the particles");

  wake::RenderOptions render_options;
  std::string render_color = "speed", render_view = "iso", render_frames;
  bool render_quiet = false;
  int render_threads = 0;
  CLI::App* render = app.add_subcommand(
      "render", "Draw a run's frames as PNG images (DIR/frames/<scene>_NNNNNN.png)");
  render->add_option("dir", render_options.dir, "Output folder of wake run (holds <scene>.h5)")
      ->required();
  render->add_option("--out,-o", render_options.out_dir,
                     "Folder for the PNGs (default DIR/frames)");
  render->add_option("--scene", render_options.scene, "Which DIR/NAME.h5 when DIR holds several");
  render->add_option("--color", render_color, "Colour the fluid by speed or depth (default speed)");
  render->add_option("--width", render_options.width, "Image width in pixels (default 960)");
  render->add_option("--height", render_options.height, "Image height in pixels (default 540)");
  render->add_option("--view", render_view, "Camera: iso, front, side or top (default iso)");
  CLI::Option* frames_option =
      render->add_option("--frames", render_frames, "Frames to draw: A:B (inclusive) or K");
  render->add_option("--every", render_options.every, "Draw every N-th frame (default 1)");
  render->add_option("--max-speed", render_options.max_speed,
                     "Speed at the top of the colour ramp, m/s (default: 99th percentile)");
  render->add_flag("--section", render_options.section,
                   "Cut the fluid in half (the half facing the camera is not drawn)");
  render->add_flag("--video", render_options.video,
                   "Also write DIR/<scene>.mp4 with ffmpeg (skipped when ffmpeg is missing)");
  render->add_flag("--quiet,-q", render_quiet, "No progress output");
  CLI::Option* render_threads_option =
      render->add_option("--threads,-j", render_threads, "OpenMP threads (>= 1; default: all)");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    return fail(kExitBadInput, std::string(e.what()) + " (see wake --help)");
  }
  if (app.get_subcommands().empty())
    return fail(kExitBadInput,
                "a subcommand is required: wake run SCENE.json --out DIR or wake render DIR "
                "(see wake --help)");

  if (render->parsed()) {
    try {
      if (render_threads_option->count() > 0) {
        if (render_threads < 1)
          throw wake::SceneError("--threads: must be >= 1 (got " + std::to_string(render_threads) +
                                 ")");
        omp_set_num_threads(render_threads);
      }
      render_options.color = wake::parseRenderColor(render_color);
      render_options.view = wake::parseRenderView(render_view);
      if (frames_option->count() > 0)
        wake::parseFrameRange(render_frames, render_options.first, render_options.last);
      if (!render_quiet) render_options.log = &std::cerr;
      wake::renderRun(render_options);
      return 0;
    } catch (const wake::SceneError& e) {
      return fail(kExitBadInput, e.what());
    } catch (const std::exception& e) {
      return fail(kExitRunFailed, e.what());
    }
  }

  try {
    if (threads_option->count() > 0) {
      if (threads < 1)
        throw wake::SceneError("--threads: must be >= 1 (got " + std::to_string(threads) + ")");
      omp_set_num_threads(threads);
    }
    wake::RunOptions options;
    options.quiet = quiet;
    options.interactive = isatty(STDERR_FILENO) != 0;
    options.log = &std::cerr;
    if (resume_option->count() > 0) {
      for (const CLI::Option* o :
           {scene_option, out_option, end_option, resolution_option, checkpoint_option})
        if (o->count() > 0)
          throw wake::SceneError("--resume: " + o->get_name() +
                                 " cannot be given with it (the checkpoint holds the run's)");
      options.out_dir = resume_dir;
      wake::resumeRun(options);
      return 0;
    }
    if (scene_option->count() == 0)
      throw wake::SceneError("run: a scene file is required (or --resume DIR)");
    if (out_option->count() == 0) throw wake::SceneError("--out: an output folder is required");
    if (checkpoint_option->count() > 0 &&
        (!std::isfinite(checkpoint_every) || !(checkpoint_every > 0)))
      throw wake::SceneError("--checkpoint-every: must be a finite number > 0 (got " +
                             std::to_string(checkpoint_every) + ")");
    wake::SceneFile scene = wake::loadScene(scene_path);
    if (end_option->count() > 0) wake::overrideEndTime(scene, end_time, "--end");
    if (resolution_option->count() > 0) wake::overrideResolution(scene, resolution, "--resolution");
    options.out_dir = out_dir;
    options.checkpoint_every = checkpoint_every;
    wake::runScene(scene, options);
    return 0;
  } catch (const wake::SceneError& e) {
    return fail(kExitBadInput, e.what());
  } catch (const std::exception& e) {
    return fail(kExitRunFailed, e.what());
  }
}
