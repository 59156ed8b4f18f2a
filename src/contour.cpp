// pipetile — contour: central point, ray casting, crossings, chain-code walk, edge classification.
//
// Min & Lee §3: rays from a central point, IN-OUT / OUT-IN crossings, a chain-code walk of the
// boundary to order them, and edge types from integers alone.

#include <pipetile/contour.h>
#include <pipetile/detail/field_image.h>
#include <pipetile/detail/pixel_window.h>
#include <pipetile/error.h>
#include <pipetile/slicer.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace pipetile {

namespace {

constexpr double kTwoPi = 6.283185307179586476925286766559;

// Walk directions, counterclockwise: E, N, W, S. Turning left is +1, right is +3 (mod 4).
const glm::ivec2 kStep[4] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
// The pixel on the left of the unit crack that leaves corner C in direction d is C + kLeft[d];
// the pixel on its right is C + kLeft[(d + 3) % 4].
const glm::ivec2 kLeft[4] = {{0, 0}, {-1, 0}, {-1, -1}, {0, -1}};

glm::dvec2 cornerPoint(const glm::ivec2& c)
{
    return {c.x - 0.5, c.y - 0.5};
}

// Angle of (x, y) around the origin in turns, in [0, 1), to within 2e-12 turn: rays only need
// which side of each ray a point lies on, and libm's correctly rounded atan2 was 7% of a run.
// Octant reduction to z in [0, 1]; above tan 15 degrees, atan z = 30 degrees + atan w with
// w = (sqrt3 z - 1) / (sqrt3 + z), so |w| <= tan 15 degrees; then the odd series of atan w to
// w^15 (alternating: the first term left out, w^17 / 17, is below 1.1e-11 rad).
double turnsOf(double x, double y)
{
    constexpr double kPi = 3.14159265358979323846, kTan15 = 0.26794919243112270, kSqrt3 = 1.7320508075688772;
    const double ax = std::abs(x), ay = std::abs(y);
    const bool steep = ay > ax;
    const double z = steep ? ax / ay : ax > 0.0 ? ay / ax : 0.0;
    const bool reduced = z > kTan15;
    const double w = reduced ? (kSqrt3 * z - 1.0) / (kSqrt3 + z) : z, w2 = w * w;
    double series = -1.0 / 15.0;
    for (const double c : {1.0 / 13.0, -1.0 / 11.0, 1.0 / 9.0, -1.0 / 7.0, 1.0 / 5.0, -1.0 / 3.0, 1.0})
        series = series * w2 + c;
    double angle = w * series + (reduced ? kPi / 6.0 : 0.0); // in [0, pi/4]
    if (steep) angle = 0.5 * kPi - angle;
    if (x < 0.0) angle = kPi - angle;
    double turns = angle / kTwoPi;
    if (y < 0.0) turns = 1.0 - turns;
    return turns >= 1.0 ? 0.0 : turns;
}

// The change of angle from one polygon point to the next, in turns, taken the short way round:
// the same rule as the crossing loop of castRaysImpl, which wraps at half of n rays.
double wrappedDelta(double delta)
{
    if (delta > 0.5) return delta - 1.0;
    if (delta < -0.5) return delta + 1.0;
    return delta;
}

void finishLoop(BoundaryLoop& loop)
{
    double area2 = 0.0, cx = 0.0, cy = 0.0;
    const std::size_t m = loop.corners.size();
    for (std::size_t i = 0; i < m; ++i) {
        const glm::dvec2 p = cornerPoint(loop.corners[i]), q = cornerPoint(loop.corners[(i + 1) % m]);
        const double cross = p.x * q.y - q.x * p.y;
        area2 += cross;
        cx += (p.x + q.x) * cross;
        cy += (p.y + q.y) * cross;
    }
    loop.area = 0.5 * area2;
    loop.centroid = area2 != 0.0 ? glm::dvec2(cx / (3.0 * area2), cy / (3.0 * area2)) : cornerPoint(loop.corners[0]);
}

// Pixels the walk may read in place: corner c's four pixels (c - (1, 1) to c) lie in a row-major
// array, and inside() there is just value < 0, when lo <= c <= hi. The walk reads four pixels per
// crack; through inside() and value() each read cost two bounds checks and an index.
struct DirectPixels {
    const double* values = nullptr;
    glm::ivec2 origin{0}; // pixel of values[0]
    int width = 0;
    glm::ivec2 lo{1}, hi{0}; // corners whose four pixels are readable: none by default
};

// Which seeds (east-facing cracks, sorted (v, u)) a walk has passed. A bitmap over the seeds' own
// box where that box is small against their number; else, for seeds scattered far apart (two
// small objects side by side in one plane, 10^8 pixels apart), a flag per seed found by binary
// search, so memory follows the seeds, not the gap between them.
class SeedMarks {
public:
    explicit SeedMarks(const std::vector<glm::ivec2>& seeds) : mSeeds(seeds)
    {
        mLo = mHi = seeds.front();
        for (const glm::ivec2& p : seeds) {
            mLo = glm::min(mLo, p);
            mHi = glm::max(mHi, p);
        }
        const double pixels = (static_cast<double>(mHi.x) - mLo.x + 1.0) * (static_cast<double>(mHi.y) - mLo.y + 1.0);
        mBitmap = pixels <= std::max(double(1 << 22), 64.0 * static_cast<double>(seeds.size()));
        mWidth = mBitmap ? mHi.x - mLo.x + 1 : 0;
        mFlags.assign(mBitmap ? static_cast<std::size_t>(pixels) : seeds.size(), 0);
    }
    bool seen(const glm::ivec2& p) const
    {
        const std::ptrdiff_t k = index(p);
        return k >= 0 && mFlags[static_cast<std::size_t>(k)];
    }
    void mark(const glm::ivec2& p)
    {
        const std::ptrdiff_t k = index(p);
        if (k >= 0) mFlags[static_cast<std::size_t>(k)] = 1;
    }

private:
    // The flag of pixel p, or -1 if p is no seed (outside the box, for the bitmap).
    std::ptrdiff_t index(const glm::ivec2& p) const
    {
        if (p.x < mLo.x || p.y < mLo.y || p.x > mHi.x || p.y > mHi.y) return -1;
        if (mBitmap) return static_cast<std::ptrdiff_t>(p.y - mLo.y) * mWidth + (p.x - mLo.x);
        const auto it = std::lower_bound(mSeeds.begin(), mSeeds.end(), p, [](const glm::ivec2& a, const glm::ivec2& b) {
            return a.y != b.y ? a.y < b.y : a.x < b.x;
        });
        return it != mSeeds.end() && *it == p ? it - mSeeds.begin() : -1;
    }

