#include <pipetile/error.h>
#include <pipetile/tiler.h>
#include <pipetile/toroidal.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "test_util.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <set>

using namespace pipetile;

namespace {

constexpr double pi = 3.14159265358979323846;

// n points counterclockwise seen from +z on a circle around the z axis, the first at `phase`.
std::vector<glm::dvec3> circle(std::size_t n, double radius, double z, double phase = 0.0)
{
    std::vector<glm::dvec3> points;
    for (std::size_t i = 0; i < n; ++i) {
        const double angle = phase + 2.0 * pi * static_cast<double>(i) / static_cast<double>(n);
        points.push_back({radius * std::cos(angle), radius * std::sin(angle), z});
    }
    return points;
}

// A star-shaped contour: one point per ray at angle 2 pi x / n, radius drawn from [4, 6].
std::vector<glm::dvec3> randomStar(std::size_t n, double z, std::mt19937& rng)
{
    std::uniform_real_distribution<double> radius(4.0, 6.0);
    std::vector<glm::dvec3> points;
    for (std::size_t x = 0; x < n; ++x) {
        const double angle = 2.0 * pi * static_cast<double>(x) / static_cast<double>(n), r = radius(rng);
        points.push_back({r * std::cos(angle), r * std::sin(angle), z});
    }
    return points;
}

// Points in no special position: angles jittered within their sectors, radii and heights random.
std::vector<glm::dvec3> randomContour(std::size_t n, double z, std::mt19937& rng)
{
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::vector<glm::dvec3> points;
    for (std::size_t i = 0; i < n; ++i) {
        const double angle = 2.0 * pi * (static_cast<double>(i) + 0.8 * unit(rng)) / static_cast<double>(n);
        const double r = 3.0 + 3.0 * unit(rng);
        points.push_back({r * std::cos(angle), r * std::sin(angle), z + 0.5 * unit(rng)});
    }
    return points;
}

const glm::dvec3& vertex(std::uint32_t id, const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b)
{
    return id < a.size() ? a[id] : b[id - a.size()];
}

double triangleArea(const glm::dvec3& p, const glm::dvec3& q, const glm::dvec3& r)
{
    return 0.5 * glm::length(glm::cross(q - p, r - p));
}

double bandArea(const std::vector<Triangle>& band, const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b)
{
    double area = 0.0;
    for (const Triangle& t : band) area += triangleArea(vertex(t[0], a, b), vertex(t[1], a, b), vertex(t[2], a, b));
    return area;
}

// Every acceptable surface: each start (i0, j0) and each order of m steps on A and n steps on B.
double exhaustiveMinimumArea(const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b)
{
    const std::size_t m = a.size(), n = b.size();
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i0 = 0; i0 < m; ++i0)
        for (std::size_t j0 = 0; j0 < n; ++j0)
            for (unsigned mask = 0; mask < (1u << (m + n)); ++mask) {
                if (static_cast<std::size_t>(__builtin_popcount(mask)) != m) continue;
                std::size_t i = i0, j = j0;
                double area = 0.0;
                for (std::size_t k = 0; k < m + n; ++k) {
                    if (mask >> k & 1u) {
                        area += triangleArea(a[i % m], a[(i + 1) % m], b[j % n]);
                        ++i;
                    } else {
                        area += triangleArea(a[i % m], b[(j + 1) % n], b[j % n]);
                        ++j;
                    }
                }
                best = std::min(best, area);
            }
    return best;
}

// The same minimum by plain dynamic programming: every acceptable surface passes through a
// spanning edge from B's point 0, so one full (m + 1) x (n + 1) table per start on A covers them all.
// Each step costs its triangle's area, plus `spanWeight` / 2 times the squared length of the span it
// reaches (a step in A the span a_(i+1) - b_j, a step in B the span a_i - b_(j+1)): with a weight,
// half of tileLeastAreaNearest's cost, which doubles the area.
double perStartMinimum(const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b, double spanWeight = 0.0)
{
    const std::size_t m = a.size(), n = b.size();
    const auto span = [&](const glm::dvec3& p, const glm::dvec3& q) {
        return 0.5 * spanWeight * glm::dot(q - p, q - p);
    };
    double best = std::numeric_limits<double>::infinity();
    std::vector<double> table((m + 1) * (n + 1));
    for (std::size_t i0 = 0; i0 < m; ++i0) {
        for (std::size_t i = 0; i <= m; ++i)
            for (std::size_t j = 0; j <= n; ++j) {
                const glm::dvec3 &ai = a[(i0 + i) % m], &bj = b[j % n];
                double cost = i == 0 && j == 0 ? 0.0 : std::numeric_limits<double>::infinity();
                if (i > 0)
                    cost = std::min(cost, table[(i - 1) * (n + 1) + j] + triangleArea(a[(i0 + i - 1) % m], ai, bj) +
                                              span(ai, bj));
                if (j > 0)
                    cost = std::min(cost,
                                    table[i * (n + 1) + j - 1] + triangleArea(ai, bj, b[(j - 1) % n]) + span(ai, bj));
                table[i * (n + 1) + j] = cost;
            }
        best = std::min(best, table.back());
    }
    return best;
}

