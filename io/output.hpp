// Frame output (DESIGN.md §7): one HDF5 file per run plus an XDMF index for ParaView.
//
// HDF5 layout (contract; extend, never rename):
//   /                       attributes scene (string), particle_radius (m),
//                           rest_density (kg/m^3), speed_of_sound (m/s), frame_rate (1/s)
//   /particle_index         0, 1, 2, ... (uint32, as long as the largest frame): the
//                           connectivity of the XDMF's one Polyvertex cell of particles
//   /frames/000000, ...     one group per output frame, attribute time (s), datasets
//                             position (N x 3, m), velocity (N x 3, m/s),
//                             density (N, kg/m^3), pressure (N, Pa; with the
//                             divergence-free solver its running mean over ~20 ms,
//                             FluidSnapshot::pressure),
//                             id (N, uint32: permanent particle number, ascending),
//                           and bodies/<name> (V x 3, float, m): each moving body's mesh
//                             vertices in the world at the frame's time
//   /bodies/<name>/         one row per output frame, extendible datasets
//                             time (F, s), position (F x 3, m, centre of mass),
//                             orientation (F x 4, x y z w), linear_velocity (F x 3, m/s),
//                             angular_velocity (F x 3, rad/s)
//                           attribute kind ("static", "kinematic" or "dynamic"), and
//                           written once: surface_points (M x 3, m) and surface_normals
//                             (M x 3, unit) of the body's M boundary samples in the BODY
//                             frame (origin = centre of mass; world = orientation * p +
//                             position); infinite shapes (planes) only within the domain;
//                             mesh_vertices (V x 3, m, body frame) and mesh_triangles
//                             (T x 3, uint32, counter-clockwise seen from outside): the
//                             body's shape as triangles (exact for flat shapes, within
//                             about 1 % of the size for curved ones: surface/shape_mesh.hpp);
//                             static bodies: mesh_world (V x 3, float, m), their vertices
//                             in the world
//
// While the run goes on, the files are DIR/<name>.h5.partial and DIR/<name>.xdmf.partial
// (flushed and rewritten after every frame, so a running or crashed run can be inspected);
// finish() renames them to DIR/<name>.h5 and DIR/<name>.xdmf. So a run that fails never
// replaces the output of an earlier, complete run.
#pragma once

#include "coupling/simulation.hpp"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace wake {

struct SceneFile;

/// What a checkpoint keeps of the output written so far (io/checkpoint.hpp), so that a
/// resumed run rebuilds its HDF5 file from the frames' own objects alone. HDF5 has no
/// journal: a run killed while it wrote can leave the file's index of frames (the
/// /frames group) and its extendible body series torn, but never a frame group that was
/// complete on disk at the checkpoint, which is found by its address.
struct OutputIndex {
  std::vector<std::uint64_t> frame_address;  ///< (frames) file address of /frames/NNNNNN
  /// (frames x bodies x kBodyRow) each frame's body rows: time, position (3), orientation
  /// (x y z w), linear velocity (3), angular velocity (3)
  std::vector<double> body_rows;
  static constexpr std::size_t kBodyRow = 14;
  std::size_t frames() const { return frame_address.size(); }
};

class FrameWriter {
 public:
  /// Creates DIR/<scene.name>.h5.partial (DIR must exist) and writes the root attributes.
  /// Throws std::runtime_error naming the file when it cannot be written.
  FrameWriter(const std::string& out_dir, const SceneFile& scene, const Simulation& sim);
  /// Continues the output of a stopped run: a new file with the root attributes and the
  /// bodies' surfaces written again, the frames of `index` copied from
  /// DIR/<scene.name>.h5.partial by their addresses and the body series rows from `index`,
  /// replaces it (the old file is only read), and the XDMF index is rewritten. Throws
  /// std::runtime_error naming the file when it is missing or a frame cannot be read.
  FrameWriter(const std::string& out_dir, const SceneFile& scene, const Simulation& sim,
              const OutputIndex& index);
  /// Closes the file; without finish() the .partial files stay as they are.
  ~FrameWriter();
  FrameWriter(const FrameWriter&) = delete;
  FrameWriter& operator=(const FrameWriter&) = delete;

  /// Appends one output frame: the fluid `fluid` (a snapshot of `sim`) and the body
  /// states at sim.time(). Flushes the file and rewrites the XDMF index.
  void writeFrame(const Simulation& sim, const FluidSnapshot& fluid);
  /// Forces the file's contents to disk (before a checkpoint that counts its frames).
  void sync();
  /// Closes the file and moves the .partial files to their final names.
  void finish();

  std::size_t frames() const;
  /// The frames written so far, for a checkpoint (call after sync()).
  const OutputIndex& index() const;
  const std::string& h5Path() const;    ///< final name, DIR/<name>.h5
  const std::string& xdmfPath() const;  ///< final name, DIR/<name>.xdmf

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace wake
