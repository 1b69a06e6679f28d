#include "io/run_file.hpp"

#include "io/scene.hpp"

#include <hdf5.h>

#include <algorithm>
#include <cstdio>
#include <cstring>

namespace wake {

using hdf5::Handle;

static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 arrays are read as N x 3 doubles");

Pose RunBody::pose(std::size_t frame) const {
  Pose p;
  if (position.empty()) return p;
  const std::size_t k = std::min(frame, position.size() - 1);
  p.position = position[k];
  if (k < orientation.size()) p.orientation = orientation[k];
  return p;
}

RunFile::RunFile(const std::string& path)
    : path_(path), file_(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose) {
  if (!file_.valid()) throw SceneError(path + ": cannot open (not an HDF5 file?)");
}

double RunFile::rootDouble(const char* name, double fallback) const {
  if (H5Aexists(file_.get(), name) <= 0) return fallback;
  const Handle attr(H5Aopen(file_.get(), name, H5P_DEFAULT), H5Aclose);
  double value = fallback;
  if (!attr.valid() || H5Aread(attr.get(), H5T_NATIVE_DOUBLE, &value) < 0)
    fail("read attribute " + std::string(name));
  return value;
}

std::string RunFile::stringAttribute(hid_t object, const char* name) {
  if (H5Aexists(object, name) <= 0) return "";
  const Handle attr(H5Aopen(object, name, H5P_DEFAULT), H5Aclose);
  if (!attr.valid()) return "";
  const Handle type(H5Aget_type(attr.get()), H5Tclose);
  if (!type.valid() || H5Tget_class(type.get()) != H5T_STRING) return "";
  if (H5Tis_variable_str(type.get()) > 0) {
    char* text = nullptr;
    if (H5Aread(attr.get(), type.get(), &text) < 0 || text == nullptr) return "";
    std::string out(text);
    H5free_memory(text);
    return out;
  }
  std::string out(H5Tget_size(type.get()), '\0');
  if (out.empty() || H5Aread(attr.get(), type.get(), &out[0]) < 0) return "";
  out.resize(std::strlen(out.c_str()));
  return out;
}

std::size_t RunFile::frameCount() const {
  if (H5Lexists(file_.get(), "frames", H5P_DEFAULT) <= 0) fail("find the group /frames");
  const Handle group(H5Gopen2(file_.get(), "frames", H5P_DEFAULT), H5Gclose);
  H5G_info_t info;
  if (!group.valid() || H5Gget_info(group.get(), &info) < 0) fail("read the group /frames");
  return static_cast<std::size_t>(info.nlinks);
}

void RunFile::readFrame(std::size_t k, RunFrame& out, bool positions, bool velocities) const {
  char name[48];
  std::snprintf(name, sizeof(name), "frames/%06zu", k);
  const Handle group(H5Gopen2(file_.get(), name, H5P_DEFAULT), H5Gclose);
  if (!group.valid()) fail(std::string("open /") + name);
  out.index = k;
  if (positions) readRows(group.get(), "position", 3, name, out.position);
  if (velocities) readRows(group.get(), "velocity", 3, name, out.velocity);
}

std::size_t RunFile::datasetRows(const char* path) const {
  if (H5Lexists(file_.get(), path, H5P_DEFAULT) <= 0) return 0;
  const Handle set(H5Dopen2(file_.get(), path, H5P_DEFAULT), H5Dclose);
  if (!set.valid()) fail(std::string("open dataset ") + path);
  const Handle space(H5Dget_space(set.get()), H5Sclose);
  hsize_t dims[2] = {0, 0};
  if (!space.valid() || H5Sget_simple_extent_ndims(space.get()) < 1 ||
      H5Sget_simple_extent_dims(space.get(), dims, nullptr) < 0)
    fail(std::string("read the shape of ") + path);
  return static_cast<std::size_t>(dims[0]);
}

std::pair<double, std::size_t> RunFile::frameInfo(std::size_t k) const {
  char name[48];
  std::snprintf(name, sizeof(name), "/frames/%06zu", k);
  const Handle group(H5Gopen2(file_.get(), name, H5P_DEFAULT), H5Gclose);
  if (!group.valid()) fail(std::string("open ") + name);
  double time = 0.0;
  const Handle attr(H5Aopen(group.get(), "time", H5P_DEFAULT), H5Aclose);
  if (!attr.valid() || H5Aread(attr.get(), H5T_NATIVE_DOUBLE, &time) < 0)
    fail(std::string("read ") + name + " attribute time");
  return {time, datasetRows((std::string(name) + "/id").c_str())};
}

void RunFile::readScalars(std::size_t k, RunFrame& out) const {
  char name[48];
  std::snprintf(name, sizeof(name), "frames/%06zu", k);
  const Handle group(H5Gopen2(file_.get(), name, H5P_DEFAULT), H5Gclose);
  if (!group.valid()) fail(std::string("open /") + name);
  out.time = frameInfo(k).first;
  readFlat(group.get(), "density", 1, name, out.density);
  std::vector<double> id;
  readFlat(group.get(), "id", 1, name, id);
  out.id.assign(id.begin(), id.end());
}

void RunFile::readSurface(std::size_t k, SurfaceMesh& out) const {
  char name[48];
  std::snprintf(name, sizeof(name), "frames/%06zu", k);
  const Handle group(H5Gopen2(file_.get(), name, H5P_DEFAULT), H5Gclose);
  if (!group.valid()) fail(std::string("open /") + name);
  readMesh(group.get(), "vertices", "triangles", name, out);
}

void RunFile::readMesh(hid_t group, const char* vertices, const char* triangles,
                       const std::string& where, SurfaceMesh& out) const {
  readRows(group, vertices, 3, where, out.vertices);
  std::vector<double> t;
  readFlat(group, triangles, 3, where, t);
  out.triangles.clear();
  for (std::size_t f = 0; f + 2 < t.size(); f += 3) {
    const std::array<std::uint32_t, 3> tri = {static_cast<std::uint32_t>(t[f]),
                                              static_cast<std::uint32_t>(t[f + 1]),
                                              static_cast<std::uint32_t>(t[f + 2])};
    for (const std::uint32_t v : tri)
      if (v >= out.vertices.size()) fail("read /" + where + "/" + triangles + " (bad index)");
    out.triangles.push_back(tri);
  }
}

std::vector<RunBody> RunFile::readBodies() const {
  std::vector<RunBody> out;
  if (H5Lexists(file_.get(), "bodies", H5P_DEFAULT) <= 0) return out;
  const Handle bodies(H5Gopen2(file_.get(), "bodies", H5P_DEFAULT), H5Gclose);
  H5G_info_t info;
  if (!bodies.valid() || H5Gget_info(bodies.get(), &info) < 0) fail("read the group /bodies");
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    const ssize_t size = H5Lget_name_by_idx(bodies.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i,
                                            nullptr, 0, H5P_DEFAULT);
    if (size < 0) fail("list /bodies");
    std::string body_name(static_cast<std::size_t>(size) + 1, '\0');
    H5Lget_name_by_idx(bodies.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i, &body_name[0],
                       body_name.size(), H5P_DEFAULT);
    body_name.resize(static_cast<std::size_t>(size));
    const Handle group(H5Gopen2(bodies.get(), body_name.c_str(), H5P_DEFAULT), H5Gclose);
    if (!group.valid()) fail("open /bodies/" + body_name);
    RunBody b;
    b.name = body_name;
    b.kind = stringAttribute(group.get(), "kind");
    const std::string where = "bodies/" + body_name;
    // Files written before surface_points existed have no surfaces: nothing to draw.
    if (H5Lexists(group.get(), "surface_points", H5P_DEFAULT) > 0 &&
        H5Lexists(group.get(), "surface_normals", H5P_DEFAULT) > 0) {
      readRows(group.get(), "surface_points", 3, where, b.points);
      readRows(group.get(), "surface_normals", 3, where, b.normals);
      if (b.normals.size() != b.points.size())
        fail("match /" + where + "/surface_normals to surface_points");
    }
    if (H5Lexists(group.get(), "mesh_vertices", H5P_DEFAULT) > 0) {
      readMesh(group.get(), "mesh_vertices", "mesh_triangles", where, b.mesh);
    }
    readRows(group.get(), "position", 3, where, b.position);
    std::vector<double> xyzw;
    readFlat(group.get(), "orientation", 4, where, xyzw);
    for (std::size_t f = 0; f + 3 < xyzw.size(); f += 4)
      b.orientation.push_back(Quat(xyzw[f + 3], xyzw[f], xyzw[f + 1], xyzw[f + 2]).normalized());
    out.push_back(std::move(b));
  }
  return out;
}

