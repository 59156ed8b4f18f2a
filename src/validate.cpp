// pipetile — validate: checks of a mesh on its own (topology) and against the volume it came from.

#include <pipetile/error.h>
#include <pipetile/quality.h>
#include <pipetile/validate.h>
#include <pipetile/volume_grid.h>

#include <glm/geometric.hpp>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cmath>
#include <limits>
#include <numeric>
#include <unordered_map>
#include <unordered_set>

namespace pipetile {

namespace {

struct DirectedEdge {
    std::uint32_t lo, hi;
    bool forward; // runs lo -> hi in its triangle
    std::uint32_t face;
    bool operator<(const DirectedEdge& o) const { return lo != o.lo ? lo < o.lo : hi < o.hi; }
};

std::uint32_t findRoot(std::vector<std::uint32_t>& parent, std::uint32_t x)
{
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
}

} // namespace

Topology checkTopology(const TriangleMesh& mesh)
{
    Topology topo;
    const std::size_t faceCount = mesh.triangles.size();
    topo.triangles = static_cast<long long>(faceCount);
    std::vector<DirectedEdge> edges;
    edges.reserve(3 * faceCount);
    std::vector<char> used(mesh.vertices.size(), 0);
    for (std::uint32_t f = 0; f < faceCount; ++f) {
        const Triangle& t = mesh.triangles[f];
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t a = t[k], b = t[(k + 1) % 3];
            used[a] = 1;
            edges.push_back({std::min(a, b), std::max(a, b), a < b, f});
        }
        const glm::dvec3 &p = mesh.vertices[t[0]], &q = mesh.vertices[t[1]], &r = mesh.vertices[t[2]];
        topo.signedVolume += glm::dot(p, glm::cross(q, r)) / 6.0;
    }
    topo.vertices = std::count(used.begin(), used.end(), 1);
    std::sort(edges.begin(), edges.end());

    std::vector<std::uint32_t> parent(faceCount);
    std::iota(parent.begin(), parent.end(), 0u);
    // One group of equal sorted edges per mesh edge. Iterators, not indices: with indices gcc
    // could not rule out a group of 2^60 edges and warned (-Waggressive-loop-optimizations).
    for (auto first = edges.begin(); first != edges.end();) {
        const DirectedEdge edge = *first;
        const auto last = std::find_if(first, edges.end(), [&](const DirectedEdge& e) { return edge < e; });
        const std::ptrdiff_t count = last - first;
        ++topo.edges;
        if (count == 1) {
            ++topo.boundaryEdges;
        } else if (count > 2) {
            if (topo.nonManifoldEdges++ == 0) topo.firstNonManifoldEdge = {edge.lo, edge.hi};
        } else if (edge.forward == first[1].forward) {
            ++topo.misorientedEdges;
        }
        for (auto other = first + 1; other != last; ++other)
            parent[findRoot(parent, other->face)] = findRoot(parent, edge.face);
        first = last;
    }
    for (std::uint32_t f = 0; f < faceCount; ++f) topo.components += findRoot(parent, f) == f ? 1 : 0;

    // A vertex is manifold when its triangles form a single fan: walking from triangle to
    // triangle across edges at the vertex reaches them all.
    std::vector<std::vector<std::uint32_t>> around(mesh.vertices.size());
    for (std::uint32_t f = 0; f < faceCount; ++f)
        for (std::uint32_t v : mesh.triangles[f]) around[v].push_back(f);
    for (std::size_t v = 0; v < around.size(); ++v) {
        const std::vector<std::uint32_t>& fan = around[v];
        if (fan.size() < 2) continue;
        // Union the triangles around v that share an edge through v.
        std::vector<std::uint32_t> local(fan.size());
        std::iota(local.begin(), local.end(), 0u);
        std::vector<std::pair<std::uint32_t, std::uint32_t>> spokes; // (other vertex, local face)
        for (std::uint32_t k = 0; k < fan.size(); ++k)
            for (std::uint32_t w : mesh.triangles[fan[k]])
                if (w != v) spokes.push_back({w, k});
        std::sort(spokes.begin(), spokes.end());
        for (std::size_t k = 1; k < spokes.size(); ++k)
            if (spokes[k].first == spokes[k - 1].first)
                local[findRoot(local, spokes[k].second)] = findRoot(local, spokes[k - 1].second);
        int groups = 0;
        for (std::uint32_t k = 0; k < fan.size(); ++k) groups += findRoot(local, k) == k ? 1 : 0;
        if (groups > 1 && topo.nonManifoldVertices++ == 0) topo.firstNonManifoldVertex = static_cast<long long>(v);
    }
    topo.euler = topo.vertices - topo.edges + topo.triangles;
    return topo;
}

DistanceStats levelSetDistanceAtVertices(const Volume& volume, const TriangleMesh& mesh)
{
    if (volume.volumeClass() != VolumeClass::LevelSet)
        throw Error("'" + volume.source() + "', grid '" + printableName(volume.gridName()) +
                    "': a fog volume's values are not distances; compare against the isosurface instead");
    DistanceStats stats;
    double sum = 0.0, sum2 = 0.0;
    for (const glm::dvec3& p : mesh.vertices) {
        const double d = std::abs(volume.signedField(p));
        stats.max = std::max(stats.max, d);
        sum += d;
        sum2 += d * d;
    }
    stats.samples = static_cast<long long>(mesh.vertices.size());
    if (stats.samples > 0) {
        stats.mean = sum / stats.samples;
        stats.rms = std::sqrt(sum2 / stats.samples);
    }
    return stats;
}