    const std::vector<glm::ivec2>& mSeeds;
    glm::ivec2 mLo{0}, mHi{0};
    bool mBitmap = true;
    int mWidth = 0;
    std::vector<std::uint8_t> mFlags;
};

// The chain-code walk over every loop of an image, seeded from its east-facing cracks. `inside`
// must read false outside [boxMin, boxMax] so that every walk closes; `value` is the field;
// `saddleJoins(corner)` says whether the diagonal inside pixels of a saddle are one region.
template <class InsideFn, class ValueFn, class SaddleFn>
std::vector<BoundaryLoop> traceLoops(const InsideFn& inside, const ValueFn& value, const SaddleFn& saddleJoins,
                                     const DirectPixels& direct, const std::vector<glm::ivec2>& eastCracks,
                                     glm::ivec2 boxMin, glm::ivec2 boxMax)
{
    std::vector<BoundaryLoop> loops;
    if (eastCracks.empty()) return loops;
    // A walk only needs to mark the seeds it passes.
    SeedMarks visited(eastCracks);
    auto seen = [&](glm::ivec2 p) { return visited.seen(p); };
    auto mark = [&](glm::ivec2 p) { visited.mark(p); };
    const std::size_t maxCorners =
        4 * static_cast<std::size_t>(boxMax.x - boxMin.x + 2) * (boxMax.y - boxMin.y + 2) + 4;

    // Corner c's pixel c + kLeft[k], as an offset from pixel c in the direct array.
    int offset[4];
    for (int k = 0; k < 4; ++k) offset[k] = kLeft[k].y * direct.width + kLeft[k].x;
    auto pixelsAt = [&](glm::ivec2 c) -> const double* {
        if (c.x < direct.lo.x || c.y < direct.lo.y || c.x > direct.hi.x || c.y > direct.hi.y) return nullptr;
        return direct.values + static_cast<std::ptrdiff_t>(c.y - direct.origin.y) * direct.width +
               (c.x - direct.origin.x);
    };
    std::size_t expected = 64; // cracks: the last loop's count, so vectors rarely grow twice
    for (const glm::ivec2& seed : eastCracks) {
        if (seen(seed)) continue;
        BoundaryLoop loop;
        loop.corners.reserve(expected);
        loop.points.reserve(expected);
        const glm::ivec2 start(seed.x + 1, seed.y); // the crack east of `seed`, walked north
        glm::ivec2 c = start;
        int d = 1;
        do {
            loop.corners.push_back(c);
            // The surface crosses the segment between this crack's inside and outside pixel
            // centres where the linearly interpolated field is zero (a marching-squares point).
            const glm::ivec2 in = c + kLeft[d], out = c + kLeft[(d + 3) & 3];
            const double* here = pixelsAt(c);
            const double fin = here ? here[offset[d]] : value(in.x, in.y);
            const double fout = here ? here[offset[(d + 3) & 3]] : value(out.x, out.y);
            const double s = fin < fout ? std::clamp(fin / (fin - fout), 0.0, 1.0) : 0.5;
            loop.points.push_back(glm::dvec2(in) + s * glm::dvec2(out - in));
            if (d == 1) mark(c + kLeft[1]); // its left pixel is the seed it would start from
            c += kStep[d];
            const double* ahead = pixelsAt(c);
            const bool aheadRight = ahead ? ahead[offset[(d + 3) & 3]] < 0.0
                                          : inside(c.x + kLeft[(d + 3) & 3].x, c.y + kLeft[(d + 3) & 3].y);
            const bool aheadLeft = ahead ? ahead[offset[d]] < 0.0 : inside(c.x + kLeft[d].x, c.y + kLeft[d].y);
            // Inside continues to the right (8-connected, unless a saddle there is left open);
            // where it ends ahead, turn left around it.
            if (aheadRight && (aheadLeft || saddleJoins(c)))
                d = (d + 3) & 3;
            else if (!aheadLeft)
                d = (d + 1) & 3;
            PIPETILE_ASSERT(loop.corners.size() <= maxCorners, "boundary walk did not close");
        } while (!(c == start && d == 1));
        finishLoop(loop);
        expected = loop.corners.size() + loop.corners.size() / 8;
        loops.push_back(std::move(loop));
    }
    return loops;
}

} // namespace

bool encloses(const BoundaryLoop& loop, const glm::dvec2& p)
{
    bool in = false;
    const std::size_t m = loop.corners.size();
    for (std::size_t i = 0, j = m - 1; i < m; j = i++) {
        const glm::dvec2 a = cornerPoint(loop.corners[i]), b = cornerPoint(loop.corners[j]);
        if ((a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x) in = !in;
    }
    return in;
}

namespace {

// Even-odd test against the marching-squares polygon, which rays are cut against.
bool insidePolygon(const std::vector<glm::dvec2>& polygon, const glm::dvec2& p)
{
    bool in = false;
    const std::size_t m = polygon.size();
    for (std::size_t i = 0, j = m - 1; i < m; j = i++) {
        const glm::dvec2 a = polygon[i], b = polygon[j];
        if ((a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x) in = !in;
    }
    return in;
}

// The enclosed pixel farthest from the boundary, by a 3-4 chamfer distance over the loop's box,
// among those inside the marching-squares polygon (in a sliver a pixel or two wide, the deepest
// pixel centre can lie outside it); the centroid if there is none.
// The pixels a loop encloses, row by row: row v (from `firstRow`) holds sorted x positions of the
// vertical cracks it crosses, each pair [x0, x1) a run of enclosed pixels.
struct PixelRuns {
    int firstRow = 0;
    std::vector<std::vector<int>> rows;
};

PixelRuns pixelRuns(const BoundaryLoop& loop)
{
    PixelRuns runs;
    int lo = loop.corners[0].y, hi = lo;
    for (const glm::ivec2& c : loop.corners) {
        lo = std::min(lo, c.y);
        hi = std::max(hi, c.y);
    }
    runs.firstRow = lo;
    runs.rows.resize(static_cast<std::size_t>(hi - lo));
    // Corners (i, v) -> (i, v + 1) or back form a vertical crack that row v crosses.
    const std::size_t m = loop.corners.size();
    for (std::size_t k = 0; k < m; ++k) {
        const glm::ivec2 a = loop.corners[k], b = loop.corners[(k + 1) % m];
        if (a.x == b.x) runs.rows[std::min(a.y, b.y) - lo].push_back(a.x);
    }
    for (std::vector<int>& row : runs.rows) std::sort(row.begin(), row.end());
    return runs;
}

} // namespace

long long overlapPixels(const BoundaryLoop& a, const BoundaryLoop& b, const glm::ivec2& shift)
{
    if (a.corners.empty() || b.corners.empty()) return 0;
    const PixelRuns ra = pixelRuns(a), rb = pixelRuns(b);
    long long common = 0;
    for (std::size_t y = 0; y < ra.rows.size(); ++y) {
        const long long yb = ra.firstRow + static_cast<long long>(y) - shift.y - rb.firstRow;
        if (yb < 0 || yb >= static_cast<long long>(rb.rows.size())) continue;
        const std::vector<int>& x = ra.rows[y];
        const std::vector<int>& z = rb.rows[static_cast<std::size_t>(yb)];
        // Merge the two run lists; z's runs moved by shift.x.
        for (std::size_t i = 0, j = 0; i + 1 < x.size() && j + 1 < z.size();) {
            const int lo = std::max(x[i], z[j] + shift.x), hi = std::min(x[i + 1], z[j + 1] + shift.x);
            if (hi > lo) common += hi - lo;
            if (x[i + 1] < z[j + 1] + shift.x)
                i += 2;
            else
                j += 2;
        }
    }
    return common;
}

namespace {

// From p to the nearest point of segment [a, b].
glm::dvec2 toSegment(const glm::dvec2& p, const glm::dvec2& a, const glm::dvec2& b)
{
    const glm::dvec2 ab = b - a;
    const double len2 = glm::dot(ab, ab);
    const double t = len2 > 0.0 ? glm::clamp(glm::dot(p - a, ab) / len2, 0.0, 1.0) : 0.0;
    return a + t * ab - p;
}

} // namespace

double polygonClearance(const std::vector<glm::dvec2>& polygon, const glm::dvec2& p)
{
    double nearest = std::numeric_limits<double>::infinity();
    const std::size_t m = polygon.size();
    for (std::size_t i = 0; i < m; ++i) {
        const glm::dvec2 d = toSegment(p, polygon[i], polygon[i + 1 < m ? i + 1 : 0]);
        nearest = std::min(nearest, glm::dot(d, d)); // squared: one root at the end
    }
    return std::sqrt(nearest);
}

bool clearOfPolygon(const std::vector<glm::dvec2>& polygon, const glm::dvec2& p, double clearance)
{
    const std::size_t m = polygon.size();
    for (std::size_t i = 0; i < m; ++i) {
        const glm::dvec2 a = polygon[i], b = polygon[i + 1 < m ? i + 1 : 0];
        // Most segments of a section lie far off: their box alone shows it, with no division.
        if (p.x < std::min(a.x, b.x) - clearance || p.x > std::max(a.x, b.x) + clearance ||
            p.y < std::min(a.y, b.y) - clearance || p.y > std::max(a.y, b.y) + clearance)
            continue;
        if (glm::length(toSegment(p, a, b)) < clearance) return false;
    }
    return true;
}

BoundaryLoop waistAround(const std::vector<const std::vector<glm::dvec2>*>& walls, double maxGrowth)
{
    glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-lo);
    for (const std::vector<glm::dvec2>* wall : walls)
        for (const glm::dvec2& p : *wall) {
            lo = glm::min(lo, p);
            hi = glm::max(hi, p);
        }
    if (walls.empty() || !(lo.x <= hi.x)) return {};
    // Room for the growth and a pixel of outside around it, so the walk sees the whole region.
    const int pad = static_cast<int>(std::ceil(maxGrowth)) + 2;
    detail::FieldImage image;
    image.origin = glm::ivec2(static_cast<int>(std::floor(lo.x)), static_cast<int>(std::floor(lo.y))) - pad;
    image.width = static_cast<int>(std::ceil(hi.x)) + pad + 1 - image.origin.x;
    image.height = static_cast<int>(std::ceil(hi.y)) + pad + 1 - image.origin.y;
    std::vector<double> distance(static_cast<std::size_t>(image.width) * image.height);
    for (int y = 0; y < image.height; ++y)
        for (int x = 0; x < image.width; ++x) {
            const glm::dvec2 p(image.origin.x + x, image.origin.y + y);
            double d = std::numeric_limits<double>::infinity();
            for (const std::vector<glm::dvec2>* wall : walls)
                d = std::min(d, insidePolygon(*wall, p) ? -polygonClearance(*wall, p) : polygonClearance(*wall, p));
            distance[static_cast<std::size_t>(y) * image.width + x] = d;
        }
    image.values.resize(distance.size());
    for (double growth = 0.0; growth <= maxGrowth; growth += 0.5) {
        for (std::size_t i = 0; i < distance.size(); ++i) image.values[i] = distance[i] - growth;
        std::vector<BoundaryLoop> loops = detail::traceBoundaries(image);
        // The walls' union is one region when one loop runs counterclockwise; the clockwise ones
        // are its holes, which the waist leaves out (filled).
        const auto outer = [](const BoundaryLoop& l) { return !l.hole(); };
        if (std::count_if(loops.begin(), loops.end(), outer) == 1)
            return std::move(*std::find_if(loops.begin(), loops.end(), outer));
    }
    return {};
}

double boundaryClearance(const BoundaryLoop& loop, const glm::dvec2& p)
{
    return polygonClearance(loop.points, p);
}

namespace {

// `depth`: with `near`, the pixels considered are those at least min(deepest - 3, depth) deep
// (chamfer units, 3 per pixel step).
glm::dvec2 deepestPixel(const BoundaryLoop& loop, const glm::dvec2* near, int depth)
{
    glm::ivec2 lo = loop.corners[0], hi = loop.corners[0];
    for (const glm::ivec2& c : loop.corners) {
        lo = glm::min(lo, c);
        hi = glm::max(hi, c);
    }
    // Pixels (u, v) with lo <= (u, v) < hi can be enclosed; pad by one outside pixel each side.
    const glm::ivec2 origin = lo - 1;
    const int w = hi.x - lo.x + 2, h = hi.y - lo.y + 2;
    std::vector<int> dist(static_cast<std::size_t>(w) * h, 0);
    const PixelRuns runs = pixelRuns(loop);
    const int far = std::numeric_limits<int>::max() / 2;
    for (std::size_t r = 0; r < runs.rows.size(); ++r) {
        const int y = runs.firstRow + static_cast<int>(r) - origin.y;
        const std::vector<int>& row = runs.rows[r];
        for (std::size_t k = 0; k + 1 < row.size(); k += 2)
            for (int u = row[k]; u < row[k + 1]; ++u) dist[y * w + (u - origin.x)] = far;
    }
    auto relax = [&](int x, int y, int dx, int dy, int cost) {
        const int nx = x + dx, ny = y + dy;
        const int other = (nx < 0 || ny < 0 || nx >= w || ny >= h) ? 0 : dist[ny * w + nx];
        dist[y * w + x] = std::min(dist[y * w + x], other + cost);
    };
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            if (dist[y * w + x]) {
                relax(x, y, -1, 0, 3);
                relax(x, y, 0, -1, 3);
                relax(x, y, -1, -1, 4);
                relax(x, y, 1, -1, 4);
            }
    int best = -1;
    glm::dvec2 point = loop.centroid;
    for (int y = h - 1; y >= 0; --y)
        for (int x = w - 1; x >= 0; --x) {
            if (!dist[y * w + x]) continue;
            relax(x, y, 1, 0, 3);
            relax(x, y, 0, 1, 3);
            relax(x, y, 1, 1, 4);
            relax(x, y, -1, 1, 4);
        }
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const glm::dvec2 p(x + origin.x, y + origin.y);
            if (dist[y * w + x] > best && insidePolygon(loop.points, p)) {
                best = dist[y * w + x];
                point = p;
            }
        }
    if (!near || best < 0) return point;
    // Along a section of even width the deepest pixels form a ridge, all about as deep: take the
    // one nearest `near` among those within one pixel step (3) of the deepest, or as deep as asked.
    const int floor = std::min(best - 3, depth);
    double nearest = std::numeric_limits<double>::infinity();
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const glm::dvec2 p(x + origin.x, y + origin.y);
            const glm::dvec2 d = p - *near;
            if (dist[y * w + x] >= floor && d.x * d.x + d.y * d.y < nearest && insidePolygon(loop.points, p)) {
                nearest = d.x * d.x + d.y * d.y;
                point = p;
            }
        }
    return point;
}

