// Shared command line and state hash of Wake's benchmarks.
#pragma once

#include "coupling/simulation.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

namespace wake::bench {

struct Options {
  long particles = 100000;
  int steps = 100;
  int warmup = 20;
  int bodies = 8;
  std::vector<int> threads = {1, 2};
  std::string scene;  ///< wake_bench_dambreak: a scene file to run instead of the synthetic one
  bool particles_given = false;
  bool dfsph = false;  ///< --solver dfsph: the divergence-free solver instead of WCSPH
  /// --skin F: the neighbour lists' skin, F x the support radius (< 0: the automatic one).
  double skin = -1.0;
  /// --pressure-gradient consistent|symmetric: WCSPH's pressure force (FluidParams).
  PressureGradient pressure_gradient = PressureGradient::Consistent;
};

[[noreturn]] inline void usage(const char* program, const char* msg) {
  std::fprintf(stderr,
               "error: %s\nusage: %s [--particles N] [--steps S] [--warmup W] [--threads 1,2]"
               " [--bodies B] [--scene FILE] [--solver wcsph|dfsph] [--skin F]"
               " [--pressure-gradient consistent|symmetric]\n",
               msg, program);
  std::exit(2);
}

inline Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    auto value = [&](const char* name) -> std::string {
      if (i + 1 >= argc) usage(argv[0], (std::string(name) + " needs a value").c_str());
      return argv[++i];
    };
    if (!std::strcmp(argv[i], "--particles")) {
      o.particles = std::stol(value("--particles"));
      o.particles_given = true;
    } else if (!std::strcmp(argv[i], "--scene"))
      o.scene = value("--scene");
    else if (!std::strcmp(argv[i], "--steps"))
      o.steps = std::stoi(value("--steps"));
    else if (!std::strcmp(argv[i], "--warmup"))
      o.warmup = std::stoi(value("--warmup"));
    else if (!std::strcmp(argv[i], "--solver")) {
      const std::string s = value("--solver");
      if (s != "wcsph" && s != "dfsph") usage(argv[0], "--solver must be wcsph or dfsph");
      o.dfsph = s == "dfsph";
    } else if (!std::strcmp(argv[i], "--pressure-gradient")) {
      const std::string s = value("--pressure-gradient");
      if (s != "consistent" && s != "symmetric")
        usage(argv[0], "--pressure-gradient must be consistent or symmetric");
      o.pressure_gradient =
          s == "symmetric" ? PressureGradient::Symmetric : PressureGradient::Consistent;
    } else if (!std::strcmp(argv[i], "--skin")) {
      o.skin = std::stod(value("--skin"));
      if (!(o.skin >= 0) || !std::isfinite(o.skin)) usage(argv[0], "--skin must be >= 0");
    } else if (!std::strcmp(argv[i], "--bodies"))
      o.bodies = std::stoi(value("--bodies"));
    else if (!std::strcmp(argv[i], "--threads")) {
      o.threads.clear();
      std::stringstream ss(value("--threads"));
      for (std::string t; std::getline(ss, t, ',');)
        o.threads.push_back(std::stoi(t));
    } else
      usage(argv[0], (std::string("unknown option ") + argv[i]).c_str());
  }
  if (o.particles < 1 || o.steps < 1 || o.warmup < 0 || o.bodies < 0 || o.threads.empty())
    usage(argv[0], "counts must be positive");
  return o;
}

/// Difference of two timings (after - before).
inline StepTimings since(const StepTimings& after, const StepTimings& before) {
  StepTimings t = after;
  t.neighbors -= before.neighbors;
  t.density -= before.density;
  t.forces -= before.forces;
  t.boundary -= before.boundary;
  t.integration -= before.integration;
  t.rigid -= before.rigid;
  t.control -= before.control;
  t.correction -= before.correction;
  t.solver -= before.solver;
  return t;
}

}  // namespace wake::bench
