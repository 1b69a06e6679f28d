// Runner pieces that the end-to-end test cannot reach: running through the library API
// (no CLI) into a folder that is a file.
#include "io/run.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

namespace wake {
namespace {

namespace fs = std::filesystem;

TEST(RunScene, OutputFolderThatIsAFileIsBadInput) {
  const SceneFile scene =
      loadScene(std::string(WAKE_TEST_DATA_DIR) + "/scenes/small_dambreak.json");
  const fs::path file = fs::temp_directory_path() / "wake_io_run_test_not_a_folder";
  std::ofstream(file) << "keep me";
  RunOptions options;
  options.out_dir = file.string();
  options.quiet = true;
  EXPECT_THROW(runScene(scene, options), SceneError);
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), "keep me");
  fs::remove(file);
}

TEST(RunScene, ApiRunWritesLogToTheGivenStream) {
  SceneFile scene = loadScene(std::string(WAKE_TEST_DATA_DIR) + "/scenes/small_dambreak.json");
  overrideEndTime(scene, 0.01);
  const fs::path dir = fs::temp_directory_path() / "wake_io_run_test_api";
  fs::remove_all(dir);
  std::ostringstream log;
  RunOptions options;
  options.out_dir = dir.string();
  options.log = &log;
  const RunResult r = runScene(scene, options);
  EXPECT_EQ(r.h5_path, dir.string() + "/small_dambreak.h5");
  EXPECT_TRUE(fs::is_regular_file(r.h5_path));
  EXPECT_TRUE(fs::is_regular_file(r.xdmf_path));
  EXPECT_TRUE(fs::is_regular_file(r.summary_path));
  EXPECT_EQ(r.summary["frames"], 2);
  EXPECT_NE(log.str().find("[wake] frame 1/1"), std::string::npos) << log.str();
  EXPECT_NE(log.str().find("[wake] done"), std::string::npos) << log.str();
  fs::remove_all(dir);
}

}  // namespace
}  // namespace wake
