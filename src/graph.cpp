// pipetile — graph: correspondence of contours through the slab between planes (TOPOLOGY.md), and
// the reconstruction's stages that build its skeleton on it (multires.h): correspond (the graph,
// with the planes it adds) and resolve events (junctions, waists, patches, a band's own planes).

#include <pipetile/caps.h>
#include <pipetile/graph.h>
#include <pipetile/multires.h>
#include <pipetile/validate.h>

#include "reconstruction_state.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <tuple>
#include <unordered_set>
#include <utility>
#include <vector>

namespace pipetile {

namespace {

struct PixelBox {
    glm::ivec2 min{0}, max{0}; // inclusive
    bool overlaps(const PixelBox& other) const
    {
        return min.x <= other.max.x && other.min.x <= max.x && min.y <= other.max.y && other.min.y <= max.y;
    }
};

// The pixels a loop's cracks run around: corner (i, j) is the lower-left corner of pixel (i, j).
PixelBox boxOf(const BoundaryLoop& loop)
{
    PixelBox box{loop.corners.front(), loop.corners.front() - 1};
    for (const glm::ivec2& c : loop.corners) {
        box.min = glm::min(box.min, c);
        box.max = glm::max(box.max, c - 1);
    }
    return box;
}

// The inside and outside pixels on either side of the crack from corner c0 to corner c1 (the
// walk keeps the inside on its left, for holes too).
std::pair<glm::ivec2, glm::ivec2> crackPixels(const glm::ivec2& c0, const glm::ivec2& c1)
{
    const glm::ivec2 d = c1 - c0;
    const glm::ivec2 left(-d.y, d.x);
    // Crack midpoint in pixel coordinates is (c0 + c1) / 2 - 1/2; the pixels lie half a pixel to
    // either side. Doubled to stay in integers: 2p = c0 + c1 - 1 +- left.
    const glm::ivec2 twice = c0 + c1 - 1;
    return {(twice + left) / 2, (twice - left) / 2};
}

// The inside and outside pixels on either side of the loop's first crack.
std::pair<glm::ivec2, glm::ivec2> pixelsBeside(const BoundaryLoop& loop)
{
    return crackPixels(loop.corners[0], loop.corners[1 % loop.corners.size()]);
}

// Union-find over the slab's voxels.
struct Labels {
    std::vector<std::int32_t> parent;
    explicit Labels(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
    std::int32_t find(std::int32_t x)
    {
        while (parent[x] != x) x = parent[x] = parent[parent[x]];
        return x;
    }
    void join(std::int32_t a, std::int32_t b)
    {
        a = find(a);
        b = find(b);
        if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
};

// Whether every hole of `plane` lies inside an outer loop of `other` whose cracks it never
// touches. Then the hole's air meets no outside air of the other plane's there, in the same pixel
// or the next one (through a side saddle): a path between their pixel centres, at most a pixel
// long, would cross both boundaries, each at least half a pixel from a centre, at one point,
// which lies on the corner lattice. Else a wall a pixel thin may have a window between the planes
// that neither shows (a crop of the smoke lacked a handle: its slab was taken for two bands).
bool holesSealed(const PlaneLoops& plane, const PlaneLoops& other)
{
    for (const BoundaryLoop* hole : plane.loops) {
        if (!hole->hole()) continue;
        const PixelBox box = boxOf(*hole);
        const glm::dvec2 corner = glm::dvec2(hole->corners.front()) - 0.5; // as contour.cpp's cornerPoint
        const auto seals = [&](const BoundaryLoop* wall) {
            const PixelBox around = boxOf(*wall);
            if (wall->hole() || !around.overlaps(box) || !encloses(*wall, corner)) return false;
            const auto key = [](const glm::ivec2& c) {
                return std::uint64_t(std::uint32_t(c.x)) << 32 | std::uint32_t(c.y);
            };
            std::unordered_set<std::uint64_t> corners;
            for (const glm::ivec2& c : wall->corners) corners.insert(key(c));
            return std::none_of(hole->corners.begin(), hole->corners.end(),
                                [&](const glm::ivec2& c) { return corners.count(key(c)) != 0; });
        };
        if (std::none_of(other.loops.begin(), other.loops.end(), seals)) return false;
    }
    return true;
}

// A loop of each plane overlapping exactly one loop of the same kind on the other plane, both
// ways, and each plane's holes sealed in the other's walls: then every piece is a band, and the
// slab needs no labelling. Overlap is a bounding-box test followed by one central point inside
// the other loop; boxes a pixel apart count as overlapping, as voxels touching along an edge
// across the slab may join them.
bool simpleBands(const PlaneLoops& below, const PlaneLoops& above, std::vector<SlabPiece>& pieces)
{
    if (below.loops.size() != above.loops.size()) return false;
    std::vector<PixelBox> boxesAbove;
    for (const BoundaryLoop* loop : above.loops) boxesAbove.push_back(boxOf(*loop));
    std::vector<int> partnerOfAbove(above.loops.size(), -1);
    for (std::size_t i = 0; i < below.loops.size(); ++i) {
        const BoundaryLoop& a = *below.loops[i];
        PixelBox box = boxOf(a);
        box.min -= 1;
        box.max += 1;
        int partner = -1;
        for (std::size_t j = 0; j < above.loops.size(); ++j) {
            const BoundaryLoop& b = *above.loops[j];
            if (b.hole() != a.hole() || !box.overlaps(boxesAbove[j])) continue;
            if (partner >= 0) return false; // two candidates: let the volume decide
            partner = static_cast<int>(j);
        }
        if (partner < 0 || partnerOfAbove[partner] >= 0) return false;
        const BoundaryLoop& b = *above.loops[partner];
        if (!encloses(a, above.centers[partner]) && !encloses(b, below.centers[i])) return false;
        partnerOfAbove[partner] = static_cast<int>(i);
        pieces.push_back({{static_cast<int>(i)}, {partner}, EventKind::Band});
    }
    return holesSealed(below, above) && holesSealed(above, below);
}

// A run of polygon points owned by one partner, cyclically: points start .. start + length - 1.
struct OwnerRun {
    int start, length, owner;
};

// Each point of a polygon goes to the partner whose polygon passes nearest (the planes share
// (u, v)); near a saddle the partners are the polygon's lobes, so the owners form arcs. Empty if
// one partner owns every point.
std::vector<OwnerRun> ownerRuns(const std::vector<glm::dvec2>& polygon,
                                const std::vector<const std::vector<glm::dvec2>*>& partners)
{
    const int m = static_cast<int>(polygon.size());
    std::vector<int> owner(m, 0);
    for (int i = 0; i < m; ++i) {
        double best = std::numeric_limits<double>::infinity();
        for (std::size_t k = 0; k < partners.size(); ++k)
            for (const glm::dvec2& q : *partners[k]) {
                const glm::dvec2 d = q - polygon[i];
                const double distance2 = d.x * d.x + d.y * d.y;
                if (distance2 < best) {
                    best = distance2;
                    owner[i] = static_cast<int>(k);
                }
            }
    }
    std::vector<OwnerRun> runs;
    int begin = 0;
    while (begin < m && owner[begin] == owner[(begin + m - 1) % m]) ++begin;
    if (begin == m) return runs;
    for (int i = 0; i < m; ++i) {
        const int p = (begin + i) % m;
        if (runs.empty() || runs.back().owner != owner[p]) runs.push_back({p, 0, owner[p]});
        ++runs.back().length;
    }
    return runs;
}

// Gives the shortest run to its neighbours (a few points owned by a third partner across a narrow
// gap, say) until `done` holds or two runs are left. A partner's last run stays: every way the
// arcs close needs each partner to own one.
template <class Done>
void mergeShortestRuns(std::vector<OwnerRun>& runs, const Done& done)
{
    std::map<int, int> runsOf;
    for (const OwnerRun& run : runs) ++runsOf[run.owner];
    while (runs.size() > 2 && !done(runs)) {
        std::size_t shortest = runs.size();
        for (std::size_t r = 0; r < runs.size(); ++r)
            if (runsOf[runs[r].owner] > 1 && (shortest == runs.size() || runs[r].length < runs[shortest].length))
                shortest = r;
        if (shortest == runs.size()) return;
        --runsOf[runs[shortest].owner];
        const std::size_t previous = (shortest + runs.size() - 1) % runs.size(), next = (shortest + 1) % runs.size();
        runs[previous].length += runs[shortest].length;
        if (runs[next].owner == runs[previous].owner && next != previous) {
            runs[previous].length += runs[next].length;
            --runsOf[runs[next].owner];
            runs.erase(runs.begin() + static_cast<std::ptrdiff_t>(std::max(shortest, next)));
            runs.erase(runs.begin() + static_cast<std::ptrdiff_t>(std::min(shortest, next)));
        } else {
            runs.erase(runs.begin() + static_cast<std::ptrdiff_t>(shortest));
        }
    }
}

// Whether run k is a bud: its partner's only run, between two runs of one other partner that
// has more (a speck budding from a body's side where the body meets another across a neck).
bool isBud(const std::vector<OwnerRun>& runs, const std::vector<int>& runsOf, std::size_t k)
{
    const std::size_t m = runs.size();
    const int previous = runs[(k + m - 1) % m].owner, next = runs[(k + 1) % m].owner, own = runs[k].owner;
    return runsOf[own] == 1 && previous == next && previous != own && runsOf[previous] >= 2;
}

// The runs' owners in order with the buds left out and the runs they parted joined: the bodies
// that meet across the junction's neck.
std::vector<int> bodiesBesideBuds(const std::vector<OwnerRun>& runs, const std::vector<int>& runsOf)
{
    std::vector<int> bodies;
    for (std::size_t k = 0; k < runs.size(); ++k)
        if (!isBud(runs, runsOf, k) && (bodies.empty() || bodies.back() != runs[k].owner))
            bodies.push_back(runs[k].owner);
    if (bodies.size() > 1 && bodies.front() == bodies.back()) bodies.pop_back();
    return bodies;
}

} // namespace

const char* toString(EventKind kind)
{
    switch (kind) {
    case EventKind::Band: return "band";
    case EventKind::Start: return "start";
    case EventKind::End: return "end";
    case EventKind::Fork: return "fork";
    case EventKind::Merge: return "merge";
    case EventKind::Rim: return "rim";
    case EventKind::Unresolved: return "unresolved";
    }
    return "unresolved";
}

EventKind classify(const SlabPiece& piece, const PlaneLoops& below, const PlaneLoops& above)
{
    const std::size_t a = piece.below.size(), b = piece.above.size();
    auto holes = [](const std::vector<int>& ids, const PlaneLoops& plane) {
        return static_cast<std::size_t>(
            std::count_if(ids.begin(), ids.end(), [&](int i) { return plane.loops[i]->hole(); }));
    };
    const std::size_t holesBelow = holes(piece.below, below), holesAbove = holes(piece.above, above);
    if (a == 1 && b == 1) return holesBelow == holesAbove ? EventKind::Band : EventKind::Unresolved;
    if (a == 0 && b == 1) return EventKind::Start;
    if (a == 1 && b == 0) return EventKind::End;
    // One contour against several, of one kind (a fork of walls or of holes) or of both (a wall
    // and the hole inside it against one wall: a ring breaking open, a lumen opening into a C).
    if (a == 1 && b >= 2) return EventKind::Fork;
    if (a >= 2 && b == 1) return EventKind::Merge;
    // A ring (a wall and the hole inside it) against several walls: it breaks open in several
    // places at once, or arcs close into it.
    if (a == 2 && holesBelow == 1 && b >= 2 && holesAbove == 0) return EventKind::Fork;
    if (b == 2 && holesAbove == 1 && a >= 2 && holesBelow == 0) return EventKind::Merge;
    // A wall and the holes inside it, ending (or beginning) together: a face with holes.
    if ((a >= 2 && b == 0 && holesBelow == a - 1) || (a == 0 && b >= 2 && holesAbove == b - 1)) return EventKind::Rim;
    return EventKind::Unresolved;
}

namespace {

// The slab's layers: both planes and every voxel plane strictly between them (the field is linear
// in w between voxel planes, so these decide connectivity along w), each with its image read.
struct SlabLayers {
    std::vector<double> w;
    std::vector<SlicePlane> planes;
    bool levelSet = false;
    SlabLayers(const Volume& volume, const SlicePlan& plan, double below, double above)
        : levelSet(volume.volumeClass() == VolumeClass::LevelSet)
    {
        w.push_back(below);
        for (double layer = std::floor(below) + 1.0; layer < above; layer += 1.0)
            if (layer > below) w.push_back(layer);
        w.push_back(above);
        for (double layer : w) {
            planes.emplace_back(volume, plan, layer);
            planes.back().eastCracks(); // reads the plane's image, with its bridges (slicer.h)
        }
    }
    int depth() const { return static_cast<int>(w.size()); }
    // Whether layers l and l + 1 are two voxel planes, one voxel apart: contacts along a voxel
    // edge between them are joined as volumeToMesh decides (slicer.h, contactJoins).
    bool acrossVoxelPlanes(int l) const
    {
        return l + 1 < depth() && w[l] == std::floor(w[l]) && w[l + 1] == w[l] + 1.0;
    }
};

// The slab's voxels in a pixel box labelled by connected region: inside voxels 8-connected in a
// layer (as the boundary walk joins inside pixels), outside voxels 4-connected, both joined along
// w; every outside voxel on the box's rim joins one exterior.
struct SlabLabels {
    glm::ivec2 lo{0};
    int width = 0, height = 0, depth = 0;
    Labels labels{0};
    std::vector<std::uint8_t> inside; // per voxel
    std::int32_t id(int layer, const glm::ivec2& pixel) const
    {
        return static_cast<std::int32_t>((static_cast<std::size_t>(layer) * height + (pixel.y - lo.y)) * width +
                                         (pixel.x - lo.x));
    }
    // False outside the box.
    bool insideAt(int layer, const glm::ivec2& pixel) const
    {
        const glm::ivec2 r = pixel - lo;
        return r.x >= 0 && r.y >= 0 && r.x < width && r.y < height && inside[id(layer, pixel)];
    }
};

// `box` widened by `margin` on every side, within the plan's pixel box (in 64 bits: the margin
// may outgrow the distance to the end of int).
PixelBox widened(const PixelBox& box, std::int64_t margin, const SlicePlan& plan)
{
    PixelBox out;
    for (int k = 0; k < 2; ++k) {
        out.min[k] = static_cast<int>(std::max<std::int64_t>(std::int64_t(box.min[k]) - margin, plan.pixelMin[k]));
        out.max[k] = static_cast<int>(std::min<std::int64_t>(std::int64_t(box.max[k]) + margin, plan.pixelMax[k]));
    }
    return out;
}

// Labels the slab's voxels over `box` widened by `margin`, doubling the margin (which it updates)
// while the inside touches the rim, so that every inside region met lies wholly in the box (a
// tube leaning out between the planes, a bridge between them).
SlabLabels labelSlab(const SlabLayers& layers, const SlicePlan& plan, const PixelBox& box, std::int64_t& margin)
{
    const std::vector<SlicePlane>& planes = layers.planes;
    SlabLabels slab;
    slab.depth = layers.depth();
    std::vector<std::uint8_t>& inside = slab.inside;
    for (bool touches = true; touches;) {
        const PixelBox pixels = widened(box, margin, plan);
        slab.lo = pixels.min;
        const glm::ivec2 hi = pixels.max;
        slab.width = hi.x - slab.lo.x + 1;
        slab.height = hi.y - slab.lo.y + 1;
        inside.assign(static_cast<std::size_t>(slab.width) * slab.height * slab.depth, 0);
        touches = false;
        for (int l = 0; l < slab.depth; ++l)
            for (int v = slab.lo.y; v <= hi.y; ++v)
                for (int u = slab.lo.x; u <= hi.x; ++u) {
                    const bool in = planes[l].inside(u, v);
                    inside[slab.id(l, {u, v})] = in;
                    touches = touches || (in && (u == slab.lo.x || v == slab.lo.y || u == hi.x || v == hi.y));
                }
        // The plan's box holds every active voxel: it cannot grow past it.
        touches = touches && (slab.lo != plan.pixelMin || hi != plan.pixelMax);
        if (touches) margin *= 2;
    }
    const std::int32_t exterior = static_cast<std::int32_t>(inside.size());
    slab.labels = Labels(inside.size() + 1);
    // Voxels one plane apart that touch along a voxel edge only (a saddle on the face between
    // them) are joined or not as volumeToMesh decides, between two voxel planes; a layer between
    // voxel planes shows such a contact in its image as a bridge (slicer.h).
    auto insideAt = [&](int l, const glm::ivec2& q) { return slab.insideAt(l, q); };
    auto linkAcrossSaddles = [&](int l, const glm::ivec2& p, bool in) {
        auto layerPair = [&](int plane, const glm::ivec2& q) { return insideAt(l + plane, q); };
        for (const glm::ivec2 step : {glm::ivec2(1, 0), glm::ivec2(-1, 0), glm::ivec2(0, 1), glm::ivec2(0, -1)}) {
            const glm::ivec2 q = p + step;
            if (insideAt(l + 1, q) != in || insideAt(l, q) == in || insideAt(l + 1, p) == in) continue;
            // p and q are the inside pair, or the outside pair whose partner pair is (q, p).
            const bool insideJoined =
                in ? contactJoins(layers.levelSet, layerPair, p, q) : contactJoins(layers.levelSet, layerPair, q, p);
            if (in == insideJoined) slab.labels.join(slab.id(l, p), slab.id(l + 1, q));
        }
    };
    for (int l = 0; l < slab.depth; ++l)
        for (int y = 0; y < slab.height; ++y)
            for (int x = 0; x < slab.width; ++x) {
                const glm::ivec2 pixel = slab.lo + glm::ivec2(x, y);
                const std::int32_t p = slab.id(l, pixel);
                const bool in = inside[p];
                auto link = [&](int layer, const glm::ivec2& offset) {
                    const std::int32_t q = slab.id(layer, pixel + offset);
                    if (inside[q] == in) slab.labels.join(p, q);
                };
                if (x + 1 < slab.width) link(l, {1, 0});
                if (y + 1 < slab.height) link(l, {0, 1});
                // Diagonal pixels: inside ones are joined as the walk joins them, outside ones
                // only through a saddle the walk leaves open.
                auto linkDiagonal = [&](const glm::ivec2& offset) {
                    const glm::ivec2 q = pixel + offset;
                    const bool side1 = inside[slab.id(l, {q.x, pixel.y})], side2 = inside[slab.id(l, {pixel.x, q.y})];
                    const bool saddle = side1 == side2 && side1 != in && inside[slab.id(l, q)] == in;
                    if (!saddle) {
                        if (in) link(l, offset);
                        return;
                    }
                    const glm::ivec2 corner(std::max(pixel.x, q.x), std::max(pixel.y, q.y));
                    if (in == planes[l].saddleJoins(corner)) link(l, offset);
                };
                if (y + 1 < slab.height && x + 1 < slab.width) linkDiagonal({1, 1});
                if (y + 1 < slab.height && x > 0) linkDiagonal({-1, 1});
                if (l + 1 < slab.depth) link(l + 1, {0, 0});
                if (layers.acrossVoxelPlanes(l)) linkAcrossSaddles(l, pixel, in);
                if (!in && (x == 0 || y == 0 || x + 1 == slab.width || y + 1 == slab.height))
                    slab.labels.join(p, exterior);
            }
    return slab;
}

// Whether the labelled slab holds a region, inside or out, that meets neither of its planes and
// is not the air around everything: a speck or a void wholly between the planes, which no loop
// shows. Only a slab with a voxel plane strictly inside can: between two voxel planes the field
// is linear along w, and a region there reaches one of them.
bool hidesRegion(SlabLabels& slab)
{
    if (slab.depth <= 2) return false;
    const std::size_t layer = static_cast<std::size_t>(slab.width) * static_cast<std::size_t>(slab.height);
    const std::size_t voxels = layer * static_cast<std::size_t>(slab.depth);
    std::vector<std::uint8_t> seen(voxels + 1, 0); // by root: meets a plane, or is the air around
    seen[static_cast<std::size_t>(slab.labels.find(static_cast<std::int32_t>(voxels)))] = 1;
    for (const std::size_t first : {std::size_t(0), voxels - layer})
        for (std::size_t v = first; v < first + layer; ++v)
            seen[static_cast<std::size_t>(slab.labels.find(static_cast<std::int32_t>(v)))] = 1;
    for (std::size_t v = layer; v < voxels - layer; ++v)
        if (!seen[static_cast<std::size_t>(slab.labels.find(static_cast<std::int32_t>(v)))]) return true;
    return false;
}

// Loops of both planes whose labelling boxes overlap, transitively: each cluster is labelled in
// its own box, so that far-apart objects in one plane cost their own pixels, not the gap's.
// Boxes of different clusters are disjoint and each holds every inside region it meets, so no
// region joins two clusters: the pieces are those one box around all the loops gives.
struct LoopCluster {
    PixelBox box;            // the pixels of its loops
    std::int64_t margin = 0; // labelled over box widened by margin
    std::vector<int> loops;  // below: i, above: below.loops.size() + j
    bool labelled = false;
};

// Merges clusters whose labelling boxes overlap until none do; true if any merged.
bool mergeOverlapping(std::vector<LoopCluster>& clusters, const SlicePlan& plan)
{
    bool mergedAny = false;
    for (bool merged = true; merged;) {
        merged = false;
        Labels groups(clusters.size());
        for (std::size_t a = 0; a < clusters.size(); ++a)
            for (std::size_t b = a + 1; b < clusters.size(); ++b)
                if (widened(clusters[a].box, clusters[a].margin, plan)
                        .overlaps(widened(clusters[b].box, clusters[b].margin, plan))) {
                    groups.join(static_cast<std::int32_t>(a), static_cast<std::int32_t>(b));
                    merged = true;
                }
        if (!merged) break;
        mergedAny = true;
        // Each group's root is its lowest index: merge the others into it, keeping that order.
        std::vector<LoopCluster> out;
        std::vector<int> slot(clusters.size(), -1);
        for (std::size_t c = 0; c < clusters.size(); ++c) {
            const std::size_t root = static_cast<std::size_t>(groups.find(static_cast<std::int32_t>(c)));
            if (root == c) {
                slot[c] = static_cast<int>(out.size());
                out.push_back(std::move(clusters[c]));
                continue;
            }
            LoopCluster& into = out[slot[root]];
            into.box.min = glm::min(into.box.min, clusters[c].box.min);
            into.box.max = glm::max(into.box.max, clusters[c].box.max);
            into.margin = std::max(into.margin, clusters[c].margin);
            into.loops.insert(into.loops.end(), clusters[c].loops.begin(), clusters[c].loops.end());
            into.labelled = false;
        }
        clusters = std::move(out);
    }
    return mergedAny;
}

// The loops of both planes (below first) in clusters, each with its initial margin: 2 pixels and
// 2 per voxel of the slab's thickness (a tube leaning out between the planes).
std::vector<LoopCluster> clusterLoops(const SlicePlan& plan, const PlaneLoops& below, const PlaneLoops& above)
{
    const std::int64_t margin = 2 + static_cast<std::int64_t>(std::ceil(2.0 * (above.w - below.w)));
    std::vector<LoopCluster> clusters;
    int index = 0;
    for (const PlaneLoops* plane : {&below, &above})
        for (const BoundaryLoop* loop : plane->loops) clusters.push_back({boxOf(*loop), margin, {index++}, false});
    mergeOverlapping(clusters, plan);
    return clusters;
}

} // namespace

PlaneLoops pastTheBox(const Volume& volume, const SlicePlan& plan, bool after)
{
    PlaneLoops empty;
    empty.w = after ? volume.bboxMax()[plan.axis] + 1.0 : volume.bboxMin()[plan.axis] - 1.0;
    return empty;
}

namespace {

// connectThroughSlab from the slab's labelled voxels alone, with no look for simple bands. With
// `hides`, also whether the slab holds a region no plane meets (hidesRegion) where it labels.
std::vector<SlabPiece> connectByLabels(const Volume& volume, const SlicePlan& plan, const PlaneLoops& below,
                                       const PlaneLoops& above, bool* hides = nullptr)
{
    std::vector<SlabPiece> pieces;
    if (below.loops.empty() && above.loops.empty()) return pieces;
    const SlabLayers layers(volume, plan, below.w, above.w);
    const int belowCount = static_cast<int>(below.loops.size());
    auto loopOf = [&](int index) -> const BoundaryLoop& {
        return index < belowCount ? *below.loops[index] : *above.loops[index - belowCount];
    };
    // A loop separates the inside and outside regions beside its first crack (in its cluster's
    // labels); loops separating the same two lie on one piece.
    struct Key {
        std::int32_t in = 0, out = 0;
    };
    std::vector<Key> keys(below.loops.size() + above.loops.size());
    std::vector<int> clusterOfLoop(keys.size(), -1);
    std::vector<LoopCluster> clusters = clusterLoops(plan, below, above);
    // A cluster whose box grew while labelling may now overlap another: merge and label again.
    do {
        for (LoopCluster& cluster : clusters) {
            if (cluster.labelled) continue;
            SlabLabels slab = labelSlab(layers, plan, cluster.box, cluster.margin);
            // A box holds every inside region it meets whole, and the voids inside them: what is
            // hidden in a smaller box stays hidden in the merged one.
            if (hides && !*hides) *hides = hidesRegion(slab);
            for (int index : cluster.loops) {
                const auto [in, out] = pixelsBeside(loopOf(index));
                const int layer = index < belowCount ? 0 : slab.depth - 1;
                keys[index] = {slab.labels.find(slab.id(layer, in)), slab.labels.find(slab.id(layer, out))};
            }
            cluster.labelled = true;
        }
    } while (mergeOverlapping(clusters, plan));
    for (std::size_t c = 0; c < clusters.size(); ++c)
        for (int index : clusters[c].loops) clusterOfLoop[index] = static_cast<int>(c);
    // Pieces in order of their first loop, below then above, as one box around all loops gives them.
    std::map<std::tuple<int, std::int32_t, std::int32_t>, std::size_t> pieceOf;
    for (int index = 0; index < static_cast<int>(keys.size()); ++index) {
        const auto [it, added] =
            pieceOf.insert({{clusterOfLoop[index], keys[index].in, keys[index].out}, pieces.size()});
        if (added) pieces.emplace_back();
        if (index < belowCount)
            pieces[it->second].below.push_back(index);
        else
            pieces[it->second].above.push_back(index - belowCount);
    }
    for (SlabPiece& piece : pieces) piece.kind = classify(piece, below, above);
    return pieces;
}

} // namespace

std::vector<SlabPiece> connectThroughSlab(const Volume& volume, const SlicePlan& plan, const PlaneLoops& below,
                                          const PlaneLoops& above)
{
    std::vector<SlabPiece> pieces;
    if (simpleBands(below, above, pieces)) return pieces;
    return connectByLabels(volume, plan, below, above);
}

namespace {

// A cube of the slab's cells: corner c is pixel offset (c & 1, (c >> 1) & 1) on layer offset c >> 2.
// Its faces, corners counterclockwise seen from outside: -w, +w, -u, +u, -v, +v.
constexpr int kCubeFaces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}};

glm::ivec2 pixelOffset(int corner)
{
    return {corner & 1, (corner >> 1) & 1};
}

// Marching cubes over the slab's labelled box, once for several pieces (patchPieces): each cycle
// of a cube goes to the piece whose regions it separates.
class PatchBuilder {
public:
    // `keys`: per piece, the inside and outside regions it separates.
    PatchBuilder(const SlabLayers& layers, SlabLabels& slab, int axis, const PlaneLoops* const planes[2],
                 const std::vector<const SlabPiece*>& pieces,
                 const std::vector<std::pair<std::int32_t, std::int32_t>>& keys)
        : mLayers(layers),
          mSlab(slab),
          mAxis(axis),
          mPlanes{planes[0], planes[1]},
          mPieces(pieces.size())
    {
        for (std::size_t p = 0; p < pieces.size(); ++p) {
            mPieceOf[keys[p]] = p;
            for (int side = 0; side < 2; ++side)
                for (int l : side == 0 ? pieces[p]->below : pieces[p]->above) {
                    const BoundaryLoop& loop = *planes[side]->loops[l];
                    const std::size_t n = loop.corners.size();
                    for (std::size_t k = 0; k < n; ++k) {
                        const auto [in, out] = crackPixels(loop.corners[k], loop.corners[(k + 1) % n]);
                        mCracks[{side, in.x, in.y, out.x, out.y}] = {p, l, static_cast<int>(k)};
                    }
                    mPieces[p].cracks += n;
                }
        }
    }

