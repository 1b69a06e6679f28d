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

ControlResult DirectForcing::control(const Boundaries& boundaries, CouplingMethod method, double dt,
                                     const std::vector<Vec3>& x_pred,
                                     const std::vector<Vec3>& v_old,
                                     const std::vector<RigidState>& now,
                                     const std::vector<RigidPrediction>& predicted,
                                     std::vector<Vec3>& v, std::vector<std::uint8_t>& in_contact,
                                     std::vector<Wrench>& wrench) {
  const std::size_t n = x_pred.size(), nb = boundaries.bodyCount();
  in_contact.assign(n, 0);
  wrench.assign(nb, Wrench{});
  ControlResult result;
  if (nb == 0 || n == 0) return result;
  const double m = particle_mass_;
  const bool global = method == CouplingMethod::Global;
  std::vector<std::uint8_t> two_way(nb);
  for (std::size_t b = 0; b < nb; ++b)
    two_way[b] = boundaries.body(b).twoWay() && predicted[b].inverse_mass > 0;

  // Effective mass of a normal impulse at a contact: 1 / (n^T K n).
  auto normalMass = [&](const Record& rec) {
    if (!two_way[rec.body]) return m;
    const RigidPrediction& p = predicted[rec.body];
    return 1.0 / normalCompliance(1.0 / m, p.inverse_mass, p.inverse_inertia_world, rec.lever,
                                  rec.normal);
  };
  auto applyImpulse = [&](Chunk& ch, const Record& rec, const Vec3& j, Vec3& vi) {
    vi += j / m;
    if (!two_way[rec.body]) return;
    ch.impulse[rec.body] -= j;
    ch.angular[rec.body] -= rec.lever.cross(j);
  };
  // Passes that only remove approach velocity towards one of several bodies, whose
  // contact points move with v_cp + extra(rec).
  auto normalPasses = [&](Chunk& ch, const Record* rec, std::size_t count, Vec3& vi, auto&& extra,
                          int passes) {
    for (int pass = 0; pass < passes; ++pass) {
      for (std::size_t c = 0; c < count; ++c) {
        const double vn = (vi - rec[c].v_cp - extra(rec[c])).dot(rec[c].normal);
        const double target_n = vn > 0.0 ? vn : rec[c].bounce;
        if (vn < target_n)
          applyImpulse(ch, rec[c], normalMass(rec[c]) * (target_n - vn) * rec[c].normal, vi);
      }
    }
  };

  const std::size_t chunk_count = (n + kChunk - 1) / kChunk;
  if (chunks_.size() < chunk_count) chunks_.resize(chunk_count);
  std::size_t particles = 0, contacts_total = 0;
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : particles, contacts_total)
  for (std::int64_t c = 0; c < static_cast<std::int64_t>(chunk_count); ++c) {
    Chunk& ch = chunks_[c];
    ch.records.clear();
    ch.impulse.assign(nb, Vec3::Zero());
    ch.angular.assign(nb, Vec3::Zero());
    if (global) ch.system.assign(nb, GlobalSystem());
    std::array<Contact, Boundaries::kMaxContacts> contacts;
    const std::size_t end = std::min(n, (c + 1) * kChunk);
    for (std::size_t i = c * kChunk; i < end; ++i) {
      const std::size_t count = boundaries.findContacts(x_pred[i], contacts);
      if (count == 0) continue;
      in_contact[i] = 1;
      ++particles;
      contacts_total += count;
      const std::size_t first = ch.records.size();
      for (std::size_t k = 0; k < count; ++k) {
        const Contact& ct = contacts[k];
        const RigidPrediction& p = predicted[ct.body];
        const BodySettings& body = boundaries.body(ct.body);
        Record rec;
        rec.particle = static_cast<std::uint32_t>(i);
        rec.body = ct.body;
        rec.count = static_cast<std::uint32_t>(count);
        rec.normal = ct.normal;
        rec.lever = ct.point - p.state.pose.position;
        rec.v_cp = p.state.linear_velocity + p.state.angular_velocity.cross(rec.lever);
        // Restitution reflects only the approach speed at the start of the step.
        const double vn_old = (v_old[i] - now[ct.body].pointVelocity(ct.point)).dot(ct.normal);
        rec.bounce = -body.restitution * std::min(0.0, vn_old);
        // Eq. 8-9's normal part: restitution, and no sticking (a separating contact is
        // left alone). The tangential part is the walls' viscous shear, already in v*
        // (Boundaries::addWallTerms), so the control leaves it as it is.
        const double vn = (v[i] - rec.v_cp).dot(ct.normal);  // predicted, v*_r . n
        const double target_n = vn > 0.0 ? vn : rec.bounce;
        rec.psi = target_n - vn;
        ch.records.push_back(rec);
      }
      if (global) {
        for (std::size_t k = first; k < ch.records.size(); ++k) {
          const Record& rec = ch.records[k];
          if (two_way[rec.body])
            ch.system[rec.body].add({m / double(rec.count), rec.lever, rec.normal, rec.psi});
        }
        continue;
      }
      // Local: each contact's normal impulse, then a few passes when there are several
      // (an impulse towards one body must not push the particle into another).
      Vec3 vi = v[i];
      normalPasses(
          ch, &ch.records[first], count, vi, [](const Record&) { return Vec3::Zero(); },
          count > 1 ? 3 : 1);
      v[i] = vi;
    }
  }
  result.particles = particles;
  result.contacts = contacts_total;

  auto reduceImpulses = [&] {
    for (std::size_t b = 0; b < nb; ++b) {
      if (!two_way[b]) continue;
      Vec3 lin = Vec3::Zero(), ang = Vec3::Zero();
      for (std::size_t c = 0; c < chunk_count; ++c) {
        lin += chunks_[c].impulse[b];
        ang += chunks_[c].angular[b];
      }
      wrench[b].force += lin / dt;
      wrench[b].torque += ang / dt;
    }
  };
  if (!global) {
    reduceImpulses();
    supportBackedContacts(dt, predicted, two_way, chunk_count, wrench);
    return result;
  }

  // Global: one 6x6 solve per two-way body, summed over chunks in a fixed order.
  std::vector<Vec6> change(nb, Vec6::Zero());  // [dV; dW]
  for (std::size_t b = 0; b < nb; ++b) {
    if (!two_way[b]) continue;
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
    if (!two_way[rec.body]) return Vec3::Zero();
    const Vec6& d = change[rec.body];
    return d.head<3>() + d.tail<3>().cross(rec.lever);
  };
