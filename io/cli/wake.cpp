// `wake`: the headless command line (DESIGN.md §7).
//
//   wake run SCENE.json --out DIR [--quiet] [--threads N] [--end T] [--resolution F]
//            [--checkpoint-every T]
//   wake run --resume DIR [--quiet] [--threads N]
//   wake render DIR [--out FRAMES_DIR] [--scene NAME] [--color speed|depth] [--width W]
//               [--height H] [--view iso|front|side|top] [--frames A:B|K] [--every N]
//               [--max-speed V] [--video] [--particles] [--quiet] [--threads N]
//   wake surface DIR [--radius-factor F] [--voxel-factor F] [--smoothing N]
//                [--adaptivity A] [--obj] [--no-vdb] [--scene NAME] [--quiet] [--threads N]
//   wake export DIR [--scene NAME] [--quiet]
//   (wake run --surface takes the surface options too and surfaces the run when it ends)
//
// Exit status: 0 success, 2 bad input (scene, options), 1 a run that failed.
// Every error is one line on stderr: "wake: error: <message>".
#include "io/files.hpp"
#include "io/process.hpp"
#include "io/run.hpp"
#include "io/scene.hpp"
#include "io/surfaces.hpp"
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

/// --threads N: sets OpenMP's thread count when given (N >= 1).
void setThreads(const CLI::Option* option, int threads) {
  if (option->count() == 0) return;
  if (threads < 1)
    throw wake::SceneError("--threads: must be >= 1 (got " + std::to_string(threads) + ")");
  omp_set_num_threads(threads);
}

/// Runs `body`; a SceneError (bad input) exits 2, any other error 1, each one line.
template <class F>
int guarded(F&& body) {
  try {
    body();
    return 0;
  } catch (const wake::SceneError& e) {
    return fail(kExitBadInput, e.what());
  } catch (const std::exception& e) {
    return fail(kExitRunFailed, e.what());
  }
}

/// The options of the fluid's surface (`wake surface`, `wake run --surface`).
void addSurfaceOptions(CLI::App* app, wake::SurfaceOptions& o) {
  const wake::SurfaceSettings d;
  app->add_option("--radius-factor", o.settings.radius_factor,
                  "Sphere radius per particle / particle radius, [1.5, 4] (default " +
                      std::to_string(d.radius_factor).substr(0, 3) + ")");
  app->add_option("--voxel-factor", o.settings.voxel_factor,
                  "Voxel size / particle radius, [0.1, radius-factor / 1.5] (default " +
                      std::to_string(d.voxel_factor).substr(0, 3) + ")");
  app->add_option(
      "--smoothing", o.settings.smoothing,
      "Gaussian smoothing passes, [0, 20] (default " + std::to_string(d.smoothing) + ")");
  app->add_option("--adaptivity", o.settings.adaptivity,
                  "Mesh adaptivity, [0, 1]: 0 uniform, higher fewer triangles (default 0)");
  app->add_flag("--obj", o.obj, "Also write the fluid's meshes as OBJ");
  app->add_flag("--no-vdb{false}", o.vdb, "Do not write the level sets (.vdb)");
}

/// `wake run`: a scene headless, or --resume a stopped run.
struct RunCommand {
  CLI::App* app = nullptr;
  std::string scene_path, out_dir, resume_dir;
  bool quiet = false, surface = false;
  int threads = 0;
  double end_time = 0.0, resolution = 1.0, checkpoint_every = 0.0;
  wake::SurfaceOptions surface_options;
  CLI::Option *scene = nullptr, *out = nullptr, *resume = nullptr, *checkpoint = nullptr,
              *threads_option = nullptr, *end = nullptr, *resolution_option = nullptr;

