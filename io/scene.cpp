// Scene loader: JSON -> SimulationSettings and BodySpecs, validated field by field (see
// scene.hpp and io/SCENE_FORMAT.md for the format).
#include "io/scene.hpp"

#include "geometry/shape.hpp"

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
/// m^2/s: from inviscid to a thick syrup; the explicit step shrinks as 0.125 H^2 / nu.
const Range kViscosityRange{0.0, 1.0, false, false};
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

// Defaults of the scene's fields are the settings structs' own (one set of defaults).
const SimulationSettings kDefaults{};

void readTime(const ObjectReader& time, SceneFile& scene) {
  time.allowOnly({"end", "frame_rate", "cfl", "max_dt"});
  scene.end_time = time.number("end", kPositive);
  scene.frame_rate = time.number("frame_rate", 30.0, kPositive);
  scene.sim.cfl = time.number("cfl", kDefaults.cfl, Range{0.0, 1.0, true, false});
  scene.sim.max_dt = time.number("max_dt", kDefaults.max_dt, kPositive);
}

void readHealth(const ObjectReader& health, SimulationSettings& sim) {
  health.allowOnly({"max_density_ratio"});
  sim.health.max_density_ratio = health.number(
      "max_density_ratio", kDefaults.health.max_density_ratio, Range{1.0, kInf, true, false});
}

/// A whole number in `range` (an iteration count).
int wholeNumber(const ObjectReader& object, const char* key, int fallback, const Range& range) {
  const double v = object.number(key, fallback, range);
  if (v != std::floor(v))
    object.at(key).fail("must be a whole number (got " + formatNumber(v) + ")");
  return static_cast<int>(v);
}

void readSolver(const ObjectReader& fluid, SimulationSettings& sim) {
  const std::string solver = fluid.choice("solver", "wcsph", {"wcsph", "dfsph"});
  sim.solver = solver == "dfsph" ? FluidSolver::Dfsph : FluidSolver::Wcsph;
  if (fluid.find("pressure_gradient") && sim.solver != FluidSolver::Wcsph)
    fluid.at("pressure_gradient")
        .fail(
            "is only used with \"solver\": \"wcsph\" (the divergence-free solver makes its "
            "own pressure force; see fluid.dfsph.gradient_correction)");
  sim.fluid.pressure_gradient =
      fluid.choice("pressure_gradient", "consistent", {"consistent", "symmetric"}) == "symmetric"
          ? PressureGradient::Symmetric
          : PressureGradient::Consistent;
  const std::optional<ObjectReader> dfsph = fluid.optionalObject("dfsph");
  if (!dfsph) return;
  if (sim.solver != FluidSolver::Dfsph)
    dfsph->where().fail("is only used with \"solver\": \"dfsph\" (solver is \"" + solver + "\")");
  dfsph->allowOnly({"max_density_error", "max_divergence_error", "max_iterations",
                    "max_divergence_iterations", "gradient_correction", "pressure_force"});
  DfsphParams& d = sim.dfsph;
  const DfsphParams defaults = kDefaults.dfsph;
  d.max_density_error =
      dfsph->number("max_density_error", defaults.max_density_error, Range{0.0, 0.1, true, false});
  d.max_divergence_error = dfsph->number("max_divergence_error", defaults.max_divergence_error,
                                         Range{0.0, 1.0, true, false});
  d.max_iterations =
      wholeNumber(*dfsph, "max_iterations", defaults.max_iterations, Range{2.0, 1e6, false, false});
  d.max_divergence_iterations =
      wholeNumber(*dfsph, "max_divergence_iterations", defaults.max_divergence_iterations,
                  Range{0.0, 1e6, false, false});
  d.correct_gradient =
      dfsph->choice("gradient_correction", defaults.correct_gradient ? "bulk" : "none",
                    {"bulk", "none"}) == "bulk";
  d.pressure_force =
      dfsph->choice("pressure_force",
                    defaults.pressure_force == DfsphParams::PressureForce::Consistent ? "consistent"
                                                                                      : "symmetric",
                    {"symmetric", "consistent"}) == "consistent"
          ? DfsphParams::PressureForce::Consistent
          : DfsphParams::PressureForce::Symmetric;
}