TriangleQuality measureQuality(const TriangleMesh& mesh)
{
    TriangleQuality q;
    q.smallestAngle = 180.0;
    constexpr double kDegrees = 57.295779513082320876798154814105;
    for (const Triangle& t : mesh.triangles) {
        const glm::dvec3 &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
        const double area = 0.5 * glm::length(glm::cross(b - a, c - a));
        q.area += area;
        const double la = glm::length(b - c), lb = glm::length(c - a), lc = glm::length(a - b);
        const double longest = std::max(la, std::max(lb, lc));
        if (!(area > 1e-12 * longest * longest)) {
            ++q.degenerate;
            ++q.needles;
            continue;
        }
        // The smallest angle faces the shortest edge; the law of cosines, clamped for rounding.
        auto angle = [](double opposite, double x, double y) {
            return std::acos(std::clamp((x * x + y * y - opposite * opposite) / (2.0 * x * y), -1.0, 1.0));
        };
        const double smallest = std::min(angle(la, lb, lc), std::min(angle(lb, lc, la), angle(lc, la, lb)));
        q.smallestAngle = std::min(q.smallestAngle, smallest * kDegrees);
        if (smallest * kDegrees < kNeedleDegrees) ++q.needles;
        const double altitude = 2.0 * area / longest;
        q.largestAspect = std::max(q.largestAspect, longest / altitude * (std::sqrt(3.0) / 2.0));
    }
    if (mesh.triangles.empty()) q.smallestAngle = 0.0;
    return q;
}

SurfaceSamples sampleSurface(const TriangleMesh& mesh, double spacing)
{
    SurfaceSamples s;
    s.points = mesh.vertices;
    s.weights.assign(mesh.vertices.size(), 0.0);
    for (const Triangle& t : mesh.triangles) {
        const glm::dvec3 &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
        const double longest = std::max(glm::length(b - a), std::max(glm::length(c - b), glm::length(a - c)));
        const double area = 0.5 * glm::length(glm::cross(b - a, c - a));
        // About one sample per spacing^2 of area, and at least one per 4 spacings along the longest
        // edge so that long thin triangles are not sampled at their centre alone.
        const double divisions = std::max(std::sqrt(2.0 * area), 0.25 * longest) / spacing;
        const int k = std::max(1, std::min(1024, static_cast<int>(std::ceil(divisions))));
        const double part = area / (static_cast<double>(k) * k);
        // Centroids of the k^2 sub-triangles: (i + 1/3, j + 1/3) upright, (i + 2/3, j + 2/3) inverted.
        for (int i = 0; i < k; ++i)
            for (int j = 0; i + j < k; ++j) {
                for (int inverted = 0; inverted < (i + j + 1 < k ? 2 : 1); ++inverted) {
                    const double u = (i + (inverted ? 2.0 : 1.0) / 3.0) / k, v = (j + (inverted ? 2.0 : 1.0) / 3.0) / k;
                    s.points.push_back(a + u * (b - a) + v * (c - a));
                    s.weights.push_back(part);
                }
            }
    }
    return s;
}

TriangleMesh isosurface(const Volume& volume, double adaptivity, double* seconds)
{
    const auto start = std::chrono::steady_clock::now();
    // volumeToMesh stores float32 world positions, which at x = 10^6 round to 1/16. It meshes a
    // shallow copy whose transform moves the centre of the active box to the origin, and the
    // centre is added back in double: the reference is then as exact anywhere as near the origin.
    const openvdb::FloatGrid& grid = gridOf(volume);
    const glm::dvec3 centre = volume.indexToWorld(0.5 * (glm::dvec3(volume.bboxMin()) + glm::dvec3(volume.bboxMax())));
    openvdb::math::Transform::Ptr centred = grid.transform().copy();
    centred->postTranslate(openvdb::Vec3d(-centre.x, -centre.y, -centre.z));
    const openvdb::FloatGrid::ConstPtr shifted =
        openvdb::gridConstPtrCast<openvdb::FloatGrid>(grid.copyGridReplacingTransform(centred));
    std::vector<openvdb::Vec3s> points;
    std::vector<openvdb::Vec3I> triangles;
    std::vector<openvdb::Vec4I> quads;
    openvdb::tools::volumeToMesh(*shifted, points, triangles, quads, volume.iso(), adaptivity);
    TriangleMesh mesh;
    mesh.vertices.reserve(points.size());
    for (const openvdb::Vec3s& p : points) mesh.vertices.push_back(centre + glm::dvec3(p.x(), p.y(), p.z()));
    mesh.triangles.reserve(triangles.size() + 2 * quads.size());
    for (const openvdb::Vec3I& t : triangles) mesh.triangles.push_back({t[0], t[1], t[2]});
    for (const openvdb::Vec4I& q : quads) {
        mesh.triangles.push_back({q[0], q[1], q[2]});
        mesh.triangles.push_back({q[0], q[2], q[3]});
    }
    if (seconds) *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return mesh;
}

