#include "coupling/boundary.hpp"

#include <Eigen/Cholesky>

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

namespace wake {

namespace {

/// Share of a no-slip wall's viscous shear that a wall of slip eps exerts: the wall with
/// Navier slip length b = eps / (1 - eps) * 2H (2H: the kernel support, 4 particle radii
/// at H = one spacing) over the first fluid layer, which lies one radius r from the
/// surface: r / (r + b) = (1 - eps) / (1 + 3 eps).
double wallShearFactor(double eps) {
  return (1.0 - eps) / (1.0 + 3.0 * eps);
}

}  // namespace

double Boundaries::flatLatticeKernelSum(const CubicSplineKernel& kernel, double s, double height) {
  const int reach = static_cast<int>(std::ceil(kernel.supportRadius() / s)) + 1;
  const double rise = (height / s) * (height / s);
  double sum = 0.0;
  for (int i = -reach; i <= reach; ++i)
    for (int j = -reach; j <= reach; ++j)
      sum += kernel.value(s * std::sqrt(rise + i * i + j * j));
  return sum;
}

Boundaries::Boundaries(const FluidParams& fluid, const Aabb& domain, double contact_fraction)
    : fluid_(fluid),
      kernel_(fluid.smoothingLength()),
      domain_(domain),
      spacing_(fluid.spacing()),
      radius_(fluid.particle_radius),
      contact_distance_(contact_fraction * fluid.particle_radius),
      volume_scale_(spacing_ * spacing_ * spacing_ * flatLatticeKernelSum(kernel_, spacing_, 0.0)) {
  if (!(contact_fraction > 0.0 && contact_fraction <= 1.0))
    throw std::invalid_argument("Boundaries: contact_fraction must be in (0, 1]");
}

std::size_t Boundaries::addBody(const BodySettings& settings) {
  if (finalized_) throw std::logic_error("Boundaries::addBody after finalize()");
  if (!settings.shape) throw std::invalid_argument("body '" + settings.name + "' has no shape");
  Body b;
  b.settings = settings;
  // Infinite shapes are sampled within the domain (grown by a support for the density).
  const Aabb clip = transformBounds(domain_.grown(fluid_.supportRadius()), settings.pose, false);
  settings.shape->sample(spacing_, radius_, clip, b.local);
  b.sample_count = b.local.size();
  for (const Vec3& p : b.local.position)
    b.extent = std::max(b.extent, p.norm() + radius_);
  b.start = frameAt(b, {settings.pose, settings.linear_velocity, settings.angular_velocity});
  shear_factor_.push_back(wallShearFactor(settings.slip));
  any_shear_ = any_shear_ || settings.slip < 1.0;
  bodies_.push_back(std::move(b));
  return bodies_.size() - 1;
}

BodyFrame Boundaries::frameAt(const Body& b, const RigidState& state) const {
  BodyFrame f;
  f.pose = state.pose;
  f.rotation = state.pose.orientation.toRotationMatrix();
  f.linear_velocity = state.linear_velocity;
  f.angular_velocity = state.angular_velocity;
  const Aabb clip = transformBounds(domain_, state.pose, false);
  f.world_bounds = transformBounds(b.settings.shape->bounds(clip), state.pose, true);
  f.contact_bounds = f.world_bounds.grown(radius_);
  if (b.moving >= 0) {
    const SampleSet& set = moving_[b.moving].samples;
    f.world_reach = set.position.empty()
                        ? Aabb()
                        : transformBounds(set.reach_box, state.pose, /*to_world=*/true);
  }
  return f;
}

void Boundaries::place(const std::vector<RigidState>& states, BodyPlacement& out) const {
  if (!finalized_) throw std::logic_error("Boundaries::place before finalize()");
  if (states.size() != bodies_.size())
    throw std::invalid_argument("Boundaries::place: " + std::to_string(states.size()) +
                                " states for " + std::to_string(bodies_.size()) + " bodies");
  out.frames.resize(bodies_.size());
  out.moving_reach = Aabb();
  for (std::size_t bi = 0; bi < bodies_.size(); ++bi) {
    const Body& b = bodies_[bi];
    if (b.moving < 0) {
      out.frames[bi] = b.start;
      continue;
    }
    out.frames[bi] = frameAt(b, states[bi]);
    out.moving_reach.extend(out.frames[bi].world_reach);
  }
  // The bins: up to kMaxCellsPerAxis cells along each axis of moving_reach.
  BodyPlacement::MovingBins& bins = out.bins;
  bins.words = (moving_.size() + 63) / 64;
  bins.mask.clear();
  if (out.moving_reach.empty()) return;
  const Vec3 extent = out.moving_reach.max - out.moving_reach.min;
  bins.origin = out.moving_reach.min;
  for (int k = 0; k < 3; ++k) {
    const double cell =
        std::max(extent[k] / BodyPlacement::MovingBins::kMaxCellsPerAxis, kernel_.supportRadius());
    bins.dims[k] = std::max(1, std::min(BodyPlacement::MovingBins::kMaxCellsPerAxis,
                                        static_cast<int>(std::ceil(extent[k] / cell))));
    bins.inv_cell[k] = 1.0 / cell;
  }
  bins.mask.assign(std::size_t(bins.dims.prod()) * bins.words, 0);
  for (std::size_t m = 0; m < moving_.size(); ++m) {
    const Aabb& reach = out.frames[moving_[m].body].world_reach;
    if (reach.empty()) continue;
    int lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
      lo[k] = bins.coord(reach.min, k);
      hi[k] = bins.coord(reach.max, k);
    }
    const std::uint64_t bit = std::uint64_t(1) << (m % 64);
    for (int z = lo[2]; z <= hi[2]; ++z)
      for (int y = lo[1]; y <= hi[1]; ++y)
        for (int x = lo[0]; x <= hi[0]; ++x)
          bins.mask[((std::size_t(z) * bins.dims[1] + y) * bins.dims[0] + x) * bins.words +
                    m / 64] |= bit;
  }
}