    // Per piece, its patch, or nothing where a cell's surface cannot be told to it (SlabPatch).
    std::vector<std::optional<SlabPatch>> build()
    {
        for (int l = 0; l + 1 < mSlab.depth; ++l)
            for (int y = 0; y + 1 < mSlab.height; ++y)
                for (int x = 0; x + 1 < mSlab.width; ++x) cube(l, mSlab.lo + glm::ivec2(x, y));
        std::vector<std::optional<SlabPatch>> patches;
        for (Piece& piece : mPieces)
            patches.push_back(!piece.failed && closes(piece) ? std::optional(std::move(piece.patch)) : std::nullopt);
        return patches;
    }

private:
    struct Piece {
        SlabPatch patch;
        std::map<std::int64_t, std::uint32_t> vertices; // per cube edge crossed
        std::size_t cracks = 0;                         // of its loops
        bool failed = false;
    };

    // The cube at layer l whose corner 0 is `pixel`: its cycles of isosurface points, each closed
    // by the segments on its faces, and each fanned into its piece's triangles.
    void cube(int l, const glm::ivec2& pixel)
    {
        bool in[8];
        int count = 0;
        for (int c = 0; c < 8; ++c) count += (in[c] = mSlab.insideAt(l + (c >> 2), pixel + pixelOffset(c))) ? 1 : 0;
        if (count == 0 || count == 8) return;
        // next[a * 8 + b]: the edge (as a corner pair) that follows edge (a, b) along its cycle.
        int next[64];
        std::fill(std::begin(next), std::end(next), -1);
        for (int f = 0; f < 6; ++f) faceSegments(l, pixel, f, in, next);
        bool done[64] = {};
        for (int start = 0; start < 64; ++start) {
            if (next[start] < 0 || done[start]) continue;
            std::vector<int> cycle;
            int e = start;
            for (; e >= 0 && !done[e]; e = next[e]) {
                done[e] = true;
                cycle.push_back(e);
            }
            // Faces turned alike always chain; were one not to, no piece here could be trusted.
            if (e != start) {
                for (Piece& piece : mPieces) piece.failed = true;
                return;
            }
            addCycle(l, pixel, in, cycle);
        }
    }

    // Face f's segments, from the edge where its counterclockwise walk leaves the inside to the one
    // where it enters it again, so each cycle runs around the inside corners it cuts off. A saddle
    // face's two segments cut off the pair its labelling keeps apart.
    void faceSegments(int l, const glm::ivec2& pixel, int f, const bool in[8], int next[64]) const
    {
        const int* q = kCubeFaces[f];
        auto undirected = [&](int i) {
            return std::min(q[i & 3], q[(i + 1) & 3]) * 8 + std::max(q[i & 3], q[(i + 1) & 3]);
        };
        auto link = [&](int from, int to) { next[undirected(from)] = undirected(to); };
        int crossings = 0;
        for (int i = 0; i < 4; ++i) crossings += in[q[i]] != in[q[(i + 1) & 3]] ? 1 : 0;
        if (crossings == 2) {
            int from = -1, to = -1;
            for (int i = 0; i < 4; ++i) {
                if (in[q[i]] && !in[q[(i + 1) & 3]]) from = i;
                if (!in[q[i]] && in[q[(i + 1) & 3]]) to = i;
            }
            link(from, to);
            return;
        }
        if (crossings != 4) return;
        const bool joined = insideJoined(l, pixel, f, in);
        for (int k = 0; k < 4; ++k) {
            if (in[q[k]] == joined) continue;
            // Cut off corner k: the walk leaves the inside on edge k - 1 and enters it on edge k
            // (an outside corner), or leaves it on edge k and enters on edge k - 1 (an inside one).
            if (joined)
                link(k + 3, k);
            else
                link(k, k + 3);
        }
    }