namespace {

namespace vtm = openvdb::tools::volume_to_mesh_internal;

// The face a cell shares with its neighbour one step along x, y or z: for each of the face's four
// edges, its number in the cell's table row and in the neighbour's (VolumeToMesh.h numbers a
// cell's edges 1 to 12).
constexpr int kFaceEdges[3][4][2] = {
    {{2, 4}, {10, 9}, {6, 8}, {11, 12}}, // x: the cell's corners 1, 2, 5, 6 are the neighbour's 0, 3, 4, 7
    {{5, 1}, {6, 2}, {7, 3}, {8, 4}},    // y: 4, 5, 6, 7 are 0, 1, 2, 3
    {{3, 1}, {11, 10}, {7, 5}, {12, 9}}, // z: 2, 3, 6, 7 are 0, 1, 4, 5
};
// The edges leaving corner 0 along x, y and z: every grid edge is one cell's.
constexpr int kCornerEdges[3] = {1, 9, 4};
// VolumeToMesh.h's corner order: corner n lies at the cell's origin plus this.
constexpr int kCorners[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}, {0, 1, 0}, {1, 1, 0}, {1, 1, 1}, {0, 1, 1}};

// The origin of neighbour b (0..26: -1..1 blocks along x, y, z) of the 8^3 block at `origin`.
openvdb::Coord neighbourBlock(const openvdb::Coord& origin, int b)
{
    return origin + openvdb::Coord(8 * (b / 9 - 1), 8 * (b / 3 % 3 - 1), 8 * (b % 3 - 1));
}

// Whether every voxel of a block of 8^3 lies below the iso value (1), none does (0), or some (2).
using BlockSign = std::uint8_t;
constexpr BlockSign kMixed = 2;

// The values below iso around one leaf, [-1, 9]^3 about its origin, read through the leaves there
// (or the constant tile or background where there is none): the corners of every cell whose
// origin lies in [-1, 8]^3.
struct CellBlock {
    openvdb::Coord origin;
    const openvdb::FloatTree::LeafNodeType* leaves[27] = {}; // blocks -1..1 along x, y, z
    std::uint32_t rows[11][11] = {};                         // [x + 1][y + 1], bit z + 1: below iso
    static int block(int local) { return local < 0 ? 0 : local < 8 ? 1 : 2; }
    std::uint32_t row(int x, int y) const { return rows[x + 1][y + 1]; }
    const openvdb::FloatTree::LeafNodeType* leafAt(int x, int y, int z) const
    {
        return leaves[(block(x) * 3 + block(y)) * 3 + block(z)];
    }
    CellBlock(const openvdb::FloatGrid::ConstAccessor& accessor, const openvdb::Coord& leafOrigin, float iso)
        : origin(leafOrigin)
    {
        float constant[27];
        for (int b = 0; b < 27; ++b) {
            const openvdb::Coord corner = neighbourBlock(origin, b);
            leaves[b] = accessor.probeConstLeaf(corner);
            constant[b] = accessor.getValue(corner);
        }
        for (int x = -1; x <= 9; ++x)
            for (int y = -1; y <= 9; ++y) {
                const int bxy = (block(x) * 3 + block(y)) * 3;
                const openvdb::Index base = ((x & 7) << 6) | ((y & 7) << 3);
                std::uint32_t bits = 0;
                for (int z = -1; z <= 9; ++z) {
                    const int b = bxy + block(z);
                    const float value = leaves[b] ? leaves[b]->getValue(base | (z & 7)) : constant[b];
                    bits |= static_cast<std::uint32_t>(vtm::isInsideValue(value, iso)) << (z + 1);
                }
                rows[x + 1][y + 1] = bits;
            }
    }
    // A cell's sign bits as volumeToMesh reads them, with an ambiguous face's signs complemented
    // where the neighbour across it is ambiguous there too (read through the accessor: rare).
    std::uint8_t signs(int x, int y, int z, const openvdb::FloatGrid::ConstAccessor& accessor, float iso) const
    {
        std::uint8_t s = 0;
        for (int n = 0; n < 8; ++n)
            s |= static_cast<std::uint8_t>(
                ((row(x + kCorners[n][0], y + kCorners[n][1]) >> (z + 1 + kCorners[n][2])) & 1) << n);
        if (s != 0 && s != 0xFF && vtm::sAmbiguousFace[s] != 0)
            vtm::correctCellSigns(s, vtm::sAmbiguousFace[s], accessor, origin + openvdb::Coord(x, y, z), iso);
        return s;
    }
};

BlockSign blockSign(const openvdb::FloatTree::LeafNodeType& leaf, float iso)
{
    bool some = false, all = true;
    for (auto it = leaf.cbeginValueAll(); it; ++it) {
        const bool b = vtm::isInsideValue(*it, iso);
        some = some || b;
        all = all && b;
    }
    return all ? 1 : some ? kMixed : 0;
}