BodyPlacement Boundaries::placeAtStart() const {
  std::vector<RigidState> states;
  for (const Body& b : bodies_)
    states.push_back({b.settings.pose, b.settings.linear_velocity, b.settings.angular_velocity});
  BodyPlacement at;
  place(states, at);
  return at;
}

void Boundaries::buildSet(SampleSet& set, const Aabb& box, const std::vector<Vec3>& pos,
                          const std::vector<Vec3>& nrm, const std::vector<std::uint32_t>& body,
                          bool flags, const std::vector<double>* area) {
  // Cells of half the support: the density share searches 2 cells around a particle,
  // contacts (reach r_f + r_b = half the support) only 1. Too many cells: full support.
  const double support = kernel_.supportRadius();
  const Aabb grid_box = box.grown(support);
  if (UniformGrid::cellsFor(grid_box, 0.5 * support) <= double(UniformGrid::kMaxCells))
    set.grid = UniformGrid(grid_box, 0.5 * support, UniformGrid::kMaxCells, 2);
  else
    set.grid = UniformGrid(grid_box, support, UniformGrid::kMaxCells, 1);
  auto cellsToCover = [&](double distance) {
    return std::max(1, static_cast<int>(std::ceil(distance / set.grid.cellSize() - 1e-12)));
  };
  set.density_reach = cellsToCover(support);
  set.sample_reach = cellsToCover(2.0 * radius_);
  // A centre within r of the surface is within r + r_b of a sample's centre along the
  // normal and at most about a spacing beside it (between samples): 4 r covers it.
  set.contact_reach = cellsToCover(4.0 * radius_);
  set.reach_box = grid_box;

  std::vector<std::uint32_t> order;
  // A grid of many more cells than samples (the static set's, over the tank's inside)
  // keeps the starts only where its rows hold samples: the same order and ranges.
  if (double(set.grid.cellCount()) > kSparseCellsPerSample * double(pos.size()))
    set.grid.sortSparse(pos, order);
  else
    set.grid.sort(pos, order);
  const std::size_t total = pos.size();
  set.position.resize(total);
  set.normal.resize(total);
  set.body.resize(total);
  set.area.assign(area ? total : 0, 0.0);
  for (std::size_t k = 0; k < total; ++k) {
    if (area) set.area[k] = (*area)[order[k]];
    set.position[k] = pos[order[k]];
    set.normal[k] = nrm[order[k]];
    set.body[k] = body[order[k]];
  }

  // Volumes (Akinci et al. 2012), normalised so that a flat wall sampled at the fluid
  // spacing stands for exactly one missing fluid layer: V_k = s^3 S_flat / sum_l W_kl.
  // Samples of an opposite face (a thin wall's other side) are not neighbours.
  set.volume.assign(total, 0.0);
  const double support_sq = support * support;
  const std::int64_t n = static_cast<std::int64_t>(total);
#pragma omp parallel for schedule(static)
  for (std::int64_t k = 0; k < n; ++k) {
    double sum = 0.0;
    const Vec3 xk = set.position[k], nk = set.normal[k];
    set.grid.forEachRangeWithin(xk, set.density_reach, [&](std::uint32_t lo, std::uint32_t hi) {
      for (std::uint32_t l = lo; l < hi; ++l) {
        const double d_sq = (xk - set.position[l]).squaredNorm();
        if (d_sq < support_sq && nk.dot(set.normal[l]) > -0.5)
          sum += kernel_.value(std::sqrt(d_sq));
      }
    });
    set.volume[k] = volume_scale_ / sum;
  }

  // Flag the cells from which a sample can be within the kernel support or contact reach.
  set.near.clear();
  if (!flags) return;
  set.near.assign(set.grid.cellCount(), 0);
  markNear(set, set.density_reach, kNearDensity, set.near);
  markNear(set, set.contact_reach, kNearContact, set.near);
}

