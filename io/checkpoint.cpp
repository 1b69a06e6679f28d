#include "io/checkpoint.hpp"

#include "io/files.hpp"
#include "io/hdf5_writer.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace wake {
namespace {

using hdf5::Handle;
using hdf5::QuietHdf5Errors;

constexpr const char* kFormat = "wake checkpoint 1";

static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 arrays are stored as N x 3 doubles");
static_assert(sizeof(Wrench) == 6 * sizeof(double), "wrenches are stored as bodies x 6");

std::string folderOf(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? "." : path.substr(0, slash);
}

}  // namespace

void writeCheckpoint(const std::string& path, const SimulationState& s,
                     const CheckpointInfo& info) {
  const QuietHdf5Errors quiet;
  const std::string tmp = path + ".tmp";
  hdf5::Writer w;
  w.path = tmp;
  {
    Handle file = w.create(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT),
                           H5Fclose, "create the file");
    const hid_t root = file.get();
    w.writeAttribute(root, "format", std::string(kFormat));
    w.writeAttribute(root, "wake_version", std::string(wakeVersion()));
    w.writeAttribute(root, "scene_path", info.scene_path);
    // A dataset, not an attribute: attributes are limited to 64 kB.
    w.writeDataset(root, "scene_text", H5T_NATIVE_UCHAR, info.scene_text.data(),
                   info.scene_text.size(), 1);
    w.writeAttribute(root, "end_time", info.end_time);
    w.writeAttribute(root, "resolution", info.resolution);
    w.writeAttribute(root, "checkpoint_every", info.checkpoint_every);
    w.writeAttribute(root, "frames", info.frames);
    if (info.output.frames() > 0) {
      const Handle out = w.createGroup(root, "output");
      const OutputIndex& o = info.output;
      w.writeDataset(out.get(), "frame_address", H5T_NATIVE_UINT64, o.frame_address.data(),
                     o.frame_address.size(), 1);
      w.writeDataset(out.get(), "body_rows", H5T_NATIVE_DOUBLE, o.body_rows.data(),
                     o.body_rows.size() / OutputIndex::kBodyRow, OutputIndex::kBodyRow);
    }

    const Handle g = w.createGroup(root, "state");
    const hid_t group = g.get();
    const RunCounters& run = s.run;
    w.writeAttribute(group, "time", run.time);
    w.writeAttribute(group, "last_dt", run.last_dt);
    w.writeAttribute(group, "max_density_ratio", run.max_density_ratio);
    w.writeAttribute(group, "window_density_ratio", run.window_density_ratio);
    w.writeAttribute(group, "steps", run.steps);
    w.writeAttribute(group, "removed_at_start", run.removed_at_start);
    w.writeAttribute(group, "lost", run.lost);
    w.writeAttribute(group, "max_penetrating", run.max_penetrating);
    w.writeAttribute(group, "window_penetrating", run.window_penetrating);
    w.writeAttribute(group, "last_contacts", run.last_contacts);
    w.writeAttribute(group, "density_error_sum", run.density_error_sum);
    w.writeAttribute(group, "max_step_density_error", run.max_step_density_error);
    w.writeAttribute(group, "solver_iterations", run.solver_iterations);
    w.writeAttribute(group, "divergence_iterations", run.divergence_iterations);
    const FluidState& f = s.fluid;
    const hsize_t n = f.size();
    w.writeDataset(group, "position", H5T_NATIVE_DOUBLE, f.position.data(), n, 3);
    w.writeDataset(group, "velocity", H5T_NATIVE_DOUBLE, f.velocity.data(), n, 3);
    w.writeDataset(group, "acceleration", H5T_NATIVE_DOUBLE, f.acceleration.data(), n, 3);
    w.writeDataset(group, "density", H5T_NATIVE_DOUBLE, f.density.data(), n, 1);
    w.writeDataset(group, "pressure", H5T_NATIVE_DOUBLE, f.pressure.data(), n, 1);
    w.writeDataset(group, "kinematic_viscosity", H5T_NATIVE_DOUBLE, f.kinematic_viscosity.data(), n,
                   1);
    w.writeDataset(group, "id", H5T_NATIVE_UINT32, f.id.data(), n, 1);
    if (f.keepsPressureMean())  // the divergence-free solver's (FluidState::pressure_mean)
      w.writeDataset(group, "pressure_mean", H5T_NATIVE_DOUBLE, f.pressure_mean.data(), n, 1);
    // Where the neighbour lists were last built (their skin): a resumed run builds them
    // where the uninterrupted one would.
    w.writeDataset(group, "neighbor_reference", H5T_NATIVE_DOUBLE, s.neighbor_reference.data(),
                   s.neighbor_reference.size(), 3);
    w.writeDataset(group, "neighbor_reference_id", H5T_NATIVE_UINT32,
                   s.neighbor_reference_id.data(), s.neighbor_reference_id.size(), 1);
    w.writeDataset(group, "wrenches", H5T_NATIVE_DOUBLE, s.wrenches.data(), s.wrenches.size(), 6);
    w.writeDataset(group, "solver_forces", H5T_NATIVE_DOUBLE, s.solver_forces.data(),
                   s.solver_forces.size(), 6);
    w.writeDataset(group, "rigid", H5T_NATIVE_DOUBLE, s.rigid.data(), s.rigid.size(), 1);
    w.check(H5Fclose(file.release()), "close the file");
  }
  syncFile(tmp);
  renameFile(tmp, path);
  syncFile(folderOf(path));
}

