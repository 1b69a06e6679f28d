#include "coupling/boundary.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace wake {

namespace {

/// Sum of W over a flat square lattice of spacing s through the origin: what one boundary
/// sample sees of a flat wall sampled at the fluid spacing.
double flatLatticeKernelSum(const CubicSplineKernel& kernel, double s) {
  const int reach = static_cast<int>(std::ceil(kernel.supportRadius() / s)) + 1;
  double sum = 0.0;
  for (int i = -reach; i <= reach; ++i)
    for (int j = -reach; j <= reach; ++j)
      sum += kernel.value(s * std::hypot(i, j));
  return sum;
}

Aabb transformBounds(const Aabb& b, const Pose& pose, bool to_world) {
  Aabb out;
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3 p = b.corner(corner);
    out.extend(to_world ? pose.toWorld(p) : pose.toBody(p));
  }
  return out;
}

}  // namespace

Boundaries::Boundaries(const FluidParams& fluid, const Aabb& domain)
    : fluid_(fluid),
      kernel_(fluid.smoothingLength()),
      domain_(domain),
      spacing_(fluid.spacing()),
      radius_(fluid.particle_radius),
      volume_scale_(spacing_ * spacing_ * spacing_ * flatLatticeKernelSum(kernel_, spacing_)),
      grid_(makeGrid(domain, fluid.supportRadius())) {
  // Cells of half the support: the density share searches 2 cells around a particle,
  // contacts (reach r_f + r_b = half the support) only 1.
  auto cellsToCover = [&](double distance) {
    return std::max(1, static_cast<int>(std::ceil(distance / grid_.cellSize() - 1e-12)));
  };
  density_reach_ = cellsToCover(kernel_.supportRadius());
  contact_reach_ = cellsToCover(2.0 * radius_);
}

UniformGrid Boundaries::makeGrid(const Aabb& domain, double support) {
  if (UniformGrid::cellsFor(domain, 0.5 * support) <= double(UniformGrid::kMaxCells))
    return UniformGrid(domain, 0.5 * support, UniformGrid::kMaxCells, 2);
  return UniformGrid(domain, support, UniformGrid::kMaxCells, 1);
}

std::size_t Boundaries::addBody(const BodySettings& settings) {
  if (!settings.shape) throw std::invalid_argument("body '" + settings.name + "' has no shape");
  Body b;
  b.settings = settings;
  const Aabb clip = transformBounds(domain_, settings.pose, /*to_world=*/false);
  settings.shape->sample(spacing_, radius_, clip, b.local);
  b.world_bounds = transformBounds(settings.shape->bounds(clip), settings.pose, true);
  bodies_.push_back(std::move(b));
  return bodies_.size() - 1;
}

void Boundaries::setBodyState(std::size_t body, const Pose& pose, const Vec3& linear_velocity,
                              const Vec3& angular_velocity) {
  Body& b = bodies_[body];
  b.settings.pose = pose;
  b.settings.linear_velocity = linear_velocity;
  b.settings.angular_velocity = angular_velocity;
  const Aabb clip = transformBounds(domain_, pose, false);
  b.world_bounds = transformBounds(b.settings.shape->bounds(clip), pose, true);
}