void Boundaries::balanceAreas(SurfaceSamples& samples) {
  // The smallest change of the areas (least squares, A_k - lambda . n_k) for which
  // sum_k A_k n_k = 0, as it is for the exact closed surface: the sampling's own imbalance
  // (a Fibonacci sphere's, a compound's trimmed children) times the fluid's whole pressure
  // would push a body at rest.
  Vec3 imbalance = Vec3::Zero();
  Mat3 normals = Mat3::Zero();
  for (std::size_t k = 0; k < samples.size(); ++k) {
    imbalance += samples.area[k] * samples.normal[k];
    normals += samples.normal[k] * samples.normal[k].transpose();
  }
  const Eigen::LDLT<Mat3> ldlt(normals);
  if (!(ldlt.rcond() > 1e-9)) return;  // normals in a plane or a line: nothing to balance
  const Vec3 lambda = ldlt.solve(imbalance);
  for (std::size_t k = 0; k < samples.size(); ++k)
    samples.area[k] = std::max(0.0, samples.area[k] - lambda.dot(samples.normal[k]));
}

void Boundaries::markNear(const SampleSet& set, int reach, std::uint8_t bit,
                          std::vector<std::uint8_t>& near) {
  const Eigen::Vector3i dims = set.grid.dims();
  for (const Vec3& p : set.position) {
    const Eigen::Vector3i c = set.grid.cellCoord(p);
    for (int z = std::max(0, c[2] - reach); z <= std::min(dims[2] - 1, c[2] + reach); ++z)
      for (int y = std::max(0, c[1] - reach); y <= std::min(dims[1] - 1, c[1] + reach); ++y)
        for (int x = std::max(0, c[0] - reach); x <= std::min(dims[0] - 1, c[0] + reach); ++x)
          near[set.grid.cellIndex(Eigen::Vector3i(x, y, z))] |= bit;
  }
}

