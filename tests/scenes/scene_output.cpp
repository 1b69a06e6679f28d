#include "scene_output.hpp"

#include "io/io_test_support.hpp"

#include <gtest/gtest.h>
#include <hdf5.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace wake::test {

namespace {

std::vector<Vec3> toVec3(const std::vector<double>& flat) {
  std::vector<Vec3> out(flat.size() / 3);
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i] = Vec3(flat[3 * i], flat[3 * i + 1], flat[3 * i + 2]);
  return out;
}

std::string h5Path(const std::string& dir, const std::string& name) {
  return dir + "/" + name + ".h5";
}

/// scenes/<name>.json, or the copy tests/CMakeLists.txt made (WAKE_DFSPH_SCENES).
std::string scenePath(const std::string& name) {
  const std::string own = std::string(WAKE_SOURCE_DIR) + "/scenes/" + name + ".json";
  if (std::ifstream(own)) return own;
  return std::string(WAKE_DFSPH_SCENES) + "/" + name + ".json";
}

}  // namespace

SceneOutput::SceneOutput(const std::string& name)
    : dir_(std::string(WAKE_SCENE_RUNS) + "/" + name), scene_(loadScene(scenePath(name))) {
  std::ifstream summary(dir_ + "/summary.json");
  if (!summary)
    throw std::runtime_error(dir_ + "/summary.json is missing: run the scene_" + name +
                             " test (wake run) first");
  summary_ = nlohmann::json::parse(summary);

  const hid_t file = H5Fopen(h5Path(dir_, scene_.name).c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (file < 0) throw std::runtime_error("cannot open " + h5Path(dir_, scene_.name));
  H5G_info_t info;
  H5Gget_info_by_name(file, "/frames", &info, H5P_DEFAULT);
  frame_count_ = info.nlinks;
  for (const BodySpec& spec : scene_.bodies) {
    const hid_t g = H5Gopen2(file, ("/bodies/" + spec.name).c_str(), H5P_DEFAULT);
    BodyTrack track;
    track.time = readDataset<double>(g, "time", H5T_NATIVE_DOUBLE);
    const std::vector<Vec3> x = toVec3(readDataset<double>(g, "position", H5T_NATIVE_DOUBLE));
    const std::vector<double> q = readDataset<double>(g, "orientation", H5T_NATIVE_DOUBLE);
    track.velocity = toVec3(readDataset<double>(g, "linear_velocity", H5T_NATIVE_DOUBLE));
    if (x.empty() || q.size() != 4 * x.size() || track.velocity.size() != x.size() ||
        track.time.size() != x.size())
      throw std::runtime_error(h5Path(dir_, scene_.name) + ": /bodies/" + spec.name +
                               " is missing or its series differ in length");
    for (std::size_t k = 0; k < x.size(); ++k) {
      Pose pose;
      pose.position = x[k];
      pose.orientation = Quat(q[4 * k + 3], q[4 * k], q[4 * k + 1], q[4 * k + 2]).normalized();
      track.pose.push_back(pose);
    }
    H5Gclose(g);
    bodies_[spec.name] = std::move(track);
  }
  H5Fclose(file);

  std::ifstream csv(dir_ + "/series.csv");
  std::string line, cell;
  std::getline(csv, line);
  std::vector<std::string> columns;
  for (std::istringstream header(line); std::getline(header, cell, ',');)
    columns.push_back(cell);
  while (std::getline(csv, line)) {
    std::istringstream row(line);
    for (const std::string& c : columns) {
      std::getline(row, cell, ',');
      series_[c].push_back(std::strtod(cell.c_str(), nullptr));
    }
  }
  world_ = std::make_unique<SceneWorld>(scene_.sim, scene_.bodies);
  world_->coupled().start();  // builds the simulation, which holds the exact shapes
}

SceneOutput::~SceneOutput() = default;

Frame SceneOutput::frame(std::size_t k) const {
  const hid_t file = H5Fopen(h5Path(dir_, scene_.name).c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  char name[32];
  std::snprintf(name, sizeof(name), "/frames/%06zu", k);
  const hid_t g = H5Gopen2(file, name, H5P_DEFAULT);
  Frame f;
  const hid_t attr = H5Aopen(g, "time", H5P_DEFAULT);
  H5Aread(attr, H5T_NATIVE_DOUBLE, &f.time);
  H5Aclose(attr);
  f.position = toVec3(readDataset<double>(g, "position", H5T_NATIVE_DOUBLE));
  f.velocity = toVec3(readDataset<double>(g, "velocity", H5T_NATIVE_DOUBLE));
  f.id = readDataset<std::uint32_t>(g, "id", H5T_NATIVE_UINT32);
  H5Gclose(g);
  H5Fclose(file);
  return f;
}

const Shape& SceneOutput::shape(const std::string& name) const {
  const Boundaries& b = world_->simulation().boundaries();
  for (std::size_t i = 0; i < b.bodyCount(); ++i)
    if (b.body(i).name == name) return *b.body(i).shape;
  throw std::runtime_error("no body " + name);
}

double SceneOutput::signedDistance(const std::string& name, std::size_t k, const Vec3& x) const {
  return shape(name).signedDistance(body(name).pose[k].toBody(x));
}

}  // namespace wake::test
