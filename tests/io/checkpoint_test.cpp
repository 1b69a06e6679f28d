// Checkpoint and restart: a run killed (SIGKILL) at any moment keeps every frame it had
// completed, and `wake run --resume` finishes it to the very output of a run that was never
// stopped (every frame, every body series row, series.csv and the final state hash), for a
// fluid-only scene, a floating two-way body and bodies resting on each other (20 kills at
// random moments in all). Also the C++ API's save and restore.
#include "io/checkpoint.hpp"
#include "io/io_test_support.hpp"
#include "io/output.hpp"

#include "bullet_bridge/scene_world.hpp"
#include "io/scene.hpp"

#include <gtest/gtest.h>
#include <hdf5.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace wake {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using test::readFile;
using test::runWake;
using test::TempDir;

using test::kScenes;

std::string inQuotes(const fs::path& p) {
  return "\"" + p.string() + "\"";
}

/// Every dataset of every frame, every body series and attribute time, as raw bytes, keyed
/// by path; empty when the file does not open.
std::map<std::string, std::string> contents(const fs::path& h5) {
  std::map<std::string, std::string> out;
  H5E_auto2_t func;
  void* data;
  H5Eget_auto2(H5E_DEFAULT, &func, &data);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // a torn file is an expected case here
  struct Restore {
    H5E_auto2_t func;
    void* data;
    ~Restore() { H5Eset_auto2(H5E_DEFAULT, func, data); }
  } restore{func, data};
  const hid_t file = H5Fopen(h5.string().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (file < 0) return out;
  auto read = [&](const std::string& path) {
    const hid_t set = H5Dopen2(file, path.c_str(), H5P_DEFAULT);
    if (set < 0) return;
    const hid_t type = H5Dget_type(set), space = H5Dget_space(set);
    const hssize_t n = H5Sget_simple_extent_npoints(space);
    std::string bytes(static_cast<std::size_t>(n) * H5Tget_size(type), '\0');
    if (n > 0) H5Dread(set, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, bytes.data());
    out[path] = bytes;
    H5Sclose(space);
    H5Tclose(type);
    H5Dclose(set);
  };
  H5G_info_t info{};
  const hid_t frames = H5Gopen2(file, "frames", H5P_DEFAULT);
  if (frames < 0 || H5Gget_info(frames, &info) < 0) info.nlinks = 0;
  for (hsize_t k = 0; k < info.nlinks; ++k) {
    char name[48];
    std::snprintf(name, sizeof(name), "frames/%06llu", static_cast<unsigned long long>(k));
    for (const char* d : {"position", "velocity", "density", "pressure", "id"})
      read(std::string(name) + "/" + d);
  }
  if (frames >= 0) H5Gclose(frames);
  const hid_t bodies = H5Gopen2(file, "bodies", H5P_DEFAULT);
  if (bodies < 0 || H5Gget_info(bodies, &info) < 0) info.nlinks = 0;
  for (hsize_t b = 0; b < info.nlinks; ++b) {
    char name[256];
    H5Lget_name_by_idx(bodies, ".", H5_INDEX_NAME, H5_ITER_INC, b, name, sizeof(name), H5P_DEFAULT);
    for (const char* d : {"time", "position", "orientation", "linear_velocity", "angular_velocity"})
      read(std::string("bodies/") + name + "/" + d);
  }
  if (bodies >= 0) H5Gclose(bodies);
  H5Fclose(file);
  return out;
}

std::size_t frameCount(const std::map<std::string, std::string>& c) {
  std::size_t n = 0;
  for (const auto& [path, bytes] : c)
    n += path.size() > 9 && path.compare(path.size() - 9, 9, "/position") == 0 &&
         path.rfind("frames/", 0) == 0;
  return n;
}

/// Starts `wake run` and kills it with SIGKILL `seconds` after its start or, with
/// `after_checkpoint`, after its first checkpoint appeared (timing alone is not enough: a
/// run of a fraction of a second on a loaded machine may not have reached its first
/// checkpoint at any fixed moment). Returns false when it had already ended.
bool runAndKill(const std::string& scene, const std::string& end, const fs::path& out, double every,
                double seconds, bool after_checkpoint) {
  std::vector<std::string> args = {WAKE_CLI_PATH,
                                   "run",
                                   scene,
                                   "--out",
                                   out.string(),
                                   "--quiet",
                                   "--end",
                                   end,
                                   "--checkpoint-every",
                                   std::to_string(every),
                                   "--threads",
                                   "1"};
  std::vector<char*> argv;
  for (std::string& a : args)
    argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawn(&pid, WAKE_CLI_PATH, nullptr, nullptr, argv.data(), environ) != 0) return false;
  while (after_checkpoint && !fs::exists(out / "checkpoint.h5") &&
         waitpid(pid, nullptr, WNOHANG) == 0)
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  const bool alive = waitpid(pid, nullptr, WNOHANG) == 0;
  if (alive) {
    kill(pid, SIGKILL);
    waitpid(pid, nullptr, 0);
  }
  return alive;
}

