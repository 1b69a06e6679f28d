// Scene loader: the shipped test scenes load with the right values and defaults, and every
// kind of bad input is refused with one line naming the file and the field.
#include "io/scene.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cctype>
#include <cmath>
#include <functional>
#include <string>

namespace wake {
namespace {

using json = nlohmann::json;

const std::string kScenes = std::string(WAKE_TEST_DATA_DIR) + "/scenes/";

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
  EXPECT_DOUBLE_EQ(s.sim.fluid.smoothing_ratio, 1.0);
  ASSERT_EQ(s.sim.blocks.size(), 1u);
  EXPECT_EQ(s.sim.blocks[0].min, Vec3(0, 0, 0));
  EXPECT_EQ(s.sim.blocks[0].max, Vec3(0.1, 0.2, 0.1));
  EXPECT_EQ(s.sim.method, CouplingMethod::Local);
  EXPECT_TRUE(s.sim.domain.empty());
  ASSERT_EQ(s.sim.bodies.size(), 1u);
  const BodySettings& tank = s.sim.bodies[0];
  EXPECT_EQ(tank.name, "tank");
  EXPECT_EQ(tank.kind, BodyKind::Static);
  ASSERT_TRUE(tank.shape);
  EXPECT_STREQ(tank.shape->typeName(), "tank");
  EXPECT_EQ(tank.slip, 0.0);
  EXPECT_EQ(tank.restitution, 0.0);
  // 5 x 10 x 5 particles at spacing 0.02 m.
  EXPECT_DOUBLE_EQ(estimateFluidParticles(s.sim), 250.0);
  EXPECT_EQ(frameCount(s), 5u);
  EXPECT_DOUBLE_EQ(frameTime(s, 0), 0.0);
  EXPECT_DOUBLE_EQ(frameTime(s, 2), 0.02);
  EXPECT_EQ(frameTime(s, 5), 0.05);
}

TEST(SceneLoader, AllStaticShapesAndDefaults) {
  const SceneFile s = loadScene(kScenes + "all_static_shapes.json");
  EXPECT_EQ(s.name, "all_static_shapes");  // default: the file's stem
  EXPECT_DOUBLE_EQ(s.frame_rate, 30.0);
  EXPECT_EQ(s.sim.gravity, Vec3(0, -9.81, 0));
  EXPECT_DOUBLE_EQ(s.sim.fluid.speed_of_sound, 20.0);
  EXPECT_DOUBLE_EQ(s.sim.fluid.smoothing_ratio, 1.2);
  EXPECT_EQ(s.sim.method, CouplingMethod::Global);
  EXPECT_EQ(s.sim.domain.min, Vec3(-0.1, -0.1, -0.1));
  EXPECT_EQ(s.sim.domain.max, Vec3(0.6, 0.6, 0.3));
  ASSERT_EQ(s.sim.bodies.size(), 5u);
  const char* types[] = {"tank", "box", "sphere", "plane", "mesh"};
  for (std::size_t i = 0; i < 5; ++i) {
    ASSERT_TRUE(s.sim.bodies[i].shape) << i;
    EXPECT_STREQ(s.sim.bodies[i].shape->typeName(), types[i]);
  }
  EXPECT_EQ(s.sim.bodies[0].slip, 1.0);
  EXPECT_EQ(s.sim.bodies[0].restitution, 0.5);
  const Quat q = s.sim.bodies[1].pose.orientation;  // [0, 0, 1, 1] normalised
  EXPECT_NEAR(q.norm(), 1.0, 1e-15);
  EXPECT_NEAR(q.z(), std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(q.w(), std::sqrt(0.5), 1e-15);
  EXPECT_EQ(s.sim.bodies[1].pose.position, Vec3(0.35, 0.05, 0.1));
  // The plane's normal is normalised by makePlane: y = -0.05 lies on the surface.
  EXPECT_NEAR(s.sim.bodies[3].shape->signedDistance(Vec3(0, -0.05, 0)), 0.0, 1e-12);
  // The mesh (a cube of half size 0.02 m) is found relative to the scene file.
  EXPECT_TRUE(s.sim.bodies[4].shape->contains(Vec3(0.019, 0, 0)));
  EXPECT_FALSE(s.sim.bodies[4].shape->contains(Vec3(0.021, 0, 0)));
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
    {"no blocks", [](json& s) { s["fluid"]["blocks"] = json::array(); },
     "fluid.blocks: ", "at least one"},
    {"block below the lattice spacing",
     [](json& s) {
       s["fluid"]["blocks"][0]["max"] = {0.005, 0.1, 0.1};
     },
     "fluid.blocks[0]: ", "no particles"},
    {"more particles than memory", [](json& s) { s["fluid"]["particle_radius"] = 1e-5; },
     "fluid.particle_radius: ", "fluid particles"},
    {"penalty", [](json& s) { s["coupling"]["method"] = "penalty"; },
     "coupling.method: ", "not available yet"},
    {"unknown method", [](json& s) { s["coupling"]["method"] = "magic"; },
     "coupling.method: ", "\"magic\""},
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
       s["bodies"][0]["shape"] = {{"type", "cone"}};
     },
     "bodies[0].shape.type: ", "\"cone\""},
    {"capsule not yet",
     [](json& s) {
       s["bodies"][0]["shape"] = {{"type", "capsule"}, {"radius", 1}};
     },
     "bodies[0].shape.type: ", "not available yet"},
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
    {"dynamic body", [](json& s) { s["bodies"][0]["kind"] = "dynamic"; },
     "bodies[0].kind: ", "need the Bullet bridge"},
    {"zero quaternion",
     [](json& s) {
       s["bodies"][0]["orientation"] = {0, 0, 0, 0};
     },
     "bodies[0].orientation: ", "non-zero quaternion"},
    {"negative mass", [](json& s) { s["bodies"][0]["mass"] = -2; }, "bodies[0].mass: ", "> 0"},
    {"density and mass",
     [](json& s) {
       s["bodies"][0]["mass"] = 2;
       s["bodies"][0]["density"] = 500;
     },
     "bodies[0].mass: ", "not both"},
    {"bodies not a list",
     [](json& s) {
       s["bodies"] = {{"name", "x"}};
     },
     "bodies: ", "must be an array"},
    {"fluid not an object", [](json& s) { s["fluid"] = 3; }, "fluid: ", "must be an object"},
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
