// Tests of the contour graph (correspondence through the slab, events, junctions) and of the
// topology of every level on phantoms whose Euler characteristic is known (samples/phantoms.h).
#include "phantoms.h"
#include "test_util.h"

#include <pipetile/graph.h>
#include <pipetile/multires.h>
#include <pipetile/quality.h>
#include <pipetile/validate.h>

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <deque>
#include <cmath>
#include <functional>
#include <initializer_list>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <vector>

using namespace pipetile;

namespace {

constexpr double kPi = 3.14159265358979323846;

// Signed volume of each connected piece of a closed mesh (divergence theorem): positive for a
// shell facing outward, negative for a void's shell facing into its cavity.
std::vector<double> shellVolumes(const TriangleMesh& mesh)
{
    std::vector<int> parent(mesh.vertices.size());
    for (std::size_t i = 0; i < parent.size(); ++i) parent[i] = static_cast<int>(i);
    auto root = [&](int v) {
        while (parent[v] != v) v = parent[v] = parent[parent[v]];
        return v;
    };
    for (const Triangle& t : mesh.triangles) {
        parent[root(t[1])] = root(t[0]);
        parent[root(t[2])] = root(t[0]);
    }
    std::map<int, double> volume;
    for (const Triangle& t : mesh.triangles) {
        const glm::dvec3 a = mesh.vertices[t[0]], b = mesh.vertices[t[1]], c = mesh.vertices[t[2]];
        volume[root(t[0])] += glm::dot(a, glm::cross(b, c)) / 6.0;
    }
    std::vector<double> result;
    for (const auto& [id, v] : volume) result.push_back(v);
    return result;
}

const samples::SampleInfo& infoOf(const std::string& name)
{
    for (const samples::SampleInfo& info : samples::sampleList())
        if (info.name == name) return info;
    throw std::runtime_error("no sample " + name);
}

// Every level, refined from the one before, given to `check`: each equal to the level built from
// scratch, its vertices a subset of the next level's bit for bit. Returns the top level.
TriangleMesh expectNestedLevels(const Reconstruction& reconstruction,
                                const std::function<void(const TriangleMesh& mesh)>& check)
{
    Refinement refinement(reconstruction);
    std::set<std::array<double, 3>> coarser;
    for (int level = 0;; ++level) {
        SCOPED_TRACE("level " + std::to_string(level));
        const TriangleMesh& mesh = refinement.mesh().mesh;
        check(mesh);
        const TriangleMesh scratch = reconstruction.buildLevel(level).mesh;
        EXPECT_TRUE(scratch.vertices == mesh.vertices && scratch.triangles == mesh.triangles)
            << "refining differs from building the level from scratch";
        std::set<std::array<double, 3>> here;
        for (const glm::dvec3& p : mesh.vertices) here.insert({p.x, p.y, p.z});
        long long lost = 0;
        for (const auto& p : coarser) lost += here.count(p) ? 0 : 1;
        EXPECT_EQ(lost, 0) << "vertices of the level below that this level lacks";
        coarser = std::move(here);
        if (!refinement.canRefine()) return mesh;
        refinement.refine();
    }
}

// Every level nested (expectNestedLevels): a closed, oriented 2-manifold with the phantom's
// Euler characteristic and number of surfaces (voids facing into their cavities); the events'
// contributions add up to the same Euler characteristic; the top level lies within one voxel of
// volumeToMesh's isosurface, both ways.
void expectIsosurfaceTopology(const std::string& name, int voids = 0, bool withinAVoxel = true)
{
    SCOPED_TRACE(name);
    const samples::SampleInfo& info = infoOf(name);
    const Volume& volume = test::cachedSample(name);
    const Reconstruction reconstruction(volume, MeshOptions{});
    EXPECT_EQ(reconstruction.stats().eventEuler, info.euler);
    EXPECT_EQ(reconstruction.stats().caps - reconstruction.stats().saddles, info.euler);
    EXPECT_EQ(reconstruction.stats().unresolvedEvents + reconstruction.stats().unresolvedJunctions, 0);
    const TriangleMesh top = expectNestedLevels(reconstruction, [&](const TriangleMesh& mesh) {
        const Topology t = checkTopology(mesh);
        EXPECT_TRUE(t.closed()) << t.boundaryEdges << " boundary edges";
        EXPECT_TRUE(t.manifold()) << t.nonManifoldEdges << " non-manifold edges, " << t.nonManifoldVertices
                                  << " non-manifold vertices";
        EXPECT_TRUE(t.oriented()) << t.misorientedEdges << " misoriented edges";
        EXPECT_EQ(t.euler, info.euler);
        EXPECT_EQ(t.components, info.components);
        int inward = 0;
        for (double v : shellVolumes(mesh)) inward += v < 0.0 ? 1 : 0;
        EXPECT_EQ(inward, voids);
    });
    if (!withinAVoxel) return;
    const Validation v = Validator(volume).validate(top);
    EXPECT_LE(v.symmetric.max, 1.0 * v.voxel);
    EXPECT_EQ(v.topology.euler, info.euler);
}

} // namespace

namespace {

// The loops of planes at `ws`, and each plane's PlaneLoops over them (with central points).
struct TracedPlanes {
    std::vector<std::vector<BoundaryLoop>> loops;
    std::vector<PlaneLoops> planes;
};
TracedPlanes tracePlanes(const Volume& volume, const SlicePlan& plan, std::initializer_list<double> ws)
{
    TracedPlanes traced;
    for (double w : ws) {
        traced.loops.push_back(traceBoundaries(SlicePlane(volume, plan, w)));
        traced.planes.push_back({w, {}, {}, {}});
    }
    for (std::size_t k = 0; k < traced.planes.size(); ++k)
        for (const BoundaryLoop& loop : traced.loops[k]) {
            traced.planes[k].loops.push_back(&loop);
            traced.planes[k].centers.push_back(centralPoint(loop));
        }
    return traced;
}

} // namespace

TEST(Graph, SlabPiecesOfAFork)
{
    // The Y's trunk (radius 12, axis x = y = 64) forks at z = 80 into two branches of radius 9
    // leaning 25 degrees out (sections 9 / cos 25 = 9.9 wide), whose sections part where their
    // centres, 60 (z - 80) / 64 apart, are 19.9 apart: z = 101. Planes at 72 and 112 are joined by
    // one piece with one loop below and two above (Euler characteristic -1: a pair of pants);
    // planes at 60 and 72, both below the fork, by a band.
    const Volume& volume = test::cachedSample("ybranch");
    const SlicePlan plan = planSlices(volume, SliceOptions{});
    const TracedPlanes traced = tracePlanes(volume, plan, {60.0, 72.0, 112.0});
    const std::vector<std::vector<BoundaryLoop>>& loops = traced.loops;
    const std::vector<PlaneLoops>& planes = traced.planes;
    ASSERT_EQ(loops[0].size(), 1u);
    ASSERT_EQ(loops[2].size(), 2u);
    const std::vector<SlabPiece> band = connectThroughSlab(volume, plan, planes[0], planes[1]);
    ASSERT_EQ(band.size(), 1u);
    EXPECT_EQ(band[0].kind, EventKind::Band);
    const std::vector<SlabPiece> fork = connectThroughSlab(volume, plan, planes[1], planes[2]);
    ASSERT_EQ(fork.size(), 1u);
    EXPECT_EQ(fork[0].kind, EventKind::Fork);
    EXPECT_EQ(fork[0].below, std::vector<int>{0});
    EXPECT_EQ(fork[0].above, (std::vector<int>{0, 1}));
    EXPECT_EQ(fork[0].euler(), -1);
    // Two tubes side by side are two bands, never one piece.
    const Volume& two = test::cachedSample("two-tubes");
    const SlicePlan twoPlan = planSlices(two, SliceOptions{});
    std::vector<BoundaryLoop> a = traceBoundaries(SlicePlane(two, twoPlan, 60.0));
    std::vector<BoundaryLoop> b = traceBoundaries(SlicePlane(two, twoPlan, 62.0));
    PlaneLoops below{60.0, {&a[0], &a[1]}, {centralPoint(a[0]), centralPoint(a[1])}, {}};
    PlaneLoops above{62.0, {&b[0], &b[1]}, {centralPoint(b[0]), centralPoint(b[1])}, {}};
    const std::vector<SlabPiece> pieces = connectThroughSlab(two, twoPlan, below, above);
    ASSERT_EQ(pieces.size(), 2u);
    for (const SlabPiece& piece : pieces) EXPECT_EQ(piece.kind, EventKind::Band);
}

// A piece's patch from its cells (graph.h, SlabPatch) on the Y: the band's is an annulus (Euler
// characteristic 0), the fork's a pair of pants (-1). Each meets its loops at every one of their
// points once, and its other vertices lie strictly between the planes; its triangles turn one way,
// so each of its edges but the loops' lies in two of them, once each way.
TEST(Graph, APatchHasItsPiecesTopologyAndFollowsItsLoops)
{
    const Volume& volume = test::cachedSample("ybranch");
    const SlicePlan plan = planSlices(volume, SliceOptions{});
    const TracedPlanes traced = tracePlanes(volume, plan, {60.0, 72.0, 112.0});
    const std::vector<PlaneLoops>& planes = traced.planes;
    for (const auto& [below, euler] : {std::pair{0, 0}, std::pair{1, -1}}) {
        SCOPED_TRACE(below);
        const PlaneLoops &a = planes[below], &b = planes[below + 1];
        const std::vector<SlabPiece> pieces = connectThroughSlab(volume, plan, a, b);
        ASSERT_EQ(pieces.size(), 1u);
        const std::optional<SlabPatch> patch = patchPieces(volume, plan, a, b, {&pieces[0]}).front();
        ASSERT_TRUE(patch);
        EXPECT_EQ(patch->euler, euler);
        std::map<std::tuple<int, int, int>, int> pointUses;
        for (const SlabPatch::Vertex& v : patch->vertices) {
            if (v.plane >= 0) {
                ++pointUses[{v.plane, v.loop, v.point}];
                continue;
            }
            EXPECT_GT(v.index[plan.axis], a.w);
            EXPECT_LT(v.index[plan.axis], b.w);
        }
        std::size_t points = 0;
        for (const PlaneLoops* plane : {&a, &b})
            for (const BoundaryLoop* loop : plane->loops) points += loop->points.size();
        EXPECT_EQ(pointUses.size(), points);
        for (const auto& [point, uses] : pointUses) EXPECT_EQ(uses, 1);
        std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;
        for (const auto& t : patch->triangles)
            for (int k = 0; k < 3; ++k) ++edges[{t[k], t[(k + 1) % 3]}];
        std::size_t open = 0;
        for (const auto& [edge, uses] : edges) {
            EXPECT_EQ(uses, 1);
            open += edges.count({edge.second, edge.first}) ? 0 : 1;
        }
        EXPECT_EQ(open, points); // one per crack, as many as the loops' points
    }
}

namespace {

// The contour graph of the Y on planes a voxel apart from 94 to the box's last voxel plane (the
// fork at z = 101, see SlabPiecesOfAFork, makes the graph compare its ranges with the cells, and
// planes stopping short of the box would have that plane added), with `cells` if given.
// `planeCount` receives how many planes it ends with.
ContourGraph yGraph(const std::function<EulerProfile()>& cells, std::size_t& planeCount)
{
    const Volume& volume = test::cachedSample("ybranch");
    const SlicePlan plan = planSlices(volume, SliceOptions{});
    std::deque<std::vector<BoundaryLoop>> loops; // in place while planes are added
    std::vector<PlaneLoops> planes;
    const auto addPlane = [&](double w) {
        loops.push_back(traceBoundaries(SlicePlane(volume, plan, w)));
        planes.push_back({w, {}, {}, {}});
        for (const BoundaryLoop& loop : loops.back()) {
            planes.back().loops.push_back(&loop);
            planes.back().centers.push_back(centralPoint(loop));
        }
        return static_cast<int>(planes.size()) - 1;
    };
    const auto dropLastPlane = [&] {
        loops.pop_back();
        planes.pop_back();
    };
    for (double w = 94.0; w <= volume.bboxMax()[plan.axis]; w += 1.0) addPlane(w);
    ContourGraph graph = buildContourGraph(volume, plan, planes, 0.5, 3.0, addPlane, dropLastPlane, cells);
    planeCount = planes.size();
    return graph;
}

} // namespace

TEST(Graph, ACutThatCannotMatchTheCellsLeavesTheGraphAsItWas)
{
    // Told the truth, the cells change nothing. Told that the isosurface had a handle between
    // planes 104 and 105, where the Y's two branches run apart as two bands (Euler characteristic
    // -2 there instead of 0), no cut finds one: every plane the attempt added is dropped again,
    // and the graph is the one built without cells, slab for slab.
    const Volume& volume = test::cachedSample("ybranch");
    std::size_t without = 0, truth = 0, told = 0;
    const ContourGraph plain = yGraph({}, without);
    const EulerProfile profile = isosurfaceEulerProfile(volume, planSlices(volume, SliceOptions{}).axis);
    const ContourGraph matched = yGraph([&] { return profile; }, truth);
    EulerProfile handle = profile;
    handle.layers.at(static_cast<std::size_t>(104 - profile.first)) -= 2;
    int calls = 0;
    const ContourGraph refused = yGraph(
        [&] {
            ++calls;
            return handle;
        },
        told);
    EXPECT_EQ(calls, 1);
    for (const ContourGraph* graph : {&matched, &refused}) {
        EXPECT_EQ(graph->cellMatches, 0);
        EXPECT_EQ(graph->order, plain.order);
        ASSERT_EQ(graph->slabs.size(), plain.slabs.size());
        for (std::size_t k = 0; k < plain.slabs.size(); ++k) {
            EXPECT_EQ(graph->slabs[k].below, plain.slabs[k].below);
            EXPECT_EQ(graph->slabs[k].pieces.size(), plain.slabs[k].pieces.size());
        }
    }
    EXPECT_EQ(truth, without);
    EXPECT_EQ(told, without);
}

namespace {

std::vector<glm::dvec2> circle(const glm::dvec2& center, double rx, double ry, int points, bool clockwise = false)
{
    std::vector<glm::dvec2> polygon;
    for (int k = 0; k < points; ++k) {
        const double a = (clockwise ? -2.0 : 2.0) * kPi * k / points;
        polygon.push_back(center + glm::dvec2(rx * std::cos(a), ry * std::sin(a)));
    }
    return polygon;
}

} // namespace

TEST(Graph, ArcsOfAPeanutGoToItsLobes)
{
    // An ellipse (10 x 4) over two circles of radius 4 at x = -5 and 5: each half of the ellipse
    // is nearest one circle, so two arcs, cut where x changes sign (the points at 90 and 270
    // degrees, x = 0), closed through a hub.
    const std::vector<glm::dvec2> single = circle({0.0, 0.0}, 10.0, 4.0, 64);
    const std::vector<glm::dvec2> left = circle({-5.0, 0.0}, 4.0, 4.0, 32), right = circle({5.0, 0.0}, 4.0, 4.0, 32);
    JunctionArcs arcs;
    ASSERT_TRUE(splitIntoArcs(single, nullptr, {&left, &right}, arcs));
    EXPECT_TRUE(arcs.hubbed);
    ASSERT_EQ(arcs.cuts.size(), 2u);
    EXPECT_NE(arcs.owner[0], arcs.owner[1]);
    for (int cut : arcs.cuts) EXPECT_LT(std::abs(single[cut].x), 1.0) << cut;
    // Two partners and a ring (a wall of radius 10 around a hole of radius 5) against them: both
    // loops are cut into a left and a right arc, in the same order.
    const std::vector<glm::dvec2> wall = circle({0.0, 0.0}, 10.0, 10.0, 64),
                                  hole = circle({0.0, 0.0}, 5.0, 5.0, 32, true);
    JunctionArcs ring;
    ASSERT_TRUE(splitIntoArcs(wall, &hole, {&left, &right}, ring));
    EXPECT_FALSE(ring.hubbed);
    ASSERT_EQ(ring.cuts.size(), 2u);
    ASSERT_EQ(ring.innerCuts.size(), 2u);
    for (int cut : ring.cuts) EXPECT_LT(std::abs(wall[cut].x), 1.0);
    for (int cut : ring.innerCuts) EXPECT_LT(std::abs(hole[cut].x), 1.0);
    // One partner alone owns everything: no arcs for the others.
    const std::vector<glm::dvec2> far = circle({50.0, 0.0}, 4.0, 4.0, 32);
    JunctionArcs none;
    EXPECT_FALSE(splitIntoArcs(circle({-5.0, 0.0}, 3.0, 3.0, 32), nullptr, {&left, &far}, none));
}

TEST(Graph, AHoleOnOnePartnersSideIsNoGapBetweenThePartners)
{
    // A peanut's ellipse (10 x 4) over its two lobes, with a hole of radius 0.5 at (6, 0), in the
    // right lobe's side: every point of the hole is nearest the right lobe. Its cuts nearest the
    // wall's (x = 0, y = +-4) lie 6 pixels away, across the right lobe's material: where the
    // partners' plane is inside there, they are refused (a keyhole on that side cuts the ring
    // open instead); where it is outside along them (a gap about to part), they stand.
    const std::vector<glm::dvec2> wall = circle({0.0, 0.0}, 10.0, 4.0, 64),
                                  hole = circle({6.0, 0.0}, 0.5, 0.5, 8, true);
    const std::vector<glm::dvec2> left = circle({-5.0, 0.0}, 4.0, 4.0, 32), right = circle({5.0, 0.0}, 4.0, 4.0, 32);
    JunctionArcs nearest;
    ASSERT_TRUE(splitIntoArcs(wall, &hole, {&left, &right}, nearest));
    EXPECT_EQ(nearest.innerCuts.size(), 2u);
    JunctionArcs refused;
    EXPECT_FALSE(splitIntoArcs(wall, &hole, {&left, &right}, refused, [](const glm::dvec2&) { return true; }));
    JunctionArcs gap;
    EXPECT_TRUE(splitIntoArcs(wall, &hole, {&left, &right}, gap, [](const glm::dvec2&) { return false; }));
}

TEST(Graph, AKeyholeCutsARingOpenThroughThePartnersGap)
{
    // A wall of radius 10 around a hole of radius 2 at (3, 0), both counterclockwise. The partners'
    // plane is inside everywhere but a corridor a pixel either side of x = 3, above the hole: the
    // slit runs up it (7.5 pixels), not to the right where the ring is thinnest (5 pixels).
    const std::vector<glm::dvec2> wall = circle({0.0, 0.0}, 10.0, 10.0, 64), hole = circle({3.0, 0.0}, 2.0, 2.0, 16);
    const auto corridor = [](const glm::dvec2& p) { return !(std::abs(p.x - 3.0) < 1.0 && p.y > 0.0); };
    Keyhole keyhole;
    ASSERT_TRUE(chooseKeyhole(wall, hole, corridor, keyhole));
    auto slitMiddles = [&](const Keyhole& k) {
        return std::pair{0.5 * (wall[(k.wall + 63) % 64] + wall[k.wall]),
                         0.5 * (hole[k.hole] + hole[(k.hole + 1) % 16])};
    };
    auto [onWall, onHole] = slitMiddles(keyhole);
    EXPECT_LT(std::abs(onWall.x - 3.0), 1.0);
    EXPECT_GT(onWall.y, 9.0);
    EXPECT_GT(onHole.y, 1.5);
    // The composite runs along the wall from its first point, then back along the hole: the ring's
    // area, less the slit's.
    const std::vector<glm::dvec2> composite = keyholePolygon(wall, hole, keyhole);
    ASSERT_EQ(composite.size(), 80u);
    EXPECT_EQ(composite[0], wall[keyhole.wall]);
    EXPECT_EQ(composite[64], hole[keyhole.hole]);
    EXPECT_EQ(composite[79], hole[(keyhole.hole + 1) % 16]);
    const double ring = polygonArea(wall) - polygonArea(hole);
    EXPECT_LT(polygonArea(composite), ring);
    EXPECT_GT(polygonArea(composite), ring - 2.0 * 7.5);
    // Where the partners' plane is inside everywhere, the shortest slit: to the right.
    Keyhole shortest;
    ASSERT_TRUE(chooseKeyhole(
        wall, hole, [](const glm::dvec2&) { return true; }, shortest));
    std::tie(onWall, onHole) = slitMiddles(shortest);
    EXPECT_GT(onWall.x, 9.5);
    EXPECT_GT(onHole.x, 4.5);
}

