// Tests of closing ends (caps.h): the flat caps' ear clipping.
#include <pipetile/caps.h>

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
