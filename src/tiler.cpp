// pipetile — tiler: the triangle band between two corresponding contours, and end caps.
// Integer-only translation unit (see tiler.h): no floating point may appear here.

#include <pipetile/tiler.h>

#include <stdexcept>

namespace pipetile {

namespace {

// Sector reached after each crossing along the main path: F moves one sector on, B one back, U
// and D stay. The running maximum keeps excursions from pulling the walk backwards.
std::vector<int> sectorKeys(const std::vector<EdgeType>& edges)
{
    std::vector<int> keys(edges.size() + 1, 0);
    int sector = 0, reached = 0;
    for (std::size_t i = 0; i < edges.size(); ++i) {
        if (edges[i] == EdgeType::Forward) ++sector;
        else if (edges[i] == EdgeType::Backward) --sector;
        if (sector > reached) reached = sector;
        keys[i + 1] = reached;
    }
    return keys;
}

} // namespace

std::vector<Triangle> tileBand(const std::vector<EdgeType>& a, const std::vector<EdgeType>& b)
{
    const std::uint32_t m = static_cast<std::uint32_t>(a.size()), n = static_cast<std::uint32_t>(b.size());
    if (m < 1 || n < 1) throw std::invalid_argument("tileBand: both contours need crossings");
    const std::vector<int> ka = sectorKeys(a), kb = sectorKeys(b);
    std::vector<Triangle> band;
    band.reserve(m + n);
    std::uint32_t i = 0, j = 0;
    while (i < m || j < n) {
        // Advance the contour whose next crossing lies in the earlier sector; on a tie, A first,
        // which splits every quad along the same diagonal.
        const bool advanceA = j == n || (i < m && ka[i + 1] <= kb[j + 1]);
        const std::uint32_t ai = i % m, bj = m + j % n;
        if (advanceA) {
            band.push_back({ai, (i + 1) % m, bj});
            ++i;
        } else {
            band.push_back({ai, m + (j + 1) % n, bj});
            ++j;
        }
    }
    return band;
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
