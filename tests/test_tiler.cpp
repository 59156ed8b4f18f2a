#include <pipetile/tiler.h>

#include <gtest/gtest.h>

#include <map>
#include <set>

using namespace pipetile;

namespace {

std::vector<EdgeType> parse(const std::string& s)
{
    std::vector<EdgeType> edges;
    std::size_t i = 0;
    while (i < s.size()) {
        std::size_t j = s.find(' ', i);
        if (j == std::string::npos) j = s.size();
        const std::string token = s.substr(i, j - i);
        if (token == "F") edges.push_back(EdgeType::Forward);
        else if (token == "B") edges.push_back(EdgeType::Backward);
        else if (token == "D_I") edges.push_back(EdgeType::DownIn);
        else if (token == "D_O") edges.push_back(EdgeType::DownOut);
        else if (token == "U_I") edges.push_back(EdgeType::UpIn);
        else if (token == "U_O") edges.push_back(EdgeType::UpOut);
        i = j + 1;
    }
    return edges;
}

// Acceptable surface (toroidal graph sense): every triangle has one contour edge and one vertex
// on the other contour; every contour edge is used exactly once; consecutive triangles share a
// spanning edge, and the last shares one with the first (a closed strip).
void expectClosedStrip(const std::vector<Triangle>& band, std::uint32_t m, std::uint32_t n)
{
    ASSERT_EQ(band.size(), m + n);
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> contourEdges;
    for (const Triangle& t : band) {
        int onA = 0;
        for (std::uint32_t v : t) onA += v < m ? 1 : 0;
        ASSERT_TRUE(onA == 1 || onA == 2);
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t a = t[k], b = t[(k + 1) % 3];
            if ((a < m) == (b < m)) ++contourEdges[{a, b}];
        }
    }
    EXPECT_EQ(contourEdges.size(), m + n);
    for (std::uint32_t i = 0; i < m; ++i) EXPECT_EQ((contourEdges[{i, (i + 1) % m}]), 1);
    for (std::uint32_t j = 0; j < n; ++j) EXPECT_EQ((contourEdges[{m + (j + 1) % n, m + j}]), 1);
    auto spanning = [&](const Triangle& t) {
        std::set<std::pair<std::uint32_t, std::uint32_t>> s;
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t a = t[k], b = t[(k + 1) % 3];
            if ((a < m) != (b < m)) s.insert({std::min(a, b), std::max(a, b)});
        }
        return s;
    };
    for (std::size_t k = 0; k < band.size(); ++k) {
        const auto s = spanning(band[k]), next = spanning(band[(k + 1) % band.size()]);
        int shared = 0;
        for (const auto& e : s) shared += static_cast<int>(next.count(e));
        EXPECT_EQ(shared, 1) << "triangles " << k << " and " << (k + 1) % band.size();
    }
}

} // namespace

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
    expectClosedStrip(band, 8, 8);
}

TEST(Tiler, BandOfMAndNPointsHasMPlusNTriangles)
{
    // A star contour of 8 crossings against one with a fold on ray 0 (10 crossings): 18 triangles.
    const auto a = parse("F F F F F F F F");
    const auto b = parse("D_I D_O F F F F F F F F");
    const std::vector<Triangle> band = tileBand(a, b);
    expectClosedStrip(band, 8, 10);
}

TEST(Tiler, AmbiguousAndFoldedContoursStillGiveClosedStrips)
{
    // Every contour that winds once, whatever its excursions, tiles as a closed m + n strip.
    const std::vector<std::string> contours = {
        "F F F F", "F U_I U_O F F F", "F D_I D_O F F F", "F U_I B U_O F F F", "F F F U_I U_O F",
        "D_I D_O F F F F", "F F B F F F",
    };
    for (const std::string& sa : contours)
        for (const std::string& sb : contours) {
            SCOPED_TRACE(sa + " | " + sb);
            const auto a = parse(sa), b = parse(sb);
            expectClosedStrip(tileBand(a, b), static_cast<std::uint32_t>(a.size()), static_cast<std::uint32_t>(b.size()));
        }
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
