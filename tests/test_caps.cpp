// Tests of closing ends (caps.h): the flat caps' ear clipping.
#include <pipetile/caps.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

using namespace pipetile;

namespace {

double twiceSignedArea(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c)
{
    return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

double twiceSignedArea(const std::vector<glm::dvec2>& polygon)
{
    double sum = 0.0;
    for (std::size_t k = 0; k < polygon.size(); ++k) {
        const glm::dvec2 &a = polygon[k], &b = polygon[(k + 1) % polygon.size()];
        sum += a.x * b.y - a.y * b.x;
    }
    return sum;
}

// `polygon`'s ear clipping covers it exactly: m - 2 triangles, each turning as the polygon does,
// whose areas add up to the polygon's. A triangle outside the polygon (a reflex corner clipped)
// turns the other way, or adds area the polygon lacks.
void expectCovers(const std::vector<glm::dvec2>& polygon)
{
    const std::vector<Triangle> triangles = earClip(polygon);
    ASSERT_EQ(triangles.size(), polygon.size() - 2);
    const double area = twiceSignedArea(polygon);
    double sum = 0.0;
    for (const Triangle& t : triangles) {
        const double a = twiceSignedArea(polygon[t[0]], polygon[t[1]], polygon[t[2]]);
        EXPECT_GE(a * area, 0.0) << t[0] << " " << t[1] << " " << t[2];
        sum += std::abs(a);
    }
    EXPECT_NEAR(sum, std::abs(area), 1e-9 * std::abs(area));
}

// A C: a square with a notch cut into its right side, counterclockwise.
std::vector<glm::dvec2> notchedSquare()
{
    return {{0, 0}, {4, 0}, {4, 1.5}, {2, 1.5}, {2, 2.5}, {4, 2.5}, {4, 4}, {0, 4}};
}

} // namespace

TEST(Caps, EarClippingCoversACounterclockwisePolygon)
{
    expectCovers(notchedSquare());
}

TEST(Caps, EarClippingCoversAHolesClockwiseRing)
{
    // A hole's ring runs clockwise, and its flat cap is clipped from it as it runs. Its turns were
    // taken as a counterclockwise polygon's: every corner looked reflex, the most convex-looking
    // was clipped first, and at the notch that is a reflex corner, a triangle laid over the
    // material beside the hole (on a crop of Gaffer's smoke, over a keyhole's slit there).
    std::vector<glm::dvec2> ring = notchedSquare();
    std::reverse(ring.begin(), ring.end());
    expectCovers(ring);
}

TEST(Caps, EarClippingLetsCopiesOfAPointTouch)
{
    // A junction's cut points are copies of crossings of the ring they cut: a keyhole's slit runs
    // through both. A copy of a corner lies on the ear, not inside it.
    expectCovers({{0, 0}, {3, 0}, {3, 0}, {3, 2}, {1, 1.2}, {0, 2}, {0, 2}});
}

TEST(Caps, NearlyStraightCornersAreNoEars)
{
    // A convex polygon: eleven points on y = -0.01 (25 - (x - 5)^2) for x = 0 to 10 (a bulge 0.25
    // deep) and an apex at (5, 5); the ring starts at the bulge's bottom. The first ear along it is
    // that corner, a triangle 2 long and 0.01 high: aspect ratio 173 (the longest edge squared over
    // twice the area, times sqrt(3) / 2). The fan from the apex has none worse than its outermost
    // triangle's 7.9 (50 over 5.45, times sqrt(3) / 2); flips of the ears' diagonals, each making
    // the thinner of two triangles fatter, end below 10.
    std::vector<glm::dvec2> polygon;
    for (int k = 0; k <= 10; ++k) {
        const double x = (5 + k) % 11;
        polygon.push_back({x, -0.01 * (25.0 - (x - 5.0) * (x - 5.0))});
    }
    std::rotate(polygon.begin(), polygon.begin() + 6, polygon.end()); // x = 0, 1, ..., 10
    polygon.push_back({5.0, 5.0});
    std::rotate(polygon.begin(), polygon.begin() + 5, polygon.end()); // starts at x = 5
    expectCovers(polygon);
    double worst = 0.0;
    for (const Triangle& t : earClip(polygon)) {
        const glm::dvec2 &a = polygon[t[0]], &b = polygon[t[1]], &c = polygon[t[2]];
        const double longest = std::max({glm::dot(b - a, b - a), glm::dot(c - b, c - b), glm::dot(a - c, a - c)});
        worst = std::max(worst, longest / std::abs(twiceSignedArea(a, b, c)) * std::sqrt(3.0) / 2.0);
    }
    EXPECT_LT(worst, 10.0);
}
