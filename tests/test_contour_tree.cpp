#include <pipetile/detail/field_image.h>
#include <pipetile/contour_tree.h>
#include <pipetile/error.h>
#include <pipetile/tiler.h>

#include <gtest/gtest.h>

#include "test_util.h"

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <cmath>
#include <map>
#include <random>
#include <set>

using namespace pipetile;
using pipetile::detail::FieldImage;

namespace {

ContourString parse(const std::string& s, std::vector<int> depth = {})
{
    ContourString c = stringOfEdges(test::parseEdges(s));
    if (!depth.empty()) c.depth = depth;
    return c;
}

ContourString rotate(const ContourString& c, int by)
{
    ContourString r = c;
    const int m = static_cast<int>(c.edges.size());
    for (int i = 0; i < m; ++i) {
        r.edges[i] = c.edges[(i + by) % m];
        r.ray[i] = c.ray[(i + by) % m];
        r.depth[i] = c.depth[(i + by) % m];
    }
    return r;
}

} // namespace

TEST(ContourTree, UnambiguousContourWithAFoldEachWay)
{
    // n = 6 (6 F edges). A fold on ray 2 met from inside (U_I U_O: rule [5] makes a U node) hangs
    // left of level-1 node 2; a fold on ray 4 met from outside (D_I D_O) hangs right of node 3.
    const ContourTree tree(parse("F F U_I U_O F F D_I D_O F F"));
    EXPECT_EQ(tree.toString(), "(R (1 F) (1 F) (1 F U:(5U U_I U_O)) (1 F D:(5D D_I D_O)) (1 F) (1 F))");
    EXPECT_EQ(tree.ambiguousSectors(), 0);
    EXPECT_EQ(tree.mainEdge(2), 4); // the F edge after the fold
}

TEST(ContourTree, AmbiguousSectorHasBothParsesOfTheWorkedExample)
{
    // DESIGN.md's fold across rays 1 and 2: `F(inner) U_I B U_O F(outer)` in sector 1 (t = 2).
    // Crossings on ray 1, from the centre out: c1 (depth 0), c4 (1), c5 (2).
    const ContourString c = parse("F F U_I B U_O F F F", {0, 0, 0, 0, 1, 2, 0, 0});
    // Outermost first (no neighbour): F(outer) in node 1; rule [9] makes `F U_I B` a composite U_I
    // and rule [5] joins it with U_O into a U node on ray 1.
    const ContourTree outer(c);
    EXPECT_EQ(outer.toString(), "(R (1 F) (1 F U:(5U (9U_I F U_I B) U_O)) (1 F) (1 F))");
    EXPECT_EQ(outer.ambiguousSectors(), 1);
    EXPECT_EQ(outer.mainEdge(1), 5);
    // Rule [1'] preferring the inner F edge (as a neighbour would): the excursion U_I [B U_O F]
    // hangs on node 2 instead.
    const ContourTree inner(c, {{0}, {0, 1}, {0}, {0}});
    EXPECT_EQ(inner.toString(), "(R (1 F) (1 F) (1 F U:(5U U_I (9U_O B U_O F))) (1 F))");
    EXPECT_EQ(inner.mainEdge(1), 1);
}

TEST(ContourTree, RefusesAStringThatDoesNotWindOnce)
{
    // #F - #B = 0: the centre lies outside the loop.
    EXPECT_THROW(ContourTree(parse("F F B B")), UsageError);
}

TEST(ContourTree, KeysIncreaseAlongTheWalkFromTheStart)
{
    // The traversal meets the crossings of one contour in walk order: keys never decrease.
    const ContourTree tree(parse("F F U_I B U_O F F F D_I D_O F", {0, 0, 0, 0, 1, 2, 0, 0, 0, 0, 0}));
    const int m = static_cast<int>(tree.keys().size());
    for (int i = 0; i + 1 < m; ++i) {
        const int a = (tree.startCrossing() + i) % m, b = (tree.startCrossing() + i + 1) % m;
        EXPECT_TRUE(tree.keys()[a] <= tree.keys()[b]) << i;
    }
}