/// The output of one run of `scene` that was never stopped, and how long it took. Runs
/// here take one thread: the tests run beside others (ctest -j), and OpenMP threads
/// that outnumber the cores make a run's duration, and so the kill moments, unpredictable.
struct Reference {
  TempDir dir;
  std::map<std::string, std::string> frames;
  std::string series, hash;
  double seconds = 0;
  Reference(const std::string& scene, const std::string& end) {
    const auto t0 = std::chrono::steady_clock::now();
    const test::CliResult r =
        runWake("run " + inQuotes(scene) + " --out " + inQuotes(dir.path / "out") +
                    " --quiet --threads 1 --end " + end,
                dir.path);
    seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_EQ(r.status, 0) << r.err;
    const std::string name = fs::path(scene).stem().string();
    frames = contents(dir.path / "out" / (name + ".h5"));
    series = readFile(dir.path / "out" / "series.csv");
    hash = json::parse(readFile(dir.path / "out" / "summary.json"))["state_hash"];
  }
};

/// Kills runs of `scene` at `kills` random moments; each time, every frame left in the
/// partial file equals the reference's, and --resume ends in the reference's output.
void killAndResume(const std::string& scene, const std::string& end, int kills, unsigned seed) {
  const Reference ref(scene, end);
  ASSERT_GT(frameCount(ref.frames), 10u);
  const std::string name = fs::path(scene).stem().string();
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> moment(0.05, 1.0);
  int resumed = 0;
  for (int i = 0; i < kills; ++i) {
    const TempDir dir;
    const fs::path out = dir.path / "out";
    // Every other kill after the first checkpoint (it must resume), the others anywhere
    // (also before the first checkpoint, or after the end).
    const bool after_checkpoint = i % 2 == 0;
    const double at = (after_checkpoint ? 0.5 * moment(random) : moment(random)) * ref.seconds;
    const bool killed = runAndKill(scene, end, out, 0.02, at, after_checkpoint);
    SCOPED_TRACE("kill " + std::to_string(i) + " after " + std::to_string(at) + " s" +
                 (after_checkpoint ? " past the first checkpoint" : ""));
    if (!killed) continue;  // it had finished
    // Every frame completed before the kill opens and equals the uninterrupted run's.
    const std::map<std::string, std::string> partial = contents(out / (name + ".h5.partial"));
    for (const auto& [path, bytes] : partial) {
      if (path.rfind("frames/", 0) != 0) continue;
      ASSERT_TRUE(ref.frames.count(path)) << path;
      EXPECT_TRUE(ref.frames.at(path) == bytes) << path << " differs";
    }
    const test::CliResult r =
        runWake("run --resume " + inQuotes(out) + " --quiet --threads 1", dir.path);
    if (!fs::exists(out / "checkpoint.h5") && r.status == 2 &&
        r.err.find("no checkpoint") != std::string::npos)
      continue;  // killed before the first checkpoint: nothing to resume, said so
    ASSERT_EQ(r.status, 0) << r.err;
    ++resumed;
    EXPECT_FALSE(fs::exists(out / "checkpoint.h5")) << "a complete run keeps no checkpoint";
    const std::map<std::string, std::string> done = contents(out / (name + ".h5"));
    EXPECT_EQ(done.size(), ref.frames.size());
    EXPECT_TRUE(done == ref.frames) << "the resumed run's output differs";
    EXPECT_EQ(readFile(out / "series.csv"), ref.series);
    EXPECT_EQ(json::parse(readFile(out / "summary.json"))["state_hash"], ref.hash);
  }
  std::printf("[ checkpoint ] %s: %d of %d killed runs resumed to the same output\n", name.c_str(),
              resumed, kills);
  EXPECT_GE(resumed, std::max(1, kills / 3));
}