// Position along a ray: the root of the field g(t) (negative inside) nearest the crack, searched
// between the neighbouring crossings of the same ray so crossings keep their order.
template <class SampleFn>
bool refineCrossing(const SampleFn& g, bool rising, double crackT, double lower, double upper, double& t)
{
    constexpr int kSteps = 8;
    double bestA = 0.0, bestB = 0.0, ga = 0.0, gb = 0.0, bestDistance = std::numeric_limits<double>::infinity();
    // The polygon lies within its chord error of the surface, so a tight bracket around the
    // polygon's crossing almost always holds the root: two samples instead of a scan.
    constexpr double kTight = 0.05;
    if (crackT - kTight >= lower && crackT + kTight <= upper) {
        const double a = crackT - kTight, b = crackT + kTight, fa = g(a), fb = g(b);
        if (rising ? (fa < 0.0 && fb >= 0.0) : (fa >= 0.0 && fb < 0.0)) {
            bestA = a;
            bestB = b;
            ga = fa;
            gb = fb;
            bestDistance = 0.0;
        }
    }
    // Otherwise scan the window and take the sign change of the right direction nearest the polygon.
    if (!std::isfinite(bestDistance)) {
        double prevT = lower, prevG = g(lower);
        for (int k = 1; k <= kSteps; ++k) {
            const double nextT = lower + (upper - lower) * k / kSteps;
            const double nextG = g(nextT);
            const bool crosses = rising ? (prevG < 0.0 && nextG >= 0.0) : (prevG >= 0.0 && nextG < 0.0);
            const double distance = std::abs(0.5 * (prevT + nextT) - crackT);
            if (crosses && distance < bestDistance) {
                bestDistance = distance;
                bestA = prevT;
                bestB = nextT;
                ga = prevG;
                gb = nextG;
            }
            prevT = nextT;
            prevG = nextG;
        }
    }
    if (!std::isfinite(bestDistance)) return false;
    // Illinois false position: the field is smooth along the ray, so this converges in a few steps.
    if (ga == 0.0 || gb == 0.0) {
        t = ga == 0.0 ? bestA : bestB; // the root is a sample
        return true;
    }
    // To 1e-7 pixel: far below what the voxels resolve, with fewer samples than a tighter bound.
    int side = 0;
    t = 0.5 * (bestA + bestB);
    for (int iteration = 0; iteration < 60 && bestB - bestA > 1e-7; ++iteration) {
        const double c = (ga * bestB - gb * bestA) / (ga - gb);
        if (!(c > bestA && c < bestB)) break;
        t = c;
        const double gc = g(c);
        if (gc == 0.0) break;
        if ((gc < 0.0) == (ga < 0.0)) {
            bestA = c;
            ga = gc;
            if (side == -1) gb *= 0.5;
            side = -1;
        } else {
            bestB = c;
            gb = gc;
            if (side == 1) ga *= 0.5;
            side = 1;
        }
    }
    return true;
}

