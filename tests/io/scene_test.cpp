// Scene loader: the shipped test scenes load with the right values and defaults, and every
// kind of bad input is refused with one line naming the file and the field.
#include "io/scene.hpp"
#include "io/io_test_support.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cctype>
#include <cmath>
#include <filesystem>
#include <functional>
#include <string>

namespace wake {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

using test::kScenes;

TEST(SceneLoader, DefaultsAreTheSettingsStructsOwn) {
  // One set of defaults: a scene that gives only what is required gets exactly what the
  // C++ API's default-constructed settings hold.
  const SceneFile s = parseScene(R"({"time": {"end": 1},
      "fluid": {"particle_radius": 0.01, "blocks": [{"min": [0, 0, 0], "max": [1, 1, 1]}]}})",
                                 "minimal.json");
  const SimulationSettings d;
  EXPECT_EQ(s.sim.gravity, d.gravity);
  EXPECT_EQ(s.sim.cfl, d.cfl);
  EXPECT_EQ(s.sim.max_dt, d.max_dt);
  EXPECT_EQ(s.sim.method, d.method);
  EXPECT_EQ(s.sim.penalty_strength, d.penalty_strength);
  EXPECT_EQ(s.sim.health.max_density_ratio, d.health.max_density_ratio);
  EXPECT_EQ(s.sim.fluid.rest_density, d.fluid.rest_density);
  EXPECT_EQ(s.sim.fluid.viscosity, d.fluid.viscosity);
  EXPECT_EQ(s.sim.fluid.kinematic_viscosity, d.fluid.kinematic_viscosity);
  EXPECT_EQ(s.sim.fluid.smoothing_ratio, d.fluid.smoothing_ratio);
  EXPECT_EQ(s.sim.fluid.gamma, d.fluid.gamma);
  const SceneFile h = parseScene(R"({"time": {"end": 1}, "health": {"max_density_ratio": 1.5},
      "fluid": {"particle_radius": 0.01, "blocks": [{"min": [0, 0, 0], "max": [1, 1, 1]}]}})",
                                 "limit.json");
  EXPECT_EQ(h.sim.health.max_density_ratio, 1.5);
  EXPECT_EQ(s.sim.solver, d.solver);
  EXPECT_EQ(s.sim.solver, FluidSolver::Wcsph);
}

TEST(SceneLoader, DivergenceFreeSolverAndItsSettings) {
  const SceneFile s = parseScene(R"({"time": {"end": 1, "cfl": 0.6},
      "fluid": {"particle_radius": 0.01, "solver": "dfsph",
                "dfsph": {"max_density_error": 0.0002, "max_divergence_iterations": 0},
                "blocks": [{"min": [0, 0, 0], "max": [1, 1, 1]}]}})",
                                 "dfsph.json");
  const DfsphParams d;
  EXPECT_EQ(s.sim.solver, FluidSolver::Dfsph);
  EXPECT_EQ(s.sim.dfsph.max_density_error, 0.0002);
  EXPECT_EQ(s.sim.dfsph.max_divergence_iterations, 0);  // no divergence solve
  EXPECT_EQ(s.sim.dfsph.max_divergence_error, d.max_divergence_error);
  EXPECT_EQ(s.sim.dfsph.max_iterations, d.max_iterations);
  EXPECT_TRUE(s.sim.dfsph.correct_gradient);  // "bulk", the default
  EXPECT_EQ(s.sim.dfsph.pressure_force, DfsphParams::PressureForce::Symmetric);  // the default
  EXPECT_EQ(s.sim.cfl, 0.6);
  const SceneFile off = parseScene(R"({"time": {"end": 1},
      "fluid": {"particle_radius": 0.01, "solver": "dfsph", "dfsph": {"gradient_correction": "none"},
                "blocks": [{"min": [0, 0, 0], "max": [1, 1, 1]}]}})",
                                   "plain.json");
  EXPECT_FALSE(off.sim.dfsph.correct_gradient);
  const SceneFile consistent = parseScene(R"({"time": {"end": 1},
      "fluid": {"particle_radius": 0.01, "solver": "dfsph",
                "dfsph": {"pressure_force": "consistent"},
                "blocks": [{"min": [0, 0, 0], "max": [1, 1, 1]}]}})",
                                          "consistent.json");
  EXPECT_EQ(consistent.sim.dfsph.pressure_force, DfsphParams::PressureForce::Consistent);
}

