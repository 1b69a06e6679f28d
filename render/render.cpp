// Software preview renderer: HDF5 in (C API), PNG out (stb_image_write). See render.hpp.
#include "render/render.hpp"

#include "io/hdf5_handle.hpp"
#include "io/run_file.hpp"
#include "render/raster.hpp"

#include "io/scene.hpp"

#include <hdf5.h>
#include <omp.h>
#include <stb/stb_image_write.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <limits>
#include <memory>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace wake {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using raster::bodyColor;
using raster::drawSphere;
using raster::drawSplat;
using raster::Image;
using raster::Light;
using raster::Rgb;
using raster::toByte;
using raster::viridisRamp;
using raster::waterRamp;

// ---------------------------------------------------------------------------------------
// Scene statistics and the camera.

/// Value at quantile q in [0, 1] of `v` (reordered).
double quantile(std::vector<double>& v, double q) {
  if (v.empty()) return 0.0;
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(q * (v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

/// Robust bounds of a particle cloud: per axis the 0.2 % and 99.8 % quantiles.
Aabb robustBounds(const std::vector<Vec3>& x) {
  Aabb box;
  if (x.empty()) return box;
  std::vector<double> v(x.size());
  for (int axis = 0; axis < 3; ++axis) {
    for (std::size_t i = 0; i < x.size(); ++i)
      v[i] = x[i][axis];
    box.min[axis] = quantile(v, 0.01);  // splashes are not what the camera should frame
    box.max[axis] = quantile(v, 0.99);
  }
  return box;
}

Vec3 viewDirection(RenderView view) {  // from the scene's centre towards the eye
  switch (view) {
    case RenderView::Front:
      return Vec3(0, 0, 1);
    case RenderView::Side:
      return Vec3(1, 0, 0);
    case RenderView::Top:
      return Vec3(0, 1, 0);
    case RenderView::Iso:
      break;
  }
  return Vec3(0.55, 0.62, 1.0).normalized();
}

RenderCamera fitCamera(const Aabb& box, RenderView view, int width, int height) {
  RenderCamera cam;
  cam.width = width;
  cam.height = height;
  const Vec3 d = viewDirection(view);
  const Vec3 world_up = view == RenderView::Top ? Vec3(0, 0, -1) : Vec3(0, 1, 0);
  cam.forward = -d;
  cam.right = cam.forward.cross(world_up).normalized();
  cam.up = cam.right.cross(cam.forward).normalized();
  const double tan_v = std::tan(0.5 * 35.0 * M_PI / 180.0);
  const double tan_h = tan_v * width / height;
  cam.focal = 0.5 * height / tan_v;
  const Vec3 centre = 0.5 * (box.min + box.max);
  const double size = std::max((box.max - box.min).norm(), 1e-6);
  double distance = 0.0;
  for (int k = 0; k < 8; ++k) {
    const Vec3 q = box.corner(k) - centre;
    const double towards = q.dot(d);
    distance = std::max(distance, towards + std::abs(q.dot(cam.right)) / tan_h);
    distance = std::max(distance, towards + std::abs(q.dot(cam.up)) / tan_v);
  }
  distance = std::max(distance * 1.06, 0.6 * size);
  cam.eye = centre + distance * d;
  return cam;
}

/// Everything that stays the same over the frames of one render.
struct Plan {
  RenderCamera camera;
  Light light;
  double radius = 0;       ///< fluid particle radius, m
  double body_radius = 0;  ///< radius of a drawn body sample, m
  double max_speed = 1;
  double near_depth = 0, far_depth = 1;  ///< depth ramp range
  double section_depth = -1;  ///< fluid nearer than this depth is not drawn; < 0: all drawn
  RenderColor color = RenderColor::Speed;
  std::vector<RunBody> bodies;
  std::vector<Rgb> body_colors;
  std::vector<std::vector<std::uint8_t>> visible;  ///< per static body sample (cut-away)
  std::unique_ptr<RunFile> surface;  ///< DIR/surface/surface.h5: draw the fluid's surface
};

/// The fluid's surface, shaded in a water colour (the cut of --section drops the
/// triangles in front of it).
void drawSurface(const Plan& plan, const SurfaceMesh& mesh, Image& im) {
  const RenderCamera& cam = plan.camera;
  const Rgb water = {0.16f, 0.46f, 0.86f};
  for (const auto& t : mesh.triangles) {
    const Vec3 &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
    if (plan.section_depth > 0 &&
        ((a + b + c) / 3.0 - cam.eye).dot(cam.forward) < plan.section_depth)
      continue;
    raster::drawTriangle(im, cam, plan.light, a, b, c, water);
  }
}

void renderFrame(const Plan& plan, const RunFrame& frame, Image& im) {
  im.clear();
  const RenderCamera& cam = plan.camera;
  for (std::size_t b = 0; b < plan.bodies.size(); ++b) {
    const RunBody& body = plan.bodies[b];
    const Pose pose = body.pose(frame.index);
    const std::vector<std::uint8_t>& visible = plan.visible[b];
    if (visible.empty() && !body.mesh.triangles.empty()) {  // its exact mesh, when written
      for (const auto& t : body.mesh.triangles)
        raster::drawTriangle(im, cam, plan.light, pose.toWorld(body.mesh.vertices[t[0]]),
                             pose.toWorld(body.mesh.vertices[t[1]]),
                             pose.toWorld(body.mesh.vertices[t[2]]), plan.body_colors[b]);
      continue;
    }
    for (std::size_t k = 0; k < body.points.size(); ++k) {
      if (!visible.empty() && !visible[k]) continue;
      drawSplat(im, cam, plan.light, pose.toWorld(body.points[k]), plan.body_radius,
                pose.rotate(body.normals[k]), plan.body_colors[b]);
    }
  }
  if (plan.surface) {
    drawSurface(plan, frame.surface, im);
    return;
  }
  const bool by_speed =
      plan.color == RenderColor::Speed && frame.velocity.size() == frame.position.size();
  const double depth_scale = 1.0 / std::max(1e-12, plan.far_depth - plan.near_depth);
  for (std::size_t i = 0; i < frame.position.size(); ++i) {
    const Vec3& p = frame.position[i];
    if (plan.section_depth > 0 && (p - cam.eye).dot(cam.forward) < plan.section_depth) continue;
    Rgb color;
    if (by_speed) {
      color = waterRamp(frame.velocity[i].norm() / plan.max_speed);
    } else {
      color = viridisRamp(((p - cam.eye).dot(cam.forward) - plan.near_depth) * depth_scale);
    }
    drawSphere(im, cam, plan.light, p, plan.radius, color);
  }
}

// ---------------------------------------------------------------------------------------
// Files and ffmpeg.

std::string findH5(const RenderOptions& o) {
  std::error_code ec;
  if (!fs::is_directory(o.dir, ec))
    throw SceneError(o.dir + ": not a folder (wake render DIR: the --out folder of wake run)");
  if (!o.scene.empty()) {
    const fs::path p = fs::path(o.dir) / (o.scene + ".h5");
    if (!fs::is_regular_file(p, ec)) throw SceneError("--scene: " + p.string() + " does not exist");
    return p.string();
  }
  std::vector<std::string> found;
  for (const fs::directory_entry& e : fs::directory_iterator(o.dir, ec))
    if (e.path().extension() == ".h5" && e.is_regular_file(ec)) found.push_back(e.path().string());
  std::sort(found.begin(), found.end());
  if (found.empty())
    throw SceneError(o.dir + ": no <scene>.h5 file in this folder (run wake run first)");
  if (found.size() > 1)
    throw SceneError(o.dir + ": " + std::to_string(found.size()) +
                     " .h5 files in this folder; pick one with --scene NAME");
  return found.front();
}

std::string shellQuote(const std::string& s) {
  std::string out = "'";
  for (const char c : s) {
    if (c == '\'')
      out += "'\\''";
    else
      out += c;
  }
  return out + "'";
}

bool onPath(const std::string& program) {
  const char* path = std::getenv("PATH");
  if (!path) return false;
  std::stringstream dirs(path);
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    if (dir.empty()) dir = ".";
    const std::string candidate = dir + "/" + program;
    if (access(candidate.c_str(), X_OK) == 0) return true;
  }
  return false;
}

std::string frameFile(const std::string& out_dir, const std::string& scene, std::size_t k) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "_%06zu.png", k);
  return (fs::path(out_dir) / (scene + buf)).string();
}