// A branch that touches the single contour along one point only: its arc is the shortest run of
// owners, but giving it away would leave that branch without an arc, so the shorter runs of a
// partner that owns several go first. The single contour is a circle of 40 points (radius 10, 9
// degrees apart); ownership reads only the partners' points: the left partner's at radius 9.5
// from 99 to 261 degrees and a stray pair at 0 and 9 degrees, radius 9.95 (the two circle points
// there), the right one's at radius 9.5 from -81 to 81 degrees, and the small one's a point at 90
// degrees, radius 9.95 (its neighbours lie 0.5 from the others' points and 1.57 from it).
TEST(Graph, ABranchTouchingAtOnePointKeepsItsArc)
{
    const std::vector<glm::dvec2> single = circle({0.0, 0.0}, 10.0, 10.0, 40);
    auto at = [](double degrees, double r) {
        return glm::dvec2(r * std::cos(degrees * kPi / 180.0), r * std::sin(degrees * kPi / 180.0));
    };
    std::vector<glm::dvec2> left{at(0.0, 9.95), at(9.0, 9.95)}, right, small{at(90.0, 9.95)};
    for (int d = 99; d <= 261; d += 9) left.push_back(at(d, 9.5));
    for (int d = -81; d <= 81; d += 9) right.push_back(at(d, 9.5));
    JunctionArcs arcs;
    ASSERT_TRUE(splitIntoArcs(single, nullptr, {&left, &right, &small}, arcs));
    EXPECT_TRUE(arcs.hubbed);
    ASSERT_EQ(arcs.cuts.size(), 3u);
    const auto owns = std::find(arcs.owner.begin(), arcs.owner.end(), 2);
    ASSERT_NE(owns, arcs.owner.end());
    EXPECT_EQ(arcs.cuts[owns - arcs.owner.begin()], 10); // the point at 90 degrees starts its arc
}

// Two bodies meet across a neck, and each has a speck budding from its side (Gaffer's smoke: a
// merge at y = 15 where such specks made one body's part take a stretch of the other's
// boundary, 1.6 voxels off). The single contour is an ellipse (20 x 6, 80 points) over circles of
// radius 4.5 at x = -10 and 10; the specks, circles of radius 0.6, sit on its top left and bottom
// right. The owners' runs are left, speck, left, right, speck, right: each body owns two runs,
// which no partner may in a hub or a C. Each speck closes by its own chord, and the bodies meet at
// the hub: every point stays with the partner nearest it.
TEST(Graph, SpecksBuddingBesideANeckCloseByTheirOwnChords)
{
    const std::vector<glm::dvec2> single = circle({0.0, 0.0}, 20.0, 6.0, 80);
    const std::vector<glm::dvec2> left = circle({-10.0, 0.0}, 4.5, 4.5, 32), right = circle({10.0, 0.0}, 4.5, 4.5, 32),
                                  top = circle({-10.0, 6.0}, 0.6, 0.6, 8), bottom = circle({10.0, -6.0}, 0.6, 0.6, 8);
    const std::vector<const std::vector<glm::dvec2>*> partners{&left, &right, &top, &bottom};
    JunctionArcs arcs;
    ASSERT_TRUE(splitIntoArcs(single, nullptr, partners, arcs));
    EXPECT_TRUE(arcs.hubbed);
    ASSERT_EQ(arcs.cuts.size(), 6u);
    ASSERT_EQ(arcs.buds.size(), 2u);
    std::vector<int> budOwners;
    for (int a : arcs.buds) budOwners.push_back(arcs.owner[static_cast<std::size_t>(a)]);
    std::sort(budOwners.begin(), budOwners.end());
    EXPECT_EQ(budOwners, (std::vector<int>{2, 3}));
    const auto nearest = [&](const glm::dvec2& p) {
        int best = -1;
        double distance = std::numeric_limits<double>::infinity();
        for (std::size_t k = 0; k < partners.size(); ++k)
            for (const glm::dvec2& q : *partners[k])
                if (glm::distance(p, q) < distance) {
                    distance = glm::distance(p, q);
                    best = static_cast<int>(k);
                }
        return best;
    };
    for (std::size_t a = 0; a < arcs.cuts.size(); ++a)
        for (int i = arcs.cuts[a]; i != arcs.cuts[(a + 1) % arcs.cuts.size()]; i = (i + 1) % 80)
            EXPECT_EQ(nearest(single[static_cast<std::size_t>(i)]), arcs.owner[a]) << "point " << i;
}

TEST(Graph, TwistingCStaysOneTube)
{
    // The C turning 15 degrees per voxel: its centroid lies in the gap, its central point on the
    // arc, and from one slice to the next (30 degrees, 6.3 voxels along the arc) the sections
    // overlap in part only, and their ends change. The slab joins them: one tube, no events, the
    // isosurface's topology (a sphere). (The old tiler's main path failed on these contours with
    // an internal error.)
    const Volume volume = test::twistingC(kPi / 12.0);
    MeshOptions options;
    options.slicing.axis = Axis::Z;
    const Reconstruction reconstruction(volume, options);
    EXPECT_EQ(reconstruction.stats().tubes, 1);
    EXPECT_EQ(reconstruction.stats().forks + reconstruction.stats().merges, 0);
    const Topology t = checkTopology(reconstruction.buildLevel(reconstruction.levelCount() - 1).mesh);
    EXPECT_TRUE(t.closed() && t.manifold() && t.oriented());
    const Topology reference = checkTopology(isosurface(volume, 0.0));
    EXPECT_EQ(reference.euler, 2);
    EXPECT_EQ(t.euler, reference.euler);
    EXPECT_EQ(t.components, reference.components);
}

// The C's flat ends twist away from the axis through the last contour's central point, which
// leaves the C through its side: capped there, the turning Cs' tops were 1.8 (10 degrees per
// voxel) and 1.0 voxels (15) below their flat ends. The end contour goes where the region reaches
// farthest (addEndContour), and its band is halved while out of register: 0.66 and 0.65.
TEST(Graph, TwistingCsAreCappedAtTheirFlatEnds)
{
    for (const double degreesPerVoxel : {10.0, 15.0, 20.0}) {
        SCOPED_TRACE(degreesPerVoxel);
        const Volume volume = test::twistingC(degreesPerVoxel * kPi / 180.0);
        MeshOptions options;
        options.slicing.axis = Axis::Z;
        const Reconstruction reconstruction(volume, options);
        const TriangleMesh mesh = reconstruction.buildLevel(reconstruction.levelCount() - 1).mesh;
        const Validation v = Validator(volume).validate(mesh);
        EXPECT_EQ(v.topology.euler, 2);
        EXPECT_LE(v.symmetric.max, 1.0 * v.voxel);
    }
}

namespace {

// `mesh` has the isosurface's Euler characteristic and components, and lies within `voxels` of it.
void expectOnTheIsosurface(const Volume& volume, const TriangleMesh& mesh, double voxels)
{
    const Validation v = Validator(volume).validate(mesh);
    const Topology reference = checkTopology(isosurface(volume, 0.0));
    EXPECT_EQ(v.topology.euler, reference.euler);
    EXPECT_EQ(v.topology.components, reference.components);
    EXPECT_LE(v.symmetric.max / v.voxel, voxels);
}

// A reconstruction of `volume` sliced along `axis`, with `levels` levels.
Reconstruction slicedAlong(const Volume& volume, Axis axis, int levels = MeshOptions{}.levels)
{
    MeshOptions options;
    options.slicing.axis = axis;
    options.levels = levels;
    return Reconstruction(volume, options);
}

// The reconstruction's top level has the isosurface's Euler characteristic and components, and
// lies within a voxel of it.
void expectTopLevelOnTheIsosurface(const Volume& volume, const Reconstruction& reconstruction)
{
    expectOnTheIsosurface(volume, reconstruction.buildLevel(reconstruction.levelCount() - 1).mesh, 1.0);
}

// The same, sliced along `axis`.
void expectTopLevelOnTheIsosurface(const Volume& volume, Axis axis = Axis::X)
{
    expectTopLevelOnTheIsosurface(volume, slicedAlong(volume, axis));
}

} // namespace

namespace {

// Two bars along z in a 16 x 16 x 22 fog, the second shifted across, touching the first only
// along a voxel edge or at a corner: across the slab (stacked) or along their length (beside).
struct FogContact {
    const char* name;
    glm::ivec2 shift; // of the second bar, in x and y
    bool stacked;     // the second bar above the first (touching across a slab), or beside it
    float bars, haze; // the density of the bars, and around them within the block
    int euler, components;
};

// Every level of `reconstruction`: closed, manifold and oriented, with `reference`'s Euler
// characteristic and components; and the events' contributions add up to that characteristic.
void expectEveryLevelAs(const Reconstruction& reconstruction, const Topology& reference)
{
    EXPECT_EQ(reconstruction.stats().eventEuler, reference.euler);
    for (int level = 0; level < reconstruction.levelCount(); ++level) {
        const Topology t = checkTopology(reconstruction.buildLevel(level).mesh);
        EXPECT_TRUE(t.closed() && t.manifold() && t.oriented()) << "level " << level;
        EXPECT_EQ(t.euler, reference.euler) << "level " << level;
        EXPECT_EQ(t.components, reference.components) << "level " << level;
    }
}

// The same, for `volume`'s mesh sliced along `axis`, planes `spacing` voxels apart.
void expectEveryLevelAs(const Volume& volume, Axis axis, const Topology& reference,
                        double spacing = SliceOptions{}.spacingVoxels)
{
    MeshOptions options;
    options.slicing.axis = axis;
    options.slicing.spacingVoxels = spacing;
    expectEveryLevelAs(Reconstruction(volume, options), reference);
}

// `volume`'s isosurface has `components` and Euler characteristic `euler` (else the phantom no
// longer shows its case), and so has every level of its mesh sliced along z.
void expectEveryLevelAlongZAs(const Volume& volume, int components, int euler,
                              double spacing = SliceOptions{}.spacingVoxels)
{
    const Topology reference = checkTopology(isosurface(volume, 0.0));
    ASSERT_EQ(reference.components, components);
    ASSERT_EQ(reference.euler, euler);
    expectEveryLevelAs(volume, Axis::Z, reference, spacing);
}

// Every level of the contact's fog at iso 0.5 against volumeToMesh's isosurface, whose Euler
// characteristic and components are the contact's.
// The two bars of `contact` in their block (read at iso 0.5).
Volume fogContactVolume(const FogContact& contact)
{
    const auto inBar = [](int x, int y, int z, glm::ivec2 at, int z0, int z1) {
        return x >= at.x && x < at.x + 5 && y >= at.y && y < at.y + 5 && z >= z0 && z <= z1;
    };
    test::TempDir dir;
    const std::string path = dir.path("contact.vdb");
    test::writeFogVoxelsVdb(path, {16, 16, 22}, [&](int x, int y, int z) {
        const glm::ivec2 first(2, 2), second = first + contact.shift;
        const bool bar = contact.stacked ? inBar(x, y, z, first, 2, 10) || inBar(x, y, z, second, 11, 19)
                                         : inBar(x, y, z, first, 2, 19) || inBar(x, y, z, second, 2, 19);
        const bool block = x >= 1 && y >= 1 && z >= 1 && x <= 14 && y <= 14 && z <= 20;
        return bar ? contact.bars : block ? contact.haze : 0.0f;
    });
    VolumeOptions read;
    read.iso = 0.5;
    return readVolume(path, read);
}

void expectFogContactAsVolumeToMesh(const FogContact& contact)
{
    SCOPED_TRACE(contact.name);
    const Volume volume = fogContactVolume(contact);
    const Topology reference = checkTopology(isosurface(volume, 0.0));
    EXPECT_EQ(reference.euler, contact.euler);
    EXPECT_EQ(reference.components, contact.components);
    expectEveryLevelAs(volume, Axis::Z, reference);
}

} // namespace

// Fog voxels that touch only along a voxel edge or at a corner meet at saddles of the trilinear
// field, which volumeToMesh resolves its own way for fog (the other pair than for a level set;
// slicer.h, saddleJoins): it parts dense voxels (two bars in empty space: Euler characteristic 4,
// two components), even in a haze of 0.45 where the saddle face's centre holds 0.725, and joins
// empty ones (the bars as cavities in a dense block: one void, an outer shell and an inner one:
// 4 and two components, where parted cavities would give 6 and three). Every level must follow.
TEST(Graph, FogSaddlesJoinAsVolumeToMeshJoinsThem)
{
    for (const FogContact& contact : {FogContact{"edge across the slab", {5, 0}, true, 1.0f, 0.0f, 4, 2},
                                      FogContact{"corner across the slab", {5, 5}, true, 1.0f, 0.0f, 4, 2},
                                      FogContact{"edge along the bars", {5, 5}, false, 1.0f, 0.0f, 4, 2},
                                      FogContact{"in a haze", {5, 0}, true, 1.0f, 0.45f, 4, 2},
                                      FogContact{"cavities, edge across the slab", {5, 0}, true, 0.0f, 1.0f, 4, 2}})
        expectFogContactAsVolumeToMesh(contact);
}

// The two cavities beside each other, touching along their length, are one hole loop in every
// slice, with the central points at their pinch. Neither end had an apex on that axis, so the
// block's top and the hole's were taken for a hollow pipe's open rim and joined by an annulus:
// the void opened (Euler characteristic 2, one component). A hole's end is now sought from
// points all over it, and a wall's too where no open hole ends with it (addEndContour). Its top
// end, under the block's lid one voxel thick, was 1.22 voxels off at the top level: its end
// contour was out of register whatever its central point, and the cap fanned to an apex at the
// cavities' pinch. That end now takes its piece's cells (patchEnd): 0.50.
TEST(Graph, CavitiesTouchingAlongTheirLengthStayOneVoid)
{
    const FogContact cavities{"cavities, edge along the bars", {5, 5}, false, 0.0f, 1.0f, 4, 2};
    expectFogContactAsVolumeToMesh(cavities);
    expectTopLevelOnTheIsosurface(fogContactVolume(cavities), Axis::Z);
}

TEST(Graph, JunctionsDoNotDependOnTheThreads)
{
    // Junctions are tiled after the parallel bands; the mesh must be the same for any threads.
    for (const char* name : {"ybranch", "ubend"}) {
        SCOPED_TRACE(name);
        MeshOptions one, two;
        one.threads = 1;
        two.threads = 2;
        const Reconstruction a(test::cachedSample(name), one), b(test::cachedSample(name), two);
        for (int level = 0; level < a.levelCount(); ++level) {
            const TriangleMesh ma = a.buildLevel(level).mesh, mb = b.buildLevel(level).mesh;
            EXPECT_TRUE(ma.vertices == mb.vertices && ma.triangles == mb.triangles) << "level " << level;
        }
    }
}

namespace {

// Junction parts tiled by the minimum-area fallback, over every level of a sample.
int areaJunctionParts(const char* name)
{
    const Reconstruction reconstruction(test::cachedSample(name), MeshOptions{});
    int parts = 0;
    for (int level = 0; level < reconstruction.levelCount(); ++level)
        parts += reconstruction.buildLevel(level).areaJunctionParts;
    return parts;
}

} // namespace

TEST(Graph, JunctionPartsAreTiledByTheIntegerBand)
{
    // Each branch of these leaves its parent steeply enough that its central point lies inside its
    // part of the parent's contour: every part is cast with the branch's rays and tiled to it by
    // the band, integers only, at every level.
    for (const char* name : {"ybranch", "ubend", "xcross", "two-tori", "tree", "serpentine", "torus-standing"}) {
        SCOPED_TRACE(name);
        EXPECT_EQ(areaJunctionParts(name), 0);
    }
}

TEST(Graph, RingSectorsAndSliversAreTiledByTheIntegerBand)
{
    // The hollow Y's open end grazes the slices: its wall's ring forms at w = 8 from four sectors
    // (at 7.5) that formed from eight slivers of one pixel (at 7). A sector's centre lay outside
    // its part, and a sliver's polygon has no point a quarter pixel clear, so 11 of its 20 parts
    // fell back to the minimum-area tiler. Each such partner now moves to the point deepest inside
    // both it and its part (centreParts), and every part is cast as a contour (a part the contour
    // trees then pair out of register is tiled by area: areaBands, not counted here).
    EXPECT_EQ(areaJunctionParts("hollow-y"), 0);
}

TEST(Graph, GapsOpeningOntoAStraightArcAreTiledByTheIntegerBand)
{
    // The trifurcation's two 2-pixel holes between its branches open onto the single contour where
    // it runs nearly straight: each part, three points of the single contour's arc and the chord's
    // middle, ran clockwise (the arc bends past its chord), wound around no point, and fell back to
    // the minimum-area tiler. The chord's middle now moves half a pixel past the arc (gapMiddle).
    EXPECT_EQ(areaJunctionParts("trifurcation"), 0);
}

// A piece of Gaffer's smoke: fog voxels barely denser than the isovalue, meeting along voxel edges.
// Within one voxel slab the slab's labelling joins walls 2:2 (and 3:2, 1:4 ...) where no plane
// between the voxel planes parts the saddles. Such a piece is meshed from its slab's cells, which
// close with its Euler characteristic (a sphere with n + m holes, as the labelling counts it);
// before, it passed through a waist (a merge into one contour in the slab's middle, then a fork),
// and before that its contours were capped one by one (4 caps instead of -2). With nothing left
// unresolved, every level (nested) has the events' sum for its Euler characteristic.
TEST(Graph, SlabsBisectionCannotPartAreMeshedFromTheirCells)
{
    test::TempDir dir;
    const std::string smoke = test::realData("gaffer_smoke_fog.vdb"), path = dir.path("crop.vdb");
    test::writeCroppedVdb(smoke, path, {36, 43, 49}, {49, 52, 61});
    VolumeOptions read;
    read.iso = readVolume(smoke).iso(); // the whole smoke's, not the crop's own default
    const Reconstruction reconstruction(readVolume(path, read), MeshOptions{});
    const ReconstructionStats& stats = reconstruction.stats();
    EXPECT_EQ(stats.waists, 0);
    EXPECT_GE(stats.patches, 1);
    EXPECT_EQ(stats.unresolvedEvents + stats.unresolvedJunctions, 0);
    expectNestedLevels(reconstruction, [&](const TriangleMesh& mesh) {
        const Topology t = checkTopology(mesh);
        EXPECT_TRUE(t.closed() && t.manifold() && t.oriented());
        EXPECT_EQ(t.euler, stats.eventEuler);
    });
}

namespace {

// How far the top level's triangles whose corners all lie between index y = lo and hi stray from
// the isosurface, in voxels; infinite if there are none (the slab no longer shows its case).
double topLevelDistanceBetweenY(const Volume& volume, const Reconstruction& reconstruction, double lo, double hi)
{
    const TriangleMesh top = reconstruction.buildLevel(reconstruction.levelCount() - 1).mesh;
    TriangleMesh slab;
    slab.vertices = top.vertices;
    for (const Triangle& t : top.triangles)
        if (std::all_of(t.begin(), t.end(), [&](std::uint32_t v) {
                const double y = volume.worldToIndex(top.vertices[v]).y;
                return y >= lo && y <= hi;
            }))
            slab.triangles.push_back(t);
    if (slab.triangles.empty()) return std::numeric_limits<double>::infinity();
    const Validation v = Validator(volume).validate(slab);
    return v.meshToReference.max / v.voxel;
}

} // namespace