// V, E and F of the isosurface as volumeToMesh meshes it (vertices, edges, faces), per cell layer
// along one axis: layer k holds the cells whose origin lies at k on it, an edge between two cells
// belongs to the higher one's layer, and a face to the layer of the cell it is counted at (the
// other cells around its grid edge lie in that layer or below). So the sum over layers up to k is
// the Euler characteristic of the mesh's part whose vertices lie in cells below k + 1.
// Also, per voxel plane, its voxels whose two neighbours along the axis both lie on the other
// side (what = 3): only where there are some can a speck or void lie wholly between the planes
// either side of it (EulerProfile::lone).
struct LayerCounts {
    int axis = 0, first = 0;
    std::vector<std::array<long long, 4>> layers;
    void add(int layer, int what, long long count) { layers[static_cast<std::size_t>(layer - first)][what] += count; }
};

// Adds the counts of the crossing cells that belong to `leaf`: one vertex per edge group, one
// edge per distinct pair of groups joined across a face, one face per crossing grid edge.
void countLeafCells(const openvdb::FloatTree::LeafNodeType& leaf, const openvdb::FloatGrid::ConstAccessor& accessor,
                    float iso, LayerCounts& counts)
{
    const CellBlock cells(accessor, leaf.origin(), iso);
    for (int x = 0; x < 8; ++x)
        for (int y = 0; y < 8; ++y) {
            // Row bit z + 1 is voxel z: along z its neighbours are the bits beside it.
            const std::uint32_t r = cells.row(x, y);
            const std::uint32_t before = counts.axis == 0   ? cells.row(x - 1, y)
                                         : counts.axis == 1 ? cells.row(x, y - 1)
                                                            : r << 1;
            const std::uint32_t after = counts.axis == 0   ? cells.row(x + 1, y)
                                        : counts.axis == 1 ? cells.row(x, y + 1)
                                                           : r >> 1;
            for (std::uint32_t lone = ((r ^ before) & (r ^ after)) >> 1 & 0xFF; lone != 0; lone &= lone - 1)
                counts.add((leaf.origin() + openvdb::Coord(x, y, __builtin_ctz(lone)))[counts.axis], 3, 1);
        }
    for (int x = -1; x < 8; ++x)
        for (int y = -1; y < 8; ++y) {
            // The cells of this row along z whose corners are not all on one side.
            const std::uint32_t r0 = cells.row(x, y), r1 = cells.row(x + 1, y), r2 = cells.row(x, y + 1),
                                r3 = cells.row(x + 1, y + 1);
            const std::uint32_t any = r0 | r1 | r2 | r3, all = r0 & r1 & r2 & r3;
            std::uint32_t crossing = ((any | any >> 1) & ~(all & all >> 1)) & 0x1FF; // z = -1..7
            for (; crossing != 0; crossing &= crossing - 1) {
                const int z = __builtin_ctz(crossing) - 1;
                // A cell belongs to the leaf of its first corner that lies in one (every crossing
                // lies in a leaf: the volume's active tiles are voxelized).
                if (x < 0 || y < 0 || z < 0) {
                    int n = 0;
                    while (n < 8 && !cells.leafAt(x + kCorners[n][0], y + kCorners[n][1], z + kCorners[n][2])) ++n;
                    if (n == 8 || cells.leafAt(x + kCorners[n][0], y + kCorners[n][1], z + kCorners[n][2]) != &leaf)
                        continue;
                }
                const int layer = (leaf.origin() + openvdb::Coord(x, y, z))[counts.axis];
                const std::uint8_t signs = cells.signs(x, y, z, accessor, iso);
                counts.add(layer, 0, vtm::sEdgeGroupTable[signs][0]);
                for (int axis = 0; axis < 3; ++axis) {
                    if (vtm::sEdgeGroupTable[signs][kCornerEdges[axis]] != 0) counts.add(layer, 2, 1);
                    // Groups of this cell and the next joined across their face, each pair once.
                    int pairs[4], count = 0;
                    std::uint8_t next = 0;
                    for (const auto& edge : kFaceEdges[axis]) {
                        const int mine = vtm::sEdgeGroupTable[signs][edge[0]];
                        if (mine == 0) continue;
                        if (count == 0)
                            next = cells.signs(x + (axis == 0), y + (axis == 1), z + (axis == 2), accessor, iso);
                        const int pair = mine * 16 + vtm::sEdgeGroupTable[next][edge[1]];
                        if (std::find(pairs, pairs + count, pair) == pairs + count) pairs[count++] = pair;
                    }
                    counts.add(layer + (axis == counts.axis ? 1 : 0), 1, count);
                }
            }
        }
}

} // namespace

