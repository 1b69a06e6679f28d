#include "io/series.hpp"

#include "io/files.hpp"

#include <cstdio>
#include <stdexcept>

namespace wake {

namespace {

std::string number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.9g", x);
  return buf;
}

}  // namespace

SeriesWriter::SeriesWriter(const std::string& out_dir, const Simulation& sim)
    : partial_(out_dir + "/series.csv.partial"), final_(out_dir + "/series.csv") {
  out_.open(partial_, std::ios::out | std::ios::trunc);
  if (!out_) throw std::runtime_error("cannot write " + partial_);
  out_ << "time,max_density_ratio,penetrating,lost_particles,contacts";
  const Boundaries& boundaries = sim.boundaries();
  for (std::size_t b = 0; b < boundaries.bodyCount(); ++b) {
    if (!boundaries.body(b).moves()) continue;
    moving_.push_back(b);
    const std::string& name = boundaries.body(b).name;
    for (const char* column : {".x", ".y", ".z", ".vx", ".vy", ".vz"})
      out_ << ',' << name << column;
  }
  out_ << '\n';
}

void SeriesWriter::writeFrame(const Simulation& sim, bool first) {
  out_ << number(sim.time()) << ','
       << (first ? std::string("nan") : number(sim.windowMaxDensityRatio())) << ','
       << sim.windowMaxPenetrating() << ',' << sim.lostParticles() << ',' << sim.lastContacts();
  const std::vector<BodyState> states = sim.bodyStates();
  for (const std::size_t b : moving_) {
    const BodyState& s = states[b];
    for (int k = 0; k < 3; ++k)
      out_ << ',' << number(s.position[k]);
    for (int k = 0; k < 3; ++k)
      out_ << ',' << number(s.linear_velocity[k]);
  }
  out_ << '\n';
  out_.flush();
  if (!out_) throw std::runtime_error("cannot write " + partial_);
}

void SeriesWriter::finish() {
  out_.close();
  if (!out_) throw std::runtime_error("cannot close " + partial_);
  renameFile(partial_, final_);
}

}  // namespace wake
