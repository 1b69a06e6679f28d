// The preview renderer's drawing (render.cpp draws frames with it): colour ramps, an
// image with a depth buffer, shaded sphere impostors (fluid particles), flat surface
// splats (body samples) and shaded triangles (the fluid's surface meshes), all in the perspective
// camera of render.hpp.
#pragma once

#include "render/render.hpp"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace wake::raster {

using Rgb = std::array<float, 3>;

/// A colour channel in [0, 1] (clamped) as a byte.
std::uint8_t toByte(float v);
/// Deep blue (still) to near white (fast), t in [0, 1].
Rgb waterRamp(double t);
/// Viridis-like: purple (near) to yellow (far), t in [0, 1].
Rgb viridisRamp(double t);
/// A body's colour by kind ("static" greys, "kinematic" greens and purples, dynamic warm
/// colours), the nth of its kind.
Rgb bodyColor(const std::string& kind, std::size_t nth_of_kind);

/// An RGB image with a depth buffer (float, camera depth).
struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
  std::vector<float> depth;
  /// Sizes the buffers to width x height, fills the background, clears the depth.
  void clear();
};

/// The light, in camera coordinates (x right, y up, z away from the viewer).
struct Light {
  Vec3 dir = Vec3(-0.35, 0.75, -0.55).normalized();
  Vec3 half = (Vec3(-0.35, 0.75, -0.55).normalized() + Vec3(0, 0, -1)).normalized();
};

/// A sphere impostor of world radius `radius` at p: per-pixel sphere normal and depth.
void drawSphere(Image& im, const RenderCamera& cam, const Light& light, const Vec3& p,
                double radius, const Rgb& color);
/// A surface splat: a disc of world radius `radius` at p in the plane normal to n (world),
/// ray-traced per pixel so that surfaces seen at a slant stay flat; shaded with n.
void drawSplat(Image& im, const RenderCamera& cam, const Light& light, const Vec3& p, double radius,
               const Vec3& n, const Rgb& color);

/// A flat triangle (world vertices a, b, c), shaded two-sided with its face normal
/// (Lambert and a specular highlight), depth-tested per pixel.
void drawTriangle(Image& im, const RenderCamera& cam, const Light& light, const Vec3& a,
                  const Vec3& b, const Vec3& c, const Rgb& color);

}  // namespace wake::raster