namespace {

// Whether the region of voxels on `seed`'s side of the isovalue, 6-connected, stays within the voxel
// layers strictly between the planes `below` and `above` (index w along `axis`): none of its
// voxels has a neighbour on its side on or past either plane, through which a plane would meet it,
// nor outside `box` (the active box grown by a voxel: past it lies the air around the object, no
// void). Also true past kMostVoxels voxels (a caller then looks closer rather than trusting a guess).
bool confinedBetween(const openvdb::FloatGrid::ConstAccessor& accessor, const openvdb::Coord& seed, float iso, int axis,
                     double below, double above, const openvdb::CoordBBox& box)
{
    constexpr std::size_t kMostVoxels = std::size_t(1) << 16;
    const bool side = vtm::isInsideValue(accessor.getValue(seed), iso);
    std::vector<openvdb::Coord> stack{seed};
    std::unordered_set<openvdb::Coord> seen{seed};
    while (!stack.empty()) {
        const openvdb::Coord c = stack.back();
        stack.pop_back();
        for (int n = 0; n < 6; ++n) {
            openvdb::Coord q = c;
            q[n / 2] += n % 2 == 0 ? 1 : -1;
            if (vtm::isInsideValue(accessor.getValue(q), iso) != side) continue;
            if (q[axis] <= below || q[axis] >= above) return false; // two voxels on one side across a plane
            if (!box.isInside(q)) return false;                     // the air around the object
            if (!seen.insert(q).second) continue;
            if (seen.size() > kMostVoxels) return true;
            stack.push_back(q);
        }
    }
    return true;
}

} // namespace

bool regionBetweenPlanes(const Volume& volume, int axis, const std::vector<double>& planes)
{
    // Voxels outside the leaves lie in tiles, 8 voxels or more across, which planes up to 8 voxels
    // apart always meet; farther apart, a region of tiles could lie between them.
    constexpr double kTile = 8.0;
    for (std::size_t k = 1; k < planes.size(); ++k)
        if (planes[k] - planes[k - 1] > kTile) return true;
    const openvdb::FloatGrid& grid = gridOf(volume);
    const float iso = static_cast<float>(volume.iso());
    const glm::ivec3 lo = volume.bboxMin() - 1, hi = volume.bboxMax() + 1;
    const openvdb::CoordBBox box(openvdb::Coord(lo.x, lo.y, lo.z), openvdb::Coord(hi.x, hi.y, hi.z));
    std::vector<const openvdb::FloatTree::LeafNodeType*> leaves;
    for (auto leaf = grid.tree().cbeginLeaf(); leaf; ++leaf) leaves.push_back(&*leaf);
    const unsigned shift = 3u * static_cast<unsigned>(2 - axis); // a leaf's offset: x << 6 | y << 3 | z
    std::atomic<bool> found{false};
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leaves.size()), [&](const tbb::blocked_range<std::size_t>& r) {
        const openvdb::FloatGrid::ConstAccessor accessor = grid.getConstAccessor();
        const auto sideOf = [&](const openvdb::Coord& ijk) { return vtm::isInsideValue(accessor.getValue(ijk), iso); };
        for (std::size_t i = r.begin(); i != r.end() && !found.load(std::memory_order_relaxed); ++i) {
            const float* values = leaves[i]->buffer().data();
            for (openvdb::Index n = 0; n < openvdb::FloatTree::LeafNodeType::SIZE && !found; ++n) {
                const bool side = vtm::isInsideValue(values[n], iso);
                // Not where a run along the axis starts: the voxel before is on the same side (in
                // this leaf, a stride of 64, 8 or 1 back along x, y, z).
                const bool first = ((n >> shift) & 7u) == 0;
                if (!first && vtm::isInsideValue(values[n - (1u << shift)], iso) == side) continue;
                const openvdb::Coord ijk = leaves[i]->offsetToGlobalCoord(n);
                openvdb::Coord step = ijk;
                step[axis] -= 1;
                if (first && sideOf(step) == side) continue;
                const auto next = std::lower_bound(planes.begin(), planes.end(), static_cast<double>(ijk[axis]));
                const double above = next == planes.end() ? std::numeric_limits<double>::infinity() : *next;
                if (above == ijk[axis]) continue; // on a plane
                // Most runs reach the next plane on their side (a tube's wall), or the air past the
                // box: met.
                const double end = std::min(above, static_cast<double>(hi[axis]));
                step = ijk;
                while (step[axis] + 1 < end && sideOf(step.offsetBy(axis == 0, axis == 1, axis == 2)) == side)
                    step[axis] += 1;
                step[axis] += 1;
                if (step[axis] >= end && sideOf(step) == side) continue;
                const double below = next == planes.begin() ? -std::numeric_limits<double>::infinity() : *(next - 1);
                if (confinedBetween(accessor, ijk, iso, axis, below, above, box)) found = true;
            }
        }
    });
    return found;
}