std::vector<glm::dvec3> rotated(const std::vector<glm::dvec3>& points, std::size_t start)
{
    std::vector<glm::dvec3> out(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) out[i] = points[(i + start) % points.size()];
    return out;
}

// A triangle as ids of the original inputs, rotated so its smallest id comes first (orientation
// kept), for comparing bands computed from inputs with other start indices.
Triangle canonical(const Triangle& t, std::uint32_t m, std::uint32_t n, std::uint32_t startA, std::uint32_t startB)
{
    Triangle out;
    for (int k = 0; k < 3; ++k) out[k] = t[k] < m ? (t[k] + startA) % m : m + (t[k] - m + startB) % n;
    while (out[0] != std::min({out[0], out[1], out[2]})) out = {out[1], out[2], out[0]};
    return out;
}

} // namespace

TEST(Toroidal, BothTilersGiveClosedStripsOfMPlusNTrianglesWithOutwardNormals)
{
    // Every acceptable surface between m and n points has m + n triangles, whatever the sizes:
    // the smallest contour (3), very unequal sizes both ways, and rotated copies.
    const std::vector<std::pair<std::size_t, std::size_t>> sizes = {
        {3, 3}, {3, 4}, {4, 3}, {3, 100}, {100, 3}, {8, 8}, {17, 40}, {64, 5}, {5, 64},
    };
    for (const auto& [m, n] : sizes) {
        for (double twist : {0.0, 0.3, 2.5}) {
            SCOPED_TRACE(std::to_string(m) + " x " + std::to_string(n) + ", twist " + std::to_string(twist));
            const auto a = circle(m, 5.0, 0.0), b = circle(n, 6.0, 2.0, twist);
            const std::uint32_t mm = static_cast<std::uint32_t>(m), nn = static_cast<std::uint32_t>(n);
            for (const auto& band : {tileOptimal(a, b), tileGreedy(a, b)}) {
                EXPECT_TRUE(test::isClosedStrip(band, mm, nn));
                // Both circles wind counterclockwise around +z: outward means away from the axis.
                for (const Triangle& t : band) {
                    const glm::dvec3 p = vertex(t[0], a, b), q = vertex(t[1], a, b), r = vertex(t[2], a, b);
                    const glm::dvec3 normal = glm::cross(q - p, r - p), centre = (p + q + r) / 3.0;
                    EXPECT_GT(glm::dot(normal, glm::dvec3(centre.x, centre.y, 0.0)), 0.0);
                }
            }
        }
    }
    // A rotated copy: the same contour turned by a third of a sector and lifted.
    std::mt19937 rng(7);
    const auto a = randomStar(24, 0.0, rng);
    std::vector<glm::dvec3> b;
    const double turn = 2.0 * pi / 72.0;
    for (const glm::dvec3& p : a)
        b.push_back({p.x * std::cos(turn) - p.y * std::sin(turn), p.x * std::sin(turn) + p.y * std::cos(turn), 1.5});
    EXPECT_TRUE(test::isClosedStrip(tileOptimal(a, b), 24, 24));
    EXPECT_TRUE(test::isClosedStrip(tileGreedy(a, b), 24, 24));
}

TEST(Toroidal, OptimalMatchesExhaustiveSearchOnTinyContours)
{
    // For m, n <= 5 every acceptable surface can be listed (at most 25 starts x 252 step orders);
    // the optimal tiler must find their minimum area, and greedy can do no better.
    std::mt19937 rng(2024);
    for (std::size_t m = 3; m <= 5; ++m)
        for (std::size_t n = 3; n <= 5; ++n)
            for (int trial = 0; trial < 6; ++trial) {
                SCOPED_TRACE(std::to_string(m) + " x " + std::to_string(n) + ", trial " + std::to_string(trial));
                const auto a = randomContour(m, 0.0, rng), b = randomContour(n, 2.0, rng);
                const double exhaustive = exhaustiveMinimumArea(a, b);
                const auto optimal = tileOptimal(a, b);
                EXPECT_TRUE(test::isClosedStrip(optimal, static_cast<std::uint32_t>(m), static_cast<std::uint32_t>(n)));
                EXPECT_NEAR(bandArea(optimal, a, b), exhaustive, 1e-9 * exhaustive);
                EXPECT_GE(bandArea(tileGreedy(a, b), a, b), exhaustive * (1.0 - 1e-12));
            }
}

