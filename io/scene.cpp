// Scene loader: JSON -> SimulationSettings, validated field by field (see scene.hpp and
// io/SCENE_FORMAT.md for the format).
#include "io/scene.hpp"

#include <unistd.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <iomanip>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <utility>
#include <vector>

namespace wake {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Rough memory per fluid particle (bytes): state, scratch copies, neighbour lists.
constexpr double kBytesPerParticle = 600.0;
/// Particle ids are uint32 and indices int: stay below 2^31.
constexpr double kMaxParticles = 2147483648.0;

std::string formatNumber(double x) {
  std::ostringstream os;
  os << std::setprecision(12) << x;
  return os.str();
}

std::string formatVec3(const Vec3& v) {
  return "[" + formatNumber(v.x()) + ", " + formatNumber(v.y()) + ", " + formatNumber(v.z()) + "]";
}

/// A JSON value as it appears in the file, shortened for an error message.
std::string formatJson(const json& j) {
  std::string s = j.dump();
  if (s.size() > 60) s = s.substr(0, 57) + "...";
  return s;
}

/// Interval of accepted values of a number; every number must also be finite.
struct Range {
  double lo = -kInf, hi = kInf;
  bool lo_open = false, hi_open = false;

  bool contains(double x) const {
    return (lo_open ? x > lo : x >= lo) && (hi_open ? x < hi : x <= hi);
  }
  /// "> 0", ">= 0", "in (0, 1]", or "" for any finite number.
  std::string describe() const {
    if (lo == -kInf && hi == kInf) return "";
    if (hi == kInf) return (lo_open ? "> " : ">= ") + formatNumber(lo);
    if (lo == -kInf) return (hi_open ? "< " : "<= ") + formatNumber(hi);
    return std::string("in ") + (lo_open ? "(" : "[") + formatNumber(lo) + ", " + formatNumber(hi) +
           (hi_open ? ")" : "]");
  }
};

const Range kAnyNumber{};
const Range kPositive{0.0, kInf, true, false};
const Range kNonNegative{0.0, kInf, false, false};
const Range kUnitInterval{0.0, 1.0, false, false};

/// Where a value sits: the file and the field path inside it ("fluid.blocks[0].max").
struct Where {
  const std::string* file;
  std::string path;

  [[noreturn]] void fail(const std::string& message) const {
    throw SceneError(*file + ": " + (path.empty() ? "" : path + ": ") + message);
  }
  Where key(const std::string& k) const { return {file, path.empty() ? k : path + "." + k}; }
  Where index(std::size_t i) const { return {file, path + "[" + std::to_string(i) + "]"}; }
};

double toNumber(const Where& at, const json& j, const Range& range) {
  if (!j.is_number()) at.fail("must be a number (got " + formatJson(j) + ")");
  const double x = j.get<double>();
  if (!std::isfinite(x)) at.fail("must be finite (got " + formatJson(j) + ")");
  if (!range.contains(x)) at.fail("must be " + range.describe() + " (got " + formatNumber(x) + ")");
  return x;
}

/// Reads a fixed-size array of numbers, each checked against `range`.
std::vector<double> toNumbers(const Where& at, const json& j, std::size_t count,
                              const Range& range) {
  if (!j.is_array() || j.size() != count)
    at.fail("must be an array of " + std::to_string(count) + " numbers (got " + formatJson(j) +
            ")");
  std::vector<double> out;
  for (std::size_t i = 0; i < count; ++i)
    out.push_back(toNumber(at.index(i), j[i], range));
  return out;
}

Vec3 toVec3(const Where& at, const json& j, const Range& range) {
  const std::vector<double> v = toNumbers(at, j, 3, range);
  return Vec3(v[0], v[1], v[2]);
}

std::string toString(const Where& at, const json& j) {
  if (!j.is_string()) at.fail("must be a string (got " + formatJson(j) + ")");
  return j.get<std::string>();
}

std::string joinQuoted(std::initializer_list<const char*> words) {
  std::string out;
  for (const char* w : words)
    out += (out.empty() ? "\"" : ", \"") + std::string(w) + "\"";
  return out;
}

/// A JSON object being read. Knows its location for error messages and refuses fields
/// it does not know, so that a misspelt field is an error rather than silently ignored.
class ObjectReader {
 public:
  ObjectReader(Where at, const json& j) : at_(std::move(at)), j_(j) {
    if (!j_.is_object()) at_.fail("must be an object {...} (got " + formatJson(j_) + ")");
  }