EulerProfile isosurfaceEulerProfile(const Volume& volume, int axis)
{
    const openvdb::FloatGrid& grid = gridOf(volume);
    const openvdb::FloatGrid::ConstAccessor accessor = grid.getConstAccessor();
    const float iso = static_cast<float>(volume.iso());
    const openvdb::FloatTree& tree = grid.tree();
    // A block is all below, all above, or mixed: a leaf whose block and its 26 neighbours agree
    // has no crossing cell, and most of a level set's narrow band is such leaves.
    std::unordered_map<openvdb::Coord, BlockSign> signOf;
    for (auto leaf = tree.cbeginLeaf(); leaf; ++leaf) signOf.emplace(leaf->origin(), blockSign(*leaf, iso));
    auto neighbourSign = [&](const openvdb::Coord& origin) -> BlockSign {
        const auto it = signOf.find(origin);
        return it != signOf.end() ? it->second : vtm::isInsideValue(accessor.getValue(origin), iso);
    };
    std::vector<const openvdb::FloatTree::LeafNodeType*> crossed;
    int lo = std::numeric_limits<int>::max(), hi = std::numeric_limits<int>::min();
    for (auto leaf = tree.cbeginLeaf(); leaf; ++leaf) {
        const openvdb::Coord origin = leaf->origin();
        const BlockSign own = signOf[origin];
        bool uniform = own != kMixed;
        for (int b = 0; b < 27 && uniform; ++b) uniform = neighbourSign(neighbourBlock(origin, b)) == own;
        if (uniform) continue;
        crossed.push_back(&*leaf);
        lo = std::min(lo, origin[axis]);
        hi = std::max(hi, origin[axis]);
    }
    EulerProfile profile;
    if (crossed.empty()) return profile;
    // A leaf's cells lie at its origin - 1 .. + 7; an edge counted there may belong to + 8.
    LayerCounts zero{axis, lo - 1, std::vector<std::array<long long, 4>>(static_cast<std::size_t>(hi - lo + 10))};
    // Summed over the leaves in parallel (an accessor per task: they are not shared).
    const LayerCounts counts = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, crossed.size()), zero,
        [&](const tbb::blocked_range<std::size_t>& range, LayerCounts sum) {
            const openvdb::FloatGrid::ConstAccessor accessor = grid.getConstAccessor();
            for (std::size_t i = range.begin(); i != range.end(); ++i) countLeafCells(*crossed[i], accessor, iso, sum);
            return sum;
        },
        [](LayerCounts a, const LayerCounts& b) {
            for (std::size_t k = 0; k < a.layers.size(); ++k)
                for (int what = 0; what < 4; ++what) a.layers[k][what] += b.layers[k][what];
            return a;
        });
    profile.first = counts.first;
    for (const auto& [vertices, edges, faces, lone] : counts.layers) {
        profile.layers.push_back(vertices - edges + faces);
        profile.lone.push_back(lone);
    }
    return profile;
}

long long isosurfaceEuler(const Volume& volume)
{
    return isosurfaceEulerProfile(volume, 0).total();
}

std::vector<EulerDifference> eulerDifferences(const EulerProfile& profile, const ContourGraph& graph,
                                              const std::vector<double>& planeW)
{
    std::vector<EulerDifference> changes;
    if (graph.slabs.empty()) return changes;
    const double none = std::numeric_limits<double>::infinity();
    double wBefore = -none;
    long long slabs = 0, cells = 0, difference = 0;
    const auto compare = [&](double w, long long cellsBelow) {
        if (cellsBelow - slabs != difference) changes.push_back({wBefore, w, cellsBelow - slabs - difference});
        difference = cellsBelow - slabs;
        wBefore = w;
    };
    // The pieces before the first plane start the surface; each slab adds its pieces'.
    for (const SlabPiece& p : graph.beforeFirst) slabs += p.euler();
    std::size_t layer = 0;
    for (std::size_t k = 0; k < graph.order.size(); ++k) {
        if (k > 0)
            for (const SlabPiece& p : graph.slabs[k - 1].pieces) slabs += p.euler();
        const double w = planeW[static_cast<std::size_t>(graph.order[k])];
        if (w != std::floor(w)) continue; // the cells part the isosurface at voxel planes only
        for (; layer < profile.layers.size() && profile.first + static_cast<double>(layer) < w; ++layer)
            cells += profile.layers[layer];
        compare(w, cells);
    }
    for (const SlabPiece& p : graph.afterLast) slabs += p.euler();
    compare(none, profile.total());
    return changes;
}

std::vector<glm::dvec3> errorColors(const std::vector<double>& distances, double redAt)
{
    // blue -> green -> yellow -> red, evenly over [0, redAt].
    static const glm::dvec3 kStops[4] = {{0.1, 0.2, 1.0}, {0.1, 0.8, 0.2}, {1.0, 0.9, 0.1}, {1.0, 0.1, 0.1}};
    std::vector<glm::dvec3> colors;
    colors.reserve(distances.size());
    for (double d : distances) {
        const double x = std::clamp(redAt > 0.0 ? d / redAt : 1.0, 0.0, 1.0) * 3.0;
        const int i = std::min(2, static_cast<int>(x));
        colors.push_back(kStops[i] + (x - i) * (kStops[i + 1] - kStops[i]));
    }
    return colors;
}

namespace {

// A bounding-volume hierarchy over the triangles of a mesh, for exact nearest-triangle queries.
class TriangleBvh {
public:
    explicit TriangleBvh(const TriangleMesh& mesh) : mMesh(&mesh)
    {
        const std::size_t n = mesh.triangles.size();
        mOrder.resize(n);
        std::iota(mOrder.begin(), mOrder.end(), 0u);
        mCentroids.resize(n);
        for (std::size_t i = 0; i < n; ++i) {
            const Triangle& t = mesh.triangles[i];
            mCentroids[i] = (mesh.vertices[t[0]] + mesh.vertices[t[1]] + mesh.vertices[t[2]]) / 3.0;
        }
        if (n > 0) {
            mNodes.reserve(2 * (n / 2 + 1));
            mNodes.resize(1);
            build(0, 0, static_cast<std::uint32_t>(n));
        }
    }

