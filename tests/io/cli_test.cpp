// End to end through the `wake` binary: a small dam break is run into a temporary folder;
// its HDF5 output is read back with the HDF5 C API and checked against the layout of
// DESIGN.md §7, the summary against its contract fields; bad input must fail with one
// error line and leave the earlier output byte for byte as it was.
#include "io/io_test_support.hpp"

#include <gtest/gtest.h>
#include <hdf5.h>
#include <sys/wait.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
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

const std::string kDambreakScene = std::string(WAKE_TEST_DATA_DIR) + "/scenes/small_dambreak.json";
constexpr std::size_t kFrames = 6;  // round(end 0.05 s * 100 /s) + 1

std::size_t lineCount(const std::string& s) {
  return static_cast<std::size_t>(std::count(s.begin(), s.end(), '\n'));
}

// --- HDF5 reading (C API) ----------------------------------------------------------------

double readDoubleAttribute(hid_t object, const char* name) {
  double value = NAN;
  const hid_t attr = H5Aopen(object, name, H5P_DEFAULT);
  EXPECT_GE(attr, 0) << name;
  if (attr >= 0) {
    H5Aread(attr, H5T_NATIVE_DOUBLE, &value);
    H5Aclose(attr);
  }
  return value;
}

std::size_t linkCount(hid_t file, const char* group_name) {
  const hid_t group = H5Gopen2(file, group_name, H5P_DEFAULT);
  if (group < 0) return 0;
  H5G_info_t info;
  H5Gget_info(group, &info);
  H5Gclose(group);
  return static_cast<std::size_t>(info.nlinks);
}

// --- One run of the small scene, shared by the tests below -------------------------------

class SmallDambreakRun : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir();
    // One thread: CTest runs a test per core, and OpenMP threads beyond the cores spin
    // against each other (a run of 0.6 s took 20 s beside another test).
    run_ = new CliResult(
        runWake("run \"" + kDambreakScene + "\" --out \"" + outDir().string() + "\" --threads 1",
                dir_->path));
  }
  static void TearDownTestSuite() {
    delete run_;
    delete dir_;
  }
  static fs::path outDir() { return dir_->path / "out"; }
  static json summary() { return json::parse(readFile(outDir() / "summary.json")); }

  static TempDir* dir_;
  static CliResult* run_;
};
TempDir* SmallDambreakRun::dir_ = nullptr;
CliResult* SmallDambreakRun::run_ = nullptr;

TEST_F(SmallDambreakRun, ExitsZeroAndWritesTheOutputFiles) {
  ASSERT_EQ(run_->status, 0) << run_->err;
  EXPECT_TRUE(fs::is_regular_file(outDir() / "small_dambreak.h5"));
  EXPECT_TRUE(fs::is_regular_file(outDir() / "small_dambreak.xdmf"));
  EXPECT_TRUE(fs::is_regular_file(outDir() / "summary.json"));
  // Nothing temporary is left behind.
  for (const auto& entry : fs::directory_iterator(outDir()))
    EXPECT_EQ(entry.path().string().find(".partial"), std::string::npos) << entry.path();
  // Not a terminal: plain progress lines, the last one for the last frame.
  EXPECT_NE(run_->err.find("frame 5/5"), std::string::npos) << run_->err;
  EXPECT_EQ(run_->err.find('\r'), std::string::npos);
}