    // A saddle face: whether its inside pair is one region, as the slab's labelling decides.
    bool insideJoined(int l, const glm::ivec2& pixel, int f, const bool in[8]) const
    {
        if (f < 2) return mLayers.planes[l + f].saddleJoins(pixel + 1);
        // The lower layer's inside corner a and the upper layer's b, diagonal on the face; the
        // outside corners c (lower) and d (upper).
        const int* q = kCubeFaces[f];
        glm::ivec2 a(0), b(0), c(0), d(0);
        for (int i = 0; i < 4; ++i) {
            const glm::ivec2 p = pixel + pixelOffset(q[i]);
            if (in[q[i]])
                (q[i] < 4 ? a : b) = p;
            else
                (q[i] < 4 ? c : d) = p;
        }
        if (!mLayers.acrossVoxelPlanes(l)) {
            // No rule decides a saddle between a plane and a voxel plane, and the labelling keeps
            // both pairs apart. The surface must part one: the inside pair, unless only that pair
            // is one region already, so that it joins no two regions the labelling keeps apart (a
            // cycle that did could not be told to a piece).
            const auto label = [&](int plane, const glm::ivec2& p) {
                return mSlab.labels.find(mSlab.id(l + plane, p));
            };
            return label(0, a) == label(1, b) && label(0, c) != label(1, d);
        }
        const auto inside = [&](int plane, const glm::ivec2& p) { return mSlab.insideAt(l + plane, p); };
        return contactJoins(mLayers.levelSet, inside, a, b);
    }

    void addCycle(int l, const glm::ivec2& pixel, const bool in[8], const std::vector<int>& cycle)
    {
        // The regions the cycle separates: a piece's, or (a saddle between layers that no rule
        // decides) two outside regions, which fails the pieces of the inside one.
        std::int32_t inLabel = -1, outLabel = -1;
        std::vector<std::int32_t> insides;
        bool mixed = false;
        for (int e : cycle) {
            const int a = e / 8, b = e % 8, inner = in[a] ? a : b, outer = in[a] ? b : a;
            const std::int32_t i = mSlab.labels.find(mSlab.id(l + (inner >> 2), pixel + pixelOffset(inner)));
            const std::int32_t o = mSlab.labels.find(mSlab.id(l + (outer >> 2), pixel + pixelOffset(outer)));
            mixed = mixed || (inLabel >= 0 && (i != inLabel || o != outLabel));
            insides.push_back(i);
            inLabel = i;
            outLabel = o;
        }
        if (mixed) {
            for (const auto& [key, p] : mPieceOf)
                if (std::find(insides.begin(), insides.end(), key.first) != insides.end()) mPieces[p].failed = true;
            return;
        }
        const auto it = mPieceOf.find({inLabel, outLabel});
        if (it == mPieceOf.end() || mPieces[it->second].failed) return;
        Piece& piece = mPieces[it->second];
        std::vector<std::uint32_t> ids;
        for (int e : cycle) {
            const std::optional<std::uint32_t> id = vertexOn(piece, it->second, l, pixel, e / 8, e % 8, in);
            if (!id) {
                piece.failed = true;
                return;
            }
            ids.push_back(*id);
        }
        // The cycle runs around the inside: its fan faces it, so the triangles turn to face out.
        const std::optional<std::size_t> apex = fanApex(piece.patch, ids);
        if (apex) {
            std::rotate(ids.begin(), ids.begin() + static_cast<std::ptrdiff_t>(*apex), ids.end());
        } else {
            ids.insert(ids.begin(), static_cast<std::uint32_t>(piece.patch.vertices.size()));
            ids.push_back(ids[1]);
            piece.patch.vertices.push_back(centreOf(piece.patch, ids));
        }
        for (std::size_t k = 1; k + 1 < ids.size(); ++k) piece.patch.triangles.push_back({ids[0], ids[k + 1], ids[k]});
    }

    // Where a cycle's fan may start: a point with no other of its own plane beyond its two
    // neighbours (a point inside the slab has none). A fan draws a chord from its apex to each of
    // those, in the plane, with a triangle lying flat in it: the patch would meet its plane in
    // more than its loops' polygons, and a chord between two points of a loop can be an edge of
    // the other side's surface too (a keyhole's slit, flat in the single contour's plane: four
    // triangles on one edge in a crop of the smoke, ARandomCropOfTheSmokeIsAManifold). Nothing
    // where every point has such others (a cube between two planes whose faces in both are
    // saddles that only one joins): then no triangulation of the cycle alone avoids them.
    static std::optional<std::size_t> fanApex(const SlabPatch& patch, const std::vector<std::uint32_t>& ids)
    {
        const std::size_t n = ids.size();
        for (std::size_t a = 0; a < n; ++a) {
            const int plane = patch.vertices[ids[a]].plane;
            bool clear = true;
            for (std::size_t k = 2; plane >= 0 && clear && k + 1 < n; ++k)
                clear = patch.vertices[ids[(a + k) % n]].plane != plane;
            if (clear) return a;
        }
        return std::nullopt;
    }

    // A point inside the slab for a cycle to fan around: the mean of its points (`ids` from 1),
    // which lie on both sides of it along the axis, so it lies in neither plane.
    static SlabPatch::Vertex centreOf(const SlabPatch& patch, const std::vector<std::uint32_t>& ids)
    {
        SlabPatch::Vertex centre;
        for (std::size_t k = 1; k + 1 < ids.size(); ++k) centre.index += patch.vertices[ids[k]].index;
        centre.index /= static_cast<double>(ids.size() - 2);
        return centre;
    }

    // The piece's vertex on the cube edge between corners a and b (a < b): a loop's point where
    // the edge lies in one of the slab's two planes, else where the field along it is zero.
    std::optional<std::uint32_t> vertexOn(Piece& piece, std::size_t p, int l, const glm::ivec2& pixel, int a, int b,
                                          const bool in[8]) const
    {
        const int inner = in[a] ? a : b, outer = in[a] ? b : a;
        const int innerLayer = l + (inner >> 2), outerLayer = l + (outer >> 2);
        const glm::ivec2 innerPixel = pixel + pixelOffset(inner), outerPixel = pixel + pixelOffset(outer);
        const int axis = (b - a) == 4 ? 2 : (b - a) == 2 ? 1 : 0;
        const std::int64_t key = std::int64_t(mSlab.id(l + (a >> 2), pixel + pixelOffset(a))) * 3 + axis;
        const auto [at, added] = piece.vertices.insert({key, static_cast<std::uint32_t>(piece.patch.vertices.size())});
        if (!added) return at->second;
        SlabPatch::Vertex vertex;
        if (axis < 2 && (innerLayer == 0 || innerLayer == mSlab.depth - 1)) {
            const int side = innerLayer == 0 ? 0 : 1;
            const auto crack = mCracks.find({side, innerPixel.x, innerPixel.y, outerPixel.x, outerPixel.y});
            if (crack == mCracks.end() || std::get<0>(crack->second) != p) return std::nullopt; // no loop of the piece
            vertex.plane = side;
            vertex.loop = std::get<1>(crack->second);
            vertex.point = std::get<2>(crack->second);
            vertex.index =
                planeToIndex(mAxis, mPlanes[side]->loops[vertex.loop]->points[vertex.point], mLayers.w[innerLayer]);
        } else {
            // As the walk places its points (contour.cpp): linear between the two samples.
            const double fin = mLayers.planes[innerLayer].value(innerPixel.x, innerPixel.y);
            const double fout = mLayers.planes[outerLayer].value(outerPixel.x, outerPixel.y);
            const double s = fin < fout ? std::clamp(fin / (fin - fout), 0.0, 1.0) : 0.5;
            const glm::dvec2 uv = glm::dvec2(innerPixel) + s * glm::dvec2(outerPixel - innerPixel);
            const double w = mLayers.w[innerLayer] + s * (mLayers.w[outerLayer] - mLayers.w[innerLayer]);
            vertex.index = planeToIndex(mAxis, uv, w);
        }
        piece.patch.vertices.push_back(vertex);
        return at->second;
    }

    // Every edge in two triangles, once each way, but the loops' cracks, each in one: a surface
    // with the piece's loops, and nothing else, for boundary. Then its Euler characteristic.
    static bool closes(Piece& piece)
    {
        SlabPatch& patch = piece.patch;
        std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges; // directed
        for (const auto& t : patch.triangles)
            for (int k = 0; k < 3; ++k)
                if (++edges[{t[k], t[(k + 1) % 3]}] > 1) return false;
        std::size_t open = 0, undirected = 0;
        for (const auto& [edge, uses] : edges) {
            const bool twin = edges.count({edge.second, edge.first}) > 0;
            undirected += twin && edge.first > edge.second ? 0 : 1;
            if (twin) continue;
            const SlabPatch::Vertex &u = patch.vertices[edge.first], &v = patch.vertices[edge.second];
            if (u.plane < 0 || u.plane != v.plane || u.loop != v.loop) return false;
            ++open;
        }
        if (open != piece.cracks) return false;
        patch.euler = static_cast<int>(patch.vertices.size()) - static_cast<int>(undirected) +
                      static_cast<int>(patch.triangles.size());
        return true;
    }

    const SlabLayers& mLayers;
    SlabLabels& mSlab;
    int mAxis;
    const PlaneLoops* mPlanes[2];
    std::vector<Piece> mPieces;
    std::map<std::pair<std::int32_t, std::int32_t>, std::size_t> mPieceOf; // by inside and outside region
    // Per crack of the pieces' loops, by plane (0 below, 1 above), inside pixel and outside pixel:
    // (piece, loop, point).
    std::map<std::tuple<int, int, int, int, int>, std::tuple<std::size_t, int, int>> mCracks;
};

} // namespace

std::vector<std::optional<SlabPatch>> patchPieces(const Volume& volume, const SlicePlan& plan, const PlaneLoops& below,
                                                  const PlaneLoops& above, const std::vector<const SlabPiece*>& pieces)
{
    const PlaneLoops* const planes[2] = {&below, &above};
    std::optional<PixelBox> box;
    for (const SlabPiece* piece : pieces)
        for (int side = 0; side < 2; ++side)
            for (int l : side == 0 ? piece->below : piece->above) {
                const PixelBox b = boxOf(*planes[side]->loops[l]);
                box = box ? PixelBox{glm::min(box->min, b.min), glm::max(box->max, b.max)} : b;
            }
    if (!box) return std::vector<std::optional<SlabPatch>>(pieces.size());
    const SlabLayers layers(volume, plan, below.w, above.w);
    std::int64_t margin = 2 + static_cast<std::int64_t>(std::ceil(2.0 * (above.w - below.w))); // as clusterLoops
    SlabLabels slab = labelSlab(layers, plan, *box, margin);
    // The regions each piece separates, which every one of its loops must separate here too; a
    // piece whose loops part, or that shares its regions with another, gets no patch.
    std::vector<std::pair<std::int32_t, std::int32_t>> keys;
    std::vector<bool> agree;
    for (const SlabPiece* piece : pieces) {
        std::optional<std::pair<std::int32_t, std::int32_t>> key;
        bool same = true;
        for (int side = 0; side < 2; ++side)
            for (int l : side == 0 ? piece->below : piece->above) {
                const auto [in, out] = pixelsBeside(*planes[side]->loops[l]);
                const int layer = side == 0 ? 0 : slab.depth - 1;
                const std::pair regions{slab.labels.find(slab.id(layer, in)), slab.labels.find(slab.id(layer, out))};
                same = same && (!key || *key == regions);
                key = regions;
            }
        keys.push_back(key.value_or(std::pair{-1, -1}));
        agree.push_back(same && key.has_value());
    }
    for (std::size_t p = 0; p < keys.size(); ++p)
        if (std::count(keys.begin(), keys.end(), keys[p]) > 1) agree[p] = false;
    std::vector<std::optional<SlabPatch>> patches = PatchBuilder(layers, slab, plan.axis, planes, pieces, keys).build();
    for (std::size_t p = 0; p < patches.size(); ++p)
        if (!agree[p]) patches[p].reset();
    return patches;
}

double shapeChange(const PlaneLoops& below, int a, const PlaneLoops& above, int b)
{
    if (below.profiles.empty() || above.profiles.empty()) return 0.0;
    return profileChange(*below.profiles[a], *above.profiles[b]);
}

long long EulerProfile::total() const
{
    return std::accumulate(layers.begin(), layers.end(), 0LL);
}

long long EulerProfile::between(double wBelow, double wAbove) const
{
    // Layer k's origin is first + k: the layers from ceil(wBelow - first) to before
    // ceil(wAbove - first), within the profile.
    const double size = static_cast<double>(layers.size());
    const auto index = [&](double w) { return static_cast<std::size_t>(std::clamp(std::ceil(w - first), 0.0, size)); };
    const std::size_t from = index(wBelow), to = index(wAbove);
    return from < to ? std::accumulate(layers.begin() + from, layers.begin() + to, 0LL) : 0LL;
}

bool EulerProfile::loneOn(double w) const
{
    const double k = w - first;
    return k >= 0.0 && k < static_cast<double>(lone.size()) && k == std::floor(k) &&
           lone[static_cast<std::size_t>(k)] > 0;
}

namespace {

int eulerOf(const std::vector<SlabPiece>& pieces)
{
    int sum = 0;
    for (const SlabPiece& p : pieces) sum += p.euler();
    return sum;
}

bool bandsOnly(const std::vector<SlabPiece>& pieces)
{
    return std::all_of(pieces.begin(), pieces.end(), [](const SlabPiece& p) { return p.kind == EventKind::Band; });
}

// How the pieces of `slabs` (in order of w) join loops: the group of each loop of the first and
// the last plane (groups numbered in order of first appearance, bottom loops first), and how many
// groups there are in all (a loop between them may join neither end: a component of its own).
struct LoopGroups {
    std::vector<int> ends;
    std::size_t count = 0;
    // Whether these join the end loops as `before` did, parting no component of it (a speck
    // between the planes can be one of their own).
    bool joinAs(const LoopGroups& before) const { return ends == before.ends && count >= before.count; }
};

LoopGroups loopGroups(const std::vector<ContourGraph::Slab>& slabs, const std::vector<PlaneLoops>& planes)
{
    std::map<std::pair<int, int>, std::int32_t> node; // (plane, loop)
    const auto id = [&](int plane, int loop) {
        return node.emplace(std::make_pair(plane, loop), static_cast<std::int32_t>(node.size())).first->second;
    };
    std::vector<int> stack{slabs.front().below};
    for (const ContourGraph::Slab& slab : slabs) stack.push_back(slab.above);
    for (int plane : stack)
        for (std::size_t l = 0; l < planes[plane].loops.size(); ++l) id(plane, static_cast<int>(l));
    Labels labels(node.size());
    for (const ContourGraph::Slab& slab : slabs)
        for (const SlabPiece& p : slab.pieces) {
            const std::int32_t first = p.below.empty() ? id(slab.above, p.above[0]) : id(slab.below, p.below[0]);
            for (int l : p.below) labels.join(first, id(slab.below, l));
            for (int l : p.above) labels.join(first, id(slab.above, l));
        }
    LoopGroups groups;
    std::map<std::int32_t, int> number;
    for (int plane : {stack.front(), stack.back()})
        for (std::size_t l = 0; l < planes[plane].loops.size(); ++l) {
            const std::int32_t root = labels.find(node.at({plane, static_cast<int>(l)}));
            groups.ends.push_back(number.emplace(root, static_cast<int>(number.size())).first->second);
        }
    for (const auto& [key, n] : node) number.emplace(labels.find(n), static_cast<int>(number.size()));
    groups.count = number.size();
    return groups;
}

// The runs of slabs (in order of w) from one voxel plane to the next, as [first, end) into
// `slabs`: the cells part the isosurface at voxel planes only, so their count is compared there.
// Slabs after a plane between voxel planes, up to the next voxel plane, are in no run.
std::vector<std::pair<std::size_t, std::size_t>> voxelLayerRuns(const std::vector<ContourGraph::Slab>& slabs,
                                                                const std::vector<PlaneLoops>& planes)
{
    std::vector<std::pair<std::size_t, std::size_t>> runs;
    std::size_t first = 0;
    for (std::size_t s = 0; s < slabs.size(); ++s) {
        const double below = planes[slabs[first].below].w, above = planes[slabs[s].above].w;
        if (above != std::floor(above)) continue;
        if (below == std::floor(below)) runs.emplace_back(first, s + 1);
        first = s + 1;
    }
    return runs;
}

// The pieces' Euler characteristics summed over slabs [first, end).
long long eulerOf(const std::vector<ContourGraph::Slab>& slabs, std::size_t first, std::size_t end)
{
    long long euler = 0;
    for (std::size_t k = first; k < end; ++k) euler += eulerOf(slabs[k].pieces);
    return euler;
}

// The stages of buildContourGraph: each slab halved while its events need it (refine), then the
// ranges between voxel planes whose pieces do not add up to the cells' cut again (matchCells).
class GraphBuilder {
public:
    GraphBuilder(const Volume& volume, const SlicePlan& plan, std::vector<PlaneLoops>& planes, double minThickness,
                 double maxShapeChange, const std::function<int(double w)>& addPlane,
                 const std::function<void()>& dropLastPlane,
                 const std::vector<std::pair<double, double>>& thinJunctions)
        : mVolume(volume),
          mPlan(plan),
          mPlanes(planes),
          mMinThickness(minThickness),
          mMaxShapeChange(maxShapeChange),
          mAddPlane(addPlane),
          mDropLastPlane(dropLastPlane),
          mThinJunctions(thinJunctions)
    {
    }

