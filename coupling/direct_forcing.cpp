#include "coupling/direct_forcing.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include <omp.h>
#include <algorithm>

namespace wake {

double normalCompliance(double particle_inverse_mass, double body_inverse_mass,
                        const Mat3& inverse_inertia, const Vec3& lever, const Vec3& normal) {
  const Vec3 rn = lever.cross(normal);
  return particle_inverse_mass + body_inverse_mass + rn.dot(inverse_inertia * rn);
}

void GlobalSystem::add(const GlobalContact& c) {
  Vec6 g;
  g << c.normal, c.lever.cross(c.normal);
  a_.noalias() += c.mass * g * g.transpose();
  b_ -= (c.mass * c.psi) * g;
}

Mat3 inertiaFromInverse(const Mat3& inverse_inertia) {
  // A locked rotation axis has a zero inverse inertia: regularise it to a very large
  // (not infinite) inertia so the system stays solvable and dW ~ 0 about that axis.
  const double scale = std::max(inverse_inertia.trace(), 1e-300);
  const Mat3 reg = inverse_inertia + 1e-12 * scale * Mat3::Identity();
  return reg.inverse();
}

Mat6 GlobalSystem::matrix(double inverse_mass, const Mat3& inverse_inertia) const {
  Mat6 a = a_;
  a.topLeftCorner<3, 3>().diagonal().array() += 1.0 / inverse_mass;
  a.bottomRightCorner<3, 3>() += inertiaFromInverse(inverse_inertia);
  return a;
}

Vec6 GlobalSystem::solve(double inverse_mass, const Mat3& inverse_inertia) const {
  return matrix(inverse_mass, inverse_inertia).ldlt().solve(b_);
}

template <class F>
void DirectForcing::forEachParticle(const std::vector<Record>& records, F&& f) {
  for (std::size_t k = 0; k < records.size(); k += records[k].count)
    f(&records[k], static_cast<std::size_t>(records[k].count));
}

double DirectForcing::normalMass(const Record& rec,
                                 const std::vector<RigidPrediction>& predicted) const {
  // Effective mass of a normal impulse at a contact: 1 / (n^T K n).
  const double m = particle_mass_;
  if (!two_way_[rec.body]) return m;
  const RigidPrediction& p = predicted[rec.body];
  return 1.0 /
         normalCompliance(1.0 / m, p.inverse_mass, p.inverse_inertia_world, rec.lever, rec.normal);
}

void DirectForcing::applyImpulse(Chunk& ch, const Record& rec, const Vec3& j, Vec3& vi) const {
  vi += j / particle_mass_;
  if (!two_way_[rec.body]) return;
  ch.impulse[rec.body] -= j;
  ch.angular[rec.body] -= rec.lever.cross(j);
}

template <class Extra>
void DirectForcing::normalPasses(Chunk& ch, const Record* rec, std::size_t count, Vec3& vi,
                                 const std::vector<RigidPrediction>& predicted, Extra&& extra,
                                 int passes) const {
  for (int pass = 0; pass < passes; ++pass) {
    for (std::size_t c = 0; c < count; ++c) {
      const double vn = (vi - rec[c].v_cp - extra(rec[c])).dot(rec[c].normal);
      const double target_n = vn > 0.0 ? vn : rec[c].bounce;
      if (vn < target_n)
        applyImpulse(ch, rec[c], normalMass(rec[c], predicted) * (target_n - vn) * rec[c].normal,
                     vi);
    }
  }
}

ControlResult DirectForcing::control(const Boundaries& boundaries, const ControlBodies& bodies,
                                     const ControlFluid& fluid, CouplingMethod method, double dt,
                                     std::vector<Wrench>& wrench) {
  const std::size_t n = fluid.v.size(), nb = boundaries.bodyCount();
  fluid.in_contact.assign(n, 0);
  wrench.assign(nb, Wrench{});
  if (nb == 0 || n == 0) return {};
  two_way_.assign(nb, 0);
  for (std::size_t b = 0; b < nb; ++b)
    two_way_[b] = boundaries.body(b).twoWay() && bodies.predicted[b].inverse_mass > 0;
  const std::size_t chunk_count = (n + kChunk - 1) / kChunk;
  const ControlResult result = findContacts(boundaries, bodies, fluid, chunk_count);
  if (method == CouplingMethod::Global)
    solveGlobal(bodies.predicted, dt, chunk_count, fluid.v, wrench);
  else
    solveLocal(bodies.predicted, chunk_count, fluid.v);
  for (std::size_t b = 0; b < nb; ++b) {
    if (!two_way_[b]) continue;
    Vec3 lin = Vec3::Zero(), ang = Vec3::Zero();
    for (std::size_t c = 0; c < chunk_count; ++c) {
      lin += chunks_[c].impulse[b];
      ang += chunks_[c].angular[b];
    }
    wrench[b].force += lin / dt;
    wrench[b].torque += ang / dt;
  }
  return result;
}

ControlResult DirectForcing::findContacts(const Boundaries& boundaries, const ControlBodies& bodies,
                                          const ControlFluid& fluid, std::size_t chunk_count) {
  const std::size_t n = fluid.v.size(), nb = boundaries.bodyCount();
  if (chunks_.size() < chunk_count) chunks_.resize(chunk_count);
  std::size_t particles = 0, contacts_total = 0;
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : particles, contacts_total)
  for (std::int64_t c = 0; c < static_cast<std::int64_t>(chunk_count); ++c) {
    Chunk& ch = chunks_[c];
    ch.records.clear();
    ch.impulse.assign(nb, Vec3::Zero());
    ch.angular.assign(nb, Vec3::Zero());
    std::array<Contact, Boundaries::kMaxContacts> contacts;
    const std::size_t end = std::min(n, (c + 1) * kChunk);
    for (std::size_t i = c * kChunk; i < end; ++i) {
      const std::size_t count = boundaries.findContacts(fluid.x_pred[i], bodies.at, contacts);
      if (count == 0) continue;
      fluid.in_contact[i] = 1;
      ++particles;
      contacts_total += count;
      for (std::size_t k = 0; k < count; ++k) {
        const Contact& ct = contacts[k];
        const RigidState& p = bodies.predicted[ct.body].state;
        Record rec;
        rec.particle = static_cast<std::uint32_t>(i);
        rec.body = ct.body;
        rec.count = static_cast<std::uint32_t>(count);
        rec.normal = ct.normal;
        rec.lever = ct.point - p.pose.position;
        rec.v_cp = p.linear_velocity + p.angular_velocity.cross(rec.lever);
        // Restitution reflects only the approach speed at the start of the step.
        const double vn_old =
            (fluid.v_old[i] - bodies.now[ct.body].pointVelocity(ct.point)).dot(ct.normal);
        rec.bounce = -boundaries.body(ct.body).restitution * std::min(0.0, vn_old);
        // Eq. 8-9's normal part: restitution, and no sticking (a separating contact is
        // left alone). The tangential part is the walls' viscous shear, already in v*
        // (Boundaries::addWallTerms), so the control leaves it as it is.
        const double vn = (fluid.v[i] - rec.v_cp).dot(ct.normal);  // predicted, v*_r . n
        const double target_n = vn > 0.0 ? vn : rec.bounce;
        rec.psi = target_n - vn;
        ch.records.push_back(rec);
      }
    }
  }
  return {particles, contacts_total};
}

