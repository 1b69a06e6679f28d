#include "io/xdmf.hpp"

#include <algorithm>
#include <cstdio>
#include <iomanip>
#include <sstream>
#include <utility>

namespace wake {
namespace {

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

class Writer {
 public:
  std::ostringstream x;

  /// A DataItem of `rows` (x `cols` when cols > 1) values in HDF5 `file`:`path`.
  void item(const char* indent, std::size_t rows, int cols, const char* type, int bytes,
            const std::string& file, const std::string& path) {
    x << indent << "<DataItem Dimensions=\"" << rows;
    if (cols > 1) x << " " << cols;
    x << "\" NumberType=\"" << type << "\" Precision=\"" << bytes << "\" Format=\"HDF\">"
      << xmlEscape(file) << ":" << xmlEscape(path) << "</DataItem>\n";
  }

  template <class Time>
  void fluid(const XdmfRun& run, const XdmfFrame& f, Time&& time) {
    const std::string group = "/frames/" + frameName(f.index) + "/";
    const char* in = "            ";
    x << "      <Grid Name=\"fluid_" << frameName(f.index) << "\" GridType=\"Uniform\">\n";
    time();
    if (f.particles == 0) {
      x << "          <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"0\"/>\n"
        << "      </Grid>\n";
      return;
    }
    // One Polyvertex cell of all the particles (ParaView draws cells, not bare points):
    // its connectivity is the first `particles` entries of /particle_index (0, 1, 2, ...).
    x << "          <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"1\" "
         "NodesPerElement=\""
      << f.particles << "\">\n"
      << "            <DataItem ItemType=\"HyperSlab\" Dimensions=\"1 " << f.particles
      << "\" Type=\"HyperSlab\">\n"
      << "              <DataItem Dimensions=\"3 1\" Format=\"XML\">0 1 " << f.particles
      << "</DataItem>\n";
    item("              ", run.particle_index, 1, "UInt", 4, run.h5, "/particle_index");
    x << "            </DataItem>\n          </Topology>\n"
      << "          <Geometry GeometryType=\"XYZ\">\n";
    item(in, f.particles, 3, "Float", 8, run.h5, group + "position");
    x << "          </Geometry>\n";
    struct Field {
      const char* name;
      const char* kind;
      int cols;
      const char* type;
      int bytes;
    };
    for (const Field& a :
         {Field{"velocity", "Vector", 3, "Float", 8}, Field{"density", "Scalar", 1, "Float", 8},
          Field{"pressure", "Scalar", 1, "Float", 8}, Field{"id", "Scalar", 1, "UInt", 4}}) {
      x << "          <Attribute Name=\"" << a.name << "\" AttributeType=\"" << a.kind
        << "\" Center=\"Node\">\n";
      item(in, f.particles, a.cols, a.type, a.bytes, run.h5, group + a.name);
      x << "          </Attribute>\n";
    }
    x << "      </Grid>\n";
  }

  template <class Time>
  void mesh(const XdmfMesh& m, std::size_t k, Time&& time) {
    const char* in = "            ";
    x << "      <Grid Name=\"" << xmlEscape(m.name) << "_" << frameName(k)
      << "\" GridType=\"Uniform\">\n";
    time();
    x << ""
      << "          <Topology TopologyType=\"Triangle\" NumberOfElements=\"" << m.triangle_count
      << "\">\n";
    item(in, m.triangle_count, 3, "UInt", 4, m.file, m.triangles);
    x << "          </Topology>\n          <Geometry GeometryType=\"XYZ\">\n";
    item(in, m.vertex_count, 3, "Float", m.vertex_bytes, m.file, m.vertices);
    x << "          </Geometry>\n      </Grid>\n";
  }
};

}  // namespace

std::string frameName(std::size_t k) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%06zu", k);
  return buf;
}

XdmfMesh bodyMeshEntry(const std::string& h5, const std::string& name, bool moves, std::size_t k,
                       std::size_t vertices, std::size_t triangles) {
  const std::string group = "/bodies/" + name + "/";
  return XdmfMesh{"body_" + name,
                  h5,
                  moves ? "/frames/" + frameName(k) + "/bodies/" + name : group + "mesh_world",
                  group + "mesh_triangles",
                  vertices,
                  triangles,
                  4};
}

std::string xdmfIndex(const XdmfRun& run) {
  Writer w;
  w.x << std::setprecision(12);
  w.x << "<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
      << "<Xdmf Version=\"2.0\">\n  <Domain>\n";
  // One temporal collection per object (fluid, each body, the surface): ParaView shows
  // each as a named block of its own, with its own visibility and colouring.
  auto open = [&](const std::string& name) {
    w.x << "    <Grid Name=\"" << xmlEscape(name)
        << "\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  };
  auto time = [&](const XdmfFrame& f) { w.x << "        <Time Value=\"" << f.time << "\"/>\n"; };
  open("fluid");
  for (const XdmfFrame& f : run.frames)
    w.fluid(run, f, [&] { time(f); });
  w.x << "    </Grid>\n";
  // The meshes in one order whoever writes the index: bodies by name, the surface last.
  std::vector<std::size_t> order(run.frames.empty() ? 0 : run.frames.front().meshes.size());
  for (std::size_t m = 0; m < order.size(); ++m)
    order[m] = m;
  auto key = [&](std::size_t m) {
    const std::string& name = run.frames.front().meshes[m].name;
    return std::make_pair(name == "surface", name);
  };
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return key(a) < key(b); });
  for (const std::size_t m : order) {
    open(run.frames.front().meshes[m].name);
    for (const XdmfFrame& f : run.frames)
      if (m < f.meshes.size()) w.mesh(f.meshes[m], f.index, [&] { time(f); });
    w.x << "    </Grid>\n";
  }
  w.x << "  </Domain>\n</Xdmf>\n";
  return w.x.str();
}

}  // namespace wake