void Boundaries::updateWorld() {
  std::size_t total = 0;
  for (Body& b : bodies_) {
    b.first = static_cast<std::uint32_t>(total);
    total += b.local.size();
  }
  std::vector<Vec3> pos(total), nrm(total);
  std::vector<std::uint32_t> body(total);
  for (std::size_t bi = 0; bi < bodies_.size(); ++bi) {
    const Body& b = bodies_[bi];
    for (std::size_t k = 0; k < b.local.size(); ++k) {
      pos[b.first + k] = b.settings.pose.toWorld(b.local.position[k]);
      nrm[b.first + k] = b.settings.pose.rotate(b.local.normal[k]);
      body[b.first + k] = static_cast<std::uint32_t>(bi);
    }
  }
  grid_.sort(pos, order_);
  position_.resize(total);
  normal_.resize(total);
  body_of_.resize(total);
  for (std::size_t k = 0; k < total; ++k) {
    position_[k] = pos[order_[k]];
    normal_[k] = nrm[order_[k]];
    body_of_[k] = body[order_[k]];
  }

  // Volumes (Akinci et al. 2012), normalised so that a flat wall sampled at the fluid
  // spacing stands for exactly one missing fluid layer: V_k = s^3 S_flat / sum_l W_kl.
  // Samples of an opposite face (a thin wall's other side) are not neighbours.
  volume_.assign(total, 0.0);
  const double support_sq = kernel_.supportRadius() * kernel_.supportRadius();
  const std::int64_t n = static_cast<std::int64_t>(total);
#pragma omp parallel for schedule(static)
  for (std::int64_t k = 0; k < n; ++k) {
    double sum = 0.0;
    const Vec3 xk = position_[k], nk = normal_[k];
    grid_.forEachNeighborRange(xk, [&](std::uint32_t lo, std::uint32_t hi) {
      for (std::uint32_t l = lo; l < hi; ++l) {
        const double d_sq = (xk - position_[l]).squaredNorm();
        if (d_sq < support_sq && nk.dot(normal_[l]) > -0.5) sum += kernel_.value(std::sqrt(d_sq));
      }
    });
    volume_[k] = volume_scale_ / sum;
  }

  // Flag the cells from which a sample can be within the kernel support or contact reach.
  near_.assign(grid_.cellCount(), 0);
  const Eigen::Vector3i dims = grid_.dims();
  auto mark = [&](const Eigen::Vector3i& c, int reach, std::uint8_t bit) {
    for (int z = std::max(0, c[2] - reach); z <= std::min(dims[2] - 1, c[2] + reach); ++z)
      for (int y = std::max(0, c[1] - reach); y <= std::min(dims[1] - 1, c[1] + reach); ++y)
        for (int x = std::max(0, c[0] - reach); x <= std::min(dims[0] - 1, c[0] + reach); ++x)
          near_[grid_.cellIndex(Eigen::Vector3i(x, y, z))] |= bit;
  };
  for (std::size_t k = 0; k < total; ++k) {
    const Eigen::Vector3i c = grid_.cellCoord(position_[k]);
    mark(c, density_reach_, kNearDensity);
    mark(c, contact_reach_, kNearContact);
  }
}

void Boundaries::addDensity(const Fluid& fluid, std::vector<double>& density) const {
  if (position_.empty()) return;
  const std::vector<Vec3>& x = fluid.state().position;
  const double rho0 = fluid_.rest_density;
  const double support_sq = kernel_.supportRadius() * kernel_.supportRadius();
  const std::int64_t n = static_cast<std::int64_t>(x.size());
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    const Vec3 xi = x[i];
    if (!near(xi, kNearDensity)) continue;
    double sum = 0.0;
    grid_.forEachRangeWithin(xi, density_reach_, [&](std::uint32_t lo, std::uint32_t hi) {
      for (std::uint32_t k = lo; k < hi; ++k) {
        const double d_sq = (xi - position_[k]).squaredNorm();
        if (d_sq < support_sq) sum += volume_[k] * kernel_.value(std::sqrt(d_sq));
      }
    });
    density[i] += rho0 * sum;
  }
}

std::size_t Boundaries::findContacts(const Vec3& x, std::array<Contact, kMaxContacts>& out) const {
  if (position_.empty() || !near(x, kNearContact)) return 0;
  const double reach = radius_ + radius_;  // r_f + r_b
  const double reach_sq = reach * reach;
  std::size_t count = 0;
  grid_.forEachRangeWithin(x, contact_reach_, [&](std::uint32_t lo, std::uint32_t hi) {
    for (std::uint32_t k = lo; k < hi; ++k) {
      const double d_sq = (x - position_[k]).squaredNorm();
      if (d_sq >= reach_sq) continue;
      const std::uint32_t body = body_of_[k];
      std::size_t c = 0;
      while (c < count && out[c].body != body)
        ++c;
      if (c < count) {
        // Ties go to the lower sample index, so the result is independent of visit order.
        if (d_sq < out[c].dist_sq || (d_sq == out[c].dist_sq && k < out[c].sample))
          out[c] = {body, k, d_sq};
      } else if (count < kMaxContacts) {
        out[count++] = {body, k, d_sq};
      } else {
        // More bodies than slots: replace the farthest contact if this one is nearer.
        std::size_t far = 0;
        for (std::size_t q = 1; q < count; ++q)
          if (out[q].dist_sq > out[far].dist_sq) far = q;
        if (d_sq < out[far].dist_sq) out[far] = {body, k, d_sq};
      }
    }
  });
  std::sort(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(count),
            [](const Contact& a, const Contact& b) {
              return a.dist_sq < b.dist_sq || (a.dist_sq == b.dist_sq && a.body < b.body);
            });
  return count;
}

