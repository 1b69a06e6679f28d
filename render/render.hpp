// Headless preview renderer behind `wake render`: reads a run's DIR/<scene>.h5 (layout in
// io/output.hpp) and writes one PNG per frame, FRAMES_DIR/<scene>_NNNNNN.png, with a small
// software rasterizer (z-buffer, perspective camera fitted to the scene, y up).
//
// Fluid particles are shaded sphere impostors (radius: the root attribute particle_radius),
// coloured by speed (a blue-to-white water ramp up to a robust maximum: the largest 99th
// percentile of the frames' speeds, or --max-speed) or by depth (a viridis-like ramp).
// Bodies are their boundary samples (surface_points / surface_normals, carried by each
// frame's pose) drawn as flat splats in the surface's plane, shaded by the sample normal
// (radius 0.75 x the sample spacing, so that they close the surface): dynamic bodies in
// warm colours, kinematic ones
// green, static ones grey. Static bodies that enclose the fluid (a tank) are cut open on the
// camera's side, so the fluid inside stays visible. `section` leaves out the fluid in front
// of the plane through the scene's centre that faces the camera, so submerged bodies show. With
// `video`, ffmpeg (when on PATH) joins the frames into DIR/<scene>.mp4.
#pragma once

#include "sph/types.hpp"

#include <array>
#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

namespace wake {

enum class RenderColor { Speed, Depth };
enum class RenderView { Iso, Front, Side, Top };

struct RenderOptions {
  std::string dir;      ///< a run's output folder (holds <scene>.h5)
  std::string scene;    ///< which <scene>.h5 when DIR holds several; empty: the only one
  std::string out_dir;  ///< where the PNGs go; empty: DIR/frames (created when missing)
  RenderColor color = RenderColor::Speed;
  RenderView view = RenderView::Iso;
  int width = 960;       ///< pixels, in [16, 8192]
  int height = 540;      ///< pixels, in [16, 8192]
  long first = 0;        ///< first frame to render
  long last = -1;        ///< last frame to render (inclusive); < 0: the run's last frame
  long every = 1;        ///< render every N-th frame of [first, last], >= 1
  double max_speed = 0;  ///< m/s at the top of the speed ramp; 0: automatic
  bool video = false;    ///< also DIR/<scene>.mp4 with ffmpeg when it is on PATH
  bool section = false;  ///< draw only the fluid behind the scene's middle (a cut)
  /// Draw the particles even when DIR/surface/surface.h5 (wake surface) holds the fluid's
  /// surface, which is drawn otherwise.
  bool particles = false;
  std::ostream* log = nullptr;  ///< progress and the "video skipped" line; nullptr: none
};

/// The perspective camera of a render (y up).
struct RenderCamera {
  Vec3 eye = Vec3::Zero();
  Vec3 forward = Vec3(0, 0, -1), right = Vec3(1, 0, 0), up = Vec3(0, 1, 0);  ///< unit
  double focal = 1;  ///< pixels: screen offset = focal * lateral / depth
  int width = 0, height = 0;

  /// Pixel coordinates (x right, y down, pixel centres at +0.5) and depth along `forward`
  /// of world point p. Returns false when p is not in front of the camera.
  bool project(const Vec3& p, double& sx, double& sy, double& depth) const;
};

struct RenderResult {
  std::string h5_path;              ///< the file that was read
  std::vector<std::string> images;  ///< PNGs written, in frame order
  std::string video;                ///< DIR/<scene>.mp4, empty when not made
  RenderCamera camera;
  double max_speed = 0;          ///< m/s, top of the speed ramp
  double seconds_per_frame = 0;  ///< wall time of reading + drawing + writing, per frame
};

/// Renders the frames of a run. Throws SceneError (one line naming the option or file)
/// for bad input, std::runtime_error when a file cannot be read or written.
RenderResult renderRun(const RenderOptions& options);

/// Parsers for the command line; throw SceneError naming `option`.
RenderColor parseRenderColor(const std::string& value, const std::string& option = "--color");
RenderView parseRenderView(const std::string& value, const std::string& option = "--view");
/// "A:B" (inclusive) or "K"; sets first and last.
void parseFrameRange(const std::string& value, long& first, long& last,
                     const std::string& option = "--frames");

/// The background colour of row y of an image `height` pixels high (a light gradient).
std::array<std::uint8_t, 3> renderBackground(int y, int height);

}  // namespace wake