// The whole smoke along y: a 3:2 piece in the slab from y = 25 to 26 passed through a waist, the
// walls' union in the plane y = 25.5. Where a wall ends inside the slab, the union reaches past
// the surface there, and the fans from the waist's hub to the wall below lay 1.53 voxels off at the
// top level. Its cells close with its Euler characteristic, so it is now a patch of the cells, and
// the top level's triangles in that slab lie within a voxel of the isosurface.
TEST(Graph, AnNmPieceWhoseCellsCloseTakesNoWaist)
{
    const Volume volume = readVolume(test::realData("gaffer_smoke_fog.vdb"));
    MeshOptions options;
    options.slicing.axis = Axis::Y;
    const Reconstruction reconstruction(volume, options);
    const Skeleton skeleton = reconstruction.skeleton();
    EXPECT_TRUE(std::none_of(skeleton.junctions.begin(), skeleton.junctions.end(),
                             [](const Skeleton::Junction& j) { return j.w == 25.5; }));
    EXPECT_LE(topLevelDistanceBetweenY(volume, reconstruction, 25.0, 26.0), 1.0);
}

// Sliced across their length, the phantoms have strips for sections, and a strip's wall can point
// at the central point: no ray meets it between its ends, however often the sectors are halved.
// Without wall vertices these top levels lie up to 2.15 voxels off (the trifurcation along y 0.97,
// the vessel tree 1.53, the U-bend 0.99, the serpentine 1.79, the phantom along y 2.15 and along x
// 1.48); the top level's wall vertices bring each within a voxel (0.81, 0.87, 0.64, 0.88, 0.96,
// 0.75). The hollow Y along x was one of them until its bands were asked as the top level tiles
// them: its tubes are no longer cut by cell patches, and no edge of its top level lies a voxel
// from its walk.
TEST(Graph, WallsThatPointAtTheCentralPointGetVertices)
{
    const std::pair<const char*, Axis> runs[] = {{"trifurcation", Axis::Y}, {"tree", Axis::Y},    {"ubend", Axis::Y},
                                                 {"serpentine", Axis::Y},   {"phantom", Axis::Y}, {"phantom", Axis::X}};
    for (const auto& [name, axis] : runs) {
        SCOPED_TRACE(std::string(name) + (axis == Axis::Y ? " along y" : " along x"));
        const Volume& volume = test::cachedSample(name);
        const Reconstruction reconstruction = slicedAlong(volume, axis);
        const LevelMesh top = reconstruction.buildLevel(reconstruction.levelCount() - 1);
        EXPECT_GT(top.wallVertices, 0);
        expectOnTheIsosurface(volume, top.mesh, 1.0);
    }
}

// The hollow Y sliced along y: its channel (radius 6 around y = 32) has its tangent planes on the
// voxel grid, at y = 26 and 38, where the voxels along the channel's ridge hold the isovalue
// itself. volumeToMesh takes them for outside: slits and pinholes of no area in the wall, which no
// contour keeps but the cells count. So the merge at y = 38 (the wall's three pieces beside the
// channel close over it) could not take its cells, and its junction fanned across the crotch,
// 2.86 voxels off (795 in aspect at levels 2 and 3). Such a voxel with no outside neighbour in
// its plane is now inside: the merge and the fork take their cells, and the top level is 0.82
// voxel off.
TEST(Graph, AChannelsTangentPlaneOnTheVoxelGridIsPatched)
{
    const Volume& volume = test::cachedSample("hollow-y");
    const Reconstruction reconstruction = slicedAlong(volume, Axis::Y);
    EXPECT_EQ(reconstruction.stats().eventEuler, -2);
    EXPECT_EQ(reconstruction.stats().junctionPatches, 2);
    const TriangleMesh top = expectNestedLevels(reconstruction, [&](const TriangleMesh& mesh) {
        const Topology t = checkTopology(mesh);
        EXPECT_TRUE(t.closed() && t.manifold() && t.oriented() && t.outward());
        EXPECT_EQ(t.euler, -2);
        EXPECT_EQ(t.components, 1);
    });
    expectOnTheIsosurface(volume, top, 1.0);
}

// The whole smoke along y, its default axis, at its default isovalue: its top level was 1.01
// voxels off, the worst at a merge at y = 70 whose part fanned a point 3 voxels across an outside
// bay. Bands and parts reaching more than 2 pixels past the other contour's point nearest them
// (3 before) go to the least-area tiler, whose ties the spans break, and the top level is within
// a voxel of the isosurface (0.78). Along z it was 1.09 voxels off where a band's slab could not be
// halved; such bands take their cells (ABandWhoseSlabCouldNotBeHalvedTakesItsCells): 0.92. Along
// x it was 1.12 voxels off where a corner pixel reaches past an end (AnEndsSpikeOnePixelWideIsReached):
// 0.73. Along y it is now 0.90: the ends that reach farther take other end contours.
TEST(Graph, TheSmokesTopLevelIsWithinAVoxel)
{
    const Volume volume = readVolume(test::realData("gaffer_smoke_fog.vdb"));
    for (const Axis axis : {Axis::Y, Axis::Z, Axis::X}) {
        SCOPED_TRACE(axis == Axis::Y ? "along y" : axis == Axis::Z ? "along z" : "along x");
        MeshOptions options;
        options.slicing.axis = axis;
        const Reconstruction reconstruction(volume, options);
        const Validation v =
            Validator(volume).validate(reconstruction.buildLevel(reconstruction.levelCount() - 1).mesh);
        EXPECT_LE(v.symmetric.max / v.voxel, 1.0);
    }
}

namespace {

// Voxels between the smoke's isosurface at iso 0.1 (data/README's value) and its top level, sliced
// along `axis`.
double smokeAtItsReadmeIsovalueOff(Axis axis)
{
    VolumeOptions read;
    read.iso = 0.1;
    const Volume volume = readVolume(test::realData("gaffer_smoke_fog.vdb"), read);
    const Reconstruction reconstruction = slicedAlong(volume, axis);
    const Validation v = Validator(volume).validate(reconstruction.buildLevel(reconstruction.levelCount() - 1).mesh);
    return v.symmetric.max / v.voxel;
}

} // namespace

// The whole smoke at iso 0.1, the value data/README.md gives it (its plume as one blob full of
// channels): its top level lies within a voxel of the isosurface (0.93). It was 2.23 voxels off
// where a band fanned across air (ABandWhoseSlabCouldNotBeHalvedTakesItsCells), 1.53 where an
// end missed a spike one pixel wide (AnEndsSpikeOnePixelWideIsReached), and 1.02 where a band's
// middle plane showed more than a band (ABandWhoseMiddlePlaneIsNoBandTakesItsCells).
TEST(Graph, TheSmokeAtItsReadmeIsovalueIsWithinAVoxel)
{
    EXPECT_LE(smokeAtItsReadmeIsovalueOff(Axis::Auto), 1.0);
}

// The same along z, where the slices lie 2 voxels apart: a cup at the bottom, whose cavity meets
// the outside at one saddle of the cells only, ended as a rim (a wall and its hole together), its
// annulus flat at the cavity's mouth 1.53 voxels above the cup's bottom. A rim's slab is halved
// to a voxel, and the voxel plane shows the cup's bottom (0.86).
TEST(Graph, TheSmokeAtItsReadmeIsovalueIsWithinAVoxelAlongZ)
{
    EXPECT_LE(smokeAtItsReadmeIsovalueOff(Axis::Z), 1.0);
}

// And along x, where an end contour had a lobe that the tube's last contour lacks: its band fanned
// the lobe to one point of the last contour 5 voxels away, 1.01 voxels off. An end contour is out
// of register where a part of either contour fans across a gap of it toward the other (0.92).
TEST(Graph, TheSmokeAtItsReadmeIsovalueIsWithinAVoxelAlongX)
{
    EXPECT_LE(smokeAtItsReadmeIsovalueOff(Axis::X), 1.0);
}

// The phantom, a plain tube, sliced along y (across its length, its sections strips hundreds of
// pixels long): where the tube's top lies nearly in the slicing plane, bands between planes an
// eighth of a voxel apart, whose contours' walls lie 28 pixels along the walk between vertices, are
// all needles. As tiled, the top level is 0.98 voxel off; the collapses that take the needles each
// moved the surface by 0.3 voxel at most from the triangles before, and in turn took it to 1.11.
// The top level's collapses now keep within its bound of the isosurface itself (SurfaceBound).
TEST(Graph, ThePhantomSlicedAlongYIsWithinAVoxel)
{
    const Volume& volume = test::cachedSample("phantom");
    const Reconstruction reconstruction = slicedAlong(volume, Axis::Y);
    expectOnTheIsosurface(volume, reconstruction.buildLevel(reconstruction.levelCount() - 1).mesh, 1.0);
}

namespace {

// The top level of `volume`'s mesh along `axis` is closed, manifold and oriented, and encloses the
// isosurface's volume to within its area times a voxel; its components are the isosurface's if
// `sameComponents`.
void expectTheIsosurfacesVolume(const Volume& volume, const Reconstruction& reconstruction, bool sameComponents)
{
    const TriangleMesh reference = isosurface(volume, 0.0);
    const Topology r = checkTopology(reference);
    const double tolerance = measureQuality(reference).area * volume.voxelSize().x;
    const Topology t = checkTopology(reconstruction.buildLevel(reconstruction.levelCount() - 1).mesh);
    EXPECT_TRUE(t.closed() && t.manifold() && t.oriented());
    EXPECT_NEAR(t.signedVolume, std::abs(r.signedVolume), tolerance); // a fog's faces inward
    if (sameComponents) {
        EXPECT_EQ(t.components, r.components);
    }
}

} // namespace

// The smoke along z holds two pieces that fit no construction and whose cells' surface, between a
// plane and a voxel plane, touches two outside regions the labelling keeps apart: no rule decides a
// saddle face across such layers, and joining the outside pair left a cycle no piece could take.
// They were capped contour by contour (Euler characteristic 408, 238 components). Joining the inside pair where
// only it is one region already (graph.cpp, insideJoined) patches both: nothing is capped, the
// enclosed volume is the isosurface's, within its area times a voxel (its topology:
// TheSmokeHasTheIsosurfaceTopology).
TEST(Graph, TheSmokeAlongZHasNothingCapped)
{
    const Volume volume = readVolume(test::realData("gaffer_smoke_fog.vdb"));
    MeshOptions options;
    options.slicing.axis = Axis::Z;
    const Reconstruction reconstruction(volume, options);
    ASSERT_GT(reconstruction.stats().patches, 0); // else the smoke no longer shows the case
    EXPECT_EQ(reconstruction.stats().unresolvedEvents + reconstruction.stats().unresolvedJunctions, 0);
    expectTheIsosurfacesVolume(volume, reconstruction, false);
}

namespace {

// A 0..1 density on 16^3 voxels (background 0): `blocks` of 1 (corners inclusive) and single voxels
// of other values.
Volume densityBlocks(const std::vector<std::pair<glm::ivec3, glm::ivec3>>& blocks,
                     const std::vector<std::pair<glm::ivec3, float>>& voxels, std::optional<double> iso)
{
    constexpr int n = 16;
    std::vector<float> values(n * n * n, 0.0f);
    const auto at = [&](const glm::ivec3& p) -> float& { return values[(p.x * n + p.y) * n + p.z]; };
    for (const auto& [lo, hi] : blocks)
        for (int i = lo.x; i <= hi.x; ++i)
            for (int j = lo.y; j <= hi.y; ++j)
                for (int k = lo.z; k <= hi.z; ++k) at({i, j, k}) = 1.0f;
    for (const auto& [p, value] : voxels) at(p) = value;
    DenseVolume dense;
    dense.values = values.data();
    dense.dims = {n, n, n};
    dense.volumeClass = VolumeClass::Fog;
    VolumeOptions options;
    options.iso = iso;
    return volumeFromDense(dense, options, "density blocks");
}

} // namespace

// volumeToMesh parts a fog's two sides by value < iso, so a voxel at the isovalue itself lies on
// the dense side: two bars meeting along an edge, with such voxels filling one corner between
// them, are one component, and the mesh joins them as the isosurface does (the slices read those
// voxels as a hair inside, not outside).
TEST(Graph, AFogVoxelAtTheIsovalueIsInsideAsVolumeToMeshTakesIt)
{
    std::vector<std::pair<glm::ivec3, float>> corner;
    for (int k = 2; k <= 12; ++k) corner.push_back({{6, 5, k}, 0.5f});
    const Volume volume = densityBlocks({{{2, 2, 2}, {5, 5, 12}}, {{6, 6, 2}, {9, 9, 12}}}, corner, 0.5);
    const Topology reference = checkTopology(isosurface(volume, 0.0));
    ASSERT_EQ(reference.components, 1); // else volumeToMesh no longer takes the corner as dense
    expectEveryLevelAs(volume, Axis::Z, reference);
}

// The default fog isovalue, halfway to the densest value (0.5 here), moves to the next float above
// where a voxel holding it has no neighbour as dense: volumeToMesh would mesh that voxel as a
// component of no size. A voxel at 0.5 next to the block only places the surface on it.
TEST(Graph, TheDefaultFogIsovalueMakesNoComponentOfNoSize)
{
    const std::pair<glm::ivec3, glm::ivec3> block{{2, 2, 2}, {5, 5, 5}};
    const Volume touching = densityBlocks({block}, {{{6, 3, 3}, 0.5f}}, std::nullopt);
    EXPECT_EQ(touching.iso(), 0.5);
    const Volume apart = densityBlocks({block}, {{{6, 3, 3}, 0.5f}, {{11, 11, 11}, 0.5f}}, std::nullopt);
    EXPECT_EQ(apart.iso(), static_cast<double>(std::nextafter(0.5f, 1.0f)));
    const Topology reference = checkTopology(isosurface(apart, 0.0));
    EXPECT_EQ(reference.components, 1);
    expectEveryLevelAs(apart, Axis::Z, reference);
}

// A one-voxel void in a block, at (6, 6, 6), enclosed by its six neighbours, touches along an edge
// a channel one plane up, (7, 6, 7) and on to the outside, and volumeToMesh's tables join those two
// outside voxels (saddleJoinsInside: the channel also holds (6, 7, 7), beside the face), so the
// isosurface is one closed surface. A plane between, at z = 6.5, reads both pixels of that face
// inside (the average of 1 and 0 against iso 0.4); it shows them outside now, and every level has
// the isosurface's topology (without: a void of its own, 2 components and Euler characteristic 4;
// the gaffer smoke along z had two such voids).
TEST(Graph, AVoidThatVolumeToMeshOpensAcrossAVoxelEdgeOpensBetweenVoxelPlanes)
{
    std::vector<std::pair<glm::ivec3, float>> channel{{{6, 6, 6}, 0.0f}};
    for (int y = 6; y < 16; ++y) channel.push_back({{7, y, 7}, 0.0f});
    for (int y = 7; y < 16; ++y) channel.push_back({{6, y, 7}, 0.0f});
    const Volume volume = densityBlocks({{{2, 2, 2}, {12, 12, 12}}}, channel, 0.4);
    expectEveryLevelAlongZAs(volume, 1, 2, 0.5); // else volumeToMesh keeps the void; a plane at z = 6.5
}

// A block of fog cut by the grid's top, z = 15, with a dimple two voxels deep in that face: the
// last plane holds the block's wall and the dimple's hole, and nothing lies past it. The wall's
// own end reaches past the plane (its central point is inside), but the hole is open there: the
// wall is the dimple's rim, and the mesh is one closed surface as the isosurface is. (The hole was
// closed flat under the wall's cap before, a void of its own: 2 components, Euler characteristic
// 4; a crop of the smoke had 3 such voids at its cut faces, README.)
TEST(Graph, AHoleOpenPastTheLastPlaneIsItsWallsRim)
{
    const Volume volume = densityBlocks({{{2, 2, 2}, {12, 12, 15}}}, {{{6, 6, 14}, 0.0f}, {{6, 6, 15}, 0.0f}}, 0.4);
    expectEveryLevelAlongZAs(volume, 1, 2);
}

// The block of AHoleOpenPastTheLastPlaneIsItsWallsRim with two and with three dimples in its cut
// face: the wall is the rim of them all, a face with that many holes in the last plane (the slab's
// Rim junction, with no slab). An annulus joined one hole only, and the others were closed flat
// under the wall's end, voids of their own: 2 and 3 components, Euler characteristic 4 and 6.
TEST(Graph, AWallIsTheRimOfEveryHoleOpenPastTheLastPlane)
{
    for (const int dimples : {2, 3}) {
        SCOPED_TRACE(dimples);
        std::vector<std::pair<glm::ivec3, float>> holes;
        for (int d = 0; d < dimples; ++d)
            for (const int z : {14, 15}) holes.push_back({{4 + 3 * d, 4 + 2 * d, z}, 0.0f});
        const Volume volume = densityBlocks({{{2, 2, 2}, {12, 12, 15}}}, holes, 0.4);
        expectEveryLevelAlongZAs(volume, 1, 2);
    }
}

// The block of AHoleOpenPastTheLastPlaneIsItsWallsRim with nine dimples in its cut face, three by
// three: the middle one is nearest to no point of the wall, so the wall's polygon does not split
// into an arc per hole. The face past the last plane is then meshed from its cells out to empty
// space (a patch), all nine holes in it. (An annulus joined one hole and the other eight were
// closed flat, voids of their own: 9 components, Euler characteristic 18.)
TEST(Graph, AFaceWithAHoleNoWallPointSeesIsPatchedFromItsCells)
{
    std::vector<std::pair<glm::ivec3, float>> holes;
    for (const int x : {4, 7, 10})
        for (const int y : {4, 7, 10})
            for (const int z : {14, 15}) holes.push_back({{x, y, z}, 0.0f});
    const Volume volume = densityBlocks({{{1, 1, 2}, {13, 13, 15}}}, holes, 0.4);
    expectEveryLevelAlongZAs(volume, 1, 2);
}

// A cup cut by the grid's top, z = 15, and a smaller cup standing free in its cavity, both open
// at that face: the last plane holds the outer wall and the cavity, and inside them the inner
// wall and its hollow, all centred alike. Each hole is its own wall's rim, the cavity the outer
// wall's and the hollow the inner wall's, though the outer wall encloses both holes' centres and
// the inner wall the cavity's. (Joining each hole to the wall nearest its central point, grouped
// per wall, gave the outer wall both holes: 3 components, Euler characteristic 6.)
TEST(Graph, NestedRimsAtTheLastPlaneEachJoinTheirOwnWall)
{
    std::vector<std::pair<glm::ivec3, float>> carved;
    const auto fill = [&](int lo, int hi, int zLo, float value) {
        for (int x = lo; x <= hi; ++x)
            for (int y = lo; y <= hi; ++y)
                for (int z = zLo; z <= 15; ++z) carved.push_back({{x, y, z}, value});
    };
    fill(4, 11, 10, 0.0f); // the cavity
    fill(6, 9, 11, 1.0f);  // the inner cup, a voxel clear of the cavity's floor
    fill(7, 8, 13, 0.0f);  // its hollow
    const Volume volume = densityBlocks({{{2, 2, 2}, {13, 13, 15}}}, carved, 0.4);
    expectEveryLevelAlongZAs(volume, 2, 4);
}

// A closed cavity in a block, with a post standing on its floor: where the cavity begins, its hole
// and the post's wall begin together, the hole around the wall, and the cavity's floor joins them
// (a rim the other way round from a pipe's: the hole's region ends past the plane, the wall's goes
// on). Each was capped on its own, so the post was closed off from the block under it: 3
// components, Euler characteristic 6, against the isosurface's block and void (2 and 4).
TEST(Graph, APostStandingInACavityJoinsItsFloor)
{
    std::vector<std::pair<glm::ivec3, float>> carved;
    for (int x = 4; x <= 11; ++x)
        for (int y = 4; y <= 11; ++y)
            for (int z = 6; z <= 11; ++z) {
                const bool post = x >= 6 && x <= 9 && y >= 6 && y <= 9 && z <= 8;
                carved.push_back({{x, y, z}, post ? 1.0f : 0.0f});
            }
    const Volume volume = densityBlocks({{{2, 2, 2}, {13, 13, 13}}}, carved, 0.4);
    expectEveryLevelAlongZAs(volume, 2, 4);
}

