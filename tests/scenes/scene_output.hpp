// Reads what `wake run` wrote for one demo scene (DIR/<name>.h5, DIR/summary.json,
// DIR/series.csv) and rebuilds the scene's exact body shapes, for the checks of the
// paper's claims in tests/scenes/.
#pragma once

#include "bullet_bridge/scene_world.hpp"
#include "io/scene.hpp"

#include <nlohmann/json.hpp>

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace wake::test {

struct Frame {
  double time = 0;
  std::vector<Vec3> position, velocity;
  std::vector<std::uint32_t> id;
};

struct BodyTrack {
  std::vector<double> time;
  std::vector<Pose> pose;  ///< centre of mass and orientation, one per frame
  std::vector<Vec3> velocity;
};

class SceneOutput {
 public:
  /// Loads scenes/<name>.json (or the divergence-free copy in WAKE_DFSPH_SCENES) and the
  /// run's output in WAKE_SCENE_RUNS/<name>/.
  /// Fails the calling test (gtest assertions) when something is missing.
  explicit SceneOutput(const std::string& name);
  ~SceneOutput();

  const nlohmann::json& summary() const { return summary_; }
  std::size_t frames() const { return frame_count_; }
  Frame frame(std::size_t k) const;
  const BodyTrack& body(const std::string& name) const { return bodies_.at(name); }
  /// Column of series.csv by name.
  const std::vector<double>& series(const std::string& column) const { return series_.at(column); }
  const SceneFile& scene() const { return scene_; }
  /// Exact shape of the body (body frame, origin at the centre of mass).
  const Shape& shape(const std::string& name) const;
  /// Signed distance (m) of x to the body at its pose of frame k (< 0 inside).
  double signedDistance(const std::string& name, std::size_t k, const Vec3& x) const;

 private:
  std::string dir_;
  SceneFile scene_;
  nlohmann::json summary_;
  std::size_t frame_count_ = 0;
  std::map<std::string, BodyTrack> bodies_;
  std::map<std::string, std::vector<double>> series_;
  std::unique_ptr<SceneWorld> world_;  // for the exact shapes
};

}  // namespace wake::test
