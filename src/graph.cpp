// pipetile — graph: correspondence of contours through the slab between planes (TOPOLOGY.md).

#include <pipetile/graph.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <tuple>

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

// A loop of each plane overlapping exactly one loop of the same kind on the other plane, both
// ways: then every piece is a band, and the slab needs no labelling. Overlap is a bounding-box
// test followed by one central point inside the other loop; boxes a pixel apart count as
// overlapping, as voxels touching along an edge across the slab may join them.
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
    return true;
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

std::vector<SlabPiece> connectThroughSlab(const Volume& volume, const SlicePlan& plan, const PlaneLoops& below,
                                          const PlaneLoops& above)
{
    std::vector<SlabPiece> pieces;
    if (simpleBands(below, above, pieces)) return pieces;
    pieces.clear();
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
    const RadialProfile& p = *below.profiles[a];
    const RadialProfile& q = *above.profiles[b];
    double change = 0.0;
    for (std::size_t d = 0; d < p.nearest.size() && d < q.nearest.size(); ++d) {
        // A direction without crossings holds infinities on one side: an infinite change.
        const double near = std::abs(p.nearest[d] - q.nearest[d]), far = std::abs(p.farthest[d] - q.farthest[d]);
        change = std::max({change, std::isnan(near) ? 0.0 : near, std::isnan(far) ? 0.0 : far});
    }
    return change;
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

// The stages of buildContourGraph: each slab halved while its events need it (refine), then the
// ranges between voxel planes whose pieces do not add up to the cells' cut again (matchCells).
class GraphBuilder {
public:
    GraphBuilder(const Volume& volume, const SlicePlan& plan, std::vector<PlaneLoops>& planes, double minThickness,
                 double maxShapeChange, const std::function<int(double w)>& addPlane,
                 const std::function<void()>& dropLastPlane)
        : mVolume(volume),
          mPlan(plan),
          mPlanes(planes),
          mMinThickness(minThickness),
          mMaxShapeChange(maxShapeChange),
          mAddPlane(addPlane),
          mDropLastPlane(dropLastPlane)
    {
    }

    std::vector<SlabPiece> connect(int below, int above) const
    {
        return connectThroughSlab(mVolume, mPlan, mPlanes[below], mPlanes[above]);
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
    bool cutRange(const std::vector<ContourGraph::Slab>& range, long long target,
                  std::vector<ContourGraph::Slab>& out) const;

    const Volume& mVolume;
    const SlicePlan& mPlan;
    std::vector<PlaneLoops>& mPlanes;
    double mMinThickness, mMaxShapeChange;
    const std::function<int(double w)>& mAddPlane;
    const std::function<void()>& mDropLastPlane;
};

// How thin the slab must get: an unresolved piece (two saddles in one slab, say) is halved down
// to an eighth of minThickness, where events at different heights fall apart; a wall ending with
// several holes, or a band changing shape fast, to a quarter; a fork or merge down to
// minThickness; anything else is left as it is (0).
double GraphBuilder::thickness(int below, int above, const std::vector<SlabPiece>& pieces) const
{
    double target = 0.0;
    for (const SlabPiece& p : pieces) {
        if (p.kind == EventKind::Unresolved) return mMinThickness / 8.0;
        // A face with several holes is flat: it must lie where the wall ends.
        if (p.kind == EventKind::Rim && p.below.size() + p.above.size() > 2) target = mMinThickness / 4.0;
        if (p.kind == EventKind::Fork || p.kind == EventKind::Merge)
            target = target == 0.0 ? mMinThickness : std::min(target, mMinThickness);
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
    // bridge for). Its pieces' Euler characteristics must add up to the slab's.
    const double wMiddle = mPlanes[middle].w;
    const bool betweenVoxelPlanes = wMiddle != std::floor(wMiddle);
    if ((betweenVoxelPlanes && eulerOf(lower) + eulerOf(upper) != eulerOf(pieces)) ||
        (wAbove - wBelow <= mMinThickness && bandsOnly(pieces) && !(bandsOnly(lower) && bandsOnly(upper)))) {
        mDropLastPlane();
        out.push_back({below, above, std::move(pieces)});
        return;
    }
    refine(below, middle, std::move(lower), out);
    refine(middle, above, std::move(upper), out);
}

// How the pieces of `slabs` (in order of w) join loops: the group of each loop of the first and
// the last plane (groups numbered in order of first appearance, bottom loops first), and how many
// groups there are in all (a loop between them may join neither end: a component of its own).
struct LoopGroups {
    std::vector<int> ends;
    std::size_t count = 0;
    bool operator==(const LoopGroups& other) const { return ends == other.ends && count == other.count; }
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

// Cuts the range (slabs between two voxel planes, in order) by planes every half, quarter, ...
// of its thickness, keeping the planes it has, until its pieces add up to `target` and join the
// loops of its two ends as the range did, joining no two components (a cut may find a handle, or a
// component of its own between the voxel planes, a speck the slices missed; it may never part a
// tube the voxel planes' labelling joined, nor join two it kept apart), and on while they still do,
// down to a quarter of minThickness (as a fork's slab is halved: the finest cut places its saddles
// nearest the surface's); then refines each slab of the finest such cut into `out`. False, with every
// plane it added dropped again, if no cut matches by an eighth of minThickness, or once a cut
// joins the loops otherwise (finer ones would not undo it).
bool GraphBuilder::cutRange(const std::vector<ContourGraph::Slab>& range, long long target,
                            std::vector<ContourGraph::Slab>& out) const
{
    std::map<double, int> stack; // plane index by w
    stack.emplace(mPlanes[range.front().below].w, range.front().below);
    for (const ContourGraph::Slab& slab : range) stack.emplace(mPlanes[slab.above].w, slab.above);
    const double wBelow = stack.begin()->first, wAbove = stack.rbegin()->first;
    const LoopGroups groups = loopGroups(range, mPlanes);
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
            cut.push_back({it->second, std::next(it)->second, connect(it->second, std::next(it)->second)});
            euler += eulerOf(cut.back().pieces);
        }
        const LoopGroups now = loopGroups(cut, mPlanes);
        const bool joinsAsBefore = now.ends == groups.ends && now.count >= groups.count;
        if (euler == target && joinsAsBefore) {
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
    // far its pieces fall short of the cells'.
    struct Range {
        std::size_t first, end;
        long long target, difference;
    };
    std::vector<Range> ranges;
    std::size_t first = 0;
    for (std::size_t s = 0; s < slabs.size(); ++s) {
        const double wBelow = mPlanes[slabs[first].below].w, w = mPlanes[slabs[s].above].w;
        if (w != std::floor(w)) continue;
        if (wBelow == std::floor(wBelow)) {
            long long euler = 0;
            for (std::size_t k = first; k <= s; ++k) euler += eulerOf(slabs[k].pieces);
            const long long target = cells.between(wBelow, w);
            ranges.push_back({first, s + 1, target, target - euler});
        }
        first = s + 1;
    }
    std::vector<ContourGraph::Slab> out;
    std::size_t copied = 0;
    // Even a range whose difference the next one undoes: that may be one critical point the two
    // place on either side of a voxel plane, or two of their own (a crop of the smoke: a speck
    // that no plane meets between z = 61 and 63, next to a handle the slabs miss between 60 and
    // 61, one component short), and a cut tells them apart, as it must match the cells.
    for (const Range& range : ranges) {
        if (range.difference == 0) continue;
        std::move(slabs.begin() + copied, slabs.begin() + range.first, std::back_inserter(out));
        copied = range.first;
        const std::vector<ContourGraph::Slab> old(slabs.begin() + range.first, slabs.begin() + range.end);
        if (!cutRange(old, range.target, out)) continue;
        copied = range.end;
        ++matches;
    }
    std::move(slabs.begin() + copied, slabs.end(), std::back_inserter(out));
    return out;
}

} // namespace

ContourGraph buildContourGraph(const Volume& volume, const SlicePlan& plan, std::vector<PlaneLoops>& planes,
                               double minThickness, double maxShapeChange, const std::function<int(double w)>& addPlane,
                               const std::function<void()>& dropLastPlane, const std::function<EulerProfile()>& cells)
{
    ContourGraph graph;
    const int original = static_cast<int>(planes.size());
    const GraphBuilder builder(volume, plan, planes, minThickness, maxShapeChange, addPlane, dropLastPlane);
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
    // than once (several objects, or specks beside one: a speck between two planes is a start and
    // an end that no plane shows) and the planes cover the box (the profile holds every voxel
    // layer of it: spheres 2e9 voxels apart would need 48 GB); a single tube would pay most of its
    // time for them.
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
    if (cells && (junctions || (starts > 1 && covered))) {
        const EulerProfile profile = cells();
        // Where the spacing stops short of the box's end, the voxel layers past the last plane can
        // hold what no plane meets (specks: five in a crop of the smoke), and the cells count it
        // there. The box's last voxel plane meets every such speck (each holds an inside voxel),
        // and the slab up to it is compared with the cells like any other.
        const double wLast = original > 0 ? planes[static_cast<std::size_t>(last)].w : 0.0;
        const double wEnd = volume.bboxMax()[plan.axis];
        if (original > 0 && wEnd > wLast && wLast == std::floor(wLast) &&
            profile.between(wLast, std::numeric_limits<double>::infinity()) != eulerOf(graph.afterLast)) {
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
                   const std::function<bool(const glm::dvec2&)>& blocked, Keyhole& keyhole)
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
    const double longest = 2.0 * slits.front().length + 4.0;
    double bestBlocked = std::numeric_limits<double>::infinity();
    for (const Slit& slit : slits) {
        if (bestBlocked == 0.0 || slit.length > longest) break; // the shortest unblocked slit is found
        const glm::dvec2 &w0 = wall[(slit.wall + walls - 1) % walls], &w1 = wall[slit.wall];
        const glm::dvec2 &h0 = hole[slit.hole], &h1 = hole[(slit.hole + 1) % holes];
        // The slit's quadrilateral, counterclockwise, with crossings w0-h0 and w1-h1.
        if (cross(w1 - w0, h1 - w0) + cross(h1 - w0, h0 - w0) <= 0.0 || segmentsCross(w0, h0, w1, h1)) continue;
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

} // namespace pipetile