SimulationState readCheckpoint(const std::string& path, CheckpointInfo* info) {
  const QuietHdf5Errors quiet;
  hdf5::Writer r;
  r.path = path;
  if (::access(path.c_str(), R_OK) != 0)
    throw std::runtime_error("no checkpoint " + path + ": " + std::strerror(errno));
  const Handle file =
      r.create(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose, "open the file");
  const hid_t root = file.get();
  if (H5Aexists(root, "format") <= 0 || r.readStringAttribute(root, "format") != kFormat)
    throw std::runtime_error(path + " is not a Wake checkpoint (\"" + kFormat + "\")");
  if (info) {
    info->scene_path = r.readStringAttribute(root, "scene_path");
    const std::vector<unsigned char> text =
        r.readDataset<unsigned char>(root, "scene_text", H5T_NATIVE_UCHAR, 1);
    info->scene_text.assign(text.begin(), text.end());
    info->end_time = r.readAttribute<double>(root, "end_time", H5T_NATIVE_DOUBLE);
    info->resolution = r.readAttribute<double>(root, "resolution", H5T_NATIVE_DOUBLE);
    info->checkpoint_every = r.readAttribute<double>(root, "checkpoint_every", H5T_NATIVE_DOUBLE);
    info->frames = r.readAttribute<std::uint64_t>(root, "frames", H5T_NATIVE_UINT64);
    info->output = OutputIndex{};
    if (H5Lexists(root, "output", H5P_DEFAULT) > 0) {
      const Handle out = r.openGroup(root, "output");
      const std::vector<std::uint64_t> address =
          r.readDataset<std::uint64_t>(out.get(), "frame_address", H5T_NATIVE_UINT64, 1);
      info->output.frame_address = address;
      info->output.body_rows =
          r.readDataset<double>(out.get(), "body_rows", H5T_NATIVE_DOUBLE, OutputIndex::kBodyRow);
    }
  }
  const Handle g = r.openGroup(root, "state");
  const hid_t group = g.get();
  SimulationState s;
  auto u64 = [&](const char* name) {
    return r.readAttribute<std::uint64_t>(group, name, H5T_NATIVE_UINT64);
  };
  auto f64 = [&](const char* name) {
    return r.readAttribute<double>(group, name, H5T_NATIVE_DOUBLE);
  };
  RunCounters& run = s.run;
  run.time = f64("time");
  run.last_dt = f64("last_dt");
  run.max_density_ratio = f64("max_density_ratio");
  run.window_density_ratio = f64("window_density_ratio");
  run.steps = u64("steps");
  run.removed_at_start = u64("removed_at_start");
  run.lost = u64("lost");
  run.max_penetrating = u64("max_penetrating");
  run.window_penetrating = u64("window_penetrating");
  run.last_contacts = u64("last_contacts");
  // Counters added with the divergence-free solver: a checkpoint written before them
  // resumes with them at zero.
  auto optional_f64 = [&](const char* name) {
    return H5Aexists(group, name) > 0 ? f64(name) : 0.0;
  };
  auto optional_u64 = [&](const char* name) {
    return H5Aexists(group, name) > 0 ? u64(name) : std::uint64_t{0};
  };
  run.density_error_sum = optional_f64("density_error_sum");
  run.max_step_density_error = optional_f64("max_step_density_error");
  run.solver_iterations = optional_u64("solver_iterations");
  run.divergence_iterations = optional_u64("divergence_iterations");
  auto vec3s = [&](const char* name) {
    const std::vector<double> flat = r.readDataset<double>(group, name, H5T_NATIVE_DOUBLE, 3);
    std::vector<Vec3> out(flat.size() / 3);
    for (std::size_t i = 0; i < out.size(); ++i)
      out[i] = Vec3(flat[3 * i], flat[3 * i + 1], flat[3 * i + 2]);
    return out;
  };
  FluidState& f = s.fluid;
  f.position = vec3s("position");
  f.velocity = vec3s("velocity");
  f.acceleration = vec3s("acceleration");
  f.density = r.readDataset<double>(group, "density", H5T_NATIVE_DOUBLE, 1);
  f.pressure = r.readDataset<double>(group, "pressure", H5T_NATIVE_DOUBLE, 1);
  f.kinematic_viscosity = r.readDataset<double>(group, "kinematic_viscosity", H5T_NATIVE_DOUBLE, 1);
  f.id = r.readDataset<std::uint32_t>(group, "id", H5T_NATIVE_UINT32, 1);
  // Written since the divergence-free solver keeps it; without it the solver starts it
  // from the pressure.
  if (H5Lexists(group, "pressure_mean", H5P_DEFAULT) > 0) {
    f.keepPressureMean();
    f.pressure_mean = r.readDataset<double>(group, "pressure_mean", H5T_NATIVE_DOUBLE, 1);
  }
  // Written since the neighbour lists' skin; without them the resumed run builds at once.
  if (H5Lexists(group, "neighbor_reference", H5P_DEFAULT) > 0) {
    s.neighbor_reference = vec3s("neighbor_reference");
    s.neighbor_reference_id =
        r.readDataset<std::uint32_t>(group, "neighbor_reference_id", H5T_NATIVE_UINT32, 1);
  }
  // Bodies x 6 doubles (force, torque) as wrenches.
  auto wrenches = [&](const char* name) {
    const std::vector<double> w = r.readDataset<double>(group, name, H5T_NATIVE_DOUBLE, 6);
    std::vector<Wrench> out(w.size() / 6);
    for (std::size_t b = 0; b < out.size(); ++b) {
      out[b].force = Vec3(w[6 * b], w[6 * b + 1], w[6 * b + 2]);
      out[b].torque = Vec3(w[6 * b + 3], w[6 * b + 4], w[6 * b + 5]);
    }
    return out;
  };
  s.wrenches = wrenches("wrenches");
  // Written since the divergence-free solver sees the bodies' answer to its pressure;
  // without it the resumed run starts that view afresh.
  if (H5Lexists(group, "solver_forces", H5P_DEFAULT) > 0)
    s.solver_forces = wrenches("solver_forces");
  s.rigid = r.readDataset<double>(group, "rigid", H5T_NATIVE_DOUBLE, 1);
  return s;
}

}  // namespace wake