  const Where& where() const { return at_; }
  Where at(const char* key) const { return at_.key(key); }

  /// Fails on the first field not in `known` (e.g. "unknown field fluid.partcle_radius").
  void allowOnly(std::initializer_list<const char*> known) const {
    for (const auto& item : j_.items()) {
      const bool ok =
          std::any_of(known.begin(), known.end(), [&](const char* k) { return item.key() == k; });
      if (!ok)
        at_.key(item.key()).fail("unknown field (known fields here: " + joinQuoted(known) + ")");
    }
  }

  const json* find(const char* key) const {
    const auto it = j_.find(key);
    return it == j_.end() ? nullptr : &*it;
  }
  const json& require(const char* key) const {
    const json* j = find(key);
    if (!j) at(key).fail("missing (this field is required)");
    return *j;
  }

  double number(const char* key, const Range& range) const {
    return toNumber(at(key), require(key), range);
  }
  double number(const char* key, double fallback, const Range& range) const {
    const json* j = find(key);
    return j ? toNumber(at(key), *j, range) : fallback;
  }
  Vec3 vec3(const char* key, const Range& range = kAnyNumber) const {
    return toVec3(at(key), require(key), range);
  }
  Vec3 vec3(const char* key, const Vec3& fallback, const Range& range = kAnyNumber) const {
    const json* j = find(key);
    return j ? toVec3(at(key), *j, range) : fallback;
  }
  std::string string(const char* key) const { return toString(at(key), require(key)); }

  /// A string that must be one of `choices`; `fallback` when the field is absent.
  std::string choice(const char* key, const char* fallback,
                     std::initializer_list<const char*> choices) const {
    const json* j = find(key);
    if (!j) return fallback;
    const std::string s = toString(at(key), *j);
    for (const char* c : choices)
      if (s == c) return s;
    at(key).fail("unknown value \"" + s + "\" (expected one of " + joinQuoted(choices) + ")");
  }

  ObjectReader object(const char* key) const { return ObjectReader(at(key), require(key)); }
  std::optional<ObjectReader> optionalObject(const char* key) const {
    const json* j = find(key);
    if (!j) return std::nullopt;
    return ObjectReader(at(key), *j);
  }

  /// Reads `min_key` and `max_key` as a box; max must exceed min on every axis.
  Aabb box(const char* min_key, const char* max_key) const {
    Aabb b;
    b.min = vec3(min_key);
    b.max = vec3(max_key);
    if (!(b.max.array() > b.min.array()).all())
      at(max_key).fail("must be greater than " + std::string(min_key) + " on every axis (got " +
                       formatVec3(b.max) + ", " + min_key + " " + formatVec3(b.min) + ")");
    return b;
  }