// ---------------------------------------------------------------------------------------
// The stages of a render.

void checkOptions(const RenderOptions& o) {
  if (o.width < 16 || o.width > 8192)
    throw SceneError("--width: must be in [16, 8192] pixels (got " + std::to_string(o.width) + ")");
  if (o.height < 16 || o.height > 8192)
    throw SceneError("--height: must be in [16, 8192] pixels (got " + std::to_string(o.height) +
                     ")");
  if (o.every < 1) throw SceneError("--every: must be >= 1 (got " + std::to_string(o.every) + ")");
  if (!(o.max_speed >= 0) || !std::isfinite(o.max_speed))
    throw SceneError("--max-speed: must be a finite speed > 0 in m/s");
}

/// The fluid's bounds and speed scale over up to 48 frames spread over the whole run (not
/// only the rendered ones, so that every render of a run has the same camera and colour
/// scale).
struct RunStatistics {
  Aabb fluid_box;          ///< over the sampled frames
  Aabb start_box;          ///< at frame 0
  double speed_scale = 0;  ///< largest 99th percentile of the speeds (when asked)
};

RunStatistics sampleRun(const RunFile& file, std::size_t frames, bool speeds_too) {
  RunStatistics stats;
  const std::size_t samples = std::min<std::size_t>(frames, 48);
  RunFrame f;
  std::vector<double> speeds;
  for (std::size_t s = 0; s < samples; ++s) {
    const std::size_t k = samples == 1 ? 0 : s * (frames - 1) / (samples - 1);
    file.readFrame(k, f, true, speeds_too);
    const Aabb bounds = robustBounds(f.position);
    stats.fluid_box.extend(bounds);
    if (k == 0) stats.start_box = bounds;
    if (speeds_too && !f.velocity.empty()) {
      speeds.resize(f.velocity.size());
      for (std::size_t i = 0; i < speeds.size(); ++i)
        speeds[i] = f.velocity[i].norm();
      stats.speed_scale = std::max(stats.speed_scale, quantile(speeds, 0.99));
    }
  }
  return stats;
}