TEST(SceneLoader, SmallDambreak) {
  const SceneFile s = loadScene(kScenes + "small_dambreak.json");
  EXPECT_EQ(s.name, "small_dambreak");
  EXPECT_EQ(s.path, kScenes + "small_dambreak.json");
  EXPECT_DOUBLE_EQ(s.end_time, 0.05);
  EXPECT_DOUBLE_EQ(s.frame_rate, 100.0);
  EXPECT_EQ(s.sim.gravity, Vec3(0, -9.81, 0));
  EXPECT_DOUBLE_EQ(s.sim.cfl, 0.4);
  EXPECT_DOUBLE_EQ(s.sim.max_dt, 1e-3);
  EXPECT_DOUBLE_EQ(s.sim.fluid.particle_radius, 0.01);
  EXPECT_DOUBLE_EQ(s.sim.fluid.rest_density, 1000.0);
  EXPECT_EQ(s.sim.fluid.speed_of_sound, 0.0);  // "auto"
  EXPECT_DOUBLE_EQ(s.sim.fluid.viscosity, 0.1);
  EXPECT_DOUBLE_EQ(s.sim.fluid.kinematic_viscosity, 1e-6);  // water
  EXPECT_DOUBLE_EQ(s.sim.fluid.smoothing_ratio, 1.0);
  EXPECT_EQ(s.sim.fluid.pressure_gradient, PressureGradient::Consistent);
  ASSERT_EQ(s.sim.blocks.size(), 1u);
  EXPECT_DOUBLE_EQ(s.sim.blocks[0].kinematic_viscosity, 1e-6);  // the fluid's
  EXPECT_EQ(s.sim.blocks[0].min, Vec3(0, 0, 0));
  EXPECT_EQ(s.sim.blocks[0].max, Vec3(0.1, 0.2, 0.1));
  EXPECT_EQ(s.sim.method, CouplingMethod::Local);
  EXPECT_TRUE(s.sim.domain.empty());
  EXPECT_DOUBLE_EQ(s.sim.health.max_density_ratio, 3.0);
  EXPECT_TRUE(s.sim.bodies.empty());  // the runner builds bodies from s.bodies
  ASSERT_EQ(s.bodies.size(), 1u);
  const BodySpec& tank = s.bodies[0];
  EXPECT_EQ(tank.name, "tank");
  EXPECT_EQ(tank.kind, BodyKind::Static);
  EXPECT_EQ(tank.coupling, CouplingMode::OneWay);
  EXPECT_EQ(tank.shape.type, "tank");
  EXPECT_EQ(tank.shape.min, Vec3(0, 0, 0));
  EXPECT_EQ(tank.shape.max, Vec3(0.4, 0.3, 0.1));
  EXPECT_EQ(tank.shape.wall_thickness, 0.0);  // automatic
  EXPECT_EQ(tank.slip, 0.0);
  EXPECT_EQ(tank.restitution, 0.0);
  EXPECT_EQ(tank.friction, 0.5);
  EXPECT_EQ(tank.mass, 0.0);
  EXPECT_EQ(tank.density, 0.0);
  // 5 x 10 x 5 particles at spacing 0.02 m.
  EXPECT_DOUBLE_EQ(estimateFluidParticles(s.sim), 250.0);
  EXPECT_EQ(frameCount(s), 5u);
  EXPECT_DOUBLE_EQ(frameTime(s, 0), 0.0);
  EXPECT_DOUBLE_EQ(frameTime(s, 2), 0.02);
  EXPECT_EQ(frameTime(s, 5), 0.05);
}

/// One body of every shape type and every kind; a mesh path relative to the scene file.
const char* const kEveryShape = R"({
  "description": "every shape type and every kind of body",
  "time": { "end": 0.1 },
  "fluid": { "particle_radius": 0.01, "speed_of_sound": 20, "smoothing_ratio": 1.2,
             "pressure_gradient": "symmetric",
             "blocks": [ { "min": [0.02, 0.02, 0.02], "max": [0.2, 0.2, 0.18] } ] },
  "coupling": { "method": "global" },
  "domain": { "min": [-0.1, -0.1, -0.1], "max": [0.6, 0.6, 0.3] },
  "bodies": [
    { "name": "tank", "kind": "static", "slip": 1.0, "restitution": 0.5, "friction": 0.2,
      "shape": { "type": "tank", "min": [0, 0, 0], "max": [0.5, 0.4, 0.2],
                 "wall_thickness": 0.03 } },
    { "name": "floor", "coupling": "one_way",
      "shape": { "type": "plane", "normal": [0, 2, 0], "offset": -0.05 } },
    { "name": "block", "kind": "dynamic", "density": 500, "coupling": "one_way",
      "position": [0.35, 0.05, 0.1], "orientation": [0, 0, 1, 1], "friction": 0.8,
      "shape": { "type": "box", "half_extents": [0.03, 0.05, 0.03], "margin": 0.002 } },
    { "name": "ball", "kind": "dynamic", "mass": 2, "linear_velocity": [1, 0, 0],
      "angular_velocity": [0, 0, 3], "shape": { "type": "sphere", "radius": 0.04 } },
    { "name": "pill", "kind": "kinematic", "linear_velocity": [0, -0.5, 0],
      "angular_velocity": [0, 1, 0],
      "shape": { "type": "capsule", "radius": 0.02, "height": 0 } },
    { "name": "can", "kind": "dynamic", "density": 800,
      "shape": { "type": "cylinder", "radius": 0.03, "height": 0.1, "margin": 0 } },
    { "name": "cone", "kind": "kinematic", "coupling": "one_way",
      "shape": { "type": "cone", "radius": 0.03, "height": 0.06 } },
    { "name": "gem", "kind": "dynamic", "mass": 0.1,
      "shape": { "type": "convex_hull",
                 "points": [[0, 0, 0], [0.05, 0, 0], [0, 0.05, 0], [0, 0, 0.05],
                            [0.01, 0.01, 0.01]] } },
    { "name": "cube", "position": [0.42, 0.3, 0.1],
      "shape": { "type": "mesh", "file": "meshes/cube.obj", "scale": 0.02 } },
    { "name": "hull", "kind": "dynamic", "density": 300,
      "shape": { "type": "mesh", "file": "meshes/../meshes/cube.obj",
                 "scale": [0.1, 0.02, 0.05] } },
    { "name": "raft", "kind": "dynamic", "density": 400,
      "shape": { "type": "compound", "margin": 0.001, "children": [
        { "shape": { "type": "box", "half_extents": [0.1, 0.01, 0.05], "margin": 0.003 } },
        { "shape": { "type": "sphere", "radius": 0.02 }, "position": [0.1, 0.02, 0],
          "orientation": [0, 2, 0, 0] },
        { "shape": { "type": "mesh", "file": "meshes/cube.obj", "scale": 0.01 },
          "position": [-0.1, 0.02, 0] } ] } }
  ]
})";