// A speck in one voxel plane: three voxels in an L, barely past the isovalue (0.41 and 0.39 at
// 0.4), so the isosurface wraps them a fortieth of a voxel thick. Its contour is alone in its plane
// and no point of it sees all of it: not its central point (outside the L), nor any cell centre (an
// average with the voxels round it). Both ends now reach past the plane from the voxels
// themselves, and one fans round its apex. (The slices dropped such contours as flat pillows: a
// component fewer, Euler characteristic 2 less; the smoke at iso 0.1 lost five so, README.)
TEST(Graph, ASpeckInOneVoxelPlaneIsAComponentOfItsOwn)
{
    const std::pair<glm::ivec3, glm::ivec3> block{{2, 2, 2}, {8, 8, 12}};
    for (const float speck : {0.41f, 0.39f}) {
        SCOPED_TRACE(speck);
        // A blob beside the block, or a void in it.
        const glm::ivec3 corner = speck > 0.4f ? glm::ivec3{11, 11, 7} : glm::ivec3{4, 4, 7};
        const Volume volume = densityBlocks(
            {block}, {{corner, speck}, {corner + glm::ivec3{1, 0, 0}, speck}, {corner + glm::ivec3{1, 1, 0}, speck}},
            0.4);
        expectEveryLevelAlongZAs(volume, 2, 4, 1.0); // a plane at z = 7
    }
}

// Two blocks and, beside them, a speck a voxel across between two planes (the plan's planes lie at
// even z, from the box's low end): no plane shows it, and the graph holds no junction, but the
// surface starts more than once, so the cells are compared, and a cut between those planes finds
// it. (The cells were compared only at junctions: 2 components, Euler characteristic 4.)
TEST(Graph, ASpeckBetweenPlanesBesideOtherObjectsIsFound)
{
    const Volume volume =
        densityBlocks({{{2, 2, 2}, {5, 5, 12}}, {{9, 9, 2}, {12, 12, 12}}}, {{{3, 11, 7}, 1.0f}}, 0.4);
    expectEveryLevelAlongZAs(volume, 3, 6);
}

// The blocks of ASpeckBetweenPlanesBesideOtherObjectsIsFound and a speck in the box's last voxel
// plane, z = 15, past the plan's last plane, z = 14 (the spacing stops short of the box's end): the
// cells count it past that plane, so a plane at the box's last voxel plane meets it. (No plane
// met it: 2 components, Euler characteristic 4; five such specks in a crop of the smoke.)
TEST(Graph, ASpeckPastTheLastPlaneIsFound)
{
    const Volume volume =
        densityBlocks({{{2, 2, 2}, {5, 5, 12}}, {{9, 9, 2}, {12, 12, 12}}}, {{{3, 11, 15}, 1.0f}}, 0.4);
    expectEveryLevelAlongZAs(volume, 3, 6);
}

// A speck of one voxel in plane z = 9 touches a slab below it along one voxel edge only, which
// volumeToMesh leaves open (a level set: the rule applies to its inside): two components. Between
// the planes, the interpolated field joins them, and the slab's loop half a voxel below the speck
// encloses its pixel. That loop is no end contour of the speck's tube: it overlaps the other loops
// of the speck's plane (the slab's), which lie on other pieces. Taken as one (the smoke's web of
// voxels, 2.5 voxels off), the band fanned the whole slab's loop onto the speck: 3.7 voxels off.
TEST(Graph, AnEndContourIsNoOtherObjectsLoop)
{
    constexpr int n = 16;
    std::vector<float> values(n * n * n, 1.0f);
    const auto at = [&](int x, int y, int z) -> float& { return values[(x * n + y) * n + z]; };
    for (int x = 1; x <= 13; ++x)
        for (int y = 1; y <= 9; ++y)
            for (int z = 4; z <= 12; ++z)
                if (z <= 8 || y <= 7) at(x, y, z) = -2.0f;
    at(7, 10, 9) = -1.0f; // the speck, diagonal to (7, 9, 8) on the face x = 7
    at(7, 9, 9) = at(7, 10, 8) = 0.5f;
    DenseVolume dense;
    dense.values = values.data();
    dense.dims = {n, n, n};
    const Volume volume = volumeFromDense(dense, VolumeOptions{}, "slab and speck");
    const Topology reference = checkTopology(isosurface(volume, 0.0));
    ASSERT_EQ(reference.components, 2); // else volumeToMesh joins the speck and the phantom shows nothing
    MeshOptions options;
    options.slicing.axis = Axis::Z;
    options.slicing.spacingVoxels = 1.0; // a plane through the speck
    const Reconstruction reconstruction(volume, options);
    expectEveryLevelAs(reconstruction, reference);
    const LevelMesh top = reconstruction.buildLevel(reconstruction.levelCount() - 1);
    const Validation v = Validator(volume).validate(top.mesh);
    EXPECT_LE(v.symmetric.max / v.voxel, 1.0);
}

// A block widens at z = 8 on two sides; three voxels at z = 7 (two on one side, one on the other)
// bud from it there: a merge of four, the block's boundary parted by the buds at two necks. Each
// bud's arc closes by its own chord across its neck, and the block's two arcs join across them. Made
// one arc per partner (through a hub), one bud took the block's stretch between the necks, and its
// band crossed the block: 2.6 voxels off at the top level.
TEST(Graph, BudsAtTwoNecksOfABodyCloseByChordsOfTheirOwn)
{
    constexpr int n = 16;
    std::vector<float> values(n * n * n, 1.0f);
    const auto fill = [&](glm::ivec3 lo, glm::ivec3 hi) {
        for (int x = lo.x; x <= hi.x; ++x)
            for (int y = lo.y; y <= hi.y; ++y)
                for (int z = lo.z; z <= hi.z; ++z) values[(x * n + y) * n + z] = -1.0f;
    };
    fill({3, 3, 2}, {10, 10, 12});  // the block
    fill({11, 3, 8}, {12, 10, 12}); // widening toward +x
    fill({4, 11, 8}, {6, 12, 12});  // and toward +y
    fill({12, 3, 7}, {12, 3, 7});   // the buds, a voxel below the widenings
    fill({12, 5, 7}, {12, 5, 7});
    fill({5, 12, 7}, {5, 12, 7});
    DenseVolume dense;
    dense.values = values.data();
    dense.dims = {n, n, n};
    const Volume volume = volumeFromDense(dense, VolumeOptions{}, "block with buds");
    const Topology reference = checkTopology(isosurface(volume, 0.0));
    ASSERT_EQ(reference.components, 1);
    ASSERT_EQ(reference.euler, 2);
    MeshOptions options;
    options.slicing.axis = Axis::Z;
    options.slicing.spacingVoxels = 1.0; // the buds' plane
    const Reconstruction reconstruction(volume, options);
    expectEveryLevelAs(reconstruction, reference);
    const LevelMesh top = reconstruction.buildLevel(reconstruction.levelCount() - 1);
    const Validation v = Validator(volume).validate(top.mesh);
    EXPECT_LE(v.symmetric.max / v.voxel, 1.0);
}

namespace {

using test::realCrop;

// The smoke's voxels in the index box [lo, hi], read at `iso`.
Volume smokeCrop(const glm::ivec3& lo, const glm::ivec3& hi, double iso)
{
    return realCrop("gaffer_smoke_fog.vdb", lo, hi, iso);
}

// The top level of `volume` sliced along `axis`: within a voxel of the isosurface, and a closed,
// oriented manifold with its Euler characteristic.
void expectTopLevelWithinAVoxelAlong(const Volume& volume, Axis axis)
{
    MeshOptions options;
    options.slicing.axis = axis;
    const Reconstruction reconstruction(volume, options);
    const TriangleMesh top = reconstruction.buildLevel(reconstruction.levelCount() - 1).mesh;
    const Validation v = Validator(volume).validate(top);
    EXPECT_LE(v.symmetric.max / v.voxel, 1.0);
    const Topology t = checkTopology(top);
    EXPECT_TRUE(t.closed() && t.manifold() && t.oriented());
    EXPECT_EQ(t.euler, checkTopology(isosurface(volume, 0.0)).euler);
}

// The second build meshes an end of `volume` sliced along `axis` from its cells, and its top
// level keeps within a voxel of the isosurface.
void expectAnEndFromItsCells(const Volume& volume, Axis axis)
{
    MeshOptions options;
    options.slicing.axis = axis;
    const Reconstruction reconstruction(volume, options);
    EXPECT_GT(reconstruction.stats().endPatches, 0);
    expectTopLevelWithinAVoxelAlong(volume, axis);
}

} // namespace

// The smoke at iso 0.1 along y (a crop of its y range 176 to 200 shows the same): between y = 187
// and 188 a kidney-shaped section becomes a blob, its left arm ending inside the slab. No plane
// between agrees with the slab's 19 pieces as a whole, so the slab stays whole, and the band fanned
// from the blob's lowest point across 13 voxels of air: its top level's triangles there lay 2.23
// voxels off. Its cells close as an annulus and stray from the band's straight triangles, so they
// mesh it, and those triangles lie within a voxel of the isosurface.
TEST(Graph, ABandWhoseSlabCouldNotBeHalvedTakesItsCells)
{
    const Volume volume = smokeCrop({1, 176, 1}, {111, 200, 112}, 0.1); // its y range
    MeshOptions options;
    options.slicing.axis = Axis::Y;
    const Reconstruction reconstruction(volume, options);
    ASSERT_GT(reconstruction.stats().bandPatches, 0);
    EXPECT_LE(topLevelDistanceBetweenY(volume, reconstruction, 187.0, 188.0), 1.0);
}

// A crop of the smoke at iso 0.2 along y: between y = 63 and 64 a void about a voxel across
// drifts two voxels (voids one pixel wide come and go in the planes between). Its contours keep
// their shape, so the band was not asked whether it strays, and it cut straight through the solid
// between them, 1.04 voxels off at the top level. Contours farther apart than the smaller one's
// radius are asked now (Reconstruction::bandMayStray); the band takes its cells.
TEST(Graph, ABandBetweenContoursThatDriftApartIsAskedWhetherItStrays)
{
    const Volume volume = smokeCrop({65, 55, 35}, {85, 72, 55}, 0.2);
    MeshOptions options;
    options.slicing.axis = Axis::Y;
    const Reconstruction reconstruction(volume, options);
    const Validation v = Validator(volume).validate(reconstruction.buildLevel(reconstruction.levelCount() - 1).mesh);
    EXPECT_LE(v.symmetric.max / v.voxel, 1.0);
    EXPECT_GT(reconstruction.stats().bandPatches, 0);
}

// A crop of the smoke at iso 0.2 along x: a fork in a slab half a voxel thick, its crotch at the
// single contour's plane, whose parts fan 4 voxels across it, 2.02 voxels off at the top level.
// Its cells count -3 against the piece's -1, so they cannot mesh it; the second build halves its
// slab down to an eighth of the events' thickness instead (Reconstruction::strayingPieces), and
// the top level comes within a voxel (0.65), with the isosurface's Euler characteristic.
TEST(Graph, AStrayingForkWhoseCellsDoNotCloseGetsThinnerSlabs)
{
    const Volume volume = smokeCrop({40, 140, 20}, {59, 165, 45}, 0.2);
    expectTopLevelWithinAVoxelAlong(volume, Axis::X);
}

// A crop of the smoke at iso 0.1 along z: between planes an eighth of a voxel apart, added for
// the events between z = 38 and 39, a contour's shape changes so much that its band fanned across
// a bay of air, 1.78 voxels off at the top level. Its own contours, tiled alone, say little in so
// thin a slab, so the band is asked as the top level tiles it (Reconstruction::strayingPieces);
// its slab's cells close with two handles too many, so the whole range between the voxel planes
// is meshed from its cells (patchWholeRanges), and the top level comes within a voxel (0.70).
TEST(Graph, AStrayingBandInAThinSlabTakesItsRangeBetweenVoxelPlanes)
{
    const Volume volume = smokeCrop({23, 117, 29}, {56, 152, 56}, 0.1);
    expectTopLevelWithinAVoxelAlong(volume, Axis::Z);
}

// A crop of the smoke at iso 0.1 along y: its first plane, y = 120, holds a contour with a bay
// about 2.4 pixels wide, and the end contour below it, where only the densest voxels of that plane
// still show, keeps the part on one side of the bay. The band between them fanned the other side
// across the bay to the end contour: 1.15 voxels off at the top level, though each triangle's
// point farthest from its corners lay within a voxel. Asked at points a voxel apart over it, the
// band strays, and the second build meshes that end from its cells (patchEnd): 0.64.
TEST(Graph, AnEndBandFannedAcrossABayLeavesTheEndToItsCells)
{
    expectAnEndFromItsCells(smokeCrop({2, 120, 52}, {30, 163, 76}, 0.1), Axis::Y);
}

// Another crop, at iso 0.1 along x: its first plane, x = 42, holds a C whose one horn lies barely
// over the isovalue, and the end contour 0.65 voxel past it keeps the dense side only. The band
// between them fans the horn to it across the valley: 1.08 voxels off at the top level, where
// the field, asked within a voxel's reach over 0.88 (1.14), still found the surface. Asked within
// the reach itself, the band strays and the end is meshed from its cells.
TEST(Graph, AnEndBandStrayingJustPastAVoxelLeavesTheEndToItsCells)
{
    expectAnEndFromItsCells(smokeCrop({42, 97, 21}, {69, 144, 49}, 0.1), Axis::X);
}

// A crop at iso 0.2 along x: two walls and a hole merge in the slab 62.5 to 63, half a voxel
// thick, and a part fanned 1.21 voxels deep into the object at the top level, where no point of
// it asked outside the object strayed. Its parts are asked inside too, and its cells mesh it.
TEST(Graph, AJunctionsPartStrayingInsideTheObjectIsFound)
{
    const Volume volume = smokeCrop({47, 86, 59}, {93, 132, 99}, 0.2);
    expectEveryLevelAs(volume, Axis::X, checkTopology(isosurface(volume, 0.0)));
    expectTopLevelWithinAVoxelAlong(volume, Axis::X);
}

// Pieces of walls and holes that no construction from contours fits (fog voxels meeting along
// edges and corners within one slab) are meshed from their slab's cells (graph.h, SlabPatch): a
// crop of the smoke's blob at iso 0.1 (data/README.md's value), whose 9 such pieces were capped,
// has nothing capped, the isosurface's volume, and its topology at every level. (It had 40
// components against 35 while holes in the crop's last plane, open past it, were closed flat
// under their wall's end, and 38 while a wall was the rim of one hole only
// (AWallIsTheRimOfEveryHoleOpenPastTheLastPlane).)
TEST(Graph, PiecesNoConstructionFitsAreMeshedFromTheirCells)
{
    const Volume volume = smokeCrop({20, 20, 20}, {60, 60, 60}, 0.1);
    const Reconstruction reconstruction(volume, MeshOptions{});
    ASSERT_GT(reconstruction.stats().patches, 0); // else the crop no longer shows the case
    EXPECT_EQ(reconstruction.stats().unresolvedEvents + reconstruction.stats().unresolvedJunctions, 0);
    expectTheIsosurfacesVolume(volume, reconstruction, false);
    expectEveryLevelAs(reconstruction, checkTopology(isosurface(volume, 0.0)));
}

// A random crop of the smoke at iso 0.3, sliced along z (survey seed 111): the slab between
// z = 35 and 37 holds a void of two voxels on the plane z = 36, which no plane meets, and a handle
// its pieces miss, so its Euler characteristic agreed with the cells' and nothing cut it: a
// component short, and the void's place 1.7 voxels from the top level. A range whose middle voxel
// plane has lone voxels (EulerProfile::lone) is labelled, and one hiding a region is cut as one
// that disagrees with the cells is (matchCells): the top level is 0.71 voxel off.
TEST(Graph, AVoidAndAHandleThatCancelInOneSlabAreBothFound)
{
    const Volume volume = smokeCrop({28, 89, 31}, {58, 123, 79}, 0.3);
    expectEveryLevelAs(volume, Axis::Z, checkTopology(isosurface(volume, 0.0)));
    expectTopLevelWithinAVoxelAlong(volume, Axis::Z);
}

// A random crop of the smoke at iso 0.3, sliced along x (survey seed 112): the range from x = 35
// to 37 counted 2 fewer than the cells. Cut at x = 36 it found two specks there (+4) and missed a
// handle inside the voxel layer 35 to 36, which no finer cut shows (at a quarter voxel the loops
// join otherwise), so the cut was refused: Euler characteristic 156 against 158, with a warning,
// and 1.73 voxels off. A cut that leaves only handles inside voxel layers is kept, and a piece's
// patch takes the handle: the isosurface's topology, 0.66 voxel off.
TEST(Graph, ACutLeavingOnlyAHandleInsideAVoxelLayerIsKept)
{
    const Volume volume = smokeCrop({21, 94, 29}, {55, 142, 62}, 0.3);
    expectEveryLevelAs(volume, Axis::X, checkTopology(isosurface(volume, 0.0)));
    expectTopLevelWithinAVoxelAlong(volume, Axis::X);
}

// A random crop of the smoke at iso 0.3, sliced along x (survey seed 117): one small tube, and a
// speck of its own between the planes x = 57 and 59 that neither meets. With one start and no
// junction the cells were not compared, so the mesh had one component against the isosurface's
// two (Euler characteristic 2 against 4, 7.9 voxels off, with a warning). A region no plane meets
// (regionBetweenPlanes) now has the cells compared too, and the range is cut where the speck is.
TEST(Graph, ASpeckBesideASingleTubeThatNoPlaneMeetsIsFound)
{
    const Volume volume = smokeCrop({55, 165, 24}, {75, 190, 66}, 0.3);
    expectEveryLevelAs(volume, Axis::X, checkTopology(isosurface(volume, 0.0)));
    expectTopLevelWithinAVoxelAlong(volume, Axis::X);
}

// A random crop of the smoke at iso 0.3, sliced along z (survey seed 120): an arm 0.02 over the
// isovalue in the voxel plane z = 79 alone reaches 1.47 pixels past its tube's last contour, in a
// plane added at 79.17, where the tube ends downward. An end was left to its cells only past 1.5
// pixels, and its cap was 1.43 voxels off at the top level; past a pixel now, as a band
// (caps.cpp, kEndStray).
TEST(Graph, AnEndsArmInTheVoxelPlanePastItsLastContourIsFound)
{
    const Volume volume = smokeCrop({32, 36, 54}, {71, 59, 99}, 0.3);
    expectEveryLevelAs(volume, Axis::Z, checkTopology(isosurface(volume, 0.0)));
    expectTopLevelWithinAVoxelAlong(volume, Axis::Z);
}

// A crop of the smoke at iso 0.3 along y: in the plane added at 100.25 an arm meets a body at a
// pinch diagonal across the cells (inside at one pixel on the voxel plane below, at the other on
// the plane above), which the interpolated plane joins; a quarter voxel up, the arm joins the body
// through the cells. The merge in that slab counts a handle in its cells that the voxel planes
// around do not, no plane halves it, and its part fanned across a bay, 1.30 voxels off at the top
// level. The range between the voxel planes is meshed from its cells (patchFindsHandles).
TEST(Graph, AJunctionWhoseCellsCountAHandleTheVoxelPlanesDoNotTakesTheWholeRange)
{
    const Volume volume = smokeCrop({71, 76, 37}, {101, 120, 84}, 0.3);
    expectEveryLevelAs(volume, Axis::Y, checkTopology(isosurface(volume, 0.0)));
    expectTopLevelWithinAVoxelAlong(volume, Axis::Y);
}