TEST(ContourTree, TilingDoesNotDependOnTheStartingCrossing)
{
    // The same contours listed from every crossing: the same triangles (ids mapped back).
    const ContourString a = parse("F F U_I B U_O F F F D_I D_O F", {0, 0, 0, 0, 1, 2, 0, 0, 0, 0, 0});
    const ContourString b = parse("F U_I U_O F F F F F F", {0, 0, 1, 2, 0, 0, 0, 0, 0});
    const std::uint32_t m = static_cast<std::uint32_t>(a.edges.size()), n = static_cast<std::uint32_t>(b.edges.size());
    auto canonical = [&](const std::vector<Triangle>& band, int ra, int rb) {
        std::set<std::array<std::uint32_t, 3>> s;
        for (Triangle t : band) {
            for (std::uint32_t& v : t) v = v < m ? (v + ra) % m : m + (v - m + rb) % n;
            std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
            s.insert(t);
        }
        return s;
    };
    const auto reference = canonical(tileBand(ContourTree(a), ContourTree(b)), 0, 0);
    for (int ra = 0; ra < static_cast<int>(m); ++ra)
        for (int rb = 0; rb < static_cast<int>(n); ++rb)
            EXPECT_EQ(canonical(tileBand(ContourTree(rotate(a, ra)), ContourTree(rotate(b, rb))), ra, rb), reference)
                << ra << " " << rb;
}

TEST(ContourTree, RandomNonStarSectionsTileAsClosedStrips)
{
    // Thousands of random cross-sections that are not star-shaped: a disk with random bumps,
    // notches and a spiral slit, and its neighbour a perturbed, rotated copy. Every band must be
    // a closed strip of m + n triangles; identical neighbours must match crossing for crossing
    // (traversal case 1 everywhere: each crossing i of A meets crossing i of B).
    std::mt19937 rng(20261122);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    int tested = 0, ambiguous = 0, nonStar = 0;
    for (int trial = 0; trial < 2000; ++trial) {
        const int size = 48;
        const glm::dvec2 c(size / 2.0 + unit(rng), size / 2.0 + unit(rng));
        const int bumps = 1 + static_cast<int>(unit(rng) * 5);
        std::vector<glm::dvec4> features; // angle, radius, width, sign
        for (int k = 0; k < bumps; ++k)
            features.push_back({unit(rng) * 6.2832, 6 + unit(rng) * 10, 1.5 + unit(rng) * 3, unit(rng) < 0.5 ? -1 : 1});
        const double spiral = unit(rng) < 0.4 ? 0.5 + unit(rng) : 0.0;
        auto image = [&](double rotation, double jitter) {
            FieldImage img;
            img.width = img.height = size;
            img.values.resize(size * size);
            for (int v = 0; v < size; ++v)
                for (int u = 0; u < size; ++u) {
                    const glm::dvec2 p = glm::dvec2(u, v) - c;
                    const double r = glm::length(p), a = std::atan2(p.y, p.x) - rotation;
                    double f = r - 12.0 - jitter;
                    for (const glm::dvec4& b : features) {
                        const glm::dvec2 q = p - b.y * glm::dvec2(std::cos(b.x + rotation), std::sin(b.x + rotation));
                        const double d = glm::length(q) - b.z;
                        f = b.w > 0 ? std::min(f, d) : std::max(f, -d);
                    }
                    if (spiral > 0.0) {
                        // A slit along r = 4 + 3 * spiral * angle: cuts a spiral notch into the disk.
                        const double wrapped = std::fmod(a + 12.566, 6.2832);
                        const double slit = std::abs(r - (4.0 + 1.3 * spiral * wrapped)) - 0.7;
                        if (wrapped > 1.0) f = std::max(f, -slit);
                    }
                    img.values[v * size + u] = f;
                }
            return img;
        };
        const FieldImage ia = image(0.0, 0.0), ib = image(0.05 * (unit(rng) - 0.5), 0.3 * unit(rng));
        const std::vector<BoundaryLoop> la = traceBoundaries(ia), lb = traceBoundaries(ib);
        auto largest = [](const std::vector<BoundaryLoop>& loops) {
            return *std::max_element(loops.begin(), loops.end(),
                                     [](const BoundaryLoop& x, const BoundaryLoop& y) { return x.area < y.area; });
        };
        if (la.empty() || lb.empty()) continue;
        const BoundaryLoop a = largest(la), b = largest(lb);
        const RaySet rays{8, trial % 3};
        const Contour ca = castRays(a, centralPoint(a), rays, ia), cb = castRays(b, centralPoint(b), rays, ib);
        if (ca.crossings.empty() || cb.crossings.empty()) continue;
        const ContourTree ta(contourString(ca)), tb(contourString(cb));
        ++tested;
        ambiguous += ta.ambiguousSectors() > 0 ? 1 : 0;
        nonStar += ca.crossings.size() > static_cast<std::size_t>(rays.count()) ? 1 : 0;
        const std::uint32_t m = static_cast<std::uint32_t>(ca.crossings.size()),
                            n = static_cast<std::uint32_t>(cb.crossings.size());
        ASSERT_TRUE(test::isClosedStrip(tileBand(ta, tb), m, n)) << "trial " << trial;
        const std::vector<Triangle> self = tileBand(ta, ta);
        ASSERT_TRUE(test::isClosedStrip(self, m, m)) << "trial " << trial;
        for (std::uint32_t i = 0; i < m; ++i) {
            // Identical contours: a quad between crossings i, i+1 of both, for every i.
            const std::uint32_t s = static_cast<std::uint32_t>(ta.startCrossing());
            const std::uint32_t p = (s + i) % m, q = (s + i + 1) % m;
            EXPECT_EQ(self[2 * i], (Triangle{p, q, m + p}));
            EXPECT_EQ(self[2 * i + 1], (Triangle{q, m + q, m + p}));
        }
    }
    // The generator must really produce what the test is about.
    EXPECT_GT(tested, 1800);
    EXPECT_GT(nonStar, tested / 4);
    EXPECT_GT(ambiguous, 20);
    std::printf("[ stats    ] %d sections, %d not star-shaped, %d with ambiguous sectors\n", tested, nonStar,
                ambiguous);
}