void DirectForcing::solveLocal(const std::vector<RigidPrediction>& predicted,
                               std::size_t chunk_count, std::vector<Vec3>& v) {
  // Each contact's normal impulse, then a few passes when there are several (an impulse
  // towards one body must not push the particle into another).
  const auto none = [](const Record&) { return Vec3::Zero(); };
#pragma omp parallel for schedule(dynamic, 1)
  for (std::int64_t c = 0; c < static_cast<std::int64_t>(chunk_count); ++c) {
    Chunk& ch = chunks_[c];
    forEachParticle(ch.records, [&](const Record* rec, std::size_t count) {
      Vec3 vi = v[rec->particle];
      normalPasses(ch, rec, count, vi, predicted, none, count > 1 ? 3 : 1);
      v[rec->particle] = vi;
    });
  }
}

void DirectForcing::solveGlobal(const std::vector<RigidPrediction>& predicted, double dt,
                                std::size_t chunk_count, std::vector<Vec3>& v,
                                std::vector<Wrench>& wrench) {
  // All contacts of one two-way body at once: one 6x6 solve per body, its system summed
  // over chunks in a fixed order. A particle's mass is shared among its contacts.
  const std::size_t nb = two_way_.size();
  const double m = particle_mass_;
  std::vector<Vec6> change(nb, Vec6::Zero());  // [dV; dW]
#pragma omp parallel for schedule(dynamic, 1)
  for (std::int64_t c = 0; c < static_cast<std::int64_t>(chunk_count); ++c) {
    Chunk& ch = chunks_[c];
    ch.system.assign(nb, GlobalSystem());
    for (const Record& rec : ch.records)
      if (two_way_[rec.body])
        ch.system[rec.body].add({m / double(rec.count), rec.lever, rec.normal, rec.psi});
  }
  for (std::size_t b = 0; b < nb; ++b) {
    if (!two_way_[b]) continue;
    GlobalSystem sum;
    for (std::size_t c = 0; c < chunk_count; ++c)
      sum.add(chunks_[c].system[b]);
    if (sum.rhs().isZero(0.0)) continue;
    const RigidPrediction& p = predicted[b];
    change[b] = sum.solve(p.inverse_mass, p.inverse_inertia_world);
    wrench[b].force = change[b].head<3>() / (p.inverse_mass * dt);
    wrench[b].torque = inertiaFromInverse(p.inverse_inertia_world) * change[b].tail<3>() / dt;
  }
  auto bodyChange = [&](const Record& rec) -> Vec3 {
    if (!two_way_[rec.body]) return Vec3::Zero();
    const Vec6& d = change[rec.body];
    return d.head<3>() + d.tail<3>().cross(rec.lever);
  };
#pragma omp parallel for schedule(dynamic, 1)
  for (std::int64_t c = 0; c < static_cast<std::int64_t>(chunk_count); ++c) {
    Chunk& ch = chunks_[c];
    forEachParticle(ch.records, [&](const Record* rec, std::size_t count) {
      const std::uint32_t i = rec->particle;
      // Each contact's share of the particle: its psi plus the body's normal velocity
      // change at the contact, along the normal.
      Vec3 vi = v[i];
      for (std::size_t q = 0; q < count; ++q)
        vi +=
            ((rec[q].psi + rec[q].normal.dot(bodyChange(rec[q]))) / double(count)) * rec[q].normal;
      if (count > 1) normalPasses(ch, rec, count, vi, predicted, bodyChange, 2);
      v[i] = vi;
    });
  }
}

}  // namespace wake