std::size_t Boundaries::controlVelocities(const std::vector<Vec3>& x_pred,
                                          const std::vector<Vec3>& v_old, std::vector<Vec3>& v,
                                          std::vector<std::uint8_t>& in_contact_flag) const {
  const std::int64_t n = static_cast<std::int64_t>(x_pred.size());
  in_contact_flag.assign(x_pred.size(), 0);
  if (position_.empty()) return 0;
  std::size_t in_contact = 0;
#pragma omp parallel for schedule(static) reduction(+ : in_contact)
  for (std::int64_t i = 0; i < n; ++i) {
    std::array<Contact, kMaxContacts> contacts;
    const std::size_t count = findContacts(x_pred[i], contacts);
    if (count == 0) continue;
    ++in_contact;
    in_contact_flag[i] = 1;
    Vec3 vi = v[i];
    // Pass 0 sets each contact's full target (eq. 8-9). With several bodies, later
    // passes only remove approach velocity that an earlier contact's update re-created.
    const int passes = count > 1 ? 3 : 1;
    for (int pass = 0; pass < passes; ++pass) {
      for (std::size_t c = 0; c < count; ++c) {
        const BodySettings& body = bodies_[contacts[c].body].settings;
        const Vec3 nrm = normal_[contacts[c].sample];
        const Vec3 x_cp = position_[contacts[c].sample] + radius_ * nrm;
        const Vec3 v_cp =
            body.linear_velocity + body.angular_velocity.cross(x_cp - body.pose.position);
        const Vec3 vr = vi - v_cp;  // predicted relative velocity v*_r
        const double vn = vr.dot(nrm);
        // Restitution reflects only the approach speed at the start of the step.
        const double vn_old = std::min(0.0, (v_old[i] - v_cp).dot(nrm));
        const double target_n = vn > 0.0 ? vn : -body.restitution * vn_old;
        if (pass == 0) {
          const Vec3 vt = vr - vn * nrm;
          vi = v_cp + body.slip * vt + target_n * nrm;
        } else if (vn < target_n) {
          vi += (target_n - vn) * nrm;
        }
      }
    }
    v[i] = vi;
  }
  return in_contact;
}

void Boundaries::correctPositions(std::vector<Vec3>& x,
                                  const std::vector<std::uint8_t>& candidates) const {
  if (position_.empty()) return;
  const std::int64_t n = static_cast<std::int64_t>(x.size());
  const double rf = radius_;
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    if (!candidates[i]) continue;
    Vec3 xi = x[i];
    std::array<Contact, kMaxContacts> contacts;
    for (int pass = 0; pass < 4; ++pass) {
      const std::size_t count = findContacts(xi, contacts);
      bool moved = false;
      for (std::size_t c = 0; c < count; ++c) {
        const Vec3 nrm = normal_[contacts[c].sample];
        const Vec3 x_cp = position_[contacts[c].sample] + radius_ * nrm;
        const double d = rf - (xi - x_cp).dot(nrm);
        if (d > 0.0) {
          xi += d * nrm;
          moved = true;
        }
      }
      if (!moved) break;
    }
    x[i] = xi;
  }
}

std::size_t Boundaries::countInside(const std::vector<Vec3>& x) const {
  const std::int64_t n = static_cast<std::int64_t>(x.size());
  std::size_t inside = 0;
#pragma omp parallel for schedule(static) reduction(+ : inside)
  for (std::int64_t i = 0; i < n; ++i) {
    for (const Body& b : bodies_) {
      if (!b.world_bounds.contains(x[i])) continue;
      if (b.settings.shape->contains(b.settings.pose.toBody(x[i]))) {
        ++inside;
        break;
      }
    }
  }
  return inside;
}

double Boundaries::signedDistance(const Vec3& x) const {
  double best = std::numeric_limits<double>::infinity();
  for (const Body& b : bodies_)
    best = std::min(best, b.settings.shape->signedDistance(b.settings.pose.toBody(x)));
  return best;
}

}  // namespace wake
