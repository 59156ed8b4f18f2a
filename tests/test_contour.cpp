#include <pipetile/contour.h>

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include <cmath>
#include <string>

using namespace pipetile;

namespace {

// A binary image: -1 inside, +1 outside, so bilinear interpolation puts the surface exactly on
// the crack between an inside and an outside pixel.
FieldImage binaryImage(glm::ivec2 origin, const std::vector<std::string>& rowsTopDown)
{
    FieldImage image;
    image.origin = origin;
    image.height = static_cast<int>(rowsTopDown.size());
    image.width = static_cast<int>(rowsTopDown[0].size());
    image.values.resize(static_cast<std::size_t>(image.width) * image.height);
    for (int y = 0; y < image.height; ++y)
        for (int x = 0; x < image.width; ++x)
            image.values[static_cast<std::size_t>(y) * image.width + x] =
                rowsTopDown[image.height - 1 - y][x] == '#' ? -1.0 : 1.0;
    return image;
}

FieldImage circleImage(glm::dvec2 center, double radius, int size)
{
    FieldImage image;
    image.width = image.height = size;
    image.values.resize(static_cast<std::size_t>(size) * size);
    for (int v = 0; v < size; ++v)
        for (int u = 0; u < size; ++u)
            image.values[static_cast<std::size_t>(v) * size + u] = std::hypot(u - center.x, v - center.y) - radius;
    return image;
}

std::string edgeString(const Contour& c)
{
    std::string s;
    for (EdgeType e : c.edges) s += std::string(s.empty() ? "" : " ") + toString(e);
    return s;
}

} // namespace

TEST(Contour, SinglePixelLoopIsFourCracksCounterclockwise)
{
    // One inside pixel: its border is 4 unit cracks, area +1, centroid at the pixel centre.
    const FieldImage image = binaryImage({5, 7}, {"#"});
    const std::vector<BoundaryLoop> loops = traceBoundaries(image);
    ASSERT_EQ(loops.size(), 1u);
    EXPECT_EQ(loops[0].corners.size(), 4u);
    EXPECT_DOUBLE_EQ(loops[0].area, 1.0);
    EXPECT_DOUBLE_EQ(loops[0].centroid.x, 5.0);
    EXPECT_DOUBLE_EQ(loops[0].centroid.y, 7.0);
}

TEST(Contour, RingHasOuterLoopAndHoleLoop)
{
    // A 5x5 square with the 3x3 middle removed: outer border area 25, hole border area -9.
    const FieldImage image = binaryImage({0, 0}, {"#####", "#...#", "#...#", "#...#", "#####"});
    std::vector<BoundaryLoop> loops = traceBoundaries(image);
    ASSERT_EQ(loops.size(), 2u);
    std::sort(loops.begin(), loops.end(), [](const BoundaryLoop& a, const BoundaryLoop& b) { return a.area > b.area; });
    EXPECT_DOUBLE_EQ(loops[0].area, 25.0);
    EXPECT_DOUBLE_EQ(loops[1].area, -9.0);
    EXPECT_TRUE(loops[1].hole());
    EXPECT_EQ(loops[1].corners.size(), 12u); // the hole's border: 4 sides of 3 cracks
}

TEST(Contour, DiagonalPixelsAreOneEightConnectedLoop)
{
    // Two pixels touching at a corner form one region (inside is 8-connected): 8 cracks, area 2.
    const FieldImage image = binaryImage({0, 0}, {".#", "#."});
    const std::vector<BoundaryLoop> loops = traceBoundaries(image);
    ASSERT_EQ(loops.size(), 1u);
    EXPECT_EQ(loops[0].corners.size(), 8u);
    EXPECT_DOUBLE_EQ(loops[0].area, 2.0);
}

TEST(Contour, CircleCrossingsLieWithinFiveHundredthsOfAVoxelOfTheRadius)
{
    // Exact distance to a circle of radius 10.3 sampled on pixels; bilinear interpolation of a
    // distance field with curvature 1/r errs by at most ~h^2/(8r) ~ 0.012 voxel.
    const glm::dvec2 c(20.37, 19.81);
    const double r = 10.3;
    const FieldImage image = circleImage(c, r, 41);
    const std::vector<BoundaryLoop> loops = traceBoundaries(image);
    ASSERT_EQ(loops.size(), 1u);
    for (int level = 0; level < 4; ++level) {
        const Contour contour = castRays(loops[0], centralPoint(loops[0]), RaySet{8, level}, image);
        ASSERT_EQ(contour.crossings.size(), static_cast<std::size_t>(8 << level)); // a circle is star-shaped
        EXPECT_TRUE(isUnambiguous(contour));
        EXPECT_EQ(contour.interpolationFallbacks, 0);
        for (const Crossing& x : contour.crossings) EXPECT_NEAR(glm::length(x.point - c), r, 0.05);
    }
}

