// `wake surface` and `wake export` end to end: a small run with a dynamic box is surfaced;
// the files are read back (binary PLY parsed here, the HDF5 with its C API) and checked
// against the run's own data: the water mesh against the particles it came from, the
// bodies' meshes against their poses, the particle caches against the frames, the XDMF
// against the files it names. Bad input exits 2 naming the problem.
#include "io/io_test_support.hpp"

#include <gtest/gtest.h>
#include <hdf5.h>
#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using wake::test::CliResult;
using wake::test::countOf;
using wake::test::datasetDims;
using wake::test::readDataset;
using wake::test::readFile;
using wake::test::runWake;
using wake::test::TempDir;

const std::string kFloatScene = std::string(WAKE_TEST_DATA_DIR) + "/scenes/small_float.json";

/// A binary little-endian PLY read back: its header's elements and properties, and the
/// data as bytes.
struct Ply {
  std::vector<std::pair<std::string, std::size_t>> elements;
  std::vector<std::string> header;
  std::string body;

  explicit Ply(const std::string& bytes) {
    const std::size_t end = bytes.find("end_header\n");
    EXPECT_NE(end, std::string::npos);
    std::istringstream h(bytes.substr(0, end));
    for (std::string line; std::getline(h, line);) {
      header.push_back(line);
      std::istringstream l(line);
      std::string word, name;
      std::size_t count = 0;
      l >> word;
      if (word == "element" && l >> name >> count) elements.emplace_back(name, count);
    }
    body = bytes.substr(end + 11);
    EXPECT_EQ(header.at(1), "format binary_little_endian 1.0");
  }
  template <class T>
  T at(std::size_t offset) const {
    T v;
    std::memcpy(&v, body.data() + offset, sizeof(T));
    return v;
  }
};

class SurfaceRun : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir();
    run_ = new CliResult(runWake("run \"" + kFloatScene + "\" --out \"" + out().string() +
                                     "\" --end 0.1 --threads 1 --surface --obj --quiet",
                                 dir_->path));
    export_ = new CliResult(runWake("export \"" + out().string() + "\" --quiet", dir_->path));
  }
  static void TearDownTestSuite() {
    delete export_;
    delete run_;
    delete dir_;
  }
  static fs::path out() { return dir_->path / "out"; }
  static json manifest() { return json::parse(readFile(out() / "surface" / "surface.json")); }
  static TempDir* dir_;
  static CliResult *run_, *export_;
};
TempDir* SurfaceRun::dir_ = nullptr;
CliResult* SurfaceRun::run_ = nullptr;
CliResult* SurfaceRun::export_ = nullptr;

TEST_F(SurfaceRun, WritesEveryFramesFilesAndTheManifest) {
  ASSERT_EQ(run_->status, 0) << run_->err;
  const json m = manifest();
  ASSERT_EQ(m["frames"].size(), 11u);  // 0.1 s at 100 frames/s, and t = 0
  EXPECT_EQ(m["scene"], "small_float");
  for (const json& f : m["frames"]) {
    const std::string k = f["fluid"]["file"].get<std::string>().substr(6, 6);
    for (const std::string ext : {".ply", ".obj", ".vdb"})
      EXPECT_TRUE(fs::is_regular_file(out() / "surface" / ("fluid_" + k + ext))) << k << ext;
    ASSERT_EQ(f["bodies"].size(), 1u);
    EXPECT_EQ(f["bodies"][0]["name"], "box");
    EXPECT_EQ(f["particles"], 200);
  }
  ASSERT_EQ(m["static_bodies"].size(), 1u);
  EXPECT_EQ(m["static_bodies"][0]["file"], "tank.ply");
  EXPECT_TRUE(fs::is_regular_file(out() / "surface" / "surface.h5"));
  for (const auto& entry : fs::directory_iterator(out() / "surface"))
    EXPECT_EQ(entry.path().extension().string().find("tmp"), std::string::npos) << entry.path();
}

