// pipetile — validate: checks of a mesh on its own (topology) and against the volume it came from.

#include <pipetile/error.h>
#include <pipetile/validate.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>

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
    for (std::size_t i = 0; i < edges.size();) {
        std::size_t j = i;
        while (j < edges.size() && edges[j].lo == edges[i].lo && edges[j].hi == edges[i].hi) ++j;
        const std::size_t count = j - i;
        ++topo.edges;
        if (count == 1) ++topo.boundaryEdges;
        else if (count > 2) ++topo.nonManifoldEdges;
        else if (edges[i].forward == edges[i + 1].forward) ++topo.misorientedEdges;
        for (std::size_t k = i + 1; k < j; ++k)
            parent[findRoot(parent, edges[k].face)] = findRoot(parent, edges[i].face);
        i = j;
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
        if (groups > 1) ++topo.nonManifoldVertices;
    }
    topo.euler = topo.vertices - topo.edges + topo.triangles;
    return topo;
}

DistanceStats levelSetDistanceAtVertices(const Volume& volume, const TriangleMesh& mesh)
{
    if (volume.volumeClass() != VolumeClass::LevelSet)
        throw Error("'" + volume.source() + "', grid '" + volume.gridName() +
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

} // namespace pipetile
