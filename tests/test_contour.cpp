#include <pipetile/detail/field_image.h>
#include <pipetile/contour.h>
#include <pipetile/error.h>

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include <cmath>
#include <string>

using namespace pipetile;
using pipetile::detail::FieldImage;

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
    const FieldImage image =
        binaryImage({-3, -3}, {
                                  "#######.###", // v = 3: top bar of the hook, not joined to the square
                                  "#######...#", "#######...#",
                                  "#######...#", // v = 0: ray 0 crosses here
                                  "#######...#", "#######...#",
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

TEST(Contour, RadialProfileIsWhereTheRaysMeetThePolygonFirstAndLast)
{
    // The profile intersects the same polygon as castRays does (crackT: the distance from the
    // centre to the polygon along the ray), without root finding: per direction, the nearest and
    // farthest crackT of that ray's crossings. On the hook above ray 0 meets the polygon at 3.5,
    // 6.5 and 7.5 (so 3.2 and 7.2 from the centre); on a circle every ray meets it once.
    const FieldImage hook = binaryImage({-3, -3}, {"#######.###", "#######...#", "#######...#", "#######...#",
                                                   "#######...#", "#######...#", "###########"});
    const FieldImage circle = circleImage({20.37, 19.81}, 10.3, 41);
    for (const FieldImage* image : {&hook, &circle}) {
        const std::vector<BoundaryLoop> loops = traceBoundaries(*image);
        ASSERT_EQ(loops.size(), 1u);
        const glm::dvec2 center = image == &hook ? glm::dvec2(0.3, 0.2) : centralPoint(loops[0]);
        for (const int rays : {4, 64}) {
            const Contour contour = castRays(loops[0], center, RaySet{rays, 0}, *image);
            const RadialProfile profile = radialProfile(viewFrom(loops[0], center), rays);
            ASSERT_EQ(profile.nearest.size(), static_cast<std::size_t>(rays));
            std::vector<double> nearest(rays, 1e300), farthest(rays, -1e300);
            for (const Crossing& x : contour.crossings) {
                nearest[x.ray] = std::min(nearest[x.ray], x.crackT);
                farthest[x.ray] = std::max(farthest[x.ray], x.crackT);
            }
            for (int d = 0; d < rays; ++d) {
                EXPECT_NEAR(profile.nearest[d], nearest[d], 1e-9) << d;
                EXPECT_NEAR(profile.farthest[d], farthest[d], 1e-9) << d;
            }
        }
    }
    const RadialProfile hookProfile = radialProfile(viewFrom(traceBoundaries(hook)[0], {0.3, 0.2}), 4);
    EXPECT_NEAR(hookProfile.nearest[0], 3.2, 1e-12);
    EXPECT_NEAR(hookProfile.farthest[0], 7.2, 1e-12);
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

TEST(Contour, ClearPixelNearIsTwoPixelsDeepNotOnTheRidge)
{
    // A crescent: the disc of radius 14 about (20, 20) less the disc of radius 12 about (15, 20),
    // 7 pixels thick along y = 20 (from the inner edge at u = 27 to the outer at u = 34). Near a
    // point just inside the inner edge, the nearest pixel two steps from the outside is (29, 20):
    // (27, 20) lies on the inner circle (outside), (28, 20) is one step in. The ridge point,
    // what a C's central point takes, lies deeper.
    FieldImage image;
    image.width = image.height = 41;
    image.values.resize(41 * 41);
    for (int v = 0; v < 41; ++v)
        for (int u = 0; u < 41; ++u)
            image.values[static_cast<std::size_t>(v) * 41 + u] =
                std::max(std::hypot(u - 20.0, v - 20.0) - 14.0, 12.0 - std::hypot(u - 15.0, v - 20.0));
    const std::vector<BoundaryLoop> loops = traceBoundaries(image);
    ASSERT_EQ(loops.size(), 1u);
    const glm::dvec2 near(27.3, 20.0);
    const glm::dvec2 clear = clearPixelNear(loops[0], near);
    EXPECT_EQ(clear, glm::dvec2(29.0, 20.0));
    EXPECT_TRUE(liesInside(loops[0], clear));
    EXPECT_GT(glm::distance(centralPoint(loops[0], &near), near), glm::distance(clear, near)); // the ridge: deeper in
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

namespace {

// A disc (radius 6) with a stem at -15 degrees carrying an arc (radius 11 to 15) that reaches
// counterclockwise to `reach` degrees; a signed field, negative inside.
FieldImage hookImage(const glm::dvec2& c, double reachDegrees)
{
    FieldImage image;
    image.width = image.height = 41;
    image.values.resize(41 * 41);
    const double degree = M_PI / 180.0;
    for (int v = 0; v < 41; ++v)
        for (int u = 0; u < 41; ++u) {
            const glm::dvec2 p(u - c.x, v - c.y);
            const double r = std::hypot(p.x, p.y), angle = std::atan2(p.y, p.x);
            const double disc = r - 6.0;
            const double along = p.x * std::cos(-15 * degree) + p.y * std::sin(-15 * degree);
            const double across = -p.x * std::sin(-15 * degree) + p.y * std::cos(-15 * degree);
            const double stem = std::max(std::abs(across) - 2.0, std::abs(along - 9.0) - 4.0);
            const double outside = std::max(angle - reachDegrees * degree, -15 * degree - angle);
            const double arc = std::max(std::abs(r - 13.0) - 2.0, outside * r);
            image.values[static_cast<std::size_t>(v) * 41 + u] = std::min({disc, stem, arc});
        }
    return image;
}

// How many crossings of `coarse` are crossings of `fine`, bit for bit.
std::size_t sharedCrossings(const Contour& coarse, const Contour& fine)
{
    std::size_t shared = 0;
    for (const Crossing& a : coarse.crossings)
        for (const Crossing& b : fine.crossings)
            if (a.point.x == b.point.x && a.point.y == b.point.y) {
                ++shared;
                break;
            }
    return shared;
}

} // namespace

TEST(Contour, AddedRaysSeeAFoldTheLevelsRaysHide)
{
    // Ray 0 of 8 crosses the arc twice in a row (a fold): the contour joins those crossings by a
    // chord along the ray, and the arc's end beyond it, up to 15 sin 28° = 7 pixels from that
    // chord, lies in sector 0 (0 to 45°), unseen.
    const glm::dvec2 center(20.3, 20.2);
    const FieldImage image = hookImage(center, 28.0);
    const std::vector<BoundaryLoop> loops = traceBoundaries(image);
    ASSERT_EQ(loops.size(), 1u);
    const LoopView view = viewFrom(loops[0], center);
    const Contour c0 = castRays(loops[0], center, RaySet{8, 0}, image);
    // A small one too, in sector 7: from the arc back to the disc the walk follows the arc's inner
    // edge and the stem's upper side (the stem, 4 wide around -15°, meets the arc at -15° +
    // asin(2/11) = -4.5°), up to 11 sin 4.5° = 0.9 pixel from the chord on ray 0.
    ASSERT_EQ(c0.crossings.size(), 10u); // ray 0: disc, arc in, arc out
    EXPECT_EQ(hiddenFolds(c0, view, 0.5), (std::vector<int>{0, 7}));
    EXPECT_EQ(hiddenFolds(c0, view, 1.5), std::vector<int>{0});
    EXPECT_TRUE(hiddenFolds(c0, view, 6.0).size() == 1 && hiddenFolds(c0, view, 7.5).empty());

    // Halving sector 0 casts a ray at 22.5°, through the arc: the fold moves to the arc's end
    // beyond that ray, about 15 sin 5.5° = 1.4 pixels from it, in sector 1 (22.5° to 45°).
    const RaySet once = RaySet{8, 0}.withMidpoints({0});
    ASSERT_EQ(once.count(), 9);
    const Contour c1 = refineContour(c0, loops[0], once, image);
    const Contour scratch1 = castRays(loops[0], center, once, image);
    ASSERT_EQ(c1.crossings.size(), scratch1.crossings.size());
    EXPECT_EQ(sharedCrossings(c1, scratch1), c1.crossings.size()); // refining = casting all
    EXPECT_EQ(sharedCrossings(c0, c1), c0.crossings.size());       // the old rays' crossings stay
    for (const Crossing& x : c1.crossings) {
        if (x.ray == 1) {
            EXPECT_NEAR(std::atan2(x.point.y - center.y, x.point.x - center.x), M_PI / 8, 1e-12);
        }
    }
    EXPECT_EQ(hiddenFolds(c1, view, 0.5), (std::vector<int>{1, 8})); // sector 7 is sector 8 now
    EXPECT_EQ(hiddenFolds(c1, view, 1.0), std::vector<int>{1});
    EXPECT_TRUE(hiddenFolds(c1, view, 2.0).empty());

    // Once more (33.75°, past the arc's end): the fold stays, and its sector cannot be halved a
    // third time for a fold (RaySet::kFoldHalvings); a straying chord at the top level may halve
    // it once more (RaySet::kFoldDepth), but not again.
    EXPECT_TRUE(once.canHalve(1, RaySet::kFoldHalvings));
    const RaySet twice = once.withMidpoints({1});
    ASSERT_EQ(twice.count(), 10);
    const Contour c2 = refineContour(c1, loops[0], twice, image);
    EXPECT_EQ(hiddenFolds(c2, view, 1.0), std::vector<int>{1});
    EXPECT_FALSE(twice.canHalve(1, RaySet::kFoldHalvings));
    EXPECT_TRUE(twice.canHalve(1));
    const RaySet thrice = twice.withMidpoints({1});
    EXPECT_EQ(thrice.count(), 11);
    EXPECT_FALSE(thrice.canHalve(1));
    EXPECT_EQ(thrice.withMidpoints({1}).count(), 11);

    // The next level keeps the added rays (22.5° is now its own ray 2; 33.75° is added): 17 rays,
    // every crossing of this level among them, bit for bit, refined or cast from scratch.
    const RaySet next = twice.next();
    EXPECT_EQ(next.level, 1);
    EXPECT_EQ(next.count(), 17);
    const Contour c3 = refineContour(c2, loops[0], image);
    const Contour scratch3 = castRays(loops[0], center, next, image);
    ASSERT_EQ(c3.crossings.size(), scratch3.crossings.size());
    EXPECT_EQ(sharedCrossings(c3, scratch3), c3.crossings.size());
    EXPECT_EQ(sharedCrossings(c2, c3), c2.crossings.size());
    EXPECT_EQ(countEdges(c3, EdgeType::Forward) - countEdges(c3, EdgeType::Backward), 17);

    // Rays that miss some of the coarse contour's break refineContour's precondition: refused, not
    // read out of range. A coarser grid, another base, and a finer grid without the added 33.75°.
    EXPECT_THROW(refineContour(c2, loops[0], RaySet{8, 1}, image), UsageError);
    EXPECT_THROW(refineContour(c0, loops[0], RaySet{6, 1}, image), UsageError);
    EXPECT_THROW(refineContour(c2, loops[0], once.next(), image), UsageError);
}

TEST(Contour, ViewAnglesAgreeWithAtan2)
{
    // LoopView::turns comes from a series, not libm's atan2 (contour.cpp, turnsOf): within
    // 2e-12 turn of atan2 / 2 pi at every point of a loop around an off-lattice centre, in all
    // eight octants, and in [0, 1).
    const FieldImage image = circleImage({15.2, 14.6}, 11.3, 31);
    const BoundaryLoop loop = traceBoundaries(image).at(0);
    for (const glm::dvec2 center : {glm::dvec2(15.2, 14.6), glm::dvec2(15.0, 15.0), glm::dvec2(13.37, 16.01)}) {
        const LoopView view = viewFrom(loop, center);
        ASSERT_EQ(view.turns.size(), loop.points.size());
        EXPECT_EQ(view.winding, 1);
        for (std::size_t i = 0; i < loop.points.size(); ++i) {
            const glm::dvec2 p = loop.points[i] - center;
            double expected = std::atan2(p.y, p.x) / (2.0 * M_PI);
            if (expected < 0.0) expected += 1.0;
            double error = std::abs(view.turns[i] - expected);
            error = std::min(error, 1.0 - error);
            EXPECT_LT(error, 2e-12) << p.x << " " << p.y;
            EXPECT_TRUE(view.turns[i] >= 0.0 && view.turns[i] < 1.0);
        }
    }
}

TEST(Contour, OverlapCountsThePixelsBothLoopsEnclose)
{
    // A 4 x 3 block against itself moved: (4 - |dx|) x (3 - |dy|) pixels, none once it has moved
    // off. A ring's outer loop encloses its hole's pixels too: 5 x 5.
    const FieldImage block = binaryImage({0, 0}, {"####", "####", "####"});
    const std::vector<BoundaryLoop> loops = traceBoundaries(block);
    ASSERT_EQ(loops.size(), 1u);
    const BoundaryLoop& a = loops[0];
    EXPECT_EQ(overlapPixels(a, a, {0, 0}), 12);
    EXPECT_EQ(overlapPixels(a, a, {1, 0}), 9);
    EXPECT_EQ(overlapPixels(a, a, {-1, -1}), 6);
    EXPECT_EQ(overlapPixels(a, a, {0, 2}), 4);
    EXPECT_EQ(overlapPixels(a, a, {4, 0}), 0);
    EXPECT_EQ(overlapPixels(a, a, {0, -3}), 0);
    const FieldImage ring = binaryImage({0, 0}, {"#####", "#...#", "#...#", "#...#", "#####"});
    const std::vector<BoundaryLoop> rings = traceBoundaries(ring);
    ASSERT_EQ(rings.size(), 2u);
    const BoundaryLoop& outer = rings[0].hole() ? rings[1] : rings[0];
    const BoundaryLoop& hole = rings[0].hole() ? rings[0] : rings[1];
    EXPECT_EQ(overlapPixels(outer, outer, {0, 0}), 25);
    EXPECT_EQ(overlapPixels(outer, hole, {0, 0}), 9);
}

TEST(Contour, StrayingChordsAreTheSectorsWhoseEdgesCutCorners)
{
    // A circle of radius 10 seen from its centre: an edge between neighbouring rays n apart
    // lies 10 (1 - cos(pi / n)) from the arc between them: 0.76 pixel for 8 rays (every sector
    // past half a pixel, none past one), 0.05 for 32.
    const glm::dvec2 center(20.0, 20.0);
    const FieldImage image = circleImage(center, 10.0, 41);
    const std::vector<BoundaryLoop> loops = traceBoundaries(image);
    ASSERT_EQ(loops.size(), 1u);
    const LoopView view = viewFrom(loops[0], center);
    const Contour eight = castRays(loops[0], center, RaySet{8, 0}, image);
    EXPECT_EQ(strayingChords(eight, view, 0.5), (std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7}));
    EXPECT_TRUE(strayingChords(eight, view, 1.0).empty());
    EXPECT_TRUE(strayingChords(castRays(loops[0], center, RaySet{32, 0}, image), view, 0.5).empty());
}

// A waist is one loop around walls that touch or lie a little apart: the walls' union traced from
// the distance to them. Squares of side 4 whose edges lie halfway between pixel centres are traced
// exactly along their edges, less a corner of half a pixel's legs (1/8 square pixel) at each of
// their four corners: 15.5 square pixels each.
TEST(Contour, WaistAroundJoinsWallsIntoOneLoop)
{
    auto square = [](double u, double v) {
        return std::vector<glm::dvec2>{{u, v}, {u + 4.0, v}, {u + 4.0, v + 4.0}, {u, v + 4.0}};
    };
    const std::vector<glm::dvec2> a = square(0.5, 0.5), corner = square(4.5, 4.5), apart = square(6.5, 0.5);
    // Touching at a corner: one loop at once, the two squares and the saddle's pixel between them.
    const BoundaryLoop touching = waistAround({&a, &corner}, 0.0);
    ASSERT_FALSE(touching.corners.empty());
    EXPECT_GE(touching.area, 31.0);
    EXPECT_LE(touching.area, 32.0);
    // Two pixels apart: each wall grows by a pixel before they meet; half a pixel is not enough.
    EXPECT_TRUE(waistAround({&a, &apart}, 0.5).corners.empty());
    const BoundaryLoop grown = waistAround({&a, &apart}, 2.0);
    ASSERT_FALSE(grown.corners.empty());
    EXPECT_FALSE(grown.hole());
    EXPECT_GT(grown.area, 2.0 * 15.5 + 4.0); // the 2 x 4 gap between them, filled at least halfway
    for (const std::vector<glm::dvec2>* wall : {&a, &apart})
        for (const glm::dvec2& p : *wall) EXPECT_TRUE(encloses(grown, p)) << p.x << ", " << p.y;
}

TEST(Contour, LongChordsAreTheSectorsWhoseCrossingsLieFarApart)
{
    // A rectangle 40 by 4 around the central point, cast with 8 rays: rays 0 and 4 meet its ends
    // at (±20, 0), the others its long sides at (±2, ±2) and (0, ±2). The chords from an end to
    // the nearest side crossing, sectors 0, 3, 4 and 7, are sqrt(18² + 2²) = 18.11 long; the
    // others 2.
    const LoopView view = viewOfPolygon({{-20, -2}, {20, -2}, {20, 2}, {-20, 2}}, {0, 0});
    const Contour contour = castPolygon(view, RaySet{8, 0});
    ASSERT_EQ(contour.crossings.size(), 8u);
    EXPECT_EQ(longChords(contour, 2.5), (std::vector<int>{0, 3, 4, 7}));
    EXPECT_EQ(longChords(contour, 18.0), (std::vector<int>{0, 3, 4, 7}));
    EXPECT_TRUE(longChords(contour, 18.2).empty());
    EXPECT_EQ(longChords(contour, 1.9).size(), 8u);
    // Halved, sector 0's new ray (22.5°) meets the side at x = 2 / tan 22.5° = 4.83: the chord
    // from the end, 15.3 long, is sector 0's, and the one to (2, 2), 2.83, is sector 1's.
    const Contour halved = castPolygon(view, RaySet{8, 0}.withMidpoints({0}));
    EXPECT_EQ(longChords(halved, 15.0), (std::vector<int>{0, 4, 5, 8}));
    EXPECT_EQ(longChords(halved, 15.5), (std::vector<int>{4, 5, 8}));
}

TEST(Contour, LongChordPointsCutAnEdgeIntoEvenPiecesAlongItsWalk)
{
    // The rectangle 40 by 4 of LongChords, its top side a polygon point every pixel at x = 19.5 down
    // to -19.5, cast with 4 rays: (20, 0), (0, 2), (-20, 0), (0, -2). The walk from the first
    // crossing up the end and along the top to the second is 2 + 20 = 22 long: pieces of at most
    // 7.4 make three of 7.33, cut at x = 22 - 7.33 and 22 - 14.67, at the polygon points nearest
    // them, x = 14.5 (index 8) and 7.5 (index 15).
    std::vector<glm::dvec2> polygon{{-20, -2}, {20, -2}, {20, 2}};
    for (int j = 0; j < 40; ++j) polygon.push_back({19.5 - j, 2});
    polygon.push_back({-20, 2});
    const LoopView view = viewOfPolygon(polygon, {0, 0});
    const Contour contour = castPolygon(view, RaySet{4, 0});
    ASSERT_EQ(contour.crossings.size(), 4u);
    ASSERT_LT(glm::distance(contour.crossings[1].point, glm::dvec2(0, 2)), 1e-9);
    const std::vector<std::vector<int>> cut = longChordPoints(contour, view, {7.4, 0.0, 0.0, 0.0});
    ASSERT_EQ(cut.size(), 4u);
    EXPECT_EQ(cut[0], (std::vector<int>{8, 15}));
    for (std::size_t k = 1; k < 4; ++k) EXPECT_TRUE(cut[k].empty()) << k;
    // Pieces longer than the walk leave it whole; pieces of at most 2.3 make ten of 2.2, cut at nine
    // points, the first the corner (20, 2) (index 2), 2 along.
    EXPECT_TRUE(longChordPoints(contour, view, {22.5, 0.0, 0.0, 0.0})[0].empty());
    const std::vector<int> nine = longChordPoints(contour, view, {2.3, 0.0, 0.0, 0.0})[0];
    ASSERT_EQ(nine.size(), 9u);
    EXPECT_EQ(nine[0], 2);
}