TEST_F(SurfaceRun, TheWaterMeshWrapsTheParticlesItCameFrom) {
  ASSERT_EQ(run_->status, 0) << run_->err;
  const json m = manifest();
  const double r = m["particle_radius"];
  const hid_t file = H5Fopen((out() / "small_float.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  for (const int k : {0, 10}) {
    const json& f = m["frames"][k];
    char name[32];
    std::snprintf(name, sizeof(name), "/frames/%06d/position", k);
    const std::vector<double> x = readDataset<double>(file, name, H5T_NATIVE_DOUBLE);
    std::array<double, 3> lo{1e9, 1e9, 1e9}, hi{-1e9, -1e9, -1e9};
    for (std::size_t i = 0; i < x.size(); ++i) {
      lo[i % 3] = std::min(lo[i % 3], x[i]);
      hi[i % 3] = std::max(hi[i % 3], x[i]);
    }
    // The mesh reaches about r beyond the outer centres (within a voxel: r here).
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(f["fluid"]["min"][a].get<double>(), lo[a] - r, 1.1 * r) << "frame " << k;
      EXPECT_NEAR(f["fluid"]["max"][a].get<double>(), hi[a] + r, 1.1 * r) << "frame " << k;
    }
    // The PLY holds what the manifest says, and its vertices lie within those bounds.
    const Ply ply(readFile(out() / "surface" / f["fluid"]["file"].get<std::string>()));
    ASSERT_EQ(ply.elements.size(), 2u);
    EXPECT_EQ(ply.elements[0].second, f["fluid"]["vertices"].get<std::size_t>());
    EXPECT_EQ(ply.elements[1].second, f["fluid"]["triangles"].get<std::size_t>());
    const std::size_t nv = ply.elements[0].second, nt = ply.elements[1].second;
    ASSERT_EQ(ply.body.size(), 12 * nv + 13 * nt);
    for (std::size_t v = 0; v < nv; ++v)
      for (int a = 0; a < 3; ++a) {
        const float c = ply.at<float>(12 * v + 4 * a);
        EXPECT_GE(c, f["fluid"]["min"][a].get<float>() - 1e-6f);
        EXPECT_LE(c, f["fluid"]["max"][a].get<float>() + 1e-6f);
      }
    for (std::size_t t = 0; t < nt; ++t) {
      ASSERT_EQ(ply.at<std::uint8_t>(12 * nv + 13 * t), 3);
      for (int c = 0; c < 3; ++c)
        ASSERT_LT(ply.at<std::int32_t>(12 * nv + 13 * t + 1 + 4 * c), static_cast<int>(nv));
    }
  }
  H5Fclose(file);
}