// A crop at iso 0.1 along z: the first build halves the slab of a straying merge between z = 38
// and 38.5 (thinJunctions). The plane the second build adds at 38.375 cuts a wall's band from
// 38.25 to 38.5, which kept to the surface, and its lower half fans a vertex across a void to the
// far wall: 1.84 voxels off at the top level. The second build's pieces in the halved ranges are
// asked too, and a third build meshes the range 38 to 39 from its cells.
TEST(Graph, ABandThePlanesOfAHalvedSlabCutAnewIsAskedToo)
{
    expectTopLevelWithinAVoxelAlong(smokeCrop({31, 104, 32}, {76, 146, 80}, 0.1), Axis::Z);
}

// A crop at iso 0.1 along y, sliced 2 voxels apart: the voxel plane y = 32 between two slices
// has a pit a pixel wide in a contour, 1.3 pixels deep, which the band from 31 to 33 fills: 1.14
// voxels off at the top level. Measured along the profiles' 64 directions, the middle plane's
// loop lay 0.88 pixel from the band; along 256 it lies 1.12, and the band takes that plane
// (Reconstruction::splitBand).
TEST(Graph, APitAPixelWideBetweenSlicesSplitsItsBand)
{
    expectTopLevelWithinAVoxelAlong(smokeCrop({39, 19, 15}, {79, 60, 53}, 0.1), Axis::Y);
}

// A crop of the vmtk aorta sliced along z, whose voxels are 1.5 long along z and 0.88 across: a
// vessel's floor lying nearly in the slicing planes reaches about 0.45 voxel of z (0.77 of the
// smallest edge) below where the axis through its first contour's central point leaves it. That
// was under the half voxel past which the end contour goes to the farthest reach instead, and the
// cap lay 1.25 voxels off at the top level. The half voxel is of the smallest edge now.
TEST(Graph, AnEndsSlackIsHalfTheSmallestVoxelEdge)
{
    expectTopLevelWithinAVoxelAlong(realCrop("vmtk_aorta_ls.vdb", {53, 126, 5}, {105, 163, 27}, std::nullopt), Axis::Z);
}

// Another crop of the aorta along z: a top end whose end contour is not star-shaped from its
// central point, so that its cap is ear-clipped flat in the contour's plane. Its end contour went
// a quarter voxel of z short of the apex, and the region reached 0.54 voxel of z past it: 1.36
// voxels off at the top level. A flat cap's end contour goes to the farthest reach (addEndContour).
TEST(Graph, AFlatCapsEndContourGoesToTheFarthestReach)
{
    expectTopLevelWithinAVoxelAlong(realCrop("vmtk_aorta_ls.vdb", {75, 119, 5}, {95, 157, 61}, std::nullopt), Axis::Z);
}

// A crop of the aorta along z (survey seed 2, run 0), at a corner of its box: the region past a
// tube's last slice, z = 21, parts into two summits by z = 21.55, where the end contour kept the
// larger, and the band to it cut the other off, 0.2 voxel of z higher: 1.18 voxels off at the top
// level. The end contour is halved back to a plane that still joins them (addEndContour).
TEST(Graph, AnEndContourHoldsEverySummitOfItsEnd)
{
    expectTopLevelWithinAVoxelAlong(realCrop("vmtk_aorta_ls.vdb", {64, 101, 5}, {87, 126, 30}, std::nullopt), Axis::Z);
}

// Another (seed 3, run 4): a sliver along a face of the box reaches 0.4 voxel of z past the last
// slice, under the quarter voxel of z inside it that an end contour keeps and the quarter voxel it
// steps at least: capped flat at the slice, 1.12 voxels off. Both are quarters of the smallest edge
// now, and the end contour holds the sliver's summits (above): 0.91.
TEST(Graph, AnEndsInsetIsAQuarterOfTheSmallestVoxelEdge)
{
    expectTopLevelWithinAVoxelAlong(realCrop("vmtk_aorta_ls.vdb", {77, 155, 5}, {97, 179, 35}, std::nullopt), Axis::Z);
}

// Survey crop 124/12, at iso 0.1 along z: a band in a slab a voxel thick (z = 82 to 83) between
// contours whose shapes differ by 2.06 pixels, under the 3 that has a band asked while the skeleton
// is decided (Reconstruction::shapeMayStray). Its middle plane's loop lies 0.87 pixel from its
// straight surface along the graph's directions and 0.91 along four times as many, under the
// pixel that splits it (splitBand); the top level's triangles cut a corner of the surface the
// profiles' points do not sample: 1.04 voxels off. A band measured within half a pixel of the
// bound is asked as the top level tiles it (strayingPieces), and takes its cells: 0.73.
TEST(Graph, ABandNearTheBoundIsAskedAsTheTopLevelTilesIt)
{
    expectTopLevelWithinAVoxelAlong(smokeCrop({61, 122, 61}, {84, 164, 100}, 0.1), Axis::Z);
}

// The first of the aorta's crops above (seed 2, run 0) sliced along x: the contours at x = 73 and
// 74 are nearly the same where the box's face y = 126 meets the vessel's top at a right angle, but
// the track of central points came within a pixel of the boundary at 74 and jumped 3.5 pixels to
// its centroid, and the band, pairing rays by index from both centres, joined the corner's
// crossings on the top of one to those on the side of the other: 1.07 voxels off. The centres
// before such a jump follow it back where that keeps the bands in better register (0.79).
TEST(Graph, TheCentresBeforeAJumpToTheCentroidFollowItBack)
{
    expectTopLevelWithinAVoxelAlong(realCrop("vmtk_aorta_ls.vdb", {64, 101, 5}, {87, 126, 30}, std::nullopt), Axis::X);
}

// Carotid crop survey 3/15 (box 46,43,133..85,63,157, sliced along x): the vessel's section
// shrinks as x grows, and between x = 57.375 and 57.5, a slab an eighth of a voxel thick, the top
// level's band fanned from a crossing at z = 153.1 to the crossings on the box's face z = 157.3,
// across the vessel's inside: points of its triangles lay 1.26 voxels inside (1.20 voxels off as
// the validator samples), but the band was asked only at each triangle's point farthest from its
// corners, all within 0.82. Such bands are asked at points all over, inside too, and this one
// takes its cells: 0.55.
TEST(Graph, ABandAcrossTheInsideIsAskedAllOver)
{
    expectTopLevelWithinAVoxelAlong(
        realCrop("ts_common_carotid_artery_left_ls.vdb", {46, 43, 133}, {85, 63, 157}, std::nullopt), Axis::X);
}

// Smoke crop survey 138/3 (box 12,36,29..59,84,76, iso 0.1, sliced along z) was 1.14 voxels off
// at the top level: its worst triangles shared a node of a fork's chord at (45.44, 81.68, 35.5), in
// the single contour's plane, where the field is 0.34, deep inside; the partners' plane half a
// voxel above is inside there too (0.18), so the crotch lies farther up. The fork's parts were
// asked at points all over but none within a voxel of a corner, corners being crossings
// elsewhere. A junction's corners are asked too now, and the fork takes its cells: 0.77.
TEST(Graph, AForksChordNodeDeepInsideIsAsked)
{
    expectTopLevelWithinAVoxelAlong(smokeCrop({12, 36, 29}, {59, 84, 76}, 0.1), Axis::Z);
}

// Known gaps of issue 13 (README, the crop survey), strict and registered with ctest as expected
// failures (CMakeLists.txt).

// Survey crop 116/10, at iso 0.2 along y: the smoke cut by the crop's last plane, y = 94, is capped
// by a fan from that plane's contour to a point at 94.21 that passes over pixels of the plane where
// the field is 0.17 to 0.18, outside, between two lobes: 1.004 voxels off at the top level.
TEST(KnownGap, AnEndAtACropsFaceKeepsOffItsNotches)
{
    expectTopLevelWithinAVoxelAlong(smokeCrop({37, 61, 46}, {79, 94, 76}, 0.2), Axis::Y);
}

// Aorta crop survey 2/24 (box 53,93,5..103,127,30, sliced along x): 1.86 voxels off at the top
// level. The section shrinks away from the box's face y = 127 as x grows; its centroid moves
// faster than a tube travels, so the centres stand, until the section leaves them and they jump
// 12 pixels; followed back, the new track stops at x = 80, where the section cannot take it, and
// the band from x = 79, between two nearly equal contours, pairs rays from centres 12 pixels
// apart across the corners at the face. Letting the jump land where the bands are in best
// register in all took this to 1.45, but the survey's runs over a voxel from 5 to 6 (note). With
// every band that may stray asked as the top level tiles it, not from its own two contours, it is
// 1.09 voxels off; not traced again.
TEST(KnownGap, ASectionShrinkingFromACropsFaceKeepsItsCentres)
{
    expectTopLevelWithinAVoxelAlong(realCrop("vmtk_aorta_ls.vdb", {53, 93, 5}, {103, 127, 30}, std::nullopt), Axis::X);
}

// Nor does a smooth tube have such a region: the phantom pays for no cells (they would cost about
// half its time).
TEST(Graph, NoRegionLiesBetweenThePlanesOfTheSmoothSamples)
{
    for (const char* name : {"phantom", "straight", "torus-flat"})
        for (Axis axis : {Axis::X, Axis::Y, Axis::Z}) {
            const Volume& volume = test::cachedSample(name);
            SliceOptions slicing;
            slicing.axis = axis;
            const SlicePlan plan = planSlices(volume, slicing);
            EXPECT_FALSE(regionBetweenPlanes(volume, plan.axis, plan.positions)) << name << " along " << int(axis);
        }
}

// A random crop of the smoke at iso 0.3, sliced along y, is a manifold with the isosurface's
// topology at every level. A ring in the added plane y = 66.5 is the single contour of a merge
// below, cut open by a keyhole whose slit (flat in that plane, facing down) spans a saddle pixel;
// the slab above is a patch from its cells, whose cube over that pixel has saddles on both faces.
// Fanned from a point on the ring, that cube's cycle drew the slit's crossing as a chord of its
// own, with a triangle lying flat in the plane: four triangles on one edge, Euler characteristic
// 123 against 122. Patches' cycles now fan from a point off their planes (graph.cpp, fanApex).
TEST(Graph, ARandomCropOfTheSmokeIsAManifold)
{
    const Volume volume = smokeCrop({61, 23, 42}, {95, 67, 65}, 0.3);
    expectEveryLevelAs(volume, Axis::Y, checkTopology(isosurface(volume, 0.0)));
}

// A random crop of the smoke at iso 0.3, sliced along x: in the plane x = 66 two walls merge into
// a ring whose hole, under a pixel across, closes at once (a flat cap). A keyhole cuts the ring
// open, its slit flat in that plane beside the hole. The hole's ring runs clockwise, and its cap's
// ear clipping took a reflex corner of it for an ear: at level 1 a triangle of the cap lay over
// the slit's, three edges with four triangles (Euler characteristic 175 against 172; level 0,
// with fewer crossings on the hole, was right). Ear clipping now follows the ring's turn (caps.h).
TEST(Graph, AHolesFlatCapBesideAKeyholeLeavesItsSlitAlone)
{
    const Volume volume = smokeCrop({29, 75, 63}, {70, 111, 89}, 0.3);
    expectEveryLevelAs(volume, Axis::X, checkTopology(isosurface(volume, 0.0)));
}

// A random crop of the smoke at iso 0.1, sliced along x: three voids of four voxels, two side by
// side in each of two voxel planes, the pairs joined across the planes along voxel edges. Where
// planes were added between, the interpolation closed each void's way out, which volumeToMesh opens
// through those edges; only a single enclosed voxel's was shown open, so each void was two
// components (97 against 94, with three handles more, Euler characteristic 162 either way). A plane
// now shows the way out of a pocket of up to four voxels too (slicer.cpp, showContacts).
TEST(Graph, AVoidOfTwoVoxelPairsJoinedAcrossAVoxelPlaneIsOneComponent)
{
    const Volume volume = smokeCrop({57, 20, 33}, {102, 46, 63}, 0.1);
    expectEveryLevelAs(volume, Axis::X, checkTopology(isosurface(volume, 0.0)));
}

// A random crop of the smoke at iso 0.2, sliced along z: between z = 61 and 63 a speck that no
// plane meets, and between 60 and 61 a handle the slabs miss, so the two ranges' differences with
// the cells cancel (+2, -2). Taken for one critical point placed on either side of z = 61, neither
// range was cut again: a patch took the handle later, but nothing found the speck (Euler
// characteristic 84 against 86, 44 components against 45). Every range whose pieces miss the
// cells' count is now cut again where a cut matches (graph.h). With two levels: the finest rays
// set the directions of the profiles that decide which bands are halved, and with four, other
// planes showed the speck.
TEST(Graph, ASpeckNextToAMissedHandleIsFound)
{
    const Volume volume = smokeCrop({66, 123, 53}, {104, 149, 103}, 0.2);
    const Reconstruction reconstruction = slicedAlong(volume, Axis::Z, 2);
    EXPECT_GT(reconstruction.graph().cellMatches, 0);
    expectEveryLevelAs(reconstruction, checkTopology(isosurface(volume, 0.0)));
}

// A random crop of the smoke at iso 0.2, sliced along x: between x = 67 and 68 a hollow arm's
// lumen opens to the outside. At 67 a pocket of air at (y, z) = (23, 64), joined to the lumen by a
// saddle, lies where at 68 a notch of the outside reaches in. Each plane shows a wall around a
// hole, each paired one to one, so the slab was taken for two bands without a look at its voxels:
// a handle short (Euler characteristic 2 against 0), and no patch could take it, as the slab's
// labels tell the two bands' loops to one region. A hole that the other plane's wall does not
// seal now sends the slab to the labelling (graph.cpp, holesSealed).
TEST(Graph, ALumenOpeningBetweenTwoPlanesIsAHandle)
{
    const Volume volume = smokeCrop({54, 3, 60}, {87, 25, 83}, 0.2);
    expectEveryLevelAs(volume, Axis::X, checkTopology(isosurface(volume, 0.0)));
}

// A random crop of the smoke at iso 0.1, sliced along x with two levels (planes two voxels
// apart): a void at x = 72 ends by 73 at (y, z) = (22, 70), and another starts diagonally beside
// it, at (22, 71), before 74. Their holes, one in each plane, overlap, so the slab passed for a
// band of air without a look at its voxels, and no cut could part what that band joined (Euler
// characteristic 10 against 12, 6 components against 7, with a warning). Where the cells disagree
// with a range of slabs, its slabs are labelled now.
TEST(Graph, AVoidThatEndsBesideOneThatStartsIsNoBand)
{
    const Volume volume = smokeCrop({54, 3, 60}, {87, 25, 92}, 0.1);
    expectEveryLevelAs(slicedAlong(volume, Axis::X, 2), checkTopology(isosurface(volume, 0.0)));
}

// A random crop of the smoke at iso 0.2, sliced along z with two levels: at z = 37 a speck of one
// pixel, (x, y) = (86, 91), meets the body diagonally at a saddle that volumeToMesh leaves open,
// so the speck is a component of its own (z 36.8 to 37.3). A plane added at 37.5 for a merge saw
// the interpolated field join them, and the Euler characteristic still came out at the cells' 8
// (a handle fewer besides), so nothing warned: 11 components against 12. A plane added between
// voxel planes must now join the slab's loops as the slab does, or the slab stays whole.
TEST(Graph, ASpeckTouchingABodyAtASaddleStaysApartAtAnAddedPlane)
{
    const Volume volume = smokeCrop({54, 89, 10}, {100, 114, 38}, 0.2);
    expectEveryLevelAs(slicedAlong(volume, Axis::Z, 2), checkTopology(isosurface(volume, 0.0)));
}

// A random crop of the smoke at iso 0.2, sliced along y: the planes stop at 47, a voxel short of
// the box, and past them lie a speck 0.4 voxel across at (41, 48, 66) and a handle of the body
// that the pieces out to empty space miss. The two make up the cells' count there, so the box's
// last voxel plane was not added: 11 components against 12, with no warning. It is added now
// wherever the cells are compared and the planes stop short.
TEST(Graph, ASpeckPastTheLastPlaneBesideAMissedHandleIsFound)
{
    const Volume volume = smokeCrop({35, 21, 56}, {48, 48, 82}, 0.2);
    expectEveryLevelAs(volume, Axis::Y, checkTopology(isosurface(volume, 0.0)));
}

// A random crop of the smoke at iso 0.2, sliced along z: a void of one voxel at z = 36, which
// volumeToMesh keeps apart from a void beside it below (it joins the dense pair across their
// voxel edge). A plane added at 35.5 for another event shows that contact as a bridge, so the
// void's contour at 36 is a component of its own, ending within the slabs on either side; but the
// field goes on past 35.5, and the search for its apex, held within half a voxel past the next
// plane, found none. Dropped as a lone contour enclosing nothing, the mesh lost a component
// (Euler characteristic 88 against 90). It fans round an apex in the slab's middle now.
TEST(Graph, AVoidOfOneVoxelThatABridgeClosesIsNotDropped)
{
    const Volume volume = smokeCrop({43, 98, 25}, {82, 120, 71}, 0.2);
    const Reconstruction reconstruction(volume, MeshOptions{});
    EXPECT_EQ(reconstruction.stats().droppedFlat, 0);
    expectEveryLevelAs(reconstruction, checkTopology(isosurface(volume, 0.0)));
}

// A random crop of the smoke at iso 0.2, sliced along y: two walls merge at y = 152.5 and the
// contour forks at 153 into a wall and a hole inside it, which end together in the slab above (a
// rim, the slab says): a ring, a handle. Sought along the hole's axis, the field closed over the
// hole past the plane (a lid), so hole and wall were capped each on its own: a sphere (Euler
// characteristic 56 against 54, with no warning). The slab's rim now joins them by an annulus.
TEST(Graph, ARimTheSlabFindsIsARimWhateverTheFieldAlongTheHole)
{
    const Volume volume = smokeCrop({71, 125, 51}, {95, 174, 74}, 0.2);
    expectEveryLevelAs(volume, Axis::Y, checkTopology(isosurface(volume, 0.0)));
}

// A random crop of the smoke at iso 0.1, sliced along x: its last plane, 72, a voxel short of the
// box, holds a wall and five holes open past it (dimples in the face the box cuts: a Rim piece
// out to the empty plane past the box). Along their axes the field closed over four of them (a
// lid each), so only one joined the wall and four were voids of their own (Euler characteristic
// 100 against 92, 77 components against 74). The piece now marks them all as the wall's rim, and
// the wall is a face with five holes.
TEST(Graph, HolesOpenPastTheLastPlaneAreTheWallsRimWhateverTheirAxes)
{
    const Volume volume = smokeCrop({32, 24, 48}, {73, 57, 75}, 0.1);
    expectEveryLevelAs(volume, Axis::X, checkTopology(isosurface(volume, 0.0)));
}

// A random crop of the smoke at iso 0.1, sliced along z: walls of the last plane, 100, join past
// it, before the box ends at 101, around a handle: two pieces of several walls against the empty
// plane past the box. Capped each on its own, they were separate objects (Euler characteristic
// 112 against 108, 60 components against 59). Such a piece is now meshed from its cells out to
// that empty plane (patchPastTheBox).
TEST(Graph, ContoursOfTheLastPlaneThatJoinPastItArePatchedToTheBox)
{
    const Volume volume = smokeCrop({60, 85, 80}, {109, 113, 101}, 0.1);
    MeshOptions options;
    options.slicing.axis = Axis::Z;
    const Reconstruction reconstruction(volume, options);
    EXPECT_GE(reconstruction.stats().patches, 2); // the one in its range, and at least one past the box
    expectEveryLevelAs(reconstruction, checkTopology(isosurface(volume, 0.0)));
}

// A random crop of the smoke at iso 0.2, sliced along z: the box cuts a ring at its first plane,
// 55, and a keyhole cuts the ring open there towards the branches above. The keyhole's slit lay
// flat in the plane over the annulus that closed the ring's material below, and its polygon had
// no triangulation without a diagonal the annulus had too: at level 0 an edge with four
// triangles (Euler characteristic 65 against 64). The cut face is meshed from its cells now.
TEST(Graph, AKeyholesSlitAtACutFaceLiesOverNoAnnulus)
{
    const Volume volume = smokeCrop({24, 83, 55}, {50, 104, 94}, 0.2);
    expectEveryLevelAs(volume, Axis::Z, checkTopology(isosurface(volume, 0.0)));
}