TEST(SceneLoader, EveryShapeAndKindAndDefaults) {
  const SceneFile s = parseScene(kEveryShape, kScenes + "every_shape.json");
  EXPECT_EQ(s.name, "every_shape");  // default: the file's stem
  EXPECT_DOUBLE_EQ(s.frame_rate, 30.0);
  EXPECT_EQ(s.sim.gravity, Vec3(0, -9.81, 0));
  EXPECT_DOUBLE_EQ(s.sim.fluid.speed_of_sound, 20.0);
  EXPECT_DOUBLE_EQ(s.sim.fluid.smoothing_ratio, 1.2);
  EXPECT_EQ(s.sim.fluid.pressure_gradient, PressureGradient::Symmetric);
  EXPECT_EQ(s.sim.method, CouplingMethod::Global);
  EXPECT_EQ(s.sim.domain.min, Vec3(-0.1, -0.1, -0.1));
  EXPECT_EQ(s.sim.domain.max, Vec3(0.6, 0.6, 0.3));
  EXPECT_TRUE(s.sim.bodies.empty());

  ASSERT_EQ(s.bodies.size(), 11u);
  const char* types[] = {"tank", "plane",       "box",  "sphere", "capsule", "cylinder",
                         "cone", "convex_hull", "mesh", "mesh",   "compound"};
  const BodyKind kinds[] = {BodyKind::Static,    BodyKind::Static,    BodyKind::Dynamic,
                            BodyKind::Dynamic,   BodyKind::Kinematic, BodyKind::Dynamic,
                            BodyKind::Kinematic, BodyKind::Dynamic,   BodyKind::Static,
                            BodyKind::Dynamic,   BodyKind::Dynamic};
  for (std::size_t i = 0; i < s.bodies.size(); ++i) {
    EXPECT_EQ(s.bodies[i].shape.type, types[i]) << i;
    EXPECT_EQ(s.bodies[i].kind, kinds[i]) << i;
  }

  const BodySpec& tank = s.bodies[0];
  EXPECT_EQ(tank.name, "tank");
  EXPECT_EQ(tank.slip, 1.0);
  EXPECT_EQ(tank.restitution, 0.5);
  EXPECT_EQ(tank.friction, 0.2);
  EXPECT_EQ(tank.coupling, CouplingMode::OneWay);
  EXPECT_EQ(tank.shape.wall_thickness, 0.03);
  EXPECT_EQ(tank.shape.max, Vec3(0.5, 0.4, 0.2));

  const ShapeSpec& floor = s.bodies[1].shape;  // normal normalised
  EXPECT_EQ(floor.normal, Vec3(0, 1, 0));
  EXPECT_EQ(floor.offset, -0.05);

  const BodySpec& block = s.bodies[2];
  EXPECT_EQ(block.coupling, CouplingMode::OneWay);
  EXPECT_EQ(block.density, 500.0);
  EXPECT_EQ(block.mass, 0.0);
  EXPECT_EQ(block.friction, 0.8);
  EXPECT_EQ(block.pose.position, Vec3(0.35, 0.05, 0.1));
  const Quat q = block.pose.orientation;  // [0, 0, 1, 1] normalised
  EXPECT_NEAR(q.norm(), 1.0, 1e-15);
  EXPECT_NEAR(q.z(), std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(q.w(), std::sqrt(0.5), 1e-15);
  EXPECT_EQ(block.shape.half_extents, Vec3(0.03, 0.05, 0.03));
  EXPECT_EQ(block.shape.margin, 0.002);

  const BodySpec& ball = s.bodies[3];
  EXPECT_EQ(ball.coupling, CouplingMode::TwoWay);  // default of dynamic bodies
  EXPECT_EQ(ball.mass, 2.0);
  EXPECT_EQ(ball.density, 0.0);
  EXPECT_EQ(ball.friction, 0.5);
  EXPECT_EQ(ball.linear_velocity, Vec3(1, 0, 0));
  EXPECT_EQ(ball.angular_velocity, Vec3(0, 0, 3));
  EXPECT_EQ(ball.shape.radius, 0.04);
  EXPECT_EQ(ball.shape.margin, -1.0);  // automatic

  const BodySpec& pill = s.bodies[4];
  EXPECT_EQ(pill.coupling, CouplingMode::OneWay);  // kinematic: always one-way
  EXPECT_EQ(pill.linear_velocity, Vec3(0, -0.5, 0));
  EXPECT_EQ(pill.angular_velocity, Vec3(0, 1, 0));
  EXPECT_EQ(pill.shape.radius, 0.02);
  EXPECT_EQ(pill.shape.height, 0.0);

  EXPECT_EQ(s.bodies[5].shape.radius, 0.03);
  EXPECT_EQ(s.bodies[5].shape.height, 0.1);
  EXPECT_EQ(s.bodies[5].shape.margin, 0.0);
  EXPECT_EQ(s.bodies[6].shape.height, 0.06);
  EXPECT_EQ(s.bodies[6].coupling, CouplingMode::OneWay);

  const ShapeSpec& gem = s.bodies[7].shape;
  ASSERT_EQ(gem.points.size(), 5u);
  EXPECT_EQ(gem.points[3], Vec3(0, 0, 0.05));

  // Mesh files: absolute, normalised, relative to the scene file's folder.
  const std::string cube = (fs::path(kScenes) / "meshes" / "cube.obj").lexically_normal().string();
  EXPECT_EQ(s.bodies[8].shape.file, cube);
  EXPECT_EQ(s.bodies[8].shape.scale, Vec3::Constant(0.02));
  EXPECT_EQ(s.bodies[8].pose.position, Vec3(0.42, 0.3, 0.1));
  EXPECT_EQ(s.bodies[9].shape.file, cube);
  EXPECT_EQ(s.bodies[9].shape.scale, Vec3(0.1, 0.02, 0.05));

  const ShapeSpec& raft = s.bodies[10].shape;
  EXPECT_EQ(raft.margin, 0.001);
  ASSERT_EQ(raft.children.size(), 3u);
  EXPECT_EQ(raft.children[0].shape.type, "box");
  EXPECT_EQ(raft.children[0].pose.position, Vec3::Zero());
  EXPECT_EQ(raft.children[0].shape.margin, 0.003);  // its own
  EXPECT_EQ(raft.children[0].shape.half_extents, Vec3(0.1, 0.01, 0.05));
  EXPECT_EQ(raft.children[1].shape.type, "sphere");
  EXPECT_EQ(raft.children[1].shape.margin, 0.001);  // the compound's
  EXPECT_EQ(raft.children[1].pose.position, Vec3(0.1, 0.02, 0));
  EXPECT_NEAR(raft.children[1].pose.orientation.y(), 1.0, 1e-15);  // [0, 2, 0, 0] normalised
  EXPECT_EQ(raft.children[2].shape.type, "mesh");
  EXPECT_EQ(raft.children[2].shape.file, cube);
  EXPECT_EQ(raft.children[2].shape.scale, Vec3::Constant(0.01));
  EXPECT_EQ(raft.children[2].shape.margin, -1.0);  // meshes take no margin
}

TEST(SceneLoader, MeshPathOfARelativeSceneFileBecomesAbsolute) {
  const std::string relative = fs::relative(fs::path(kScenes) / "every_shape.json").string();
  ASSERT_FALSE(fs::path(relative).is_absolute());
  const SceneFile s = parseScene(kEveryShape, relative);
  const fs::path file = s.bodies[8].shape.file;
  EXPECT_TRUE(file.is_absolute()) << file;
  EXPECT_TRUE(fs::equivalent(file, fs::path(kScenes) / "meshes" / "cube.obj")) << file;
}

TEST(SceneLoader, FrameTimesEndOnEndTime) {
  SceneFile s;
  s.end_time = 0.05;
  s.frame_rate = 30;  // 1.5 frame intervals: frames at 0, 1/30, 0.05
  EXPECT_EQ(frameCount(s), 2u);
  EXPECT_DOUBLE_EQ(frameTime(s, 1), 1.0 / 30.0);
  EXPECT_EQ(frameTime(s, 2), 0.05);
  s.end_time = 2.0;  // 60 intervals exactly
  EXPECT_EQ(frameCount(s), 60u);
  s.end_time = 1e-4;  // shorter than one interval: frames at 0 and end
  EXPECT_EQ(frameCount(s), 1u);
}

TEST(SceneLoader, EndTimeOverride) {
  SceneFile s = loadScene(kScenes + "small_dambreak.json");
  overrideEndTime(s, 0.02);
  EXPECT_EQ(s.end_time, 0.02);
  for (const double bad : {0.0, -1.0, std::nan(""), HUGE_VAL}) {
    try {
      overrideEndTime(s, bad, "--end");
      ADD_FAILURE() << "accepted " << bad;
    } catch (const SceneError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("--end: ", 0), 0u) << e.what();
    }
  }
}