TEST(Toroidal, OptimalMatchesPlainDynamicProgrammingOverEveryStart)
{
    // Sizes where the bisection over starts nests several levels deep, against an independent
    // search that tries every start on A with a full table.
    std::mt19937 rng(99);
    for (const auto& [m, n] : std::vector<std::pair<std::size_t, std::size_t>>{
             {6, 6}, {7, 19}, {19, 7}, {16, 17}, {31, 33}, {40, 12}, {3, 50}, {64, 64}}) {
        for (int trial = 0; trial < 3; ++trial) {
            SCOPED_TRACE(std::to_string(m) + " x " + std::to_string(n) + ", trial " + std::to_string(trial));
            const auto a = randomContour(m, 0.0, rng), b = randomContour(n, 1.0, rng);
            const double reference = perStartMinimum(a, b);
            EXPECT_NEAR(bandArea(tileOptimal(a, b), a, b), reference, 1e-9 * reference);
        }
    }
}

TEST(Toroidal, OptimalAreaIsNoMoreThanGreedyOrTheStarBand)
{
    // The optimum is a minimum over all acceptable surfaces, and greedy and tileBand (all-Forward
    // strings: ray x of A pairs with ray x of B) each return one of them.
    std::mt19937 rng(11);
    for (std::size_t n : {3u, 8u, 16u, 33u, 64u}) {
        for (int trial = 0; trial < 4; ++trial) {
            SCOPED_TRACE(std::to_string(n) + " rays, trial " + std::to_string(trial));
            const auto a = randomStar(n, 0.0, rng), b = randomStar(n, 1.0, rng);
            const double optimal = bandArea(tileOptimal(a, b), a, b);
            const std::vector<EdgeType> star(n, EdgeType::Forward);
            const auto band = tileBand(star, star);
            EXPECT_TRUE(test::isClosedStrip(band, static_cast<std::uint32_t>(n), static_cast<std::uint32_t>(n)));
            EXPECT_LE(optimal, bandArea(band, a, b) * (1.0 + 1e-12));
            EXPECT_LE(optimal, bandArea(tileGreedy(a, b), a, b) * (1.0 + 1e-12));
        }
    }
    // Unequal sizes, against greedy only: tileBand pairs contours cast with the same rays.
    const auto a = randomStar(12, 0.0, rng), b = randomStar(20, 1.0, rng);
    EXPECT_LE(bandArea(tileOptimal(a, b), a, b), bandArea(tileGreedy(a, b), a, b) * (1.0 + 1e-12));
}

TEST(Toroidal, IdenticalCoaxialCirclesTileAsRectanglesOfChordTimesHeight)
{
    // B is A lifted by h: the quads a_i a_i+1 b_i+1 b_i are chord x h rectangles. No surface does
    // better: a triangle on a contour edge of length chord has height >= h (the other contour lies
    // h away along z), so area >= chord h / 2, and the m + n = 2n triangles reach that bound.
    const std::size_t n = 12;
    const double radius = 5.0, h = 2.0;
    const double chord = 2.0 * radius * std::sin(pi / static_cast<double>(n));
    const double expected = static_cast<double>(n) * chord * h;
    const auto a = circle(n, radius, 0.0, 0.1), b = circle(n, radius, h, 0.1);
    EXPECT_NEAR(bandArea(tileOptimal(a, b), a, b), expected, 1e-12 * expected);
    // The same surface from every start of B: the optimum does not depend on the labels.
    for (std::size_t start = 1; start < n; ++start)
        EXPECT_NEAR(bandArea(tileOptimal(a, rotated(b, start)), a, rotated(b, start)), expected, 1e-12 * expected);
    // Greedy finds it too: it starts straight above a_0, and the vertical edge h is shorter than
    // either diagonal sqrt(chord^2 + h^2), so it alternates along the rectangles.
    EXPECT_NEAR(bandArea(tileGreedy(a, b), a, b), expected, 1e-12 * expected);
}

