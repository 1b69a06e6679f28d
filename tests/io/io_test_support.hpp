// Small readers shared by the tests that look at Wake's output files (tests/io/,
// tests/scenes/): whole files, and HDF5 datasets through the C API.
#pragma once

#include <gtest/gtest.h>
#include <hdf5.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace wake::test {

/// The test scenes (tests/data/scenes/).
inline const std::string kScenes = std::string(WAKE_TEST_DATA_DIR) + "/scenes/";

inline std::string readFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Dimensions of a dataset; empty when there is none of that name.
inline std::vector<hsize_t> datasetDims(hid_t location, const std::string& name) {
  const hid_t set = H5Dopen2(location, name.c_str(), H5P_DEFAULT);
  if (set < 0) return {};
  const hid_t space = H5Dget_space(set);
  std::vector<hsize_t> dims(static_cast<std::size_t>(H5Sget_simple_extent_ndims(space)));
  H5Sget_simple_extent_dims(space, dims.data(), nullptr);
  H5Sclose(space);
  H5Dclose(set);
  return dims;
}

/// All values of a dataset, flattened; empty when there is none of that name.
template <class T>
std::vector<T> readDataset(hid_t location, const std::string& name, hid_t memory_type) {
  const std::vector<hsize_t> dims = datasetDims(location, name);
  if (dims.empty()) return {};
  std::size_t n = 1;
  for (const hsize_t d : dims)
    n *= d;
  std::vector<T> values(n);
  const hid_t set = H5Dopen2(location, name.c_str(), H5P_DEFAULT);
  if (n > 0) {
    EXPECT_GE(H5Dread(set, memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()), 0) << name;
  }
  H5Dclose(set);
  return values;
}

/// A fresh folder under the system's temporary folder, removed at the end.
struct TempDir {
  std::filesystem::path path;
  TempDir() {
    static int counter = 0;
    path = std::filesystem::temp_directory_path() /
           ("wake_io_test_" + std::to_string(getpid()) + "_" + std::to_string(counter++));
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

/// Occurrences of `needle` in `text`.
inline std::size_t countOf(const std::string& text, const std::string& needle) {
  std::size_t n = 0;
  for (auto at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1))
    ++n;
  return n;
}

struct CliResult {
  int status = -1;  ///< exit status of the wake binary
  std::string out, err;
};

/// Runs the wake binary with `args` (already shell-quoted), capturing stdout and stderr.
inline CliResult runWake(const std::string& args, const std::filesystem::path& scratch) {
  const std::filesystem::path out = scratch / "stdout.txt", err = scratch / "stderr.txt";
  const std::string command = std::string("\"") + WAKE_CLI_PATH + "\" " + args + " >\"" +
                              out.string() + "\" 2>\"" + err.string() + "\"";
  const int raw = std::system(command.c_str());
  CliResult r;
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  r.out = readFile(out);
  r.err = readFile(err);
  std::filesystem::remove(out);
  std::filesystem::remove(err);
  return r;
}

}  // namespace wake::test