    std::vector<SlabPiece> connect(int below, int above) const
    {
        return connectThroughSlab(mVolume, mPlan, mPlanes[below], mPlanes[above]);
    }

    // The slab's pieces from its labelled voxels, even where it looks like simple bands; with
    // `hides`, whether a speck or void lies wholly between its planes (hidesRegion).
    std::vector<SlabPiece> label(int below, int above, bool* hides = nullptr) const
    {
        return connectByLabels(mVolume, mPlan, mPlanes[below], mPlanes[above], hides);
    }

    // Halves the slab while it is thicker than its pieces need; appends the slabs to `out` in
    // order of w.
    void refine(int below, int above, std::vector<SlabPiece> pieces, std::vector<ContourGraph::Slab>& out) const;

    // `slabs` (in order of w) with each range between two voxel planes whose pieces do not add up
    // to `cells` cut again where that makes them; the number of such ranges in `matches`.
    std::vector<ContourGraph::Slab> matchCells(std::vector<ContourGraph::Slab> slabs, const EulerProfile& cells,
                                               int& matches) const;

private:
    double thickness(int below, int above, const std::vector<SlabPiece>& pieces) const;
    bool cutRange(const std::vector<ContourGraph::Slab>& range, long long target, const EulerProfile& cells,
                  std::vector<ContourGraph::Slab>& out) const;

