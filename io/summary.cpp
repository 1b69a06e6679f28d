#include "io/summary.hpp"

#include "io/files.hpp"
#include "io/scene.hpp"

#include <algorithm>
#include <cstdio>

namespace wake {
namespace {

nlohmann::ordered_json toJson(const Vec3& v) {
  return {v.x(), v.y(), v.z()};
}
nlohmann::ordered_json toJson(const Quat& q) {
  return {q.x(), q.y(), q.z(), q.w()};
}  // x, y, z, w

}  // namespace

nlohmann::ordered_json makeSummary(const SceneFile& scene, const Simulation& sim,
                                   const RunStats& stats) {
  nlohmann::ordered_json bodies = nlohmann::ordered_json::array();
  for (const BodyState& b : sim.bodyStates())
    bodies.push_back({{"name", b.name},
                      {"position", toJson(b.position)},
                      {"orientation", toJson(b.orientation)},
                      {"linear_velocity", toJson(b.linear_velocity)},
                      {"angular_velocity", toJson(b.angular_velocity)}});
  const StepTimings& t = sim.timings();
  const FluidParams& fluid = sim.fluid().params();
  const double mean_dt = sim.steps() > 0 ? sim.time() / static_cast<double>(sim.steps()) : 0.0;
  nlohmann::ordered_json j;
  // Contract fields.
  j["scene"] = scene.name;
  j["fluid_particles"] = sim.fluidParticles();
  j["boundary_particles"] = sim.boundaryParticles();
  j["steps"] = sim.steps();
  j["sim_time"] = sim.time();              // s
  j["wall_seconds"] = stats.wall_seconds;  // s
  j["max_density_ratio"] = sim.maxDensityRatio();
  j["max_penetrating"] = sim.maxPenetrating();
  j["lost_particles"] = sim.lostParticles();
  j["bodies"] = bodies;
  // Extensions.
  j["wake_version"] = wakeVersion();
  j["removed_at_start"] = sim.removedAtStart();
  j["speed_of_sound"] = fluid.speed_of_sound;    // m/s, "auto" resolved
  j["particle_radius"] = fluid.particle_radius;  // m
  j["rest_density"] = fluid.rest_density;        // kg/m^3
  j["method"] = sim.settings().method == CouplingMethod::Global    ? "global"
                : sim.settings().method == CouplingMethod::Penalty ? "penalty"
                                                                   : "local";
  const bool dfsph = sim.settings().solver == FluidSolver::Dfsph;
  j["solver"] = dfsph ? "dfsph" : "wcsph";
  // Average over the steps of the fluid's average compression max(0, rho / rho0 - 1).
  j["avg_density_error"] = sim.averageDensityError();
  j["max_step_density_error"] = sim.maxStepDensityError();  // the worst step's average
  if (dfsph) {
    const double steps = std::max<double>(1.0, static_cast<double>(sim.steps()));
    j["density_iterations_per_step"] = static_cast<double>(sim.densityIterations()) / steps;
    j["divergence_iterations_per_step"] = static_cast<double>(sim.divergenceIterations()) / steps;
  }
  j["end_time"] = scene.end_time;  // s
  j["frames"] = stats.frames;
  j["threads"] = stats.threads;
  j["mean_dt"] = mean_dt;  // s
  j["output"] = stats.output;
  {
    char hash[17];
    std::snprintf(hash, sizeof(hash), "%016llx", static_cast<unsigned long long>(stateHash(sim)));
    j["state_hash"] = hash;  // the fluid's final positions and velocities
  }
  j["timings"] = {{"neighbors", t.neighbors},
                  {"density", t.density},
                  {"forces", t.forces},
                  {"boundary", t.boundary},
                  {"integration", t.integration},
                  {"rigid", t.rigid},
                  {"control", t.control},
                  {"correction", t.correction},
                  {"solver", t.solver},
                  {"coupling", t.coupling()},
                  {"total", t.total()}};
  return j;
}

void writeSummary(const std::string& path, const nlohmann::ordered_json& summary) {
  writeFileAtomically(path, summary.dump(2) + "\n");
}

}  // namespace wake
