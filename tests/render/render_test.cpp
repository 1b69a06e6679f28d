// `wake render` and the body surfaces in the HDF5 output: a tiny tank with a floating box is
// run into a temporary folder, its surfaces are read back and compared with the simulation's
// boundary samples, and its frames are rendered and read back with stb_image.
#include "render/render.hpp"
#include "bullet_bridge/scene_world.hpp"
#include "io/run.hpp"

#include "io/io_test_support.hpp"

#include <gtest/gtest.h>
#include <hdf5.h>
#include <stb/stb_image.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace wake {
namespace {

namespace fs = std::filesystem;
using test::datasetDims;
using test::readFile;

std::vector<double> readDoubles(hid_t file, const std::string& name) {
  return test::readDataset<double>(file, name, H5T_NATIVE_DOUBLE);
}

const char* const kScene = R"({
  "name": "render_tank",
  "gravity": [0, -9.81, 0],
  "time": { "end": 0.02, "frame_rate": 100 },
  "fluid": {
    "particle_radius": 0.008,
    "blocks": [ { "min": [0, 0, 0], "max": [0.1, 0.08, 0.1] } ]
  },
  "bodies": [
    { "name": "tank", "kind": "static",
      "shape": { "type": "tank", "min": [0, 0, 0], "max": [0.2, 0.15, 0.1] } },
    { "name": "crate", "kind": "dynamic", "density": 500, "position": [0.15, 0.06, 0.05],
      "shape": { "type": "box", "half_extents": [0.025, 0.02, 0.025] } }
  ]
})";

/// The tiny scene, run once per test program into a temporary folder.
class RenderTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ =
        new fs::path(fs::temp_directory_path() / ("wake_render_test_" + std::to_string(getpid())));
    fs::remove_all(*root_);
    fs::create_directories(*root_);
    RunOptions options;
    options.out_dir = runDir().string();
    options.quiet = true;
    runScene(scene(), options);
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    fs::remove_all(*root_, ec);
    delete root_;
  }
  static SceneFile scene() { return parseScene(kScene, (*root_ / "render_tank.json").string()); }
  static fs::path runDir() { return *root_ / "run"; }
  static fs::path h5() { return runDir() / "render_tank.h5"; }

  struct Cli {
    int status = -1;
    std::string err;
  };
  static Cli wake(const std::string& args) {
    const fs::path err = *root_ / "stderr.txt";
    const std::string command =
        std::string("\"") + WAKE_CLI_PATH + "\" " + args + " >/dev/null 2>\"" + err.string() + "\"";
    const int raw = std::system(command.c_str());
    Cli r;
    r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
    r.err = readFile(err);
    return r;
  }

  static fs::path* root_;
};
fs::path* RenderTest::root_ = nullptr;

std::string readStringAttribute(hid_t file, const std::string& object, const char* name) {
  const hid_t attr = H5Aopen_by_name(file, object.c_str(), name, H5P_DEFAULT, H5P_DEFAULT);
  if (attr < 0) return "<missing>";
  const hid_t type = H5Aget_type(attr);
  std::string s(H5Tget_size(type), '\0');
  H5Aread(attr, type, &s[0]);
  H5Tclose(type);
  H5Aclose(attr);
  return s.c_str();
}

struct Png {
  int width = 0, height = 0;
  std::vector<unsigned char> rgb;
  const unsigned char* at(int x, int y) const { return &rgb[3 * (std::size_t(y) * width + x)]; }
};

Png loadPng(const fs::path& path) {
  Png png;
  int channels = 0;
  unsigned char* data = stbi_load(path.string().c_str(), &png.width, &png.height, &channels, 3);
  if (!data) return png;
  png.rgb.assign(data, data + std::size_t(png.width) * png.height * 3);
  stbi_image_free(data);
  return png;
}

/// Calls f(pixel colour, row) for every point of `xyz` (x, y, z, x, y, z, ...) that the
/// render's camera projects inside the image; returns how many did.
template <class T, class F>
std::size_t forEachProjectedPixel(const RenderResult& r, const Png& png, const std::vector<T>& xyz,
                                  F&& f) {
  std::size_t inside = 0;
  for (std::size_t k = 0; k + 2 < xyz.size(); k += 3) {
    double sx, sy, depth;
    if (!r.camera.project(Vec3(xyz[k], xyz[k + 1], xyz[k + 2]), sx, sy, depth)) continue;
    const int px = static_cast<int>(sx), py = static_cast<int>(sy);
    if (px < 0 || py < 0 || px >= png.width || py >= png.height) continue;
    ++inside;
    f(png.at(px, py), py);
  }
  return inside;
}