// A crop of the smoke at iso 0.1, sliced along x: the cells count a handle between the voxel
// planes x = 37 and 38 that spans the planes added there for the events' crotches, so that no
// slab's patch finds it (Euler characteristic 38 against 36, and a warning). The range's pieces,
// taken across the whole range and patched from its cells, find it (patchWholeRanges).
TEST(Graph, AHandleAcrossThePlanesAddedInsideAVoxelIsPatchedWhole)
{
    const Volume volume = smokeCrop({37, 175, 48}, {57, 209, 72}, 0.1);
    expectEveryLevelAs(volume, Axis::X, checkTopology(isosurface(volume, 0.0)));
}

// A crop of the smoke at iso 0.1, sliced along y: between the voxel planes y = 161 and 162 the
// slabs' pieces add up to the cells' count, but a piece no construction fits, between 161 and the
// plane added at 161.5 (where no rule decides a saddle), patched from its cells had a handle the
// cells do not count (Euler characteristic 132 against 134). The range's pieces taken whole and
// patched from its cells give the cells' count, and each takes its own patch's handles.
TEST(Graph, APatchBetweenAVoxelPlaneAndAnAddedOneFindsNoHandleTheCellsLack)
{
    const Volume volume = smokeCrop({9, 120, 19}, {49, 169, 47}, 0.1);
    expectEveryLevelAs(volume, Axis::Y, checkTopology(isosurface(volume, 0.0)));
}

namespace {

// Every level of the smoke sliced along `axis` against volumeToMesh's isosurface.
void expectTheSmokesTopology(Axis axis)
{
    const Volume volume = readVolume(test::realData("gaffer_smoke_fog.vdb"));
    expectEveryLevelAs(volume, axis, checkTopology(isosurface(volume, 0.0)));
}

} // namespace

// Gaffer's smoke as a whole, sliced along its longest side (y), along x or along z, has the
// isosurface's topology at every level (Euler characteristic 386, 231 components, at the default
// isovalue just above the value 19 of its voxels hold: README, Isovalue). Along y its 8 pieces of
// walls and holes that no construction fits are patched from their cells (capped contour by contour
// they gave 484 and 260 components), and so are 7 pieces in ranges where the cells count fewer than
// the pieces and the patch finds the handles they miss, no more than the cells count (two patches
// between 16 and 17 each found its one handle: 384). Along x the ranges where the pieces fall short
// of the cells are cut again, and a cut may add a component of its own (a speck between slices)
// where it joins the range's end loops as before: 350 and 214 components without. Along z two
// one-voxel voids that volumeToMesh opens across a voxel edge, between voxel planes with a plane
// added between them, were components of their own (233 components) until such planes showed that
// edge's outside pair joined (AVoidThatVolumeToMeshOpensAcrossAVoxelEdgeOpensBetweenVoxelPlanes).
TEST(Graph, TheSmokeHasTheIsosurfaceTopology)
{
    for (const Axis axis : {Axis::Y, Axis::X, Axis::Z}) {
        SCOPED_TRACE(static_cast<int>(axis));
        expectTheSmokesTopology(axis);
    }
}

// At iso 0.1 (data/README.md's value) the smoke is its whole plume: one blob full of channels,
// 1314 small components round it (volumeToMesh's count), and the mesh has the isosurface's
// topology at every level (Euler characteristic 1174). Five of those components are specks in
// one voxel plane, each a lone contour in a plane of the plan, which the slices dropped as flat
// pillows (ASpeckInOneVoxelPlaneIsAComponentOfItsOwn): 1164 and 1310.
TEST(Graph, TheSmokesWholePlumeHasTheIsosurfaceTopology)
{
    VolumeOptions read;
    read.iso = 0.1;
    const Volume volume = readVolume(test::realData("gaffer_smoke_fog.vdb"), read);
    expectEveryLevelAs(volume, Axis::Y, checkTopology(isosurface(volume, 0.0)));
}

namespace {

struct Capsule {
    glm::dvec3 a, b;
    double radius;
};

// The level set of a union of capsules, voxels of 1 on [0, 112)^3.
Volume capsuleUnion(const std::vector<Capsule>& capsules, const std::string& source)
{
    return samples::levelSetFromDistance(
        [&](const glm::dvec3& p) {
            double d = std::numeric_limits<double>::infinity();
            for (const Capsule& c : capsules) d = std::min(d, samples::capsuleDistance(p, c.a, c.b, c.radius));
            return d;
        },
        {112, 112, 112}, 1.0, source);
}

} // namespace

namespace {

// Three generations of capsules (radii 7, 5.25, 3.94; 2 or 3 children each, directions drawn at
// random, seeds 0 and 1 of a numpy generator, rounded to a tenth of a voxel) whose branches run
// into each other: overlaps of up to 6 voxels close loops, and where three nearly meet the gaps
// between them are tunnels a voxel or two across.
const std::vector<std::vector<Capsule>>& crossingTrees()
{
    static const std::vector<std::vector<Capsule>> trees = {{{{56, 56, 10}, {56, 56, 39.6}, 7.0},
                                                             {{56, 56, 39.6}, {68.5, 58.1, 62.7}, 5.25},
                                                             {{68.5, 58.1, 62.7}, {86.1, 67.4, 70.1}, 3.94},
                                                             {{68.5, 58.1, 62.7}, {69.1, 59.7, 77}, 3.94},
                                                             {{56, 56, 39.6}, {40.7, 47, 54}, 5.25},
                                                             {{40.7, 47, 54}, {41.3, 42, 72.5}, 3.94},
                                                             {{40.7, 47, 54}, {31.7, 52.1, 73.1}, 3.94},
                                                             {{56, 56, 39.6}, {45.8, 50.9, 61}, 5.25},
                                                             {{45.8, 50.9, 61}, {39.4, 47.3, 77.6}, 3.94},
                                                             {{45.8, 50.9, 61}, {42.8, 39.2, 78.5}, 3.94}},
                                                            {{{56, 56, 10}, {56, 56, 38.1}, 7.0},
                                                             {{56, 56, 38.1}, {58.4, 46.4, 57.4}, 5.25},
                                                             {{58.4, 46.4, 57.4}, {55.7, 46, 71.4}, 3.94},
                                                             {{58.4, 46.4, 57.4}, {62.9, 44.4, 76.9}, 3.94},
                                                             {{58.4, 46.4, 57.4}, {55, 46.1, 74.2}, 3.94},
                                                             {{56, 56, 38.1}, {47.7, 53.3, 56.5}, 5.25},
                                                             {{47.7, 53.3, 56.5}, {50.2, 36, 61.7}, 3.94},
                                                             {{47.7, 53.3, 56.5}, {40.4, 53.4, 69.5}, 3.94},
                                                             {{56, 56, 38.1}, {48.5, 53.5, 63.3}, 5.25},
                                                             {{48.5, 53.5, 63.3}, {52.7, 43, 72.5}, 3.94},
                                                             {{48.5, 53.5, 63.3}, {45.8, 40.5, 72.5}, 3.94}}};
    return trees;
}

} // namespace

// A crop of the smoke at iso 0.1, sliced along y: a speck two pixels across ends at y = 108.66 in
// an end contour, and the next end contour past it was sought in a plane that holds that contour
// alone, so no other loop kept it off the ring of 1698 pixels that encloses the speck's centre at
// y = 109.11: the speck's band fanned to that ring, capped flat inside the solid, 5.8 voxels from
// the isosurface. End contours now keep off the loops of the tube's last plane of the graph. The
// bound is the crop's known gap: its noisy contours' bands elsewhere lie up to 1.7 voxels off
// (the ring trees' misregistration, README).
TEST(Graph, AnEndContourPastAnotherKeepsOffOtherObjects)
{
    const Volume volume = smokeCrop({25, 100, 20}, {95, 116, 90}, 0.1);
    MeshOptions options;
    options.slicing.axis = Axis::Y;
    const Reconstruction reconstruction(volume, options);
    expectOnTheIsosurface(volume, reconstruction.buildLevel(reconstruction.levelCount() - 1).mesh, 2.0);
}

// A bar's end with a spike one pixel wide, a voxel past it and short of the next plane (the smoke
// along x: a blob's end at x = 35 whose corner pixel reaches x = 36.5, 1.12 voxels off). The
// spike's neighbours are just below the isovalue, so no cell centre (the average of four pixels)
// in the end contour lies in the spike: probed from cell centres only, the end was capped a voxel
// short of it (1.15). farthestReach probes the pixels' own centres too.
TEST(Graph, AnEndsSpikeOnePixelWideIsReached)
{
    test::TempDir dir;
    const std::string path = dir.path("spike.vdb");
    test::writeFogVoxelsVdb(path, {14, 14, 20}, [](int x, int y, int z) {
        if (x >= 3 && x <= 10 && y >= 3 && y <= 10 && z >= 2 && z <= 14) return 1.0f; // the bar
        if (z != 15) return 0.0f;
        const int fromSpike = std::abs(x - 4) + std::abs(y - 4);
        return fromSpike == 0 ? 1.0f : fromSpike == 1 ? 0.45f : 0.0f;
    });
    VolumeOptions read;
    read.iso = 0.5;
    const Volume volume = readVolume(path, read);
    MeshOptions options;
    options.slicing.axis = Axis::Z;
    options.slicing.spacingVoxels = 2.0; // planes at 14 and 16, the spike's tip between them
    const Reconstruction reconstruction(volume, options);
    expectTopLevelOnTheIsosurface(volume, reconstruction);
}

// A crop of the smoke at iso 0.2 (sliced along z, its default): at the crop's last voxel plane,
// z = 71, a contour of 235 pixels has an arm that ends within a quarter voxel past it, while the
// rest reaches on. The end contour there, of 56 pixels, could not be brought into register (3.7
// pixels apart on average), and its band fanned the arm's crossings across air to one point 12
// voxels away: 2.30 voxels off at the top level. An end contour still out of register once its
// step is a quarter voxel or less is no end of the contour, which is capped instead.
TEST(Graph, AnEndContourOutOfRegisterIsNoEnd)
{
    expectTopLevelOnTheIsosurface(smokeCrop({43, 98, 25}, {82, 120, 71}, 0.2), Axis::Z);
}

// A crop of the smoke at iso 0.1, sliced along z: at the crop's first plane, z = 71, a contour is
// U-shaped, a bar and a blob joined by a thin arm, and the field dies out past the box. The end
// contour past it keeps the blob alone: 2.25 pixels from the last contour on average, under the
// bound, but its band fanned the bar across 14 pixels of air to the blob, 4.05 voxels off at every
// level. An end contour whose band would fan a part of the contour across a gap wider than that
// bound is out of register too.
TEST(Graph, AnEndContourThatFansAcrossAGapIsNoEnd)
{
    expectTopLevelOnTheIsosurface(smokeCrop({42, 146, 71}, {66, 173, 97}, 0.1), Axis::Z);
}

// A crop of the smoke at iso 0.2, sliced along y: a tube's first contour, at y = 115, has no end
// contour in register below it, so it was capped at the contour, 1.16 voxels from where the
// surface goes on past the plane. The cells of the graph's piece that starts the tube close it
// (a disk), and mesh it now: 0.64. (The same takes crop s102_1's top level from 2.08 to 1.06.)
TEST(Graph, AnEndWithNoEndContourInRegisterTakesItsCells)
{
    expectTopLevelOnTheIsosurface(smokeCrop({70, 93, 60}, {108, 140, 86}, 0.2), Axis::Y);
}

// A crop of the smoke at iso 0.3, sliced along y: a tube starts at y = 100 with a loop of a few
// pixels, and in the voxel plane below, 99, its region reaches 4 voxels past that loop (a ledge
// barely past the isovalue, gone again by 98). Its end contour, 1.37 voxels on at 98.6, was in
// register with the loop, and the band to it passed the ledge by: 2.48 voxels off at the top
// level. From a voxel plane, the first end contour now goes no farther than the next one.
TEST(Graph, AnEndContourStopsAtTheNextVoxelPlane)
{
    expectTopLevelOnTheIsosurface(smokeCrop({30, 92, 76}, {78, 113, 104}, 0.3), Axis::Y);
}

// The same crop sliced along z: a blob's contour at z = 94 ends before 96, and in the voxel plane
// between, its flat top (barely past the isovalue) reaches 2 pixels beyond the contour. The axis
// through the contour's central point leaves the blob at 95.0, so the end contour a quarter voxel
// below was a sliver of it, and the cap left that top 2.40 voxels from the mesh. An end that a
// voxel plane before the next plane shows wider than its contours takes its piece's cells.
TEST(Graph, AnEndThatAVoxelPlaneShowsWiderTakesItsCells)
{
    const Volume volume = smokeCrop({30, 92, 76}, {78, 113, 104}, 0.3);
    const Reconstruction reconstruction = slicedAlong(volume, Axis::Z);
    ASSERT_GT(reconstruction.stats().endPatches, 0);
    expectTopLevelOnTheIsosurface(volume, reconstruction);
}

// A crop of the smoke at iso 0.2, sliced along z: a tube ends past z = 83, its end contour and
// cap's apex (83.55) a small knob at one side of it, while the voxel plane 84 shows the end's
// region 2 pixels past the contour at the other side. The voxel planes up to the next plane are
// looked at, whatever the apex: 2.32 voxels off at the top level before.
TEST(Graph, AnEndWhoseApexFallsShortOfItsVoxelPlaneTakesItsCells)
{
    expectTopLevelOnTheIsosurface(smokeCrop({48, 31, 65}, {96, 63, 111}, 0.2), Axis::Z);
}

// A crop of the smoke at iso 0.2, sliced along z: a tube starts at z = 64, and in the voxel plane
// below, 63, its region lies in two parts. The end contour followed one part; the other, against
// the crop's face, lay a voxel below the contour's cap and reached on to 62.6: 1.40 voxels off at
// the top level. An end whose voxel plane shows a loop that none of its contours within half a
// voxel overlaps takes its cells.
TEST(Graph, AnEndThatPartsBeforeItEndsTakesItsCells)
{
    expectTopLevelOnTheIsosurface(smokeCrop({6, 116, 52}, {30, 148, 95}, 0.2), Axis::Z);
}

// A crop of the smoke at iso 0.2, sliced along z: in the slab from 51 to 51.5, three contours
// merge into one. The part of the single contour that one of them got was a few points at its
// side, and the merge fanned that contour's whole loop, 7 pixels across, to them: triangles
// nearly flat across the slab, 1.50 voxels off at the top level. The top level's junctions are
// now tiled once first, and this one, straying more than a voxel from the isosurface, takes its
// piece's cells: 0.74.
TEST(Graph, AJunctionWhosePartsStrayFromTheSurfaceTakesItsCells)
{
    const Volume volume = smokeCrop({31, 20, 40}, {64, 53, 87}, 0.2);
    const Reconstruction reconstruction = slicedAlong(volume, Axis::Z);
    ASSERT_GT(reconstruction.stats().junctionPatches, 0);
    expectTopLevelOnTheIsosurface(volume, reconstruction);
}

// A crop of the smoke at iso 0.2, sliced along z: between the planes 54 and 55 a contour grows by
// 4.6 pixels, and its band, out of register and tiled by area, fanned one vertex of the plane
// below across 3 pixels of the plane above: 1.45 voxels off at the top level. Bands in slabs
// thicker than half a voxel whose contours change shape by more than 3 pixels are tiled once
// first too, and this one, straying more than a voxel, takes its cells: 0.69.
TEST(Graph, ABandThatFansAcrossItsSlabTakesItsCells)
{
    expectTopLevelOnTheIsosurface(smokeCrop({34, 18, 25}, {55, 68, 70}, 0.2), Axis::Z);
}

// A crop of the smoke at iso 0.1, sliced along x: at x = 54.5 a ring (a wall and its hole) is the
// one contour of a merge from below and of a fork above, and each cut it open by a keyhole. Both
// took the same slit, whose flat faces, one from below and one from above, lay on each other:
// from level 2 on, 4 and 8 edges of four triangles and Euler characteristics -6 and -2 against
// -10. The second slit keeps clear of the first.
TEST(Graph, ARingCutOpenFromBothSidesIsCutInTwoPlaces)
{
    const Volume volume = smokeCrop({40, 142, 41}, {65, 191, 89}, 0.1);
    expectEveryLevelAs(slicedAlong(volume, Axis::X), checkTopology(isosurface(volume, 0.0)));
}

// A crop of the smoke at iso 0.1, sliced along y: a tube's first pass over its end at y = 66 placed
// an end contour and found no apex past it, and the second pass, which seeks the end from points
// all over the contour, took the end's cells, and the end contour stayed: 8 edges open and 12
// shared by four triangles at the coarsest level. An end contour of an earlier pass stays, and
// so does the end.
TEST(Graph, AnEndSoughtTwiceKeepsItsFirstEndContour)
{
    const Volume volume = smokeCrop({50, 56, 54}, {87, 90, 91}, 0.1);
    expectEveryLevelAs(slicedAlong(volume, Axis::Y), checkTopology(isosurface(volume, 0.0)));
}

// A crop of the smoke at iso 0.1, sliced along z: against the crop's face x = 50 a band from
// z = 94 to 96 passes a bulge in the voxel plane between, 1.41 pixels past its straight triangles
// and 1.33 voxels off at the top level. A band whose middle plane's loop lies more than a pixel
// from it takes that loop as a plane.
TEST(Graph, ABandWhoseMiddleLoopStraysAPixelTakesItsPlane)
{
    const Volume volume = smokeCrop({24, 105, 58}, {50, 129, 97}, 0.1);
    const Reconstruction reconstruction = slicedAlong(volume, Axis::Z);
    ASSERT_GT(reconstruction.stats().bandPlanes, 0);
    expectTopLevelOnTheIsosurface(volume, reconstruction);
}

// A crop of the smoke at iso 0.2, sliced along x: between x = 66 and 67 a bump on a contour moves
// 3.6 pixels while the contours' shape changes by 2.2 pixels at most, under the bound for taking
// a band's cells, and the middle plane's loop splits, so that no plane could be added for the band
// alone. Its straight triangles lay 1.24 voxels off at the top level. A band whose middle plane
// joins it otherwise than one to one has its cells looked at whatever its shape change, and they
// stray from it: they mesh it.
TEST(Graph, ABandWhoseMiddlePlaneIsNoBandTakesItsCells)
{
    const Volume volume = smokeCrop({64, 132, 40}, {102, 167, 65}, 0.2);
    const Reconstruction reconstruction = slicedAlong(volume, Axis::X);
    ASSERT_GT(reconstruction.stats().bandPatches, 0);
    expectTopLevelOnTheIsosurface(volume, reconstruction);
}

// A crop of the smoke at iso 0.1, sliced along y: at y = 153 a contour forks into six partners a
// voxel above, and the plane between showed other pieces than the voxel planes' cells, so the
// slab stayed a voxel thick. An arm of the contour that ends inside the slab went to one part, and
// its partner's band fanned to it 12 pixels off, 2.8 voxels from the isosurface. A fork or merge
// whose slab stays thicker than the events' half voxel is meshed from its cells: every junction
// left joins contours at most half a voxel apart. The bound on the top level is the crop's known
// gap, as above.
TEST(Graph, AJunctionInASlabTooThickForItIsMeshedFromItsCells)
{
    const Volume volume = smokeCrop({50, 146, 50}, {95, 160, 95}, 0.1);
    MeshOptions options;
    options.slicing.axis = Axis::Y;
    const Reconstruction reconstruction(volume, options);
    const Skeleton skeleton = reconstruction.skeleton();
    for (const Skeleton::Junction& junction : skeleton.junctions)
        for (const int p : junction.partners) {
            const Skeleton::Segment& partner = skeleton.segments[static_cast<std::size_t>(p)];
            const double w = junction.kind == EventKind::Merge ? partner.wLast : partner.wFirst;
            EXPECT_LE(std::abs(w - junction.w), 0.5) << "junction at w = " << junction.w;
        }
    expectOnTheIsosurface(volume, reconstruction.buildLevel(reconstruction.levelCount() - 1).mesh, 2.0);
}