    const Volume& mVolume;
    const SlicePlan& mPlan;
    std::vector<PlaneLoops>& mPlanes;
    double mMinThickness, mMaxShapeChange;
    const std::function<int(double w)>& mAddPlane;
    const std::function<void()>& mDropLastPlane;
    const std::vector<std::pair<double, double>>& mThinJunctions;
};

// How thin the slab must get: an unresolved piece (two saddles in one slab, say) is halved down
// to an eighth of minThickness, where events at different heights fall apart; a wall ending with
// several holes, or a band changing shape fast, to a quarter; a fork or merge down to
// minThickness, or an eighth of it within the ranges of thinJunctions (forks and merges whose
// parts strayed in a first build and whose cells do not close); a wall ending with its one hole
// to a voxel; anything else is left as it is (0).
double GraphBuilder::thickness(int below, int above, const std::vector<SlabPiece>& pieces) const
{
    // A wall and its hole that end together across voxel planes may not end as a rim: the hole
    // can close a voxel before the wall (a cup whose cavity meets the outside at one saddle of
    // the cells only: the smoke at iso 0.1 along z, spaced 2 voxels, had its annulus flat at the
    // cavity's mouth, 1.53 voxels above the cup's bottom). A voxel plane between shows that end
    // (a start, then a fork: 0.86), and a true rim ends as it did, a voxel nearer its ridge (at
    // the top level, the hollow tube along z 0.30 voxel off before, 0.25 now; the torus lying
    // flat 0.25, 0.24; the torus standing, along x, 0.39, 0.30).
    constexpr double kRimSlab = 1.0;
    const double wBelow = mPlanes[below].w, wAbove = mPlanes[above].w;
    const bool thin = overlapsAny(mThinJunctions, wBelow, wAbove);
    const double junction = thin ? mMinThickness / 8.0 : mMinThickness;
    double target = 0.0;
    for (const SlabPiece& p : pieces) {
        if (p.kind == EventKind::Unresolved) return mMinThickness / 8.0;
        // A face with several holes is flat: it must lie where the wall ends.
        if (p.kind == EventKind::Rim && p.below.size() + p.above.size() > 2) target = mMinThickness / 4.0;
        if (p.kind == EventKind::Rim) target = target == 0.0 ? kRimSlab : std::min(target, kRimSlab);
        if (p.kind == EventKind::Fork || p.kind == EventKind::Merge)
            target = target == 0.0 ? junction : std::min(target, junction);
        // A band's change halves with its slab where the shape changes smoothly; where it does
        // not (the horns of a crescent running along a pipe's open rim), it takes planes closer
        // than minThickness.
        if (p.kind == EventKind::Band &&
            shapeChange(mPlanes[below], p.below[0], mPlanes[above], p.above[0]) > mMaxShapeChange)
            target = target == 0.0 ? mMinThickness / 4.0 : std::min(target, mMinThickness / 4.0);
    }
    return target;
}

void GraphBuilder::refine(int below, int above, std::vector<SlabPiece> pieces,
                          std::vector<ContourGraph::Slab>& out) const
{
    const double wBelow = mPlanes[below].w, wAbove = mPlanes[above].w;
    const double needed = thickness(below, above, pieces);
    if (needed == 0.0 || wAbove - wBelow <= needed) {
        out.push_back({below, above, std::move(pieces)});
        return;
    }
    const int middle = mAddPlane(0.5 * (wBelow + wAbove));
    std::vector<SlabPiece> lower = connect(below, middle);
    std::vector<SlabPiece> upper = connect(middle, above);
    // Below minThickness a slab of bands is halved for its shape alone, and a plane added for
    // shape must not change what the slab's own planes decided: a neck that pinches for an
    // instant between voxel planes (a random capsule tree: a fork and a merge a quarter voxel
    // apart, a handle the isosurface does not have) keeps the slab whole.
    // Nor may a plane between voxel planes: the slab's labelling saw the voxel planes around
    // it, and an interpolated plane can miss what joins them (a contact its image shows no
    // bridge for), or join what the cells keep apart (a crop of the smoke: a speck of one pixel
    // meets a body at a saddle that volumeToMesh leaves open, and the field half a voxel on joins
    // them). Its pieces' Euler characteristics must add up to the slab's, and it must join the
    // slab's loops as the slab does (it may find a component of its own between them).
    const double wMiddle = mPlanes[middle].w;
    const bool betweenVoxelPlanes = wMiddle != std::floor(wMiddle);
    const auto joinsAsTheSlab = [&] {
        return loopGroups({{below, middle, lower}, {middle, above, upper}}, mPlanes)
            .joinAs(loopGroups({{below, above, pieces}}, mPlanes));
    };
    if ((betweenVoxelPlanes && (eulerOf(lower) + eulerOf(upper) != eulerOf(pieces) || !joinsAsTheSlab())) ||
        (wAbove - wBelow <= mMinThickness && bandsOnly(pieces) && !(bandsOnly(lower) && bandsOnly(upper)))) {
        mDropLastPlane();
        out.push_back({below, above, std::move(pieces)});
        return;
    }
    refine(below, middle, std::move(lower), out);
    refine(middle, above, std::move(upper), out);
}

// Cuts the range (slabs between two voxel planes, in order) by planes every half, quarter, ...
// of its thickness, keeping the planes it has, until its pieces add up to `target` and join the
// loops of its two ends as the range did, joining no two components (a cut may find a handle, or a
// component of its own between the voxel planes, a speck the slices missed; it may never part a
// tube the voxel planes' labelling joined, nor join two it kept apart), and on while they still do,
// down to a quarter of minThickness (as a fork's slab is halved: the finest cut places its saddles
// nearest the surface's); then refines each slab of the finest such cut into `out`. False, with every
// plane it added dropped again, if no cut matches by an eighth of minThickness, or once a cut
// joins the loops otherwise (finer ones would not undo it).
bool GraphBuilder::cutRange(const std::vector<ContourGraph::Slab>& range, long long target, const EulerProfile& cells,
                            std::vector<ContourGraph::Slab>& out) const
{
    std::map<double, int> stack; // plane index by w
    stack.emplace(mPlanes[range.front().below].w, range.front().below);
    for (const ContourGraph::Slab& slab : range) stack.emplace(mPlanes[slab.above].w, slab.above);
    const double wBelow = stack.begin()->first, wAbove = stack.rbegin()->first;
    const LoopGroups groups = loopGroups(range, mPlanes);
    const long long uncut = eulerOf(range, 0, range.size()); // the range's pieces' count as it came
    std::vector<ContourGraph::Slab> matched;
    int added = 0, addedWhenMatched = 0;
    for (double step = 0.5 * (wAbove - wBelow); step >= mMinThickness / 8.0; step *= 0.5) {
        if (!matched.empty() && step < mMinThickness / 4.0) break;
        std::map<double, int> finer = stack;
        for (double w = wBelow + step; w < wAbove; w += 2.0 * step) {
            if (finer.count(w) != 0) continue;
            finer.emplace(w, mAddPlane(w));
            ++added;
        }
        std::vector<ContourGraph::Slab> cut;
        long long euler = 0;
        for (auto it = finer.begin(); std::next(it) != finer.end(); ++it) {
            cut.push_back({it->second, std::next(it)->second, label(it->second, std::next(it)->second)});
            euler += eulerOf(cut.back().pieces);
        }
        const bool joinsAsBefore = loopGroups(cut, mPlanes).joinAs(groups);
        // A range whose pieces counted fewer than the cells (something no plane met), cut at
        // every voxel plane inside it into layers whose pieces count no fewer than the cells' (so
        // only handles inside a voxel layer are left, where the field is linear along w and no
        // labels show them), is as good as matched: the pieces whose patches find those handles
        // take them (Reconstruction, missed handles). A crop of the smoke: cut at x = 36, a range
        // found two specks, +4 where the cells count +2, and a handle inside the layer 35 to 36.
        bool handlesOnly = uncut < target && euler > target && step <= 1.0;
        for (const auto& [first, end] : voxelLayerRuns(cut, mPlanes))
            handlesOnly = handlesOnly && eulerOf(cut, first, end) >=
                                             cells.between(mPlanes[cut[first].below].w, mPlanes[cut[end - 1].above].w);
        if ((euler == target || handlesOnly) && joinsAsBefore) {
            matched = std::move(cut);
            addedWhenMatched = added;
        } else if (!matched.empty() || !joinsAsBefore) {
            // Finer planes between the same voxel planes see more of the interpolated field's
            // contacts, not fewer: a cut that joins loops differently stays wrong (the smoke).
            break;
        }
        stack = std::move(finer);
    }
    // Planes are appended, so the last ones added are this range's.
    for (; added > addedWhenMatched; --added) mDropLastPlane();
    for (ContourGraph::Slab& slab : matched) refine(slab.below, slab.above, std::move(slab.pieces), out);
    return !matched.empty();
}

std::vector<ContourGraph::Slab> GraphBuilder::matchCells(std::vector<ContourGraph::Slab> slabs,
                                                         const EulerProfile& cells, int& matches) const
{
    // The ranges between voxel planes (the cells part the isosurface there only), each with how
    // far its pieces fall short of the cells', and whether a speck or void lies wholly between
    // its planes where they agree: the counts can agree by chance (a crop of the smoke: a void of
    // two voxels and a handle in one slab two voxels thick, a component short with no warning).
    struct Range {
        std::size_t first, end;
        long long target, difference;
        std::vector<std::vector<SlabPiece>> labelled; // per slab, where it hides a region
    };
    std::vector<Range> ranges;
    for (const auto& [first, end] : voxelLayerRuns(slabs, mPlanes)) {
        const double wBelow = mPlanes[slabs[first].below].w, w = mPlanes[slabs[end - 1].above].w;
        const long long euler = eulerOf(slabs, first, end), target = cells.between(wBelow, w);
        // Two voxel planes apart, only lone voxels on the plane between can hide something;
        // farther apart, a speck may span planes (--spacing over 2), and the slabs are labelled.
        std::vector<std::vector<SlabPiece>> labelled;
        bool hides = false;
        if (target == euler && (w - wBelow > 2.0 || (w - wBelow == 2.0 && cells.loneOn(wBelow + 1.0))))
            for (std::size_t k = first; k < end; ++k)
                labelled.push_back(label(slabs[k].below, slabs[k].above, hides ? nullptr : &hides));
        if (!hides) labelled.clear();
        ranges.push_back({first, end, target, target - euler, std::move(labelled)});
    }
    std::vector<ContourGraph::Slab> out;
    std::size_t copied = 0;
    // Even a range whose difference the next one undoes: that may be one critical point the two
    // place on either side of a voxel plane, or two of their own (a crop of the smoke: a speck
    // that no plane meets between z = 61 and 63, next to a handle the slabs miss between 60 and
    // 61, one component short), and a cut tells them apart, as it must match the cells.
    for (Range& range : ranges) {
        const bool hides = !range.labelled.empty();
        if (range.difference == 0 && !hides) continue;
        std::move(slabs.begin() + copied, slabs.begin() + range.first, std::back_inserter(out));
        copied = range.first;
        // Where the cells disagree, the range's slabs are labelled first: simpleBands pairs loops
        // by overlap, and a loop that ends inside a slab two voxels thick beside one that starts
        // there passes for a band (a crop of the smoke: a handle more, a component fewer).
        std::vector<ContourGraph::Slab> labelled(slabs.begin() + range.first, slabs.begin() + range.end);
        for (std::size_t k = 0; k < labelled.size(); ++k)
            labelled[k].pieces = hides ? std::move(range.labelled[k]) : label(labelled[k].below, labelled[k].above);
        if (eulerOf(labelled, 0, labelled.size()) == range.target && !hides) {
            for (ContourGraph::Slab& slab : labelled) refine(slab.below, slab.above, std::move(slab.pieces), out);
        } else if (!cutRange(labelled, range.target, cells, out)) {
            std::move(labelled.begin(), labelled.end(), slabs.begin() + static_cast<std::ptrdiff_t>(range.first));
            continue;
        }
        copied = range.end;
        ++matches;
    }
    std::move(slabs.begin() + copied, slabs.end(), std::back_inserter(out));
    return out;
}

} // namespace

ContourGraph buildContourGraph(const Volume& volume, const SlicePlan& plan, std::vector<PlaneLoops>& planes,
                               double minThickness, double maxShapeChange, const std::function<int(double w)>& addPlane,
                               const std::function<void()>& dropLastPlane, const std::function<EulerProfile()>& cells,
                               const std::vector<std::pair<double, double>>& thinJunctions)
{
    ContourGraph graph;
    const int original = static_cast<int>(planes.size());
    const GraphBuilder builder(volume, plan, planes, minThickness, maxShapeChange, addPlane, dropLastPlane,
                               thinJunctions);
    for (int k = 0; k + 1 < original; ++k) builder.refine(k, k + 1, builder.connect(k, k + 1), graph.slabs);
    // Past the first and the last plane (added planes all lie between), out to empty space.
    int last = original - 1;
    const auto past = [&](int plane, bool after) {
        const PlaneLoops empty = pastTheBox(volume, plan, after);
        const PlaneLoops& loops = planes[static_cast<std::size_t>(plane)];
        if (loops.loops.empty()) return std::vector<SlabPiece>{};
        return after ? connectThroughSlab(volume, plan, loops, empty) : connectThroughSlab(volume, plan, empty, loops);
    };
    if (original > 0) {
        graph.beforeFirst = past(0, false);
        graph.afterLast = past(last, true);
    }
    // The cells are compared where the graph holds a junction, or where the surface starts more
    // than once (several objects, or specks beside one) or a speck or void could lie between two
    // planes (a region on either side of the isovalue that no plane meets, regionBetweenPlanes: a
    // speck there is a start and an end no plane shows; a crop of the smoke, one tube and a speck
    // between x = 57 and 59, a component short), and the planes cover the box (the profile holds
    // every voxel layer of it: spheres 2e9 voxels apart would need 48 GB); a single smooth tube
    // would pay most of its time for them.
    const double layers = static_cast<double>(volume.bboxMax()[plan.axis]) - volume.bboxMin()[plan.axis] + 1.0;
    const bool covered = layers <= 64.0 * original;
    long long starts = static_cast<long long>(graph.beforeFirst.size());
    bool junctions = false;
    for (const ContourGraph::Slab& slab : graph.slabs)
        for (const SlabPiece& p : slab.pieces) {
            starts += p.kind == EventKind::Start ? 1 : 0;
            junctions =
                junctions || (p.kind != EventKind::Band && p.kind != EventKind::Start && p.kind != EventKind::End);
        }
    if (cells && (junctions || (covered && (starts > 1 || regionBetweenPlanes(volume, plan.axis, plan.positions))))) {
        const EulerProfile profile = cells();
        // Where the spacing stops short of the box's end, the voxel layers past the last plane can
        // hold what no plane meets (specks: five in a crop of the smoke), and the cells count it
        // there. The box's last voxel plane meets every such speck (each holds an inside voxel),
        // and the slab up to it is compared with the cells like any other. It is added even where
        // the counts agree past the last plane: a speck there can hide behind a handle that the
        // pieces out to empty space miss (another crop: a component short, with no warning).
        const double wLast = original > 0 ? planes[static_cast<std::size_t>(last)].w : 0.0;
        const double wEnd = volume.bboxMax()[plan.axis];
        if (original > 0 && wEnd > wLast && wLast == std::floor(wLast)) {
            const int end = addPlane(wEnd);
            builder.refine(last, end, builder.connect(last, end), graph.slabs);
            last = end;
            graph.afterLast = past(last, true);
        }
        graph.slabs = builder.matchCells(std::move(graph.slabs), profile, graph.cellMatches);
    }
    graph.addedPlanes = static_cast<int>(planes.size()) - original;
    graph.order.push_back(0);
    for (const ContourGraph::Slab& slab : graph.slabs) graph.order.push_back(slab.above);
    if (original == 0) graph.order.clear();
    return graph;
}

namespace {

// How many pixels of the segment from `from` to `to` `blocked` holds, sampled every quarter pixel.
double blockedStretch(const glm::dvec2& from, const glm::dvec2& to,
                      const std::function<bool(const glm::dvec2&)>& blocked)
{
    constexpr double kStep = 0.25;
    const int samples = static_cast<int>(std::ceil(glm::distance(from, to) / kStep));
    double stretch = 0.0;
    for (int s = 0; s <= samples; ++s)
        if (blocked(glm::mix(from, to, samples > 0 ? static_cast<double>(s) / samples : 0.0))) stretch += kStep;
    return stretch;
}

// A hole too small for every partner to be nearest some of it (a pixel-wide gap where two walls
// are about to part): each cut of the hole is its point nearest the wall's cut, if they come in
// the same order around, and (with `blocked`) if the chords between them cross at most a pixel
// that the partners' plane still holds. A hole that opens into one partner's side, far from the
// neck, is no such gap: chords from the neck ran 7 pixels over that partner's material (a crop of
// the smoke, 2.3 voxels from the isosurface), where a keyhole on that side cuts the ring open.
bool cutsNearest(const std::vector<glm::dvec2>& single, const std::vector<glm::dvec2>& inner,
                 const std::vector<OwnerRun>& runs, const std::function<bool(const glm::dvec2&)>& blocked,
                 JunctionArcs& arcs)
{
    std::vector<int> innerCuts;
    for (const OwnerRun& run : runs) {
        int nearest = 0;
        for (std::size_t i = 1; i < inner.size(); ++i)
            if (glm::distance(inner[i], single[run.start]) < glm::distance(inner[nearest], single[run.start]))
                nearest = static_cast<int>(i);
        if (blocked && blockedStretch(single[run.start], inner[nearest], blocked) > 1.0) return false;
        innerCuts.push_back(nearest);
    }
    int descents = 0;
    for (std::size_t k = 0; k < innerCuts.size(); ++k) {
        const int next = innerCuts[(k + 1) % innerCuts.size()];
        if (next == innerCuts[k]) return false;
        descents += next < innerCuts[k] ? 1 : 0;
    }
    if (descents != 1) return false;
    for (std::size_t k = 0; k < runs.size(); ++k) {
        arcs.cuts.push_back(runs[k].start);
        arcs.owner.push_back(runs[k].owner);
        arcs.innerCuts.push_back(innerCuts[k]);
    }
    arcs.hubbed = false;
    return true;
}

} // namespace

bool splitIntoArcs(const std::vector<glm::dvec2>& single, const std::vector<glm::dvec2>* inner,
                   const std::vector<const std::vector<glm::dvec2>*>& partners, JunctionArcs& arcs,
                   const std::function<bool(const glm::dvec2&)>& blocked)
{
    const int n = static_cast<int>(partners.size());
    std::vector<OwnerRun> runs = ownerRuns(single, partners);
    auto arcsPerOwner = [&](const std::vector<OwnerRun>& r) {
        std::vector<int> count(n, 0);
        for (const OwnerRun& run : r) ++count[run.owner];
        return count;
    };
    auto onePerOwner = [&](const std::vector<OwnerRun>& r) {
        const std::vector<int> count = arcsPerOwner(r);
        return std::count(count.begin(), count.end(), 1) == n;
    };
    if (inner) {
        // A wall and its hole against several walls (a ring breaking open in several places at
        // once, or arcs closing into a ring): each partner owns one arc of each, in the same
        // order around; sector k is the wall's arc k, a chord to the hole, the hole's arc k
        // backward (the ring on its left) and a chord back.
        std::vector<OwnerRun> innerRuns = ownerRuns(*inner, partners);
        mergeShortestRuns(runs, onePerOwner);
        mergeShortestRuns(innerRuns, onePerOwner);
        if (!onePerOwner(runs)) return false;
        for (std::vector<OwnerRun>* r : {&runs, &innerRuns})
            std::sort(r->begin(), r->end(), [](const OwnerRun& x, const OwnerRun& y) { return x.start < y.start; });
        if (!onePerOwner(innerRuns)) return cutsNearest(single, *inner, runs, blocked, arcs);
        const std::size_t shift =
            static_cast<std::size_t>(std::find_if(innerRuns.begin(), innerRuns.end(),
                                                  [&](const OwnerRun& r) { return r.owner == runs[0].owner; }) -
                                     innerRuns.begin());
        for (std::size_t k = 0; k < runs.size(); ++k)
            if (innerRuns[(k + shift) % innerRuns.size()].owner != runs[k].owner) return false; // not in the same order
        for (std::size_t k = 0; k < runs.size(); ++k) {
            arcs.cuts.push_back(runs[k].start);
            arcs.owner.push_back(runs[k].owner);
            arcs.innerCuts.push_back(innerRuns[(k + shift) % innerRuns.size()].start);
        }
        arcs.hubbed = false;
        return true;
    }
    // Two ways to close the arcs, both with every partner owning arcs: each partner one arc (a
    // fork: the arcs' chords meet at a hub), or one partner several, each of the others one (a C
    // with gaps against a wall and the holes it will enclose, or lobes budding from a body at
    // several necks: each other arc's chord closes it, and the several's arcs join into one loop
    // across those chords). Specks budding from a body at two necks, made one arc each, gave one
    // speck a stretch of the body's boundary, and its band crossed the body (the smoke: 1.8
    // voxels inside).
    // A third way: specks budding from the bodies beside the neck (the smoke: a merge of two
    // bodies, each with a speck on its side, gave one body's part a stretch of the other's
    // boundary, 1.6 voxels off). Each bud closes by its own chord, and the bodies' arcs, joined
    // across them, meet at the hub.
    auto withBuds = [&](const std::vector<OwnerRun>& r) {
        const std::vector<int> count = arcsPerOwner(r);
        const std::vector<int> bodies = bodiesBesideBuds(r, count);
        std::vector<int> seen(n, 0);
        for (int owner : bodies) ++seen[owner];
        return bodies.size() >= 2 && std::all_of(seen.begin(), seen.end(), [](int k) { return k <= 1; }) &&
               std::all_of(count.begin(), count.end(), [](int k) { return k >= 1; });
    };
    auto oneOwnsSeveral = [&](const std::vector<OwnerRun>& r) {
        const std::vector<int> count = arcsPerOwner(r);
        const int several = static_cast<int>(std::max_element(count.begin(), count.end()) - count.begin());
        return count[several] >= 2 && std::count(count.begin(), count.end(), 1) == n - 1;
    };
    auto valid = [&](const std::vector<OwnerRun>& r) { return onePerOwner(r) || oneOwnsSeveral(r) || withBuds(r); };
    mergeShortestRuns(runs, valid);
    if (runs.empty() || !valid(runs)) return false;
    std::sort(runs.begin(), runs.end(), [](const OwnerRun& a, const OwnerRun& b) { return a.start < b.start; });
    arcs.hubbed = onePerOwner(runs) || !oneOwnsSeveral(runs);
    const std::vector<int> count = arcsPerOwner(runs);
    for (std::size_t k = 0; k < runs.size(); ++k) {
        arcs.cuts.push_back(runs[k].start);
        arcs.owner.push_back(runs[k].owner);
        if (arcs.hubbed && isBud(runs, count, k)) arcs.buds.push_back(static_cast<int>(k));
    }
    return true;
}

std::pair<int, int> Keyhole::at(int q) const
{
    if (q < wallSize) return {0, (wall + q) % wallSize};
    return {1, ((hole - (q - wallSize)) % holeSize + holeSize) % holeSize};
}

std::vector<glm::dvec2> keyholePolygon(const std::vector<glm::dvec2>& wall, const std::vector<glm::dvec2>& hole,
                                       const Keyhole& keyhole)
{
    std::vector<glm::dvec2> polygon;
    polygon.reserve(static_cast<std::size_t>(keyhole.size()));
    for (int q = 0; q < keyhole.size(); ++q) {
        const auto [member, point] = keyhole.at(q);
        polygon.push_back((member == 0 ? wall : hole)[static_cast<std::size_t>(point)]);
    }
    return polygon;
}

namespace {

double cross(const glm::dvec2& a, const glm::dvec2& b)
{
    return a.x * b.y - a.y * b.x;
}

// Whether segments ab and cd cross at a point inside both (touching at an end is no crossing).
bool segmentsCross(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c, const glm::dvec2& d)
{
    const double abc = cross(b - a, c - a), abd = cross(b - a, d - a);
    const double cda = cross(d - c, a - c), cdb = cross(d - c, b - c);
    return ((abc > 0.0 && abd < 0.0) || (abc < 0.0 && abd > 0.0)) &&
           ((cda > 0.0 && cdb < 0.0) || (cda < 0.0 && cdb > 0.0));
}

bool crossesPolygon(const glm::dvec2& a, const glm::dvec2& b, const std::vector<glm::dvec2>& polygon)
{
    for (std::size_t i = 0; i < polygon.size(); ++i)
        if (segmentsCross(a, b, polygon[i], polygon[(i + 1) % polygon.size()])) return true;
    return false;
}

} // namespace

bool chooseKeyhole(const std::vector<glm::dvec2>& wall, const std::vector<glm::dvec2>& hole,
                   const std::function<bool(const glm::dvec2&)>& blocked, Keyhole& keyhole, const Keyhole* apart)
{
    keyhole = Keyhole{};
    const int walls = static_cast<int>(wall.size()), holes = static_cast<int>(hole.size());
    if (walls < 3 || holes < 3) return false;
    // Slits by the length of their middle line, from the wall segment's middle to the hole's, up
    // to twice the shortest and 4 pixels: a gap that closes lies near the hole (seed 11 of the
    // crossing trees took 9 pixels where the ring is 6 thick), and longer slits cost time alone.
    struct Slit {
        double length;
        int wall, hole;
    };
    auto middleLength = [&](int p, int h) {
        return glm::distance(0.5 * (wall[(p + walls - 1) % walls] + wall[p]), 0.5 * (hole[h] + hole[(h + 1) % holes]));
    };
    std::vector<Slit> slits;
    slits.reserve(static_cast<std::size_t>(walls) * holes);
    for (int p = 0; p < walls; ++p)
        for (int h = 0; h < holes; ++h) slits.push_back({middleLength(p, h), p, h});
    std::sort(slits.begin(), slits.end(), [](const Slit& a, const Slit& b) {
        return std::tie(a.length, a.wall, a.hole) < std::tie(b.length, b.wall, b.hole);
    });
    // Two slits of one ring, one tiled flat from below and one from above, must share no point:
    // on one spot, their faces lay on each other (a crop of the smoke: a ring merged into and
    // forked out of, 4 and 8 edges of four triangles at the finer levels). Their segments lie a
    // point apart at least on both polygons, and their crossings do not cross.
    const auto clearOfApart = [&](int p, int h) {
        if (!apart || !apart->open() || apart->wallSize != walls || apart->holeSize != holes) return true;
        const auto near = [](int a, int b, int n) { return std::min((a - b + n) % n, (b - a + n) % n) <= 1; };
        if (near(p, apart->wall, walls) || near(h, apart->hole, holes)) return false;
        const glm::dvec2 &w0 = wall[(p + walls - 1) % walls], &w1 = wall[p], &h0 = hole[h], &h1 = hole[(h + 1) % holes];
        const glm::dvec2 &v0 = wall[(apart->wall + walls - 1) % walls], &v1 = wall[apart->wall];
        const glm::dvec2 &g0 = hole[apart->hole], &g1 = hole[(apart->hole + 1) % holes];
        for (const auto& [a, b] : {std::pair{w0, h0}, std::pair{w1, h1}})
            if (segmentsCross(a, b, v0, g0) || segmentsCross(a, b, v1, g1)) return false;
        return true;
    };
    const double longest = 2.0 * slits.front().length + 4.0;
    double bestBlocked = std::numeric_limits<double>::infinity();
    for (const Slit& slit : slits) {
        if (bestBlocked == 0.0 || slit.length > longest) break; // the shortest unblocked slit is found
        const glm::dvec2 &w0 = wall[(slit.wall + walls - 1) % walls], &w1 = wall[slit.wall];
        const glm::dvec2 &h0 = hole[slit.hole], &h1 = hole[(slit.hole + 1) % holes];
        // The slit's quadrilateral, counterclockwise, with crossings w0-h0 and w1-h1.
        if (cross(w1 - w0, h1 - w0) + cross(h1 - w0, h0 - w0) <= 0.0 || segmentsCross(w0, h0, w1, h1) ||
            !clearOfApart(slit.wall, slit.hole))
            continue;
        const double stretch = blockedStretch(0.5 * (w0 + w1), 0.5 * (h0 + h1), blocked);
        if (stretch >= bestBlocked) continue;
        if (crossesPolygon(w0, h0, wall) || crossesPolygon(w0, h0, hole) || crossesPolygon(w1, h1, wall) ||
            crossesPolygon(w1, h1, hole))
            continue;
        bestBlocked = stretch;
        keyhole = {slit.wall, slit.hole, walls, holes, stretch};
    }
    return keyhole.open();
}

// The reconstruction's correspond and resolveEvents stages.

namespace {

constexpr double kPi = 3.14159265358979323846;

// Pixels of a keyhole's slit that may lie where the partners' plane is inside before its junction
// goes to the cells (resolveEvents): as many as a junction's chords may cross (graph.cpp,
// cutsNearest).
constexpr double kMaxBlocked = 1.0;
// Pixels the isosurface may lie from a band's straight triangles, between its planes, before the
// band takes a plane between (splitBand) or its cells (strayingBandPatch): the top level's bound,
// a voxel. A distance across the plane overstates the distance to a surface that leans toward
// the plane, but a margin let bands stray up to 1.47 voxels: with 1.5 pixels, 19 of 177 random
// crops of the smoke were more than a voxel off at the top level, with 1 pixel 13, for 2.8% more
// triangles over the evaluation's meshes.
constexpr double kBandStray = 1.0;

// The band's straight surface between loop a below and loop b above, at fraction t of the way up,
// in direction d of the profiles' n: its points at the nearest and the farthest radius, the loops'
// radial profiles and central points interpolated (infinite where a ray misses either loop).
std::array<glm::dvec2, 2> bandPoints(const PlaneLoops& lower, int a, const PlaneLoops& upper, int b, std::size_t d,
                                     std::size_t n, double t)
{
    const RadialProfile& p = *lower.profiles[a];
    const RadialProfile& r = *upper.profiles[b];
    const double angle = 2.0 * kPi * static_cast<double>(d) / static_cast<double>(n);
    const glm::dvec2 direction(std::cos(angle), std::sin(angle));
    const glm::dvec2 center = (1.0 - t) * lower.centers[a] + t * upper.centers[b];
    std::array<glm::dvec2, 2> points;
    int k = 0;
    for (const auto& radius : {&RadialProfile::nearest, &RadialProfile::farthest}) {
        const double expected = (1.0 - t) * (p.*radius)[d] + t * (r.*radius)[d];
        points[k++] = std::isfinite(expected) ? center + direction * expected
                                              : glm::dvec2(std::numeric_limits<double>::infinity());
    }
    return points;
}

// How far the middle plane's loop lies from where the band's straight triangles put it, in pixels:
// the loops' radial profiles (each from its own central point) give, per direction, the middle
// loop's nearest and farthest crossings and the band's, the means of the lower and upper loops'.
// Each point of either set is as far as the nearest point of the other within a sixteenth of a
// turn either way, so that a shift across an oblique boundary counts its distance, not its length
// along a ray.
double strayFromBand(const PlaneLoops& lower, int a, const PlaneLoops& middle, int m, const PlaneLoops& upper, int b)
{
    const RadialProfile& q = *middle.profiles[m];
    const std::size_t n =
        std::min({lower.profiles[a]->nearest.size(), q.nearest.size(), upper.profiles[b]->nearest.size()});
    if (n == 0) return 0.0;
    // Per direction: the band's two points halfway up, then the loop's (infinite where a ray misses).
    std::vector<std::array<glm::dvec2, 4>> points(n);
    const glm::dvec2 none(std::numeric_limits<double>::infinity());
    for (std::size_t d = 0; d < n; ++d) {
        const std::array<glm::dvec2, 2> band = bandPoints(lower, a, upper, b, d, n, 0.5);
        const double angle = 2.0 * kPi * static_cast<double>(d) / static_cast<double>(n);
        const glm::dvec2 direction(std::cos(angle), std::sin(angle));
        points[d][0] = band[0];
        points[d][1] = band[1];
        int k = 2;
        for (const auto& radius : {&RadialProfile::nearest, &RadialProfile::farthest}) {
            const double actual = (q.*radius)[d];
            points[d][k++] = std::isfinite(actual) ? middle.centers[m] + direction * actual : none;
        }
    }
    // The largest of the nearest distances, squared. A point's search stops at the first point
    // within the largest so far, which it cannot raise; searched from its own direction outward,
    // most points stop at once (a tree's bands took 8% of its time before).
    const std::size_t window = std::max<std::size_t>(n / 16, 1);
    double stray2 = 0.0;
    for (std::size_t d = 0; d < n; ++d)
        for (int k = 0; k < 4; ++k) {
            const glm::dvec2& from = points[d][k];
            if (!std::isfinite(from.x)) continue;
            double nearest2 = std::numeric_limits<double>::infinity();
            for (std::size_t step = 0; step <= 2 * window && nearest2 > stray2; ++step) {
                const std::size_t e = (step % 2 == 0 ? n + d + step / 2 : n + d - (step + 1) / 2) % n;
                for (const int other : k < 2 ? std::array<int, 2>{2, 3} : std::array<int, 2>{0, 1}) {
                    const glm::dvec2 to = points[e][other] - from;
                    if (std::isfinite(to.x)) nearest2 = std::min(nearest2, glm::dot(to, to));
                }
            }
            if (std::isfinite(nearest2)) stray2 = std::max(stray2, nearest2);
        }
    return std::sqrt(stray2);
}

// How far the patch's vertices inside its slab lie from the straight surface of the band between
// loop a below and loop b above, in pixels: each against the loops' radial profiles interpolated to
// its own w, within a sixteenth of a turn of its own direction (as strayFromBand).
double patchStrayFromBand(const SlabPatch& patch, int axis, const PlaneLoops& lower, int a, const PlaneLoops& upper,
                          int b)
{
    const std::size_t n = std::min(lower.profiles[a]->nearest.size(), upper.profiles[b]->nearest.size());
    if (n == 0) return 0.0;
    const std::size_t window = std::max<std::size_t>(n / 16, 1);
    double stray = 0.0;
    for (const SlabPatch::Vertex& v : patch.vertices) {
        if (v.plane >= 0) continue;
        const double t = (v.index[axis] - lower.w) / (upper.w - lower.w);
        const glm::dvec2 center = (1.0 - t) * lower.centers[a] + t * upper.centers[b];
        const glm::dvec2 uv(v.index[(axis + 1) % 3], v.index[(axis + 2) % 3]);
        double angle = std::atan2(uv.y - center.y, uv.x - center.x);
        if (angle < 0.0) angle += 2.0 * kPi;
        const std::size_t d = static_cast<std::size_t>(std::lround(angle / (2.0 * kPi) * static_cast<double>(n))) % n;
        double nearest = std::numeric_limits<double>::infinity();
        for (std::size_t e = n + d - window; e <= n + d + window; ++e)
            for (const glm::dvec2& point : bandPoints(lower, a, upper, b, e % n, n, t))
                if (std::isfinite(point.x)) nearest = std::min(nearest, glm::length(point - uv));
        if (std::isfinite(nearest)) stray = std::max(stray, nearest);
    }
    return stray;
}

// The middle of the chord that closes a gap's arc, from cut `from` to cut `to` of `polygon`;
// `sign` is -1 where the part runs the other way round (a hole's part of a wall). The chord's
// midpoint, unless the arc bends past it (a gap opening onto a contour that runs nearly straight:
// the trifurcation's 2-pixel holes between its branches): the part of arc and midpoint would run
// clockwise, wind around no point, and take no ray. There the middle moves off the chord, half a
// pixel past the arc's farthest point, so that the part encloses room for its partner's rays.
glm::dvec2 gapMiddle(const std::vector<glm::dvec2>& polygon, int from, int to, double sign)
{
    constexpr double kPastArc = 0.5; // pixels
    const glm::dvec2 first = polygon[static_cast<std::size_t>(from)], last = polygon[static_cast<std::size_t>(to)];
    const glm::dvec2 middle = 0.5 * (first + last);
    std::vector<glm::dvec2> part;
    for (std::size_t p = static_cast<std::size_t>(from);; p = (p + 1) % polygon.size()) {
        part.push_back(polygon[p]);
        if (p == static_cast<std::size_t>(to)) break;
    }
    part.push_back(middle);
    const glm::dvec2 chord = first - last;
    if (sign * polygonArea(part) > 0.0 || glm::length(chord) == 0.0) return middle;
    // The direction in which moving the middle adds area to the part as it runs.
    const glm::dvec2 away = sign * glm::dvec2(chord.y, -chord.x) / glm::length(chord);
    double past = 0.0;
    for (const glm::dvec2& q : part) past = std::max(past, glm::dot(q - middle, away));
    return middle + (past + kPastArc) * away;
}

} // namespace

void Reconstruction::correspond()
{
    // A fork's crotch is the chord across its contour's neck, which lies within the slab's
    // thickness of the saddle (the surface curves away from the chord by less than that), so
    // event slabs are halved until they are at most half a voxel thick. So are bands whose
    // contours change shape by more than 3 pixels (graph.h, shapeChange): a profile changing by
    // d across the slab along a parabola strays d / 4 from the band's straight triangles, so
    // this keeps them within 0.75 voxel where the shape changes smoothly, and splits the slab
    // where it does not (the aorta's end: 1.19 voxels without), below half a voxel if need be
    // (the hollow Y's crescents: 1.07 voxels off when halving stopped at half a voxel). Tubes
    // that lean and turn (the helix: ellipses turning by up to 3 pixels between slices) follow
    // their chords and get none.
    std::vector<PlaneLoops> planes;
    for (std::size_t s = 0; s < mLoops.size(); ++s) planes.push_back(planeLoops(static_cast<int>(s)));
    std::vector<SliceCounts> dropped; // per added plane
    const auto addPlane = [&](double w) {
        mPositions.push_back(w);
        dropped.emplace_back();
        mLoops.push_back(traceContours(w, dropped.back())); // moving the outer vector keeps each loop in place
        planes.push_back(planeLoops(static_cast<int>(planes.size())));
        return static_cast<int>(planes.size()) - 1;
    };
    const auto dropLastPlane = [&] {
        mPositions.pop_back();
        dropped.pop_back();
        mLoops.pop_back();
        planes.pop_back();
    };
    // The cells' Euler characteristic layer by layer: where the slabs' pieces add up to another count, a
    // handle at the voxel scale hides in them (graph.h).
    const auto cells = [&] {
        mCells = cellProfile();
        return *mCells;
    };
    mGraph = buildContourGraph(mVolume, mPlan, planes, kEventThickness, kShapeChange, addPlane, dropLastPlane, cells,
                               mCellPieces.thinJunctions);
    mStats.addedPlanes = mGraph.addedPlanes;
    mStats.cellMatches = mGraph.cellMatches;
    for (const SliceCounts& counts : dropped) {
        mStats.droppedSmall += counts.small;
        mStats.droppedUnwound += counts.unwound;
    }
    for (std::size_t s = mPlan.positions.size(); s < mLoops.size(); ++s) {
        mStats.contours += static_cast<int>(mLoops[s].size());
        for (const SliceLoop& l : mLoops[s]) mStats.holes += l.loop.hole() ? 1 : 0;
    }
}

void Reconstruction::resolveEvents()
{
    // Tubes grow along bands; every other piece ends the tubes of its lower contours and starts
    // tubes for its upper ones. A junction joins those ends where it splits into arcs.
    std::vector<std::vector<int>> tubeOf(mLoops.size());
    for (std::size_t s = 0; s < mLoops.size(); ++s) tubeOf[s].assign(mLoops[s].size(), -1);
    auto startTube = [&](int s, int l) {
        tubeOf[s][l] = static_cast<int>(mTubes.size());
        mTubes.emplace_back();
        mTubes.back().hole = mLoops[s][l].loop.hole();
        mTubes.back().members.push_back({s, l});
        return tubeOf[s][l];
    };
    // A patch's loops end the tubes below it and start those above; the handles it found are the
    // piece's.
    auto joinPatch = [&](const ContourGraph::Slab& slab, SlabPiece& piece, SlabPatch&& surface) {
        const int id = addPatch(slab.below, slab.above, piece, std::move(surface));
        for (int l : piece.below) mTubes[tubeOf[slab.below][l]].top.patch = id;
        for (int l : piece.above) mTubes[startTube(slab.above, l)].bottom.patch = id;
    };
    if (mGraph.order.empty()) return;
    const int first = mGraph.order.front(), last = mGraph.order.back();
    // The pieces out to the empty plane past the box: a wall and holes ending there are a rim; a
    // piece joining several contours is patched where its cells close; the rest are ends.
    const auto resolvePastTheBox = [&](std::vector<SlabPiece>& past, bool top) {
        for (SlabPiece& piece : past) {
            mStats.eventEuler += piece.euler();
            const std::vector<int>& loops = top ? piece.below : piece.above;
            if (piece.kind == EventKind::Rim)
                markRim(top ? last : first, loops, top, tubeOf);
            else if (loops.size() > 1)
                patchPastTheBox(piece, top, tubeOf);
        }
    };
    for (int l = 0; l < static_cast<int>(mLoops[first].size()); ++l) startTube(first, l);
    mStats.starts += static_cast<int>(mLoops[first].size());
    resolvePastTheBox(mGraph.beforeFirst, false);
    // Where the cells count fewer than the pieces between two voxel planes (handles the pieces'
    // 2 - a - b misses, which no cut showed: graph.h), a piece whose patch finds handles is
    // meshed by it, whatever its kind, as long as the range still misses that many: patches
    // between interpolated planes can each find the one handle the cells count (the smoke, y 16
    // to 17: two patches, each with a handle), and the first in w takes it.
    std::vector<EulerDifference> missed;
    const auto countMissed = [&] {
        missed.clear();
        for (const EulerDifference& d : eulerDifferences(*mCells, mGraph, mPositions))
            if (d.difference < 0) missed.push_back(d);
    };
    if (mCells) countMissed();
    if (mCells || !mCellPieces.bandRanges.empty()) {
        patchWholeRanges(missed);
        if (mCells) countMissed(); // a whole range's pieces can count otherwise than its slabs' did
    }
    for (ContourGraph::Slab& slab : mGraph.slabs) {
        BandMiddle middle; // the slab's middle plane, traced for its first band that asks
        const auto range = std::find_if(missed.begin(), missed.end(), [&](const EulerDifference& d) {
            return mPositions[slab.below] >= d.wBelow && mPositions[slab.above] <= d.wAbove;
        });
        const bool missesHandles = range != missed.end();
        // The patches the slab's pieces may take, in one pass over its cells: every piece's where
        // handles were missed, else the unresolved ones'.
        std::vector<const SlabPiece*> wanted;
        std::vector<std::size_t> wantedAt;
        for (std::size_t k = 0; k < slab.pieces.size(); ++k)
            if (missesHandles || slab.pieces[k].kind == EventKind::Unresolved) {
                wanted.push_back(&slab.pieces[k]);
                wantedAt.push_back(k);
            }
        std::vector<std::optional<SlabPatch>> patches(slab.pieces.size()),
            found = patchesOf(slab.below, slab.above, wanted);
        for (std::size_t i = 0; i < found.size(); ++i) patches[wantedAt[i]] = std::move(found[i]);
        for (std::size_t k = 0; k < slab.pieces.size(); ++k) {
            SlabPiece& piece = slab.pieces[k]; // a patch records the handles it finds
            std::optional<SlabPatch>& patch = patches[k];
            mStats.eventEuler += piece.euler();
            if (missesHandles && patch && patch->euler < piece.euler() &&
                piece.euler() - patch->euler <= -range->difference) {
                range->difference += piece.euler() - patch->euler;
                joinPatch(slab, piece, std::move(*patch));
                continue;
            }
            if (piece.kind == EventKind::Band) {
                // Where the middle plane shows the band as more than a band (its loop there joins
                // it otherwise than one to one), its cells are looked at whatever its shape change:
                // a crop of the smoke, whose contours change by 2.2 pixels at most, had a bump
                // that moves 3.6 pixels in a voxel fanned 1.24 voxels off.
                std::optional<SlabPatch> cells = strayingBandPatch(slab, piece, false);
                // A band whose top level strayed from the isosurface in a first build
                // (strayingPieces) takes its cells, where they close as an annulus.
                if (!cells && mCellPieces.bands.count({slab.below, piece.below[0]}) > 0) {
                    cells = std::move(patchesOf(slab.below, slab.above, {&piece}).front());
                    if (cells && cells->euler != piece.euler()) cells.reset();
                }
                std::vector<int> steps;
                if (!cells && !splitBand(slab.below, piece.below[0], slab.above, piece.above[0], middle, steps))
                    cells = strayingBandPatch(slab, piece, true);
                if (cells) {
                    ++mStats.bandPatches;
                    joinPatch(slab, piece, std::move(*cells));
                    continue;
                }
                const int t = tubeOf[slab.below][piece.below[0]];
                for (const int plane : steps) {
                    tubeOf.emplace_back(1, t);
                    mTubes[t].members.push_back({plane, 0});
                }
                mStats.bandPlanes += static_cast<int>(steps.size());
                mTubes[t].members.push_back({slab.above, piece.above[0]});
                tubeOf[slab.above][piece.above[0]] = t;
                continue;
            }
            const bool joins = piece.kind == EventKind::Fork || piece.kind == EventKind::Merge ||
                               (piece.kind == EventKind::Rim && piece.below.size() + piece.above.size() > 2);
            // The cells mesh a piece, where they close with its Euler characteristic, before any
            // construction from contours that would stray: an n:m piece (a waist is the walls'
            // union, wider than the slab's middle where a wall ends inside the slab: the smoke's
            // top level 1.53 voxels off at one), and a fork or merge whose slab stayed thicker than
            // the events' thickness (a plane between voxel planes showed other pieces).
            const bool thick = joins && mPositions[slab.above] - mPositions[slab.below] > kEventThickness;
            // The piece's patch, where no pass above took it already.
            const auto cells = [&] {
                if (!patch) patch = std::move(patchesOf(slab.below, slab.above, {&piece}).front());
            };
            if (thick) cells();
            if ((thick || piece.kind == EventKind::Unresolved) && patch && patch->euler == piece.euler()) {
                joinPatch(slab, piece, std::move(*patch));
                continue;
            }
            Junction merge, fork;
            if (piece.kind == EventKind::Unresolved && makeWaist(slab, piece, merge, fork)) {
                const int waist = static_cast<int>(mLoops.size()) - 1, id = static_cast<int>(mJunctions.size());
                tubeOf.emplace_back(1, -1);
                for (int l : piece.below) mTubes[tubeOf[slab.below][l]].top.junction = id;
                const int t = startTube(waist, 0);
                mTubes[t].bottom.junction = id;
                mTubes[t].top.junction = id + 1;
                for (int l : piece.above) mTubes[startTube(slab.above, l)].bottom.junction = id + 1;
                ++mStats.waists;
                mStats.saddles += static_cast<int>(piece.below.size() + piece.above.size()) - 2;
                mJunctions.push_back(std::move(merge));
                mJunctions.push_back(std::move(fork));
                continue;
            }
            Junction junction;
            if (joins && makeJunction(slab, piece, junction)) {
                // A ring cut open by a slit that runs over material the partners' plane holds
                // too puts the slit inside the surface, which closes the hole beyond that plane (a
                // ring tree: no slit clear of it, 6 pixels blocked, 1.48 voxels off at the top
                // level). The piece's cells mesh it instead, where they close.
                // So does a fork or merge whose parts strayed from the isosurface at the top level
                // of a first build (strayingPieces).
                const bool strayed = mCellPieces.junctions.count(keyOf(junction)) > 0;
                if (junction.keyhole.blocked > kMaxBlocked || strayed) {
                    cells();
                    if (patch && patch->euler == piece.euler()) {
                        mStats.junctionPatches += strayed ? 1 : 0;
                        joinPatch(slab, piece, std::move(*patch));
                        continue;
                    }
                }
                const int id = addJunction(std::move(junction));
                for (int l : piece.below) mTubes[tubeOf[slab.below][l]].top.junction = id;
                for (int l : piece.above) mTubes[startTube(slab.above, l)].bottom.junction = id;
                continue;
            }
            if (joins) cells();
            if ((joins || piece.kind == EventKind::Unresolved) && patch) {
                joinPatch(slab, piece, std::move(*patch));
                continue;
            }
            for (int l : piece.above) startTube(slab.above, l);
            if (piece.kind == EventKind::Rim && !joins) {
                if (piece.above.empty())
                    markRim(slab.below, piece.below, true, tubeOf);
                else
                    markRim(slab.above, piece.above, false, tubeOf);
            }
            if (joins || piece.kind == EventKind::Unresolved) {
                for (int l : piece.below) mTubes[tubeOf[slab.below][l]].top.goesOn = true;
                for (int l : piece.above) mTubes[tubeOf[slab.above][l]].bottom.goesOn = true;
                Skeleton::Unresolved u{mPositions[slab.below], mPositions[slab.above], 0, 0, 0, 0};
                for (int l : piece.below) ++(mLoops[slab.below][l].loop.hole() ? u.holesBelow : u.wallsBelow);
                for (int l : piece.above) ++(mLoops[slab.above][l].loop.hole() ? u.holesAbove : u.wallsAbove);
                mUnresolved.push_back(u);
            }
            mStats.unresolvedJunctions += joins ? 1 : 0;
            mStats.unresolvedEvents += piece.kind == EventKind::Unresolved ? 1 : 0;
            mStats.starts += piece.kind == EventKind::Start ? 1 : 0;
            mStats.ends += piece.kind == EventKind::End ? 1 : 0;
            mStats.rims += piece.kind == EventKind::Rim && !joins ? 1 : 0;
        }
    }
    mStats.ends += static_cast<int>(mLoops[last].size());
    resolvePastTheBox(mGraph.afterLast, true);
}

void Reconstruction::markRim(int s, const std::vector<int>& loops, bool top,
                             const std::vector<std::vector<int>>& tubeOf)
{
    // A wall and holes that begin or end together. A hole around the wall: the floor of a cavity
    // that a post stands in (or its roof); the hole's region ends past the plane and the wall's
    // goes on, the other way round from a pipe's rim. Holes inside the wall: a pipe's rim, the
    // slab joining each hole's outside past the plane to the outside around the wall, though the
    // field along a hole's axis may close over it (a lid). Either way the slab says so, and no
    // end takes end contours that would part them: capped on their own, hole and wall made a
    // sphere where the rim makes a handle (crops of the smoke: Euler characteristic 56 against 54
    // in one, 100 against 92 in another whose last plane held a wall and five holes).
    std::vector<int> walls, holes;
    for (int l : loops) (mLoops[s][l].loop.hole() ? holes : walls).push_back(l);
    if (walls.size() != 1 || holes.empty()) return;
    const BoundaryLoop& wall = mLoops[s][walls[0]].loop;
    if (wall.points.empty()) return;
    const auto inWall = [&](int h) {
        const BoundaryLoop& hole = mLoops[s][h].loop;
        return !hole.points.empty() && encloses(wall, hole.points.front());
    };
    const bool aroundWall = holes.size() == 1 && encloses(mLoops[s][holes[0]].loop, wall.points.front());
    const bool rim = !aroundWall && std::all_of(holes.begin(), holes.end(), inWall);
    for (int l : loops) {
        TubeEnd& end = top ? mTubes[tubeOf[s][l]].top : mTubes[tubeOf[s][l]].bottom;
        end.aroundWall = aroundWall;
        end.rim = rim;
    }
}

void Reconstruction::patchPastTheBox(SlabPiece& piece, bool top, const std::vector<std::vector<int>>& tubeOf)
{
    // Contours of the first or last plane that join past it, between it and the empty plane past
    // the grid's box (a plane there stops up to a voxel short of the box): capped each on its own,
    // they were separate objects (a crop of the smoke: two walls of its last plane, 100, joined
    // at 101 around a handle, Euler characteristic 112 against 108). Their piece is meshed from
    // its cells out to that empty plane, as a face the box cuts is (patchFace).
    // A patch that finds a handle the labelling lacks is left out: past the plane, where no cut
    // refines the labelling, the cells' count did not confirm one (a crop along y: Euler
    // characteristic 2 against the isosurface's 6, 8 with the contours capped).
    const int s = top ? mGraph.order.back() : mGraph.order.front();
    std::optional<SlabPatch> surface = std::move(patchesOf(top ? s : -1, top ? -1 : s, {&piece}).front());
    if (!surface || surface->euler != piece.euler()) return;
    const int id = addPatch(top ? s : -1, top ? -1 : s, piece, std::move(*surface));
    for (int l : top ? piece.below : piece.above)
        (top ? mTubes[tubeOf[s][l]].top : mTubes[tubeOf[s][l]].bottom).patch = id;
}

bool Reconstruction::cellsClose(int s, int l, bool lowerSide) const
{
    for (const ContourGraph::Slab& slab : mGraph.slabs) {
        if ((lowerSide ? slab.below : slab.above) != s) continue;
        for (const SlabPiece& piece : slab.pieces) {
            const std::vector<int>& loops = lowerSide ? piece.below : piece.above;
            if (std::find(loops.begin(), loops.end(), l) == loops.end()) continue;
            const std::optional<SlabPatch> patch = std::move(patchesOf(slab.below, slab.above, {&piece}).front());
            return patch && patch->euler == piece.euler();
        }
    }
    return false;
}

bool Reconstruction::makeJunction(const ContourGraph::Slab& slab, const SlabPiece& piece, Junction& junction) const
{
    junction.kind = piece.kind;
    if (piece.kind == EventKind::Rim) {
        // A wall with several holes, in one plane: its polygon is split into one arc per hole,
        // closed through a hub in the plane, and each arc tiled to its hole: a face with holes.
        junction.top = piece.above.empty();
        const int s = junction.top ? slab.below : slab.above;
        for (int l : junction.top ? piece.below : piece.above)
            (mLoops[s][l].loop.hole() ? junction.many.emplace_back(s, l) : junction.single = {s, l});
        return splitJunction(junction);
    }
    // A fork's one side lies below, a merge's above: one contour, or a ring (a wall and its hole).
    const bool fork = piece.kind == EventKind::Fork;
    const int s1 = fork ? slab.below : slab.above, s2 = fork ? slab.above : slab.below;
    const std::vector<int>& ones = fork ? piece.below : piece.above;
    for (int l : ones) (ones.size() == 2 && mLoops[s1][l].loop.hole() ? junction.inner : junction.single) = {s1, l};
    for (int l : fork ? piece.above : piece.below) junction.many.push_back({s2, l});
    return splitJunction(junction);
}

std::optional<SlabPatch> Reconstruction::strayingBandPatch(const ContourGraph::Slab& slab, const SlabPiece& piece,
                                                           bool anyShape) const
{
    // A band whose slab the graph could not halve down to what its shape change asks (a plane
    // between showed other pieces elsewhere in the slab: graph.h) can fan a contour's arm that
    // ends inside the slab across the air beside it (the smoke at iso 0.1: a kidney-shaped section
    // a voxel below a blob, fanned from the blob across 13 voxels, 2.23 voxels off at the top
    // level). Where its cells close as an annulus and lie farther than kBandStray from the band's
    // straight triangles, they mesh it instead, at every level; as for a fork or merge, only in a
    // slab thicker than the events' thickness. The profiles measure across the plane, which
    // overstates how far a thinner slab's band strays: three random capsule trees, sliced along x,
    // had a band patched in a slab a quarter or half a voxel thick where an arm grows 16 to 30
    // pixels, and it left needles at three more levels (up to 986).
    if (mPositions[slab.above] - mPositions[slab.below] <= kEventThickness) return std::nullopt;
    const PlaneLoops lower = planeLoops(slab.below), upper = planeLoops(slab.above);
    const int a = piece.below[0], b = piece.above[0];
    if (!anyShape && shapeChange(lower, a, upper, b) <= kShapeChange) return std::nullopt;
    std::optional<SlabPatch> patch = std::move(patchesOf(slab.below, slab.above, {&piece}).front());
    if (!patch || patch->euler != piece.euler() ||
        patchStrayFromBand(*patch, mPlan.axis, lower, a, upper, b) <= kBandStray)
        return std::nullopt;
    return patch;
}

bool Reconstruction::splitBand(int below, int lowerLoop, int above, int upperLoop, BandMiddle& middle,
                               std::vector<int>& steps)
{
    // The graph halves a slab for its bands' shape only where a plane between agrees with the
    // slab's pieces as a whole (graph.h). On a noisy fog most do not (some other piece of the slab
    // shows a speck or a contact there), and a slice spacing of 2 voxels misses what lies between
    // the planes: a crop of Gaffer's smoke has a ledge in one voxel plane between two slices, 2.7
    // voxels past the band. The band alone takes the middle plane's loop where that loop joins it
    // one to one through either half and lies farther from the band's straight triangles than
    // kBandStray pixels.
    if (mPositions[above] - mPositions[below] <= kEventThickness / 4.0) return true;
    const PlaneLoops lower = planeLoops(below), upper = planeLoops(above);
    if (!middle.traced) {
        SliceCounts dropped;
        middle.w = 0.5 * (mPositions[below] + mPositions[above]);
        middle.loops = traceContours(middle.w, dropped);
        const PlaneLoops between = planeLoopsOf(middle.loops, middle.w);
        middle.lowerHalf = connectThroughSlab(mVolume, mPlan, lower, between);
        middle.upperHalf = connectThroughSlab(mVolume, mPlan, between, upper);
        middle.traced = true;
    }
    // The piece that holds loop `l` of the lower (`onLower`) or upper plane.
    const auto pieceOf = [](const std::vector<SlabPiece>& pieces, int l, bool onLower) -> const SlabPiece* {
        for (const SlabPiece& p : pieces) {
            const std::vector<int>& loops = onLower ? p.below : p.above;
            if (std::find(loops.begin(), loops.end(), l) != loops.end()) return &p;
        }
        return nullptr;
    };
    const SlabPiece* first = pieceOf(middle.lowerHalf, lowerLoop, true);
    const SlabPiece* second = pieceOf(middle.upperHalf, upperLoop, false);
    if (!first || !second || first->kind != EventKind::Band || second->kind != EventKind::Band ||
        second->below != first->above)
        return false;
    // Where the profiles' directions show half a pixel, along four times as many: a notch a pixel
    // wide in the middle plane falls between 64 of them (a crop of the smoke at iso 0.1, slices 2
    // voxels apart: a pit in one voxel plane measured 0.88 pixel, 1.12 along 256 directions, and
    // the band over it lay 1.14 voxels off at the top level). Not everywhere: the phantom's bands
    // took 30% more of its time.
    const PlaneLoops between = planeLoopsOf(middle.loops, middle.w);
    if (strayFromBand(lower, lowerLoop, between, first->above[0], upper, upperLoop) <= kBandStray / 2.0) return true;
    const SliceLoop &l0 = mLoops[below][lowerLoop], &l1 = middle.loops[first->above[0]], &l2 = mLoops[above][upperLoop];
    const int directions = 4 * profileDirections();
    const std::array<RadialProfile, 3> fine{radialProfile(l0.view, directions), radialProfile(l1.view, directions),
                                            radialProfile(l2.view, directions)};
    const auto alone = [](const SliceLoop& l, const RadialProfile& profile) {
        return PlaneLoops{0.0, {&l.loop}, {l.view.center}, {&profile}};
    };
    if (strayFromBand(alone(l0, fine[0]), 0, alone(l1, fine[1]), 0, alone(l2, fine[2]), 0) <= kBandStray) {
        // The profiles sample the band halfway along rays from each loop's centre; the top level's
        // triangles join the contours' vertices as its tiler pairs them, and can lie farther off
        // (a crop of the smoke at iso 0.1: 0.91 pixel measured, the top level 1.04 voxels off).
        // Near the bound, the top level's own band is asked.
        mNearBands.insert({below, lowerLoop});
        return true;
    }
    // A plane of that loop alone: the slab's other pieces do not pass through it.
    mPositions.push_back(middle.w);
    mLoops.push_back({middle.loops[static_cast<std::size_t>(first->above[0])]});
    const int plane = static_cast<int>(mLoops.size()) - 1;
    BandMiddle lowerMiddle, upperMiddle;
    splitBand(below, lowerLoop, plane, 0, lowerMiddle, steps);
    steps.push_back(plane);
    splitBand(plane, 0, above, upperLoop, upperMiddle, steps);
    return true;
}

bool Reconstruction::makeWaist(const ContourGraph::Slab& slab, const SlabPiece& piece, Junction& merge, Junction& fork)
{
    // Where the slab's labelling joins several walls below to several above in one genus-0 piece
    // and bisection found no plane between their saddles (fog voxels meeting along edges within
    // one voxel slab), a contour around them all in the middle plane passes the piece's topology
    // on: n walls merge into it, and it forks into m. Its geometry is the walls' union, so the
    // crotches lie within the slab; holes have no construction here.
    constexpr double kMaxGrowth = 2.0; // pixels: walls farther apart than twice this make no waist
    if (piece.below.size() < 2 || piece.above.size() < 2) return false;
    std::vector<const std::vector<glm::dvec2>*> walls;
    for (const auto& [s, loops] : {std::pair{slab.below, &piece.below}, std::pair{slab.above, &piece.above}})
        for (int l : *loops) {
            if (mLoops[s][l].loop.hole()) return false;
            walls.push_back(&mLoops[s][l].view.polygon);
        }
    SliceLoop waist;
    waist.loop = waistAround(walls, kMaxGrowth);
    if (waist.loop.corners.empty()) return false;
    waist.view = viewFrom(waist.loop, centralPoint(waist.loop));
    if (waist.view.winding != 1) return false;
    waist.profile = radialProfile(waist.view, profileDirections());
    waist.onPolygon = true;
    const int plane = static_cast<int>(mLoops.size());
    mPositions.push_back(0.5 * (mPositions[slab.below] + mPositions[slab.above]));
    mLoops.push_back({std::move(waist)});
    if (makeJunction({slab.below, plane, {}}, {piece.below, {0}, EventKind::Merge}, merge) &&
        makeJunction({plane, slab.above, {}}, {{0}, piece.above, EventKind::Fork}, fork))
        return true;
    mPositions.pop_back();
    mLoops.pop_back();
    return false;
}

std::vector<std::optional<SlabPatch>> Reconstruction::patchesOf(int below, int above,
                                                                const std::vector<const SlabPiece*>& pieces) const
{
    // Unlike a waist, the cells give holes and handles too; but their triangles are as fine as
    // the voxels at every level, so the constructions from contours go first.
    if (pieces.empty()) return {};
    const PlaneLoops lower = below >= 0 ? planeLoops(below) : pastTheBox(mVolume, mPlan, false);
    const PlaneLoops upper = above >= 0 ? planeLoops(above) : pastTheBox(mVolume, mPlan, true);
    return patchPieces(mVolume, mPlan, lower, upper, pieces);
}

PlaneLoops Reconstruction::planeLoops(int s) const
{
    return planeLoopsOf(mLoops[static_cast<std::size_t>(s)], mPositions[static_cast<std::size_t>(s)]);
}

PlaneLoops Reconstruction::planeLoopsOf(const std::vector<SliceLoop>& loops, double w)
{
    PlaneLoops plane;
    plane.w = w;
    for (const SliceLoop& l : loops) {
        plane.loops.push_back(&l.loop);
        plane.centers.push_back(l.view.center);
        plane.profiles.push_back(&l.profile);
    }
    return plane;
}

void Reconstruction::patchWholeRanges(const std::vector<EulerDifference>& missed)
{
    // Planes added inside a range between voxel planes (for its events' crotches) see the
    // interpolated field's contacts there, and a handle the cells count can span them, so that no
    // slab's patch finds it (the smoke's crops: nine of 75 runs a handle short, each within one
    // voxel); or a patch between a voxel plane and an added one, where no rule decides a saddle,
    // finds a handle the cells do not count (one crop: Euler characteristic 132 against 134).
    // Where the pieces of the whole range, patched from its cells, add up to the cells' count,
    // they replace its slabs; the planes between are then no part of the graph.
    std::vector<EulerDifference> ranges = missed;
    // The ranges of bands whose top level strayed in a first build (strayingPieces), which their
    // own slabs' cells could not mesh: the count stays.
    for (const auto& [below, above] : mCellPieces.bandRanges) ranges.push_back({below, above, 0});
    std::size_t from = 0; // the slab after the last voxel plane
    for (std::size_t k = 1; mCells && k < mGraph.order.size(); ++k) {
        const double w = mPositions[mGraph.order[k]];
        if (w != std::floor(w)) continue;
        const double wFrom = mPositions[mGraph.order[from]];
        const bool missing =
            std::any_of(missed.begin(), missed.end(), [&](const EulerDifference& d) { return d.wBelow == wFrom; });
        const auto contradicts = [&](const ContourGraph::Slab& slab) { return patchFindsHandles(slab); };
        const auto slab = mGraph.slabs.begin() + static_cast<std::ptrdiff_t>(from);
        if (k - from >= 2 && wFrom == std::floor(wFrom) && !missing &&
            std::any_of(slab, slab + static_cast<std::ptrdiff_t>(k - from), contradicts))
            ranges.push_back({wFrom, w, 0});
        from = k;
    }
    for (const EulerDifference& d : ranges) {
        if (!std::isfinite(d.wBelow) || !std::isfinite(d.wAbove)) continue;
        const auto inRange = [&](const ContourGraph::Slab& slab) {
            return mPositions[slab.below] >= d.wBelow && mPositions[slab.above] <= d.wAbove;
        };
        std::vector<ContourGraph::Slab>& slabs = mGraph.slabs;
        const auto first = std::find_if(slabs.begin(), slabs.end(), inRange);
        const auto end = std::find_if_not(first, slabs.end(), inRange);
        if (end - first < 2) continue; // one slab's pieces are patched as they are
        ContourGraph::Slab whole{first->below, std::prev(end)->above, {}};
        whole.pieces = connectThroughSlab(mVolume, mPlan, planeLoops(whole.below), planeLoops(whole.above));
        std::vector<const SlabPiece*> pieces;
        for (const SlabPiece& piece : whole.pieces) pieces.push_back(&piece);
        long long now = 0, patched = 0;
        for (auto slab = first; slab != end; ++slab)
            for (const SlabPiece& piece : slab->pieces) now += piece.euler();
        bool closes = true; // else a piece the cells do not close: the range stays as it was
        for (const std::optional<SlabPatch>& patch : patchesOf(whole.below, whole.above, pieces)) {
            closes = closes && patch.has_value();
            patched += patch ? patch->euler : 0;
        }
        if (!closes || patched != now + d.difference) continue;
        std::vector<int>& order = mGraph.order;
        order.erase(std::find(order.begin(), order.end(), whole.below) + 1,
                    std::find(order.begin(), order.end(), whole.above));
        slabs.insert(slabs.erase(first, end), std::move(whole));
    }
}

bool Reconstruction::patchFindsHandles(const ContourGraph::Slab& slab) const
{
    // A junction in a slab between voxel planes whose cells count a handle the voxel planes
    // around do not (a crop of the smoke: an arm joined to a body for a quarter voxel at a pinch
    // diagonal across the cells, where the interpolated plane joins it) cannot be halved (the
    // halves would count that handle) and fans across the handle's hole (1.3 voxels off): the
    // whole range's cells mesh it, where they close with the range's count.
    const bool thinJunction = overlapsAny(mCellPieces.thinJunctions, mPositions[slab.below], mPositions[slab.above]);
    std::vector<const SlabPiece*> asked;
    for (const SlabPiece& piece : slab.pieces)
        if (piece.kind == EventKind::Unresolved ||
            (thinJunction && (piece.kind == EventKind::Fork || piece.kind == EventKind::Merge)))
            asked.push_back(&piece);
    const std::vector<std::optional<SlabPatch>> patches = patchesOf(slab.below, slab.above, asked);
    for (std::size_t k = 0; k < patches.size(); ++k)
        if (patches[k] && patches[k]->euler != asked[k]->euler()) return true;
    return false;
}

int Reconstruction::addPatch(int below, int above, SlabPiece& piece, SlabPatch&& surface)
{
    mPatches.push_back({below, above, std::move(surface)});
    ++mStats.patches;
    mStats.patchEuler += mPatches.back().surface.euler;
    const int before = piece.euler();
    piece.handles = (before - mPatches.back().surface.euler) / 2;
    mStats.eventEuler += piece.euler() - before;
    return static_cast<int>(mPatches.size()) - 1;
}

bool Reconstruction::splitJunction(Junction& junction) const
{
    std::vector<const std::vector<glm::dvec2>*> partners;
    for (const auto& [s, l] : junction.many) partners.push_back(&mLoops[s][l].view.polygon);
    const std::vector<glm::dvec2>& polygon = mLoops[junction.single.first][junction.single.second].view.polygon;
    const std::vector<glm::dvec2>* inner =
        junction.inner.first >= 0 ? &mLoops[junction.inner.first][junction.inner.second].view.polygon : nullptr;
    const double w = mPositions[junction.single.first], wPartners = mPositions[junction.many.front().first];
    const SlicePlane plane(mVolume, mPlan, w);
    // A ring whose hole the partners do not share out (splitIntoArcs) is cut open where the
    // partners' plane is outside, the gap its material closes, and split as one contour.
    std::vector<glm::dvec2> keyholed;
    const auto blocked = [&](const glm::dvec2& point) { return plane.sampleAt(point, wPartners) < 0.0; };
    if (!splitIntoArcs(polygon, inner, partners, junction, blocked)) {
        if (!inner) return false;
        // The keyhole of a junction on the ring's other side, if one was cut.
        const Keyhole* apart = nullptr;
        for (const Junction& other : mJunctions)
            if (other.single == junction.single && other.inner == junction.inner && other.keyhole.open())
                apart = &other.keyhole;
        if (chooseKeyhole(polygon, *inner, blocked, junction.keyhole, apart))
            keyholed = keyholePolygon(polygon, *inner, junction.keyhole);
        if (keyholed.empty() || !splitIntoArcs(keyholed, nullptr, partners, junction)) {
            // No keyhole splits: the hole's cuts nearest the wall's, whatever their chords cross.
            static_cast<JunctionArcs&>(junction) = JunctionArcs{};
            junction.keyhole = Keyhole{};
            keyholed.clear();
            if (!splitIntoArcs(polygon, inner, partners, junction)) return false;
        }
    }
    const Keyhole& keyhole = junction.keyhole;
    const std::vector<glm::dvec2>& single = keyhole.open() ? keyholed : polygon;
    const bool ring = inner && !keyhole.open(); // split into sectors
    auto addNode = [&](const glm::dvec2& point, double wNode) {
        junction.nodePoints.push_back(point);
        junction.nodeIndex.push_back(planeToIndex(mPlan.axis, point, wNode));
    };
    auto addContourNode = [&](int member, int point) {
        addNode((member == 0 ? polygon : *inner)[static_cast<std::size_t>(point)], w);
        junction.nodeOn.emplace_back(member, point);
    };
    for (int cut : junction.cuts) {
        const auto [member, point] = keyhole.open() ? keyhole.at(cut) : std::pair{0, cut};
        addContourNode(member, point);
    }
    for (int cut : junction.innerCuts) addContourNode(1, cut);
    // The slit's four ends: its crossings join them.
    if (keyhole.open())
        for (int q : {keyhole.wallSize - 1, keyhole.wallSize, keyhole.size() - 1, 0}) {
            const auto [member, point] = keyhole.at(q);
            if (junction.nodeAt(member, point) < 0) addContourNode(member, point);
        }
    // Hub and chord middles lie just short of the saddle: inside across a neck or a ring's wall,
    // outside across a gap that closes. Toward the partners' plane the field changes sides at
    // the saddle itself, so they move there (and stay put if they do not get there).
    auto addSaddleNode = [&](const glm::dvec2& point) {
        double wSaddle = w;
        const double side = plane.sampleAt(point, w) < 0.0 ? 1.0 : -1.0;
        findApex(plane, point, wPartners > w ? 1.0 : -1.0, std::abs(wPartners - w), wSaddle, side);
        addNode(point, wSaddle);
    };
    const std::size_t n = junction.cuts.size();
    // A ring's chord k + 1 runs from the wall's cut k + 1 to the hole's; a gap's (or a bud's) from
    // cut a + 1 back to cut a.
    auto addChord = [&](std::size_t a) {
        const std::size_t b = (a + 1) % n;
        junction.chordArcs.push_back(static_cast<int>(a));
        if (ring) {
            addSaddleNode(0.5 * (single[junction.cuts[b]] + (*inner)[junction.innerCuts[b]]));
            return;
        }
        const bool reversed =
            mLoops[junction.many[junction.owner[a]].first][junction.many[junction.owner[a]].second].loop.hole() !=
                mLoops[junction.single.first][junction.single.second].loop.hole() &&
            junction.kind != EventKind::Rim;
        addSaddleNode(gapMiddle(single, junction.cuts[a], junction.cuts[b], reversed ? -1.0 : 1.0));
    };
    if (junction.hubbed && !ring) {
        // The buds' chords, then the hub amid the cuts where two bodies' arcs meet (every cut
        // where there are no buds).
        for (int a : junction.buds) addChord(static_cast<std::size_t>(a));
        const auto bud = [&](std::size_t a) {
            return std::find(junction.buds.begin(), junction.buds.end(), static_cast<int>(a)) != junction.buds.end();
        };
        glm::dvec2 hub(0.0);
        int meets = 0;
        for (std::size_t a = 0; a < n; ++a)
            if (!bud(a) && !bud((a + n - 1) % n)) {
                hub += single[junction.cuts[a]];
                ++meets;
            }
        addSaddleNode(hub / static_cast<double>(meets));
        composeParts(junction);
        return true;
    }
    junction.hubbed = false;
    std::vector<int> arcs(junction.many.size(), 0);
    for (int owner : junction.owner) ++arcs[owner];
    for (std::size_t a = 0; a < n; ++a)
        if (ring || arcs[junction.owner[a]] == 1) addChord(a);
    composeParts(junction);
    return true;
}

int Reconstruction::Junction::nodeAt(int member, int point) const
{
    const auto at = std::find(nodeOn.begin(), nodeOn.end(), std::pair{member, point});
    return at == nodeOn.end() ? -1 : static_cast<int>(at - nodeOn.begin());
}

void Reconstruction::composeParts(Junction& junction) const
{
    using Part = Junction::Part;
    const SliceLoop& single = mLoops[junction.single.first][junction.single.second];
    const SliceLoop* inner = junction.inner.first >= 0 ? &mLoops[junction.inner.first][junction.inner.second] : nullptr;
    const Keyhole& keyhole = junction.keyhole;
    const bool ring = inner && !keyhole.open();
    const std::size_t n = junction.cuts.size();
    const int firstMiddle = static_cast<int>(junction.nodeOn.size());
    const int hub = firstMiddle + static_cast<int>(junction.chordArcs.size()); // if hubbed
    auto middleOf = [&](std::size_t a) { // the node of the chord closing arc a, or -1
        const auto at = std::find(junction.chordArcs.begin(), junction.chordArcs.end(), static_cast<int>(a));
        return at == junction.chordArcs.end() ? -1 : firstMiddle + static_cast<int>(at - junction.chordArcs.begin());
    };
    // The corners from point `from` to point `to` of the single contour (member 0: the
    // keyhole's composite where it is cut open) or its hole (1), stepping `step`.
    auto appendArc = [&](Part& part, int member, int from, int to, int step) {
        const int size = static_cast<int>(member == 1      ? inner->view.polygon.size()
                                          : keyhole.open() ? static_cast<std::size_t>(keyhole.size())
                                                           : single.view.polygon.size());
        for (int q = from;; q = (q + step + size) % size) {
            const auto [m, p] = member == 0 && keyhole.open() ? keyhole.at(q) : std::pair{member, q};
            part.corners.push_back({m, p, junction.nodeAt(m, p)});
            if (q == to) break;
        }
    };
    auto appendNode = [](Part& part, int node) {
        if (node >= 0) part.corners.push_back({-1, -1, node});
    };
    const bool singleHole = single.loop.hole(), rim = junction.kind == EventKind::Rim;
    for (std::size_t k = 0; k < junction.many.size(); ++k) {
        // The corners in the order the minimum-area tiling took them (assemble): partner k's arcs
        // in walk order, each closed through the hub, by its chord, or for a ring's sector the
        // wall's arc, the chord at its end, the hole's arc back and the chord at its start.
        Part part;
        for (std::size_t a = 0; a < n; ++a) {
            if (junction.owner[a] != static_cast<int>(k)) continue;
            const std::size_t b = (a + 1) % n;
            appendArc(part, 0, junction.cuts[a], junction.cuts[b], 1);
            if (ring) {
                appendNode(part, middleOf(a));
                appendArc(part, 1, junction.innerCuts[b], junction.innerCuts[a], -1);
                appendNode(part, middleOf((a + n - 1) % n));
            } else {
                const int own = middleOf(a);
                if (own >= 0) {
                    appendNode(part, own); // its own chord, back to its first cut
                    continue;
                }
                // The several's arc (or a body's): across the chords of the arcs up to its next
                // one, through the cuts between them; up to another body's arc, to the hub.
                for (std::size_t c = b; junction.owner[c] != static_cast<int>(k); c = (c + 1) % n) {
                    const std::size_t next = (c + 1) % n;
                    if (middleOf(c) < 0) {
                        appendNode(part, hub);
                        break;
                    }
                    appendNode(part, middleOf(c));
                    if (junction.owner[next] != static_cast<int>(k))
                        appendArc(part, 0, junction.cuts[next], junction.cuts[next], 1);
                }
            }
        }
        const SliceLoop& partner = mLoops[junction.many[k].first][junction.many[k].second];
        if (partner.loop.hole() != singleHole && !rim) std::reverse(part.corners.begin(), part.corners.end());
        for (const Part::Corner& c : part.corners)
            part.polygon.push_back(c.member < 0 ? junction.nodePoints[c.node]
                                                : (c.member == 0 ? single : *inner).view.polygon[c.point]);
        junction.parts.push_back(std::move(part));
    }
}

int Reconstruction::addJunction(Junction&& junction)
{
    mStats.forks += junction.kind == EventKind::Fork ? 1 : 0;
    mStats.merges += junction.kind == EventKind::Merge ? 1 : 0;
    mStats.rims += junction.kind == EventKind::Rim ? 1 : 0;
    mStats.keyholes += junction.keyhole.open() ? 1 : 0;
    // A junction of c contours is a sphere with c holes less one disc (Euler 2 - c): c - 2
    // saddles, so that caps - saddles stays the mesh's Euler characteristic.
    const int contours = 1 + (junction.inner.first >= 0 ? 1 : 0) + static_cast<int>(junction.many.size());
    mStats.saddles += contours - 2;
    mJunctions.push_back(std::move(junction));
    return static_cast<int>(mJunctions.size()) - 1;
}

} // namespace pipetile
