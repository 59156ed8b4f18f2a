// pipetile — toroidal: baseline tilers over the toroidal graph of two contours.
//
// H. Fuchs, Z. M. Kedem, S. P. Uselton, "Optimal surface reconstruction from planar contours",
//   Communications of the ACM 20(10):693-702, 1977. Minimum-area acceptable surface; minimal
//   paths from different starts do not cross, which bounds each search by two earlier ones.
// H. N. Christiansen, T. W. Sederberg, "Conversion of complex contour line definitions into
//   polygonal element mosaics", Computer Graphics 12(3):187-192 (SIGGRAPH 1978). Greedy: the
//   shorter spanning edge wins.
// M. Maes, "On a cyclic string-to-string correction problem", Information Processing Letters
//   35(2):73-78, 1990: the same divide and conquer over cyclic starts, O(mn log m).

#include <pipetile/toroidal.h>

#include <pipetile/error.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

namespace pipetile {

namespace {

void checkContour(const std::vector<glm::dvec3>& points, const char* tiler, const char* name)
{
    if (points.size() < 3)
        throw Error(std::string(tiler) + ": contour " + name + " has " + std::to_string(points.size()) +
                    " points; a closed contour needs at least 3");
    for (std::size_t i = 0; i < points.size(); ++i) {
        const glm::dvec3& p = points[i];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
            throw Error(std::string(tiler) + ": point " + std::to_string(i) + " of contour " + name + " is not finite");
    }
}

void checkPair(const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b, const char* tiler)
{
    checkContour(a, tiler, "A");
    checkContour(b, tiler, "B");
    // Vertex ids are 32-bit: m + n of them.
    if (a.size() + b.size() > std::numeric_limits<std::uint32_t>::max())
        throw Error(std::string(tiler) + ": contours too large for 32-bit vertex ids");
}

// Twice the area of triangle (p, q, r); the factor 2 is common to every cost, so it never changes
// which surface is smallest.
double doubleArea(const glm::dvec3& p, const glm::dvec3& q, const glm::dvec3& r)
{
    return glm::length(glm::cross(q - p, r - p));
}

// Squared length of the spanning edge p - q.
double squaredSpan(const glm::dvec3& p, const glm::dvec3& q)
{
    const glm::dvec3 d = q - p;
    return glm::dot(d, d);
}

// The toroidal graph unrolled along the smaller contour X (p points) against Y (q points).
// Vertex (x, y) is the spanning edge X[x mod p] - Y[y mod q]; a step in x adds the triangle
// (X_x, X_x+1, Y_y), a step in y adds (X_x, Y_y, Y_y+1). Every acceptable surface passes through
// a vertex with y = 0 (mod q), so it is a monotone lattice path from (s, 0) to (s + p, q) for one
// start s in [0, p): searching p starts, not p * q, is exact.
class MinimalAreaSurface {
public:
    // A monotone path, stored by the last x it reaches on each row; row y begins where row y - 1
    // ends (the step in y keeps x). q + 1 words per path, where the DP table would need p * q.
    struct Path {
        std::uint32_t start = 0;
        std::vector<std::uint32_t> right;
        std::uint32_t left(std::size_t y) const { return y == 0 ? start : right[y - 1]; }
    };

    // Each step costs its triangle's (doubled) area, plus `spanWeight` times the squared length of
    // the spanning edge it reaches (each of the surface's spans once).
    MinimalAreaSurface(const std::vector<glm::dvec3>& x, const std::vector<glm::dvec3>& y, double spanWeight)
        : mP(static_cast<std::uint32_t>(x.size())),
          mQ(static_cast<std::uint32_t>(y.size())),
          mSpanWeight(spanWeight)
    {
        // Unrolled copies (x < 2p, y <= q) so the inner loops index without wrapping.
        mX.reserve(2 * mP);
        mX.insert(mX.end(), x.begin(), x.end());
        mX.insert(mX.end(), x.begin(), x.end());
        mY.reserve(mQ + 1);
        mY.insert(mY.end(), y.begin(), y.end());
        mY.push_back(y.front());
        // Rows are clipped to [s, s + p], so one table of (p + 1)(q + 1) bits serves every start.
        const std::size_t cells = static_cast<std::size_t>(mP + 1) * (mQ + 1);
        mChoice.assign((cells + 63) / 64, 0);
        mCost.resize(mP + 1);
        mAreaX.resize(mP + 1);
        std::size_t depth = 1;
        while ((std::size_t{1} << depth) < mP) ++depth;
        mStack.resize(depth + 1);
    }