void readFluid(const ObjectReader& fluid, SimulationSettings& sim) {
  fluid.allowOnly({"particle_radius", "rest_density", "speed_of_sound", "viscosity",
                   "kinematic_viscosity", "smoothing_ratio", "solver", "pressure_gradient", "dfsph",
                   "blocks"});
  FluidParams& p = sim.fluid;
  p.particle_radius = fluid.number("particle_radius", kPositive);
  const FluidParams defaults = kDefaults.fluid;
  p.rest_density = fluid.number("rest_density", defaults.rest_density, kPositive);
  p.speed_of_sound = 0.0;  // "auto": resolved by the simulation
  if (const json* c = fluid.find("speed_of_sound"); c && !(c->is_string() && *c == "auto")) {
    if (c->is_string())
      fluid.at("speed_of_sound")
          .fail("must be a number > 0 or \"auto\" (got " + formatJson(*c) + ")");
    p.speed_of_sound = toNumber(fluid.at("speed_of_sound"), *c, kPositive);
  }
  p.viscosity = fluid.number("viscosity", defaults.viscosity, kNonNegative);
  p.kinematic_viscosity =
      fluid.number("kinematic_viscosity", defaults.kinematic_viscosity, kViscosityRange);
  p.smoothing_ratio =
      fluid.number("smoothing_ratio", defaults.smoothing_ratio, Range{0.8, 2.0, false, false});
  readSolver(fluid, sim);

  const Where blocks_at = fluid.at("blocks");
  const json& blocks = requireArray(blocks_at, fluid.require("blocks"));
  if (blocks.empty()) blocks_at.fail("must list at least one block of fluid");
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    const ObjectReader block(blocks_at.index(i), blocks[i]);
    block.allowOnly({"min", "max", "velocity", "kinematic_viscosity"});
    const Aabb box = block.box("min", "max");
    FluidBlock b;
    b.min = box.min;
    b.max = box.max;
    b.velocity = block.vec3("velocity", Vec3::Zero());
    b.kinematic_viscosity =
        block.number("kinematic_viscosity", p.kinematic_viscosity, kViscosityRange);
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
  coupling.allowOnly({"method", "penalty_strength"});
  const std::string method = coupling.choice("method", "local", {"local", "global", "penalty"});
  sim.method = method == "global"    ? CouplingMethod::Global
               : method == "penalty" ? CouplingMethod::Penalty
                                     : CouplingMethod::Local;
  if (coupling.find("penalty_strength")) {
    if (sim.method != CouplingMethod::Penalty)
      coupling.at("penalty_strength")
          .fail("is only used with \"method\": \"penalty\" (method is \"" + method + "\")");
    sim.penalty_strength = coupling.number("penalty_strength", 0.0, kPositive);
  }
}

/// Unit quaternion from "[x, y, z, w]": any finite, non-zero quaternion, normalised.
Quat toOrientation(const Where& at, const json& j) {
  const std::vector<double> xyzw = toNumbers(at, j, 4, kAnyNumber);
  double largest = 0.0;
  for (const double c : xyzw)
    largest = std::max(largest, std::abs(c));
  if (largest == 0.0) at.fail("must be a non-zero quaternion [x, y, z, w] (got [0, 0, 0, 0])");
  // Scaled first so that neither huge nor tiny components overflow the norm.
  const Quat q(xyzw[3] / largest, xyzw[0] / largest, xyzw[1] / largest, xyzw[2] / largest);
  return q.normalized();  // Eigen's constructor order is (w, x, y, z)
}

