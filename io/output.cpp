// HDF5 (C API) + XDMF frame writer; layout in output.hpp.
#include "io/output.hpp"

#include "io/files.hpp"
#include "io/hdf5_handle.hpp"
#include "io/scene.hpp"

#include <hdf5.h>

#include <array>
#include <cstdint>
#include <cstdio>
#include <iomanip>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace wake {
namespace {

using hdf5::Handle;
using hdf5::QuietHdf5Errors;

static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 arrays are written as N x 3 doubles");

std::string frameName(std::size_t k) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%06zu", k);
  return buf;
}

std::string xmlEscape(const std::string& s) {
  std::string out;
  for (const char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string fileName(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

/// One per-body series: extendible datasets with one row per output frame.
struct BodySeries {
  Handle group, time, position, orientation, linear_velocity, angular_velocity;
};

/// One output frame as the XDMF index lists it.
struct FrameEntry {
  std::size_t index;
  double time;        ///< s
  std::size_t count;  ///< fluid particles
};

}  // namespace

struct FrameWriter::Impl {
  std::string h5_final, h5_partial, xdmf_final, xdmf_partial;
  Handle file, frames_group, bodies_group;
  std::vector<BodySeries> bodies;  // in the order of sim.bodyStates()
  std::vector<FrameEntry> entries;
  bool finished = false;

  // Every HDF5 call goes through check(): a negative result becomes an exception naming
  // the file and what was being done.
  template <class Id>
  Id check(Id result, const std::string& what) const {
    if (result < 0) throw std::runtime_error("HDF5: cannot " + what + " in " + h5_partial);
    return result;
  }
  Handle create(hid_t id, Handle::Closer close, const std::string& what) const {
    return Handle(check(id, what), close);
  }
  Handle createGroup(hid_t parent, const std::string& name) const {
    return create(H5Gcreate2(parent, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                  "create group " + name);
  }

  void writeAttribute(hid_t object, const char* name, const double* values, hsize_t n) const {
    const Handle space = create(n == 1 ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &n, nullptr),
                                H5Sclose, std::string("create dataspace for ") + name);
    const Handle attr =
        create(H5Acreate2(object, name, H5T_NATIVE_DOUBLE, space.get(), H5P_DEFAULT, H5P_DEFAULT),
               H5Aclose, std::string("create attribute ") + name);
    check(H5Awrite(attr.get(), H5T_NATIVE_DOUBLE, values), std::string("write attribute ") + name);
  }
  void writeAttribute(hid_t object, const char* name, double value) const {
    writeAttribute(object, name, &value, 1);
  }
  void writeAttribute(hid_t object, const char* name, const std::string& value) const {
    const Handle type = create(H5Tcopy(H5T_C_S1), H5Tclose, "create string type");
    check(H5Tset_size(type.get(), value.empty() ? 1 : value.size()), "set string size");
    check(H5Tset_cset(type.get(), H5T_CSET_UTF8), "set string character set");
    const Handle space = create(H5Screate(H5S_SCALAR), H5Sclose, "create dataspace");
    const Handle attr =
        create(H5Acreate2(object, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT),
               H5Aclose, std::string("create attribute ") + name);
    const std::string padded = value.empty() ? std::string(1, '\0') : value;
    check(H5Awrite(attr.get(), type.get(), padded.data()), std::string("write attribute ") + name);
  }

  /// Writes a fixed-size dataset of `rows` x `cols` values (cols == 1: a 1-D dataset).
  void writeDataset(hid_t group, const char* name, hid_t type, const void* data, hsize_t rows,
                    hsize_t cols) const {
    const hsize_t dims[2] = {rows, cols};
    const Handle space =
        create(H5Screate_simple(cols == 1 ? 1 : 2, dims, nullptr), H5Sclose, "create dataspace");
    const Handle set =
        create(H5Dcreate2(group, name, type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
               H5Dclose, std::string("create dataset ") + name);
    // HDF5 refuses a null buffer even for zero elements; an empty dataset needs no write.
    if (rows > 0)
      check(H5Dwrite(set.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data),
            std::string("write dataset ") + name);
  }

  /// Creates an empty dataset of 0 x `cols` rows that grows by one row per frame.
  Handle createSeries(hid_t group, const char* name, hsize_t cols) const {
    const hsize_t dims[2] = {0, cols};
    const hsize_t max_dims[2] = {H5S_UNLIMITED, cols};
    const hsize_t chunk[2] = {256, cols};
    const int rank = cols == 1 ? 1 : 2;
    const Handle space =
        create(H5Screate_simple(rank, dims, max_dims), H5Sclose, "create dataspace");
    const Handle props = create(H5Pcreate(H5P_DATASET_CREATE), H5Pclose, "create properties");
    check(H5Pset_chunk(props.get(), rank, chunk), "set chunk size");
    return create(H5Dcreate2(group, name, H5T_NATIVE_DOUBLE, space.get(), H5P_DEFAULT, props.get(),
                             H5P_DEFAULT),
                  H5Dclose, std::string("create dataset ") + name);
  }

  /// Appends row `row` (the frame index) of `cols` doubles to a series.
  void appendRow(const Handle& set, hsize_t row, const double* values, hsize_t cols) const {
    const int rank = cols == 1 ? 1 : 2;
    const hsize_t new_dims[2] = {row + 1, cols};
    check(H5Dset_extent(set.get(), new_dims), "extend a body series");
    const Handle file_space = create(H5Dget_space(set.get()), H5Sclose, "get dataspace");
    const hsize_t start[2] = {row, 0};
    const hsize_t count[2] = {1, cols};
    check(H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start, nullptr, count, nullptr),
          "select a row");
    const Handle memory_space =
        create(H5Screate_simple(rank, count, nullptr), H5Sclose, "create dataspace");
    check(H5Dwrite(set.get(), H5T_NATIVE_DOUBLE, memory_space.get(), file_space.get(), H5P_DEFAULT,
                   values),
          "append to a body series");
  }

  /// Each body's boundary samples in its body frame (surface_points, surface_normals) and
  /// its kind, from the samples at the current pose. Groups in the order of sim.bodyStates().
  void writeSurfaces(const Simulation& sim) const {
    const Boundaries& boundaries = sim.boundaries();
    std::vector<Vec3> position, normal;
    std::vector<double> volume;
    std::vector<std::uint32_t> owner;
    boundaries.worldSamples(position, normal, volume, owner);
    std::vector<std::vector<Vec3>> points(boundaries.bodyCount()), normals(boundaries.bodyCount());
    for (std::size_t b = 0; b < boundaries.bodyCount(); ++b) {
      points[b].reserve(boundaries.bodySampleCount(b));
      normals[b].reserve(boundaries.bodySampleCount(b));
    }
    for (std::size_t k = 0; k < position.size(); ++k) {
      const std::uint32_t b = owner[k];
      if (b >= boundaries.bodyCount()) continue;
      const Pose& pose = boundaries.body(b).pose;
      points[b].push_back(pose.toBody(position[k]));
      normals[b].push_back(pose.orientation.conjugate() * normal[k]);
    }
    for (std::size_t b = 0; b < boundaries.bodyCount() && b < bodies.size(); ++b) {
      const hid_t group = bodies[b].group.get();
      const hsize_t m = points[b].size();
      writeDataset(group, "surface_points", H5T_NATIVE_DOUBLE, points[b].data(), m, 3);
      writeDataset(group, "surface_normals", H5T_NATIVE_DOUBLE, normals[b].data(), m, 3);
      const BodyKind kind = boundaries.body(b).kind;
      writeAttribute(group, "kind",
                     std::string(kind == BodyKind::Static      ? "static"
                                 : kind == BodyKind::Kinematic ? "kinematic"
                                                               : "dynamic"));
    }
  }

  /// The XDMF index of all frames so far, its data in the HDF5 file `h5_name` (relative).
  std::string xdmf(const std::string& h5_name) const {
    std::ostringstream x;
    x << std::setprecision(12);
    const std::string h5 = xmlEscape(h5_name);
    auto item = [&](std::size_t n, int cols, const char* type, int bytes, const std::string& path) {
      x << "          <DataItem Dimensions=\"" << n << (cols > 1 ? " 3" : "") << "\" NumberType=\""
        << type << "\" Precision=\"" << bytes << "\" Format=\"HDF\">" << h5 << ":" << path
        << "</DataItem>\n";
    };
    x << "<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
      << "<Xdmf Version=\"2.0\">\n  <Domain>\n"
      << "    <Grid Name=\"fluid\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
    for (const FrameEntry& e : entries) {
      const std::string group = "/frames/" + frameName(e.index) + "/";
      x << "      <Grid Name=\"frame_" << frameName(e.index) << "\" GridType=\"Uniform\">\n"
        << "        <Time Value=\"" << e.time << "\"/>\n"
        << "        <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << e.count
        << "\" NodesPerElement=\"1\"/>\n"
        << "        <Geometry GeometryType=\"XYZ\">\n";
      item(e.count, 3, "Float", 8, group + "position");
      x << "        </Geometry>\n";
      struct Field {
        const char* name;
        const char* kind;
        int cols;
        const char* type;
        int bytes;
      };
      for (const Field& f :
           {Field{"velocity", "Vector", 3, "Float", 8}, Field{"density", "Scalar", 1, "Float", 8},
            Field{"pressure", "Scalar", 1, "Float", 8}, Field{"id", "Scalar", 1, "UInt", 4}}) {
        x << "        <Attribute Name=\"" << f.name << "\" AttributeType=\"" << f.kind
          << "\" Center=\"Node\">\n";
        item(e.count, f.cols, f.type, f.bytes, group + f.name);
        x << "        </Attribute>\n";
      }
      x << "      </Grid>\n";
    }
    x << "    </Grid>\n  </Domain>\n</Xdmf>\n";
    return x.str();
  }
};

FrameWriter::FrameWriter(const std::string& out_dir, const SceneFile& scene, const Simulation& sim)
    : impl_(std::make_unique<Impl>()) {
  const QuietHdf5Errors quiet;
  Impl& d = *impl_;
  const std::string stem = out_dir + "/" + scene.name;
  d.h5_final = stem + ".h5";
  d.h5_partial = d.h5_final + ".partial";
  d.xdmf_final = stem + ".xdmf";
  d.xdmf_partial = d.xdmf_final + ".partial";

  d.file = d.create(H5Fcreate(d.h5_partial.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT),
                    H5Fclose, "create the file");
  const hid_t root = d.file.get();
  const FluidParams& fluid = sim.fluid().params();
  d.writeAttribute(root, "scene", scene.name);
  d.writeAttribute(root, "wake_version", std::string(wakeVersion()));
  d.writeAttribute(root, "particle_radius", fluid.particle_radius);     // m
  d.writeAttribute(root, "rest_density", fluid.rest_density);           // kg/m^3
  d.writeAttribute(root, "speed_of_sound", fluid.speed_of_sound);       // m/s (resolved)
  d.writeAttribute(root, "smoothing_ratio", fluid.smoothing_ratio);     // H / spacing
  d.writeAttribute(root, "frame_rate", scene.frame_rate);               // 1/s
  d.writeAttribute(root, "gravity", sim.settings().gravity.data(), 3);  // m/s^2

  d.frames_group = d.createGroup(root, "frames");
  d.bodies_group = d.createGroup(root, "bodies");
  for (const BodyState& body : sim.bodyStates()) {
    BodySeries s;
    s.group = d.createGroup(d.bodies_group.get(), body.name);
    s.time = d.createSeries(s.group.get(), "time", 1);
    s.position = d.createSeries(s.group.get(), "position", 3);
    s.orientation = d.createSeries(s.group.get(), "orientation", 4);
    s.linear_velocity = d.createSeries(s.group.get(), "linear_velocity", 3);
    s.angular_velocity = d.createSeries(s.group.get(), "angular_velocity", 3);
    d.bodies.push_back(std::move(s));
  }
  d.writeSurfaces(sim);
  d.check(H5Fflush(root, H5F_SCOPE_GLOBAL), "flush the file");
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
  for (std::size_t i = 0; i < states.size(); ++i) {
    const BodyState& b = states[i];
    const BodySeries& s = d.bodies[i];
    const std::array<double, 4> xyzw = {b.orientation.x(), b.orientation.y(), b.orientation.z(),
                                        b.orientation.w()};
    d.appendRow(s.time, k, &time, 1);
    d.appendRow(s.position, k, b.position.data(), 3);
    d.appendRow(s.orientation, k, xyzw.data(), 4);
    d.appendRow(s.linear_velocity, k, b.linear_velocity.data(), 3);
    d.appendRow(s.angular_velocity, k, b.angular_velocity.data(), 3);
  }
  d.check(H5Fflush(d.file.get(), H5F_SCOPE_GLOBAL), "flush the file");

  d.entries.push_back(FrameEntry{k, time, static_cast<std::size_t>(n)});
  writeFileAtomically(d.xdmf_partial, d.xdmf(fileName(d.h5_partial)));
}

void FrameWriter::finish() {
  const QuietHdf5Errors quiet;
  Impl& d = *impl_;
  if (d.finished) return;
  d.bodies.clear();
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
const std::string& FrameWriter::h5Path() const {
  return impl_->h5_final;
}
const std::string& FrameWriter::xdmfPath() const {
  return impl_->xdmf_final;
}

}  // namespace wake