    // Finds the minimal path over all starts: start 0 unconstrained, start p is start 0 shifted by
    // a period, and every start in between lies between the minimal paths of its neighbours.
    void solve()
    {
        Path first;
        mBestCost = search(0, nullptr, nullptr, first);
        mBest = first;
        Path last = first;
        last.start += mP;
        for (std::uint32_t& r : last.right) r += mP;
        bisect(first, last, 0);
        mKept = pathBytes(first) + pathBytes(last);
    }

    const Path& best() const { return mBest; }

    std::size_t bytes() const
    {
        std::size_t total = mChoice.capacity() * sizeof(std::uint64_t) +
                            (mCost.capacity() + mAreaX.capacity()) * sizeof(double) +
                            (mX.capacity() + mY.capacity()) * sizeof(glm::dvec3) + pathBytes(mBest) + mKept;
        for (const Path& path : mStack) total += pathBytes(path);
        return total;
    }

private:
    static std::size_t pathBytes(const Path& path) { return path.right.capacity() * sizeof(std::uint32_t); }

    bool choice(std::size_t bit) const { return (mChoice[bit >> 6] >> (bit & 63)) & 1u; }

    // Row y of the search for start s: x in [s, s + p], and between the lower and upper paths.
    std::uint32_t rowBegin(std::uint32_t s, const Path* lower, std::size_t y) const
    {
        return lower ? std::max(s, lower->left(y)) : s;
    }
    std::uint32_t rowEnd(std::uint32_t s, const Path* upper, std::size_t y) const
    {
        return upper ? std::min(s + mP, upper->right[y]) : s + mP;
    }

    // Minimal path from (s, 0) to (s + p, q) that stays between `lower` and `upper` (none: free).
    // Exact: where a minimal path crosses a neighbouring minimal path they share a vertex, and
    // swapping the pieces between shared vertices keeps both costs, so a minimal path exists
    // inside the band (FKU). Keeps one row of costs and one choice bit per cell.
    double search(std::uint32_t s, const Path* lower, const Path* upper, Path& path)
    {
        constexpr double unreachable = std::numeric_limits<double>::infinity();
        // Choices are written as one bit stream, row after row, a word at a time.
        std::uint64_t word = 0;
        unsigned filled = 0;
        std::size_t words = 0, offset = 0;
        auto put = [&](bool stepX) {
            word |= std::uint64_t{stepX} << filled;
            if (++filled == 64) mChoice[words++] = word, word = 0, filled = 0;
        };
        std::uint32_t prevEnd = s;
        for (std::uint32_t y = 0; y <= mQ; ++y) {
            // Both bounds only grow with y, so row y overlaps row y - 1 on [begin, prevEnd] and the
            // cost row can be updated in place.
            const std::uint32_t begin = rowBegin(s, lower, y), end = rowEnd(s, upper, y);
            PIPETILE_ASSERT(begin <= prevEnd && prevEnd <= end, "a search row does not overlap the row below it");
            double* cost = mCost.data(); // both indexed by x - s
            double* areaX = mAreaX.data();
            // The row's triangle areas first: independent of each other, so they pipeline, and
            // the scan below only adds and compares.
            for (std::uint32_t x = begin; x < end; ++x) areaX[x - s] = doubleArea(mX[x], mX[x + 1], mY[y]);
            if (mSpanWeight > 0.0)
                for (std::uint32_t x = begin; x < end; ++x) areaX[x - s] += mSpanWeight * squaredSpan(mX[x + 1], mY[y]);
            if (y == 0)
                cost[0] = 0.0;
            else
                for (std::uint32_t x = begin; x <= prevEnd; ++x)
                    cost[x - s] += doubleArea(mX[x], mY[y - 1], mY[y]) +
                                   (mSpanWeight > 0.0 ? mSpanWeight * squaredSpan(mX[x], mY[y]) : 0.0);
            for (std::uint32_t x = prevEnd + 1; x <= end; ++x) cost[x - s] = unreachable;
            put(false);
            for (std::uint32_t i = begin - s + 1; i <= end - s; ++i) {
                const double viaX = cost[i - 1] + areaX[i - 1];
                const bool stepX = viaX < cost[i];
                cost[i] = stepX ? viaX : cost[i];
                put(stepX);
            }
            offset += end - begin + 1;
            prevEnd = end;
        }
        if (filled > 0) mChoice[words] = word;
        const double total = mCost[mP];
        PIPETILE_ASSERT(total < unreachable, "no path between the bounding paths");

        // Walk the choices back from (s + p, q); rows are visited top down, so their offsets are
        // recovered by subtracting widths instead of being stored.
        path.start = s;
        path.right.resize(mQ + 1);
        std::uint32_t x = s + mP;
        for (std::uint32_t y = mQ;; --y) {
            const std::uint32_t begin = rowBegin(s, lower, y), end = rowEnd(s, upper, y);
            offset -= end - begin + 1;
            path.right[y] = x;
            while (choice(offset + (x - begin))) --x;
            if (y == 0) break;
        }
        PIPETILE_ASSERT(x == s, "the traced path does not end at its start");
        return total;
    }