template <class Inside>
void Boundaries::markInteriorRuns(SampleSet& set, Inside&& inside) {
  // A cell beyond contact reach of every sample is wholly inside or wholly outside each
  // body (a surface passes within a spacing of its samples), and so is a run of such
  // cells along x (connected, and no surface passes through it): the centre of its first
  // cell tells which, one shape query per run.
  const Eigen::Vector3i dims = set.grid.dims();
  const std::int64_t rows = std::int64_t(dims[1]) * dims[2];
#pragma omp parallel for schedule(dynamic, 64)
  for (std::int64_t row = 0; row < rows; ++row) {
    const int y = static_cast<int>(row % dims[1]), z = static_cast<int>(row / dims[1]);
    std::uint8_t* flags = set.near.data() + row * dims[0];
    for (int x = 0; x < dims[0];) {
      if (flags[x] & kNearContact) {
        ++x;
        continue;
      }
      int end = x;
      while (end < dims[0] && !(flags[end] & kNearContact))
        ++end;
      if (inside(set.grid.cellCenter(Eigen::Vector3i(x, y, z))))
        for (int k = x; k < end; ++k)
          flags[k] |= kInterior;
      x = end;
    }
  }
}

void Boundaries::markInterior(SampleSet& set, const Body& body) {
  markInteriorRuns(set, [&](const Vec3& p) { return body.settings.shape->contains(p); });
}

void Boundaries::markStaticInterior() {
  // Cells beyond contact reach of every static sample: inside some static body or outside
  // all. The exact shapes alone: a body's world_bounds are clipped to the domain (a plane's
  // half space), so a run of cells that starts beyond the domain would take its first
  // cell's "outside the bounds" for the whole run (a particle 20 cm inside a ground plane
  // was not counted).
  markInteriorRuns(static_, [&](const Vec3& p) {
    for (std::uint32_t b : static_bodies_) {
      const Body& body = bodies_[b];
      if (body.settings.shape->contains(body.start.pose.toBody(p))) return true;
    }
    return false;
  });
}

void Boundaries::finalize() {
  if (finalized_) throw std::logic_error("Boundaries::finalize called twice");
  finalized_ = true;
  // Static bodies: one world-space set over the domain.
  std::vector<Vec3> pos, nrm;
  std::vector<std::uint32_t> owner;
  for (std::size_t bi = 0; bi < bodies_.size(); ++bi) {
    Body& b = bodies_[bi];
    if (b.settings.moves()) continue;
    for (std::size_t k = 0; k < b.local.size(); ++k) {
      pos.push_back(b.settings.pose.toWorld(b.local.position[k]));
      nrm.push_back(b.settings.pose.rotate(b.local.normal[k]));
      owner.push_back(static_cast<std::uint32_t>(bi));
    }
    b.local = {};  // its memory too
  }
  for (std::size_t bi = 0; bi < bodies_.size(); ++bi)
    if (!bodies_[bi].settings.moves()) static_bodies_.push_back(static_cast<std::uint32_t>(bi));
  if (!pos.empty()) {
    // The static set's grid covers what lies within kStaticMargin of its samples (and of
    // the domain): every query a particle makes of them. Beyond it no static sample is
    // that close (the queries check reach_box first); the domain's empty space costs no
    // cells (a domain-sized grid took 6 bytes per cell of it).
    Aabb near_samples;
    for (const Vec3& p : pos)
      near_samples.extend(p);
    const double margin = kStaticMargin * kernel_.supportRadius();
    const Aabb around = near_samples.grown(margin), domain = domain_.grown(margin);
    Aabb box{around.min.cwiseMax(domain.min), around.max.cwiseMin(domain.max)};
    if (box.empty()) box = around;  // every sample far outside the domain
    buildSet(static_, box, pos, nrm, owner, /*flags=*/true);
    markStaticInterior();
  }
  // Moving bodies: one body-space set each.
  for (std::size_t bi = 0; bi < bodies_.size(); ++bi) {
    Body& b = bodies_[bi];
    if (!b.settings.moves()) continue;
    MovingBody m;
    m.body = static_cast<std::uint32_t>(bi);
    Aabb box;
    for (const Vec3& p : b.local.position)
      box.extend(p);
    if (std::isfinite(b.settings.shape->volume())) balanceAreas(b.local);
    if (!box.empty()) {
      buildSet(m.samples, box, b.local.position, b.local.normal,
               std::vector<std::uint32_t>(b.local.size(), m.body), /*flags=*/true, &b.local.area);
      markInterior(m.samples, b);
    }
    b.local = {};  // its memory too
    b.moving = static_cast<std::int32_t>(moving_.size());
    moving_.push_back(std::move(m));
    b.start =
        frameAt(b, {b.settings.pose, b.settings.linear_velocity, b.settings.angular_velocity});
  }
}