 private:
  Where at_;
  const json& j_;
};

/// A JSON value that must be an array.
const json& requireArray(const Where& at, const json& j) {
  if (!j.is_array()) at.fail("must be an array [...] (got " + formatJson(j) + ")");
  return j;
}

/// Parses JSON, rejecting duplicate keys (nlohmann would keep the last one silently).
json parseJson(const std::string& text, const std::string& file) {
  // One frame per open object/array: the keys seen (objects) or the element index (arrays).
  struct Frame {
    bool is_array = false;
    long index = -1;
    std::string key;
    std::set<std::string> keys;
  };
  std::vector<Frame> stack;
  auto path = [&stack] {
    std::string p;
    for (const Frame& f : stack) {
      if (f.is_array && f.index >= 0) p += "[" + std::to_string(f.index) + "]";
      if (!f.is_array && !f.key.empty()) p += (p.empty() ? "" : ".") + f.key;
    }
    return p;
  };
  auto callback = [&](int /*depth*/, json::parse_event_t event, json& parsed) {
    using E = json::parse_event_t;
    const bool starts_value =
        event == E::object_start || event == E::array_start || event == E::value;
    if (starts_value && !stack.empty() && stack.back().is_array) ++stack.back().index;
    if (event == E::object_start || event == E::array_start) {
      stack.push_back(Frame{event == E::array_start, -1, {}, {}});
    } else if (event == E::object_end || event == E::array_end) {
      stack.pop_back();
    } else if (event == E::key) {
      Frame& f = stack.back();
      f.key = parsed.get<std::string>();
      if (!f.keys.insert(f.key).second)
        Where{&file, path()}.fail("duplicate field (given twice in the same object)");
    }
    return true;
  };
  try {
    return json::parse(text, callback);
  } catch (const json::exception& e) {
    // e.what(): "[json.exception.parse_error.101] parse error at line 3, column 5: ..."
    // or "[json.exception.out_of_range.406] number overflow parsing '1e999'"
    std::string message = e.what();
    const auto bracket = message.find("] ");
    if (bracket != std::string::npos) message = message.substr(bracket + 2);
    throw SceneError(file + ": invalid JSON: " + message);
  }
}

/// Estimated particle count of one block on a lattice of `spacing` (m): the product over
/// the axes of round(extent / spacing). A double, so that absurd scenes do not overflow.
double blockParticles(const FluidBlock& b, double spacing) {
  double count = 1.0;
  for (int axis = 0; axis < 3; ++axis)
    count *= std::round((b.max[axis] - b.min[axis]) / spacing);
  return count;
}

/// A name that becomes a file name or an HDF5 group name.
void checkName(const Where& at, const std::string& name) {
  if (name.empty()) at.fail("must not be empty");
  if (name == "." || name == "..") at.fail("\"" + name + "\" is not a usable name");
  for (const char c : name)
    if (c == '/' || c == '\\' || static_cast<unsigned char>(c) < 0x20)
      at.fail("must not contain '/', '\\' or control characters (got \"" + name + "\")");
}

void readTime(const ObjectReader& time, SceneFile& scene) {
  time.allowOnly({"end", "frame_rate", "cfl", "max_dt"});
  scene.end_time = time.number("end", kPositive);
  scene.frame_rate = time.number("frame_rate", 30.0, kPositive);
  scene.sim.cfl = time.number("cfl", 0.4, Range{0.0, 1.0, true, false});
  scene.sim.max_dt = time.number("max_dt", 1e-3, kPositive);
}

void readFluid(const ObjectReader& fluid, SimulationSettings& sim) {
  fluid.allowOnly({"particle_radius", "rest_density", "speed_of_sound", "viscosity",
                   "smoothing_ratio", "blocks"});
  FluidParams& p = sim.fluid;
  p.particle_radius = fluid.number("particle_radius", kPositive);
  p.rest_density = fluid.number("rest_density", 1000.0, kPositive);
  p.speed_of_sound = 0.0;  // "auto": resolved by the simulation
  if (const json* c = fluid.find("speed_of_sound"); c && !(c->is_string() && *c == "auto")) {
    if (c->is_string())
      fluid.at("speed_of_sound")
          .fail("must be a number > 0 or \"auto\" (got " + formatJson(*c) + ")");
    p.speed_of_sound = toNumber(fluid.at("speed_of_sound"), *c, kPositive);
  }
  p.viscosity = fluid.number("viscosity", 0.1, kNonNegative);
  p.smoothing_ratio = fluid.number("smoothing_ratio", 1.0, Range{0.8, 2.0, false, false});

  const Where blocks_at = fluid.at("blocks");
  const json& blocks = requireArray(blocks_at, fluid.require("blocks"));
  if (blocks.empty()) blocks_at.fail("must list at least one block of fluid");
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    const ObjectReader block(blocks_at.index(i), blocks[i]);
    block.allowOnly({"min", "max", "velocity"});
    const Aabb box = block.box("min", "max");
    FluidBlock b;
    b.min = box.min;
    b.max = box.max;
    b.velocity = block.vec3("velocity", Vec3::Zero());
    sim.blocks.push_back(b);
    if (blockParticles(b, p.spacing()) < 1.0)
      block.where().fail("holds no particles: it is smaller than the lattice spacing " +
                         formatNumber(p.spacing()) + " m (2 * particle_radius) on some axis");
  }
}

/// Refuses a fluid that cannot fit in memory, before anything allocates.
void checkParticleCount(const Where& radius_at, const SimulationSettings& sim) {
  const double count = estimateFluidParticles(sim);
  const double pages = static_cast<double>(sysconf(_SC_PHYS_PAGES));
  const double page_size = static_cast<double>(sysconf(_SC_PAGESIZE));
  const double memory = pages > 0 && page_size > 0 ? pages * page_size : kInf;
  const std::string what = formatNumber(sim.fluid.particle_radius) + " m gives about " +
                           formatNumber(std::round(count)) + " fluid particles, ";
  if (count > kMaxParticles)
    radius_at.fail(what +
                   "more than the limit of 2^31; use a larger particle_radius or "
                   "smaller blocks");
  if (count * kBytesPerParticle > memory)
    radius_at.fail(what + "needing about " +
                   formatNumber(std::round(count * kBytesPerParticle / 1e9)) +
                   " GB, more than the " + formatNumber(std::round(memory / 1e9)) +
                   " GB of this machine; use a larger "
                   "particle_radius or smaller blocks");
}

