// Frame output (DESIGN.md §7): one HDF5 file per run plus an XDMF index for ParaView.
//
// HDF5 layout (contract; extend, never rename):
//   /                       attributes scene (string), particle_radius (m),
//                           rest_density (kg/m^3), speed_of_sound (m/s), frame_rate (1/s)
//   /frames/000000, ...     one group per output frame, attribute time (s), datasets
//                             position (N x 3, m), velocity (N x 3, m/s),
//                             density (N, kg/m^3), pressure (N, Pa),
//                             id (N, uint32: permanent particle number, ascending)
//   /bodies/<name>/         one row per output frame, extendible datasets
//                             time (F, s), position (F x 3, m, centre of mass),
//                             orientation (F x 4, x y z w), linear_velocity (F x 3, m/s),
//                             angular_velocity (F x 3, rad/s)
//                           attribute kind ("static", "kinematic" or "dynamic"), and
//                           written once: surface_points (M x 3, m) and surface_normals
//                             (M x 3, unit) of the body's M boundary samples in the BODY
//                             frame (origin = centre of mass; world = orientation * p +
//                             position); infinite shapes (planes) only within the domain
//
// While the run goes on, the files are DIR/<name>.h5.partial and DIR/<name>.xdmf.partial
// (flushed and rewritten after every frame, so a running or crashed run can be inspected);
// finish() renames them to DIR/<name>.h5 and DIR/<name>.xdmf. So a run that fails never
// replaces the output of an earlier, complete run.
#pragma once

#include "coupling/simulation.hpp"

#include <memory>
#include <string>

namespace wake {

struct SceneFile;

class FrameWriter {
 public:
  /// Creates DIR/<scene.name>.h5.partial (DIR must exist) and writes the root attributes.
  /// Throws std::runtime_error naming the file when it cannot be written.
  FrameWriter(const std::string& out_dir, const SceneFile& scene, const Simulation& sim);
  /// Continues the output of a stopped run: copies the first `frames` frames (and body
  /// series rows, and the bodies' surfaces) of DIR/<scene.name>.h5.partial into a new file
  /// that replaces it (a run killed while writing a frame may leave that frame's HDF5
  /// metadata half written: the old file is only read), and rewrites the XDMF index.
  /// Throws std::runtime_error naming the file when it is missing or holds fewer frames.
  FrameWriter(const std::string& out_dir, const SceneFile& scene, const Simulation& sim,
              std::size_t frames);
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
  const std::string& h5Path() const;    ///< final name, DIR/<name>.h5
  const std::string& xdmfPath() const;  ///< final name, DIR/<name>.xdmf

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace wake
