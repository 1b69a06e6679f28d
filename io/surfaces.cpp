#include "io/surfaces.hpp"

#include "io/files.hpp"
#include "io/hdf5_writer.hpp"
#include "io/mesh_files.hpp"
#include "io/progress.hpp"
#include "io/run.hpp"
#include "io/run_file.hpp"
#include "io/scene.hpp"
#include "io/xdmf.hpp"
#include "surface/fluid_surface.hpp"

#include <openvdb/io/File.h>
#include <tbb/global_control.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>

namespace wake {
namespace {

namespace fs = std::filesystem;

/// The finished run in `dir`: DIR/<scene>.h5, or its one .h5 file (not checkpoint.h5, not
/// .partial) when `scene` is empty.
std::string findRun(const std::string& dir, const std::string& scene) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw SceneError(dir + ": not a folder");
  if (!scene.empty()) {
    const std::string path = dir + "/" + scene + ".h5";
    if (!fs::is_regular_file(path, ec))
      throw SceneError("--scene: " + path + " is not there (no finished run of that name)");
    return path;
  }
  std::vector<std::string> found;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const fs::path p = entry.path();
    if (p.extension() == ".h5" && p.filename() != "checkpoint.h5") found.push_back(p.string());
  }
  if (found.empty())
    throw SceneError(dir + ": no finished run (<scene>.h5) in this folder; run wake run first");
  if (found.size() > 1)
    throw SceneError(dir + ": holds several runs (" + found[0] + ", " + found[1] +
                     "); name one with --scene");
  return found[0];
}

std::string stemOf(const std::string& path) {
  return fs::path(path).stem().string();
}

void makeFolder(const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw RunError("cannot create the folder " + dir + ": " + ec.message());
}

FloatVertices toFloat(const SurfaceMesh& mesh, const Pose& pose) {
  FloatVertices v;
  v.reserve(mesh.vertices.size());
  for (const Vec3& p : mesh.vertices) {
    const Vec3 w = pose.toWorld(p);
    v.push_back({static_cast<float>(w.x()), static_cast<float>(w.y()), static_cast<float>(w.z())});
  }
  return v;
}

/// Writes `grid` to `path` (through path.tmp).
void writeVdb(const openvdb::FloatGrid::Ptr& grid, const std::string& path) {
  const std::string tmp = path + ".tmp";
  try {
    openvdb::io::File file(tmp);
    file.write({grid});
    file.close();
  } catch (const openvdb::Exception& e) {
    throw RunError("cannot write " + path + ": " + e.what());
  }
  renameFile(tmp, path);
}

/// The run's frames as the XDMF index lists them, with the surface meshes in
/// surface/surface.h5 when `surface_triangles` is given (one count per frame).
XdmfRun runIndex(const RunFile& run, const std::string& h5_name, const std::vector<RunBody>& bodies,
                 const std::vector<std::pair<std::size_t, std::size_t>>* surface) {
  XdmfRun x;
  x.h5 = h5_name;
  x.particle_index = run.datasetRows("/particle_index");
  const std::size_t frames = run.frameCount();
  for (std::size_t k = 0; k < frames; ++k) {
    const auto [time, particles] = run.frameInfo(k);
    if (particles > x.particle_index)
      throw SceneError(h5_name +
                       " lacks /particle_index (written by an older Wake?): run it again");
    XdmfFrame f{k, time, particles, {}};
    for (const RunBody& b : bodies)
      f.meshes.push_back(bodyMeshEntry(h5_name, b.name, b.kind != "static", k,
                                       b.mesh.vertices.size(), b.mesh.triangles.size()));
    if (surface) {
      const std::string g = "/frames/" + frameName(k) + "/";
      f.meshes.push_back(XdmfMesh{"surface", "surface/surface.h5", g + "vertices", g + "triangles",
                                  (*surface)[k].first, (*surface)[k].second, 4});
    }
    x.frames.push_back(std::move(f));
  }
  return x;
}