std::size_t Boundaries::sampleCount() const {
  std::size_t total = static_.position.size();
  for (const MovingBody& m : moving_)
    total += m.samples.position.size();
  return total;
}

void Boundaries::bodySamples(std::size_t b, std::vector<Vec3>& position,
                             std::vector<Vec3>& normal) const {
  position.clear();
  normal.clear();
  const Body& body = bodies_[b];
  if (body.moving >= 0) {
    const SampleSet& set = moving_[body.moving].samples;
    position = set.position;
    normal = set.normal;
    return;
  }
  const Pose& pose = body.start.pose;
  for (std::size_t k = 0; k < static_.position.size(); ++k) {
    if (static_.body[k] != b) continue;
    position.push_back(pose.toBody(static_.position[k]));
    normal.push_back(pose.orientation.conjugate() * static_.normal[k]);
  }
}

void Boundaries::worldSamples(const BodyPlacement& at, std::vector<Vec3>& position,
                              std::vector<Vec3>& normal, std::vector<double>& volume,
                              std::vector<std::uint32_t>& body) const {
  position = static_.position;
  normal = static_.normal;
  volume = static_.volume;
  body = static_.body;
  for (const MovingBody& m : moving_) {
    const Pose& pose = at[m.body].pose;
    for (std::size_t k = 0; k < m.samples.position.size(); ++k) {
      position.push_back(pose.toWorld(m.samples.position[k]));
      normal.push_back(pose.rotate(m.samples.normal[k]));
      volume.push_back(m.samples.volume[k]);
      body.push_back(m.body);
    }
  }
}

template <class F>
void Boundaries::forEachBodyDistance(const Vec3& x, const BodyPlacement& at, F&& f) const {
  if (nearStatic(x, kNearContact)) {
    for (const std::uint32_t bi : static_bodies_) {
      const BodyFrame& frame = at[bi];
      if (frame.contact_bounds.contains(x))
        f(bi, true, bodies_[bi].settings.shape->signedDistance(frame.pose.toBody(x)));
    }
  }
  at.forEachMovingNear(x, [&](std::size_t mi) {
    const MovingBody& m = moving_[mi];
    const BodyFrame& frame = at[m.body];
    if (!frame.world_reach.contains(x)) return true;
    const Vec3 p = frame.rotation.transpose() * (x - frame.pose.position);
    if (m.samples.reach_box.contains(p) &&
        (m.samples.near[m.samples.grid.cellIndex(p)] & (kNearContact | kInterior)))
      f(m.body, false, bodies_[m.body].settings.shape->signedDistance(p));
    return true;
  });
}