TEST_F(RenderTest, BodySurfacesAreWrittenInTheBodyFrame) {
  SceneFile s = scene();
  SceneWorld world(s.sim, s.bodies);
  world.coupled().start();
  const Boundaries& boundaries = world.simulation().boundaries();
  ASSERT_EQ(boundaries.bodyCount(), 2u);

  const hid_t file = H5Fopen(h5().string().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  for (std::size_t b = 0; b < boundaries.bodyCount(); ++b) {
    const std::string group = "/bodies/" + boundaries.body(b).name;
    const std::size_t m = boundaries.bodySampleCount(b);
    EXPECT_GT(m, 0u);
    EXPECT_EQ(datasetDims(file, group + "/surface_points"), (std::vector<hsize_t>{m, 3})) << group;
    EXPECT_EQ(datasetDims(file, group + "/surface_normals"), (std::vector<hsize_t>{m, 3})) << group;
    const std::vector<double> n = readDoubles(file, group + "/surface_normals");
    for (std::size_t k = 0; k + 2 < n.size(); k += 3)
      ASSERT_NEAR(std::sqrt(n[k] * n[k] + n[k + 1] * n[k + 1] + n[k + 2] * n[k + 2]), 1.0, 1e-9);
  }
  EXPECT_EQ(readStringAttribute(file, "/bodies/tank", "kind"), "static");
  EXPECT_EQ(readStringAttribute(file, "/bodies/crate", "kind"), "dynamic");
  // The crate's samples are around its centre of mass (body frame): their centres lie one
  // particle radius inside its faces (the spheres touch the surface from inside).
  const std::vector<double> p = readDoubles(file, "/bodies/crate/surface_points");
  const double half[3] = {0.025, 0.02, 0.025}, radius = 0.008;
  double reach[3] = {0, 0, 0};
  for (std::size_t k = 0; k + 2 < p.size(); k += 3)
    for (int a = 0; a < 3; ++a) {
      EXPECT_LE(std::abs(p[k + a]), half[a] + 1e-9) << "sample " << k / 3;
      reach[a] = std::max(reach[a], std::abs(p[k + a]));
    }
  for (int a = 0; a < 3; ++a)
    EXPECT_NEAR(reach[a], half[a] - radius, 0.25 * radius) << "axis " << a;
  H5Fclose(file);
}

TEST_F(RenderTest, FramesShowTheFluidAndTheBody) {
  RenderOptions options;
  options.dir = runDir().string();
  options.out_dir = (*root_ / "frames").string();
  options.width = 320;
  options.height = 200;
  const RenderResult r = renderRun(options);
  EXPECT_EQ(r.h5_path, h5().string());
  ASSERT_EQ(r.images.size(), 3u);  // t = 0, 0.01, 0.02
  for (std::size_t k = 0; k < 3; ++k) {
    const fs::path expected =
        *root_ / "frames" / ("render_tank_00000" + std::to_string(k) + ".png");
    EXPECT_EQ(r.images[k], expected.string());
    int w = 0, h = 0, c = 0;
    ASSERT_EQ(stbi_info(expected.string().c_str(), &w, &h, &c), 1) << expected;
    EXPECT_EQ(w, 320);
    EXPECT_EQ(h, 200);
  }

  const Png png = loadPng(r.images[0]);
  ASSERT_EQ(png.width, 320);
  // Where the fluid's particles project, the image is not background (and is bluish).
  const hid_t file = H5Fopen(h5().string().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  const std::vector<double> x = readDoubles(file, "/frames/000000/position");
  H5Fclose(file);
  ASSERT_GT(x.size(), 300u);
  std::size_t drawn = 0, blue = 0;
  const std::size_t inside = forEachProjectedPixel(r, png, x, [&](const unsigned char* c, int py) {
    const auto bg = renderBackground(py, png.height);
    const int diff = std::abs(c[0] - bg[0]) + std::abs(c[1] - bg[1]) + std::abs(c[2] - bg[2]);
    if (diff > 30) ++drawn;
    if (c[2] > c[0] + 40) ++blue;
  });
  EXPECT_EQ(inside, x.size() / 3) << "the camera sees all of the fluid";
  EXPECT_GE(drawn, inside * 98 / 100);
  EXPECT_GE(blue, inside * 80 / 100);
  // The dynamic crate is drawn in a warm colour, which nothing else uses.
  std::size_t warm = 0;
  for (int py = 0; py < png.height; ++py)
    for (int px = 0; px < png.width; ++px) {
      const unsigned char* c = png.at(px, py);
      if (c[0] > 120 && c[0] > c[1] + 30 && c[0] > c[2] + 60) ++warm;
    }
  EXPECT_GT(warm, 50u);
  EXPECT_LT(warm, std::size_t(png.width) * png.height / 4);
}

TEST_F(RenderTest, DrawsTheWaterSurfaceWhenItWasWritten) {
  // A copy of the run, surfaced: the render draws the surface mesh in the water colour
  // where its vertices project, and --particles draws the particles instead.
  const fs::path dir = *root_ / "surfaced";
  fs::remove_all(dir);
  fs::copy(runDir(), dir, fs::copy_options::recursive);
  const Cli s = wake("surface \"" + dir.string() + "\" --quiet --no-vdb");
  ASSERT_EQ(s.status, 0) << s.err;
  RenderOptions options;
  options.dir = dir.string();
  options.out_dir = (dir / "frames").string();
  options.width = 320;
  options.height = 200;
  options.first = options.last = 2;
  const RenderResult r = renderRun(options);
  ASSERT_EQ(r.images.size(), 1u);
  const Png png = loadPng(r.images[0]);
  ASSERT_EQ(png.width, 320);
  const hid_t file = H5Fopen((dir / "surface" / "surface.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  const std::vector<float> v =
      test::readDataset<float>(file, "/frames/000002/vertices", H5T_NATIVE_FLOAT);
  H5Fclose(file);
  ASSERT_GT(v.size(), 300u);
  std::size_t blue = 0;
  const std::size_t inside = forEachProjectedPixel(r, png, v, [&](const unsigned char* c, int) {
    if (c[2] > c[0] + 40) ++blue;
  });
  EXPECT_EQ(inside, v.size() / 3) << "the camera sees all of the surface";
  // Vertices on the silhouette may show the body or the tank behind: most are water.
  EXPECT_GE(blue, inside * 70 / 100);
  options.particles = true;
  options.out_dir = (dir / "particle_frames").string();
  const RenderResult p = renderRun(options);
  ASSERT_EQ(p.images.size(), 1u);
  EXPECT_NE(readFile(p.images[0]), readFile(r.images[0]));
}

TEST_F(RenderTest, CommandLineRendersChosenFramesAndViews) {
  const fs::path out = *root_ / "cli_frames";
  const Cli r = wake("render \"" + runDir().string() + "\" --out \"" + out.string() +
                     "\" --color depth --view top --frames 1:2 --width 100 --height 64 --quiet");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_FALSE(fs::exists(out / "render_tank_000000.png"));
  for (const char* name : {"render_tank_000001.png", "render_tank_000002.png"}) {
    int w = 0, h = 0, c = 0;
    ASSERT_EQ(stbi_info((out / name).string().c_str(), &w, &h, &c), 1) << name;
    EXPECT_EQ(w, 100);
    EXPECT_EQ(h, 64);
  }
  // Default folder DIR/frames; --video without ffmpeg is no error.
  const Cli d =
      wake("render \"" + runDir().string() + "\" --frames 2 --width 64 --height 48" + " --video");
  EXPECT_EQ(d.status, 0) << d.err;
  EXPECT_TRUE(fs::exists(runDir() / "frames" / "render_tank_000002.png"));
  EXPECT_EQ(d.err.find("error"), std::string::npos) << d.err;
}

TEST_F(RenderTest, BadInputFailsWithOneLineNamingIt) {
  const std::string dir = "\"" + runDir().string() + "\"";
  struct Case {
    std::string args, needle;
  };
  const fs::path empty = *root_ / "empty_dir";
  fs::create_directories(empty);
  const std::vector<Case> cases = {
      {"render " + dir + " --color rainbow", "--color"},
      {"render " + dir + " --view diagonal", "--view"},
      {"render " + dir + " --frames 7", "--frames"},
      {"render " + dir + " --frames 2:1", "--frames"},
      {"render " + dir + " --frames a:b", "--frames"},
      {"render " + dir + " --width 0", "--width"},
      {"render " + dir + " --every 0", "--every"},
      {"render " + dir + " --scene nosuch", "nosuch"},
      {"render \"" + empty.string() + "\"", empty.string()},
      {"render \"" + (*root_ / "missing").string() + "\"", (*root_ / "missing").string()},
  };
  for (const Case& c : cases) {
    const Cli r = wake(c.args);
    EXPECT_EQ(r.status, 2) << c.args << "\n" << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.args << "\n" << r.err;
    EXPECT_EQ(r.err.rfind("wake: error: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(c.needle), std::string::npos) << c.args << "\n" << r.err;
  }
}

TEST_F(RenderTest, PlotScriptDrawsTheSeries) {
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) GTEST_SKIP() << "no gnuplot";
  const std::string script = std::string(WAKE_SOURCE_DIR) + "/scripts/plot.sh";
  const std::string command = "bash \"" + script + "\" \"" + runDir().string() + "\" >/dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0);
  for (const char* name :
       {"heights.png", "velocities.png", "density_ratio.png", "penetrating.png"}) {
    int w = 0, h = 0, c = 0;
    EXPECT_EQ(stbi_info((runDir() / "plots" / name).string().c_str(), &w, &h, &c), 1) << name;
  }
  // A folder without series.csv: one clear message, non-zero exit.
  const std::string bad =
      "bash \"" + script + "\" \"" + (*root_ / "nothing").string() + "\" >/dev/null 2>&1";
  EXPECT_NE(std::system(bad.c_str()), 0);
}

}  // namespace
}  // namespace wake
