#include "io/series.hpp"

#include "io/files.hpp"

#include <unistd.h>

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
  findMovingBodies(sim);
  const Boundaries& boundaries = sim.boundaries();
  for (const std::size_t b : moving_) {
    const std::string& name = boundaries.body(b).name;
    for (const char* column : {".x", ".y", ".z", ".vx", ".vy", ".vz"})
      out_ << ',' << name << column;
  }
  out_ << '\n';
}

SeriesWriter::SeriesWriter(const std::string& out_dir, const Simulation& sim, std::size_t frames)
    : partial_(out_dir + "/series.csv.partial"), final_(out_dir + "/series.csv") {
  findMovingBodies(sim);
  // A run stopped while it finished: its complete series becomes the partial one again.
  if (::access(partial_.c_str(), F_OK) != 0 && ::access(final_.c_str(), R_OK) == 0)
    renameFile(final_, partial_);
  std::ifstream in(partial_, std::ios::binary);
  if (!in) throw std::runtime_error("cannot resume: " + partial_ + " is missing");
  std::string kept, line;
  std::size_t lines = 0;
  while (lines < frames + 1 && std::getline(in, line)) {
    kept += line + '\n';
    ++lines;
  }
  if (lines < frames + 1)
    throw std::runtime_error("cannot resume: " + partial_ + " has " +
                             std::to_string(lines > 0 ? lines - 1 : 0) + " rows, the checkpoint " +
                             std::to_string(frames) + " frames");
  in.close();
  writeFileAtomically(partial_, kept);
  out_.open(partial_, std::ios::out | std::ios::app);
  if (!out_) throw std::runtime_error("cannot write " + partial_);
}

void SeriesWriter::findMovingBodies(const Simulation& sim) {
  const Boundaries& boundaries = sim.boundaries();
  for (std::size_t b = 0; b < boundaries.bodyCount(); ++b)
    if (boundaries.body(b).moves()) moving_.push_back(b);
}

void SeriesWriter::sync() {
  out_.flush();
  if (!out_) throw std::runtime_error("cannot write " + partial_);
  syncFile(partial_);
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
