// Reading a run's output back: the HDF5 file that `wake run` writes (layout in
// io/output.hpp): its frames' particles and its bodies' surfaces and poses. Used by
// `wake render` (render/); HDF5 is not thread-safe, so one RunFile is read on one thread.
#pragma once

#include "geometry/shape.hpp"
#include "io/hdf5_handle.hpp"
#include "sph/types.hpp"

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace wake {

/// One body of a run: its boundary samples (body frame) and its pose per frame.
struct RunBody {
  std::string name, kind;             ///< kind: "static", "kinematic" or "dynamic"
  std::vector<Vec3> points, normals;  ///< body frame
  std::vector<Vec3> position;         ///< per frame
  std::vector<Quat> orientation;      ///< per frame
  SurfaceMesh mesh;                   ///< body frame; empty in files without mesh_vertices
  /// The pose at frame `frame` (the last one past the end; identity without a series).
  Pose pose(std::size_t frame) const;
};

/// The particles of one frame, in id order.
struct RunFrame {
  std::size_t index = 0;
  double time = 0.0;  ///< s (read by readScalars)
  std::vector<Vec3> position, velocity;
  std::vector<double> density;    ///< kg/m^3 (read by readScalars)
  std::vector<std::uint32_t> id;  ///< (read by readScalars)
  SurfaceMesh surface;            ///< the fluid's surface (readSurface of surface.h5)
};

class RunFile {
 public:
  /// Opens `path` read-only; throws SceneError when it is not an HDF5 file.
  explicit RunFile(const std::string& path);

  /// A double attribute of the root (`fallback` when it is missing).
  double rootDouble(const char* name, double fallback) const;
  /// A string attribute of the root ("" when missing).
  std::string rootString(const char* name) const { return stringAttribute(file_.get(), name); }
  /// A string attribute of `object` (fixed or variable length); "" when missing.
  static std::string stringAttribute(hid_t object, const char* name);
  std::size_t frameCount() const;
  /// Frame k's positions and/or velocities into `out`.
  void readFrame(std::size_t k, RunFrame& out, bool positions, bool velocities) const;
  /// Frame k's time (s) and number of particles.
  std::pair<double, std::size_t> frameInfo(std::size_t k) const;
  /// Rows of the dataset at `path` (0 when it is missing).
  std::size_t datasetRows(const char* path) const;
  /// Frame k's time, densities and ids into `out`.
  void readScalars(std::size_t k, RunFrame& out) const;
  std::vector<RunBody> readBodies() const;
  /// Frame k's mesh of a surface file (DIR/surface/surface.h5: /frames/NNNNNN/vertices,
  /// triangles) into `out` (world).
  void readSurface(std::size_t k, SurfaceMesh& out) const;

 private:
  [[noreturn]] void fail(const std::string& what) const;
  /// Reads dataset `name` of rows x cols doubles into `out` (row-major).
  void readFlat(hid_t group, const char* name, hsize_t cols, const std::string& where,
                std::vector<double>& out) const;
  void readRows(hid_t group, const char* name, hsize_t cols, const std::string& where,
                std::vector<Vec3>& out) const;
  /// A triangle mesh: V x 3 `vertices`, T x 3 `triangles` (indices checked).
  void readMesh(hid_t group, const char* vertices, const char* triangles, const std::string& where,
                SurfaceMesh& out) const;

  std::string path_;
  hdf5::Handle file_;
};

}  // namespace wake