nlohmann::ordered_json boundsJson(const Aabb& b) {
  if (b.empty()) return {{"min", nullptr}, {"max", nullptr}};
  return {{"min", {b.min.x(), b.min.y(), b.min.z()}}, {"max", {b.max.x(), b.max.y(), b.max.z()}}};
}

/// One mesh file's entry of surface.json: file, counts, bounds.
nlohmann::ordered_json meshJson(const std::string& file, const FloatVertices& v,
                                const Triangles& t) {
  Aabb b;
  for (const auto& p : v)
    b.extend(Vec3(p[0], p[1], p[2]));
  nlohmann::ordered_json j = {{"file", file}, {"vertices", v.size()}, {"triangles", t.size()}};
  j.update(boundsJson(b));
  return j;
}

std::ostream* logOf(bool quiet, std::ostream* log) {
  return quiet ? nullptr : log ? log : &std::cerr;
}

}  // namespace

SurfaceResult surfaceRun(const SurfaceOptions& options) {
  try {
    options.settings.check();
  } catch (const std::invalid_argument& e) {
    throw SceneError(e.what());
  }
  if (options.threads < 0) throw SceneError("--threads must be >= 0");
  const std::string h5 = findRun(options.dir, options.scene);
  const RunFile run(h5);
  const double radius = run.rootDouble("particle_radius", NAN);
  if (!(radius > 0.0)) throw SceneError(h5 + ": no particle_radius attribute (not a Wake run?)");
  const std::vector<RunBody> bodies = run.readBodies();
  const std::size_t frames = run.frameCount();

  std::optional<tbb::global_control> threads;
  if (options.threads > 0)
    threads.emplace(tbb::global_control::max_allowed_parallelism,
                    static_cast<std::size_t>(options.threads));
  openvdb::initialize();

  SurfaceResult result;
  result.folder = options.dir + "/surface";
  makeFolder(result.folder);
  const std::string out = result.folder + "/";
  nlohmann::ordered_json manifest;
  manifest["scene"] = run.rootString("scene");
  manifest["particle_radius"] = radius;
  manifest["settings"] = {{"radius_factor", options.settings.radius_factor},
                          {"voxel_factor", options.settings.voxel_factor},
                          {"smoothing", options.settings.smoothing},
                          {"adaptivity", options.settings.adaptivity}};
  // Static bodies once, at their (only) pose.
  manifest["static_bodies"] = nlohmann::ordered_json::array();
  for (const RunBody& b : bodies)
    if (b.kind == "static" && !b.mesh.triangles.empty()) {
      const FloatVertices v = toFloat(b.mesh, b.pose(0));
      writeFileAtomically(out + b.name + ".ply", plyMesh(v, b.mesh.triangles));
      nlohmann::ordered_json j = meshJson(b.name + ".ply", v, b.mesh.triangles);
      j["name"] = b.name;
      manifest["static_bodies"].push_back(j);
    }
  manifest["frames"] = nlohmann::ordered_json::array();

  hdf5::Writer h5w;
  h5w.path = out + "surface.h5.partial";
  hdf5::Handle file =
      h5w.create(H5Fcreate(h5w.path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose,
                 "create the file");
  const hdf5::Handle frames_group = h5w.createGroup(file.get(), "frames");
  h5w.writeAttribute(file.get(), "particle_radius", radius);
  h5w.writeAttribute(file.get(), "radius_factor", options.settings.radius_factor);
  h5w.writeAttribute(file.get(), "voxel_factor", options.settings.voxel_factor);
  h5w.writeAttribute(file.get(), "smoothing", static_cast<double>(options.settings.smoothing));
  h5w.writeAttribute(file.get(), "adaptivity", options.settings.adaptivity);

  ProgressLine progress(logOf(options.quiet, options.log), options.interactive);
  std::vector<std::pair<std::size_t, std::size_t>> counts;
  RunFrame frame;
  for (std::size_t k = 0; k < frames; ++k) {
    run.readFrame(k, frame, true, false);
    const FluidSurface s = fluidSurface(frame.position, radius, options.settings);
    const std::string name = frameName(k);
    if (options.vdb) writeVdb(s.level_set, out + "fluid_" + name + ".vdb");
    writeFileAtomically(out + "fluid_" + name + ".ply", plyMesh(s.mesh.vertices, s.mesh.triangles));
    if (options.obj)
      writeFileAtomically(out + "fluid_" + name + ".obj",
                          objMesh(s.mesh.vertices, s.mesh.triangles));
    nlohmann::ordered_json entry = {
        {"frame", k},
        {"time", run.frameInfo(k).first},
        {"particles", frame.position.size()},
        {"fluid", meshJson("fluid_" + name + ".ply", s.mesh.vertices, s.mesh.triangles)},
        {"bodies", nlohmann::ordered_json::array()}};
    if (options.vdb) entry["fluid"]["vdb"] = "fluid_" + name + ".vdb";
    for (const RunBody& b : bodies)
      if (b.kind != "static" && !b.mesh.triangles.empty()) {
        const FloatVertices v = toFloat(b.mesh, b.pose(k));
        const std::string ply = b.name + "_" + name + ".ply";
        writeFileAtomically(out + ply, plyMesh(v, b.mesh.triangles));
        nlohmann::ordered_json j = meshJson(ply, v, b.mesh.triangles);
        j["name"] = b.name;
        entry["bodies"].push_back(j);
      }
    manifest["frames"].push_back(entry);
    const hdf5::Handle g = h5w.createGroup(frames_group.get(), name);
    h5w.writeDataset(g.get(), "vertices", H5T_NATIVE_FLOAT, s.mesh.vertices.data(),
                     s.mesh.vertices.size(), 3);
    h5w.writeDataset(g.get(), "triangles", H5T_NATIVE_UINT32, s.mesh.triangles.data(),
                     s.mesh.triangles.size(), 3);
    counts.emplace_back(s.mesh.vertices.size(), s.mesh.triangles.size());
    result.last_triangles = s.mesh.triangles.size();
    char line[160];
    std::snprintf(line, sizeof(line), "[wake] surface frame %zu/%zu  %zu triangles  %.1f s", k + 1,
                  frames, s.mesh.triangles.size(), progress.elapsed());
    progress.update(line, k + 1 == frames);
  }
  h5w.check(H5Fclose(file.release()), "close the file");
  renameFile(out + "surface.h5.partial", out + "surface.h5");
  writeFileAtomically(out + "surface.json", manifest.dump(1) + "\n");
  const std::string h5_name = fs::path(h5).filename().string();
  writeFileAtomically(options.dir + "/" + stemOf(h5) + ".xdmf",
                      xdmfIndex(runIndex(run, h5_name, bodies, &counts)));
  result.frames = frames;
  result.seconds = progress.elapsed();
  return result;
}

std::size_t exportParticles(const ExportOptions& options) {
  const std::string h5 = findRun(options.dir, options.scene);
  const RunFile run(h5);
  const std::size_t frames = run.frameCount();
  const std::string folder = options.dir + "/particles";
  makeFolder(folder);
  ProgressLine progress(logOf(options.quiet, options.log), options.interactive);
  RunFrame frame;
  for (std::size_t k = 0; k < frames; ++k) {
    run.readFrame(k, frame, true, true);
    run.readScalars(k, frame);
    writeFileAtomically(folder + "/particles_" + frameName(k) + ".ply", plyParticles(frame));
    char line[128];
    std::snprintf(line, sizeof(line), "[wake] export frame %zu/%zu  %zu particles", k + 1, frames,
                  frame.position.size());
    progress.update(line, k + 1 == frames);
  }
  return frames;
}

}  // namespace wake