TEST(Toroidal, OptimalDoesNotDependOnTheStartIndexOfEitherContour)
{
    // Points in general position have one minimal surface, so rotating the inputs' start indices
    // must give the same triangles once the ids are mapped back; both m < n and m > n, since the
    // starts are searched along the smaller contour.
    std::mt19937 rng(5);
    for (const auto& [m, n] : std::vector<std::pair<std::uint32_t, std::uint32_t>>{{9, 13}, {13, 9}, {10, 10}}) {
        const auto a = randomContour(m, 0.0, rng), b = randomContour(n, 1.5, rng);
        std::set<Triangle> reference;
        for (const Triangle& t : tileOptimal(a, b)) reference.insert(canonical(t, m, n, 0, 0));
        ASSERT_EQ(reference.size(), m + n);
        for (std::uint32_t startA : {0u, 1u, 4u, m - 1})
            for (std::uint32_t startB : {0u, 5u, n - 1}) {
                SCOPED_TRACE(std::to_string(m) + " x " + std::to_string(n) + ", starts " + std::to_string(startA) +
                             ", " + std::to_string(startB));
                std::set<Triangle> relabelled;
                for (const Triangle& t : tileOptimal(rotated(a, startA), rotated(b, startB)))
                    relabelled.insert(canonical(t, m, n, startA, startB));
                EXPECT_EQ(relabelled, reference);
            }
    }
}

TEST(Toroidal, GreedyStartsAtPointZeroOfAAndTheNearestPointOfB)
{
    // B's point 7 sits straight above A's point 0 (same angle and radius); it must be in the first
    // triangle with A's point 0, i.e. the spanning edge a_0 - b_7 (ids 0 and 16 + 7) opens the strip.
    const auto a = circle(16, 5.0, 0.0), b = circle(16, 5.0, 1.0, -2.0 * pi * 7.0 / 16.0);
    const auto band = tileGreedy(a, b);
    ASSERT_FALSE(band.empty());
    EXPECT_NE(std::find(band[0].begin(), band[0].end(), 0u), band[0].end());
    EXPECT_NE(std::find(band[0].begin(), band[0].end(), 16u + 7u), band[0].end());
}

TEST(Toroidal, OptimalMemoryGrowsQuadraticallyAndGreedyMemoryLinearly)
{
    ToroidalStats previousOptimal, previousGreedy;
    for (std::size_t n : {32u, 64u, 128u, 256u, 512u}) {
        SCOPED_TRACE(std::to_string(n) + " points each");
        const auto a = circle(n, 10.0, 0.0), b = circle(n, 11.0, 1.0, 0.1);
        ToroidalStats optimal, greedy;
        tileOptimal(a, b, &optimal);
        tileGreedy(a, b, &greedy);
        // At least one choice bit per vertex of the n x n toroidal graph; besides it only O(n log n)
        // bytes (point copies, a cost row, the paths on the bisection stack, the 2n triangles).
        EXPECT_GE(optimal.bytes, n * n / 8);
        EXPECT_LE(optimal.bytes, n * n / 8 + 256 * n);
        // Greedy keeps nothing but the 2n triangles it returns, 12 bytes each.
        EXPECT_EQ(greedy.bytes, 2 * n * sizeof(Triangle));
        if (previousOptimal.bytes > 0) {
            // Doubling n exactly doubles anything linear; the bit table quadruples, so the excess
            // over doubling is at least its growth, (2n)^2 / 8 - 2 n^2 / 8 = n^2 / 4 bytes.
            const std::size_t half = n / 2;
            EXPECT_GE(optimal.bytes - 2 * previousOptimal.bytes, half * half / 4);
            EXPECT_EQ(greedy.bytes, 2 * previousGreedy.bytes);
        }
        previousOptimal = optimal;
        previousGreedy = greedy;
    }
}

TEST(Toroidal, ContoursWithFewerThanThreePointsOrNonFinitePointsAreRejected)
{
    // A closed contour needs at least three points; a NaN has no area to compare.
    const auto good = circle(5, 1.0, 0.0), two = circle(2, 1.0, 1.0);
    EXPECT_THROW(tileOptimal(good, two), Error);
    EXPECT_THROW(tileOptimal(two, good), Error);
    EXPECT_THROW(tileGreedy(good, two), Error);
    EXPECT_THROW(tileGreedy({}, good), Error);
    auto bad = circle(5, 1.0, 1.0);
    bad[3].y = std::numeric_limits<double>::quiet_NaN();
    EXPECT_THROW(tileOptimal(good, bad), Error);
    EXPECT_THROW(tileGreedy(bad, good), Error);
    EXPECT_THROW(tileLeastAreaNearest(good, two), Error);
    EXPECT_THROW(tileLeastAreaNearest(bad, good), Error);
}