void readCoupling(const ObjectReader& coupling, SimulationSettings& sim) {
  coupling.allowOnly({"method"});
  const std::string method = coupling.choice("method", "local", {"local", "global", "penalty"});
  if (method == "penalty")
    coupling.at("method").fail("\"penalty\" is not available yet (use \"local\" or \"global\")");
  sim.method = method == "global" ? CouplingMethod::Global : CouplingMethod::Local;
}

/// Reads a shape object; `particle_radius` gives the tank's default wall thickness and
/// `folder` is the base of relative mesh paths.
std::shared_ptr<const Shape> readShape(const ObjectReader& shape, double particle_radius,
                                       const fs::path& folder) {
  // Shapes of the format that this version cannot build yet get their own message.
  if (const json& t = shape.require("type"); t == "capsule" || t == "cylinder" || t == "compound")
    shape.at("type").fail("shape type " + t.dump() +
                          " is not available yet (available: box, sphere, plane, tank, mesh)");
  const std::string type = shape.choice("type", "", {"box", "sphere", "plane", "tank", "mesh"});
  // Any exception from a shape constructor names the shape object.
  auto build = [&](auto make) -> std::shared_ptr<const Shape> {
    try {
      return make();
    } catch (const std::exception& e) {
      shape.where().fail(e.what());
    }
  };
  if (type == "box") {
    shape.allowOnly({"type", "half_extents"});
    const Vec3 half = shape.vec3("half_extents", kPositive);
    return build([&] { return makeBox(half); });
  }
  if (type == "sphere") {
    shape.allowOnly({"type", "radius"});
    const double radius = shape.number("radius", kPositive);
    return build([&] { return makeSphere(radius); });
  }
  if (type == "plane") {
    shape.allowOnly({"type", "normal", "offset"});
    const Vec3 normal = shape.vec3("normal");
    if (normal.norm() < 1e-12) shape.at("normal").fail("must be a non-zero vector (got [0, 0, 0])");
    const double offset = shape.number("offset", 0.0, kAnyNumber);
    return build([&] { return makePlane(normal, offset); });
  }
  if (type == "tank") {
    shape.allowOnly({"type", "min", "max", "wall_thickness"});
    const Aabb cavity = shape.box("min", "max");
    // Default: two lattice spacings (spacing = 2 * particle_radius).
    const double wall = shape.number("wall_thickness", 4.0 * particle_radius, kPositive);
    return build([&] { return makeTank(cavity.min, cavity.max, wall); });
  }
  if (type == "mesh") {
    shape.allowOnly({"type", "file", "scale"});
    const Where file_at = shape.at("file");
    const std::string name = shape.string("file");
    if (name.empty()) file_at.fail("must name an OBJ file");
    const fs::path file = fs::path(name).is_absolute() ? fs::path(name) : folder / name;
    Vec3 scale = Vec3::Ones();
    if (const json* s = shape.find("scale"))
      scale = s->is_array() ? toVec3(shape.at("scale"), *s, kPositive)
                            : Vec3::Constant(toNumber(shape.at("scale"), *s, kPositive));
    std::error_code ec;
    if (!fs::is_regular_file(file, ec))
      file_at.fail("mesh file not found: " + file.string() +
                   " (relative paths are relative to the scene file's folder)");
    try {
      return makeMesh(file.string(), scale);
    } catch (const std::exception& e) {
      file_at.fail(e.what());
    }
  }
  shape.at("type").fail("must be given");  // unreachable: choice() checked the type
}