/// The camera's box: the fluid, the moving bodies wherever they go, static bodies that
/// hold them (a tank) and the parts of other static bodies near them (an infinite plane
/// is sampled over the whole domain). `static_bounds` (bodies): each static body's bounds.
Aabb cameraBox(const Plan& plan, const Aabb& fluid_box, std::vector<Aabb>& static_bounds) {
  Aabb box = fluid_box;
  static_bounds.assign(plan.bodies.size(), Aabb());
  for (std::size_t b = 0; b < plan.bodies.size(); ++b) {
    const RunBody& body = plan.bodies[b];
    Aabb local;
    for (const Vec3& p : body.points)
      local.extend(p);
    if (local.empty()) continue;
    if (body.kind == "static") {
      static_bounds[b] = transformBounds(local, body.pose(0), true);
    } else {
      const std::size_t n = std::max<std::size_t>(body.position.size(), 1);
      for (std::size_t k = 0; k < n; k += std::max<std::size_t>(1, n / 64))
        box.extend(transformBounds(local, body.pose(k), true));
      box.extend(transformBounds(local, body.pose(n - 1), true));
    }
  }
  if (box.empty()) {  // no fluid and no moving body
    for (const Aabb& s : static_bounds)
      box.extend(s);
  } else {
    const double grow = std::max((box.max - box.min).maxCoeff(), 4 * plan.radius);
    Aabb reach = box;
    reach.min.array() -= grow;
    reach.max.array() += grow;
    const Vec3 centre = 0.5 * (box.min + box.max);
    for (const Aabb& s : static_bounds) {
      if (s.empty()) continue;
      if (s.contains(centre)) {  // a container (tank): all of it
        box.extend(s);
        continue;
      }
      Aabb clipped;
      clipped.min = s.min.cwiseMax(reach.min);
      clipped.max = s.max.cwiseMin(reach.max);
      box.extend(clipped);
    }
  }
  if (box.empty()) box.extend(Vec3::Zero());
  box.min.array() -= plan.radius;
  box.max.array() += plan.radius;
  return box;
}