void RunFile::fail(const std::string& what) const {
  throw SceneError(path_ + ": cannot " + what);
}

void RunFile::readFlat(hid_t group, const char* name, hsize_t cols, const std::string& where,
                       std::vector<double>& out) const {
  const std::string full = "/" + where + "/" + name;
  const Handle set(H5Dopen2(group, name, H5P_DEFAULT), H5Dclose);
  if (!set.valid()) fail("open dataset " + full);
  const Handle space(H5Dget_space(set.get()), H5Sclose);
  hsize_t dims[2] = {0, 0};
  const int rank = space.valid() ? H5Sget_simple_extent_ndims(space.get()) : -1;
  if (rank < 1 || rank > 2) fail("read dataset " + full + " (unexpected shape)");
  H5Sget_simple_extent_dims(space.get(), dims, nullptr);
  if (rank == 2 ? dims[1] != cols : (dims[0] != 0 && cols != 1))
    fail("read dataset " + full + " (expected " + std::to_string(cols) + " columns)");
  out.assign(static_cast<std::size_t>(dims[0] * cols), 0.0);
  if (!out.empty() &&
      H5Dread(set.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0)
    fail("read dataset " + full);
}

void RunFile::readRows(hid_t group, const char* name, hsize_t cols, const std::string& where,
                       std::vector<Vec3>& out) const {
  std::vector<double> flat;
  readFlat(group, name, cols, where, flat);
  out.resize(flat.size() / 3);
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i] = Vec3(flat[3 * i], flat[3 * i + 1], flat[3 * i + 2]);
}

}  // namespace wake
