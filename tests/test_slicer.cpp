#include <pipetile/error.h>
#include <pipetile/multires.h>
#include <pipetile/slicer.h>
#include <pipetile/validate.h>
#include <pipetile/volume_grid.h>

#include "test_util.h"

#include <glm/geometric.hpp>
#include <openvdb/tools/SignedFloodFill.h>

#include <cmath>

using namespace pipetile;

namespace {

// A sphere of world radius 10 about (20, 20, 20) on voxels of 1 x 1 x 2.5: an ellipsoid in index
// space. Narrow band of 3 world units.
Volume anisotropicSphere()
{
    openvdb::initialize();
    auto grid = openvdb::FloatGrid::create(3.0f);
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    grid->setName("sphere");
    openvdb::math::Mat4d m = openvdb::math::Mat4d::identity();
    m.preScale(openvdb::Vec3d(1.0, 1.0, 2.5));
    grid->setTransform(openvdb::math::Transform::createLinearTransform(m));
    auto acc = grid->getAccessor();
    for (int i = 0; i <= 40; ++i)
        for (int j = 0; j <= 40; ++j)
            for (int k = 0; k <= 16; ++k) {
                const double d =
                    std::sqrt((i - 20.0) * (i - 20.0) + (j - 20.0) * (j - 20.0) + (2.5 * k - 20.0) * (2.5 * k - 20.0)) -
                    10.0;
                if (std::abs(d) < 3.0) acc.setValue(openvdb::Coord(i, j, k), static_cast<float>(d));
            }
    openvdb::tools::signedFloodFill(grid->tree());
    return volumeFromGrid(grid, {}, "anisotropic sphere");
}

} // namespace

TEST(Slicer, AutoAxisOfTheAortaIsY)
{
    // Active box 46 x 103 x 23 voxels of 0.879 x 0.879 x 1.5 mm: 40 x 91 x 35 mm, longest along y.
    const Volume v = readVolume(test::realData("vmtk_aorta_ls.vdb"));
    const SlicePlan plan = planSlices(v, {Axis::Auto, 2.0});
    EXPECT_EQ(plan.axis, 1);
    // From y = 80 to 182 every 2 voxels: 52 planes.
    ASSERT_EQ(plan.positions.size(), 52u);
    EXPECT_EQ(plan.positions.front(), 80.0);
    EXPECT_EQ(plan.positions.back(), 182.0);
}

TEST(Slicer, PlaneAxesAreACyclicPermutation)
{
    // (u, v, w) = (y, z, x) for axis x, (z, x, y) for axis y, (x, y, z) for axis z: right-handed.
    EXPECT_EQ(planeToIndex(0, {1, 2}, 3), glm::dvec3(3, 1, 2));
    EXPECT_EQ(planeToIndex(1, {1, 2}, 3), glm::dvec3(2, 3, 1));
    EXPECT_EQ(planeToIndex(2, {1, 2}, 3), glm::dvec3(1, 2, 3));
}

TEST(Slicer, SpacingOutOfRangeIsAUsageError)
{
    const Volume v = readVolume(test::realData("ts_common_carotid_artery_left_ls.vdb"));
    EXPECT_THROW(planSlices(v, {Axis::Z, 0.0}), UsageError);
    EXPECT_THROW(planSlices(v, {Axis::Z, std::nan("")}), UsageError);
}

TEST(Slicer, FractionalPlanesInterpolateBetweenVoxelPlanes)
{
    // On the plane w = 7.25 a pixel reads 3/4 of plane 7 plus 1/4 of plane 8.
    const Volume v = anisotropicSphere();
    const SlicePlan plan = planSlices(v, {Axis::Z, 1.0});
    const SlicePlane p7(v, plan, 7.0), p8(v, plan, 8.0), pq(v, plan, 7.25);
    EXPECT_NEAR(pq.value(15, 20), 0.75 * p7.value(15, 20) + 0.25 * p8.value(15, 20), 1e-12);
}

TEST(Slicer, AnisotropicVoxelsGiveWorldSpaceVertices)
{
    // Slicing along z (2.5 world units per voxel), every vertex must land on the world sphere
    // of radius 10; the trilinear zero of an exact distance field errs by ~h^2/(8R) < 0.1.
    const Volume v = anisotropicSphere();
    MeshOptions options;
    options.slicing = {Axis::Z, 1.0};
    options.levels = 3;
    const Reconstruction r(v, options);
    const LevelMesh top = r.buildLevel(2);
    ASSERT_GT(top.mesh.vertices.size(), 100u);
    for (const glm::dvec3& p : top.mesh.vertices) EXPECT_NEAR(glm::length(p - glm::dvec3(20.0)), 10.0, 0.25);
    const Topology topo = checkTopology(top.mesh);
    EXPECT_TRUE(topo.closed() && topo.manifold() && topo.oriented() && topo.outward());
    EXPECT_EQ(topo.euler, 2);
    // Enclosed volume near 4/3 pi 10^3 = 4189: a polyhedron inscribed in slices loses some.
    EXPECT_NEAR(topo.signedVolume, 4188.8, 0.06 * 4188.8);
}

TEST(Slicer, FarApartSpheresCostTheirOwnSlicesNotTheGap)
{
    // Two spheres of radius 5 (narrow band 3: active voxels within 8 of each centre, in the leaf
    // slabs [c - 8, c + 7]), 1e8 and 2e9 voxels apart and at +-1.5e9 (extents past 2^31). Planes
    // go every 2 voxels from the low end of the box, only where leaves lie, padded by a spacing
    // and a voxel (3) either side: odd w in [c - 11, c + 10], i.e. 9 planes about the sphere at
    // 0 (w = -7 .. 9, the box starting at -7), 10 about one at 1e8 (c - 11 .. c + 7, the box ending
    // at c + 7), and for the pair at +-1.5e9 9 + 10 as well. The gap once cost 5e7 planes (70 s,
    // 5.7 GB), 2e9 ran out of memory, +-1.5e9 overflowed.
    for (const auto& [zA, zB] :
         std::vector<std::pair<int, int>>{{0, 100000000}, {0, 2000000000}, {-1500000000, 1500000000}}) {
        SCOPED_TRACE(std::to_string(zA) + " and " + std::to_string(zB));
        test::TempDir dir;
        test::writeFarSpheresVdb(dir.path("far.vdb"), {0, 0, zA}, {0, 0, zB});
        const Volume v = readVolume(dir.path("far.vdb"));
        const SlicePlan plan = planSlices(v, {Axis::Auto, 2.0});
        EXPECT_EQ(plan.axis, 2);
        ASSERT_EQ(plan.positions.size(), 19u);
        for (double w : plan.positions) EXPECT_LE(std::min(std::abs(w - zA), std::abs(w - zB)), 11.0) << w;
        // Each sphere is one closed tube of its own.
        MeshOptions options;
        options.levels = 2;
        const Reconstruction r(v, options);
        EXPECT_EQ(r.stats().tubes, 2);
        const Topology t = checkTopology(r.buildLevel(1).mesh);
        EXPECT_TRUE(t.closed() && t.manifold() && t.oriented());
        EXPECT_EQ(t.euler, 4);
        EXPECT_EQ(t.components, 2);
    }
}