TEST_F(SmallDambreakRun, SummaryHasTheContractFields) {
  ASSERT_EQ(run_->status, 0) << run_->err;
  const json s = summary();
  for (const char* field :
       {"scene", "fluid_particles", "boundary_particles", "steps", "sim_time", "wall_seconds",
        "max_density_ratio", "max_penetrating", "lost_particles", "bodies", "removed_at_start",
        "speed_of_sound", "particle_radius", "frames", "threads", "timings", "mean_dt"})
    EXPECT_TRUE(s.contains(field)) << field;
  EXPECT_EQ(s["scene"], "small_dambreak");
  EXPECT_GT(s["fluid_particles"].get<long>(), 0);
  EXPECT_GT(s["boundary_particles"].get<long>(), 0);
  EXPECT_GT(s["steps"].get<long>(), 0);
  EXPECT_NEAR(s["sim_time"].get<double>(), 0.05, 1e-9);
  EXPECT_GT(s["wall_seconds"].get<double>(), 0.0);
  EXPECT_GT(s["max_density_ratio"].get<double>(), 0.5);
  EXPECT_LT(s["max_density_ratio"].get<double>(), 2.0);
  EXPECT_EQ(s["max_penetrating"], 0);
  EXPECT_EQ(s["lost_particles"], 0);
  EXPECT_GT(s["speed_of_sound"].get<double>(), 0.0);
  EXPECT_EQ(s["particle_radius"], 0.01);
  EXPECT_EQ(s["frames"], kFrames);
  EXPECT_EQ(s["threads"], 1);
  EXPECT_GT(s["mean_dt"].get<double>(), 0.0);
  for (const char* part : {"neighbors", "density", "forces", "boundary", "integration"})
    EXPECT_GE(s["timings"][part].get<double>(), 0.0) << part;
  ASSERT_EQ(s["bodies"].size(), 1u);
  const json& tank = s["bodies"][0];
  EXPECT_EQ(tank["name"], "tank");
  EXPECT_EQ(tank["orientation"], json({0.0, 0.0, 0.0, 1.0}));
  EXPECT_EQ(tank["linear_velocity"], json({0.0, 0.0, 0.0}));
  EXPECT_EQ(tank["angular_velocity"], json({0.0, 0.0, 0.0}));
  EXPECT_EQ(tank["position"].size(), 3u);
}