  void add(CLI::App& parent) {
    app = parent.add_subcommand(
        "run", "Run a scene headless; write DIR/<scene>.h5, DIR/<scene>.xdmf, DIR/summary.json");
    scene = app->add_option("scene", scene_path, "Scene file (JSON, see io/SCENE_FORMAT.md)");
    out = app->add_option("--out,-o", out_dir, "Output folder (created when missing)");
    resume = app->add_option(
        "--resume", resume_dir,
        "Continue the stopped run in DIR from its last checkpoint (no scene, --out, --end, "
        "--resolution or --checkpoint-every with it)");
    checkpoint = app->add_option(
        "--checkpoint-every", checkpoint_every,
        "Write DIR/checkpoint.h5 every T s of simulated time (at the first frame at or past it)");
    app->add_flag("--quiet,-q", quiet, "No progress output");
    threads_option =
        app->add_option("--threads,-j", threads, "OpenMP threads (>= 1; default: all cores)");
    end = app->add_option("--end", end_time, "End time in s, overrides the scene's time.end");
    resolution_option = app->add_option(
        "--resolution", resolution,
        "Refinement factor F > 0: particle_radius / F, about F^3 times the particles");
    app->add_flag("--surface", surface,
                  "When the run ends, write the fluid's surfaces as wake surface DIR does");
    addSurfaceOptions(app, surface_options);
  }

  /// wake surface DIR after the run, with the run's progress settings.
  void surfaceAfter(const wake::RunOptions& run_options) const {
    if (!surface) return;
    wake::SurfaceOptions o = surface_options;
    o.dir = run_options.out_dir;
    o.quiet = run_options.quiet;
    o.interactive = run_options.interactive;
    o.log = run_options.log;
    o.threads = threads;
    wake::surfaceRun(o);
  }

  void execute() const {
    setThreads(threads_option, threads);
    wake::RunOptions options;
    options.quiet = quiet;
    options.interactive = isatty(STDERR_FILENO) != 0;
    options.log = &std::cerr;
    if (resume->count() > 0) {
      for (const CLI::Option* o : {scene, out, end, resolution_option, checkpoint})
        if (o->count() > 0)
          throw wake::SceneError("--resume: " + o->get_name() +
                                 " cannot be given with it (the checkpoint holds the run's)");
      options.out_dir = resume_dir;
      wake::resumeRun(options);
      surfaceAfter(options);
      return;
    }
    if (surface) {  // settings checked before the run, not after it
      try {
        surface_options.settings.check();
      } catch (const std::invalid_argument& e) {
        throw wake::SceneError(e.what());
      }
    }
    if (scene->count() == 0)
      throw wake::SceneError("run: a scene file is required (or --resume DIR)");
    if (out->count() == 0) throw wake::SceneError("--out: an output folder is required");
    if (checkpoint->count() > 0 && (!std::isfinite(checkpoint_every) || !(checkpoint_every > 0)))
      throw wake::SceneError("--checkpoint-every: must be a finite number > 0 (got " +
                             std::to_string(checkpoint_every) + ")");
    wake::SceneFile file = wake::loadScene(scene_path);
    if (end->count() > 0) wake::overrideEndTime(file, end_time, "--end");
    if (resolution_option->count() > 0) wake::overrideResolution(file, resolution, "--resolution");
    options.out_dir = out_dir;
    options.checkpoint_every = checkpoint_every;
    wake::runScene(file, options);
    surfaceAfter(options);
  }
};

/// `wake surface`: the fluid's surfaces (level sets, meshes) and the bodies' meshes.
struct SurfaceCommand {
  CLI::App* app = nullptr;
  wake::SurfaceOptions options;
  int threads = 0;
  CLI::Option* threads_option = nullptr;

  void add(CLI::App& parent) {
    app = parent.add_subcommand(
        "surface",
        "Write the fluid's surface per frame (DIR/surface/fluid_NNNNNN.vdb, .ply) and the "
        "bodies' meshes; add them to DIR/<scene>.xdmf");
    app->add_option("dir", options.dir, "Output folder of wake run (holds <scene>.h5)")->required();
    app->add_option("--scene", options.scene, "Which DIR/NAME.h5 when DIR holds several");
    addSurfaceOptions(app, options);
    app->add_flag("--quiet,-q", options.quiet, "No progress output");
    threads_option = app->add_option("--threads,-j", threads, "Threads (>= 1; default: all)");
  }

  void execute() {
    if (threads_option->count() > 0 && threads < 1)
      throw wake::SceneError("--threads: must be >= 1 (got " + std::to_string(threads) + ")");
    options.threads = threads;
    options.interactive = isatty(STDERR_FILENO) != 0;
    options.log = &std::cerr;
    wake::surfaceRun(options);
  }
};