// Position along a ray, in closed form: the root of the field in the pixel cell where the ray
// meets the loop's polygon. The field is bilinear in a cell, so along a line it is quadratic in
// t; the polygon's segment there is the chord of the cell's zero curve (marching squares), so the
// ray almost always meets that curve in the same cell. Takes the root of the right direction
// nearest the polygon, within the cell and [lower, upper]; false if there is none (the caller
// then searches along the ray). Gives what root finding on the samples converges to, without
// the dozen samples it takes.
template <class Field>
bool cellRoot(const Field& field, const glm::dvec2& center, const glm::dvec2& d, double sign, bool rising,
              double crackT, double lower, double upper, double& t)
{
    const glm::dvec2 p = center + crackT * d;
    int u = static_cast<int>(p.x), v = static_cast<int>(p.y); // floor, inline (no SSE4.1 round)
    u -= p.x < u ? 1 : 0;
    v -= p.y < v ? 1 : 0;
    const double fu = u, fv = v;
    double f[4];
    field.cell(u, v, f);
    const double f00 = sign * f[0], f10 = sign * f[1], f01 = sign * f[2], f11 = sign * f[3];
    // g(crackT + tau) = C + B tau + A tau^2, around the polygon's point (s, r) in the cell.
    const double s = p.x - fu, r = p.y - fv;
    const double a = f10 - f00, b = f01 - f00, c = f11 - f10 - f01 + f00;
    const double C = f00 + s * a + r * b + s * r * c;
    const double B = a * d.x + b * d.y + c * (s * d.y + r * d.x);
    const double A = c * d.x * d.y;
    double roots[2];
    int count = 0;
    if (A == 0.0) {
        if (B == 0.0) return false;
        roots[count++] = -C / B;
    } else {
        const double discriminant = B * B - 4.0 * A * C;
        if (discriminant < 0.0) return false;
        const double q = -0.5 * (B + std::copysign(std::sqrt(discriminant), B)); // no cancellation
        roots[count++] = q / A;
        if (q != 0.0) roots[count++] = C / q;
    }
    constexpr double kInCell = 1e-9;
    bool found = false;
    double best = 0.0;
    for (int k = 0; k < count; ++k) {
        const double tau = roots[k];
        const double slope = B + 2.0 * A * tau;
        if (!(rising ? slope > 0.0 : slope < 0.0)) continue;
        const double su = s + tau * d.x, rv = r + tau * d.y;
        if (!(su >= -kInCell && su <= 1.0 + kInCell && rv >= -kInCell && rv <= 1.0 + kInCell)) continue;
        const double candidate = crackT + tau;
        if (!(candidate >= lower && candidate <= upper)) continue;
        if (!found || std::abs(tau) < std::abs(best)) {
            best = tau;
            found = true;
        }
    }
    if (found) t = crackT + best;
    return found;
}

// A ray's crossing with the loop's polygon, before its position is refined.
struct Hit {
    int ray;
    CrossingKind kind;
    double crackT;
    int segment;
    long long along;
    int old; // index of the coarse crossing it is, or -1 if cast here
};

// castRaysImpl's working arrays, kept per thread: allocating them for every contour and level
// cost 8% of a run. Reached through one call per contour: inlined, the compiler recomputes a
// thread_local's address (a call into the dynamic linker, in a shared library) at every use.
struct CastScratch {
    std::vector<double> rho;
    std::vector<Hit> hits;
    std::vector<int> balance, fresh;
    std::vector<glm::dvec2> uniformDirections; // for the ray count last cast on this thread
};

[[gnu::noinline]] CastScratch& castScratch()
{
    thread_local CastScratch scratch;
    return scratch;
}

// The rays that the polygon segment from ray coordinate `from` to `to` (angle in turns * grid, in
// [0, grid)) crosses, going the short way round. Ray x is crossed where the walk passes from
// rho < x to rho >= x (forward: InOut) or back (backward: OutIn); a point exactly on a ray counts
// on the >= side, so no crossing is lost or counted twice. Calls cross(x, along, forward) with x
// in [0, grid) and `along` increasing along the segment (the crossing's walk order within it).
template <class Cross>
void crossedRays(double from, double to, long grid, const Cross& cross)
{
    const double scale = static_cast<double>(grid);
    double delta = to - from;
    if (delta > 0.5 * scale) delta -= scale;
    if (delta < -0.5 * scale) delta += scale;
    if (delta == 0.0) return;
    const long fa = static_cast<long>(from), fb = static_cast<long>(to); // floor: rho >= 0
    if (delta > 0.0) {
        const long last = fb + (to < from ? grid : 0);
        for (long x = fa + 1; x <= last; ++x) cross(x < grid ? x : x - grid, x, true); // x < 2 * grid
    } else {
        const long last = fb + 1 - (to > from ? grid : 0);
        for (long x = fa; x >= last; --x) cross(x >= 0 ? x : x + grid, -x, false); // x > -grid
    }
}

// Unit directions of n rays evenly spaced from angle 0, into `table` unless it holds them already
// (a sincos per ray, not per crossing).
void evenDirections(std::vector<glm::dvec2>& table, int n)
{
    if (static_cast<int>(table.size()) == n) return;
    table.resize(n);
    for (int ray = 0; ray < n; ++ray) {
        const double angle = kTwoPi * (static_cast<double>(ray) / static_cast<double>(n));
        table[ray] = glm::dvec2(std::cos(angle), std::sin(angle));
    }
}

// Distance along the ray from `center` in direction d to where it meets segment ab: solve for the
// point on the segment and clamp it there, so a ray running along the segment (a near-zero cross
// product) still meets it on the segment and not somewhere on its line far away.
double crackDistance(const glm::dvec2& center, const glm::dvec2& d, const glm::dvec2& a, const glm::dvec2& b)
{
    const glm::dvec2 e = b - a, ca = center - a;
    const double denominator = e.x * d.y - e.y * d.x;
    const double s = denominator != 0.0 ? std::clamp((ca.x * d.y - ca.y * d.x) / denominator, 0.0, 1.0) : 0.5;
    const glm::dvec2 p = a + s * e - center;
    return p.x * d.x + p.y * d.y;
}

