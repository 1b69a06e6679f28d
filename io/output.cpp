// HDF5 (C API) + XDMF frame writer; layout in output.hpp.
#include "io/output.hpp"

#include "io/files.hpp"
#include "io/hdf5_writer.hpp"
#include "io/scene.hpp"
#include "io/xdmf.hpp"
#include "surface/shape_mesh.hpp"

#include <hdf5.h>
#include <unistd.h>

#include <array>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <vector>

namespace wake {
namespace {

using hdf5::Handle;
using hdf5::QuietHdf5Errors;

static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 arrays are written as N x 3 doubles");

std::string fileName(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

/// One per-body series: extendible datasets with one row per output frame.
struct BodySeries {
  Handle group, time, position, orientation, linear_velocity, angular_velocity;
};

/// One body's triangle mesh (body frame), written once; moving bodies' world vertices
/// are written with every frame.
struct BodyMesh {
  std::string name;
  SurfaceMesh mesh;
  bool moves = false;
};

}  // namespace

struct FrameWriter::Impl : hdf5::Writer {
  std::string h5_final, h5_partial, xdmf_final, xdmf_partial;
  Handle file, frames_group, bodies_group;
  std::vector<BodySeries> bodies;  // in the order of sim.bodyStates()
  std::vector<BodyMesh> meshes;    // in the order of sim.bodyStates()
  std::vector<XdmfFrame> entries;  // what the XDMF index lists
  Handle particle_index;           // /particle_index: 0, 1, 2, ... (the fluid's cell)
  hsize_t particle_index_size = 0;
  OutputIndex index;
  bool finished = false;

  /// The output's file names in `out_dir` for the scene `name` (final and .partial).
  void setNames(const std::string& out_dir, const std::string& name) {
    const std::string stem = out_dir + "/" + name;
    h5_final = stem + ".h5";
    h5_partial = h5_final + ".partial";
    path = h5_partial;
    xdmf_final = stem + ".xdmf";
    xdmf_partial = xdmf_final + ".partial";
  }

  /// Creates `file_path` with the root attributes, the groups, the bodies' empty series
  /// and their surfaces.
  void createFile(const std::string& file_path, const SceneFile& scene, const Simulation& sim) {
    path = file_path;
    file = create(H5Fcreate(file_path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose,
                  "create the file");
    const hid_t root = file.get();
    const FluidParams& fluid = sim.fluid().params();
    writeAttribute(root, "scene", scene.name);
    writeAttribute(root, "wake_version", std::string(wakeVersion()));
    writeAttribute(root, "particle_radius", fluid.particle_radius);  // m
    writeAttribute(root, "rest_density", fluid.rest_density);        // kg/m^3
    writeAttribute(root, "speed_of_sound", fluid.speed_of_sound);    // m/s (resolved)
    writeAttribute(root, "smoothing_ratio", fluid.smoothing_ratio);  // H / spacing
    writeAttribute(root, "pressure_gradient",
                   std::string(fluid.pressure_gradient == PressureGradient::Symmetric
                                   ? "symmetric"
                                   : "consistent"));                    // WCSPH's pressure force
    writeAttribute(root, "frame_rate", scene.frame_rate);               // 1/s
    writeAttribute(root, "gravity", sim.settings().gravity.data(), 3);  // m/s^2

    frames_group = createGroup(root, "frames");
    bodies_group = createGroup(root, "bodies");
    for (const BodyState& body : sim.bodyStates()) {
      BodySeries s;
      s.group = createGroup(bodies_group.get(), body.name);
      s.time = createSeries(s.group.get(), "time", 1);
      s.position = createSeries(s.group.get(), "position", 3);
      s.orientation = createSeries(s.group.get(), "orientation", 4);
      s.linear_velocity = createSeries(s.group.get(), "linear_velocity", 3);
      s.angular_velocity = createSeries(s.group.get(), "angular_velocity", 3);
      bodies.push_back(std::move(s));
    }
    writeSurfaces(sim);
    writeMeshes(sim);
    particle_index = createIndexSeries(root, "particle_index");
    growParticleIndex(sim.fluidParticles());
    check(H5Fflush(root, H5F_SCOPE_GLOBAL), "flush the file");
  }

  /// An empty 1-D uint32 dataset that grows (chunks of 64k).
  Handle createIndexSeries(hid_t group, const char* name) const {
    const hsize_t dims[1] = {0}, max_dims[1] = {H5S_UNLIMITED}, chunk[1] = {65536};
    const Handle space = create(H5Screate_simple(1, dims, max_dims), H5Sclose, "create dataspace");
    const Handle props = create(H5Pcreate(H5P_DATASET_CREATE), H5Pclose, "create properties");
    check(H5Pset_chunk(props.get(), 1, chunk), "set chunk size");
    return create(H5Dcreate2(group, name, H5T_NATIVE_UINT32, space.get(), H5P_DEFAULT, props.get(),
                             H5P_DEFAULT),
                  H5Dclose, std::string("create dataset ") + name);
  }

  /// Makes /particle_index hold 0 .. n-1 (it only grows).
  void growParticleIndex(hsize_t n) {
    if (n <= particle_index_size) return;
    const hsize_t dims[1] = {n};
    check(H5Dset_extent(particle_index.get(), dims), "extend /particle_index");
    const Handle file_space = create(H5Dget_space(particle_index.get()), H5Sclose, "get dataspace");
    const hsize_t start[1] = {particle_index_size}, count[1] = {n - particle_index_size};
    check(H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start, nullptr, count, nullptr),
          "select /particle_index rows");
    std::vector<std::uint32_t> values(count[0]);
    for (hsize_t i = 0; i < count[0]; ++i)
      values[i] = static_cast<std::uint32_t>(start[0] + i);
    const Handle memory_space =
        create(H5Screate_simple(1, count, nullptr), H5Sclose, "create dataspace");
    check(H5Dwrite(particle_index.get(), H5T_NATIVE_UINT32, memory_space.get(), file_space.get(),
                   H5P_DEFAULT, values.data()),
          "write /particle_index");
    particle_index_size = n;
  }