/// Reads an optional "position" and "orientation" pair into a pose.
Pose readPose(const ObjectReader& object) {
  Pose pose;
  pose.position = object.vec3("position", Vec3::Zero());
  if (const json* q = object.find("orientation"))
    pose.orientation = toOrientation(object.at("orientation"), *q);
  return pose;
}

/// True when the points span a volume: they neither coincide nor lie on one line or one
/// plane (up to a relative 1e-9 of their extent). Picks a far point b from a = p[0], the
/// point c farthest from the line ab, then looks for a point off the plane abc.
bool spansVolume(const std::vector<Vec3>& p) {
  const Vec3& a = p[0];
  auto farthest = [&p](auto distance) {
    std::size_t best = 0;
    double best_distance = 0.0;
    for (std::size_t i = 0; i < p.size(); ++i)
      if (const double d = distance(p[i]); d > best_distance) {
        best = i;
        best_distance = d;
      }
    return std::make_pair(best, best_distance);
  };
  const auto [b, extent] = farthest([&](const Vec3& x) { return (x - a).norm(); });
  if (!(extent > 0.0)) return false;
  const double tolerance = 1e-9 * extent;
  const Vec3 u = (p[b] - a) / extent;
  const auto [c, off_line] =
      farthest([&](const Vec3& x) { return ((x - a) - u * u.dot(x - a)).norm(); });
  if (off_line <= tolerance) return false;
  const Vec3 n = u.cross(p[c] - a).normalized();
  const auto off_plane = farthest([&](const Vec3& x) { return std::abs(n.dot(x - a)); });
  return off_plane.second > tolerance;
}

/// Optional Bullet collision margin: >= 0 m, or -1 (automatic) when absent.
double readMargin(const ObjectReader& shape) {
  return shape.number("margin", -1.0, kNonNegative);
}