/// The camera fitted to `box`, the section plane and the depth ramp's range (the fluid's).
void placeCamera(Plan& plan, const Aabb& box, const Aabb& fluid_box, const RenderOptions& o) {
  plan.camera = fitCamera(box, o.view, o.width, o.height);
  // A section through the middle of the scene, facing the camera: bodies under water show.
  if (o.section)
    plan.section_depth = (0.5 * (box.min + box.max) - plan.camera.eye).dot(plan.camera.forward);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (int k = 0; k < 8; ++k) {
    const double z = (fluid_box.empty() ? box : fluid_box).corner(k).dot(plan.camera.forward) -
                     plan.camera.eye.dot(plan.camera.forward);
    lo = std::min(lo, z);
    hi = std::max(hi, z);
  }
  plan.near_depth = lo;
  plan.far_depth = hi;
}

/// Colours, and the cut-away of containers: a static body whose bounds hold the centre of
/// the fluid at the start loses the samples on the camera's side of its own centre (along
/// each sample's normal), e.g. a tank keeps its floor and back walls but not its front wall.
void colourBodies(Plan& plan, const std::vector<Aabb>& static_bounds, const Vec3& fluid_centre) {
  std::size_t counts[3] = {0, 0, 0};
  plan.visible.resize(plan.bodies.size());
  for (std::size_t b = 0; b < plan.bodies.size(); ++b) {
    const RunBody& body = plan.bodies[b];
    const int kind = body.kind == "static" ? 0 : body.kind == "kinematic" ? 1 : 2;
    plan.body_colors.push_back(bodyColor(body.kind, counts[kind]++));
    const Aabb& s = static_bounds[b];
    if (kind != 0 || s.empty() || !s.contains(fluid_centre)) continue;
    const Vec3 centre = 0.5 * (s.min + s.max);
    const Vec3 to_eye = (plan.camera.eye - centre).normalized();
    const Pose pose = body.pose(0);
    std::vector<std::uint8_t>& visible = plan.visible[b];
    visible.assign(body.points.size(), 1);
    for (std::size_t k = 0; k < body.points.size(); ++k) {
      const Vec3 n = pose.rotate(body.normals[k]);
      const double facing = n.dot(to_eye);
      const double side = n.dot(pose.toWorld(body.points[k]) - centre);
      if (std::abs(facing) > 0.2 && facing * side > 0) visible[k] = 0;
    }
  }
}

/// Draws the `selected` frames into out_dir: read in batches on one thread, drawn and
/// written in parallel. Appends the images' paths to `images`.
void drawFrames(const RunFile& file, const Plan& plan, const RenderOptions& o,
                const std::string& out_dir, const std::string& scene,
                const std::vector<std::size_t>& selected, std::vector<std::string>& images) {
  const std::size_t batch = static_cast<std::size_t>(std::max(1, 2 * omp_get_max_threads()));
  std::vector<RunFrame> data;
  std::vector<std::string> errors;
  for (std::size_t b0 = 0; b0 < selected.size(); b0 += batch) {
    const std::size_t n = std::min(batch, selected.size() - b0);
    data.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      file.readFrame(selected[b0 + i], data[i], !plan.surface, o.color == RenderColor::Speed);
      data[i].index = selected[b0 + i];
      if (plan.surface) plan.surface->readSurface(selected[b0 + i], data[i].surface);
    }
    errors.assign(n, std::string());
#pragma omp parallel
    {
      Image im;
      im.width = o.width;
      im.height = o.height;
#pragma omp for schedule(dynamic, 1)
      for (long i = 0; i < static_cast<long>(n); ++i) {
        try {
          renderFrame(plan, data[static_cast<std::size_t>(i)], im);
          const std::string path =
              frameFile(out_dir, scene, data[static_cast<std::size_t>(i)].index);
          if (stbi_write_png(path.c_str(), im.width, im.height, 3, im.rgb.data(), im.width * 3) ==
              0)
            errors[static_cast<std::size_t>(i)] = "cannot write " + path;
        } catch (const std::exception& e) {
          errors[static_cast<std::size_t>(i)] = e.what();
        }
      }
    }
    for (std::size_t i = 0; i < n; ++i) {
      if (!errors[i].empty()) throw std::runtime_error(errors[i]);
      images.push_back(frameFile(out_dir, scene, data[i].index));
    }
  }
}

