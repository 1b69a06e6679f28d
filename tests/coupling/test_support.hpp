// Small scene builders shared by the coupling tests.
#pragma once

#include "coupling/simulation.hpp"

#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <limits>
#include <memory>
#include <string>

namespace wake::test {

/// A test that runs with each pressure model (SimulationSettings::solver): the weakly
/// compressible fluid and the divergence-free solver. Instantiate with kSolvers and
/// solverName: the tests are named .../wcsph and .../dfsph.
class SolverTest : public ::testing::TestWithParam<FluidSolver> {
 protected:
  FluidSolver solver() const { return GetParam(); }
  bool dfsph() const { return GetParam() == FluidSolver::Dfsph; }
};

inline const auto kSolvers = ::testing::Values(FluidSolver::Wcsph, FluidSolver::Dfsph);

inline std::string solverName(const ::testing::TestParamInfo<FluidSolver>& info) {
  return info.param == FluidSolver::Dfsph ? "dfsph" : "wcsph";
}

inline BodySettings staticBody(const std::string& name, std::shared_ptr<const Shape> shape,
                               double slip = 0.0, double restitution = 0.0,
                               const Pose& pose = Pose()) {
  BodySettings b;
  b.name = name;
  b.kind = BodyKind::Static;
  b.shape = std::move(shape);
  b.pose = pose;
  b.slip = slip;
  b.restitution = restitution;
  return b;
}

/// A static tank (body 0) and one two-way body (body 1) held on a set velocity until
/// `release` seconds (for good by default), then free to translate under `gravity` and the
/// fluid's force with its own `mass` (semi-implicit Euler, as SimpleRigidBodies; no
/// rotation: for a body on a symmetric tank's axis). While held it is two-way with a huge
/// mass, so the control sees a free body and its wrench is computed as for one.
class HeldBody final : public RigidBodies {
 public:
  static constexpr double kHeldMass = 1e6;
  HeldBody(const RigidState& tank, const RigidState& body, const Vec3& inertia,
           double release = std::numeric_limits<double>::infinity(), double mass = kHeldMass,
           const Vec3& gravity = Vec3(0, -9.81, 0))
      : states_{tank, body}, inertia_(inertia), release_(release), mass_(mass), gravity_(gravity) {}
  std::size_t count() const override { return 2; }
  RigidState state(std::size_t b) const override { return states_[b]; }
  void predict(double dt, std::vector<RigidPrediction>& out) const override {
    out.resize(2);
    for (std::size_t b = 0; b < 2; ++b)
      out[b].state = states_[b];
    out[0].inverse_mass = 0.0;
    out[0].inverse_inertia_world = Mat3::Zero();
    out[1].inverse_mass = 1.0 / (held() ? kHeldMass : mass_);
    out[1].inverse_inertia_world =
        held() ? Mat3(inertia_.cwiseInverse().asDiagonal()) : Mat3::Zero();
    if (!held()) out[1].state.linear_velocity += dt * gravity_;
    out[1].state.pose.position += dt * out[1].state.linear_velocity;
  }
  void step(double dt, const std::vector<Wrench>& fluid) override {
    if (!held()) states_[1].linear_velocity += dt * (gravity_ + fluid[1].force / mass_);
    states_[1].pose.position += dt * states_[1].linear_velocity;
    time_ += dt;
    if (held() && time_ >= move_from_ - 1e-12) states_[1].linear_velocity = move_velocity_;
  }
  bool held() const { return time_ < release_ - 1e-12; }
  /// While held: from time `t` on (a step's end), at the set velocity `v` instead of the
  /// start's.
  void moveFrom(double t, const Vec3& v) {
    move_from_ = t;
    move_velocity_ = v;
  }

 private:
  std::array<RigidState, 2> states_;
  Vec3 inertia_;
  double release_, mass_;
  Vec3 gravity_;
  double time_ = 0.0;
  double move_from_ = std::numeric_limits<double>::infinity();
  Vec3 move_velocity_ = Vec3::Zero();
};

/// A tank (cavity [0, size]) with one fluid block.
inline SimulationSettings tankScene(const Vec3& tank_size, const FluidBlock& block,
                                    double particle_radius) {
  SimulationSettings s;
  s.fluid.particle_radius = particle_radius;
  s.blocks.push_back(block);
  s.bodies.push_back(staticBody("tank", makeTank(Vec3::Zero(), tank_size, 4.0 * particle_radius)));
  return s;
}

/// A free box in zero gravity hit by a sheet of fluid particles.
inline Simulation sheetOnFreeBox(CouplingMethod method, double restitution, int threads = 0,
                                 FluidSolver solver = FluidSolver::Wcsph) {
  SimulationSettings s;
  s.solver = solver;
  s.gravity = Vec3::Zero();
  s.fluid.particle_radius = 0.01;
  s.fluid.speed_of_sound = 20.0;
  s.method = method;
  s.blocks.push_back({Vec3(-0.05, 0.04, -0.05), Vec3(0.07, 0.06, 0.07), Vec3(0.3, -1.0, 0.1)});
  BodySettings box;
  box.name = "box";
  box.kind = BodyKind::Dynamic;
  box.shape = makeBox(Vec3(0.1, 0.02, 0.1));
  box.mass = 0.5;
  box.inertia = Vec3(0.0017, 0.0033, 0.0017);
  box.restitution = restitution;
  box.pose.orientation = Quat(Eigen::AngleAxisd(0.2, Vec3::UnitZ()));
  s.bodies.push_back(box);
  s.domain = Aabb{Vec3::Constant(-0.5), Vec3::Constant(0.5)};
  if (threads > 0) omp_set_num_threads(threads);
  return Simulation(s);
}

inline Vec3 totalMomentum(const Simulation& sim, double body_mass) {
  Vec3 p = body_mass * sim.bodyStates()[0].linear_velocity;
  const FluidState& st = sim.fluid().state();
  for (std::size_t i = 0; i < st.size(); ++i)
    p += sim.fluid().particleMass() * st.velocity[i];
  return p;
}

/// Steps the simulation to time t, asserting after every step that no fluid centre is
/// inside a body's exact shape (the direct-forcing guarantee).
inline void runWithoutPenetration(Simulation& sim, double t) {
  while (sim.time() < t) {
    sim.step(t);
    const std::size_t inside = sim.countPenetrating();
    ASSERT_EQ(inside, 0u) << "fluid inside a body at t = " << sim.time() << " (step " << sim.steps()
                          << ")";
  }
}

}  // namespace wake::test