// Under the sanitizers (a run is ~10x slower) fewer kills: the same code paths, in CI time.
#if defined(__SANITIZE_ADDRESS__)
constexpr int kKillScale = 3;
#else
constexpr int kKillScale = 1;
#endif

TEST(Checkpoint, KilledFluidRunKeepsItsFramesAndResumesToTheSameOutput) {
  killAndResume(kScenes + "small_dambreak.json", "0.3", 8 / kKillScale, 11);
}

TEST(Checkpoint, KilledRunWithATwoWayBodyResumesToTheSameOutput) {
  killAndResume(kScenes + "small_float.json", "0.3", 6 / kKillScale, 12);
}

TEST(Checkpoint, KilledRunWithBodiesInContactResumesToTheSameOutput) {
  // Two boxes stacked on the floor: Bullet's contact cache (the impulses it warm-starts
  // with, the order of its manifolds) is part of the checkpoint.
  killAndResume(kScenes + "small_stack.json", "0.3", 6 / kKillScale, 13);
}

TEST(Checkpoint, RunStoppedWhileItFinishesResumesToTheSameOutput) {
  // A run finishes in steps: its .h5 renamed from .partial, then series.csv, then the
  // summary written, then the checkpoint removed. Stopped anywhere in between, the folder
  // holds a checkpoint beside finished files, and --resume still ends in the output of a
  // run that was never stopped. The states are made exactly: a folder where summary.json
  // goes makes the run stop after its files are finished and before the checkpoint is
  // removed; the variants undo the later steps (the series not yet renamed, the xdmf
  // index not yet written) or add a summary (stopped just before the checkpoint removal).
  const std::string scene = kScenes + "small_float.json";
  const std::string name = "small_float";
  const Reference ref(scene, "0.15");
  ASSERT_GT(frameCount(ref.frames), 5u);
  for (const std::string variant : {"files finished", "series not renamed", "summary written"}) {
    SCOPED_TRACE(variant);
    const TempDir dir;
    const fs::path out = dir.path / "out";
    fs::create_directories(out / "summary.json");
    test::CliResult r = runWake("run " + inQuotes(scene) + " --out " + inQuotes(out) +
                                    " --quiet --threads 1 --end 0.15 --checkpoint-every 0.02",
                                dir.path);
    ASSERT_NE(r.status, 0) << "the summary cannot be written: the run must say so";
    EXPECT_NE(r.err.find("summary.json"), std::string::npos) << r.err;
    ASSERT_TRUE(fs::exists(out / "checkpoint.h5"));
    ASSERT_TRUE(fs::exists(out / (name + ".h5")));
    ASSERT_FALSE(fs::exists(out / (name + ".h5.partial")));
    fs::remove_all(out / "summary.json");
    fs::remove(out / "summary.json.tmp");
    if (variant == "series not renamed") {
      fs::rename(out / "series.csv", out / "series.csv.partial");
      fs::remove(out / (name + ".xdmf"));
    } else if (variant == "summary written") {
      fs::copy_file(ref.dir.path / "out" / "summary.json", out / "summary.json");
    }
    r = runWake("run --resume " + inQuotes(out) + " --quiet --threads 1", dir.path);
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_FALSE(fs::exists(out / "checkpoint.h5")) << "a complete run keeps no checkpoint";
    for (const char* partial : {".h5.partial", ".xdmf.partial"})
      EXPECT_FALSE(fs::exists(out / (name + partial))) << partial;
    EXPECT_FALSE(fs::exists(out / "series.csv.partial"));
    EXPECT_TRUE(fs::exists(out / (name + ".xdmf")));
    EXPECT_TRUE(contents(out / (name + ".h5")) == ref.frames) << "the resumed output differs";
    EXPECT_EQ(readFile(out / "series.csv"), ref.series);
    EXPECT_EQ(json::parse(readFile(out / "summary.json"))["state_hash"], ref.hash);
  }
}