// A crop of the smoke at iso 0.2, sliced along x: its last plane, x = 95, cuts a wall with holes
// open past the box. The face was tiled in the plane, each hole to the arc of the wall nearest it,
// and lay over the bays of a wall that its holes do not see whole: 2.44 voxels off at the top
// level. A face the box cuts is meshed from its cells out to the empty plane past the box, as
// volumeToMesh closes it, and the top level is within a voxel.
TEST(Graph, ACutFaceIsMeshedFromItsCells)
{
    expectTopLevelOnTheIsosurface(smokeCrop({57, 32, 59}, {95, 63, 92}, 0.2));
}

// A capsule along z with a ledge in one voxel plane between two slices (the slices lie 2 voxels
// apart): 4 voxels wide and reaching 3 voxels past the wall, inside in that plane only (the voxel
// planes beside it are outside there, up to 3 voxels). Neither slice sees it, and the band between
// them passed about 3 voxels from its edge. The band takes the middle plane's loop, which strays
// from it, and the top level is within a voxel of the isosurface, with its topology.
TEST(Graph, ABandTakesTheMiddlePlaneWhereItsLoopStrays)
{
    for (const int ledge : {15, 16}) { // whichever of the two lies between the slices
        SCOPED_TRACE(ledge);
        constexpr int n = 32;
        std::vector<float> values(n * n * n);
        for (int x = 0; x < n; ++x)
            for (int y = 0; y < n; ++y)
                for (int z = 0; z < n; ++z) {
                    const double along = std::max({6.0 - z, z - 26.0, 0.0}); // past the capsule's ends
                    double value = std::hypot(std::hypot(x - 16.0, y - 16.0), along) - 6.0;
                    if (z == ledge && x >= 16 && x <= 25 && y >= 14 && y <= 17) value = -1.0;
                    values[(x * n + y) * n + z] = static_cast<float>(value);
                }
        DenseVolume dense;
        dense.values = values.data();
        dense.dims = {n, n, n};
        const Volume volume = volumeFromDense(dense, VolumeOptions{}, "capsule with a ledge");
        MeshOptions options;
        options.slicing.axis = Axis::Z;
        const Reconstruction reconstruction(volume, options);
        expectTopLevelOnTheIsosurface(volume, reconstruction);
    }
}

// The same on real data: a crop of the smoke at iso 0.2, sliced along x, whose surface bulges
// between two slices near x = 55, 1.05 voxels past the band between them at the top level.
TEST(Graph, ABulgeBetweenSlicesOfTheSmokeTakesAPlane)
{
    expectTopLevelOnTheIsosurface(smokeCrop({52, 110, 27}, {97, 140, 54}, 0.2));
}

// AHoleOnOnePartnersSideIsNoGapBetweenThePartners in a crop of the smoke at iso 0.2, sliced along
// z: at z = 40.5 a lobe forks off a body with a one-pixel hole, which opens into the body's side by
// 40.75. The hole was cut where it is nearest the neck, 7 pixels across the body, and the lobe's
// band closed over that stretch of the plane inside the body: 2.31 voxels from the isosurface at
// the top level. A keyhole through the pixel the partners' plane has opened cuts the ring instead:
// within a voxel.
TEST(Graph, AHoleThatOpensIntoOnePartnersSideIsCutOpenByAKeyhole)
{
    const Volume volume = smokeCrop({69, 95, 25}, {94, 117, 59}, 0.2);
    const Reconstruction reconstruction = slicedAlong(volume, Axis::Z);
    EXPECT_GE(reconstruction.stats().keyholes, 1);
    expectTopLevelOnTheIsosurface(volume, reconstruction);
}

TEST(Graph, TheCellsCountTheHandlesOfTreesWhoseBranchesCross)
{
    // The check the tool warns by (Cli.WarnsWhenTheIsosurfaceHasHandlesTheSlabsMiss): on trees whose
    // tunnels are voxels across, the cells' count is volumeToMesh's mesh's Euler characteristic.
    for (const std::vector<Capsule>& tree : crossingTrees()) {
        const Volume volume = capsuleUnion(tree, "capsule tree");
        EXPECT_EQ(isosurfaceEuler(volume), checkTopology(isosurface(volume, 0.0)).euler);
    }
}

TEST(Graph, AProfileSumsTheLayersWhoseOriginLiesInARange)
{
    // Layers 3 to 6 (each from its voxel plane to the next) hold 1, 2, 4 and 8: a range takes the
    // layers whose origin lies in [below, above), so every sum below names its layers.
    const EulerProfile profile{3, {1, 2, 4, 8}, {}};
    EXPECT_EQ(profile.between(3.0, 5.0), 1 + 2);
    EXPECT_EQ(profile.between(3.5, 5.0), 2);
    EXPECT_EQ(profile.between(4.0, 4.5), 2);
    EXPECT_EQ(profile.between(6.5, 7.0), 0);
    EXPECT_EQ(profile.between(5.0, 5.0), 0);
    EXPECT_EQ(profile.between(-10.0, 3.0), 0);
    EXPECT_EQ(profile.between(6.0, 100.0), 8);
    EXPECT_EQ(profile.between(-10.0, 100.0), profile.total());
    EXPECT_EQ(profile.total(), 15);
}

TEST(Graph, RandomTreesWhoseBranchesCrossHaveTheIsosurfaceTopology)
{
    // Once a known gap: in each crossing tree the slabs' labelling misses one tunnel, Euler
    // characteristic 2 where volumeToMesh's isosurface has 0 (tree 0), 0 where it has -2 (tree 1),
    // one component each. Seen in tree 1: three voxels around one corner of a cell, each pair
    // touching along a voxel edge and joined, close a loop within one slab a voxel thick that no
    // contour shows. The cells' count parts from the slabs' there, and the planes that cut that
    // slab again show the tunnel as a fork and a merge. Every level has the isosurface's topology.
    const std::vector<std::vector<Capsule>>& trees = crossingTrees();
    for (std::size_t k = 0; k < trees.size(); ++k) {
        SCOPED_TRACE("tree " + std::to_string(k));
        const Volume volume = capsuleUnion(trees[k], "capsule tree");
        const Topology reference = checkTopology(isosurface(volume, 0.0));
        const Reconstruction reconstruction(volume, MeshOptions{});
        EXPECT_EQ(reconstruction.stats().eventEuler, reference.euler);
        for (int level = 0; level < reconstruction.levelCount(); ++level) {
            const Topology t = checkTopology(reconstruction.buildLevel(level).mesh);
            EXPECT_TRUE(t.closed() && t.manifold() && t.oriented()) << "L" << level;
            EXPECT_EQ(t.euler, reference.euler) << "L" << level;
            EXPECT_EQ(t.components, reference.components) << "L" << level;
        }
        const Validation v =
            Validator(volume).validate(reconstruction.buildLevel(reconstruction.levelCount() - 1).mesh);
        EXPECT_LE(v.symmetric.max, 1.0 * v.voxel);
    }
}

TEST(Graph, ADenseTreesArmSeenEndOnIsMeshedWithinAVoxel)
{
    // Seed 5 of the generator that made the crossing trees, sliced along x. Its fused blob's
    // sections have their central point 15 to 39 pixels short of an arm that runs away from it
    // along the rays: consecutive rays meet the arm's walls far apart, and after two halvings of
    // those sectors the top level's bands there were 1.17 voxels off. The top level halves a
    // straying chord's sector a third time (RaySet::kFoldDepth): 0.71.
    const std::vector<Capsule> tree = {{{56, 56, 10}, {56, 56, 41.7}, 7.0},
                                       {{56, 56, 41.7}, {54.2, 59.1, 62.6}, 5.25},
                                       {{54.2, 59.1, 62.6}, {48.5, 54.3, 83.1}, 3.94},
                                       {{54.2, 59.1, 62.6}, {56.7, 41.7, 75.1}, 3.94},
                                       {{54.2, 59.1, 62.6}, {54.8, 46.8, 75.6}, 3.94},
                                       {{56, 56, 41.7}, {46.1, 48.3, 57.5}, 5.25},
                                       {{46.1, 48.3, 57.5}, {38.1, 47.5, 71.2}, 3.94},
                                       {{46.1, 48.3, 57.5}, {37.5, 34.6, 68.5}, 3.94}};
    expectTopLevelOnTheIsosurface(capsuleUnion(tree, "dense tree"));
}

TEST(Graph, TheCellsPlaceTheHandlesTheSlabsMiss)
{
    // The tunnel above lies within one slab a voxel thick: before the cells were compared, each
    // tree's differences (validate.h) were one change of -2 between two voxel planes a voxel
    // apart, and nothing else. Now that one range is cut again (graph.h), and the contour graph's
    // sums and the cells' agree at every voxel plane.
    for (const std::vector<Capsule>& tree : crossingTrees()) {
        const Volume volume = capsuleUnion(tree, "capsule tree");
        const Reconstruction reconstruction(volume, MeshOptions{});
        const EulerProfile profile = isosurfaceEulerProfile(volume, reconstruction.plan().axis);
        EXPECT_EQ(reconstruction.graph().cellMatches, 1);
        EXPECT_EQ(profile.total(), reconstruction.stats().eventEuler);
        EXPECT_TRUE(eulerDifferences(profile, reconstruction.graph(), reconstruction.planePositions()).empty());
    }
    // Where the slabs see the isosurface's topology, the sums agree at every voxel plane: the
    // phantoms (a disc's start, a fork's saddle and a handle's two saddles all fall in the same
    // slab for both).
    for (const char* name : {"ybranch", "torus-standing", "two-tori", "tank", "tree"}) {
        SCOPED_TRACE(name);
        const Volume& volume = test::cachedSample(name);
        const Reconstruction reconstruction(volume, MeshOptions{});
        const EulerProfile profile = isosurfaceEulerProfile(volume, reconstruction.plan().axis);
        EXPECT_TRUE(eulerDifferences(profile, reconstruction.graph(), reconstruction.planePositions()).empty());
        EXPECT_EQ(reconstruction.graph().cellMatches, 0);
    }
}

TEST(Graph, TreesWhoseBranchesFuseIntoBlobsAreWithinAVoxelAtTheTopLevel)
{
    // Seeds 3 and 4 of the crossing trees' generator (to a hundredth of a voxel), sliced along x,
    // where branches fuse into blobs whose sections are 15 pixels in radius. Bands pair rays from
    // both contours' central points, so a jump between them misregisters the band:
    // - seed 3: a centre that came within a pixel of the blob's edge jumped to the section's
    //   centroid, 17 pixels away in another branch (2.57 voxels off; 0.88 now: it moves to the
    //   clear pixel nearest where it would have gone);
    // - seed 4: a centre in an arm of the section (a branch lying along the plane) jumped 13
    //   pixels when the branch's top took the arm away within an eighth of a voxel (3.56 voxels
    //   off; 0.89 now: the centres before the jump follow it back).
    const std::vector<std::vector<Capsule>> trees = {{{{56, 56, 10}, {56, 56, 33.03}, 7.0},
                                                      {{56, 56, 33.03}, {62.29, 47.45, 52.02}, 5.25},
                                                      {{62.29, 47.45, 52.02}, {49.73, 41.25, 57.24}, 3.9375},
                                                      {{62.29, 47.45, 52.02}, {69.38, 37.32, 65.9}, 3.9375},
                                                      {{56, 56, 33.03}, {45.81, 52.23, 54.23}, 5.25},
                                                      {{45.81, 52.23, 54.23}, {41.68, 51.2, 70.04}, 3.9375},
                                                      {{45.81, 52.23, 54.23}, {37.62, 49.22, 69.63}, 3.9375},
                                                      {{45.81, 52.23, 54.23}, {40.38, 49.33, 70.03}, 3.9375}},
                                                     {{{56, 56, 10}, {56, 56, 43.32}, 7.0},
                                                      {{56, 56, 43.32}, {75, 63.53, 49.01}, 5.25},
                                                      {{75, 63.53, 49.01}, {81.76, 70.28, 64.57}, 3.9375},
                                                      {{75, 63.53, 49.01}, {86.06, 78.74, 56.21}, 3.9375},
                                                      {{75, 63.53, 49.01}, {73.63, 81.21, 60.66}, 3.9375},
                                                      {{56, 56, 43.32}, {49.79, 39.42, 63.24}, 5.25},
                                                      {{49.79, 39.42, 63.24}, {43.6, 47.71, 77.87}, 3.9375},
                                                      {{49.79, 39.42, 63.24}, {37.59, 38.3, 76.54}, 3.9375},
                                                      {{56, 56, 43.32}, {57.37, 46.3, 60.95}, 5.25},
                                                      {{57.37, 46.3, 60.95}, {72.85, 50.12, 68.73}, 3.9375},
                                                      {{57.37, 46.3, 60.95}, {56.62, 46.74, 77.79}, 3.9375},
                                                      {{57.37, 46.3, 60.95}, {51.57, 29.42, 71.76}, 3.9375}}};
    for (std::size_t k = 0; k < trees.size(); ++k) {
        SCOPED_TRACE("seed " + std::to_string(k + 3));
        expectTopLevelOnTheIsosurface(capsuleUnion(trees[k], "fused capsule tree"));
    }
}

TEST(Graph, CentresStandWhereAFusedSectionChangesBetweenClosePlanes)
{
    // Seeds 7 and 10 of the crossing trees' generator (to a hundredth of a voxel), sliced along x.
    // Where a branch joins or leaves a fused blob, the section's centroid moves 2 to 3.5 pixels
    // between planes an eighth of a voxel apart, a slope no travelling tube has. Its centre
    // travelled with the centroid, and rays of one index met the boundary up to 5 rays apart
    // (1.21 and 1.46 voxels off at the top level); it stands now (sectionChanged). Seed 9 goes
    // from 1.51 to 1.30: a centre left in a branch's arm of the section by earlier moves stays
    // there, clear of the boundary by 2 pixels.
    const std::vector<std::vector<Capsule>> trees = {{{{56, 56, 10}, {56, 56, 39.5}, 7.0},
                                                      {{56, 56, 39.5}, {51.45, 41.23, 60.39}, 5.25},
                                                      {{51.45, 41.23, 60.39}, {48.39, 49.74, 75.58}, 3.9375},
                                                      {{51.45, 41.23, 60.39}, {54.04, 36.32, 76.99}, 3.9375},
                                                      {{51.45, 41.23, 60.39}, {41.55, 37.09, 77.47}, 3.9375},
                                                      {{56, 56, 39.5}, {40.85, 45.72, 45.07}, 5.25},
                                                      {{40.85, 45.72, 45.07}, {27.91, 36.53, 52.82}, 3.9375},
                                                      {{40.85, 45.72, 45.07}, {26.12, 38.53, 52.26}, 3.9375},
                                                      {{40.85, 45.72, 45.07}, {30.67, 34.68, 49.37}, 3.9375},
                                                      {{56, 56, 39.5}, {50.34, 55.77, 57.72}, 5.25},
                                                      {{50.34, 55.77, 57.72}, {44.2, 56.84, 77.35}, 3.9375},
                                                      {{50.34, 55.77, 57.72}, {46, 72.49, 63.56}, 3.9375},
                                                      {{50.34, 55.77, 57.72}, {48.81, 52.47, 76.04}, 3.9375}},
                                                     {{{56, 56, 10}, {56, 56, 43.47}, 7.0},
                                                      {{56, 56, 43.47}, {47.22, 59, 59.94}, 5.25},
                                                      {{47.22, 59, 59.94}, {48.89, 69.16, 78.73}, 3.9375},
                                                      {{47.22, 59, 59.94}, {32.69, 52.98, 72.08}, 3.9375},
                                                      {{56, 56, 43.47}, {46.42, 44.82, 63.38}, 5.25},
                                                      {{46.42, 44.82, 63.38}, {45.17, 28.75, 66.54}, 3.9375},
                                                      {{46.42, 44.82, 63.38}, {47.63, 34.94, 76.22}, 3.9375}}};
    const int seeds[] = {7, 10};
    for (std::size_t k = 0; k < trees.size(); ++k) {
        SCOPED_TRACE("seed " + std::to_string(seeds[k]));
        expectTopLevelOnTheIsosurface(capsuleUnion(trees[k], "fused capsule tree"));
    }
}

TEST(Graph, AWallARayGrazesIsTiledAlongIt)
{
    // Seed 4 of the crossing trees' generator, to a ten-thousandth of a voxel (the test above has
    // it to a hundredth, where the graze does not happen), sliced along x. Near x = 53.5 a ray of
    // the fused section runs along its wall for 25 pixels; the upper contour's ray clips a bulge
    // a pixel deep that the lower one's misses, so the two contours parse that wall differently.
    // Pairing the excursions' children by position fanned the wall's far end onto the lower
    // contour's crossing at its near end, a triangle 1.68 voxels off the isosurface across a
    // concave corner; aligned by their rays (tileBand), the wall's crossings pair along it.
    const std::vector<Capsule> tree = {{{56, 56, 10}, {56, 56, 43.3167}, 7.0},
                                       {{56, 56, 43.3167}, {74.9993, 63.5273, 49.0099}, 5.25},
                                       {{74.9993, 63.5273, 49.0099}, {81.7559, 70.2795, 64.5691}, 3.9375},
                                       {{74.9993, 63.5273, 49.0099}, {86.0629, 78.7374, 56.2094}, 3.9375},
                                       {{74.9993, 63.5273, 49.0099}, {73.6302, 81.2065, 60.6565}, 3.9375},
                                       {{56, 56, 43.3167}, {49.7887, 39.4197, 63.2361}, 5.25},
                                       {{49.7887, 39.4197, 63.2361}, {43.6010, 47.7140, 77.8685}, 3.9375},
                                       {{49.7887, 39.4197, 63.2361}, {37.5871, 38.2953, 76.5437}, 3.9375},
                                       {{56, 56, 43.3167}, {57.3730, 46.3040, 60.9513}, 5.25},
                                       {{57.3730, 46.3040, 60.9513}, {72.8489, 50.1234, 68.7276}, 3.9375},
                                       {{57.3730, 46.3040, 60.9513}, {56.6242, 46.7363, 77.7878}, 3.9375},
                                       {{57.3730, 46.3040, 60.9513}, {51.5727, 29.4191, 71.7611}, 3.9375}};
    expectTopLevelOnTheIsosurface(capsuleUnion(tree, "grazed capsule tree"));
}