TEST_F(SurfaceRun, TheBoxMeshFollowsTheBoxsPose) {
  ASSERT_EQ(run_->status, 0) << run_->err;
  const json m = manifest();
  const hid_t file = H5Fopen((out() / "small_float.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  const std::vector<double> centre =
      readDataset<double>(file, "/bodies/box/position", H5T_NATIVE_DOUBLE);
  // The box's mesh: 6 faces, 2 triangles each, in its body frame (half extents 0.04, 0.02, 0.03).
  EXPECT_EQ(datasetDims(file, "/bodies/box/mesh_triangles"), (std::vector<hsize_t>{12, 3}));
  EXPECT_EQ(datasetDims(file, "/bodies/tank/mesh_world")[1], 3u);
  for (const int k : {0, 5, 10}) {
    const json& b = m["frames"][k]["bodies"][0];
    // Its bounds are centred on the body's position of that frame.
    for (int a = 0; a < 3; ++a)
      EXPECT_NEAR(0.5 * (b["min"][a].get<double>() + b["max"][a].get<double>()), centre[3 * k + a],
                  1e-5)
          << "frame " << k;
    EXPECT_EQ(b["triangles"], 12);
    char name[48];
    std::snprintf(name, sizeof(name), "/frames/%06d/bodies/box", k);
    EXPECT_EQ(datasetDims(file, name), (std::vector<hsize_t>{b["vertices"].get<hsize_t>(), 3}));
  }
  H5Fclose(file);
}

TEST_F(SurfaceRun, TheXdmfNamesTheSurfaceAndBodiesOfEveryTimeStep) {
  ASSERT_EQ(run_->status, 0) << run_->err;
  const std::string x = readFile(out() / "small_float.xdmf");
  const std::size_t surfaces = countOf(x, "Name=\"surface_0");
  const std::size_t boxes = countOf(x, "Name=\"body_box_0");
  const std::size_t times = countOf(x, "<Time ");
  EXPECT_EQ(times, 11u * 4);  // fluid, box, tank, surface: a grid per frame each
  EXPECT_EQ(surfaces, 11u);
  EXPECT_EQ(boxes, 11u);
  EXPECT_NE(x.find("surface/surface.h5:/frames/000010/triangles"), std::string::npos);
  EXPECT_NE(x.find("small_float.h5:/particle_index"), std::string::npos);
  // Every dataset the index names exists with the dimensions it states.
  const hid_t run = H5Fopen((out() / "small_float.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t surf =
      H5Fopen((out() / "surface" / "surface.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(run, 0);
  ASSERT_GE(surf, 0);
  std::size_t checked = 0;
  const std::string open = "<DataItem Dimensions=\"";
  for (auto at = x.find(open); at != std::string::npos; at = x.find(open, at + 1)) {
    const auto close = x.find("</DataItem>", at);
    const std::string item = x.substr(at, close - at);
    const auto colon = item.rfind(':'), gt = item.find('>');
    if (item.find("Format=\"HDF\"") == std::string::npos) continue;
    const std::string file = item.substr(gt + 1, colon - gt - 1), path = item.substr(colon + 1);
    const std::string dims = item.substr(open.size(), item.find('"', open.size()) - open.size());
    const std::vector<hsize_t> actual = datasetDims(file == "small_float.h5" ? run : surf, path);
    std::ostringstream s;
    for (std::size_t i = 0; i < actual.size(); ++i)
      s << (i ? " " : "") << actual[i];
    EXPECT_EQ(s.str(), dims) << file << ":" << path;
    ++checked;
  }
  EXPECT_GT(checked, 11u * 8);
  H5Fclose(surf);
  H5Fclose(run);
}

TEST_F(SurfaceRun, ExportWritesTheParticlesOfEveryFrameAsPly) {
  ASSERT_EQ(export_->status, 0) << export_->err;
  const hid_t file = H5Fopen((out() / "small_float.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  for (const int k : {0, 7}) {
    char name[64];
    std::snprintf(name, sizeof(name), "particles_%06d.ply", k);
    const Ply ply(readFile(out() / "particles" / name));
    ASSERT_EQ(ply.elements.size(), 1u);
    const std::size_t n = ply.elements[0].second;
    ASSERT_EQ(n, 200u);
    ASSERT_EQ(ply.body.size(), 32 * n);
    std::snprintf(name, sizeof(name), "/frames/%06d/", k);
    const std::vector<double> x =
        readDataset<double>(file, std::string(name) + "position", H5T_NATIVE_DOUBLE);
    const std::vector<double> v =
        readDataset<double>(file, std::string(name) + "velocity", H5T_NATIVE_DOUBLE);
    const std::vector<double> rho =
        readDataset<double>(file, std::string(name) + "density", H5T_NATIVE_DOUBLE);
    const std::vector<std::uint32_t> id =
        readDataset<std::uint32_t>(file, std::string(name) + "id", H5T_NATIVE_UINT32);
    for (std::size_t i = 0; i < n; i += 37) {
      for (int a = 0; a < 3; ++a) {
        EXPECT_EQ(ply.at<float>(32 * i + 4 * a), static_cast<float>(x[3 * i + a]));
        EXPECT_EQ(ply.at<float>(32 * i + 12 + 4 * a), static_cast<float>(v[3 * i + a]));
      }
      EXPECT_EQ(ply.at<float>(32 * i + 24), static_cast<float>(rho[i]));
      EXPECT_EQ(ply.at<std::uint32_t>(32 * i + 28), id[i]);
    }
  }
  H5Fclose(file);
}

TEST_F(SurfaceRun, BadInputExitsTwoNamingIt) {
  ASSERT_EQ(run_->status, 0) << run_->err;
  const std::string dir = "\"" + out().string() + "\"";
  struct Bad {
    std::string args, names;
  };
  for (const Bad& b :
       {Bad{"surface " + dir + " --voxel-factor 5", "surface.voxel_factor"},
        Bad{"surface " + dir + " --radius-factor 0", "surface.radius_factor"},
        Bad{"surface " + dir + " --smoothing -1", "surface.smoothing"},
        Bad{"surface " + dir + " --adaptivity 2", "surface.adaptivity"},
        Bad{"surface " + dir + " --scene nope", "--scene"},
        Bad{"surface \"" + dir_->path.string() + "\"", "no finished run"},
        Bad{"export \"" + (dir_->path / "missing").string() + "\"", "not a folder"},
        Bad{"run \"" + kFloatScene + "\" --out " + dir + " --surface --voxel-factor 9",
            "surface.voxel_factor"}}) {
    const std::string before = readFile(out() / "surface" / "surface.json");
    const CliResult r = runWake(b.args, dir_->path);
    EXPECT_EQ(r.status, 2) << b.args << ": " << r.err;
    EXPECT_NE(r.err.find(b.names), std::string::npos) << b.args << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(readFile(out() / "surface" / "surface.json"), before) << b.args;
  }
}

}  // namespace