TEST_F(SmallDambreakRun, Hdf5HasTheContractLayout) {
  ASSERT_EQ(run_->status, 0) << run_->err;
  const std::size_t n = summary()["fluid_particles"].get<std::size_t>();
  const hid_t file = H5Fopen((outDir() / "small_dambreak.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  EXPECT_NEAR(readDoubleAttribute(file, "particle_radius"), 0.01, 0.0);
  EXPECT_EQ(readDoubleAttribute(file, "rest_density"), 1000.0);
  EXPECT_GT(readDoubleAttribute(file, "speed_of_sound"), 0.0);
  EXPECT_GT(H5Aexists(file, "scene"), 0);

  ASSERT_EQ(linkCount(file, "/frames"), kFrames);
  for (std::size_t k = 0; k < kFrames; ++k) {
    char name[32];
    std::snprintf(name, sizeof(name), "/frames/%06zu", k);
    const hid_t frame = H5Gopen2(file, name, H5P_DEFAULT);
    ASSERT_GE(frame, 0) << name;
    EXPECT_NEAR(readDoubleAttribute(frame, "time"), 0.01 * static_cast<double>(k), 1e-12) << name;
    EXPECT_EQ(datasetDims(frame, "position"), (std::vector<hsize_t>{n, 3})) << name;
    EXPECT_EQ(datasetDims(frame, "velocity"), (std::vector<hsize_t>{n, 3})) << name;
    EXPECT_EQ(datasetDims(frame, "density"), (std::vector<hsize_t>{n})) << name;
    EXPECT_EQ(datasetDims(frame, "pressure"), (std::vector<hsize_t>{n})) << name;
    const std::vector<std::uint32_t> id =
        readDataset<std::uint32_t>(frame, "id", H5T_NATIVE_UINT32);
    ASSERT_EQ(id.size(), n) << name;
    EXPECT_TRUE(std::adjacent_find(id.begin(), id.end(), std::greater_equal<>()) == id.end())
        << name << ": ids not strictly ascending";
    for (const double x : readDataset<double>(frame, "position", H5T_NATIVE_DOUBLE))
      ASSERT_TRUE(std::isfinite(x)) << name;
    H5Gclose(frame);
  }
  // Frame 0 holds the initial block: all particles inside [0, 0.1] x [0, 0.2] x [0, 0.1].
  const hid_t first = H5Gopen2(file, "/frames/000000", H5P_DEFAULT);
  const std::vector<double> x = readDataset<double>(first, "position", H5T_NATIVE_DOUBLE);
  for (std::size_t i = 0; i < x.size(); i += 3) {
    EXPECT_GE(x[i], 0.0);
    EXPECT_LE(x[i], 0.1);
    EXPECT_LE(x[i + 1], 0.2);
  }
  H5Gclose(first);

  const hid_t tank = H5Gopen2(file, "/bodies/tank", H5P_DEFAULT);
  ASSERT_GE(tank, 0);
  EXPECT_EQ(datasetDims(tank, "time"), (std::vector<hsize_t>{kFrames}));
  EXPECT_EQ(datasetDims(tank, "position"), (std::vector<hsize_t>{kFrames, 3}));
  EXPECT_EQ(datasetDims(tank, "orientation"), (std::vector<hsize_t>{kFrames, 4}));
  EXPECT_EQ(datasetDims(tank, "linear_velocity"), (std::vector<hsize_t>{kFrames, 3}));
  EXPECT_EQ(datasetDims(tank, "angular_velocity"), (std::vector<hsize_t>{kFrames, 3}));
  const std::vector<double> times = readDataset<double>(tank, "time", H5T_NATIVE_DOUBLE);
  EXPECT_NEAR(times.back(), 0.05, 1e-9);
  const std::vector<double> q = readDataset<double>(tank, "orientation", H5T_NATIVE_DOUBLE);
  EXPECT_EQ(q[3], 1.0);  // x, y, z, w: identity
  H5Gclose(tank);
  H5Fclose(file);
}

TEST_F(SmallDambreakRun, TheFirstFrameHasItsDensities) {
  // Frame 0 is written before the first step: its densities are summed for it, so the
  // fluid at rest on its lattice has the rest density inside (the median) and no particle
  // is without one.
  ASSERT_EQ(run_->status, 0) << run_->err;
  const hid_t file = H5Fopen((outDir() / "small_dambreak.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  std::vector<double> rho = readDataset<double>(file, "/frames/000000/density", H5T_NATIVE_DOUBLE);
  const std::vector<double> p =
      readDataset<double>(file, "/frames/000000/pressure", H5T_NATIVE_DOUBLE);
  H5Fclose(file);
  ASSERT_FALSE(rho.empty());
  EXPECT_EQ(p.size(), rho.size());
  for (const double r : rho)
    ASSERT_GT(r, 300.0);
  std::nth_element(rho.begin(), rho.begin() + rho.size() / 2, rho.end());
  EXPECT_NEAR(rho[rho.size() / 2], 1000.0, 30.0);
}

TEST_F(SmallDambreakRun, XdmfIndexesEveryFrameOfTheH5File) {
  ASSERT_EQ(run_->status, 0) << run_->err;
  const std::string x = readFile(outDir() / "small_dambreak.xdmf");
  EXPECT_NE(x.find("small_dambreak.h5:/frames/000000/position"), std::string::npos);
  EXPECT_EQ(x.find(".partial"), std::string::npos);
  EXPECT_NE(x.find("CollectionType=\"Temporal\""), std::string::npos);
  EXPECT_NE(x.find("Polyvertex"), std::string::npos);
  // One temporal collection per object: the fluid's has a grid per frame, and so has the
  // tank's.
  const std::size_t fluid = countOf(x, "Name=\"fluid_");
  const std::size_t tank = countOf(x, "Name=\"body_tank_");
  const std::size_t times = countOf(x, "<Time ");
  EXPECT_EQ(fluid, kFrames);
  EXPECT_EQ(tank, kFrames);
  EXPECT_EQ(times, 2 * kFrames);
}

TEST_F(SmallDambreakRun, BadInputFailsAndLeavesEarlierOutputUntouched) {
  ASSERT_EQ(run_->status, 0) << run_->err;
  std::map<fs::path, std::string> before;
  for (const auto& entry : fs::directory_iterator(outDir()))
    before[entry.path()] = readFile(entry.path());

  // A scene naming the same output file, with a misspelt field and a bad slip.
  const json good = json::parse(readFile(kDambreakScene));
  struct Bad {
    std::function<void(json&)> edit;
    const char* field;
  };
  const Bad cases[] = {
      {[](json& s) { s["fluid"]["partcle_radius"] = 0.01; }, "fluid.partcle_radius"},
      {[](json& s) { s["bodies"][0]["slip"] = 1.5; }, "bodies[0].slip"},
      {[](json& s) { s["fluid"]["particle_radius"] = 1e-6; }, "fluid.particle_radius"},
  };
  const fs::path scene = dir_->path / "bad.json";
  for (const Bad& c : cases) {
    json bad = good;
    c.edit(bad);
    std::ofstream(scene) << bad.dump(2);
    const CliResult r =
        runWake("run \"" + scene.string() + "\" --out \"" + outDir().string() + "\"", dir_->path);
    EXPECT_EQ(r.status, 2) << c.field;
    EXPECT_EQ(r.err.rfind("wake: error: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(c.field), std::string::npos) << r.err;
    EXPECT_EQ(lineCount(r.err), 1u) << r.err;
  }

  std::map<fs::path, std::string> after;
  for (const auto& entry : fs::directory_iterator(outDir()))
    after[entry.path()] = readFile(entry.path());
  EXPECT_TRUE(before == after) << "earlier output changed";
}

TEST(WakeCli, UnstableRunExitsOneNamingTheParticleAndKeepsTheFramesBefore) {
  // A speed of sound far too low: the fluid piles up beyond 3 x its rest density.
  const TempDir dir;
  json scene = json::parse(readFile(kDambreakScene));
  scene["fluid"]["speed_of_sound"] = 0.05;
  scene["time"]["end"] = 1.0;
  const fs::path file = dir.path / "unstable.json";
  std::ofstream(file) << scene.dump(2);
  const fs::path out = dir.path / "out";
  const CliResult r =
      runWake("run \"" + file.string() + "\" --out \"" + out.string() + "\" --quiet", dir.path);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(lineCount(r.err), 1u) << r.err;
  EXPECT_EQ(r.err.rfind("wake: error: ", 0), 0u) << r.err;
  for (const char* says :
       {"step ", "(t = ", "fluid particle ", "x rest density", "health.max_density_ratio = 3",
        "fluid.speed_of_sound (now 0.05", "frames before are in"})
    EXPECT_NE(r.err.find(says), std::string::npos) << says << "\n" << r.err;
  EXPECT_FALSE(fs::exists(out / "small_dambreak.h5"));
  EXPECT_FALSE(fs::exists(out / "summary.json"));

  // Every frame written before the failure opens and holds finite values.
  const fs::path partial = out / "small_dambreak.h5.partial";
  const hid_t h5 = H5Fopen(partial.string().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(h5, 0) << partial;
  const std::size_t frames = linkCount(h5, "frames");
  EXPECT_GE(frames, 2u);
  EXPECT_NE(r.err.find("the " + std::to_string(frames) + " frames before"), std::string::npos)
      << r.err;
  for (std::size_t k = 0; k < frames; ++k) {
    char name[48];
    std::snprintf(name, sizeof(name), "frames/%06zu/position", k);
    const std::vector<double> x = readDataset<double>(h5, name, H5T_NATIVE_DOUBLE);
    EXPECT_FALSE(x.empty()) << name;
    for (const double v : x)
      ASSERT_TRUE(std::isfinite(v)) << name;
  }
  H5Fclose(h5);
}

// --- Command line without a run -----------------------------------------------------------

TEST(WakeCli, HelpAndVersion) {
  const TempDir dir;
  CliResult r = runWake("--help", dir.path);
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.out.find("run"), std::string::npos) << r.out;
  r = runWake("run --help", dir.path);
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.out.find("--out"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--threads"), std::string::npos) << r.out;
  r = runWake("--version", dir.path);
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.out.find("wake "), std::string::npos) << r.out;
}

TEST(WakeCli, BadCommandLinesExitTwoWithOneLine) {
  const TempDir dir;
  const std::string out = " --out \"" + (dir.path / "out").string() + "\"";
  const struct {
    std::string args;
    const char* says;
  } cases[] = {
      {"", "subcommand"},
      {"run \"" + kDambreakScene + "\"", "--out"},
      {"run \"" + kDambreakScene + "\"" + out + " --threads 0", "--threads"},
      {"run \"" + kDambreakScene + "\"" + out + " --end -1", "--end"},
      {"run \"" + kDambreakScene + "\"" + out + " --end nan", "--end"},
      {"run no_such_scene.json" + out, "no_such_scene.json"},
      {"frobnicate", "frobnicate"},
  };
  for (const auto& c : cases) {
    const CliResult r = runWake(c.args, dir.path);
    EXPECT_EQ(r.status, 2) << c.args << "\n" << r.err;
    EXPECT_EQ(r.err.rfind("wake: error: ", 0), 0u) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find(c.says), std::string::npos) << c.args << "\n" << r.err;
    EXPECT_EQ(lineCount(r.err), 1u) << c.args << "\n" << r.err;
  }
  EXPECT_FALSE(fs::exists(dir.path / "out")) << "bad input created the output folder";
}

TEST(WakeCli, EndOverrideQuietAndThreads) {
  const TempDir dir;
  const CliResult r = runWake("run \"" + kDambreakScene + "\" --out \"" + dir.path.string() +
                                  "\" --end 0.02 --quiet --threads 2",
                              dir.path);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_EQ(r.out, "");
  const json s = json::parse(readFile(dir.path / "summary.json"));
  EXPECT_NEAR(s["sim_time"].get<double>(), 0.02, 1e-9);
  EXPECT_EQ(s["frames"], 3);
  EXPECT_EQ(s["threads"], 2);
}

TEST(WakeCli, ResolutionRefinesTheFluidAndSeriesHasARowPerFrame) {
  const TempDir coarse, fine;
  const std::string args = "run \"" + kDambreakScene + "\" --end 0.02 --quiet --out ";
  ASSERT_EQ(runWake(args + "\"" + coarse.path.string() + "\"", coarse.path).status, 0);
  const CliResult r = runWake(args + "\"" + fine.path.string() + "\" --resolution 2", fine.path);
  ASSERT_EQ(r.status, 0) << r.err;
  const json a = json::parse(readFile(coarse.path / "summary.json"));
  const json b = json::parse(readFile(fine.path / "summary.json"));
  EXPECT_EQ(b["particle_radius"].get<double>(), 0.5 * a["particle_radius"].get<double>());
  EXPECT_EQ(b["fluid_particles"].get<long>(), 8 * a["fluid_particles"].get<long>());

  // series.csv: a header naming the columns, then one row per frame at its time.
  std::istringstream csv(readFile(fine.path / "series.csv"));
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "time,max_density_ratio,penetrating,lost_particles,contacts");
  std::vector<std::string> rows;
  while (std::getline(csv, line))
    rows.push_back(line);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].rfind("0,nan,0,0,", 0), 0u) << rows[0];
  EXPECT_EQ(rows[2].rfind("0.02,", 0), 0u) << rows[2];
  const double ratio = std::stod(rows[2].substr(rows[2].find(',') + 1));
  EXPECT_GT(ratio, 0.9);
  EXPECT_LT(ratio, 1.2);
}

TEST(WakeCli, BadResolutionExitsTwoNamingIt) {
  const TempDir dir;
  for (const char* value : {"0", "-1", "nan"}) {
    const CliResult r = runWake("run \"" + kDambreakScene + "\" --out \"" +
                                    (dir.path / "out").string() + "\" --resolution " + value,
                                dir.path);
    EXPECT_EQ(r.status, 2) << value << "\n" << r.err;
    EXPECT_NE(r.err.find("--resolution"), std::string::npos) << r.err;
    EXPECT_EQ(lineCount(r.err), 1u) << r.err;
  }
  EXPECT_FALSE(fs::exists(dir.path / "out")) << "bad input created the output folder";
}

}  // namespace
