// pipetile — tiler: the triangle band between two corresponding contours, and end caps.
// Integer-only translation unit (see tiler.h): no floating point may appear here.

#include <pipetile/tiler.h>
#include <pipetile/error.h>

namespace pipetile {

std::vector<Triangle> tileBand(const ContourTree& a, const ContourTree& b)
{
    const std::uint32_t m = static_cast<std::uint32_t>(a.keys().size()),
                        n = static_cast<std::uint32_t>(b.keys().size());
    const std::uint32_t sa = static_cast<std::uint32_t>(a.startCrossing()),
                        sb = static_cast<std::uint32_t>(b.startCrossing());
    // Past the last crossing the traversal is back at F_0: the key of the closing vertex.
    const TraversalKey end{a.rays(), 3, 0, 0};
    auto keyA = [&](std::uint32_t i) { return i == m ? end : a.keys()[(sa + i) % m]; };
    auto keyB = [&](std::uint32_t j) { return j == n ? end : b.keys()[(sb + j) % n]; };
    std::vector<Triangle> band;
    band.reserve(m + n);
    std::uint32_t i = 0, j = 0;
    while (i < m || j < n) {
        // Advance the contour whose next crossing comes first in the traversal; on a tie, A
        // first, which splits every quad along the same diagonal.
        const bool advanceA = j == n || (i < m && keyA(i + 1) <= keyB(j + 1));
        const std::uint32_t ai = (sa + i) % m, bj = m + (sb + j) % n;
        if (advanceA) {
            band.push_back({ai, (sa + i + 1) % m, bj});
            ++i;
        } else {
            band.push_back({ai, m + (sb + j + 1) % n, bj});
            ++j;
        }
    }
    return band;
}

ContourString stringOfEdges(const std::vector<EdgeType>& edges)
{
    ContourString c;
    c.edges = edges;
    int ray = 0;
    for (EdgeType t : edges) {
        c.ray.push_back(ray);
        ray += t == EdgeType::Forward ? 1 : t == EdgeType::Backward ? -1 : 0;
    }
    c.rays = ray; // #F - #B for a contour that winds once
    for (int& r : c.ray) r = c.rays > 0 ? ((r % c.rays) + c.rays) % c.rays : 0;
    c.depth.assign(edges.size(), 0);
    return c;
}

std::vector<Triangle> tileBand(const std::vector<EdgeType>& a, const std::vector<EdgeType>& b)
{
    if (a.empty() || b.empty()) throw UsageError("tileBand: both contours need crossings");
    return tileBand(ContourTree(stringOfEdges(a)), ContourTree(stringOfEdges(b)));
}

std::vector<Triangle> tileCap(std::uint32_t m, bool top)
{
    std::vector<Triangle> cap;
    cap.reserve(m);
    for (std::uint32_t i = 0; i < m; ++i) {
        const std::uint32_t next = (i + 1) % m;
        cap.push_back(top ? Triangle{i, next, m} : Triangle{next, i, m});
    }
    return cap;
}

std::vector<Triangle> tileFlatCap(std::uint32_t m, bool top)
{
    std::vector<Triangle> cap;
    cap.reserve(m > 2 ? m - 2 : 0);
    for (std::uint32_t i = 1; i + 1 < m; ++i) cap.push_back(top ? Triangle{0, i, i + 1} : Triangle{0, i + 1, i});
    return cap;
}

} // namespace pipetile