BodySettings readBody(const ObjectReader& body, double particle_radius, const fs::path& folder) {
  body.allowOnly({"name", "kind", "slip", "restitution", "position", "orientation", "shape",
                  "density", "mass", "coupling", "linear_velocity", "angular_velocity",
                  "friction"});
  BodySettings b;
  b.name = body.string("name");
  checkName(body.at("name"), b.name);
  const std::string kind = body.choice("kind", "static", {"static", "kinematic", "dynamic"});
  if (kind != "static")
    body.at("kind").fail(kind + " bodies need the Bullet bridge, not available in this version " +
                         "(use \"static\")");
  b.kind = BodyKind::Static;
  b.slip = body.number("slip", 0.0, kUnitInterval);
  b.restitution = body.number("restitution", 0.0, kUnitInterval);
  b.pose.position = body.vec3("position", Vec3::Zero());
  if (const json* q = body.find("orientation")) {
    const std::vector<double> xyzw = toNumbers(body.at("orientation"), *q, 4, kAnyNumber);
    const Quat orientation(xyzw[3], xyzw[0], xyzw[1], xyzw[2]);  // Eigen: (w, x, y, z)
    if (orientation.norm() < 1e-12)
      body.at("orientation").fail("must be a non-zero quaternion [x, y, z, w] (got [0, 0, 0, 0])");
    b.pose.orientation = orientation.normalized();
  }
  // Used from the Bullet version on (dynamic bodies); validated now so scenes stay valid.
  if (body.find("density") && body.find("mass"))
    body.at("mass").fail("give either density or mass, not both");
  body.number("density", 1.0, kPositive);
  body.number("mass", 1.0, kPositive);
  body.number("friction", 0.0, kNonNegative);
  body.choice("coupling", "two_way", {"two_way", "one_way"});
  body.vec3("linear_velocity", Vec3::Zero());
  body.vec3("angular_velocity", Vec3::Zero());

  b.shape = readShape(body.object("shape"), particle_radius, folder);
  return b;
}

void readBodies(const Where& at, const json& list, double particle_radius, const fs::path& folder,
                SimulationSettings& sim) {
  requireArray(at, list);
  std::map<std::string, std::size_t> index_of_name;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const ObjectReader body(at.index(i), list[i]);
    // Unique names first: they become HDF5 group names (/bodies/<name>).
    if (const json* name = body.find("name"); name && name->is_string()) {
      const auto [it, fresh] = index_of_name.emplace(name->get<std::string>(), i);
      if (!fresh)
        body.at("name").fail("duplicate body name \"" + it->first + "\" (also bodies[" +
                             std::to_string(it->second) + "])");
    }
    sim.bodies.push_back(readBody(body, particle_radius, folder));
  }
}

}  // namespace

double estimateFluidParticles(const SimulationSettings& sim) {
  double total = 0.0;
  for (const FluidBlock& b : sim.blocks)
    total += blockParticles(b, sim.fluid.spacing());
  return total;
}

SceneFile parseScene(const std::string& json_text, const std::string& path) {
  const json root_json = parseJson(json_text, path);
  const ObjectReader root(Where{&path, ""}, root_json);
  root.allowOnly(
      {"name", "description", "gravity", "time", "fluid", "coupling", "domain", "bodies"});

  SceneFile scene;
  scene.path = path;
  scene.name = fs::path(path).stem().string();
  if (root.find("name")) scene.name = root.string("name");
  checkName(root.find("name") ? root.at("name") : root.where(), scene.name);
  if (root.find("description")) root.string("description");

  scene.sim.gravity = root.vec3("gravity", Vec3(0.0, -9.81, 0.0));
  readTime(root.object("time"), scene);
  readFluid(root.object("fluid"), scene.sim);
  checkParticleCount(root.at("fluid").key("particle_radius"), scene.sim);
  if (const auto coupling = root.optionalObject("coupling")) readCoupling(*coupling, scene.sim);
  if (const auto domain = root.optionalObject("domain")) {
    domain->allowOnly({"min", "max"});
    scene.sim.domain = domain->box("min", "max");
  }
  if (const json* bodies = root.find("bodies"))
    readBodies(root.at("bodies"), *bodies, scene.sim.fluid.particle_radius,
               fs::path(path).parent_path(), scene.sim);
  return scene;
}

SceneFile loadScene(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw SceneError(path + ": scene file not found");
  if (fs::is_directory(path, ec)) throw SceneError(path + ": is a directory, not a scene file");
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  if (!in && !in.eof()) throw SceneError(path + ": cannot read the scene file");
  return parseScene(text.str(), path);
}

void overrideEndTime(SceneFile& scene, double end_time, const std::string& option) {
  if (!std::isfinite(end_time) || !kPositive.contains(end_time))
    throw SceneError(option + ": must be a finite number > 0 (got " + formatNumber(end_time) + ")");
  scene.end_time = end_time;
}

std::size_t frameCount(const SceneFile& scene) {
  // A frame within 1e-9 of a frame interval of the end is the end frame itself.
  const double intervals = scene.end_time * scene.frame_rate;
  return static_cast<std::size_t>(std::max(1.0, std::ceil(intervals - 1e-9)));
}

double frameTime(const SceneFile& scene, std::size_t k) {
  if (k >= frameCount(scene)) return scene.end_time;
  return std::min(static_cast<double>(k) / scene.frame_rate, scene.end_time);
}

}  // namespace wake