// Casts the rays of `rays` against the loop. With `coarse` (the same loop's contour one level
// down), only the new rays are cast; the coarse crossings are reused as they are and merged in by
// their walk positions, which gives exactly what casting every ray would (paper §4.3).
template <class Field>
Contour castRaysImpl(const LoopView& view, const RaySet& rays, const Field& field, const Contour* coarse = nullptr)
{
    Contour contour;
    const glm::dvec2 center = view.center;
    contour.center = center;
    contour.hole = view.hole;
    contour.rays = rays;
    const int n = rays.count();
    const std::size_t m = view.polygon.size();
    // The loop must wind once around the centre: then every ray has one more InOut than OutIn
    // crossing.
    if (m < 4 || n < 3 || view.winding != 1) return contour;
    const std::vector<glm::dvec2>& poly = view.polygon;
    const double inwardSign = contour.hole ? -1.0 : 1.0;

    // Ray coordinate of each point: its angle in turns * the grid count (n0 * 2^level, times
    // 2^kFoldDepth with added rays), the power of two exact, so a point compares with ray x of
    // level L exactly as with ray 2x of level L+1, or the same angle on a finer grid: levels nest.
    const long grid = rays.gridCount();
    const double scale = static_cast<double>(grid);
    CastScratch& scratch = castScratch();
    std::vector<double>& rho = scratch.rho;
    rho.resize(m);
    for (std::size_t i = 0; i < m; ++i) rho[i] = view.turns[i] * scale;

    std::vector<Hit>& hits = scratch.hits;
    hits.clear();
    hits.reserve(2 * static_cast<std::size_t>(n) + (coarse ? coarse->crossings.size() : 0));
    // Grid index x -> ray index, or -1 where the grid has no ray. Rays the coarse contour has
    // (its grid is `coarseStep` times coarser) are not cast again.
    const AddedRays* added = rays.added.get();
    auto rayAt = [&](long x) { return added ? added->rank[x] : static_cast<int>(x); };
    const long coarseStep = coarse ? grid / coarse->rays.gridCount() : 1; // a power of two
    const AddedRays* coarseAdded = coarse ? coarse->rays.added.get() : nullptr;
    auto isNew = [&](long x) {
        if (coarse == nullptr || (x & (coarseStep - 1)) != 0) return true;
        return coarseAdded != nullptr && coarseAdded->rank[x / coarseStep] < 0;
    };
    // Ray directions: for the level's own rays computed once per thread and ray count (a sincos
    // per crossing cost more than the rest of the intersection); added rays carry their own. Both
    // from the same fraction of a turn, so the same angle gives the same bits.
    std::vector<glm::dvec2>& uniformDirections = scratch.uniformDirections;
    if (!added) evenDirections(uniformDirections, n);
    const std::vector<glm::dvec2>& directions = added ? added->directions : uniformDirections;
    auto direction = [&](int ray) { return directions[ray]; };
    for (std::size_t i = 0; i < m; ++i) {
        const std::size_t j = i + 1 == m ? 0 : i + 1; // not % m: a division per point and level
        crossedRays(rho[i], rho[j], grid, [&](long wrapped, long along, bool forward) {
            const int ray = rayAt(wrapped);
            if (ray < 0 || !isNew(wrapped)) return;
            hits.push_back({ray, forward ? CrossingKind::InOut : CrossingKind::OutIn,
                            crackDistance(center, direction(ray), poly[i], poly[j]), static_cast<int>(i), along, -1});
        });
    }
    // Merge the coarse crossings back in walk order: same segment, positions along it scaled to
    // this grid. The new hits are in walk order already, and the coarse contour is its walk order
    // rotated to its start: one merge, no sort. (New and coarse rays differ: no ties.)
    if (coarse) {
        auto walkOrder = [](const Hit& a, const Hit& b) {
            return a.segment != b.segment ? a.segment < b.segment : a.along < b.along;
        };
        const std::vector<Crossing>& old = coarse->crossings;
        std::size_t first = 0;
        for (std::size_t k = 1; k < old.size(); ++k)
            if (old[k].segment != old[first].segment ? old[k].segment < old[first].segment
                                                     : old[k].along < old[first].along)
                first = k;
        const std::size_t fresh = hits.size();
        for (std::size_t i = 0; i < old.size(); ++i) {
            const std::size_t k = (first + i) % old.size();
            const int ray = rayAt(coarse->rays.gridIndex(old[k].ray) * coarseStep);
            hits.push_back(
                {ray, old[k].kind, old[k].crackT, old[k].segment, coarseStep * old[k].along, static_cast<int>(k)});
        }
        std::inplace_merge(hits.begin(), hits.begin() + static_cast<std::ptrdiff_t>(fresh), hits.end(), walkOrder);
    }
    // Every ray must then have one more InOut than OutIn crossing; a segment through the centre
    // itself (half a turn to within rounding) can still break that.
    std::vector<int>& balance = scratch.balance;
    balance.assign(n, 0);
    for (const Hit& h : hits) balance[h.ray] += h.kind == CrossingKind::InOut ? 1 : -1;
    for (int b : balance)
        if (b != 1) return contour;

    // Start at the outermost InOut crossing of ray 0, so the contour does not depend on where
    // the walk began.
    std::size_t start = hits.size();
    for (std::size_t k = 0; k < hits.size(); ++k)
        if (hits[k].ray == 0 && hits[k].kind == CrossingKind::InOut &&
            (start == hits.size() || hits[k].crackT > hits[start].crackT))
            start = k;
    std::rotate(hits.begin(), hits.begin() + static_cast<std::ptrdiff_t>(start), hits.end());

    contour.crossings.resize(hits.size());
    std::vector<int>& fresh = scratch.fresh; // the crossings cast here (not reused), grouped by ray below
    fresh.clear();
    fresh.reserve(hits.size());
    if (coarse) contour.interpolationFallbacks = coarse->interpolationFallbacks;
    for (std::size_t k = 0; k < hits.size(); ++k) {
        Crossing& c = contour.crossings[k];
        if (hits[k].old >= 0) {
            c = coarse->crossings[hits[k].old]; // reused: position, depth, everything
        } else {
            c.kind = hits[k].kind;
            c.crackT = hits[k].crackT;
            fresh.push_back(static_cast<int>(k));
        }
        c.ray = hits[k].ray;
        c.segment = hits[k].segment;
        c.along = hits[k].along;
    }
    std::sort(fresh.begin(), fresh.end(), [&](int a, int b) {
        const Crossing &p = contour.crossings[a], &q = contour.crossings[b];
        if (p.ray != q.ray) return p.ray < q.ray;
        return p.crackT != q.crackT ? p.crackT < q.crackT : a < b; // ties (a pinch): walk order
    });
    for (std::size_t first = 0, last = 0; first < fresh.size(); first = last) {
        const int ray = contour.crossings[fresh[first]].ray;
        while (last < fresh.size() && contour.crossings[fresh[last]].ray == ray) ++last;
        const int* ids = fresh.data() + first;
        const std::size_t count = last - first;
        for (std::size_t k = 0; k < count; ++k) contour.crossings[ids[k]].depth = static_cast<int>(k);
        const glm::dvec2 d = direction(ray);
        auto g = [&](double t) { return inwardSign * field.sample(center + t * d); };
        for (std::size_t k = 0; k < count; ++k) {
            Crossing& c = contour.crossings[ids[k]];
            // Never past the neighbouring crossings of the same ray, so the order stays the walk's.
            double lowest = 0.0, highest = std::numeric_limits<double>::infinity();
            if (k > 0) lowest = 0.5 * (contour.crossings[ids[k - 1]].crackT + c.crackT);
            if (k + 1 < count) highest = 0.5 * (contour.crossings[ids[k + 1]].crackT + c.crackT);
            // In closed form where the polygon meets the ray; else search along the ray, close to
            // the polygon first (it lies within its chord error of the surface).
            bool found =
                cellRoot(field, center, d, inwardSign, c.kind == CrossingKind::InOut, c.crackT, lowest, highest, c.t);
            for (double reach : {0.5, 1.5}) {
                if (found) break;
                const double lower = std::max(c.crackT - reach, lowest), upper = std::min(c.crackT + reach, highest);
                if ((found = refineCrossing(g, c.kind == CrossingKind::InOut, c.crackT, lower, upper, c.t))) break;
            }
            if (!found) {
                // On the polygon, and never behind the centre: where the polygon passes through
                // the centre itself (a centre on the boundary), crackT is 0 only up to rounding.
                c.t = std::max(c.crackT, 0.0);
                ++contour.interpolationFallbacks;
            }
            c.point = center + c.t * d;
        }
    }

    const std::size_t count = contour.crossings.size();
    contour.edges.resize(count);
    for (std::size_t k = 0; k < count; ++k)
        contour.edges[k] = classifyEdge(contour.crossings[k], contour.crossings[(k + 1) % count], n);
    return contour;
}

} // namespace

namespace detail {

double FieldImage::value(int u, int v) const
{
    const int x = u - origin.x, y = v - origin.y;
    if (x < 0 || y < 0 || x >= width || y >= height) return 1.0;
    return values[static_cast<std::size_t>(y) * width + x];
}

void FieldImage::cell(int u, int v, double values[4]) const
{
    values[0] = value(u, v);
    values[1] = value(u + 1, v);
    values[2] = value(u, v + 1);
    values[3] = value(u + 1, v + 1);
}

double FieldImage::sample(const glm::dvec2& uv) const
{
    const double fu = std::floor(uv.x), fv = std::floor(uv.y);
    const int u = static_cast<int>(fu), v = static_cast<int>(fv);
    const double s = uv.x - fu, t = uv.y - fv;
    double f[4];
    cell(u, v, f);
    return (1.0 - t) * (f[0] + s * (f[1] - f[0])) + t * (f[2] + s * (f[3] - f[2]));
}

} // namespace detail

std::vector<BoundaryLoop> traceBoundaries(const SlicePlane& plane)
{
    const SlicePlan& plan = plane.plan();
    const std::vector<glm::ivec2> seeds = plane.eastCracks();
    // The walk reads the plane's image in place; the plane's inside() and value() serve the
    // corners at its edges and planes without one.
    const detail::PixelWindow window = detail::pixelWindow(plane);
    DirectPixels direct;
    if (window.values) {
        direct = {window.values, window.min, window.width, glm::max(window.min, plan.pixelMin) + 1,
                  glm::min(window.min + glm::ivec2(window.width, window.height) - 1, plan.pixelMax)};
    }
    return traceLoops([&](int u, int v) { return plane.inside(u, v); }, [&](int u, int v) { return plane.value(u, v); },
                      [&](const glm::ivec2& corner) { return plane.saddleJoins(corner); }, direct, seeds, plan.pixelMin,
                      plan.pixelMax + 1);
}

std::vector<BoundaryLoop> detail::traceBoundaries(const FieldImage& image)
{
    std::vector<glm::ivec2> seeds;
    for (int v = image.origin.y; v < image.origin.y + image.height; ++v)
        for (int u = image.origin.x; u < image.origin.x + image.width; ++u)
            if (image.inside(u, v) && !image.inside(u + 1, v)) seeds.push_back({u, v});
    const DirectPixels direct{image.values.data(), image.origin, image.width, image.origin + 1,
                              image.origin + glm::ivec2(image.width, image.height) - 1};
    // An image has no planes beside it: every saddle joins (8-connected).
    return traceLoops([&](int u, int v) { return image.inside(u, v); }, [&](int u, int v) { return image.value(u, v); },
                      [](const glm::ivec2&) { return true; }, direct, seeds, image.origin - 1,
                      image.origin + glm::ivec2(image.width, image.height));
}

namespace {

// Whether a point lies off a polygon by more than rounding (pixels; crossings are placed to about
// 1e-12): a centre on it gives no rays.
bool offPolygon(const std::vector<glm::dvec2>& polygon, const glm::dvec2& point)
{
    constexpr double kRounding = 1e-9;
    return clearOfPolygon(polygon, point, kRounding);
}

} // namespace