TEST(Contour, RaysThroughCornersOfASymmetricSquareCrossOnce)
{
    // A 6x6 square centred on a pixel corner: the diagonal rays pass exactly through crack
    // corners. Each of the 16 rays must still cross exactly once (half-open crossing rule).
    const FieldImage image = binaryImage({0, 0}, {"######", "######", "######", "######", "######", "######"});
    const std::vector<BoundaryLoop> loops = traceBoundaries(image);
    ASSERT_EQ(loops.size(), 1u);
    EXPECT_DOUBLE_EQ(loops[0].centroid.x, 2.5);
    const Contour contour = castRays(loops[0], loops[0].centroid, RaySet{16, 0}, image);
    ASSERT_EQ(contour.crossings.size(), 16u);
    for (int x = 0; x < 16; ++x) EXPECT_EQ(contour.crossings[x].ray, x);
    EXPECT_EQ(countEdges(contour, EdgeType::Forward), 16);
}

TEST(Contour, FoldAcrossRayZeroGivesDownInDownOut)
{
    // A 7x7 square with a hook on its right (an open pocket between them). From the centre
    // (0.3, 0.2), ray 0 (+u) leaves the square at u = 3.5 (InOut), enters the hook at 6.5 (OutIn)
    // and leaves it at 7.5 (InOut); rays 1-3 cross the square once. The walk starts at the
    // outermost InOut of ray 0 and meets 6.5 then 3.5 going inward: D_I, D_O (DESIGN.md's worked
    // example, "if it meets r3 first"), then one F per sector.
    const FieldImage image = binaryImage({-3, -3}, {
        "#######.###", // v = 3: top bar of the hook, not joined to the square
        "#######...#",
        "#######...#",
        "#######...#", // v = 0: ray 0 crosses here
        "#######...#",
        "#######...#",
        "###########", // v = -3: bottom bar joins the hook to the square
    });
    const std::vector<BoundaryLoop> loops = traceBoundaries(image);
    ASSERT_EQ(loops.size(), 1u);
    const Contour contour = castRays(loops[0], {0.3, 0.2}, RaySet{4, 0}, image);
    EXPECT_EQ(edgeString(contour), "D_I D_O F F F F");
    ASSERT_EQ(contour.crossings.size(), 6u);
    EXPECT_DOUBLE_EQ(contour.crossings[0].point.x, 7.5);
    EXPECT_DOUBLE_EQ(contour.crossings[1].point.x, 6.5);
    EXPECT_DOUBLE_EQ(contour.crossings[2].point.x, 3.5);
    EXPECT_TRUE(isUnambiguous(contour)); // every sector keeps one F edge
    EXPECT_EQ(countEdges(contour, EdgeType::Forward) - countEdges(contour, EdgeType::Backward), 4);
}

TEST(Contour, FoldAcrossTwoRaysMakesAnAmbiguousSector)
{
    // A spiral-like arm: a 5x5 square plus an arm that leaves it upward at the right, turns left
    // above it, and comes back down on the left side past ray 2, then ends. Rays 1 (up) crosses
    // the square and the arm: 3 crossings; the contour still winds once: #F - #B = n.
    const FieldImage image = binaryImage({-2, -2}, {
        "#######", // v = 4
        "#.....#",
        "#.#####", // v = 2: square top row
        "#.#####",
        "#.#####", // v = 0
        "..#####",
        "..#####", // v = -2
    });
    const std::vector<BoundaryLoop> loops = traceBoundaries(image);
    ASSERT_EQ(loops.size(), 1u);
    const Contour contour = castRays(loops[0], {2.2, 0.1}, RaySet{8, 0}, image);
    ASSERT_FALSE(contour.crossings.empty());
    EXPECT_EQ(countEdges(contour, EdgeType::Forward) - countEdges(contour, EdgeType::Backward), 8);
    EXPECT_GT(countEdges(contour, EdgeType::Backward), 0); // the arm runs backward across a sector
    EXPECT_FALSE(isUnambiguous(contour));
}

TEST(Contour, CentralPointOfACShapeIsInside)
{
    // A C whose centroid falls in its mouth: the central point must still be enclosed.
    const FieldImage image = binaryImage({0, 0}, {
        "#########",
        "#########",
        "##.......",
        "##.......",
        "##.......",
        "#########",
        "#########",
    });
    const std::vector<BoundaryLoop> loops = traceBoundaries(image);
    ASSERT_EQ(loops.size(), 1u);
    EXPECT_FALSE(encloses(loops[0], loops[0].centroid)); // (3.5, 3): in the mouth
    const glm::dvec2 center = centralPoint(loops[0]);
    EXPECT_TRUE(encloses(loops[0], center));
    EXPECT_TRUE(image.inside(static_cast<int>(std::lround(center.x)), static_cast<int>(std::lround(center.y))));
}

TEST(Contour, LevelsNestBitForBit)
{
    // Ray x of level L is ray 2x of level L+1: the same crossing, computed the same way.
    const FieldImage image = circleImage({15.2, 14.6}, 9.1, 31);
    const BoundaryLoop loop = traceBoundaries(image).at(0);
    const glm::dvec2 center = centralPoint(loop);
    const Contour coarse = castRays(loop, center, RaySet{6, 1}, image);
    const Contour fine = castRays(loop, center, RaySet{6, 3}, image);
    ASSERT_EQ(fine.crossings.size(), 4 * coarse.crossings.size());
    for (std::size_t i = 0; i < coarse.crossings.size(); ++i) {
        EXPECT_EQ(coarse.crossings[i].point.x, fine.crossings[4 * i].point.x);
        EXPECT_EQ(coarse.crossings[i].point.y, fine.crossings[4 * i].point.y);
    }
}
