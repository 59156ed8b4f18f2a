#include <pipetile/tiler.h>

#include <gtest/gtest.h>

#include "test_util.h"

#include <algorithm>
#include <cstdlib>
#include <map>
#include <set>

using namespace pipetile;

TEST(Tiler, StarContoursTileAsQuadsSplitAlongOneDiagonal)
{
    // 8 F edges each: sector x of A pairs with sector x of B, one quad (two triangles) each.
    const std::vector<EdgeType> star(8, EdgeType::Forward);
    const std::vector<Triangle> band = tileBand(star, star);
    ASSERT_EQ(band.size(), 16u);
    for (std::uint32_t x = 0; x < 8; ++x) {
        EXPECT_EQ(band[2 * x], (Triangle{x, (x + 1) % 8, 8 + x}));
        EXPECT_EQ(band[2 * x + 1], (Triangle{(x + 1) % 8, 8 + (x + 1) % 8, 8 + x}));
    }
    EXPECT_TRUE(test::isClosedStrip(band, 8, 8));
}

TEST(Tiler, BandOfMAndNPointsHasMPlusNTriangles)
{
    // A star contour of 8 crossings against one with a fold on ray 0 (10 crossings): 18 triangles.
    const auto a = test::parseEdges("F F F F F F F F");
    const auto b = test::parseEdges("D_I D_O F F F F F F F F");
    const std::vector<Triangle> band = tileBand(a, b);
    EXPECT_TRUE(test::isClosedStrip(band, 8, 10));
}

TEST(Tiler, AmbiguousAndFoldedContoursStillGiveClosedStrips)
{
    // Every contour that winds once, whatever its excursions, tiles as a closed m + n strip.
    const std::vector<std::string> contours = {
        "F F F F",         "F U_I U_O F F F", "F D_I D_O F F F", "F U_I B U_O F F F",
        "F F F U_I U_O F", "D_I D_O F F F F", "F F B F F F",
    };
    for (const std::string& sa : contours)
        for (const std::string& sb : contours) {
            SCOPED_TRACE(sa + " | " + sb);
            const auto a = test::parseEdges(sa), b = test::parseEdges(sb);
            EXPECT_TRUE(test::isClosedStrip(tileBand(a, b), static_cast<std::uint32_t>(a.size()),
                                            static_cast<std::uint32_t>(b.size())));
        }
}

TEST(Tiler, ExcursionsThatParseDifferentlyAreTiledAlongTheirRays)
{
    // A ray grazes a wall: both contours leave ray 4 backward and come back along the wall,
    // crossing rays 3 and 2 twice, but the upper one (B) touches ray 4 in between (it clips a
    // bulge the lower one misses). A's excursion parses as D_I and one composite, B's as two
    // D_I + composite pairs, so pairing children by position fans B's first pair (rays 3, 2, 2,
    // 3, 4) onto A's crossing on ray 4, and A's composite onto B's second pair: spanning edges
    // two rays long. Aligned by their rays, no spanning edge skips more than one ray.
    const auto a = test::parseEdges("F F F F D_I B B D_O F D_I B D_O F F F F F F");
    const auto b = test::parseEdges("F F F F D_I B B D_O F F D_I B D_O F F F F F");
    const ContourString sa = stringOfEdges(a), sb = stringOfEdges(b);
    ASSERT_EQ(sa.rays, 8);
    ASSERT_EQ(sb.rays, 8);
    const std::uint32_t m = static_cast<std::uint32_t>(a.size()), n = static_cast<std::uint32_t>(b.size());
    const std::vector<Triangle> band = tileBand(a, b);
    EXPECT_TRUE(test::isClosedStrip(band, m, n));
    auto rayOf = [&](std::uint32_t v) { return v < m ? sa.ray[v] : sb.ray[v - m]; };
    int widest = 0;
    for (const Triangle& t : band)
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t u = t[k], v = t[(k + 1) % 3];
            const int gap = std::abs(rayOf(u) - rayOf(v)); // the short way round 8 rays
            if ((u < m) != (v < m)) widest = std::max(widest, std::min(gap, 8 - gap));
        }
    EXPECT_EQ(widest, 1);
}

TEST(Tiler, CapIsAFanOfMTrianglesUsingEachContourEdgeOnce)
{
    // A fan over m crossings: m triangles, contour edge (i, i+1) reversed on the bottom cap so the
    // band and the cap run opposite ways along it.
    const std::vector<Triangle> bottom = tileCap(5, false), top = tileCap(5, true);
    ASSERT_EQ(bottom.size(), 5u);
    ASSERT_EQ(top.size(), 5u);
    for (std::uint32_t i = 0; i < 5; ++i) {
        EXPECT_EQ(top[i], (Triangle{i, (i + 1) % 5, 5}));
        EXPECT_EQ(bottom[i], (Triangle{(i + 1) % 5, i, 5}));
    }
}

TEST(Tiler, FlatCapIsAFanOfMMinusTwoTrianglesFromCrossingZero)
{
    // Without an apex, m crossings close with m - 2 triangles, all through crossing 0.
    const std::vector<Triangle> top = tileFlatCap(6, true), bottom = tileFlatCap(6, false);
    ASSERT_EQ(top.size(), 4u);
    for (std::uint32_t i = 0; i < 4; ++i) {
        EXPECT_EQ(top[i], (Triangle{0, i + 1, i + 2}));
        EXPECT_EQ(bottom[i], (Triangle{0, i + 2, i + 1}));
    }
}