bool liesInside(const BoundaryLoop& loop, const glm::dvec2& point)
{
    return encloses(loop, point) && insidePolygon(loop.points, point);
}

bool centroidInside(const BoundaryLoop& loop)
{
    return liesInside(loop, loop.centroid);
}

glm::dvec2 centralPoint(const BoundaryLoop& loop, const glm::dvec2* near)
{
    if (loop.corners.empty()) return loop.centroid;
    // A centroid on the polygon is inside only by rounding, and no rays can be cast from it.
    const bool usable = centroidInside(loop) && offPolygon(loop.points, loop.centroid);
    return usable ? loop.centroid : deepestPixel(loop, near, std::numeric_limits<int>::max());
}

glm::dvec2 clearPixelNear(const BoundaryLoop& loop, const glm::dvec2& near)
{
    constexpr int kTwoPixels = 6;
    return loop.corners.empty() ? loop.centroid : deepestPixel(loop, &near, kTwoPixels);
}

LoopView viewFrom(const BoundaryLoop& loop, const glm::dvec2& center)
{
    std::vector<glm::dvec2> polygon = loop.points;
    if (loop.hole()) std::reverse(polygon.begin(), polygon.end());
    LoopView view = viewOfPolygon(std::move(polygon), center);
    view.hole = loop.hole();
    return view;
}

LoopView viewOfPolygon(std::vector<glm::dvec2> polygon, const glm::dvec2& center)
{
    LoopView view;
    view.center = center;
    const std::size_t m = polygon.size();
    view.turns.resize(m);
    double total = 0.0;
    for (std::size_t i = 0; i < m; ++i) {
        view.turns[i] = turnsOf(polygon[i].x - center.x, polygon[i].y - center.y);
        if (i > 0) total += wrappedDelta(view.turns[i] - view.turns[i - 1]);
    }
    if (m > 0) total += wrappedDelta(view.turns[0] - view.turns[m - 1]);
    // A centre on the polygon itself sees one of its segments as half a turn either way: it is
    // wound around by no defined number of turns.
    view.winding = offPolygon(polygon, center) ? static_cast<int>(std::lround(total)) : 0;
    view.polygon = std::move(polygon);
    return view;
}

double polygonArea(const std::vector<glm::dvec2>& polygon)
{
    double area2 = 0.0;
    for (std::size_t i = 0, m = polygon.size(); i < m; ++i) {
        const glm::dvec2 a = polygon[i], b = polygon[(i + 1) % m];
        area2 += a.x * b.y - a.y * b.x;
    }
    return 0.5 * area2;
}

std::optional<glm::dvec2> polygonCentroid(const std::vector<glm::dvec2>& polygon)
{
    glm::dvec2 sum(0.0);
    double area2 = 0.0;
    for (std::size_t i = 0, m = polygon.size(); i < m; ++i) {
        const glm::dvec2 a = polygon[i], b = polygon[(i + 1) % m];
        const double cross = a.x * b.y - a.y * b.x;
        sum += cross * (a + b);
        area2 += cross;
    }
    if (!(std::abs(area2) > 0.0)) return std::nullopt;
    return sum / (3.0 * area2);
}

double commonDepth(const BoundaryLoop& loop, const std::vector<const std::vector<glm::dvec2>*>& polygons,
                   const glm::dvec2& p)
{
    if (!liesInside(loop, p)) return -1.0;
    double depth = boundaryClearance(loop, p);
    for (const std::vector<glm::dvec2>* polygon : polygons) {
        if (!insidePolygon(*polygon, p)) return -1.0;
        depth = std::min(depth, polygonClearance(*polygon, p));
    }
    return depth;
}

double deepestCommonPoint(const BoundaryLoop& loop, const std::vector<const std::vector<glm::dvec2>*>& polygons,
                          glm::dvec2& point)
{
    // The box they all share, and 64 x 64 points over it: a quarter pixel apart in a box 16 pixels
    // wide, finer in the slivers where a branch barely touches a slab.
    glm::dvec2 lo(-std::numeric_limits<double>::infinity()), hi(std::numeric_limits<double>::infinity());
    auto clip = [&](const std::vector<glm::dvec2>& polygon) {
        glm::dvec2 a(std::numeric_limits<double>::infinity()), b(-std::numeric_limits<double>::infinity());
        for (const glm::dvec2& q : polygon) {
            a = glm::min(a, q);
            b = glm::max(b, q);
        }
        lo = glm::max(lo, a);
        hi = glm::min(hi, b);
    };
    clip(loop.points);
    for (const std::vector<glm::dvec2>* polygon : polygons) clip(*polygon);
    if (!(lo.x < hi.x && lo.y < hi.y)) return -1.0;
    constexpr int kPoints = 64;
    const glm::dvec2 step = (hi - lo) / static_cast<double>(kPoints);
    double best = -1.0;
    for (int y = 0; y < kPoints; ++y)
        for (int x = 0; x < kPoints; ++x) {
            // Cell middles: never on the box's edges, where the polygons' extreme points lie.
            const glm::dvec2 p = lo + step * glm::dvec2(x + 0.5, y + 0.5);
            const double depth = commonDepth(loop, polygons, p);
            if (depth > best) {
                best = depth;
                point = p;
            }
        }
    return best;
}

double profileChange(const RadialProfile& p, const RadialProfile& q)
{
    double change = 0.0;
    for (std::size_t d = 0; d < p.nearest.size() && d < q.nearest.size(); ++d) {
        // A direction without crossings holds infinities on one side: an infinite change.
        const double near = std::abs(p.nearest[d] - q.nearest[d]), far = std::abs(p.farthest[d] - q.farthest[d]);
        change = std::max({change, std::isnan(near) ? 0.0 : near, std::isnan(far) ? 0.0 : far});
    }
    return change;
}

RadialProfile radialProfile(const LoopView& view, int directions)
{
    RadialProfile profile;
    profile.nearest.assign(directions, std::numeric_limits<double>::infinity());
    profile.farthest.assign(directions, -std::numeric_limits<double>::infinity());
    // The crossings castRays would find with `directions` rays, by the same rule and the same
    // arithmetic (directions, ray coordinates, distances), without the root finding.
    thread_local std::vector<glm::dvec2> table;
    std::vector<glm::dvec2>& unit = table; // one thread-local lookup, not one per use
    evenDirections(unit, directions);
    const std::size_t m = view.polygon.size();
    const double scale = static_cast<double>(directions);
    for (std::size_t i = 0; i < m; ++i) {
        const std::size_t j = i + 1 == m ? 0 : i + 1;
        crossedRays(view.turns[i] * scale, view.turns[j] * scale, directions, [&](long ray, long, bool) {
            const double r = crackDistance(view.center, unit[ray], view.polygon[i], view.polygon[j]);
            profile.nearest[ray] = std::min(profile.nearest[ray], r);
            profile.farthest[ray] = std::max(profile.farthest[ray], r);
        });
    }
    return profile;
}

double misregistration(const LoopView& a, const RadialProfile& p, const LoopView& b, const RadialProfile& q)
{
    constexpr double kPi = 3.14159265358979323846;
    const std::size_t directions = std::min(p.nearest.size(), q.nearest.size());
    double sum = 0.0;
    long long count = 0;
    for (std::size_t d = 0; d < directions; ++d) {
        if (!std::isfinite(p.farthest[d]) || !std::isfinite(q.farthest[d])) continue;
        const double angle = 2.0 * kPi * static_cast<double>(d) / static_cast<double>(directions);
        const glm::dvec2 unit(std::cos(angle), std::sin(angle));
        sum += glm::length(a.center + p.nearest[d] * unit - (b.center + q.nearest[d] * unit)) +
               glm::length(a.center + p.farthest[d] * unit - (b.center + q.farthest[d] * unit));
        count += 2;
    }
    return count > 0 ? sum / static_cast<double>(count) : std::numeric_limits<double>::infinity();
}