TEST(SceneLoader, MissingFileNamesIt) {
  try {
    loadScene(kScenes + "no_such_scene.json");
    FAIL() << "no error";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_scene.json"), std::string::npos);
  }
}

/// A valid scene (in JSON) that each bad-input case breaks in one place.
json validScene() {
  return json::parse(R"({
    "name": "t",
    "time": { "end": 0.1 },
    "fluid": { "particle_radius": 0.01,
               "blocks": [ { "min": [0, 0, 0], "max": [0.1, 0.1, 0.1] } ] },
    "bodies": [ { "name": "tank",
                  "shape": { "type": "tank", "min": [0, 0, 0], "max": [0.4, 0.3, 0.1] } } ]
  })");
}

struct BadCase {
  const char* what;
  std::function<void(json&)> edit;  ///< breaks the valid scene
  const char* field;                ///< the message must contain this field path
  const char* says;                 ///< ... and this explanation
};

class BadScene : public ::testing::TestWithParam<BadCase> {};

TEST_P(BadScene, IsRefusedWithOneLineNamingTheField) {
  const BadCase& c = GetParam();
  json scene = validScene();
  c.edit(scene);
  try {
    parseScene(scene.dump(), "scene.json");
    FAIL() << c.what << ": accepted";
  } catch (const SceneError& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.rfind("scene.json: ", 0), 0u) << m;
    EXPECT_NE(m.find(c.field), std::string::npos) << c.what << ": " << m;
    EXPECT_NE(m.find(c.says), std::string::npos) << c.what << ": " << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
}

json box(double half) {
  return {{"type", "box"}, {"half_extents", {half, half, half}}};
}

/// A dynamic body with a box shape and the given extra fields (mass, density, coupling).
json dynamicBox(const char* name, const json& extra) {
  json body = {{"name", name}, {"kind", "dynamic"}, {"shape", box(0.05)}};
  body.update(extra);
  return body;
}