namespace {

// Seeds 6 and 11 of the crossing trees' generator (to a hundredth of a voxel), whose walls join
// into rings (RingsWhoseHoleNoPartnerSharesAreCutOpenByAKeyhole).
const std::vector<std::vector<Capsule>>& ringTrees()
{
    static const std::vector<std::vector<Capsule>> trees = {{{{56, 56, 10}, {56, 56, 38.46}, 7},
                                                             {{56, 56, 38.46}, {41.82, 55.23, 53.61}, 5.25},
                                                             {{41.82, 55.23, 53.61}, {38.79, 68.81, 68.82}, 3.9375},
                                                             {{41.82, 55.23, 53.61}, {30.85, 39.73, 60.23}, 3.9375},
                                                             {{56, 56, 38.46}, {52.19, 64.34, 58.18}, 5.25},
                                                             {{52.19, 64.34, 58.18}, {68.16, 59.3, 68.96}, 3.9375},
                                                             {{52.19, 64.34, 58.18}, {52.57, 51.85, 66.75}, 3.9375},
                                                             {{52.19, 64.34, 58.18}, {45.49, 74.93, 70.09}, 3.9375},
                                                             {{56, 56, 38.46}, {59.1, 69.3, 61.65}, 5.25},
                                                             {{59.1, 69.3, 61.65}, {53.31, 77, 75.02}, 3.9375},
                                                             {{59.1, 69.3, 61.65}, {60.26, 68.4, 82.04}, 3.9375},
                                                             {{59.1, 69.3, 61.65}, {59.38, 75.7, 80.63}, 3.9375}},
                                                            {{{56, 56, 10}, {56, 56, 33.54}, 7},
                                                             {{56, 56, 33.54}, {72.73, 49.03, 52.89}, 5.25},
                                                             {{72.73, 49.03, 52.89}, {83.48, 45.87, 68.06}, 3.9375},
                                                             {{72.73, 49.03, 52.89}, {85.15, 46.65, 63}, 3.9375},
                                                             {{56, 56, 33.54}, {52.73, 60, 55.46}, 5.25},
                                                             {{52.73, 60, 55.46}, {62.67, 47.17, 63.98}, 3.9375},
                                                             {{52.73, 60, 55.46}, {45.99, 47.22, 62.07}, 3.9375},
                                                             {{52.73, 60, 55.46}, {42.97, 51.37, 67.39}, 3.9375},
                                                             {{56, 56, 33.54}, {53.74, 48.78, 53.91}, 5.25},
                                                             {{53.74, 48.78, 53.91}, {50.26, 49.33, 74.62}, 3.9375},
                                                             {{53.74, 48.78, 53.91}, {46.1, 47.78, 68.77}, 3.9375},
                                                             {{53.74, 48.78, 53.91}, {41.73, 39.26, 60.51}, 3.9375}}};
    return trees;
}

} // namespace

TEST(Graph, RingsWhoseHoleNoPartnerSharesAreCutOpenByAKeyhole)
{
    // Seeds 6 and 11 of the crossing trees' generator (to a hundredth of a voxel), sliced along x.
    // In each, a wall and the hole inside it (a ring) meet several walls across one slab thinner
    // than a voxel, and the hole is too small for each of them to be nearest a part of it:
    // - seed 6: a ring breaks into two walls where its sliver of a hole meets an arm that ends;
    // - seed 11: a C closes around a new hole while a rod, or two other branches, join it.
    // Split into sectors (each partner an arc of the wall and one of the hole), they fitted no
    // construction and were capped contour by contour (seed 6: Euler characteristic 6 for 0, 4
    // components for 1; seed 11 as wrong). Cut open into one contour by a keyhole through the
    // partners' gap, each is an ordinary fork or merge, and every level has the isosurface's
    // topology.
    const std::vector<std::vector<Capsule>>& trees = ringTrees();
    for (std::size_t k = 0; k < trees.size(); ++k) {
        SCOPED_TRACE(k == 0 ? "seed 6" : "seed 11");
        const Volume volume = capsuleUnion(trees[k], "ring-merging capsule tree");
        MeshOptions options;
        options.slicing.axis = Axis::X;
        const Reconstruction reconstruction(volume, options);
        const Topology reference = checkTopology(isosurface(volume, 0.0));
        EXPECT_EQ(reconstruction.stats().unresolvedJunctions, 0);
        EXPECT_GE(reconstruction.stats().keyholes, 1);
        EXPECT_EQ(reconstruction.stats().eventEuler, reference.euler);
        expectNestedLevels(reconstruction, [&](const TriangleMesh& mesh) {
            const Topology t = checkTopology(mesh);
            EXPECT_TRUE(t.closed() && t.manifold() && t.oriented());
            EXPECT_EQ(t.euler, reference.euler);
            EXPECT_EQ(t.components, reference.components);
        });
    }
}

// Seed 6's top level lies within a voxel of the isosurface. Between a merge at x = 54.5 and a
// fork at 55 (one segment half a voxel long) the two contours are nearly one (0.33 pixel out of
// register), but their contour trees parse a notch's excursions differently (96 crossings against
// 94), and the band fanned a vertex at 55 onto crossings at 54.5 twelve pixels away: 1.44 voxels
// off. A band that joins a point more than 3 pixels (now 2) farther than the other contour's
// point nearest it is tiled by area instead (tileBands, outOfRegister).
TEST(Graph, RingTreeSixIsWithinAVoxelAtTheTopLevel)
{
    const Volume volume = capsuleUnion(ringTrees()[0], "ring-merging capsule tree");
    MeshOptions options;
    options.slicing.axis = Axis::X;
    const Reconstruction reconstruction(volume, options);
    const LevelMesh top = reconstruction.buildLevel(reconstruction.levelCount() - 1);
    EXPECT_GT(top.areaBands, 0); // else the tree no longer shows the case
    expectOnTheIsosurface(volume, top.mesh, 1.0);
}

// Seed 11's top level lies within a voxel of the isosurface, sliced along x. The keyhole that cuts
// the ring open at the merge at x = 50.5 ran through its wall where the partners' plane, 50, is
// inside too (no slit from the wall to the hole is clear of it, however long: 6 pixels blocked).
// Its crossings lay in the plane 50.5, up to 1.48 voxels inside, where the surface is a wall near
// x = 49. A junction whose slit runs over more than a pixel of such material is meshed from its
// slab's cells instead.
TEST(Graph, RingTreeElevenIsWithinAVoxelAtTheTopLevel)
{
    const Volume volume = capsuleUnion(ringTrees()[1], "ring-merging capsule tree");
    MeshOptions options;
    options.slicing.axis = Axis::X;
    const Reconstruction reconstruction(volume, options);
    ASSERT_GT(reconstruction.stats().patches, 0); // else the tree no longer shows the case
    expectTopLevelOnTheIsosurface(volume, reconstruction);
}

namespace {

// Sliced along `axis`, the largest aspect ratio of each level of a reconstruction of `volume`;
// infinite where a triangle has no area (measureQuality counts those apart).
std::vector<double> largestAspects(const Volume& volume, Axis axis = Axis::X)
{
    MeshOptions options;
    options.slicing.axis = axis;
    const Reconstruction reconstruction(volume, options);
    std::vector<double> aspects;
    for (int level = 0; level < reconstruction.levelCount(); ++level) {
        const TriangleQuality quality = measureQuality(reconstruction.buildLevel(level).mesh);
        aspects.push_back(quality.degenerate > 0 ? std::numeric_limits<double>::infinity() : quality.largestAspect);
    }
    return aspects;
}

// Issue 17's bound at every level.
void expectNoNeedleAtAnyLevel(const std::vector<double>& aspects)
{
    for (std::size_t level = 0; level < aspects.size(); ++level)
        EXPECT_LE(aspects[level], kLargestAspect) << "level " << level;
}

} // namespace

// Crossing tree 1's trunk, sliced along x, is a long stadium whose straight walls, 28 voxels
// long, the slabs of the branches' events cut an eighth of a voxel apart. Bands there that the
// contour trees paired out of register were tiled by least area, which cannot tell the tilings of
// two nearly equal walls apart and fanned points over chords up to 25 voxels away (aspect ratios
// to 7600 before the needle passes, 396 after them at the top level). Ties broken by the spans
// (tileLeastAreaNearest), the top level has no needle over issue 17's bound.
TEST(Graph, AThinSlabAcrossATrunksStraightWallsTilesWithoutFans)
{
    const std::vector<double> aspects = largestAspects(capsuleUnion(crossingTrees()[1], "capsule tree"));
    EXPECT_LE(aspects.back(), kLargestAspect);
}

// A random crop of the smoke at iso 0.2, sliced along x. Where 64 crossings of a contour thinner
// than a voxel go into a patch's point, its top level kept a needle of aspect 3140 when the
// collapses were made in order of position; with the shortest edges first (collapseNeedleEdges),
// its largest is 41.
TEST(Graph, ACollapsesShortestEdgesGoFirst)
{
    expectNoNeedleAtAnyLevel(largestAspects(smokeCrop({50, 76, 80}, {91, 115, 105}, 0.2)));
}

// A random crop of the smoke at iso 0.2 (seed 110, crop 6), sliced along x. A ray along a pixel row
// met a loop at one of its polygon's points, and the patch of the slab beside it had its own vertex
// there: an edge of no length, and from level 1 on two triangles of no area that no collapse could
// take. The patch now takes the crossing (Assembly::vertexAtPoint).
TEST(Graph, APatchTakesTheCrossingAtItsPoint)
{
    expectNoNeedleAtAnyLevel(largestAspects(smokeCrop({57, 34, 25}, {106, 82, 66}, 0.2)));
}

// A random crop of the smoke at iso 0.3 (seed 107, crop 9), sliced along x. A fork's part met its
// single contour's arc at a polygon point that a patch on the contour's other side held too: two
// vertices there, and from level 1 on two triangles of no area. The patch now takes the part's.
TEST(Graph, APatchTakesAJunctionsVertexAtItsPoint)
{
    expectNoNeedleAtAnyLevel(largestAspects(smokeCrop({57, 55, 28}, {95, 78, 67}, 0.3)));
}

// A random crop of the smoke at iso 0.1 (seed 109, crop 11), sliced along x. A speck alone in its
// tube had its central point 0.007 pixel from a crossing (0.1 pixel inside its polygon), and the
// fan round its apex made needles of aspect 157 to 167 at every level. Its rays now go out from the middle
// of its crossings (Reconstruction::centreLoneContour).
TEST(Graph, ALoneSpecksRaysGoOutFromItsMiddle)
{
    expectNoNeedleAtAnyLevel(largestAspects(smokeCrop({25, 94, 51}, {54, 138, 95}, 0.1)));
}

// Crossing tree 1 sliced along x: at level 2 a vertex of a plane beside one of the events' slabs,
// an eighth of a voxel thick, lay 0.24 voxel from another of that plane, and both were vertices of
// level 0, so no collapse of a finer level could take either: their edge fanned to a point 9
// voxels away across the slab (aspect 313). Below the top level such edges, up to 0.3 voxel, go
// whatever their triangles' shape (Assembly::build, ThinSlabPlanes).
TEST(Graph, AThinSlabsPlanesKeepNoShortEdgeBelowTheTopLevel)
{
    expectNoNeedleAtAnyLevel(largestAspects(capsuleUnion(crossingTrees()[1], "capsule tree")));
}

// Issue 17's bound, no triangle over aspect 100 at any level, on the crossing and ring trees
// sliced along x. Ring tree 1 kept 100.23 at levels 1 and 2 (an expected failure until then): in
// a slab an eighth of a voxel thick, a chord of 11.6 voxels on one side faces a wall that cells
// tiled a vertex per pixel on the other, and the fan from the chord's end to that wall is a
// needle whatever the flips do. Its corner on the wall cannot go along the needle's own edges
// (a triangle would turn over), but below the top level it may go along its other edges, and
// one of a quarter voxel takes it (Assembly::build): 49 now. Ring tree 0's level 1 held 108
// until coarse levels took longer edges: there three sections' centroids lie on the line of the
// trunk's straight wall (to a thousandth of a pixel), the ray along it grazes the wall and meets
// it twice, 30 voxels apart. Crossing tree 1's level 2 held 313 until short edges in thin slabs'
// planes went.
TEST(Graph, CapsuleTreesSlicedAlongXHaveNoNeedles)
{
    std::vector<std::vector<Capsule>> trees = crossingTrees();
    trees.insert(trees.end(), ringTrees().begin(), ringTrees().end());
    for (std::size_t k = 0; k < trees.size(); ++k) {
        SCOPED_TRACE("tree " + std::to_string(k));
        expectNoNeedleAtAnyLevel(largestAspects(capsuleUnion(trees[k], "capsule tree")));
    }
}

// The same along y and z: the tests slice the trees along x, and issue 17's bound holds for them
// along every axis (the largest, 76.6 along y, is ring tree 1's).
TEST(Graph, CapsuleTreesSlicedAlongYAndZHaveNoNeedles)
{
    std::vector<std::vector<Capsule>> trees = crossingTrees();
    trees.insert(trees.end(), ringTrees().begin(), ringTrees().end());
    for (const Axis axis : {Axis::Y, Axis::Z})
        for (std::size_t k = 0; k < trees.size(); ++k) {
            SCOPED_TRACE("tree " + std::to_string(k) + (axis == Axis::Y ? " along y" : " along z"));
            expectNoNeedleAtAnyLevel(largestAspects(capsuleUnion(trees[k], "capsule tree"), axis));
        }
}

TEST(Graph, BaselineTilersCloseEveryLevelToo)
{
    // The baseline tilers on the same skeleton: a strip that fans one point over a whole contour
    // (the oblique tube's sections of a few pixels, with the optimal tiler) repeats a spanning
    // edge in four triangles; it is broken, so every level is still a closed 2-manifold with the
    // phantom's Euler characteristic.
    for (const char* name : {"oblique", "trifurcation"})
        for (TilerKind tiler : {TilerKind::Optimal, TilerKind::Greedy}) {
            SCOPED_TRACE(std::string(name) + (tiler == TilerKind::Optimal ? " optimal" : " greedy"));
            MeshOptions options;
            options.tiler = tiler;
            options.levels = 2;
            const Reconstruction reconstruction(test::cachedSample(name), options);
            for (int level = 0; level < 2; ++level) {
                const Topology t = checkTopology(reconstruction.buildLevel(level).mesh);
                EXPECT_TRUE(t.closed() && t.manifold() && t.oriented()) << "level " << level;
                EXPECT_EQ(t.euler, infoOf(name).euler);
            }
        }
}

// Each phantom's expected numbers are its own (samples/phantoms.cpp derives them, and
// Samples.KnownTopologyMatchesTheIsosurface checks them against volumeToMesh).
TEST(Graph, YBranch)
{
    expectIsosurfaceTopology("ybranch");
}
TEST(Graph, UBend)
{
    expectIsosurfaceTopology("ubend");
}
TEST(Graph, XCrossFusesThenParts)
{
    expectIsosurfaceTopology("xcross");
}
TEST(Graph, TorusLyingFlat)
{
    expectIsosurfaceTopology("torus-flat");
}
TEST(Graph, TorusStanding)
{
    expectIsosurfaceTopology("torus-standing");
}
TEST(Graph, ClosedHollowTank)
{
    expectIsosurfaceTopology("tank", 1);
}
// The channel's ends were closed flat (holes sought no apex), 2 voxels from its rounded ends.
TEST(Graph, LumenClosedInsideARod)
{
    expectIsosurfaceTopology("lumen-rod", 1);
}
// Its three branches touch pairwise above the fork: a ring with two holes whose gaps open at once
// (one contour against a wall and two holes, closed by chords across the gaps).
TEST(Graph, Trifurcation)
{
    expectIsosurfaceTopology("trifurcation");
}
// Lying flat, their wall begins and ends with both holes at once: faces with two holes.
TEST(Graph, TwoFusedTori)
{
    expectIsosurfaceTopology("two-tori");
}
TEST(Graph, SerpentineAcrossTheSlices)
{
    expectIsosurfaceTopology("serpentine");
}
TEST(Graph, ObliqueThinVessel)
{
    expectIsosurfaceTopology("oblique");
}
TEST(Graph, TwoTubesStayTwo)
{
    expectIsosurfaceTopology("two-tubes");
}
TEST(Graph, HollowPipe)
{
    expectIsosurfaceTopology("hollow");
}

// Three generations: forks, and where the branches' sections touch above a fork, a ring that
// breaks open in two places at once (a wall and its hole against two walls: two sectors).
TEST(Graph, VesselTree)
{
    expectIsosurfaceTopology("tree");
}
// Two branches touch along a seam and part through a one-pixel hole: a ring against two walls
// whose hole is too small for each wall to be nearest part of it (it was capped contour by
// contour: 4 components, Euler 8).
TEST(Graph, BranchesPartThroughAPixelHole)
{
    expectIsosurfaceTopology("parting");
}
// Its level 2 was 1.45 voxels off: a junction part whose contour trees paired a crossing far out
// of register with its partner's (outOfRegister). Such a part is tiled by area, as such a band is, and
// the level lies within a voxel (0.77), as level 2 of the other trees does.
TEST(Graph, APartOutOfRegisterIsTiledByArea)
{
    const Volume& volume = test::cachedSample("parting");
    const LevelMesh level = Reconstruction(volume, MeshOptions{}).buildLevel(2);
    EXPECT_GT(level.areaBands, 0); // else the sample no longer shows the case
    expectOnTheIsosurface(volume, level.mesh, 1.0);
}
// A T whose side branch lies in a slicing plane: the arm grows along its whole length at once.
// Its first section pulled the centroid 8 voxels along the arm (the trunk's band then ran 2.7
// voxels inside the trunk), and the arm's rounded tip, 40 voxels from the trunk's centre, falls
// between rays 4 voxels apart at the top level: centres follow their tube, and the top level
// halves sectors whose edges cut corners.
TEST(Graph, TBranchInTheSlicingPlane)
{
    expectIsosurfaceTopology("tbranch");
}
// At its event the T's planes lie an eighth of a voxel apart, and rays from the trunk's centre
// meet the arm's straight sides up to 30 voxels apart at level 0 (240 times the slab): a band
// there holds needles whatever its tiling, and cuts across the arm. Such chords are halved at
// every level (addFoldRays, longChords), as often as at the top level; levels 1 and 2, whose rays
// are a quarter and half as dense as the top level's, now lie within the top level's voxel too
// (level 2 2.31 voxels before any halving, level 1 4.21, and 1.34 with two halvings below the top).
TEST(Graph, ChordsTooLongForTheirSlabAreHalvedAtEveryLevel)
{
    const Volume& volume = test::cachedSample("tbranch");
    const Reconstruction reconstruction(volume, MeshOptions{});
    for (int level : {1, 2}) {
        SCOPED_TRACE("level " + std::to_string(level));
        expectOnTheIsosurface(volume, reconstruction.buildLevel(level).mesh, 1.0);
    }
}
// A Y-shaped pipe open at its three ends: its rounded rims appear as arcs that close into a ring
// (several walls against a wall and its hole), and its channel forks with the wall. Where the
// oblique channel leaves each rounded end, the last sections are thin crescents whose horns run
// along the rim: their bands are halved below half a voxel while the shape changes fast, and each
// crescent's centre stays a pixel clear near its predecessor's (a jump to the centroid, by the
// inner edge, turned the horns against each other's rays: 1.07 voxels off).
TEST(Graph, HollowY)
{
    expectIsosurfaceTopology("hollow-y");
}
// Two boxes whose voxels touch along one voxel edge in a voxel plane, and nowhere else: the walk
// joined the two diagonal pixels there (8-connected), one surface, where volumeToMesh has two
// (a random capsule tree grew a handle this way). On voxel planes the walk and the slab now
// leave such a saddle open as volumeToMesh's cell tables do. Boxes' sharp edges, not what the
// tool is for, put the top level up to 2 voxels off at their corners: topology only.
TEST(Graph, BlocksTouchingAlongAVoxelEdgeStayTwo)
{
    expectIsosurfaceTopology("touching-blocks", 0, false);
}
// Steps touching the next only along voxel edges across a voxel plane: volumeToMesh joins them
// (one surface, Euler 2). The slab linked inside voxels across planes only one above the other,
// so each step was a surface of its own (Euler 8, 4 components); between two voxel planes it now
// links such contacts as volumeToMesh does, and a plane added between voxel planes, which cannot
// show them, is dropped when its halves disagree with the slab's Euler characteristic (a random
// capsule tree's void, closed off by such contacts, was lost).
TEST(Graph, StepsTouchingAcrossAVoxelPlane)
{
    expectIsosurfaceTopology("steps");
}
// Two pillars, each with a loop of its own on every plane, touching along voxel edges across a
// voxel plane: volumeToMesh joins them (Euler 2, 1 component). The slab took them as two bands
// without labelling (Euler 4, 2 components); labelled, it held one piece against two loops on
// each side, two saddles within one voxel. Loop boxes a pixel apart now send a slab to the
// labelling, and planes between voxel planes show the contact as a bridge of two pixels, so the
// slab bisects into a merge and a fork (a random capsule tree missed a handle this way).
TEST(Graph, PillarsTouchingAcrossAVoxelPlane)
{
    expectIsosurfaceTopology("pillars");
}