double widestGapToward(const LoopView& a, const LoopView& b, double far)
{
    const auto cross = [](const glm::dvec2& u, const glm::dvec2& v) { return u.x * v.y - u.y * v.x; };
    const std::size_t n = a.polygon.size();
    double widest = 0.0;
    std::vector<double> crossings; // along a segment, strictly between its ends
    for (const glm::dvec2& from : a.polygon) {
        glm::dvec2 to = from;
        double nearest2 = std::numeric_limits<double>::infinity();
        for (const glm::dvec2& q : b.polygon) {
            const glm::dvec2 d = q - from;
            if (glm::dot(d, d) < nearest2) {
                nearest2 = glm::dot(d, d);
                to = q;
            }
        }
        if (!(nearest2 > far * far) || std::sqrt(nearest2) <= widest) continue;
        const glm::dvec2 along = to - from;
        crossings.clear();
        for (std::size_t i = 0; i < n; ++i) {
            const glm::dvec2 c = a.polygon[i], e = a.polygon[i + 1 < n ? i + 1 : 0] - c;
            const double denominator = cross(along, e);
            if (denominator == 0.0) continue;
            const double t = cross(c - from, e) / denominator, s = cross(c - from, along) / denominator;
            if (t > 1e-6 && t < 1.0 - 1e-6 && s >= 0.0 && s < 1.0) crossings.push_back(t);
        }
        // `from` lies on the polygon itself, so only the stretches between two crossings lie
        // between stretches inside and outside.
        std::sort(crossings.begin(), crossings.end());
        const double length = std::sqrt(nearest2);
        for (std::size_t k = 0; k + 1 < crossings.size(); ++k) {
            const double gap = (crossings[k + 1] - crossings[k]) * length;
            if (gap > widest && !insidePolygon(a.polygon, from + 0.5 * (crossings[k] + crossings[k + 1]) * along))
                widest = gap;
        }
    }
    return widest;
}

Contour castRays(const LoopView& view, const RaySet& rays, const SlicePlane& plane)
{
    return castRaysImpl(view, rays, plane);
}

namespace {

// No field at all: castRaysImpl then leaves every crossing on the polygon.
struct NoField {
    void cell(int, int, double values[4]) const { values[0] = values[1] = values[2] = values[3] = 1.0; }
    double sample(const glm::dvec2&) const { return 1.0; }
};

// refineContour's precondition: every ray of `coarse` is a ray of `rays`. castRaysImpl reads the
// coarse rays' places on the finer grid, so a coarser or foreign set would index out of range.
void checkHoldsRays(const RaySet& coarse, const RaySet& rays)
{
    const long grid = rays.gridCount(), coarseGrid = coarse.gridCount();
    bool holds = rays.baseRays == coarse.baseRays && grid >= coarseGrid;
    if (holds && rays.added) {
        const long step = grid / coarseGrid; // a power of two
        for (int ray = 0; holds && ray < coarse.count(); ++ray)
            holds = rays.added->rank[coarse.gridIndex(ray) * step] >= 0;
    }
    if (!holds) throw UsageError("refineContour: the rays given do not hold every ray of the coarse contour");
}

} // namespace

Contour castPolygon(const LoopView& view, const RaySet& rays)
{
    Contour contour = castRaysImpl(view, rays, NoField{});
    contour.interpolationFallbacks = 0; // on the polygon by design, not for want of a root
    return contour;
}

Contour detail::castRays(const BoundaryLoop& loop, const glm::dvec2& center, const RaySet& rays,
                         const FieldImage& image)
{
    return castRaysImpl(viewFrom(loop, center), rays, image);
}

Contour refineContour(const Contour& coarse, const LoopView& view, const RaySet& rays, const SlicePlane& plane)
{
    if (coarse.crossings.empty()) return coarse;
    checkHoldsRays(coarse.rays, rays);
    return castRaysImpl(view, rays, plane, &coarse);
}

Contour refineContour(const Contour& coarse, const LoopView& view, const SlicePlane& plane)
{
    return refineContour(coarse, view, coarse.rays.next(), plane);
}

Contour detail::refineContour(const Contour& coarse, const BoundaryLoop& loop, const RaySet& rays,
                              const FieldImage& image)
{
    if (coarse.crossings.empty()) return coarse;
    checkHoldsRays(coarse.rays, rays);
    return castRaysImpl(viewFrom(loop, coarse.center), rays, image, &coarse);
}

Contour detail::refineContour(const Contour& coarse, const BoundaryLoop& loop, const FieldImage& image)
{
    return refineContour(coarse, loop, coarse.rays.next(), image);
}

namespace {

// A set of rays given by their indices on the grid of n0 * 2^(level + kFoldDepth) angles.
RaySet addedRaySet(int baseRays, int level, std::vector<long> fine)
{
    auto added = std::make_shared<AddedRays>();
    const long grid = static_cast<long>(baseRays) << (level + RaySet::kFoldDepth);
    added->rank.assign(static_cast<std::size_t>(grid), -1);
    added->directions.reserve(fine.size());
    for (std::size_t r = 0; r < fine.size(); ++r) {
        added->rank[fine[r]] = static_cast<int>(r);
        // The same fraction of a turn as the uniform table's ray / count: the same bits.
        const double angle = kTwoPi * (static_cast<double>(fine[r]) / static_cast<double>(grid));
        added->directions.push_back(glm::dvec2(std::cos(angle), std::sin(angle)));
    }
    added->fine = std::move(fine);
    return RaySet{baseRays, level, std::move(added)};
}

// Sector x's ends on the grid of kFoldDepth added levels, where the level's own rays are every
// 2^kFoldDepth-th index.
std::pair<long, long> sectorOnGrid(const RaySet& rays, int x)
{
    const long step = rays.added ? 1 : 1L << RaySet::kFoldDepth;
    const long grid = static_cast<long>(rays.baseRays) << (rays.level + RaySet::kFoldDepth);
    return {rays.gridIndex(x) * step, x + 1 < rays.count() ? rays.gridIndex(x + 1) * step : grid};
}

} // namespace

bool RaySet::canHalve(int sector, int halvings) const
{
    const auto [a, b] = sectorOnGrid(*this, sector);
    return b - a >= 2L << (kFoldDepth - halvings);
}

RaySet RaySet::withMidpoints(const std::vector<int>& sectors) const
{
    const int n = count();
    const long step = added ? 1 : 1L << kFoldDepth;
    std::vector<long> fine;
    fine.reserve(static_cast<std::size_t>(n) + sectors.size());
    for (int x = 0; x < n; ++x) fine.push_back(gridIndex(x) * step);
    bool grew = false;
    for (int x : sectors) {
        if (!canHalve(x)) continue;
        const auto [a, b] = sectorOnGrid(*this, x);
        fine.push_back((a + b) / 2);
        grew = true;
    }
    if (!grew) return *this;
    std::sort(fine.begin(), fine.end());
    return addedRaySet(baseRays, level, std::move(fine));
}

RaySet RaySet::next() const
{
    if (!added) return RaySet{baseRays, level + 1};
    // Grid indices double; the next level's own rays are every 2^kFoldDepth-th of its grid.
    const long grid = static_cast<long>(baseRays) << (level + 1 + kFoldDepth);
    std::vector<long> fine;
    fine.reserve(added->fine.size() + static_cast<std::size_t>(uniformCount()));
    for (long x = 0; x < grid; x += 1L << kFoldDepth) fine.push_back(x);
    for (long x : added->fine) fine.push_back(2 * x);
    std::sort(fine.begin(), fine.end());
    fine.erase(std::unique(fine.begin(), fine.end()), fine.end());
    return addedRaySet(baseRays, level + 1, std::move(fine));
}

namespace {

// How far the walk from crossing k to crossing k + 1 (polygon points a.segment + 1 .. b.segment)
// strays from the chord between them, squared, and on which side of crossing k's ray the
// farthest point lies (> 0: counterclockwise, in sector a.ray).
std::pair<double, double> strayFromChord(const Contour& contour, const LoopView& view, std::size_t k)
{
    const std::size_t count = contour.crossings.size(), m = view.polygon.size();
    const Crossing& a = contour.crossings[k];
    const Crossing& b = contour.crossings[(k + 1) % count];
    const glm::dvec2 chord = b.point - a.point;
    const double chord2 = glm::dot(chord, chord);
    const glm::dvec2 d = a.point - contour.center; // along the ray
    double farthest2 = 0.0, side = 0.0;
    for (std::size_t i = (static_cast<std::size_t>(a.segment) + 1) % m;; i = (i + 1) % m) {
        const glm::dvec2 p = view.polygon[i];
        const double s = chord2 > 0.0 ? std::clamp(glm::dot(p - a.point, chord) / chord2, 0.0, 1.0) : 0.0;
        const glm::dvec2 off = p - (a.point + s * chord);
        const double distance2 = glm::dot(off, off);
        if (distance2 > farthest2) {
            farthest2 = distance2;
            side = d.x * (p.y - contour.center.y) - d.y * (p.x - contour.center.x);
        }
        if (i == static_cast<std::size_t>(b.segment)) break;
    }
    return {farthest2, side};
}

std::vector<int> sortedOnce(std::vector<int> sectors)
{
    std::sort(sectors.begin(), sectors.end());
    sectors.erase(std::unique(sectors.begin(), sectors.end()), sectors.end());
    return sectors;
}

// The sectors (ascending, once each) of the chords between crossings of two neighbouring rays
// that `keep` takes: keep(k, a, b) for the chord from crossing k (a) to crossing k + 1 (b).
template <class Keep>
std::vector<int> chordSectors(const Contour& contour, const Keep& keep)
{
    std::vector<int> sectors;
    const std::size_t count = contour.crossings.size();
    const int n = contour.rays.count();
    for (std::size_t k = 0; k < count; ++k) {
        const Crossing& a = contour.crossings[k];
        const Crossing& b = contour.crossings[(k + 1) % count];
        if (a.ray != b.ray && keep(k, a, b)) sectors.push_back((b.ray + n - a.ray) % n == 1 ? a.ray : b.ray);
    }
    return sortedOnce(std::move(sectors));
}

} // namespace