std::size_t Boundaries::findContacts(const Vec3& x, const BodyPlacement& at,
                                     std::array<Contact, kMaxContacts>& out) const {
  // A body is in contact when x is closer than the contact distance to its exact surface:
  // the same test as the position correction, so that velocity control stops fluid before
  // the correction would have to move it (a correction of a particle that control let
  // through does work against the pressure: it pumps energy into the fluid). Sample cells
  // only say where a surface may be near.
  const double rf = contact_distance_;
  std::size_t count = 0;
  auto offer = [&](std::uint32_t body, double d) {
    if (!(d < rf)) return;
    if (count < kMaxContacts) {
      out[count].body = body;
      out[count].distance = d;
      ++count;
      return;
    }
    // More bodies than slots: replace the farthest contact if this one is nearer.
    std::size_t far = 0;
    for (std::size_t q = 1; q < count; ++q)
      if (out[q].distance > out[far].distance) far = q;
    if (d < out[far].distance) out[far].body = body, out[far].distance = d;
  };
  forEachBodyDistance(x, at, [&](std::uint32_t body, bool, double d) { offer(body, d); });
  if (count == 0) return 0;
  std::sort(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(count),
            [](const Contact& a, const Contact& b) {
              return a.distance < b.distance || (a.distance == b.distance && a.body < b.body);
            });
  std::size_t kept = 0;
  for (std::size_t c = 0; c < count; ++c)
    if (contactGeometry(x, at, out[c])) out[kept++] = out[c];
  return kept;
}

bool Boundaries::contactGeometry(const Vec3& x, const BodyPlacement& at, Contact& ct) const {
  // n = grad SDF at x, x_cp = x - SDF(x) n: edges and corners push the fluid the
  // shortest way out.
  const Body& b = bodies_[ct.body];
  const BodyFrame& frame = at[ct.body];
  const Shape& shape = *b.settings.shape;
  const Vec3 p = frame.rotation.transpose() * (x - frame.pose.position);
  const double d = ct.distance;
  const Vec3 grad = sdfGradient(shape, p, 1e-3 * radius_);
  if (!grad.isZero() && std::isfinite(d)) {
    ct.normal = frame.rotation * grad;
    ct.point = x - d * ct.normal;
    return true;
  }
  // No gradient (x on a medial point, e.g. midway in a slot of the body): the nearest
  // sample's normal and surface point.
  const SampleSet& set = b.moving < 0 ? static_ : moving_[b.moving].samples;
  const Vec3 q = b.moving < 0 ? x : p;
  double best = std::numeric_limits<double>::infinity();
  std::uint32_t nearest = 0;
  set.grid.forEachRangeWithin(q, set.contact_reach, [&](std::uint32_t lo, std::uint32_t hi) {
    for (std::uint32_t k = lo; k < hi; ++k) {
      const double d_sq = (q - set.position[k]).squaredNorm();
      if (set.body[k] == ct.body && (d_sq < best || (d_sq == best && k < nearest)))
        best = d_sq, nearest = k;
    }
  });
  if (!std::isfinite(best)) return false;
  ct.normal = frame.rotation * set.normal[nearest];
  ct.point = frame.rotation * (set.position[nearest] + radius_ * set.normal[nearest]);
  if (b.moving >= 0) ct.point += frame.pose.position;
  return true;
}

Boundaries::Clearance Boundaries::clearance(const Vec3& x, const BodyPlacement& at) const {
  Clearance c{radius_, radius_};
  forEachBodyDistance(x, at, [&](std::uint32_t, bool is_static, double d) {
    c.all = std::min(c.all, d);
    if (is_static) c.walls = std::min(c.walls, d);
  });
  return c;
}