TEST(Checkpoint, BadResumeCommandsExitTwoNamingTheProblem) {
  const TempDir dir;
  test::CliResult r = runWake("run --resume " + inQuotes(dir.path), dir.path);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("no checkpoint in"), std::string::npos) << r.err;
  r = runWake("run --resume " + inQuotes(dir.path) + " --out " + inQuotes(dir.path), dir.path);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--resume: --out"), std::string::npos) << r.err;
  r = runWake("run " + inQuotes(kScenes + "small_dambreak.json") + " --out " +
                  inQuotes(dir.path / "o") + " --checkpoint-every 0",
              dir.path);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--checkpoint-every"), std::string::npos) << r.err;
  // A complete run has nothing to resume.
  r = runWake("run " + inQuotes(kScenes + "small_dambreak.json") + " --out " +
                  inQuotes(dir.path / "done") + " --quiet --checkpoint-every 0.01",
              dir.path);
  ASSERT_EQ(r.status, 0) << r.err;
  r = runWake("run --resume " + inQuotes(dir.path / "done"), dir.path);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("is complete"), std::string::npos) << r.err;
}

TEST(Checkpoint, ResumeRebuildsTheOutputWhenTheFrameIndexIsTorn) {
  // HDF5 has no journal: a run killed while it wrote frames after a checkpoint can leave
  // the /frames group's index (its header, B-tree, heap) half written, so the frames the
  // checkpoint counts are no longer found by name. Here the index is torn on purpose (the
  // /frames group's object header overwritten) after 5 frames were checkpointed and 3
  // more written: the resumed file still holds the 5 frames bit for bit, found by address,
  // and the body series rows from the checkpoint.
  const SceneFile scene = loadScene(kScenes + "small_float.json");
  SceneWorld world(scene.sim, scene.bodies);
  world.coupled().start();
  const Simulation& sim = world.simulation();
  const TempDir dir;
  const std::string partial = (dir.path / (scene.name + ".h5.partial")).string();
  OutputIndex index;
  {
    FrameWriter writer(dir.path.string(), scene, sim);
    FluidSnapshot fluid;
    for (int k = 0; k < 8; ++k) {
      if (k > 0) world.coupled().advanceTo(0.01 * k);
      sim.snapshot(fluid);
      writer.writeFrame(sim, fluid);
      if (k == 4) {
        writer.sync();
        index = writer.index();
      }
    }
  }  // not finished: the .partial stays, as after a kill
  ASSERT_EQ(index.frames(), 5u);
  const std::map<std::string, std::string> before = contents(partial);
  ASSERT_EQ(frameCount(before), 8u);

  // Tear the index: overwrite the /frames group's object header.
  haddr_t frames_address = 0;
  {
    const hid_t file = H5Fopen(partial.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    ASSERT_GE(file, 0);
    const hid_t group = H5Gopen2(file, "frames", H5P_DEFAULT);
    H5O_info_t info;
    ASSERT_GE(H5Oget_info2(group, &info, H5O_INFO_BASIC), 0);
    frames_address = info.addr;
    H5Gclose(group);
    H5Fclose(file);
  }
  {
    std::fstream raw(partial, std::ios::in | std::ios::out | std::ios::binary);
    raw.seekp(static_cast<std::streamoff>(frames_address));
    const std::string junk(64, '\xff');
    raw.write(junk.data(), static_cast<std::streamsize>(junk.size()));
  }
  EXPECT_EQ(frameCount(contents(partial)), 0u) << "the index should be unreadable now";

  { FrameWriter resumed(dir.path.string(), scene, sim, index); }
  const std::map<std::string, std::string> after = contents(partial);
  EXPECT_EQ(frameCount(after), 5u);
  for (const auto& [path, bytes] : after) {
    if (path.rfind("frames/", 0) == 0) {
      ASSERT_TRUE(before.count(path)) << path;
      EXPECT_TRUE(before.at(path) == bytes) << path << " differs";
    }
  }
  // Body series: the first 5 rows of each, from the checkpoint's index.
  const hid_t file = H5Fopen(partial.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  const hid_t set = H5Dopen2(file, "bodies/box/position", H5P_DEFAULT);
  ASSERT_GE(set, 0);
  std::vector<double> rows(15, 0.0);
  const hid_t space = H5Dget_space(set);
  hsize_t dims[2] = {0, 0};
  H5Sget_simple_extent_dims(space, dims, nullptr);
  EXPECT_EQ(dims[0], 5u);
  H5Dread(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, rows.data());
  for (std::size_t k = 0; k < 5; ++k)
    for (std::size_t c = 0; c < 3; ++c)
      EXPECT_EQ(rows[3 * k + c],
                index.body_rows[k * 2 * OutputIndex::kBodyRow + OutputIndex::kBodyRow + 1 + c]);
  H5Sclose(space);
  H5Dclose(set);
  H5Fclose(file);
}

TEST(Checkpoint, TheCppApiSavesAndRestoresARunBitForBit) {
  // A scene world (Bullet, a two-way box): saved to a file at 0.1 s, restored into a
  // second world built from the same scene, both run on to 0.2 s. With the automatic
  // skin (every build lists it here), and with a skin so thin that most builds do not
  // (the flow moves too fast for it: Fluid::updateNeighbors), so that the run saves and
  // resumes between both kinds.
  // And with the divergence-free solver: its running mean of the pressure
  // (FluidState::pressure_mean) is part of the state.
  struct Case {
    double skin_fraction;
    FluidSolver solver;
  };
  for (const Case c : {Case{-1.0, FluidSolver::Wcsph}, Case{0.01, FluidSolver::Wcsph},
                       Case{-1.0, FluidSolver::Dfsph}}) {
    const double skin_fraction = c.skin_fraction;
    const bool dfsph = c.solver == FluidSolver::Dfsph;
    SCOPED_TRACE(std::to_string(skin_fraction) + (dfsph ? " dfsph" : " wcsph"));
    SceneFile scene = loadScene(kScenes + "small_float.json");
    if (skin_fraction > 0)
      scene.sim.neighbor_skin = skin_fraction * scene.sim.fluid.supportRadius();
    scene.sim.solver = c.solver;
    SceneWorld a(scene.sim, scene.bodies);
    a.coupled().advanceTo(0.1);
    const TempDir dir;
    const std::string file = (dir.path / "state.h5").string();
    writeCheckpoint(file, a.simulation().saveState());
    a.coupled().advanceTo(0.2);
    const Fluid& fluid = a.simulation().fluid();
    EXPECT_EQ(fluid.state().keepsPressureMean(), dfsph);
    if (!dfsph) {
      EXPECT_GT(fluid.neighborSkinnedBuilds(), 0u);
      if (skin_fraction > 0) {
        EXPECT_GT(fluid.neighborBuilds(), 2 * fluid.neighborSkinnedBuilds());
      } else {
        EXPECT_EQ(fluid.neighborBuilds(), fluid.neighborSkinnedBuilds());
      }
    }

    SceneWorld b(scene.sim, scene.bodies);
    b.coupled().start();
    b.coupled().simulation().restoreState(readCheckpoint(file));
    EXPECT_EQ(b.simulation().time(), 0.1);
    b.coupled().advanceTo(0.2);
    EXPECT_EQ(b.simulation().steps(), a.simulation().steps());
    EXPECT_EQ(stateHash(b.simulation()), stateHash(a.simulation()));
    const BodyState box_a = a.simulation().bodyStates()[1], box_b = b.simulation().bodyStates()[1];
    EXPECT_EQ(box_a.position, box_b.position);
    EXPECT_EQ(box_a.linear_velocity, box_b.linear_velocity);
    EXPECT_EQ(box_a.orientation.coeffs(), box_b.orientation.coeffs());

    // Rewound: the state restored into the world that ran past it (its fluid's lists and
    // the walls' candidates were built later) runs on to the same state again.
    a.coupled().simulation().restoreState(readCheckpoint(file));
    a.coupled().advanceTo(0.2);
    EXPECT_EQ(stateHash(a.simulation()), stateHash(b.simulation()));

    // A state that does not fit the simulation is refused.
    SimulationState wrong = readCheckpoint(file);
    wrong.wrenches.pop_back();
    EXPECT_THROW(b.coupled().simulation().restoreState(wrong), std::invalid_argument);
    if (dfsph) {
      SimulationState torn = readCheckpoint(file);
      torn.fluid.pressure_mean.pop_back();
      EXPECT_THROW(b.coupled().simulation().restoreState(torn), std::invalid_argument);
      // The density solve's last push on each body (it sees the bodies move against it).
      SimulationState pushes = readCheckpoint(file);
      ASSERT_EQ(pushes.solver_forces.size(), pushes.wrenches.size());
      EXPECT_GT(pushes.solver_forces[1].force.norm(), 0.0);
      pushes.solver_forces.pop_back();
      EXPECT_THROW(b.coupled().simulation().restoreState(pushes), std::invalid_argument);
    }
    EXPECT_THROW(readCheckpoint((dir.path / "none.h5").string()), std::runtime_error);
  }
}

}  // namespace
}  // namespace wake