std::vector<int> hiddenFolds(const Contour& contour, const LoopView& view, double tolerance)
{
    std::vector<int> sectors;
    const std::size_t count = contour.crossings.size();
    const int n = contour.rays.count();
    if (count <= static_cast<std::size_t>(n)) return sectors; // one crossing per ray: no fold
    for (std::size_t k = 0; k < count; ++k) {
        const Crossing& a = contour.crossings[k];
        const Crossing& b = contour.crossings[(k + 1) % count];
        if (a.ray != b.ray || a.segment == b.segment) continue;
        const auto [farthest2, side] = strayFromChord(contour, view, k);
        if (farthest2 > tolerance * tolerance) sectors.push_back(side > 0.0 ? a.ray : (a.ray + n - 1) % n);
    }
    return sortedOnce(std::move(sectors));
}

std::vector<int> strayingChords(const Contour& contour, const LoopView& view, double tolerance)
{
    return chordSectors(contour, [&](std::size_t k, const Crossing& a, const Crossing& b) {
        return a.segment != b.segment && strayFromChord(contour, view, k).first > tolerance * tolerance;
    });
}

namespace {

// The walk from crossing k to crossing k + 1 along the polygon: the crossings' points at its ends
// and the polygon points between them, with their indices into view.polygon (-1 at the ends).
void walkBetween(const Contour& contour, const LoopView& view, std::size_t k, std::vector<glm::dvec2>& walk,
                 std::vector<int>& index)
{
    const std::size_t m = view.polygon.size();
    const Crossing& a = contour.crossings[k];
    const Crossing& b = contour.crossings[(k + 1) % contour.crossings.size()];
    walk.assign(1, a.point);
    index.assign(1, -1);
    for (std::size_t i = (static_cast<std::size_t>(a.segment) + 1) % m;; i = (i + 1) % m) {
        walk.push_back(view.polygon[i]);
        index.push_back(static_cast<int>(i));
        if (i == static_cast<std::size_t>(b.segment)) break;
    }
    walk.push_back(b.point);
    index.push_back(-1);
}

} // namespace

std::vector<std::vector<int>> wallPoints(const Contour& contour, const LoopView& view, double reach, double tolerance)
{
    const std::size_t count = contour.crossings.size();
    std::vector<std::vector<int>> kept(count);
    std::vector<glm::dvec2> walk;
    std::vector<int> index;
    std::vector<bool> keep;
    for (std::size_t k = 0; k < count; ++k) {
        if (contour.crossings[k].segment == contour.crossings[(k + 1) % count].segment)
            continue; // no polygon point between them
        walkBetween(contour, view, k, walk, index);
        keep.assign(walk.size(), false);
        // Douglas-Peucker on the walk's points between its two ends, where the edge strays past
        // `reach`.
        std::vector<std::pair<std::size_t, std::size_t>> spans{{0, walk.size() - 1}};
        while (!spans.empty()) {
            const auto [lo, hi] = spans.back();
            spans.pop_back();
            const glm::dvec2 chord = walk[hi] - walk[lo];
            const double chord2 = glm::dot(chord, chord);
            const double bound = lo == 0 && hi + 1 == walk.size() ? reach : tolerance;
            double farthest2 = bound * bound;
            std::size_t at = 0;
            for (std::size_t i = lo + 1; i < hi; ++i) {
                const double s =
                    chord2 > 0.0 ? std::clamp(glm::dot(walk[i] - walk[lo], chord) / chord2, 0.0, 1.0) : 0.0;
                const glm::dvec2 off = walk[i] - (walk[lo] + s * chord);
                if (glm::dot(off, off) > farthest2) {
                    farthest2 = glm::dot(off, off);
                    at = i;
                }
            }
            if (at == 0) continue;
            keep[at] = true;
            spans.push_back({lo, at});
            spans.push_back({at, hi});
        }
        for (std::size_t i = 1; i + 1 < walk.size(); ++i)
            if (keep[i]) kept[k].push_back(index[i]);
    }
    return kept;
}

std::vector<std::vector<int>> longChordPoints(const Contour& contour, const LoopView& view,
                                              const std::vector<double>& pieces)
{
    std::vector<std::vector<int>> kept(contour.crossings.size());
    std::vector<glm::dvec2> walk;
    std::vector<int> index;
    std::vector<double> along; // arc length along the walk
    for (std::size_t k = 0; k < contour.crossings.size(); ++k) {
        const Crossing& a = contour.crossings[k];
        const Crossing& b = contour.crossings[(k + 1) % contour.crossings.size()];
        if (a.segment == b.segment || pieces[k] <= 0.0) continue;
        walkBetween(contour, view, k, walk, index);
        along.assign(1, 0.0);
        for (std::size_t i = 1; i < walk.size(); ++i)
            along.push_back(along.back() + glm::distance(walk[i - 1], walk[i]));
        // Pieces of equal length along the walk, each cut at the polygon point nearest its end.
        const int count = static_cast<int>(std::ceil(along.back() / pieces[k]));
        std::size_t at = 0;
        for (int j = 1; j < count; ++j) {
            const double target = along.back() * j / count;
            while (at + 1 < walk.size() && along[at + 1] <= target) ++at;
            const std::size_t nearest =
                at + 1 < walk.size() && along[at + 1] - target < target - along[at] ? at + 1 : at;
            if (index[nearest] >= 0 && (kept[k].empty() || kept[k].back() != index[nearest]))
                kept[k].push_back(index[nearest]);
        }
    }
    return kept;
}

std::vector<int> longChords(const Contour& contour, double length)
{
    return chordSectors(contour, [&](std::size_t, const Crossing& a, const Crossing& b) {
        const glm::dvec2 chord = b.point - a.point;
        return glm::dot(chord, chord) > length * length;
    });
}

EdgeType classifyEdge(const Crossing& from, const Crossing& to, int rayCount)
{
    const bool fromInOut = from.kind == CrossingKind::InOut, toInOut = to.kind == CrossingKind::InOut;
    if (fromInOut && toInOut) {
        PIPETILE_ASSERT(to.ray == (from.ray + 1) % rayCount, "F edge must join ray x to ray x+1");
        return EdgeType::Forward;
    }
    if (!fromInOut && !toInOut) {
        PIPETILE_ASSERT(from.ray == (to.ray + 1) % rayCount, "B edge must join ray x+1 to ray x");
        return EdgeType::Backward;
    }
    PIPETILE_ASSERT(from.ray == to.ray, "U and D edges join two crossings of one ray");
    const bool up = to.crackT > from.crackT;
    if (fromInOut) return up ? EdgeType::UpIn : EdgeType::DownIn;
    return up ? EdgeType::UpOut : EdgeType::DownOut;
}

int countEdges(const Contour& contour, EdgeType type)
{
    return static_cast<int>(std::count(contour.edges.begin(), contour.edges.end(), type));
}

bool isUnambiguous(const Contour& contour)
{
    return !contour.edges.empty() && countEdges(contour, EdgeType::Forward) == contour.rays.count();
}

const char* toString(EdgeType type)
{
    switch (type) {
    case EdgeType::Forward: return "F";
    case EdgeType::Backward: return "B";
    case EdgeType::DownIn: return "D_I";
    case EdgeType::DownOut: return "D_O";
    case EdgeType::UpIn: return "U_I";
    case EdgeType::UpOut: return "U_O";
    }
    return "?";
}

} // namespace pipetile