    /// Distance from p to the nearest triangle.
    double distance(const glm::dvec3& p) const
    {
        double best2 = std::numeric_limits<double>::infinity();
        if (mNodes.empty()) return best2;
        std::uint32_t stack[128]; // depth is log2(n / 4) + 1; each level adds at most one entry
        int top = 0;
        stack[top++] = 0;
        while (top > 0) {
            const Node& node = mNodes[stack[--top]];
            if (boxDistance2(node, p) >= best2) continue;
            if (node.count > 0) {
                for (std::uint32_t k = node.first; k < node.first + node.count; ++k) {
                    const Triangle& t = mMesh->triangles[mOrder[k]];
                    const glm::dvec3 q =
                        closestOnTriangle(p, mMesh->vertices[t[0]], mMesh->vertices[t[1]], mMesh->vertices[t[2]]);
                    best2 = std::min(best2, glm::dot(p - q, p - q));
                }
                continue;
            }
            // Visit the nearer child first: it tightens the bound sooner.
            const std::uint32_t l = node.first, r = node.first + 1;
            const bool leftFirst = boxDistance2(mNodes[l], p) <= boxDistance2(mNodes[r], p);
            stack[top++] = leftFirst ? r : l;
            stack[top++] = leftFirst ? l : r;
        }
        return std::sqrt(best2);
    }

private:
    struct Node {
        glm::dvec3 lo, hi;
        std::uint32_t first = 0; // leaf: first index into mOrder; inner: index of the left child
        std::uint32_t count = 0; // triangles in a leaf, 0 for an inner node
    };

    static double boxDistance2(const Node& n, const glm::dvec3& p)
    {
        const glm::dvec3 d = glm::max(glm::max(n.lo - p, p - n.hi), glm::dvec3(0.0));
        return glm::dot(d, d);
    }

    // Fills node `index` (already allocated) for triangles [begin, end); children are allocated
    // next to each other, so an inner node needs only the index of its left child.
    void build(std::uint32_t index, std::uint32_t begin, std::uint32_t end)
    {
        glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
        glm::dvec3 clo = lo, chi = hi;
        for (std::uint32_t k = begin; k < end; ++k) {
            for (std::uint32_t v : mMesh->triangles[mOrder[k]]) {
                lo = glm::min(lo, mMesh->vertices[v]);
                hi = glm::max(hi, mMesh->vertices[v]);
            }
            clo = glm::min(clo, mCentroids[mOrder[k]]);
            chi = glm::max(chi, mCentroids[mOrder[k]]);
        }
        mNodes[index].lo = lo;
        mNodes[index].hi = hi;
        if (end - begin <= 4) {
            mNodes[index].first = begin;
            mNodes[index].count = end - begin;
            return;
        }
        const glm::dvec3 extent = chi - clo;
        const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
        const std::uint32_t mid = begin + (end - begin) / 2;
        std::nth_element(mOrder.begin() + begin, mOrder.begin() + mid, mOrder.begin() + end,
                         [&](std::uint32_t a, std::uint32_t b) { return mCentroids[a][axis] < mCentroids[b][axis]; });
        const std::uint32_t children = static_cast<std::uint32_t>(mNodes.size());
        mNodes.resize(mNodes.size() + 2);
        mNodes[index].first = children;
        build(children, begin, mid);
        build(children + 1, mid, end);
    }

    const TriangleMesh* mMesh;
    std::vector<std::uint32_t> mOrder;
    std::vector<glm::dvec3> mCentroids;
    std::vector<Node> mNodes;
};

// Distances from weighted samples to a mesh, in parallel; the reduction runs in sample order, so
// the result does not depend on the thread count.
DistanceStats distancesTo(const TriangleBvh& target, const SurfaceSamples& samples, int threads,
                          std::vector<double>* perSample = nullptr)
{
    std::vector<double> d(samples.points.size());
    tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
    arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, d.size(), 256),
                          [&](const tbb::blocked_range<std::size_t>& r) {
                              for (std::size_t i = r.begin(); i < r.end(); ++i)
                                  d[i] = target.distance(samples.points[i]);
                          });
    });
    DistanceStats stats;
    double weight = 0.0, sum = 0.0, sum2 = 0.0;
    for (std::size_t i = 0; i < d.size(); ++i) {
        stats.max = std::max(stats.max, d[i]);
        weight += samples.weights[i];
        sum += samples.weights[i] * d[i];
        sum2 += samples.weights[i] * d[i] * d[i];
    }
    stats.samples = static_cast<long long>(d.size());
    if (weight > 0.0) {
        stats.mean = sum / weight;
        stats.rms = std::sqrt(sum2 / weight);
    }
    if (perSample) *perSample = std::move(d);
    return stats;
}

double totalWeight(const SurfaceSamples& s)
{
    return std::accumulate(s.weights.begin(), s.weights.end(), 0.0);
}

} // namespace

struct Validator::Impl {
    Volume volume;
    ValidationOptions options;
    TriangleMesh reference;
    double referenceSeconds = 0.0;
    std::unique_ptr<TriangleBvh> referenceBvh;
    SurfaceSamples referenceSamples;
    double referenceArea = 0.0, referenceVolume = 0.0;
};

