#include "render/raster.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace wake::raster {
namespace {

Rgb ramp(const Rgb* stops, int count, double t) {
  if (!(t > 0)) return stops[0];
  if (t >= 1) return stops[count - 1];
  const double x = t * (count - 1);
  const int i = std::min(static_cast<int>(x), count - 2);
  const float f = static_cast<float>(x - i);
  Rgb c;
  for (int j = 0; j < 3; ++j)
    c[j] = stops[i][j] + f * (stops[i + 1][j] - stops[i][j]);
  return c;
}

/// Where a disc of world radius `radius` at p lands on the image: its projected centre
/// (sx, sy), depth z, pixel radius rp and pixel box [x0, x1] x [y0, y1].
struct Footprint {
  double sx = 0, sy = 0, z = 0, rp = 0;
  int x0 = 0, x1 = -1, y0 = 0, y1 = -1;
};

/// False when the disc is behind the camera or off the image.
bool footprint(const Image& im, const RenderCamera& cam, const Vec3& p, double radius,
               Footprint& f) {
  if (!cam.project(p, f.sx, f.sy, f.z) || f.z <= radius) return false;
  f.rp = std::max(0.7, cam.focal * radius / f.z);
  f.x0 = std::max(0, static_cast<int>(std::floor(f.sx - f.rp)));
  f.x1 = std::min(im.width - 1, static_cast<int>(std::ceil(f.sx + f.rp)));
  f.y0 = std::max(0, static_cast<int>(std::floor(f.sy - f.rp)));
  f.y1 = std::min(im.height - 1, static_cast<int>(std::ceil(f.sy + f.rp)));
  return f.x0 <= f.x1 && f.y0 <= f.y1;
}

}  // namespace

std::uint8_t toByte(float v) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f));
}

void Image::clear() {
  rgb.resize(static_cast<std::size_t>(width) * height * 3);
  depth.assign(static_cast<std::size_t>(width) * height, std::numeric_limits<float>::infinity());
  for (int y = 0; y < height; ++y) {
    const std::array<std::uint8_t, 3> bg = renderBackground(y, height);
    std::uint8_t* row = &rgb[static_cast<std::size_t>(y) * width * 3];
    for (int x = 0; x < width; ++x)
      for (int j = 0; j < 3; ++j)
        row[3 * x + j] = bg[j];
  }
}

Rgb waterRamp(double t) {
  static const Rgb stops[] = {
      {0.05f, 0.20f, 0.52f}, {0.10f, 0.42f, 0.82f}, {0.38f, 0.74f, 0.96f}, {0.93f, 0.97f, 1.00f}};
  return ramp(stops, 4, t);
}

Rgb viridisRamp(double t) {
  static const Rgb stops[] = {{0.267f, 0.005f, 0.329f},
                              {0.229f, 0.322f, 0.546f},
                              {0.128f, 0.567f, 0.551f},
                              {0.369f, 0.789f, 0.383f},
                              {0.993f, 0.906f, 0.144f}};
  return ramp(stops, 5, t);
}

Rgb bodyColor(const std::string& kind, std::size_t nth_of_kind) {
  static const Rgb warm[] = {{0.93f, 0.45f, 0.12f},
                             {0.85f, 0.18f, 0.15f},
                             {0.95f, 0.70f, 0.10f},
                             {0.78f, 0.25f, 0.45f},
                             {0.70f, 0.35f, 0.10f}};
  static const Rgb kinematic[] = {{0.25f, 0.65f, 0.30f}, {0.45f, 0.30f, 0.70f}};
  static const Rgb grey[] = {{0.80f, 0.80f, 0.82f}, {0.68f, 0.69f, 0.71f}, {0.86f, 0.85f, 0.80f}};
  if (kind == "static") return grey[nth_of_kind % 3];
  if (kind == "kinematic") return kinematic[nth_of_kind % 2];
  return warm[nth_of_kind % 5];
}

/// Writes colour `rgb` at pixel `at` when `depth` is nearer than what is there.
static void plot(Image& im, std::size_t at, float depth, const std::array<std::uint8_t, 3>& rgb) {
  if (depth >= im.depth[at]) return;
  im.depth[at] = depth;
  std::uint8_t* out = &im.rgb[3 * at];
  out[0] = rgb[0];
  out[1] = rgb[1];
  out[2] = rgb[2];
}

void drawSphere(Image& im, const RenderCamera& cam, const Light& light, const Vec3& p,
                double radius, const Rgb& color) {
  Footprint fp;
  if (!footprint(im, cam, p, radius, fp)) return;
  const double sx = fp.sx, sy = fp.sy, z = fp.z, rp = fp.rp;
  const int x0 = fp.x0, x1 = fp.x1, y0 = fp.y0, y1 = fp.y1;
  const double inv = 1.0 / rp;
  for (int y = y0; y <= y1; ++y) {
    const double dy = (y + 0.5 - sy) * inv;
    for (int x = x0; x <= x1; ++x) {
      const double dx = (x + 0.5 - sx) * inv;
      const double d2 = dx * dx + dy * dy;
      if (d2 >= 1.0) continue;
      const double nz = std::sqrt(1.0 - d2);
      const float depth = static_cast<float>(z - radius * nz);
      const std::size_t at = static_cast<std::size_t>(y) * im.width + x;
      if (depth >= im.depth[at]) continue;
      im.depth[at] = depth;
      const Vec3 n(dx, -dy, -nz);
      const double lambert = std::max(0.0, n.dot(light.dir));
      const double spec = std::pow(std::max(0.0, n.dot(light.half)), 40.0);
      const float shade = static_cast<float>(0.38 + 0.62 * lambert);
      const float highlight = static_cast<float>(0.35 * spec);
      std::uint8_t* out = &im.rgb[3 * at];
      for (int j = 0; j < 3; ++j)
        out[j] = toByte(color[j] * shade + highlight);
    }
  }
}