    void bisect(const Path& lower, const Path& upper, std::size_t depth)
    {
        if (upper.start - lower.start < 2) return;
        PIPETILE_ASSERT(depth < mStack.size(), "bisection deeper than log2 of the starts");
        const std::uint32_t s = lower.start + (upper.start - lower.start) / 2;
        Path& middle = mStack[depth];
        const double cost = search(s, &lower, &upper, middle);
        // The smallest start wins a tie, whatever order the starts are searched in.
        if (cost < mBestCost || (cost == mBestCost && s < mBest.start)) {
            mBestCost = cost;
            mBest = middle;
        }
        bisect(lower, middle, depth + 1);
        bisect(middle, upper, depth + 1);
    }

    const std::uint32_t mP, mQ;
    const double mSpanWeight;
    std::vector<glm::dvec3> mX, mY;     // X twice over, Y with its first point again at the end
    std::vector<std::uint64_t> mChoice; // per searched cell: 1 = reached by a step in x
    std::vector<double> mCost;          // path costs of the current row, indexed by x - s
    std::vector<double> mAreaX;         // areas of the row's steps in x, indexed by x - s
    std::vector<Path> mStack;           // one path per recursion depth of bisect
    Path mBest;
    double mBestCost = std::numeric_limits<double>::infinity();
    std::size_t mKept = 0; // bytes of the two outer paths of the bisection
};

} // namespace

namespace {

// The minimal surface of MinimalAreaSurface's cost, as a strip of triangles.
std::vector<Triangle> tileMinimal(const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b,
                                  ToroidalStats* stats, double spanWeight)
{
    const std::uint32_t m = static_cast<std::uint32_t>(a.size()), n = static_cast<std::uint32_t>(b.size());
    // Starts are tried along the smaller contour; area is symmetric in the two contours, so
    // swapping them changes only how steps map back to triangles.
    const bool alongA = m <= n;
    MinimalAreaSurface surface(alongA ? a : b, alongA ? b : a, spanWeight);
    surface.solve();
    const MinimalAreaSurface::Path& path = surface.best();

    const std::uint32_t p = alongA ? m : n, q = alongA ? n : m;
    auto wrapX = [p](std::uint32_t x) { return x % p; };
    auto wrapY = [q](std::uint32_t y) { return y % q; };
    std::vector<Triangle> band;
    band.reserve(m + n);
    std::uint32_t x = path.start;
    for (std::uint32_t y = 0; y <= q; ++y) {
        for (; x < path.right[y]; ++x) {
            if (alongA)
                band.push_back({wrapX(x), wrapX(x + 1), m + wrapY(y)}); // advance A
            else
                band.push_back({wrapY(y), m + wrapX(x + 1), m + wrapX(x)}); // advance B
        }
        if (y == q) break;
        if (alongA)
            band.push_back({wrapX(x), m + wrapY(y + 1), m + wrapY(y)}); // advance B
        else
            band.push_back({wrapY(y), wrapY(y + 1), m + wrapX(x)}); // advance A
    }
    PIPETILE_ASSERT(band.size() == static_cast<std::size_t>(m) + n, "an acceptable surface has m + n triangles");
    if (stats) stats->bytes = surface.bytes() + band.capacity() * sizeof(Triangle);
    return band;
}

} // namespace

std::vector<Triangle> tileOptimal(const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b,
                                  ToroidalStats* stats)
{
    checkPair(a, b, "tileOptimal");
    return tileMinimal(a, b, stats, 0.0);
}

std::vector<Triangle> tileLeastAreaNearest(const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b,
                                           ToroidalStats* stats)
{
    checkPair(a, b, "tileLeastAreaNearest");
    return tileMinimal(a, b, stats, kSpanWeight);
}

std::vector<Triangle> tileGreedy(const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b,
                                 ToroidalStats* stats)
{
    checkPair(a, b, "tileGreedy");
    const std::uint32_t m = static_cast<std::uint32_t>(a.size()), n = static_cast<std::uint32_t>(b.size());
    // Squared distances: the comparisons are the same and no square root is needed.
    auto distance2 = [](const glm::dvec3& p, const glm::dvec3& q) { return glm::dot(p - q, p - q); };
    std::uint32_t start = 0;
    for (std::uint32_t j = 1; j < n; ++j)
        if (distance2(a[0], b[j]) < distance2(a[0], b[start])) start = j;

    std::vector<Triangle> band;
    band.reserve(m + n);
    // i and j count the steps taken on each contour; each goes once around.
    std::uint32_t i = 0, j = 0;
    while (i < m || j < n) {
        const std::uint32_t ai = i % m, aNext = (i + 1) % m;
        const std::uint32_t bj = (start + j) % n, bNext = (start + j + 1) % n;
        const bool advanceA = j == n || (i < m && distance2(a[aNext], b[bj]) <= distance2(a[ai], b[bNext]));
        if (advanceA) {
            band.push_back({ai, aNext, m + bj});
            ++i;
        } else {
            band.push_back({ai, m + bNext, m + bj});
            ++j;
        }
    }
    if (stats) stats->bytes = band.capacity() * sizeof(Triangle);
    return band;
}

std::vector<Triangle> withoutFullFans(const std::vector<Triangle>& strip, std::uint32_t m, std::uint32_t n)
{
    // Steps: true advances A (a triangle with two points of A), false advances B.
    std::vector<bool> steps;
    for (const Triangle& t : strip) steps.push_back((t[0] < m) + (t[1] < m) + (t[2] < m) == 2);
    const std::size_t count = steps.size();
    for (std::size_t start = 0; start < count; ++start) {
        const bool kind = steps[start];
        if (steps[(start + count - 1) % count] == kind) continue; // not the start of a run
        std::size_t length = 0;
        while (length < count && steps[(start + length) % count] == kind) ++length;
        if (length < (kind ? m : n)) continue;
        // A run of m A-steps (n B-steps) fans one point of the other contour over all of this one.
        steps[(start + length - 1) % count] = !kind;
        steps[(start + length) % count] = kind;
    }
    if (std::equal(steps.begin(), steps.end(), strip.begin(),
                   [&](bool step, const Triangle& t) { return step == ((t[0] < m) + (t[1] < m) + (t[2] < m) == 2); }))
        return strip;
    // Rebuild from where the first triangle starts: an A-step is {a_i, a_i+1, b_j}, a B-step
    // {a_i, b_j+1, b_j}.
    std::uint32_t as[2] = {0, 0}, bs[2] = {0, 0}, na = 0, nb = 0;
    for (std::uint32_t v : strip.front()) {
        if (v < m)
            as[na++] = v;
        else
            bs[nb++] = v - m;
    }
    std::uint32_t i = as[0], j = bs[0];
    if (na == 2)
        i = as[1] == (as[0] + 1) % m ? as[0] : as[1];
    else
        j = bs[1] == (bs[0] + 1) % n ? bs[0] : bs[1];
    std::vector<Triangle> result;
    for (bool stepA : steps) {
        if (stepA) {
            result.push_back({i, (i + 1) % m, m + j});
            i = (i + 1) % m;
        } else {
            result.push_back({i, m + (j + 1) % n, m + j});
            j = (j + 1) % n;
        }
    }
    return result;
}

} // namespace pipetile
