// The XDMF index of a run (DESIGN.md §7): what ParaView (and VisIt) open. One temporal
// collection (a grid per output time) for each object, so that ParaView shows each as a
// named block:
//   fluid            the particles: one Polyvertex cell over all of them (connectivity a
//                    slice of /particle_index), point arrays velocity, density, pressure, id
//   body_<name>      each body's triangle mesh
//   surface          the fluid's surface mesh, when `wake surface` wrote it
// Data stay in the HDF5 files; the index names them by paths relative to its own folder.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace wake {

/// A triangle mesh stored in HDF5: vertices (V x 3, float of `vertex_bytes`) and
/// triangles (T x 3, uint32).
struct XdmfMesh {
  std::string name;       ///< grid name
  std::string file;       ///< HDF5 file, relative to the index
  std::string vertices;   ///< dataset path in `file`
  std::string triangles;  ///< dataset path in `file`
  std::size_t vertex_count = 0;
  std::size_t triangle_count = 0;
  int vertex_bytes = 4;  ///< 4 (float) or 8 (double)
};

struct XdmfFrame {
  std::size_t index = 0;  ///< frame number (its group /frames/NNNNNN)
  double time = 0.0;      ///< s
  std::size_t particles = 0;
  std::vector<XdmfMesh> meshes;
};

struct XdmfRun {
  std::string h5;                  ///< the run's HDF5 file, relative to the index
  std::size_t particle_index = 0;  ///< length of /particle_index (>= every frame's count)
  std::vector<XdmfFrame> frames;
};

/// Body `name`'s mesh at frame k in the run's HDF5 file `h5`: triangles in
/// /bodies/<name>/mesh_triangles, world vertices in /frames/NNNNNN/bodies/<name> when it
/// moves, else once in /bodies/<name>/mesh_world.
XdmfMesh bodyMeshEntry(const std::string& h5, const std::string& name, bool moves, std::size_t k,
                       std::size_t vertices, std::size_t triangles);

/// The XDMF document of `run`.
std::string xdmfIndex(const XdmfRun& run);

/// The frame group's name: "000012".
std::string frameName(std::size_t k);

}  // namespace wake