/// Reads a shape object. `kind` is the body's kind ("static", ...): planes and tanks are
/// for static bodies only. `child` marks a compound's child, which may not be a plane, a
/// tank or a compound. `folder` is the base of relative mesh paths.
ShapeSpec readShape(const ObjectReader& shape, const std::string& kind, bool child,
                    const fs::path& folder) {
  ShapeSpec s;
  shape.require("type");
  s.type = shape.choice("type", "",
                        {"box", "sphere", "capsule", "cylinder", "cone", "convex_hull", "plane",
                         "tank", "mesh", "compound"});
  const bool static_only = s.type == "plane" || s.type == "tank";
  if (child && (static_only || s.type == "compound"))
    shape.at("type").fail(
        "a compound's child cannot be a " + s.type +
        " (allowed: \"box\", \"sphere\", \"capsule\", \"cylinder\", \"cone\", \"convex_hull\", "
        "\"mesh\")");
  if (static_only && kind != "static")
    shape.at("type").fail("a " + s.type + " is only allowed on a static body (this body is " +
                          kind + ")");

  if (s.type == "box") {
    shape.allowOnly({"type", "half_extents", "margin"});
    s.half_extents = shape.vec3("half_extents", kPositive);
  } else if (s.type == "sphere") {
    shape.allowOnly({"type", "radius", "margin"});
    s.radius = shape.number("radius", kPositive);
  } else if (s.type == "capsule") {
    shape.allowOnly({"type", "radius", "height", "margin"});
    s.radius = shape.number("radius", kPositive);
    s.height = shape.number("height", kNonNegative);
  } else if (s.type == "cylinder" || s.type == "cone") {
    shape.allowOnly({"type", "radius", "height", "margin"});
    s.radius = shape.number("radius", kPositive);
    s.height = shape.number("height", kPositive);
  } else if (s.type == "convex_hull") {
    shape.allowOnly({"type", "points", "margin"});
    const Where points_at = shape.at("points");
    const json& points = requireArray(points_at, shape.require("points"));
    if (points.size() < 4)
      points_at.fail("a convex hull needs at least 4 points (got " + std::to_string(points.size()) +
                     ")");
    for (std::size_t i = 0; i < points.size(); ++i)
      s.points.push_back(toVec3(points_at.index(i), points[i], kAnyNumber));
    if (!spansVolume(s.points))
      points_at.fail("the points must span a volume (they all lie in one plane)");
  } else if (s.type == "plane") {
    shape.allowOnly({"type", "normal", "offset"});
    const Vec3 normal = shape.vec3("normal");
    if (normal.norm() < 1e-12) shape.at("normal").fail("must be a non-zero vector (got [0, 0, 0])");
    s.normal = normal.normalized();
    s.offset = shape.number("offset", 0.0, kAnyNumber);
  } else if (s.type == "tank") {
    shape.allowOnly({"type", "min", "max", "wall_thickness"});
    const Aabb cavity = shape.box("min", "max");
    s.min = cavity.min;
    s.max = cavity.max;
    s.wall_thickness = shape.number("wall_thickness", 0.0, kPositive);  // 0: automatic
  } else if (s.type == "mesh") {
    shape.allowOnly({"type", "file", "scale"});
    const Where file_at = shape.at("file");
    const std::string name = shape.string("file");
    if (name.empty()) file_at.fail("must name an OBJ file");
    if (const json* scale = shape.find("scale"))
      s.scale = scale->is_array() ? toVec3(shape.at("scale"), *scale, kPositive)
                                  : Vec3::Constant(toNumber(shape.at("scale"), *scale, kPositive));
    fs::path file = fs::path(name).is_absolute() ? fs::path(name) : folder / name;
    std::error_code ec;
    if (const fs::path absolute = fs::absolute(file, ec); !ec) file = absolute.lexically_normal();
    if (!fs::is_regular_file(file, ec))
      file_at.fail("mesh file not found: " + file.string() +
                   " (relative paths are relative to the scene file's folder)");
    s.file = file.string();
    try {
      makeMesh(s.file, s.scale);  // loads now, so that a broken file is bad input
    } catch (const std::exception& e) {
      file_at.fail(e.what());
    }
  } else if (s.type == "compound") {
    shape.allowOnly({"type", "children", "margin"});
    const Where children_at = shape.at("children");
    const json& children = requireArray(children_at, shape.require("children"));
    if (children.empty()) children_at.fail("must list at least one child {shape, position, ...}");
    for (std::size_t i = 0; i < children.size(); ++i) {
      const ObjectReader child_object(children_at.index(i), children[i]);
      child_object.allowOnly({"shape", "position", "orientation"});
      ShapeChild c;
      c.shape = readShape(child_object.object("shape"), kind, true, folder);
      c.pose = readPose(child_object);
      s.children.push_back(std::move(c));
    }
  }
  if (s.type != "plane" && s.type != "tank" && s.type != "mesh") s.margin = readMargin(shape);
  // A compound's margin is the default of its children that give none (meshes have none).
  for (ShapeChild& c : s.children)
    if (c.shape.margin < 0.0 && c.shape.type != "mesh") c.shape.margin = s.margin;
  return s;
}