namespace {

// A random cyclic edge string that winds once around n rays but may spiral on the way: a random
// walk over (ray, crossing kind) whose sector level (F +1, B -1) wanders up to `reach` turns either
// side before the walk is steered home to level n. Noisy sections (fog with noise, CT) give such
// strings: an arm that curls more than a full turn around the centre and comes back.
ContourString spiralString(std::mt19937& rng, int n, int steps, int reach)
{
    std::uniform_int_distribution<int> coin(0, 1);
    std::vector<EdgeType> edges;
    int level = 0;
    bool inOut = true; // the walk starts at an IN-OUT crossing of ray 0
    auto step = [&](bool forward) {
        if (forward) {
            if (!inOut) edges.push_back(coin(rng) ? EdgeType::UpOut : EdgeType::DownOut);
            edges.push_back(EdgeType::Forward);
            inOut = true;
            ++level;
        } else {
            if (inOut) edges.push_back(coin(rng) ? EdgeType::UpIn : EdgeType::DownIn);
            edges.push_back(EdgeType::Backward);
            inOut = false;
            --level;
        }
    };
    edges.push_back(EdgeType::Forward); // F_0 is a forward crossing of level 0
    ++level;
    for (int k = 0; k < steps; ++k) {
        const bool forward = level <= -reach * n ? true : level >= (reach + 1) * n ? false : coin(rng) == 1;
        step(forward);
    }
    while (level != n) step(level < n);
    if (!inOut) edges.push_back(coin(rng) ? EdgeType::UpOut : EdgeType::DownOut);
    ContourString c = stringOfEdges(edges);
    std::uniform_int_distribution<int> depth(0, 3);
    for (int& d : c.depth) d = depth(rng); // rule [1'] without a neighbour: the outermost F edge
    return c;
}

} // namespace

TEST(ContourTree, SpiralSectionsHaveABalancedMainPath)
{
    // Rule [1] needs one F edge per sector whose excursions in between come back to their ray:
    // F_x must cross sector level x on the walk from F_0 (F +1, B -1), not x plus or minus a turn.
    // Strings that spiral (levels beyond n or below 0) used to pick F edges a turn away, which
    // left an unbalanced excursion or no main path at all (issue 14, noisy fog volumes). Every
    // such string must build, with F_x in sector x, in walk order, a level x from F_0, and tile
    // against any other string of the same n as a closed strip of m + n triangles.
    std::mt19937 rng(14);
    int spirals = 0;
    for (int trial = 0; trial < 3000; ++trial) {
        const int n = 3 + trial % 6;
        const ContourString a = spiralString(rng, n, 4 + trial % 40, 1 + trial % 2);
        const ContourString b = spiralString(rng, n, 4 + (trial * 7) % 40, 1);
        ASSERT_EQ(a.rays, n);
        const ContourTree ta(a), tb(b);
        const int m = static_cast<int>(a.edges.size());
        int level = 0, x = 0;
        bool spiral = false;
        for (int i = 0; i < m; ++i) {
            const int edge = (ta.startCrossing() + i) % m;
            if (x < n && edge == ta.mainEdge(x)) {
                ASSERT_EQ(level, x) << "trial " << trial << ": F_" << x << " lies a turn away";
                ASSERT_EQ(a.ray[edge], x);
                ++x;
            }
            level += a.edges[edge] == EdgeType::Forward ? 1 : a.edges[edge] == EdgeType::Backward ? -1 : 0;
            spiral = spiral || level < 0 || level > n;
        }
        ASSERT_EQ(x, n) << "trial " << trial << ": main path out of walk order";
        spirals += spiral ? 1 : 0;
        ASSERT_TRUE(test::isClosedStrip(tileBand(ta, tb), static_cast<std::uint32_t>(m),
                                        static_cast<std::uint32_t>(b.edges.size())))
            << "trial " << trial;
    }
    EXPECT_GT(spirals, 1000); // the generator must really make spirals
}