/// A static body with a convex hull of the given points.
json hull(const json& points) {
  return {{"name", "h"}, {"shape", {{"type", "convex_hull"}, {"points", points}}}};
}

json compound(const json& children) {
  return {{"type", "compound"}, {"children", children}};
}

const BadCase kBadCases[] = {
    {"negative radius", [](json& s) { s["fluid"]["particle_radius"] = -0.01; },
     "fluid.particle_radius: ", "must be > 0 (got -0.01)"},
    {"radius of wrong type", [](json& s) { s["fluid"]["particle_radius"] = "0.01"; },
     "fluid.particle_radius: ", "must be a number"},
    {"missing radius", [](json& s) { s["fluid"].erase("particle_radius"); },
     "fluid.particle_radius: ", "required"},
    {"max < min",
     [](json& s) {
       s["fluid"]["blocks"][0]["max"] = {0.1, -0.2, 0.3};
     },
     "fluid.blocks[0].max: ", "must be greater than min on every axis"},
    {"nan as a string",
     [](json& s) {
       s["gravity"] = {0, "nan", 0};
     },
     "gravity[1]: ", "must be a number (got \"nan\")"},
    {"vector of two",
     [](json& s) {
       s["gravity"] = {0, -9.81};
     },
     "gravity: ", "must be an array of 3 numbers"},
    {"unknown field", [](json& s) { s["fluid"]["partcle_radius"] = 0.01; },
     "fluid.partcle_radius: ", "unknown field"},
    {"unknown top-level field", [](json& s) { s["bodys"] = json::array(); },
     "bodys: ", "unknown field"},
    {"missing end", [](json& s) { s["time"].erase("end"); }, "time.end: ", "required"},
    {"cfl zero", [](json& s) { s["time"]["cfl"] = 0; }, "time.cfl: ", "in (0, 1]"},
    {"frame rate negative", [](json& s) { s["time"]["frame_rate"] = -30; },
     "time.frame_rate: ", "> 0"},
    {"smoothing ratio", [](json& s) { s["fluid"]["smoothing_ratio"] = 3; },
     "fluid.smoothing_ratio: ", "in [0.8, 2]"},
    {"speed of sound word", [](json& s) { s["fluid"]["speed_of_sound"] = "fast"; },
     "fluid.speed_of_sound: ", "\"auto\""},
    {"negative viscosity", [](json& s) { s["fluid"]["viscosity"] = -0.1; },
     "fluid.viscosity: ", ">= 0"},
    {"negative kinematic viscosity", [](json& s) { s["fluid"]["kinematic_viscosity"] = -1e-6; },
     "fluid.kinematic_viscosity: ", "in [0, 1]"},
    {"block kinematic viscosity too large",
     [](json& s) { s["fluid"]["blocks"][0]["kinematic_viscosity"] = 5; },
     "fluid.blocks[0].kinematic_viscosity: ", "in [0, 1]"},
    {"no blocks", [](json& s) { s["fluid"]["blocks"] = json::array(); },
     "fluid.blocks: ", "at least one"},
    {"block below the lattice spacing",
     [](json& s) {
       s["fluid"]["blocks"][0]["max"] = {0.005, 0.1, 0.1};
     },
     "fluid.blocks[0]: ", "no particles"},
    {"more particles than memory", [](json& s) { s["fluid"]["particle_radius"] = 1e-5; },
     "fluid.particle_radius: ", "fluid particles"},
    {"penalty strength without penalty",
     [](json& s) {
       s["coupling"]["method"] = "local";
       s["coupling"]["penalty_strength"] = 10.0;
     },
     "coupling.penalty_strength: ", "only used with"},
    {"penalty strength zero",
     [](json& s) {
       s["coupling"]["method"] = "penalty";
       s["coupling"]["penalty_strength"] = 0.0;
     },
     "coupling.penalty_strength: ", "> 0"},
    {"unknown method", [](json& s) { s["coupling"]["method"] = "magic"; },
     "coupling.method: ", "\"magic\""},
    {"unknown solver", [](json& s) { s["fluid"]["solver"] = "isph"; },
     "fluid.solver: ", "unknown value \"isph\""},
    {"unknown pressure gradient", [](json& s) { s["fluid"]["pressure_gradient"] = "exact"; },
     "fluid.pressure_gradient: ", "unknown value \"exact\""},
    {"pressure gradient with dfsph",
     [](json& s) {
       s["fluid"]["solver"] = "dfsph";
       s["fluid"]["pressure_gradient"] = "symmetric";
     },
     "fluid.pressure_gradient: ", "only used with \"solver\": \"wcsph\""},
    {"dfsph settings without dfsph",
     [](json& s) {
       s["fluid"]["dfsph"] = {{"max_iterations", 50}};
     },
     "fluid.dfsph: ", "only used with \"solver\": \"dfsph\""},
    {"dfsph density error too large",
     [](json& s) {
       s["fluid"]["solver"] = "dfsph";
       s["fluid"]["dfsph"] = {{"max_density_error", 0.5}};
     },
     "fluid.dfsph.max_density_error: ", "in (0, 0.1]"},
    {"dfsph unknown gradient correction",
     [](json& s) {
       s["fluid"]["solver"] = "dfsph";
       s["fluid"]["dfsph"] = {{"gradient_correction", "local"}};
     },
     "fluid.dfsph.gradient_correction: ", "unknown value \"local\""},
    {"dfsph unknown pressure force",
     [](json& s) {
       s["fluid"]["solver"] = "dfsph";
       s["fluid"]["dfsph"] = {{"pressure_force", "difference"}};
     },
     "fluid.dfsph.pressure_force: ", "unknown value \"difference\""},
    {"dfsph iterations not whole",
     [](json& s) {
       s["fluid"]["solver"] = "dfsph";
       s["fluid"]["dfsph"] = {{"max_iterations", 10.5}};
     },
     "fluid.dfsph.max_iterations: ", "whole number"},
    {"dfsph one iteration",
     [](json& s) {
       s["fluid"]["solver"] = "dfsph";
       s["fluid"]["dfsph"] = {{"max_iterations", 1}};
     },
     "fluid.dfsph.max_iterations: ", "in [2, 1000000] (got 1)"},
    {"dfsph unknown field",
     [](json& s) {
       s["fluid"]["solver"] = "dfsph";
       s["fluid"]["dfsph"] = {{"tolerance", 0.01}};
     },
     "fluid.dfsph.tolerance: ", "unknown field"},
    {"dfsph with a large cfl",
     [](json& s) {
       s["fluid"]["solver"] = "dfsph";
       s["time"]["cfl"] = 0.8;
     },
     "time.cfl: ", "(0, 0.6] with fluid.solver \"dfsph\""},
    {"domain max < min",
     [](json& s) {
       s["domain"] = {{"min", {0, 0, 0}}, {"max", {1, 0, 1}}};
     },
     "domain.max: ", "greater than min"},
    {"bad slip", [](json& s) { s["bodies"][0]["slip"] = 1.5; },
     "bodies[0].slip: ", "in [0, 1] (got 1.5)"},
    {"bad restitution", [](json& s) { s["bodies"][0]["restitution"] = -1; },
     "bodies[0].restitution: ", "in [0, 1]"},
    {"unknown shape type",
     [](json& s) {
       s["bodies"][0]["shape"] = {{"type", "torus"}};
     },
     "bodies[0].shape.type: ", "\"torus\""},
    {"shape without type", [](json& s) { s["bodies"][0]["shape"].erase("type"); },
     "bodies[0].shape.type: ", "required"},
    {"missing mesh file",
     [](json& s) {
       s["bodies"][0]["shape"] = {{"type", "mesh"}, {"file", "nope.obj"}};
     },
     "bodies[0].shape.file: ", "nope.obj"},
    {"mesh scale zero",
     [](json& s) {
       s["bodies"][0]["shape"] = {{"type", "mesh"}, {"file", "nope.obj"}, {"scale", 0}};
     },
     "bodies[0].shape.scale: ", "> 0"},
    {"box half extent zero",
     [](json& s) {
       s["bodies"].push_back({{"name", "b"}, {"shape", box(0)}});
     },
     "bodies[1].shape.half_extents[0]: ", "> 0"},
    {"sphere field of a box",
     [](json& s) {
       s["bodies"].push_back({{"name", "b"}, {"shape", {{"type", "box"}, {"radius", 1}}}});
     },
     "bodies[1].shape.radius: ", "unknown field"},
    {"plane zero normal",
     [](json& s) {
       s["bodies"].push_back(
           {{"name", "p"}, {"shape", {{"type", "plane"}, {"normal", {0, 0, 0}}}}});
     },
     "bodies[1].shape.normal: ", "non-zero"},
    {"tank wall thickness", [](json& s) { s["bodies"][0]["shape"]["wall_thickness"] = -1; },
     "bodies[0].shape.wall_thickness: ", "> 0"},
    {"duplicate body name",
     [](json& s) {
       s["bodies"].push_back({{"name", "tank"}, {"shape", box(0.1)}});
     },
     "bodies[1].name: ", "duplicate body name \"tank\""},
    {"body without name", [](json& s) { s["bodies"][0].erase("name"); },
     "bodies[0].name: ", "required"},
    {"body name with a slash", [](json& s) { s["bodies"][0]["name"] = "a/b"; },
     "bodies[0].name: ", "'/'"},
    {"unknown kind", [](json& s) { s["bodies"][0]["kind"] = "floating"; },
     "bodies[0].kind: ", "\"floating\""},
    {"tank on a dynamic body",
     [](json& s) {
       s["bodies"][0]["kind"] = "dynamic";
       s["bodies"][0]["mass"] = 1;
     },
     "bodies[0].shape.type: ", "only allowed on a static body (this body is dynamic)"},
    {"plane on a kinematic body",
     [](json& s) {
       s["bodies"].push_back({{"name", "p"},
                              {"kind", "kinematic"},
                              {"shape", {{"type", "plane"}, {"normal", {0, 1, 0}}}}});
     },
     "bodies[1].shape.type: ", "only allowed on a static body (this body is kinematic)"},
    {"zero quaternion",
     [](json& s) {
       s["bodies"][0]["orientation"] = {0, 0, 0, 0};
     },
     "bodies[0].orientation: ", "non-zero quaternion"},
    {"quaternion of three",
     [](json& s) {
       s["bodies"][0]["orientation"] = {0, 0, 1};
     },
     "bodies[0].orientation: ", "array of 4 numbers"},
    {"quaternion with a string",
     [](json& s) {
       s["bodies"][0]["orientation"] = {0, 0, "inf", 1};
     },
     "bodies[0].orientation[2]: ", "must be a number"},
    {"negative mass",
     [](json& s) {
       s["bodies"].push_back(dynamicBox("b", {{"mass", -2}}));
     },
     "bodies[1].mass: ", "> 0"},
    {"zero density",
     [](json& s) {
       s["bodies"].push_back(dynamicBox("b", {{"density", 0}}));
     },
     "bodies[1].density: ", "> 0"},
    {"density and mass",
     [](json& s) {
       s["bodies"].push_back(dynamicBox("b", {{"mass", 2}, {"density", 500}}));
     },
     "bodies[1].mass: ", "not both"},
    {"dynamic body without density or mass",
     [](json& s) { s["bodies"].push_back(dynamicBox("b", json::object())); },
     "bodies[1].density: ", "needs either density (kg/m^3) or mass (kg)"},
    {"mass of a static body", [](json& s) { s["bodies"][0]["mass"] = 2; },
     "bodies[0].mass: ", "only dynamic bodies take a mass (this body is static)"},
    {"density of a kinematic body",
     [](json& s) {
       s["bodies"].push_back(
           {{"name", "k"}, {"kind", "kinematic"}, {"density", 500}, {"shape", box(0.1)}});
     },
     "bodies[1].density: ", "only dynamic bodies take a density (this body is kinematic)"},
    {"two-way static body", [](json& s) { s["bodies"][0]["coupling"] = "two_way"; },
     "bodies[0].coupling: ", "static and kinematic bodies are always one-way"},
    {"two-way kinematic body",
     [](json& s) {
       s["bodies"].push_back(dynamicBox("b", {{"mass", 1}}));
       s["bodies"].push_back(
           {{"name", "k"}, {"kind", "kinematic"}, {"coupling", "two_way"}, {"shape", box(0.1)}});
     },
     "bodies[2].coupling: ", "always one-way (this body is kinematic)"},
    {"unknown coupling mode",
     [](json& s) {
       s["bodies"].push_back(dynamicBox("b", {{"mass", 1}, {"coupling", "three_way"}}));
     },
     "bodies[1].coupling: ", "\"three_way\""},
    {"moving static body",
     [](json& s) {
       s["bodies"][0]["linear_velocity"] = {0, 1, 0};
     },
     "bodies[0].linear_velocity: ", "a static body never moves"},
    {"spinning static body",
     [](json& s) {
       s["bodies"][0]["angular_velocity"] = {0, 0, -2};
     },
     "bodies[0].angular_velocity: ", "a static body never moves"},
    {"negative friction", [](json& s) { s["bodies"][0]["friction"] = -0.1; },
     "bodies[0].friction: ", ">= 0"},
    {"capsule negative height",
     [](json& s) {
       s["bodies"].push_back(
           {{"name", "c"}, {"shape", {{"type", "capsule"}, {"radius", 0.1}, {"height", -1}}}});
     },
     "bodies[1].shape.height: ", ">= 0"},
    {"cylinder without height",
     [](json& s) {
       s["bodies"].push_back({{"name", "c"}, {"shape", {{"type", "cylinder"}, {"radius", 0.1}}}});
     },
     "bodies[1].shape.height: ", "required"},
    {"cone zero height",
     [](json& s) {
       s["bodies"].push_back(
           {{"name", "c"}, {"shape", {{"type", "cone"}, {"radius", 0.1}, {"height", 0}}}});
     },
     "bodies[1].shape.height: ", "> 0"},
    {"cone zero radius",
     [](json& s) {
       s["bodies"].push_back(
           {{"name", "c"}, {"shape", {{"type", "cone"}, {"radius", 0}, {"height", 1}}}});
     },
     "bodies[1].shape.radius: ", "> 0"},
    {"negative margin",
     [](json& s) {
       s["bodies"].push_back({{"name", "b"}, {"shape", box(0.1)}});
       s["bodies"][1]["shape"]["margin"] = -0.01;
     },
     "bodies[1].shape.margin: ", ">= 0"},
    {"margin of a tank", [](json& s) { s["bodies"][0]["shape"]["margin"] = 0.01; },
     "bodies[0].shape.margin: ", "unknown field"},
    {"margin of a mesh",
     [](json& s) {
       s["bodies"][0]["shape"] = {{"type", "mesh"}, {"file", "cube.obj"}, {"margin", 0}};
     },
     "bodies[0].shape.margin: ", "unknown field"},
    {"hull of three points",
     [](json& s) {
       s["bodies"].push_back(hull({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}));
     },
     "bodies[1].shape.points: ", "at least 4 points (got 3)"},
    {"flat hull",
     [](json& s) {
       s["bodies"].push_back(hull({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {0.5, 2, 0}}));
     },
     "bodies[1].shape.points: ", "must span a volume"},
    {"hull on a line",
     [](json& s) {
       s["bodies"].push_back(hull({{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {3, 3, 3}}));
     },
     "bodies[1].shape.points: ", "must span a volume"},
    {"hull of one point",
     [](json& s) {
       s["bodies"].push_back(hull({{1, 1, 1}, {1, 1, 1}, {1, 1, 1}, {1, 1, 1}}));
     },
     "bodies[1].shape.points: ", "must span a volume"},
    {"hull point of two numbers",
     [](json& s) {
       s["bodies"].push_back(hull({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}));
       s["bodies"][1]["shape"]["points"][2] = {0, 1};
     },
     "bodies[1].shape.points[2]: ", "array of 3 numbers"},
    {"hull points not a list",
     [](json& s) {
       s["bodies"].push_back(hull({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}));
       s["bodies"][1]["shape"]["points"] = 4;
     },
     "bodies[1].shape.points: ", "must be an array"},
    {"plane in a compound",
     [](json& s) {
       s["bodies"][0]["shape"] = compound(
           {{{"shape", {{"type", "plane"}, {"normal", {0, 1, 0}}}}}, {{"shape", box(0.1)}}});
     },
     "bodies[0].shape.children[0].shape.type: ", "a compound's child cannot be a plane"},
    {"tank in a compound",
     [](json& s) {
       s["bodies"][0]["shape"] =
           compound({{{"shape", box(0.1)}}, {{"shape", s["bodies"][0]["shape"]}}});
     },
     "bodies[0].shape.children[1].shape.type: ", "a compound's child cannot be a tank"},
    {"nested compound",
     [](json& s) {
       s["bodies"].push_back(dynamicBox("b", {{"mass", 1}}));
       s["bodies"][1]["shape"] = compound({{{"shape", compound({{{"shape", box(0.1)}}})}}});
     },
     "bodies[1].shape.children[0].shape.type: ", "cannot be a compound"},
    {"empty compound",
     [](json& s) {
       s["bodies"].push_back({{"name", "c"}, {"shape", compound(json::array())}});
     },
     "bodies[1].shape.children: ", "at least one child"},
    {"compound child without shape",
     [](json& s) {
       s["bodies"].push_back({{"name", "c"}, {"shape", compound({{{"position", {0, 0, 0}}}})}});
     },
     "bodies[1].shape.children[0].shape: ", "required"},
    {"compound child unknown field",
     [](json& s) {
       s["bodies"].push_back(
           {{"name", "c"}, {"shape", compound({{{"shape", box(0.1)}, {"velocity", {0, 0, 0}}}})}});
     },
     "bodies[1].shape.children[0].velocity: ", "unknown field"},
    {"compound child zero quaternion",
     [](json& s) {
       s["bodies"].push_back(
           {{"name", "c"},
            {"shape", compound({{{"shape", box(0.1)}, {"orientation", {0, 0, 0, 0}}}})}});
     },
     "bodies[1].shape.children[0].orientation: ", "non-zero quaternion"},
    {"compound child bad radius",
     [](json& s) {
       s["bodies"].push_back(
           {{"name", "c"},
            {"shape", compound({{{"shape", box(0.1)}},
                                {{"shape", {{"type", "sphere"}, {"radius", -1}}}}})}});
     },
     "bodies[1].shape.children[1].shape.radius: ", "> 0"},
    {"mesh file that is not a mesh",
     [](json& s) {
       s["bodies"][0]["shape"] = {{"type", "mesh"}, {"file", kScenes + "small_dambreak.json"}};
     },
     "bodies[0].shape.file: ", "small_dambreak.json"},
    {"bodies not a list",
     [](json& s) {
       s["bodies"] = {{"name", "x"}};
     },
     "bodies: ", "must be an array"},
    {"fluid not an object", [](json& s) { s["fluid"] = 3; }, "fluid: ", "must be an object"},
    {"density limit at one",
     [](json& s) {
       s["health"] = {{"max_density_ratio", 1}};
     },
     "health.max_density_ratio: ", "> 1"},
    {"density limit not a number",
     [](json& s) {
       s["health"] = {{"max_density_ratio", "high"}};
     },
     "health.max_density_ratio: ", "number"},
    {"health unknown field",
     [](json& s) {
       s["health"] = {{"max_density", 4}};
     },
     "health.max_density: ", "unknown field"},
    {"scene name with a slash", [](json& s) { s["name"] = "../x"; }, "name: ", "'/'"},
};

INSTANTIATE_TEST_SUITE_P(Table, BadScene, ::testing::ValuesIn(kBadCases),
                         [](const ::testing::TestParamInfo<BadCase>& p) {
                           std::string name = p.param.what;
                           for (char& ch : name)
                             if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return name;
                         });

/// Cases that cannot be written as an edit of parsed JSON: raw text.
struct BadText {
  const char* text;
  const char* says;
};

TEST(SceneLoader, BadJsonTextIsRefusedWithItsPosition) {
  const BadText cases[] = {
      {"{\n  \"name\": \"t\",\n  \"time\": { \"end\": 1 }\n  \"fluid\": {}\n}", "line 4"},
      {"{ \"time\": { \"end\": 1, } }", "line 1"},
      {"", "invalid JSON"},
      {"{ \"fluid\": { \"particle_radius\": 0.01, \"particle_radius\": 0.02 } }",
       "fluid.particle_radius: duplicate field"},
      {"{ \"gravity\": [0, 1e999, 0] }", "invalid JSON: number overflow parsing '1e999'"},
      {"[1, 2, 3]", "must be an object"},
  };
  for (const BadText& c : cases) {
    try {
      parseScene(c.text, "scene.json");
      ADD_FAILURE() << c.text << ": accepted";
    } catch (const SceneError& e) {
      const std::string m = e.what();
      EXPECT_EQ(m.rfind("scene.json: ", 0), 0u) << m;
      EXPECT_NE(m.find(c.says), std::string::npos) << c.text << " -> " << m;
      EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
  }
}

TEST(SceneLoader, ExampleMessageFormat) {
  json s = validScene();
  s["fluid"]["blocks"][0] = {{"min", {0.2, 0.2, 0.2}}, {"max", {0.1, 0.2, 0.3}}};
  try {
    parseScene(s.dump(), "scene.json");
    FAIL();
  } catch (const SceneError& e) {
    EXPECT_EQ(std::string(e.what()),
              "scene.json: fluid.blocks[0].max: must be greater than min on every axis "
              "(got [0.1, 0.2, 0.3], min [0.2, 0.2, 0.2])");
  }
}

}  // namespace
}  // namespace wake