namespace {

// tileLeastAreaNearest's cost of a band: twice its area, plus kSpanWeight times the squared length
// of each spanning edge once.
double leastAreaNearestCost(const std::vector<Triangle>& band, const std::vector<glm::dvec3>& a,
                            const std::vector<glm::dvec3>& b)
{
    const std::uint32_t m = static_cast<std::uint32_t>(a.size());
    std::set<std::pair<std::uint32_t, std::uint32_t>> spans;
    for (const Triangle& t : band)
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t p = t[k], q = t[(k + 1) % 3];
            if ((p < m) != (q < m)) spans.insert({std::min(p, q), std::max(p, q)});
        }
    double cost = 2.0 * bandArea(band, a, b);
    for (const auto& [p, q] : spans) {
        const glm::dvec3 d = vertex(q, a, b) - vertex(p, a, b);
        cost += kSpanWeight * glm::dot(d, d);
    }
    return cost;
}

// A long thin loop at height z, counterclockwise seen from +z: its long sides (y = 0 and y = 2,
// from x = 0 to 24) hold a point every 4 units from x = `offset`, and one point at each rounded
// end. With `bow`, the sides' points lie `bow` farther out, all but the middle one of each.
std::vector<glm::dvec3> longLoop(double z, double offset, double bow)
{
    std::vector<glm::dvec3> points;
    for (double x = offset; x <= 24.0; x += 4.0) points.push_back({x, x == 12.0 + offset ? 0.0 : -bow, z});
    points.push_back({26.0, 1.0, z});
    for (double x = 24.0 - offset; x >= 0.0; x -= 4.0) points.push_back({x, x == 12.0 - offset ? 2.0 : 2.0 + bow, z});
    points.push_back({-2.0, 1.0, z});
    return points;
}

} // namespace

TEST(Toroidal, LeastAreaNearestMatchesPlainDynamicProgrammingOverEveryStart)
{
    // The spans' cost keeps FKU's bisection over starts exact: minimal paths still do not cross.
    std::mt19937 rng(7);
    for (const auto& [m, n] :
         std::vector<std::pair<std::size_t, std::size_t>>{{6, 6}, {7, 19}, {19, 7}, {31, 33}, {3, 50}}) {
        for (int trial = 0; trial < 3; ++trial) {
            SCOPED_TRACE(std::to_string(m) + " x " + std::to_string(n) + ", trial " + std::to_string(trial));
            const auto a = randomContour(m, 0.0, rng), b = randomContour(n, 1.0, rng);
            const double reference = 2.0 * perStartMinimum(a, b, kSpanWeight);
            EXPECT_NEAR(leastAreaNearestCost(tileLeastAreaNearest(a, b), a, b), reference, 1e-9 * reference);
        }
    }
}

TEST(Toroidal, LeastAreaNearestPairsNearestPointsAcrossAThinSlab)
{
    // Two long thin loops an eighth apart, their points 4 apart along the long sides and offset by
    // 1, the upper loop's sides a twentieth farther out but at their middle points: a strip's
    // area is its chords' length times the distance between the sides, so least area joins every
    // chord of the lower loop to the upper loop's nearest point, in fans 9 long (a capsule
    // tree's trunk, sliced across, had such fans 25 voxels long). With the spans each point joins
    // the other loop's points at most one spacing (4) away in the plane.
    const auto a = longLoop(0.0, 0.0, 0.0), b = longLoop(0.125, 1.0, 0.05);
    const auto longestSpan = [&](const std::vector<Triangle>& band) {
        double longest = 0.0;
        for (const Triangle& t : band)
            for (int k = 0; k < 3; ++k) {
                const std::uint32_t p = t[k], q = t[(k + 1) % 3];
                if ((p < a.size()) == (q < a.size())) continue;
                glm::dvec3 d = vertex(q, a, b) - vertex(p, a, b);
                d.z = 0.0;
                longest = std::max(longest, glm::length(d));
            }
        return longest;
    };
    EXPECT_GT(longestSpan(tileOptimal(a, b)), 8.0); // else the case is not shown
    EXPECT_LE(longestSpan(tileLeastAreaNearest(a, b)), 4.0);
}
