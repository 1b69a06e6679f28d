// `wake surface DIR` and `wake export DIR` (README "Output"): files for renderers and DCC
// tools from the output of a finished `wake run` in DIR.
//
// wake surface writes into DIR/surface/, per frame NNNNNN:
//   fluid_NNNNNN.vdb   the fluid's narrow-band level set (OpenVDB FloatGrid "fluid", < 0 inside)
//   fluid_NNNNNN.ply   its surface mesh, binary PLY (and fluid_NNNNNN.obj with obj = true)
//   <body>_NNNNNN.ply  each moving body's mesh at the frame's pose; static bodies once as
//                      <body>.ply
// and surface.h5 (/frames/NNNNNN/vertices (V x 3 float, m), triangles (T x 3 uint32)),
// surface.json (the settings; per frame its time, particle count, and each mesh file with
// its vertex and triangle counts and bounds: what importers check against), then rewrites
// DIR/<scene>.xdmf so the surface is a grid of every time step.
// wake export writes DIR/particles/particles_NNNNNN.ply: binary PLY point clouds with
// position, velocity, density and id (io/mesh_files.hpp).
// Every file is written under a temporary name and renamed when complete.
#pragma once

#include "surface/surface_settings.hpp"

#include <cstddef>
#include <iosfwd>
#include <string>

namespace wake {

struct SurfaceOptions {
  std::string dir;    ///< the output folder of a finished run
  std::string scene;  ///< which DIR/<scene>.h5 when DIR holds several ("": the one)
  SurfaceSettings settings;
  bool vdb = true;              ///< write the level sets (.vdb)
  bool obj = false;             ///< also write the meshes as .obj
  int threads = 0;              ///< OpenVDB's (TBB) threads; 0 = every core
  bool quiet = false;           ///< no progress output
  bool interactive = false;     ///< one updating progress line (a terminal)
  std::ostream* log = nullptr;  ///< where progress goes; nullptr = std::cerr
};

struct SurfaceResult {
  std::size_t frames = 0;
  std::string folder;              ///< DIR/surface
  double seconds = 0.0;            ///< wall time
  std::size_t last_triangles = 0;  ///< of the last frame's fluid mesh
};

/// Surfaces every frame of the run in options.dir. Throws SceneError (io/scene.hpp) when
/// DIR holds no finished run or a setting is out of range (naming it), RunError when a
/// file cannot be written.
SurfaceResult surfaceRun(const SurfaceOptions& options);

struct ExportOptions {
  std::string dir;
  std::string scene;  ///< as SurfaceOptions::scene
  bool quiet = false;
  bool interactive = false;
  std::ostream* log = nullptr;
};

/// Writes DIR/particles/particles_NNNNNN.ply for every frame; returns the frame count.
/// Errors as surfaceRun.
std::size_t exportParticles(const ExportOptions& options);

}  // namespace wake
