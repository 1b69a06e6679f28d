// Per-frame time series of a run, DIR/series.csv: one row per output frame, for plots
// (scripts/plot.sh) and quick checks with any CSV tool.
//
// Columns (extend, never rename):
//   time                 s, the frame's time
//   max_density_ratio    largest density / rest density over the steps since the last
//                        frame ("nan" for frame 0, before any step)
//   penetrating          most fluid centres inside a body's exact shape after any of
//                        those steps (the per-frame version of summary's max_penetrating)
//   lost_particles       fluid particles lost so far (left the domain)
//   contacts             particle-body contacts in the frame's last step
//   then for each moving (kinematic or dynamic) body, in scene order:
//   <name>.x <name>.y <name>.z      centre of mass, m
//   <name>.vx <name>.vy <name>.vz   linear velocity, m/s
//
// Like the HDF5 file, it is written as DIR/series.csv.partial while the run goes on and
// renamed when the run completes.
#pragma once

#include "coupling/simulation.hpp"

#include <fstream>
#include <string>
#include <vector>

namespace wake {

class SeriesWriter {
 public:
  /// Creates DIR/series.csv.partial and writes the header. Throws std::runtime_error
  /// naming the file when it cannot be written.
  SeriesWriter(const std::string& out_dir, const Simulation& sim);
  /// Continues the series of a stopped run: keeps the header and the first `frames` rows
  /// of DIR/series.csv.partial, drops later ones. Throws std::runtime_error naming the file
  /// when it is missing or shorter.
  SeriesWriter(const std::string& out_dir, const Simulation& sim, std::size_t frames);
  /// Appends the row of the current frame (call after sim.resetWindow() was last called
  /// at the previous frame) and flushes.
  void writeFrame(const Simulation& sim, bool first);
  /// Forces the file's contents to disk (before a checkpoint that counts its rows).
  void sync();
  /// Closes the file and renames it to DIR/series.csv.
  void finish();

  const std::string& path() const { return final_; }

 private:
  std::string partial_, final_;
  std::vector<std::size_t> moving_;  // indices of moving bodies
  void findMovingBodies(const Simulation& sim);
  std::ofstream out_;
};

}  // namespace wake