std::size_t Boundaries::countInside(const std::vector<Vec3>& x, const BodyPlacement& at) const {
  const std::int64_t n = static_cast<std::int64_t>(x.size());
  const bool has_static = !static_.position.empty();
  // A body without samples has no reach box in at.moving_reach: then every particle looks.
  bool all_sampled = true;
  for (const MovingBody& m : moving_)
    all_sampled = all_sampled && !m.samples.position.empty();
  // Exactly inside body b (its exact shape), within its bounds.
  auto in_body = [&](std::size_t b, const Vec3& xi) {
    const BodyFrame& frame = at[b];
    return frame.world_bounds.contains(xi) &&
           bodies_[b].settings.shape->contains(frame.pose.toBody(xi));
  };
  std::size_t inside = 0;
#pragma omp parallel for schedule(static) reduction(+ : inside)
  for (std::int64_t i = 0; i < n; ++i) {
    const Vec3& xi = x[i];
    bool in = false;
    // A cell beyond contact reach of every sample lies wholly inside or wholly outside
    // (its kInterior flag): only the cells near a surface need the exact shapes.
    if (has_static) {
      // Outside the grid's box (no static sample within kStaticMargin supports): the
      // exact shapes, which their bounds reject but for a body the samples do not enclose
      // (a shape clipped to the domain).
      const std::uint8_t flags = staticFlags(xi, kNearContact);
      if (flags & kNearContact) {
        for (std::uint32_t b : static_bodies_)
          if ((in = in_body(b, xi))) break;
      } else {
        in = (flags & kInterior) != 0;
      }
    }
    // Moving body m: inside it, when x lies within its bounds. Beyond its samples' reach
    // box (and so beyond its world_reach: what the bins tell) outside, the samples
    // enclosing it; a body without samples asks its shape.
    auto in_moving = [&](std::size_t m) {
      const MovingBody& body = moving_[m];
      const BodyFrame& frame = at[body.body];
      if (!frame.world_bounds.contains(xi)) return false;
      const SampleSet& set = body.samples;
      const Vec3 p = frame.pose.toBody(xi);
      if (set.position.empty()) return bodies_[body.body].settings.shape->contains(p);
      if (!set.reach_box.contains(p)) return false;
      const std::uint8_t flags = set.near[set.grid.cellIndex(p)];
      return flags & kNearContact ? bodies_[body.body].settings.shape->contains(p)
                                  : (flags & kInterior) != 0;
    };
    if (!in && all_sampled) {
      at.forEachMovingNear(xi, [&](std::size_t m) { return !(in = in_moving(m)); });
    } else {
      for (std::size_t m = 0; m < moving_.size() && !in; ++m)
        in = in_moving(m);
    }
    if (in) ++inside;
  }
  return inside;
}

double Boundaries::signedDistance(const Vec3& x, const BodyPlacement& at) const {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t b = 0; b < bodies_.size(); ++b)
    best = std::min(best, bodies_[b].settings.shape->signedDistance(at[b].pose.toBody(x)));
  return best;
}