  /// Each body's shape as a triangle mesh in its body frame (mesh_vertices, mesh_triangles;
  /// infinite shapes within the domain); static bodies' world vertices once (mesh_world,
  /// float), moving bodies' with every frame.
  void writeMeshes(const Simulation& sim) {
    const Boundaries& boundaries = sim.boundaries();
    meshes.clear();
    for (std::size_t b = 0; b < boundaries.bodyCount() && b < bodies.size(); ++b) {
      const BodySettings& body = boundaries.body(b);
      BodyMesh m;
      m.name = body.name;
      m.moves = body.moves();
      m.mesh = shapeMesh(*body.shape, transformBounds(sim.model().domain, body.pose, false));
      const hid_t group = bodies[b].group.get();
      writeDataset(group, "mesh_vertices", H5T_NATIVE_DOUBLE, m.mesh.vertices.data(),
                   m.mesh.vertices.size(), 3);
      writeDataset(group, "mesh_triangles", H5T_NATIVE_UINT32, m.mesh.triangles.data(),
                   m.mesh.triangles.size(), 3);
      if (!m.moves) writeWorldVertices(group, "mesh_world", m.mesh, body.pose);
      meshes.push_back(std::move(m));
    }
  }

  void writeWorldVertices(hid_t group, const char* name, const SurfaceMesh& mesh,
                          const Pose& pose) const {
    std::vector<float> xyz;
    xyz.reserve(3 * mesh.vertices.size());
    for (const Vec3& v : mesh.vertices) {
      const Vec3 w = pose.toWorld(v);
      xyz.insert(xyz.end(),
                 {static_cast<float>(w.x()), static_cast<float>(w.y()), static_cast<float>(w.z())});
    }
    writeDataset(group, name, H5T_NATIVE_FLOAT, xyz.data(), mesh.vertices.size(), 3);
  }

  /// The XDMF entry of frame k: the fluid and every body's mesh.
  XdmfFrame entry(std::size_t k, double time, std::size_t particles) const {
    XdmfFrame f{k, time, particles, {}};
    const std::string h5 = fileName(h5_final);
    for (const BodyMesh& m : meshes)
      f.meshes.push_back(
          bodyMeshEntry(h5, m.name, m.moves, k, m.mesh.vertices.size(), m.mesh.triangles.size()));
    return f;
  }

  /// The XDMF index of all frames so far, its data in the HDF5 file `h5_name` (relative).
  std::string xdmf(const std::string& h5_name) const {
    XdmfRun run{h5_name, particle_index_size, entries};
    for (XdmfFrame& f : run.frames)
      for (XdmfMesh& m : f.meshes)
        m.file = h5_name;
    return xdmfIndex(run);
  }

  /// Appends frame k's body rows (bodies x OutputIndex::kBodyRow numbers) to the body
  /// series and to the index.
  void appendBodyRows(std::size_t k, const double* rows) {
    for (std::size_t b = 0; b < bodies.size(); ++b) {
      const double* r = rows + b * OutputIndex::kBodyRow;
      const BodySeries& s = bodies[b];
      appendRow(s.time, k, r, 1);
      appendRow(s.position, k, r + 1, 3);
      appendRow(s.orientation, k, r + 4, 4);
      appendRow(s.linear_velocity, k, r + 8, 3);
      appendRow(s.angular_velocity, k, r + 11, 3);
    }
    index.body_rows.insert(index.body_rows.end(), rows,
                           rows + bodies.size() * OutputIndex::kBodyRow);
  }