/// `wake export`: particle caches (binary PLY per frame).
struct ExportCommand {
  CLI::App* app = nullptr;
  wake::ExportOptions options;

  void add(CLI::App& parent) {
    app = parent.add_subcommand(
        "export",
        "Write each frame's particles as a binary PLY point cloud "
        "(DIR/particles/particles_NNNNNN.ply: position, velocity, density, id)");
    app->add_option("dir", options.dir, "Output folder of wake run (holds <scene>.h5)")->required();
    app->add_option("--scene", options.scene, "Which DIR/NAME.h5 when DIR holds several");
    app->add_flag("--quiet,-q", options.quiet, "No progress output");
  }

  void execute() {
    options.interactive = isatty(STDERR_FILENO) != 0;
    options.log = &std::cerr;
    wake::exportParticles(options);
  }
};

/// `wake render`: a run's frames as PNG images.
struct RenderCommand {
  CLI::App* app = nullptr;
  wake::RenderOptions options;
  std::string color = "speed", view = "iso", frames;
  bool quiet = false;
  int threads = 0;
  CLI::Option *frames_option = nullptr, *threads_option = nullptr;

  void add(CLI::App& parent) {
    app = parent.add_subcommand(
        "render", "Draw a run's frames as PNG images (DIR/frames/<scene>_NNNNNN.png)");
    app->add_option("dir", options.dir, "Output folder of wake run (holds <scene>.h5)")->required();
    app->add_option("--out,-o", options.out_dir, "Folder for the PNGs (default DIR/frames)");
    app->add_option("--scene", options.scene, "Which DIR/NAME.h5 when DIR holds several");
    app->add_option("--color", color, "Colour the fluid by speed or depth (default speed)");
    app->add_option("--width", options.width, "Image width in pixels (default 960)");
    app->add_option("--height", options.height, "Image height in pixels (default 540)");
    app->add_option("--view", view, "Camera: iso, front, side or top (default iso)");
    frames_option = app->add_option("--frames", frames, "Frames to draw: A:B (inclusive) or K");
    app->add_option("--every", options.every, "Draw every N-th frame (default 1)");
    app->add_option("--max-speed", options.max_speed,
                    "Speed at the top of the colour ramp, m/s (default: 99th percentile)");
    app->add_flag("--section", options.section,
                  "Cut the fluid in half (the half facing the camera is not drawn)");
    app->add_flag("--particles", options.particles,
                  "Draw the particles even when DIR/surface/ holds the fluid's surface");
    app->add_flag("--video", options.video,
                  "Also write DIR/<scene>.mp4 with ffmpeg (skipped when ffmpeg is missing)");
    app->add_flag("--quiet,-q", quiet, "No progress output");
    threads_option =
        app->add_option("--threads,-j", threads, "OpenMP threads (>= 1; default: all)");
  }

  void execute() {
    setThreads(threads_option, threads);
    options.color = wake::parseRenderColor(color);
    options.view = wake::parseRenderView(view);
    if (frames_option->count() > 0) wake::parseFrameRange(frames, options.first, options.last);
    if (!quiet) options.log = &std::cerr;
    wake::renderRun(options);
  }
};

}  // namespace

int main(int argc, char** argv) {
  wake::mapLargeBlocksApart();
  CLI::App app("Wake: a weakly compressible SPH fluid coupled to rigid bodies by direct forcing.",
               "wake");
  app.set_version_flag("--version", std::string("wake ") + wake::wakeVersion());
  app.require_subcommand(0, 1);  // none: an error below, naming what to type
  RunCommand run;
  run.add(app);
  RenderCommand render;
  render.add(app);
  SurfaceCommand surface;
  surface.add(app);
  ExportCommand export_command;
  export_command.add(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    return fail(kExitBadInput, std::string(e.what()) + " (see wake --help)");
  }
  if (app.get_subcommands().empty())
    return fail(kExitBadInput,
                "a subcommand is required: wake run SCENE.json --out DIR, wake render DIR, "
                "wake surface DIR or wake export DIR (see wake --help)");
  if (render.app->parsed()) return guarded([&] { render.execute(); });
  if (surface.app->parsed()) return guarded([&] { surface.execute(); });
  if (export_command.app->parsed()) return guarded([&] { export_command.execute(); });
  return guarded([&] { run.execute(); });
}