void Boundaries::addContactPressure(const BodyPlacement& at, const Vec3& gravity,
                                    SamplePressure& pressure, bool wet_too) const {
  const double reach = radius_ + radius_;  // the gap no particle crosses: 2 r
  const double rho0 = fluid_.rest_density;
  std::vector<std::uint32_t> contact, level, next;
  // 0 neither, 1 known (wet, not facing a surface), 2 contact not yet reached, 4 queued
  // for the next level, 3 reached
  std::vector<std::uint8_t> state, source;
  std::vector<double> value;  // P^s (Pa) of the known and the reached
  pressure.touching.resize(moving_.size() + 1);
  for (std::size_t m = 0; m < moving_.size(); ++m) {
    const MovingBody& mb = moving_[m];
    if (!bodies_[mb.body].settings.twoWay()) continue;
    const SampleSet& set = mb.samples;
    std::vector<double>& force = pressure.surface_force[m + 1];
    const std::vector<std::uint8_t>& wet = pressure.wet[m + 1];
    const std::size_t n = set.position.size();
    if (force.size() != n || wet.size() != n)
      throw std::logic_error("Boundaries::addContactPressure before computeSamplePressure");
    const BodyFrame& frame = at[mb.body];
    // The contact samples: those whose surface point another body's surface is within
    // reach of, dry, or wet and facing it (a film thinner than a particle's diameter,
    // whose few squeezed particles are no measure of its pressure). The other wet samples
    // are the known ones.
    contact.clear();
    source.assign(n, 0);
    std::vector<std::uint8_t>& touch = pressure.touching[m + 1];
    touch.assign(wet_too ? n : 0, 0);
    std::size_t known = 0;
    for (std::size_t k = 0; k < n; ++k) {
      const Vec3 normal = frame.rotation * set.normal[k];
      const Vec3 s = frame.rotation * set.position[k] + frame.pose.position + radius_ * normal;
      std::array<std::pair<std::uint32_t, double>, kMaxContacts> near;
      std::size_t near_count = 0;
      forEachBodyDistance(s, at, [&](std::uint32_t body, bool, double d) {
        if (body != mb.body && d < reach && near_count < near.size())
          near[near_count++] = {body, d};
      });
      bool facing = false;
      if (wet[k] && near_count > 0) {
        // Facing: the other surface's distance falls along the sample's normal.
        const double step = 0.25 * radius_;
        forEachBodyDistance(s + step * normal, at, [&](std::uint32_t body, bool, double d) {
          for (std::size_t q = 0; q < near_count; ++q)
            if (near[q].first == body && d - near[q].second < -0.5 * step) facing = true;
        });
      }
      if (wet[k] && !facing) {
        source[k] = 1;
        ++known;
      }
      if (near_count == 0) continue;
      if (wet_too) touch[k] = 1;
      if (!source[k]) contact.push_back(static_cast<std::uint32_t>(k));
    }
    if (contact.empty() || known == 0) continue;
    state.assign(n, 0);
    value.assign(n, 0.0);
    for (std::size_t k = 0; k < n; ++k)
      if (source[k]) {
        state[k] = 1;
        value[k] = force[k] / set.area[k];
      }
    for (const std::uint32_t k : contact)
      state[k] = 2;
    // Gravity in the body's frame: the hydrostatic step from one surface point to another.
    const Vec3 g = frame.rotation.transpose() * gravity;
    auto surface = [&](std::uint32_t k) { return Vec3(set.position[k] + radius_ * set.normal[k]); };
    // A sample's neighbours on the surface: within 1.5 sample spacings (3 r; the spacing is
    // 2 r), so that a face's square lattice links its diagonals too. The grid is searched
    // over the kernel support's cells, so the link may not be longer than the support.
    const double link = std::min(1.5 * reach, kernel_.supportRadius()), link_sq = link * link;
    auto forEachLinked = [&](std::uint32_t k, auto&& f) {
      const Vec3& p = set.position[k];
      set.grid.forEachRangeInSphere(p, set.density_reach, link, false,
                                    [&](std::uint32_t lo, std::uint32_t hi) {
                                      for (std::uint32_t j = lo; j < hi; ++j)
                                        if (j != k && (p - set.position[j]).squaredNorm() < link_sq)
                                          f(j);
                                    });
    };
    // Level by level from the wetted rim: each level reads only the levels before it, in
    // the samples' order (the same bits on any number of threads).
    level.clear();
    for (const std::uint32_t k : contact) {
      bool rim = false;
      forEachLinked(k, [&](std::uint32_t j) {
        if (state[j] == 1) rim = true;
      });
      if (rim) level.push_back(k);
    }
    while (!level.empty()) {
      for (const std::uint32_t k : level) {
        double sum = 0.0;
        int count = 0;
        const Vec3 sk = surface(k);
        forEachLinked(k, [&](std::uint32_t j) {
          if (state[j] != 1 && state[j] != 3) return;
          sum += value[j] + rho0 * g.dot(sk - surface(j));
          ++count;
        });
        value[k] = count > 0 ? sum / count : 0.0;
      }
      for (const std::uint32_t k : level)
        state[k] = 3;
      next.clear();
      for (const std::uint32_t k : level)
        forEachLinked(k, [&](std::uint32_t j) {
          if (state[j] == 2) {
            state[j] = 4;  // queued
            next.push_back(j);
          }
        });
      std::sort(next.begin(), next.end());
      level.swap(next);
    }
    for (const std::uint32_t k : contact)
      if (state[k] == 3) force[k] = std::max(0.0, value[k]) * set.area[k];
  }
}

}  // namespace wake
