// pipetile — tiler: the triangle band between two corresponding contours, and end caps.
// Integer-only translation unit (see tiler.h): no floating point may appear here.

#include <pipetile/tiler.h>
#include <pipetile/error.h>

#include <utility>

namespace pipetile {

namespace {

// A contour in traversal order: position p is the p-th crossing from where F_0 starts; position
// `count` is that crossing again, where the band closes.
struct Walk {
    const ContourTree& tree;
    std::uint32_t count, start;

    explicit Walk(const ContourTree& t)
        : tree(t),
          count(static_cast<std::uint32_t>(t.keys().size())),
          start(static_cast<std::uint32_t>(t.startCrossing()))
    {
    }
    std::uint32_t crossing(std::uint32_t p) const { return (start + p) % count; }
    TraversalKey key(std::uint32_t p) const
    {
        return p == count ? TraversalKey{tree.rays(), 3, 0, 0} : tree.keys()[crossing(p)];
    }
    int ray(std::uint32_t p) const { return tree.crossingRays()[crossing(p)]; }
    // The number of crossings of the excursion that starts at position p + 1, or 0 if p + 1
    // does not start one.
    std::uint32_t excursionAfter(std::uint32_t p) const
    {
        auto inExcursion = [](const TraversalKey& k) { return k.slot == 1 || k.slot == 2; };
        auto same = [](const TraversalKey& k, const TraversalKey& o) {
            return k.sector == o.sector && k.slot == o.slot;
        };
        if (p >= count || !inExcursion(key(p + 1)) || same(key(p), key(p + 1))) return 0;
        std::uint32_t length = 1;
        while (same(key(p + 1), key(p + 1 + length))) ++length;
        return length;
    }
};

// Rays apart, the short way round a set of n.
int rayGap(int r, int s, int n)
{
    const int d = r > s ? r - s : s - r;
    return d < n - d ? d : n - d;
}

// An alignment's lattice has (p + 1) (q + 1) states; above this many the traversal's own order is
// kept (a sector whose excursions hold thousands of crossings: noise, not a wall).
constexpr std::size_t kMostAlignmentStates = std::size_t{1} << 22;

// The steps (true: advance A) that tile the excursions A[i+1 .. i+p] and B[j+1 .. j+q] of one
// sector: the monotone path from (i, j) to (i+p, j+q) whose spanning edges skip the fewest rays
// in all, and among those the one that departs least from the traversal's own order.
//
// Why: the paper pairs an excursion's children by position, which holds while the two contours
// parse alike. Where a ray grazes a wall, the two contours' excursions cross the same wall the
// same way but parse differently (one clips a bulge the other misses), position pairing puts
// unrelated children together, and a whole child is fanned to one vertex 25 pixels along the
// wall. The rays the crossings lie on say where along the wall each one is, in integers.
void alignExcursions(const Walk& a, std::uint32_t i, std::uint32_t p, const Walk& b, std::uint32_t j, std::uint32_t q,
                     std::vector<bool>& steps)
{
    const std::size_t width = q + 1;
    auto at = [&](std::uint32_t u, std::uint32_t v) { return u * width + v; };
    // One ray skipped outweighs every departure from the traversal's order the path can make.
    const long long weight = static_cast<long long>(p) + q + 1;
    std::vector<long long> cost((p + 1) * width, 0);
    std::vector<std::uint8_t> byA((p + 1) * width, 0);
    for (std::uint32_t u = 0; u <= p; ++u) {
        for (std::uint32_t v = 0; v <= q; ++v) {
            if (u == 0 && v == 0) continue;
            const long long here = weight * rayGap(a.ray(i + u), b.ray(j + v), a.tree.rays());
            long long best = -1;
            if (u > 0) { // A advanced from (u - 1, v): what the traversal does there if A's key is first
                const bool traversalAdvancesA = a.key(i + u) <= b.key(j + v + 1);
                best = cost[at(u - 1, v)] + (traversalAdvancesA ? 0 : 1);
                byA[at(u, v)] = 1;
            }
            if (v > 0) {
                const bool traversalAdvancesA = a.key(i + u + 1) <= b.key(j + v);
                const long long viaB = cost[at(u, v - 1)] + (traversalAdvancesA ? 1 : 0);
                if (best < 0 || viaB < best) {
                    best = viaB;
                    byA[at(u, v)] = 0;
                }
            }
            cost[at(u, v)] = best + here;
        }
    }
    std::vector<bool> path;
    path.reserve(p + q);
    for (std::uint32_t u = p, v = q; u > 0 || v > 0;) {
        const bool advancedA = byA[at(u, v)] != 0;
        path.push_back(advancedA);
        if (advancedA)
            --u;
        else
            --v;
    }
    steps.insert(steps.end(), path.rbegin(), path.rend());
}

// The rays an excursion reaches, as offsets from the ray it hangs on (crossing `from`): the
// farthest back and the farthest on.
std::pair<int, int> reach(const Walk& w, std::uint32_t from, std::uint32_t length)
{
    const int n = w.tree.rays();
    int back = 0, on = 0;
    for (std::uint32_t k = 1; k <= length; ++k) {
        const int offset = ((w.ray(from + k) - w.ray(from)) % n + n + n / 2) % n - n / 2;
        back = offset < back ? offset : back;
        on = offset > on ? offset : on;
    }
    return {back, on};
}

// Whether two excursions of a sector cross the same wall but parse differently: they reach the
// same rays along different ray sequences. Alike ones keep the paper's pairing, and so do ones
// whose reach differs: the wall itself changed between the planes (a slot closing, a bump
// growing), and fanning the part one of them lacks is the paper's answer (traversal case 3).
bool sameWallParsedDifferently(const Walk& a, std::uint32_t i, std::uint32_t p, const Walk& b, std::uint32_t j,
                               std::uint32_t q)
{
    if (reach(a, i, p) != reach(b, j, q)) return false;
    if (p != q) return true;
    for (std::uint32_t k = 1; k <= p; ++k)
        if (a.ray(i + k) != b.ray(j + k)) return true;
    return false;
}

// Whether the excursions after positions i and j (p and q crossings) are tiled along their rays:
// both excursions of one sector and slot, of contours cast with as many rays, within the bound,
// crossing the same wall but parsed differently.
bool alignedByRays(const Walk& a, std::uint32_t i, std::uint32_t p, const Walk& b, std::uint32_t j, std::uint32_t q)
{
    return p > 0 && q > 0 && a.tree.rays() == b.tree.rays() && a.key(i + 1).sector == b.key(j + 1).sector &&
           a.key(i + 1).slot == b.key(j + 1).slot && (p + 1) * std::size_t{q + 1} <= kMostAlignmentStates &&
           sameWallParsedDifferently(a, i, p, b, j, q);
}

} // namespace

std::vector<Triangle> tileBand(const ContourTree& a, const ContourTree& b)
{
    const Walk wa(a), wb(b);
    const std::uint32_t m = wa.count, n = wb.count;
    std::vector<bool> steps; // true: advance A
    steps.reserve(m + n);
    std::uint32_t i = 0, j = 0;
    while (i < m || j < n) {
        const std::uint32_t p = wa.excursionAfter(i), q = wb.excursionAfter(j);
        if (alignedByRays(wa, i, p, wb, j, q)) {
            alignExcursions(wa, i, p, wb, j, q, steps);
            i += p;
            j += q;
            continue;
        }
        // Advance the contour whose next crossing comes first in the traversal; on a tie, A
        // first, which splits every quad along the same diagonal.
        const bool advanceA = j == n || (i < m && wa.key(i + 1) <= wb.key(j + 1));
        steps.push_back(advanceA);
        if (advanceA)
            ++i;
        else
            ++j;
    }
    std::vector<Triangle> band;
    band.reserve(m + n);
    i = 0;
    j = 0;
    for (bool advanceA : steps) {
        const std::uint32_t ai = wa.crossing(i), bj = m + wb.crossing(j);
        if (advanceA)
            band.push_back({ai, wa.crossing(++i), bj});
        else
            band.push_back({ai, m + wb.crossing(++j), bj});
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