#pragma omp parallel for schedule(dynamic, 1)
  for (std::int64_t c = 0; c < static_cast<std::int64_t>(chunk_count); ++c) {
    Chunk& ch = chunks_[c];
    ch.impulse.assign(nb, Vec3::Zero());
    ch.angular.assign(nb, Vec3::Zero());
    for (std::size_t k = 0; k < ch.records.size();) {
      const Record* rec = &ch.records[k];
      const std::size_t count = rec->count;
      const std::uint32_t i = rec->particle;
      // Each contact's share of the particle: its psi plus the body's normal velocity
      // change at the contact, along the normal.
      Vec3 vi = v[i];
      for (std::size_t q = 0; q < count; ++q)
        vi +=
            ((rec[q].psi + rec[q].normal.dot(bodyChange(rec[q]))) / double(count)) * rec[q].normal;
      if (count > 1) normalPasses(ch, rec, count, vi, bodyChange, 2);
      v[i] = vi;
      k += count;
    }
  }
  reduceImpulses();
  supportBackedContacts(dt, predicted, two_way, chunk_count, wrench);
  return result;
}

void DirectForcing::supportBackedContacts(double dt, const std::vector<RigidPrediction>& predicted,
                                          const std::vector<std::uint8_t>& two_way,
                                          std::size_t chunk_count, std::vector<Wrench>& wrench) {
  // A particle pressed between a two-way body and a one-way one (a box settling on the
  // floor, a body pushed against a wall) cannot give way: the one-way contact fixes its
  // normal velocity. So the two-way body meets it as it would meet the wall: the contact's
  // impulse acts on the body alone (infinite particle mass) until the body no longer
  // approaches the particle. Solved for all such contacts of a body at once by projected
  // Gauss-Seidel (accumulated impulses >= 0), in the fixed order of the particles.
  backed_.clear();
  for (std::size_t c = 0; c < chunk_count; ++c) {
    const std::vector<Record>& records = chunks_[c].records;
    for (std::size_t k = 0; k < records.size();) {
      const Record* rec = &records[k];
      const std::size_t count = rec->count;
      for (std::size_t a = 0; a < count && count > 1; ++a) {
        if (!two_way[rec[a].body]) continue;
        // The most opposed one-way contact backs it.
        double opposed = -0.5;
        std::size_t backer = count;
        for (std::size_t b = 0; b < count; ++b) {
          const double cosine = rec[a].normal.dot(rec[b].normal);
          if (!two_way[rec[b].body] && cosine < opposed) opposed = cosine, backer = b;
        }
        if (backer == count) continue;
        backed_.push_back(rec[a]);
        backed_.back().backer = rec[backer].v_cp;
      }
      k += count;
    }
  }
  if (backed_.empty()) return;
  const std::size_t nb = wrench.size();
  for (std::size_t b = 0; b < nb; ++b) {
    if (!two_way[b]) continue;
    const RigidPrediction& p = predicted[b];
    const Mat3& inv_i = p.inverse_inertia_world;
    // The body's velocity change from the control so far.
    Vec3 dV = wrench[b].force * (dt * p.inverse_mass);
    Vec3 dW = inv_i * wrench[b].torque * dt;
    Vec3 impulse = Vec3::Zero(), angular = Vec3::Zero();
    lambda_.assign(backed_.size(), 0.0);
    for (int iteration = 0; iteration < 20; ++iteration) {
      double largest = 0.0;
      for (std::size_t c = 0; c < backed_.size(); ++c) {
        const Record& rec = backed_[c];
        if (rec.body != b) continue;
        // The particle moves with the one-way body behind it (that contact fixed its
        // normal velocity): the body approaches that body, not the particle's own
        // velocity, which would let a fast particle push the body as if it had no end of
        // mass.
        const Vec3 v_body = rec.v_cp + dV + dW.cross(rec.lever);
        const double vn = (rec.backer - v_body).dot(rec.normal);
        const Vec3 rn = rec.lever.cross(rec.normal);
        const double k = normalCompliance(0.0, p.inverse_mass, inv_i, rec.lever, rec.normal);
        const double j = std::max(-lambda_[c], (rec.bounce - vn) / k);
        if (j == 0.0) continue;
        lambda_[c] += j;
        // The particle would take +j n: the body takes -j n at the lever.
        dV -= (j * p.inverse_mass) * rec.normal;
        dW -= inv_i * (j * rn);
        impulse -= j * rec.normal;
        angular -= j * rn;
        largest = std::max(largest, std::abs(j) * k);
      }
      if (largest < 1e-9) break;
    }
    wrench[b].force += impulse / dt;
    wrench[b].torque += angular / dt;
  }
}

}  // namespace wake