Validator::Validator(const Volume& volume, const ValidationOptions& options) : mImpl(std::make_unique<Impl>())
{
    mImpl->volume = volume;
    mImpl->options = options;
    mImpl->reference = isosurface(volume, 0.0, &mImpl->referenceSeconds);
    mImpl->referenceBvh = std::make_unique<TriangleBvh>(mImpl->reference);
    mImpl->referenceSamples = sampleSurface(mImpl->reference, options.sampleSpacingVoxels * volume.smallestVoxel());
    mImpl->referenceArea = totalWeight(mImpl->referenceSamples);
    // Fog volumes come out of volumeToMesh inside out: the enclosed volume is the magnitude.
    double volume6 = 0.0;
    for (const Triangle& t : mImpl->reference.triangles) {
        const glm::dvec3 &p = mImpl->reference.vertices[t[0]], &q = mImpl->reference.vertices[t[1]],
                         &r = mImpl->reference.vertices[t[2]];
        volume6 += glm::dot(p, glm::cross(q, r));
    }
    mImpl->referenceVolume = std::abs(volume6) / 6.0;
}

Validator::~Validator() = default;

const TriangleMesh& Validator::reference() const
{
    return mImpl->reference;
}
double Validator::referenceSeconds() const
{
    return mImpl->referenceSeconds;
}

Validation Validator::validate(const TriangleMesh& mesh) const
{
    if (mesh.triangles.empty()) throw Error("the mesh has no triangles; nothing to validate");
    const auto start = std::chrono::steady_clock::now();
    const Volume& volume = mImpl->volume;
    Validation v;
    v.voxel = volume.smallestVoxel();
    v.topology = checkTopology(mesh);
    v.quality = measureQuality(mesh);
    v.referenceArea = mImpl->referenceArea;
    v.referenceVolume = mImpl->referenceVolume;
    v.referenceTriangles = static_cast<long long>(mImpl->reference.triangles.size());
    v.referenceSeconds = mImpl->referenceSeconds;

    const SurfaceSamples samples = sampleSurface(mesh, mImpl->options.sampleSpacingVoxels * v.voxel);
    std::vector<double> perSample;
    v.meshToReference = distancesTo(*mImpl->referenceBvh, samples, mImpl->options.threads, &perSample);
    v.vertexDistance.assign(perSample.begin(), perSample.begin() + static_cast<std::ptrdiff_t>(mesh.vertices.size()));
    if (!mImpl->reference.triangles.empty()) {
        const TriangleBvh meshBvh(mesh);
        v.referenceToMesh = distancesTo(meshBvh, mImpl->referenceSamples, mImpl->options.threads);
    }
    // Symmetric: the larger maximum; mean and RMS over both sample sets, weighted by area.
    const double wa = totalWeight(samples), wb = totalWeight(mImpl->referenceSamples);
    v.symmetric.max = std::max(v.meshToReference.max, v.referenceToMesh.max);
    v.symmetric.samples = v.meshToReference.samples + v.referenceToMesh.samples;
    if (wa + wb > 0.0) {
        v.symmetric.mean = (wa * v.meshToReference.mean + wb * v.referenceToMesh.mean) / (wa + wb);
        v.symmetric.rms = std::sqrt(
            (wa * v.meshToReference.rms * v.meshToReference.rms + wb * v.referenceToMesh.rms * v.referenceToMesh.rms) /
            (wa + wb));
    }
    if (volume.volumeClass() == VolumeClass::LevelSet) {
        v.hasLevelSet = true;
        // |value - iso| at each sample, read through one accessor per task.
        std::vector<double> phi(samples.points.size());
        tbb::task_arena arena(mImpl->options.threads > 0 ? mImpl->options.threads : tbb::task_arena::automatic);
        arena.execute([&] {
            tbb::parallel_for(
                tbb::blocked_range<std::size_t>(0, phi.size(), 1024), [&](const tbb::blocked_range<std::size_t>& r) {
                    // The sampler keeps a reference to the accessor: it must outlive the sampler.
                    const openvdb::FloatGrid::ConstAccessor accessor = gridOf(volume).getConstAccessor();
                    const openvdb::tools::GridSampler<openvdb::FloatGrid::ConstAccessor, openvdb::tools::BoxSampler>
                        sampler(accessor, gridOf(volume).transform());
                    for (std::size_t i = r.begin(); i < r.end(); ++i) {
                        const glm::dvec3& p = samples.points[i];
                        phi[i] = std::abs(sampler.wsSample(openvdb::Vec3d(p.x, p.y, p.z)) - volume.iso());
                    }
                });
        });
        double weight = 0.0, sum = 0.0, sum2 = 0.0;
        for (std::size_t i = 0; i < samples.points.size(); ++i) {
            const double d = phi[i];
            v.levelSet.max = std::max(v.levelSet.max, d);
            weight += samples.weights[i];
            sum += samples.weights[i] * d;
            sum2 += samples.weights[i] * d * d;
        }
        v.levelSet.samples = static_cast<long long>(samples.points.size());
        if (weight > 0.0) {
            v.levelSet.mean = sum / weight;
            v.levelSet.rms = std::sqrt(sum2 / weight);
        }
    }
    v.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return v;
}

} // namespace pipetile