  /// The file address of an object (what H5Oopen_by_addr opens).
  std::uint64_t addressOf(hid_t object) const {
    H5O_info_t info;
    check(H5Oget_info2(object, &info, H5O_INFO_BASIC), "get an object's address");
    return static_cast<std::uint64_t>(info.addr);
  }

  static std::string kindName(BodyKind kind) {
    return kind == BodyKind::Static      ? "static"
           : kind == BodyKind::Kinematic ? "kinematic"
                                         : "dynamic";
  }

  /// Each body's boundary samples in its body frame (surface_points, surface_normals) and
  /// its kind: the same at any time of the run. Groups in the order of sim.bodyStates().
  void writeSurfaces(const Simulation& sim) const {
    const Boundaries& boundaries = sim.boundaries();
    std::vector<Vec3> points, normals;
    for (std::size_t b = 0; b < boundaries.bodyCount() && b < bodies.size(); ++b) {
      boundaries.bodySamples(b, points, normals);
      const hid_t group = bodies[b].group.get();
      const hsize_t m = points.size();
      writeDataset(group, "surface_points", H5T_NATIVE_DOUBLE, points.data(), m, 3);
      writeDataset(group, "surface_normals", H5T_NATIVE_DOUBLE, normals.data(), m, 3);
      writeAttribute(group, "kind", kindName(boundaries.body(b).kind));
    }
  }
};

FrameWriter::FrameWriter(const std::string& out_dir, const SceneFile& scene, const Simulation& sim)
    : impl_(std::make_unique<Impl>()) {
  const QuietHdf5Errors quiet;
  Impl& d = *impl_;
  d.setNames(out_dir, scene.name);

  d.createFile(d.h5_partial, scene, sim);
}

FrameWriter::FrameWriter(const std::string& out_dir, const SceneFile& scene, const Simulation& sim,
                         const OutputIndex& index)
    : impl_(std::make_unique<Impl>()) {
  const QuietHdf5Errors quiet;
  Impl& d = *impl_;
  d.setNames(out_dir, scene.name);
  // The old file is never written again, nor trusted beyond the frames the checkpoint
  // counts, each opened by its address (HDF5 has no journal: a run killed while it wrote
  // can leave the /frames group's index, or a body series, torn). A new file takes them
  // and replaces it.
  const std::size_t frames = index.frames();
  const std::size_t nb = sim.bodyStates().size();
  if (index.body_rows.size() != frames * nb * OutputIndex::kBodyRow)
    throw std::runtime_error("cannot resume: the checkpoint's body rows do not match its " +
                             std::to_string(frames) + " frames and " + std::to_string(nb) +
                             " bodies");
  if (::access(d.h5_partial.c_str(), F_OK) != 0 && ::access(d.h5_final.c_str(), R_OK) == 0) {
    // A run stopped while it finished (its file renamed, its checkpoint not yet removed):
    // the final file holds every frame the checkpoint counts. It becomes the partial file
    // again (its index first, so no index names a missing file) and the frames after the
    // checkpoint are written again, the same bits.
    std::remove(d.xdmf_final.c_str());
    renameFile(d.h5_final, d.h5_partial);
  }
  if (::access(d.h5_partial.c_str(), R_OK) != 0)
    throw std::runtime_error("cannot resume: " + d.h5_partial + " is missing");
  hdf5::Writer old_file;
  old_file.path = d.h5_partial;
  const Handle old = old_file.create(H5Fopen(d.h5_partial.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT),
                                     H5Fclose, "open the file");
  const std::string fresh = d.h5_partial + ".resume";
  d.createFile(fresh, scene, sim);
  for (std::size_t k = 0; k < frames; ++k) {
    const std::string name = frameName(k);
    const Handle frame(H5Oopen_by_addr(old.get(), static_cast<haddr_t>(index.frame_address[k])),
                       H5Oclose);
    if (!frame.valid())
      throw std::runtime_error("cannot resume: " + d.h5_partial + " lacks frame " + name +
                               " of the " + std::to_string(frames) + " the checkpoint counts");
    old_file.check(
        H5Ocopy(frame.get(), ".", d.frames_group.get(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT),
        "copy frame " + name);
    const Handle group = d.openGroup(d.frames_group.get(), name);
    const double time = d.readAttribute<double>(group.get(), "time", H5T_NATIVE_DOUBLE);
    const std::vector<std::uint32_t> id =
        d.readDataset<std::uint32_t>(group.get(), "id", H5T_NATIVE_UINT32, 1);
    d.entries.push_back(d.entry(k, time, id.size()));
    d.growParticleIndex(id.size());
    d.appendBodyRows(k, &index.body_rows[k * nb * OutputIndex::kBodyRow]);
    d.index.frame_address.push_back(d.addressOf(group.get()));
  }
  d.check(H5Fflush(d.file.get(), H5F_SCOPE_GLOBAL), "flush the file");
  renameFile(fresh, d.h5_partial);  // the open file keeps its data under the new name
  d.path = d.h5_partial;
  writeFileAtomically(d.xdmf_partial, d.xdmf(fileName(d.h5_partial)));
}

void FrameWriter::sync() {
  const QuietHdf5Errors quiet;
  Impl& d = *impl_;
  d.check(H5Fflush(d.file.get(), H5F_SCOPE_GLOBAL), "flush the file");
  void* handle = nullptr;
  d.check(H5Fget_vfd_handle(d.file.get(), H5P_DEFAULT, &handle), "get the file handle");
  if (handle && ::fsync(*static_cast<int*>(handle)) != 0)
    throw std::runtime_error("cannot sync " + d.h5_partial + " to disk");
}

FrameWriter::~FrameWriter() {
  const QuietHdf5Errors quiet;
  impl_.reset();  // closes every handle, children first (declaration order, reversed)
}

void FrameWriter::writeFrame(const Simulation& sim, const FluidSnapshot& fluid) {
  const QuietHdf5Errors quiet;
  Impl& d = *impl_;
  const std::size_t k = d.entries.size();
  const hsize_t n = fluid.position.size();
  const double time = sim.time();

  const Handle group = d.createGroup(d.frames_group.get(), frameName(k));
  d.writeAttribute(group.get(), "time", time);
  d.writeDataset(group.get(), "position", H5T_NATIVE_DOUBLE, fluid.position.data(), n, 3);
  d.writeDataset(group.get(), "velocity", H5T_NATIVE_DOUBLE, fluid.velocity.data(), n, 3);
  d.writeDataset(group.get(), "density", H5T_NATIVE_DOUBLE, fluid.density.data(), n, 1);
  d.writeDataset(group.get(), "pressure", H5T_NATIVE_DOUBLE, fluid.pressure.data(), n, 1);
  d.writeDataset(group.get(), "id", H5T_NATIVE_UINT32, fluid.id.data(), n, 1);

  const std::vector<BodyState> states = sim.bodyStates();
  if (states.size() != d.bodies.size())
    throw std::logic_error("FrameWriter: the number of bodies changed during the run");
  d.growParticleIndex(n);
  bool any_moves = false;
  for (const BodyMesh& m : d.meshes)
    any_moves = any_moves || m.moves;
  if (any_moves) {
    const Handle meshes = d.createGroup(group.get(), "bodies");
    for (std::size_t b = 0; b < d.meshes.size(); ++b)
      if (d.meshes[b].moves)
        d.writeWorldVertices(meshes.get(), d.meshes[b].name.c_str(), d.meshes[b].mesh,
                             Pose{states[b].position, states[b].orientation});
  }
  std::vector<double> rows;
  for (const BodyState& b : states) {
    const std::array<double, OutputIndex::kBodyRow> row = {time,
                                                           b.position.x(),
                                                           b.position.y(),
                                                           b.position.z(),
                                                           b.orientation.x(),
                                                           b.orientation.y(),
                                                           b.orientation.z(),
                                                           b.orientation.w(),
                                                           b.linear_velocity.x(),
                                                           b.linear_velocity.y(),
                                                           b.linear_velocity.z(),
                                                           b.angular_velocity.x(),
                                                           b.angular_velocity.y(),
                                                           b.angular_velocity.z()};
    rows.insert(rows.end(), row.begin(), row.end());
  }
  d.appendBodyRows(k, rows.data());
  d.check(H5Fflush(d.file.get(), H5F_SCOPE_GLOBAL), "flush the file");
  d.index.frame_address.push_back(d.addressOf(group.get()));

  d.entries.push_back(d.entry(k, time, static_cast<std::size_t>(n)));
  writeFileAtomically(d.xdmf_partial, d.xdmf(fileName(d.h5_partial)));
}

void FrameWriter::finish() {
  const QuietHdf5Errors quiet;
  Impl& d = *impl_;
  if (d.finished) return;
  d.bodies.clear();
  d.particle_index.reset();
  d.bodies_group.reset();
  d.frames_group.reset();
  d.check(H5Fclose(d.file.release()), "close the file");
  renameFile(d.h5_partial, d.h5_final);
  writeFileAtomically(d.xdmf_final, d.xdmf(fileName(d.h5_final)));
  std::remove(d.xdmf_partial.c_str());
  d.finished = true;
}

std::size_t FrameWriter::frames() const {
  return impl_->entries.size();
}
const OutputIndex& FrameWriter::index() const {
  return impl_->index;
}
const std::string& FrameWriter::h5Path() const {
  return impl_->h5_final;
}
const std::string& FrameWriter::xdmfPath() const {
  return impl_->xdmf_final;
}

}  // namespace wake
