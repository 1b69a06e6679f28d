// Particles -> level set -> mesh with OpenVDB; see fluid_surface.hpp.
#include "surface/fluid_surface.hpp"

#include "surface/vdb_mesh.hpp"

#include <openvdb/tools/Morphology.h>
#include <openvdb/tools/TopologyToLevelSet.h>
#include <openvdb/tools/ValueTransformer.h>

#include <cmath>
#include <stdexcept>
#include <string>

namespace wake {
namespace {

void checkRange(const char* name, double value, double lo, double hi) {
  if (!(value >= lo && value <= hi))
    throw std::invalid_argument("surface." + std::string(name) + " must be in [" +
                                std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
                                std::to_string(value));
}

}  // namespace

void SurfaceSettings::check() const {
  checkRange("radius_factor", radius_factor, 0.5, 3.0);
  checkRange("voxel_factor", voxel_factor, 0.25, 2.0);
  checkRange("smoothing", smoothing, 0, 10);
  checkRange("adaptivity", adaptivity, 0.0, 1.0);
}

Aabb TriangleMeshF::bounds() const {
  Aabb b;
  for (const auto& v : vertices)
    b.extend(Vec3(v[0], v[1], v[2]));
  return b;
}

FluidSurface fluidSurface(const std::vector<Vec3>& positions, double particle_radius,
                          const SurfaceSettings& settings) {
  settings.check();
  if (!(particle_radius > 0.0) || !std::isfinite(particle_radius))
    throw std::invalid_argument("particle radius must be > 0, got " +
                                std::to_string(particle_radius));
  const double voxel = settings.voxel_factor * particle_radius;  // m
  // Particles 2r apart are 2 / voxel_factor voxels apart: dilating each particle's voxel
  // by `dilation` voxels joins them into one solid.
  const int dilation = static_cast<int>(std::ceil(1.0 / settings.voxel_factor));
  // topologyToLevelSet's zero crossing lies about dilation + 1 voxels beyond the outer
  // particles' voxel centres, half a voxel further on the low side of each axis than on
  // the high side (its distance field is rebuilt from the voxels' in/out step by
  // first-order upwind normalisation; measured over particle sizes, voxel sizes and
  // offsets in tests/surface): the grid is moved half a voxel up each axis and its zero
  // crossing by `shift`, to radius_factor r beyond the centres.
  const double shift = settings.radius_factor * particle_radius - (dilation + 1.0) * voxel;  // m
  const int half_width = 3 + static_cast<int>(std::ceil(std::abs(shift) / voxel));  // voxels
  FluidSurface out;
  if (positions.empty()) {
    out.level_set = openvdb::createLevelSet<openvdb::FloatGrid>(voxel, half_width);
  } else {
    const openvdb::MaskGrid::Ptr mask = openvdb::MaskGrid::create();
    mask->setTransform(openvdb::math::Transform::createLinearTransform(voxel));
    auto acc = mask->getAccessor();
    for (const Vec3& p : positions)
      acc.setValueOn(
          mask->transform().worldToIndexNodeCentered(openvdb::Vec3d(p.x(), p.y(), p.z())));
    // 26-neighbour dilation: each particle's voxel grows to a cube of 2 dilation + 1
    // voxels, so that neighbours on a diagonal join too (a 6-neighbour dilation leaves
    // holes between particles on a lattice).
    openvdb::tools::dilateActiveValues(mask->tree(), dilation, openvdb::tools::NN_FACE_EDGE_VERTEX,
                                       openvdb::tools::IGNORE_TILES);
    out.level_set = openvdb::tools::topologyToLevelSet(*mask, half_width, /*closingSteps=*/1,
                                                       /*dilation=*/0, settings.smoothing);
    out.level_set->transform().postTranslate(openvdb::Vec3d(0.5 * voxel));
    // Move the zero crossing out by `shift` (a distance field shifted is one).
    const float s = static_cast<float>(shift);
    openvdb::tools::foreach (
        out.level_set->beginValueOn(),
        [s](const openvdb::FloatGrid::ValueOnIter& it) { it.setValue(*it - s); });
  }
  out.level_set->setName("fluid");
  out.level_set->setGridClass(openvdb::GRID_LEVEL_SET);
  out.mesh = meshLevelSet(*out.level_set, settings.adaptivity);
  return out;
}

}  // namespace wake