/// DIR/<scene>.mp4 from the frames with ffmpeg (skipped, with a line, when it is not on
/// PATH). ffmpeg reads a numbered sequence without gaps: with --every > 1 it gets one made
/// of links in a scratch folder.
void writeVideo(const RenderOptions& o, const std::string& out_dir, const std::string& scene,
                std::size_t first_frame, double frame_rate, RenderResult& result) {
  if (!onPath("ffmpeg")) {
    if (o.log) *o.log << "[wake] video skipped: ffmpeg is not on PATH" << std::endl;
    return;
  }
  std::error_code ec;
  std::string pattern = (fs::path(out_dir) / (scene + "_%06d.png")).string();
  double rate = frame_rate > 0 ? frame_rate : 30.0;
  std::size_t start_number = first_frame;
  const fs::path links = fs::path(out_dir) / (".video_" + scene);
  if (o.every > 1) {
    fs::remove_all(links, ec);
    fs::create_directories(links, ec);
    for (std::size_t i = 0; i < result.images.size(); ++i)
      fs::create_symlink(fs::absolute(result.images[i], ec), frameFile(links, scene, i), ec);
    pattern = (links / (scene + "_%06d.png")).string();
    rate /= static_cast<double>(o.every);
    start_number = 0;
  }
  const std::string video = (fs::path(o.dir) / (scene + ".mp4")).string();
  std::ostringstream cmd;
  cmd << "ffmpeg -y -loglevel error -framerate " << rate << " -start_number " << start_number
      << " -i " << shellQuote(pattern) << " -frames:v " << result.images.size()
      << " -pix_fmt yuv420p -vf 'pad=ceil(iw/2)*2:ceil(ih/2)*2' " << shellQuote(video);
  const int status = std::system(cmd.str().c_str());
  if (o.every > 1) fs::remove_all(links, ec);
  if (status != 0) throw std::runtime_error("ffmpeg failed to write " + video);
  result.video = video;
  if (o.log) *o.log << "[wake] video " << video << std::endl;
}

}  // namespace

// ---------------------------------------------------------------------------------------

bool RenderCamera::project(const Vec3& p, double& sx, double& sy, double& depth) const {
  const Vec3 v = p - eye;
  depth = v.dot(forward);
  if (depth <= 1e-9) return false;
  sx = 0.5 * width + focal * v.dot(right) / depth;
  sy = 0.5 * height - focal * v.dot(up) / depth;
  return true;
}

std::array<std::uint8_t, 3> renderBackground(int y, int height) {
  const float t = height > 1 ? static_cast<float>(y) / static_cast<float>(height - 1) : 0.0f;
  const Rgb top = {0.96f, 0.97f, 0.99f}, bottom = {0.80f, 0.84f, 0.89f};
  return {toByte(top[0] + t * (bottom[0] - top[0])), toByte(top[1] + t * (bottom[1] - top[1])),
          toByte(top[2] + t * (bottom[2] - top[2]))};
}

RenderColor parseRenderColor(const std::string& value, const std::string& option) {
  if (value == "speed") return RenderColor::Speed;
  if (value == "depth") return RenderColor::Depth;
  throw SceneError(option + ": must be speed or depth (got \"" + value + "\")");
}

RenderView parseRenderView(const std::string& value, const std::string& option) {
  if (value == "iso") return RenderView::Iso;
  if (value == "front") return RenderView::Front;
  if (value == "side") return RenderView::Side;
  if (value == "top") return RenderView::Top;
  throw SceneError(option + ": must be iso, front, side or top (got \"" + value + "\")");
}