void drawSplat(Image& im, const RenderCamera& cam, const Light& light, const Vec3& p, double radius,
               const Vec3& n, const Rgb& color) {
  Footprint fp;
  if (!footprint(im, cam, p, radius, fp)) return;
  const double sx = fp.sx, sy = fp.sy, z = fp.z;
  const int x0 = fp.x0, x1 = fp.x1, y0 = fp.y0, y1 = fp.y1;
  // Camera coordinates (x right, y up, z forward): the splat's centre c and normal m.
  const Vec3 c(z * (sx - 0.5 * im.width) / cam.focal, -z * (sy - 0.5 * im.height) / cam.focal, z);
  Vec3 m(n.dot(cam.right), n.dot(cam.up), n.dot(cam.forward));
  if (m.z() > 0) m = -m;  // two-sided: the face towards the viewer
  const double lambert = std::max(0.0, m.dot(light.dir));
  const float shade = static_cast<float>(0.42 + 0.58 * lambert);
  const std::array<std::uint8_t, 3> rgb = {toByte(color[0] * shade), toByte(color[1] * shade),
                                           toByte(color[2] * shade)};
  const double mc = m.dot(c), r2 = radius * radius, inv_f = 1.0 / cam.focal;
  const double hw = 0.5 * im.width, hh = 0.5 * im.height;
  for (int y = y0; y <= y1; ++y) {
    const double ry = -(y + 0.5 - hh) * inv_f;
    for (int x = x0; x <= x1; ++x) {
      const double rx = (x + 0.5 - hw) * inv_f;
      // The pixel's ray is t * (rx, ry, 1); it meets the splat's plane at t = depth.
      const double mr = m.x() * rx + m.y() * ry + m.z();
      if (std::abs(mr) < 1e-3) continue;
      const double t = mc / mr;
      const double ex = t * rx - c.x(), ey = t * ry - c.y(), ez = t - c.z();
      if (t <= 0 || ex * ex + ey * ey + ez * ez >= r2) continue;
      const std::size_t at = static_cast<std::size_t>(y) * im.width + x;
      const float depth = static_cast<float>(t);
      plot(im, at, depth, rgb);
    }
  }
}

void drawTriangle(Image& im, const RenderCamera& cam, const Light& light, const Vec3& a,
                  const Vec3& b, const Vec3& c, const Rgb& color) {
  double x[3], y[3], z[3];
  const Vec3* v[3] = {&a, &b, &c};
  for (int i = 0; i < 3; ++i)
    if (!cam.project(*v[i], x[i], y[i], z[i])) return;
  const double area = (x[1] - x[0]) * (y[2] - y[0]) - (x[2] - x[0]) * (y[1] - y[0]);
  if (std::abs(area) < 1e-12) return;
  // Shading from the face normal in camera coordinates, turned towards the viewer.
  const Vec3 n = (b - a).cross(c - a).normalized();
  Vec3 m(n.dot(cam.right), n.dot(cam.up), n.dot(cam.forward));
  if (m.z() > 0) m = -m;
  const double lambert = std::max(0.0, m.dot(light.dir));
  const double spec = std::pow(std::max(0.0, m.dot(light.half)), 60.0);
  const float shade = static_cast<float>(0.30 + 0.70 * lambert);
  const float highlight = static_cast<float>(0.45 * spec);
  const std::array<std::uint8_t, 3> rgb = {toByte(color[0] * shade + highlight),
                                           toByte(color[1] * shade + highlight),
                                           toByte(color[2] * shade + highlight)};
  const int x0 = std::max(0, static_cast<int>(std::floor(std::min({x[0], x[1], x[2]}))));
  const int x1 = std::min(im.width - 1, static_cast<int>(std::ceil(std::max({x[0], x[1], x[2]}))));
  const int y0 = std::max(0, static_cast<int>(std::floor(std::min({y[0], y[1], y[2]}))));
  const int y1 = std::min(im.height - 1, static_cast<int>(std::ceil(std::max({y[0], y[1], y[2]}))));
  const double inv = 1.0 / area;
  for (int py = y0; py <= y1; ++py) {
    const double cy = py + 0.5;
    for (int px = x0; px <= x1; ++px) {
      const double cx = px + 0.5;
      // Barycentric weights of the pixel centre (screen space).
      const double w0 = ((x[1] - cx) * (y[2] - cy) - (x[2] - cx) * (y[1] - cy)) * inv;
      const double w1 = ((x[2] - cx) * (y[0] - cy) - (x[0] - cx) * (y[2] - cy)) * inv;
      const double w2 = 1.0 - w0 - w1;
      if (w0 < 0 || w1 < 0 || w2 < 0) continue;
      const float depth = static_cast<float>(w0 * z[0] + w1 * z[1] + w2 * z[2]);
      const std::size_t at = static_cast<std::size_t>(py) * im.width + px;
      plot(im, at, depth, rgb);
    }
  }
}

}  // namespace wake::raster
