// pipetile — libFuzzer harness: boundary walk, central point, ray casting, contour trees and tiling
// of arbitrary small images. Every promise of contour.h, contour_tree.h and tiler.h that can be
// checked from outside is checked, and a broken one traps, so libFuzzer keeps the input.
//
// Input layout (missing bytes read as 0, missing pixels as outside):
//   byte 0      width - 1  (mod 32)
//   byte 1      height - 1 (mod 32)
//   byte 2      bits 0-2: baseRays = 3 + value % 6; bit 6: also cast from the loop's centroid;
//               bit 7: binary image (-1 / +1) instead of graded values
//   byte 3      origin: low nibble - 8 = u, high nibble - 8 = v
//   bytes 4...  one byte per pixel, row-major; graded value = int8(byte) / 8 (negative inside)

#include <pipetile/detail/field_image.h>
#include <pipetile/contour.h>
#include <pipetile/contour_tree.h>
#include <pipetile/tiler.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <tuple>
#include <utility>
#include <vector>

using namespace pipetile;
using pipetile::detail::FieldImage;

namespace {

[[noreturn]] void fail(const char* what, int line)
{
    std::fprintf(stderr, "fuzz_contour: invariant broken at line %d: %s\n", line, what);
    __builtin_trap();
}

#define FUZZ_CHECK(condition)                                                                                          \
    do {                                                                                                               \
        if (!(condition)) fail(#condition, __LINE__);                                                                  \
    } while (false)

struct Input {
    const std::uint8_t* data;
    std::size_t size;
    std::uint8_t at(std::size_t i) const { return i < size ? data[i] : 0; }
};

constexpr glm::ivec2 kStep[4] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
// Pixel on the left of the crack leaving corner C in direction d is C + kLeft[d] (contour.h: corner
// (i, j) is the lower-left corner of pixel (i, j)); the pixel on its right is C + kLeft[(d + 3) % 4].
constexpr glm::ivec2 kLeft[4] = {{0, 0}, {-1, 0}, {-1, -1}, {0, -1}};

int directionOf(glm::ivec2 step)
{
    for (int d = 0; d < 4; ++d)
        if (step == kStep[d]) return d;
    return -1;
}

// traceBoundaries: every crack between an inside and an outside pixel is walked exactly once,
// with the inside on its left; loops close; areas count pixels (holes negative).
void checkLoops(const FieldImage& image, const std::vector<BoundaryLoop>& loops)
{
    std::vector<std::tuple<int, int, int>> walked; // (corner, direction) of every crack
    double areaSum = 0.0;
    for (const BoundaryLoop& loop : loops) {
        const std::size_t m = loop.corners.size();
        FUZZ_CHECK(m >= 4);
        FUZZ_CHECK(loop.points.size() == m);
        double area2 = 0.0;
        for (std::size_t i = 0; i < m; ++i) {
            const glm::ivec2 c = loop.corners[i], next = loop.corners[(i + 1) % m];
            const int d = directionOf(next - c);
            FUZZ_CHECK(d >= 0);
            const glm::ivec2 in = c + kLeft[d], out = c + kLeft[(d + 3) % 4];
            FUZZ_CHECK(image.inside(in.x, in.y));
            FUZZ_CHECK(!image.inside(out.x, out.y));
            walked.emplace_back(c.x, c.y, d);
            // The marching-squares point lies on the segment between the two pixel centres.
            const glm::dvec2 p = loop.points[i];
            FUZZ_CHECK(std::isfinite(p.x) && std::isfinite(p.y));
            FUZZ_CHECK(p.x >= std::min(in.x, out.x) && p.x <= std::max(in.x, out.x));
            FUZZ_CHECK(p.y >= std::min(in.y, out.y) && p.y <= std::max(in.y, out.y));
            area2 += static_cast<double>(c.x) * next.y - static_cast<double>(next.x) * c.y;
        }
        FUZZ_CHECK(loop.area == 0.5 * area2);
        FUZZ_CHECK(loop.area != 0.0);
        FUZZ_CHECK(loop.hole() == (loop.area < 0.0));
        FUZZ_CHECK(std::isfinite(loop.centroid.x) && std::isfinite(loop.centroid.y));
        areaSum += loop.area;
    }
    // Count the cracks directly: each inside pixel with an outside 4-neighbour.
    std::size_t cracks = 0, insidePixels = 0;
    for (int v = image.origin.y; v < image.origin.y + image.height; ++v)
        for (int u = image.origin.x; u < image.origin.x + image.width; ++u) {
            if (!image.inside(u, v)) continue;
            ++insidePixels;
            for (const glm::ivec2 s : kStep) cracks += image.inside(u + s.x, v + s.y) ? 0 : 1;
        }
    std::sort(walked.begin(), walked.end());
    FUZZ_CHECK(std::adjacent_find(walked.begin(), walked.end()) == walked.end()); // each once
    FUZZ_CHECK(walked.size() == cracks);
    // Green: the signed areas of all loops add up to the inside pixels.
    FUZZ_CHECK(areaSum == static_cast<double>(insidePixels));
}

// castRays: either empty, or a contour that winds once with consistent crossings and edges.
void checkContour(const Contour& c, const BoundaryLoop& loop, const glm::dvec2& center, const RaySet& rays)
{
    const int n = rays.count();
    FUZZ_CHECK(c.rays.baseRays == rays.baseRays && c.rays.level == rays.level);
    FUZZ_CHECK(c.center == center);
    FUZZ_CHECK(c.edges.size() == c.crossings.size());
    if (c.crossings.empty()) return;
    const std::size_t count = c.crossings.size();
    FUZZ_CHECK(countEdges(c, EdgeType::Forward) - countEdges(c, EdgeType::Backward) == n);
    FUZZ_CHECK(isUnambiguous(c) == (countEdges(c, EdgeType::Forward) == n));
    FUZZ_CHECK(c.interpolationFallbacks >= 0 && static_cast<std::size_t>(c.interpolationFallbacks) <= count);
    // crackT is the distance from the centre to the loop's polygon along the ray: never beyond
    // the polygon's farthest point.
    double reach = 0.0;
    for (const glm::dvec2& p : loop.points) reach = std::max(reach, std::hypot(p.x - center.x, p.y - center.y));
    std::vector<std::vector<const Crossing*>> perRay(n);
    for (std::size_t k = 0; k < count; ++k) {
        const Crossing& x = c.crossings[k];
        FUZZ_CHECK(x.ray >= 0 && x.ray < n);
        FUZZ_CHECK(std::isfinite(x.crackT) && std::isfinite(x.t));
        FUZZ_CHECK(x.crackT >= -1e-9 && x.crackT <= reach * (1.0 + 1e-9) + 1e-9);
        FUZZ_CHECK(std::isfinite(x.point.x) && std::isfinite(x.point.y));
        FUZZ_CHECK(c.edges[k] == classifyEdge(x, c.crossings[(k + 1) % count], n));
        perRay[x.ray].push_back(&x);
    }
    // Starts at the outermost InOut crossing of ray 0.
    const Crossing& first = c.crossings[0];
    FUZZ_CHECK(first.ray == 0 && first.kind == CrossingKind::InOut);
    for (const Crossing* x : perRay[0])
        if (x->kind == CrossingKind::InOut) FUZZ_CHECK(x->crackT <= first.crackT);
    // radialProfile cuts the same polygon along the same directions: its nearest and farthest
    // distance per direction are that ray's nearest and farthest crackT (without added rays, its
    // directions are the rays).
    if (!rays.added) {
        const RadialProfile profile = radialProfile(viewFrom(loop, center), n);
        for (int ray = 0; ray < n; ++ray) {
            double nearest = std::numeric_limits<double>::infinity(), farthest = -nearest;
            for (const Crossing* x : perRay[ray]) {
                nearest = std::min(nearest, x->crackT);
                farthest = std::max(farthest, x->crackT);
            }
            FUZZ_CHECK(std::abs(profile.nearest[ray] - nearest) <= 1e-9 * std::max(1.0, reach));
            FUZZ_CHECK(std::abs(profile.farthest[ray] - farthest) <= 1e-9 * std::max(1.0, reach));
        }
    }
    for (int ray = 0; ray < n; ++ray) {
        std::vector<const Crossing*>& xs = perRay[ray];
        // One more InOut than OutIn on every ray (the loop winds once around the centre).
        int balance = 0;
        for (const Crossing* x : xs) balance += x->kind == CrossingKind::InOut ? 1 : -1;
        FUZZ_CHECK(balance == 1);
        FUZZ_CHECK(xs.size() % 2 == 1);
        std::stable_sort(xs.begin(), xs.end(),
                         [](const Crossing* a, const Crossing* b) { return a->crackT < b->crackT; });
        // From the centre outward the ray leaves, enters, leaves, ...: InOut, OutIn, ..., InOut.
        // Unless two crossings tie in distance, up to rounding: where the marching-squares polygon
        // touches itself (at the centre of a pixel whose value is exactly 0) and the ray passes
        // through that point, the order of the two crossings there is not defined.
        bool ties = false;
        for (std::size_t k = 1; k < xs.size(); ++k)
            ties |= xs[k]->crackT - xs[k - 1]->crackT <= 1e-9 * std::max(1.0, std::abs(xs[k]->crackT));
        if (!ties)
            for (std::size_t k = 0; k < xs.size(); ++k)
                FUZZ_CHECK(xs[k]->kind == (k % 2 == 0 ? CrossingKind::InOut : CrossingKind::OutIn));
        for (std::size_t k = 0; k < xs.size(); ++k) {
            // Refinement never moves a crossing past its neighbours on the ray.
            if (k > 0) FUZZ_CHECK(xs[k - 1]->t <= xs[k]->t);
            FUZZ_CHECK(xs[k]->t >= 0.0);
        }
    }
}

// Levels nest: ray x of level L is ray 2x of level L+1, with the same crossings bit for bit.
void checkNesting(const Contour& coarse, const Contour& fine)
{
    if (coarse.crossings.empty()) return;
    FUZZ_CHECK(!fine.crossings.empty());
    using Key = std::tuple<int, int, double, double, double, double>;
    std::vector<Key> fineKeys, coarseKeys;
    for (const Crossing& x : fine.crossings)
        if (x.ray % 2 == 0) fineKeys.emplace_back(x.ray, static_cast<int>(x.kind), x.crackT, x.t, x.point.x, x.point.y);
    for (const Crossing& x : coarse.crossings)
        coarseKeys.emplace_back(2 * x.ray, static_cast<int>(x.kind), x.crackT, x.t, x.point.x, x.point.y);
    std::sort(fineKeys.begin(), fineKeys.end());
    std::sort(coarseKeys.begin(), coarseKeys.end());
    FUZZ_CHECK(fineKeys == coarseKeys);
}

// Added rays (contour.h, hiddenFolds and RaySet::withMidpoints): refining a contour with them
// equals casting all of them, and keeps every crossing it had, bit for bit.
void checkAddedRays(const Contour& c, const BoundaryLoop& loop, const glm::dvec2& center, const FieldImage& image)
{
    if (c.crossings.empty()) return;
    const std::vector<int> sectors = hiddenFolds(c, viewFrom(loop, center), 0.5);
    for (std::size_t k = 0; k < sectors.size(); ++k)
        FUZZ_CHECK(sectors[k] >= 0 && sectors[k] < c.rays.count() && (k == 0 || sectors[k - 1] < sectors[k]));
    const RaySet grown = c.rays.withMidpoints(sectors);
    if (grown.count() == c.rays.count()) return;
    const Contour refined = refineContour(c, loop, grown, image);
    const Contour scratch = castRays(loop, center, grown, image);
    checkContour(scratch, loop, center, grown);
    auto points = [](const Contour& x) {
        std::vector<std::pair<double, double>> p;
        for (const Crossing& k : x.crossings) p.emplace_back(k.point.x, k.point.y);
        return p;
    };
    FUZZ_CHECK(points(refined) == points(scratch));
    if (scratch.crossings.empty()) return;
    std::vector<std::pair<double, double>> all = points(refined), old = points(c);
    std::sort(all.begin(), all.end());
    std::sort(old.begin(), old.end());
    FUZZ_CHECK(std::includes(all.begin(), all.end(), old.begin(), old.end()));
}

// tileBand: m + n triangles, ids < m + n, a closed strip in which every contour edge lies in one
// triangle, A's edges run i -> i+1 and B's (j+1) -> j (counterclockwise seen from outside), and
// consecutive triangles share a spanning edge. For contours of at least 3 crossings the strip
// visits no spanning edge twice, so each is used once in each direction: with caps that use A's
// edges reversed and B's as they are (checkCaps), the tube is a closed oriented manifold.
void checkBand(const std::vector<Triangle>& band, std::uint32_t m, std::uint32_t n)
{
    FUZZ_CHECK(band.size() == m + n);
    std::vector<int> aUsed(m, 0), bUsed(n, 0);
    std::vector<std::uint64_t> entry, exit; // spanning edges (A vertex, B vertex) as one number
    auto spanning = [](std::uint32_t a, std::uint32_t b) { return (std::uint64_t(a) << 32) | b; };
    for (const Triangle& t : band) {
        int fromA = 0;
        for (std::uint32_t id : t) {
            FUZZ_CHECK(id < m + n);
            fromA += id < m ? 1 : 0;
        }
        FUZZ_CHECK(fromA == 1 || fromA == 2);
        // Rotate so the triangle reads (A, A, B) or (A, B, B).
        Triangle r = t;
        for (int k = 0; k < 3 && !(r[0] < m && (fromA == 1 || r[2] >= m)); ++k) r = {r[1], r[2], r[0]};
        FUZZ_CHECK(r[0] < m && r[2] >= m);
        if (fromA == 2) {
            FUZZ_CHECK(r[1] == (r[0] + 1) % m);
            ++aUsed[r[0]];
            entry.push_back(spanning(r[0], r[2]));
            exit.push_back(spanning(r[1], r[2]));
        } else {
            FUZZ_CHECK(r[1] >= m && r[1] - m == (r[2] - m + 1) % n);
            ++bUsed[r[2] - m];
            entry.push_back(spanning(r[0], r[2]));
            exit.push_back(spanning(r[0], r[1]));
        }
    }
    for (int used : aUsed) FUZZ_CHECK(used == 1);
    for (int used : bUsed) FUZZ_CHECK(used == 1);
    for (std::size_t k = 0; k < band.size(); ++k) FUZZ_CHECK(exit[k] == entry[(k + 1) % band.size()]);
    if (m < 3 || n < 3) return;
    std::sort(entry.begin(), entry.end());
    FUZZ_CHECK(std::adjacent_find(entry.begin(), entry.end()) == entry.end());
}

// tileCap and tileFlatCap over m >= 3 crossings: every contour edge once, reversed (i+1 -> i) for
// a bottom cap and as walked (i -> i+1) for a top one, and every other edge once each way.
void checkCaps(std::uint32_t m)
{
    // Caps depend on m alone: check each size once per process.
    static std::vector<bool> checked;
    if (m < 3 || (m < checked.size() && checked[m])) return;
    if (m >= checked.size()) checked.resize(m + 1, false);
    checked[m] = true;
    for (const bool top : {false, true})
        for (const bool apex : {true, false}) {
            const std::vector<Triangle> cap = apex ? tileCap(m, top) : tileFlatCap(m, top);
            FUZZ_CHECK(cap.size() == (apex ? m : m - 2));
            std::vector<std::uint64_t> edges;
            for (const Triangle& t : cap)
                for (int k = 0; k < 3; ++k) {
                    FUZZ_CHECK(t[k] < (apex ? m + 1 : m));
                    edges.push_back((std::uint64_t(t[k]) << 32) | t[(k + 1) % 3]);
                }
            std::sort(edges.begin(), edges.end());
            FUZZ_CHECK(std::adjacent_find(edges.begin(), edges.end()) == edges.end());
            for (const std::uint64_t e : edges) {
                const auto from = static_cast<std::uint32_t>(e >> 32), to = static_cast<std::uint32_t>(e);
                const bool boundary = from < m && to < m && (to == (from + 1) % m || from == (to + 1) % m);
                const bool reversed = std::binary_search(edges.begin(), edges.end(), (std::uint64_t(to) << 32) | from);
                if (!boundary)
                    FUZZ_CHECK(reversed);
                else
                    FUZZ_CHECK(!reversed && (top ? to == (from + 1) % m : from == (to + 1) % m));
            }
        }
}

// ContourTree: level-1 node x holds an F edge leaving ray x, the traversal starts where F_0 starts,
// every contour edge is in exactly one node (a level-1 node or a leaf), and the traversal keys
// grow along the walk from the start.
void checkTree(const ContourTree& tree, const ContourString& s)
{
    const int m = static_cast<int>(s.edges.size());
    FUZZ_CHECK(tree.rays() == s.rays);
    FUZZ_CHECK(static_cast<int>(tree.keys().size()) == m);
    FUZZ_CHECK(tree.startCrossing() >= 0 && tree.startCrossing() < m);
    FUZZ_CHECK(tree.mainEdge(0) == tree.startCrossing());
    for (int x = 0; x < s.rays; ++x) {
        const int e = tree.mainEdge(x);
        FUZZ_CHECK(e >= 0 && e < m);
        FUZZ_CHECK(s.edges[e] == EdgeType::Forward && s.ray[e] == x);
    }
    std::vector<int> owned(m, 0);
    for (const TreeNode& node : tree.nodes())
        if (node.kind == NodeKind::Edge || node.kind == NodeKind::LevelOne) {
            FUZZ_CHECK(node.edge >= 0 && node.edge < m);
            ++owned[node.edge];
            if (node.kind == NodeKind::Edge) FUZZ_CHECK(node.type == s.edges[node.edge]);
        }
    for (int k : owned) FUZZ_CHECK(k == 1);
    for (int i = 0; i + 1 < m; ++i) {
        const int at = (tree.startCrossing() + i) % m;
        FUZZ_CHECK(tree.keys()[at] <= tree.keys()[(at + 1) % m]);
    }
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const Input in{data, size};
    FieldImage image;
    image.width = 1 + in.at(0) % 32;
    image.height = 1 + in.at(1) % 32;
    const int baseRays = 3 + (in.at(2) & 7) % 6;
    const bool fromCentroid = in.at(2) & 0x40;
    const bool binary = in.at(2) & 0x80;
    image.origin = glm::ivec2((in.at(3) & 15) - 8, (in.at(3) >> 4) - 8);
    image.values.resize(static_cast<std::size_t>(image.width) * image.height);
    for (std::size_t i = 0; i < image.values.size(); ++i) {
        const std::size_t at = 4 + i;
        const auto byte = static_cast<std::int8_t>(in.at(at));
        image.values[i] = at >= size ? 1.0 : binary ? (byte < 0 ? -1.0 : 1.0) : byte / 8.0;
    }

    const std::vector<BoundaryLoop> loops = traceBoundaries(image);
    checkLoops(image, loops);

    constexpr int kLevels = 4;
    // contours[level] over all loops (and both centres), in the same order for every level.
    std::vector<std::vector<Contour>> contours(kLevels);
    for (const BoundaryLoop& loop : loops) {
        const glm::dvec2 center = centralPoint(loop);
        // contour.h: a point inside the region the loop encloses.
        FUZZ_CHECK(encloses(loop, center));
        std::vector<glm::dvec2> centers{center};
        if (fromCentroid) centers.push_back(loop.centroid);
        for (const glm::dvec2& c : centers) {
            for (int level = 0; level < kLevels; ++level) {
                const RaySet rays{baseRays, level};
                contours[level].push_back(castRays(loop, c, rays, image));
                checkContour(contours[level].back(), loop, c, rays);
                checkAddedRays(contours[level].back(), loop, c, image);
                if (level > 0) checkNesting(contours[level - 1].back(), contours[level].back());
            }
        }
    }

    // Trees of every contour, and bands between each contour and itself and the next one of the
    // same level, from the trees and from the edge strings.
    constexpr std::size_t kMaxPairs = 8;
    for (int level = 0; level < kLevels; ++level) {
        std::vector<const Contour*> wound;
        std::vector<ContourTree> trees;
        for (const Contour& c : contours[level]) {
            if (c.crossings.empty()) continue;
            const ContourString s = contourString(c);
            trees.emplace_back(s);
            checkTree(trees.back(), s);
            if (wound.size() < kMaxPairs) checkCaps(static_cast<std::uint32_t>(c.crossings.size()));
            wound.push_back(&c);
        }
        for (std::size_t i = 0; i < std::min(wound.size(), kMaxPairs); ++i)
            for (const std::size_t j : {i, (i + 1) % wound.size()}) {
                const auto m = static_cast<std::uint32_t>(wound[i]->crossings.size());
                const auto n = static_cast<std::uint32_t>(wound[j]->crossings.size());
                checkBand(tileBand(trees[i], trees[j]), m, n);
                checkBand(tileBand(wound[i]->edges, wound[j]->edges), m, n);
            }
    }
    return 0;
}