void parseFrameRange(const std::string& value, long& first, long& last, const std::string& option) {
  auto number = [&](const std::string& s) {
    std::size_t used = 0;
    long v = -1;
    try {
      v = std::stol(s, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (s.empty() || used != s.size() || v < 0)
      throw SceneError(option +
                       ": expected a frame K or a range A:B of frame numbers >= 0 (got \"" + value +
                       "\")");
    return v;
  };
  const auto colon = value.find(':');
  if (colon == std::string::npos) {
    first = last = number(value);
    return;
  }
  first = number(value.substr(0, colon));
  last = number(value.substr(colon + 1));
  if (last < first) throw SceneError(option + ": the range " + value + " ends before it starts");
}

RenderResult renderRun(const RenderOptions& o) {
  const Clock::time_point start = Clock::now();
  const hdf5::QuietHdf5Errors quiet;
  checkOptions(o);
  RenderResult result;
  result.h5_path = findH5(o);
  const RunFile file(result.h5_path);
  const std::string scene = fs::path(result.h5_path).stem().string();  // names the frames
  const std::size_t frames = file.frameCount();
  if (frames == 0) throw SceneError(result.h5_path + ": the run has no frames");
  const long last_frame = static_cast<long>(frames) - 1;
  const long first = o.first;
  const long last = o.last < 0 ? last_frame : o.last;
  if (first > last_frame || last > last_frame)
    throw SceneError("--frames: frame " + std::to_string(std::max(first, last)) +
                     " is out of range (" + result.h5_path + " has frames 0.." +
                     std::to_string(last_frame) + ")");

  std::error_code ec;
  Plan plan;
  plan.color = o.color;
  plan.radius = file.rootDouble("particle_radius", 0.01);
  if (!(plan.radius > 0)) plan.radius = 0.01;
  // Body samples lie on a lattice of the fluid's spacing 2r: splats of radius 0.75 * 2r
  // close the surface.
  plan.body_radius = 1.5 * plan.radius;
  plan.bodies = file.readBodies();
  const std::string surface = (fs::path(o.dir) / "surface" / "surface.h5").string();
  if (!o.particles && fs::is_regular_file(surface, ec)) {
    plan.surface = std::make_unique<RunFile>(surface);
    if (plan.surface->frameCount() != frames)
      throw SceneError(surface + " has " + std::to_string(plan.surface->frameCount()) +
                       " frames, the run " + std::to_string(frames) +
                       ": run wake surface again (or draw the particles: --particles)");
  }
  const RunStatistics stats = sampleRun(file, frames, o.max_speed == 0);
  plan.max_speed = o.max_speed > 0 ? o.max_speed : std::max(stats.speed_scale, 0.05);
  result.max_speed = plan.max_speed;
  std::vector<Aabb> static_bounds;
  const Aabb box = cameraBox(plan, stats.fluid_box, static_bounds);
  placeCamera(plan, box, stats.fluid_box, o);
  result.camera = plan.camera;
  const Aabb& held = stats.start_box.empty() ? stats.fluid_box : stats.start_box;
  colourBodies(plan, static_bounds,
               held.empty() ? 0.5 * (box.min + box.max) : Vec3(0.5 * (held.min + held.max)));

  const std::string out_dir = o.out_dir.empty() ? (fs::path(o.dir) / "frames").string() : o.out_dir;
  fs::create_directories(out_dir, ec);
  if (!fs::is_directory(out_dir, ec))
    throw SceneError("--out: cannot create the folder " + out_dir);
  std::vector<std::size_t> selected;
  for (long k = first; k <= last; k += o.every)
    selected.push_back(static_cast<std::size_t>(k));
  drawFrames(file, plan, o, out_dir, scene, selected, result.images);
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  result.seconds_per_frame = seconds / static_cast<double>(selected.size());
  if (o.log) {
    char line[160];
    std::snprintf(line, sizeof(line), "%zu frame%s, %.0f ms per frame, speed scale %.3g m/s",
                  selected.size(), selected.size() == 1 ? "" : "s",
                  1000.0 * result.seconds_per_frame, plan.max_speed);
    *o.log << "[wake] rendered " << out_dir << "/" << scene << "_*.png: " << line << std::endl;
  }
  if (o.video)
    writeVideo(o, out_dir, scene, selected.front(), file.rootDouble("frame_rate", 30.0), result);
  return result;
}

}  // namespace wake