BodySpec readBody(const ObjectReader& body, const fs::path& folder) {
  body.allowOnly({"name", "kind", "slip", "restitution", "position", "orientation", "shape",
                  "density", "mass", "coupling", "linear_velocity", "angular_velocity",
                  "friction"});
  BodySpec b;
  b.name = body.string("name");
  checkName(body.at("name"), b.name);
  const std::string kind = body.choice("kind", "static", {"static", "kinematic", "dynamic"});
  b.kind = kind == "dynamic"     ? BodyKind::Dynamic
           : kind == "kinematic" ? BodyKind::Kinematic
                                 : BodyKind::Static;
  const bool dynamic = b.kind == BodyKind::Dynamic;

  if (dynamic) {
    b.coupling = body.choice("coupling", "two_way", {"two_way", "one_way"}) == "one_way"
                     ? CouplingMode::OneWay
                     : CouplingMode::TwoWay;
    const bool has_density = body.find("density") != nullptr;
    const bool has_mass = body.find("mass") != nullptr;
    if (has_density && has_mass) body.at("mass").fail("give either density or mass, not both");
    if (!has_density && !has_mass)
      body.at("density").fail("missing: a dynamic body needs either density (kg/m^3) or mass (kg)");
    if (has_density) b.density = body.number("density", kPositive);
    if (has_mass) b.mass = body.number("mass", kPositive);
  } else {
    if (body.choice("coupling", "one_way", {"two_way", "one_way"}) == "two_way")
      body.at("coupling")
          .fail("static and kinematic bodies are always one-way (this body is " + kind +
                "); use \"one_way\", leave the field out, or make the body dynamic");
    b.coupling = CouplingMode::OneWay;
    for (const char* key : {"density", "mass"})
      if (body.find(key))
        body.at(key).fail(std::string("only dynamic bodies take a ") + key + " (this body is " +
                          kind + ")");
  }

  b.slip = body.number("slip", 0.0, kUnitInterval);
  b.restitution = body.number("restitution", 0.0, kUnitInterval);
  b.friction = body.number("friction", 0.5, kNonNegative);
  b.pose = readPose(body);
  b.linear_velocity = body.vec3("linear_velocity", Vec3::Zero());
  b.angular_velocity = body.vec3("angular_velocity", Vec3::Zero());
  if (b.kind == BodyKind::Static)
    for (const char* key : {"linear_velocity", "angular_velocity"})
      if (const Vec3 v = body.vec3(key, Vec3::Zero()); v != Vec3::Zero())
        body.at(key).fail("a static body never moves: must be [0, 0, 0] (got " + formatVec3(v) +
                          "); use kind \"kinematic\" for a body that moves");

  b.shape = readShape(body.object("shape"), kind, false, folder);
  return b;
}

void readBodies(const Where& at, const json& list, const fs::path& folder,
                std::vector<BodySpec>& bodies) {
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
    bodies.push_back(readBody(body, folder));
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
  root.allowOnly({"name", "description", "gravity", "time", "fluid", "coupling", "domain", "health",
                  "bodies"});

  SceneFile scene;
  scene.path = path;
  scene.text = json_text;
  scene.name = fs::path(path).stem().string();
  if (root.find("name")) scene.name = root.string("name");
  checkName(root.find("name") ? root.at("name") : root.where(), scene.name);
  if (root.find("description")) root.string("description");

  scene.sim.gravity = root.vec3("gravity", kDefaults.gravity);
  readTime(root.object("time"), scene);
  readFluid(root.object("fluid"), scene.sim);
  if (scene.sim.solver == FluidSolver::Dfsph && scene.sim.cfl > 0.6)
    root.at("time").key("cfl").fail("must be in (0, 0.6] with fluid.solver \"dfsph\" (got " +
                                    formatNumber(scene.sim.cfl) + ")");
  checkParticleCount(root.at("fluid").key("particle_radius"), scene.sim);
  if (const auto coupling = root.optionalObject("coupling")) readCoupling(*coupling, scene.sim);
  if (const auto health = root.optionalObject("health")) readHealth(*health, scene.sim);
  if (const auto domain = root.optionalObject("domain")) {
    domain->allowOnly({"min", "max"});
    scene.sim.domain = domain->box("min", "max");
  }
  // sim.bodies stays empty: the runner builds the bodies from scene.bodies through Bullet.
  if (const json* bodies = root.find("bodies"))
    readBodies(root.at("bodies"), *bodies, fs::path(path).parent_path(), scene.bodies);
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

void overrideResolution(SceneFile& scene, double factor, const std::string& option) {
  if (!std::isfinite(factor) || !kPositive.contains(factor))
    throw SceneError(option + ": must be a finite number > 0 (got " + formatNumber(factor) + ")");
  scene.sim.fluid.particle_radius /= factor;
  scene.resolution *= factor;
  const std::string where = option + " " + formatNumber(factor);
  checkParticleCount(Where{&where, ""}, scene.sim);
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
