#include <pipetile/multires.h>
#include <pipetile/quality.h>
#include <pipetile/validate.h>
#include <pipetile/volume.h>

#include "phantoms.h"
#include "test_util.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>

using namespace pipetile;

namespace {

// The bound on the angle between a field normal and the exact one, for the exact signed distance
// of a shape whose surface has radius of curvature `radius` voxels (voxel 1). Each component of
// Volume::fieldGradient is a central difference over +-0.5 voxel of the trilinear interpolant,
// which is a convex combination of the voxel edges' forward differences, each the exact
// derivative at a point of its edge (mean value theorem). Those points lie within 1.5 voxels of
// the vertex along the component's axis and 1 along the two others: sqrt(4.25) voxels. The exact
// gradient is the unit normal field, whose derivative is at most 1 / (distance to the centre of
// curvature) >= 1 / (radius - sqrt(4.25) - 1) (the vertex lies within a voxel of the surface,
// checked). So each component errs by at most sqrt(4.25) / (radius - sqrt(4.25) - 1), the vector
// by sqrt(3) times that, and the angle by the arcsine of it. All those points lie within the
// narrow band (3 voxels), where the stored values are the exact distances to float precision.
double normalBoundDegrees(double radius)
{
    const double reach = std::sqrt(4.25);
    return std::asin(std::sqrt(3.0) * reach / (radius - reach - 1.0)) * 180.0 / 3.14159265358979323846;
}

// Every vertex normal of every level within `boundDegrees` of `analytic`, and outward.
void expectFieldNormals(const Volume& volume, const std::function<glm::dvec3(const glm::dvec3&)>& analytic,
                        double boundDegrees)
{
    MeshOptions options;
    options.levels = 3;
    const Reconstruction reconstruction(volume, options);
    double worst = 0.0;
    for (int level = 0; level < reconstruction.levelCount(); ++level) {
        const TriangleMesh mesh = reconstruction.buildLevel(level).mesh;
        const std::vector<glm::dvec3> normals = vertexNormals(volume, mesh);
        ASSERT_FALSE(mesh.vertices.empty()) << "level " << level;
        ASSERT_EQ(normals.size(), mesh.vertices.size());
        for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
            ASSERT_LT(std::abs(volume.signedField(mesh.vertices[i])), 1.0) << "vertex " << i << " off the surface";
            const glm::dvec3 exact = analytic(mesh.vertices[i]);
            EXPECT_NEAR(glm::length(normals[i]), 1.0, 1e-12);
            EXPECT_GT(glm::dot(normals[i], exact), 0.0) << "level " << level << " vertex " << i << " points inward";
            const double angle =
                std::acos(std::clamp(glm::dot(normals[i], exact), -1.0, 1.0)) * 180.0 / 3.14159265358979323846;
            worst = std::max(worst, angle);
        }
    }
    EXPECT_LE(worst, boundDegrees);
    std::printf("worst normal: %.3f degrees (bound %.3f)\n", worst, boundDegrees);
}

} // namespace

TEST(Quality, SphereNormalsFromTheFieldAreTheRadialOnes)
{
    // A sphere of radius 24 voxels: the bound is 10.1 degrees.
    const glm::dvec3 centre(32.0);
    const Volume sphere = samples::levelSetFromDistance(
        [&](const glm::dvec3& p) { return glm::length(p - centre) - 24.0; }, glm::ivec3(64), 1.0, "sphere");
    expectFieldNormals(
        sphere, [&](const glm::dvec3& p) { return glm::normalize(p - centre); }, normalBoundDegrees(24.0));
}

TEST(Quality, ASurfaceBoundHoldsWhereTheFieldShowsTheSurfaceNearEnough)
{
    // Equilateral triangles with their corners on a sphere of radius 24 voxels around its pole:
    // a triangle whose corners lie at angle t from the pole has its circumcentre, the point farthest
    // from its corners, 24 (1 - cos t) below the surface, 24 sin t from each corner.
    const double radius = 24.0;
    const glm::dvec3 centre(32.0);
    const Volume sphere = samples::levelSetFromDistance(
        [&](const glm::dvec3& p) { return glm::length(p - centre) - radius; }, glm::ivec3(64), 1.0, "sphere");
    const auto around = [&](double depth) {
        const double c = 1.0 - depth / radius, s = std::sqrt(1.0 - c * c);
        std::array<glm::dvec3, 3> corners;
        for (int k = 0; k < 3; ++k) {
            const double phi = 2.0 * 3.14159265358979323846 * k / 3.0;
            corners[k] = centre + radius * glm::dvec3(s * std::cos(phi), s * std::sin(phi), c);
        }
        return corners;
    };
    const SurfaceBound bound{&sphere, 0.9};
    // Half a voxel deep, 4.9 from its corners: the field shows the surface (within 0.88 of the
    // reach it always does). Two voxels deep, it does not, as no surface lies within the reach.
    const std::array<glm::dvec3, 3> shallow = around(0.5), deep = around(2.0);
    EXPECT_TRUE(bound.holds(shallow[0], shallow[1], shallow[2]));
    EXPECT_FALSE(bound.holds(deep[0], deep[1], deep[2]));
    // Without a volume, no bound.
    EXPECT_TRUE(SurfaceBound{}.holds(deep[0], deep[1], deep[2]));
}

TEST(Quality, CapsuleNormalsFromTheFieldAreTheAnalyticOnes)
{
    // A capsule of radius 24 along z: the normal points away from the nearest point of its axis
    // segment (radially on the cylinder, from the end centres on the caps). Bound 10.1 degrees.
    const glm::dvec3 a(32.0, 32.0, 30.0), b(32.0, 32.0, 66.0);
    auto nearest = [&](const glm::dvec3& p) {
        return a + (b - a) * std::clamp(glm::dot(p - a, b - a) / glm::dot(b - a, b - a), 0.0, 1.0);
    };
    const Volume capsule =
        samples::levelSetFromDistance([&](const glm::dvec3& p) { return glm::length(p - nearest(p)) - 24.0; },
                                      glm::ivec3(64, 64, 96), 1.0, "capsule");
    expectFieldNormals(
        capsule, [&](const glm::dvec3& p) { return glm::normalize(p - nearest(p)); }, normalBoundDegrees(24.0));
}

TEST(Quality, FogNormalsPointOutwardToo)
{
    // A fog volume is dense inside: its outward normal is minus the gradient of its values. The
    // bundled fog tube (radius 6 along z through (12, 12)): every normal outward from the axis.
    test::TempDir dir;
    test::writeTubeFogVdb(dir.path("tube.vdb"));
    const Volume fog = readVolume(dir.path("tube.vdb"));
    ASSERT_EQ(fog.volumeClass(), VolumeClass::Fog);
    const TriangleMesh mesh = Reconstruction(fog, MeshOptions{}).buildLevel(1).mesh;
    const std::vector<glm::dvec3> normals = vertexNormals(fog, mesh);
    const glm::dvec3 axis = fog.indexToWorld({12.0, 12.0, 0.0});
    long long outward = 0;
    for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
        glm::dvec3 radial = mesh.vertices[i] - axis;
        radial.z = 0.0;
        // Cap vertices near the axis have no radial direction to compare with.
        if (glm::length(radial) < 3.0) continue;
        outward += glm::dot(normals[i], radial) > 0.0 ? 1 : 0;
        EXPECT_GT(glm::dot(normals[i], radial), 0.0) << "vertex " << i;
    }
    EXPECT_GT(outward, 0);
}

namespace {

// Every level of a volume, refined from level 0, stays closed, manifold and oriented, and
// `expect` checks its triangles' quality.
void expectEveryLevel(const Volume& volume, const MeshOptions& options,
                      const std::function<void(const TriangleQuality&)>& expect)
{
    const Reconstruction reconstruction(volume, options);
    Refinement refinement(reconstruction);
    while (true) {
        const LevelMesh& level = refinement.mesh();
        SCOPED_TRACE("level " + std::to_string(level.level));
        expect(measureQuality(level.mesh));
        const Topology t = checkTopology(level.mesh);
        EXPECT_TRUE(t.closed() && t.manifold() && t.oriented());
        if (!refinement.canRefine()) break;
        refinement.refine();
    }
}

// The same for each sample, with the default options.
void expectEveryLevel(const std::vector<const char*>& names, const std::function<void(const TriangleQuality&)>& expect)
{
    for (const char* name : names) {
        SCOPED_TRACE(name);
        expectEveryLevel(test::cachedSample(name), MeshOptions{}, expect);
    }
}

// The bound of issue 17: no triangle with an aspect ratio over 100 at any level, and none
// degenerate; the flips keep every level closed, manifold and oriented.
void expectNoNeedlesIn(const TriangleQuality& q)
{
    EXPECT_EQ(q.degenerate, 0);
    EXPECT_LE(q.largestAspect, 100.0);
}

void expectNoNeedles(const std::vector<const char*>& names)
{
    expectEveryLevel(names, expectNoNeedlesIn);
}

// The same, each sample sliced along `axis`.
void expectNoNeedlesAlong(const std::vector<const char*>& names, Axis axis)
{
    MeshOptions options;
    options.slicing.axis = axis;
    for (const char* name : names) {
        SCOPED_TRACE(name);
        expectEveryLevel(test::cachedSample(name), options, expectNoNeedlesIn);
    }
}

} // namespace

TEST(Quality, FlipsLeaveThePhantomsClosedAndFreeOfNeedles)
{
    expectNoNeedles({"straight", "hollow", "torus-flat", "helix", "two-tubes"});
}

TEST(Quality, NoNeedlesOnBranchesAndFolds)
{
    // Junctions (ybranch, tree, trifurcation, tbranch) and C-shaped sections that rays cross
    // three times (bean). Their needles had an edge under 0.3 voxel in a slice plane (a junction
    // part's crossing next to the single contour's own: aspect up to 4081 on the tree's top
    // level); the collapses take it out (collapseNeedleEdges). The T branch's worst (122 at level
    // 2) had an edge of 0.66 voxel along its junction's contour, past that level's reach (0.6),
    // which goes where the surface moves less than the reach.
    expectNoNeedles({"ybranch", "tree", "trifurcation", "bean", "tbranch"});
}

TEST(Quality, NoNeedlesOnAHollowY)
{
    // The hollow Y's top level held two triangles of aspect 104, mirror images: an edge of 0.331
    // voxel in the plane at z = 112.75 whose third corner lies 5.6 voxels across, in the plane an
    // eighth of a voxel above (an event slab halved three times, where the crescent at the rim
    // shifts). The edge is just over the top level's reach (kNeedleReachVoxels, 0.3); the contour
    // is nearly straight there, so collapsing it moves the surface less than the reach, and it goes.
    expectNoNeedles({"hollow-y"});
}

// Sliced across their lengths, the hollow Y kept 230 and 299 at levels 1 and 2 and the Y 125 and
// 107 at levels 2 and 3: a vertex fanned over a patch's wall, a vertex per pixel, nearly in line
// with it, its three corners all kept from the level below, so that neither a collapse nor a flip
// could take them. Parts of such fans are tiled anew (retileNeedleFans). Along x the hollow Y's
// last, 111 at level 1 on three contour points nearly in line, went with the flips that wait.
TEST(Quality, NoNeedlesOnTheHollowYAndTheYSlicedAcrossTheirLengths)
{
    expectNoNeedlesAlong({"hollow-y"}, Axis::X);
    expectNoNeedlesAlong({"hollow-y", "ybranch"}, Axis::Y);
}

TEST(Quality, LevelsBelowTheTopKeepNoEdgeUnderATenthOfAVoxel)
{
    // A level's vertices are vertices of every finer level, where two of them a hair apart make a
    // needle no collapse may take (Gaffer's smoke: 0.05 voxel kept at level 1 under aspect 10 was
    // 232 at level 2). Below the top level such an edge goes whatever its triangles' shape; the
    // tree kept 24 at level 1 and 73 at level 2, the hollow Y 27 and 49. The top level keeps the
    // aspect rule (its short edges near a cap's apex are a smooth tube's own).
    for (const char* name : {"tree", "hollow-y"}) {
        SCOPED_TRACE(name);
        const Volume& volume = test::cachedSample(name);
        const Reconstruction reconstruction(volume, MeshOptions{});
        Refinement refinement(reconstruction);
        while (refinement.canRefine()) {
            const TriangleMesh& mesh = refinement.mesh().mesh;
            double shortest = std::numeric_limits<double>::infinity();
            for (const Triangle& t : mesh.triangles)
                for (int k = 0; k < 3; ++k)
                    shortest = std::min(shortest, glm::length(mesh.vertices[t[k]] - mesh.vertices[t[(k + 1) % 3]]));
            EXPECT_GE(shortest, kNeedleEdgeVoxels * volume.smallestVoxel()) << "level " << refinement.mesh().level;
            refinement.refine();
        }
    }
}

TEST(Quality, NoNeedlesOnTwistingCs)
{
    // Sections that overlap in part only from one slice to the next, and whose ends move
    // (Graph.TwistingCsAreCappedAtTheirFlatEnds). At 20 degrees per voxel the top level held a
    // triangle of aspect 120: an edge of 0.31 voxel along a contour, against a corner 4.6 voxels
    // across in the plane a quarter voxel above; like the hollow Y's, it goes.
    for (const double degreesPerVoxel : {10.0, 15.0, 20.0}) {
        SCOPED_TRACE(degreesPerVoxel);
        MeshOptions options;
        options.slicing.axis = Axis::Z;
        expectEveryLevel(test::twistingC(degreesPerVoxel * M_PI / 180.0), options, expectNoNeedlesIn);
    }
}

namespace {

// The octahedron, and one whose edge (0, 1) is split by vertex 6 at `split`.
const std::vector<Triangle> kOctahedron = {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}, {0, 4, 1},
                                           {5, 2, 1}, {5, 3, 2}, {5, 4, 3}, {5, 1, 4}};

TriangleMesh splitOctahedron(const glm::dvec3& split)
{
    TriangleMesh mesh;
    mesh.vertices = {{0, 0, 1}, {1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}, split};
    mesh.triangles = {{0, 6, 2}, {6, 1, 2}, {0, 2, 3}, {0, 3, 4}, {0, 4, 6},
                      {6, 4, 1}, {5, 2, 1}, {5, 3, 2}, {5, 4, 3}, {5, 1, 4}};
    return mesh;
}

std::vector<Triangle> canonical(std::vector<Triangle> triangles)
{
    for (Triangle& t : triangles) std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
    std::sort(triangles.begin(), triangles.end());
    return triangles;
}

} // namespace

TEST(Quality, ACoincidentVertexOnAnEdgeIsCollapsed)
{
    // Vertex 6 lies on vertex 0, as a junction part's crossing fell on the single contour's: two
    // triangles of no area. The collapse removes them and vertex 6 (the higher-numbered copy),
    // and gives back the octahedron itself (Euler 2 throughout).
    TriangleMesh mesh = splitOctahedron({0, 0, 1});
    EXPECT_EQ(measureQuality(mesh).degenerate, 2);
    EXPECT_EQ(collapseNeedleEdges(mesh, 1e-9, {}), 1);
    EXPECT_EQ(mesh.vertices.size(), 6u);
    EXPECT_EQ(canonical(mesh.triangles), canonical(kOctahedron));
    // Nothing shorter than the tolerance is left: a second pass collapses nothing.
    EXPECT_EQ(collapseNeedleEdges(mesh, 1e-9, {}), 0);
}

TEST(Quality, ANeedleCollapseKeepsTheLevelBelowsVertices)
{
    // Vertex 6 lies 0.01 from vertex 0 along edge (0, 1): the triangles on (0, 6) are needles.
    const glm::dvec3 top(0, 0, 1), split = glm::mix(top, glm::dvec3(1, 0, 0), 0.01 / std::sqrt(2.0));
    const std::vector<glm::dvec3> rim = {{1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
    // Both new: the one later by position (x, then y, then z) goes, vertex 6 (x = 0.007 > 0).
    TriangleMesh mesh = splitOctahedron(split);
    EXPECT_EQ(collapseNeedleEdges(mesh, 0.02, {}), 1);
    std::vector<glm::dvec3> want = {top};
    want.insert(want.end(), rim.begin(), rim.end());
    EXPECT_EQ(mesh.vertices, want);
    EXPECT_EQ(canonical(mesh.triangles), canonical(kOctahedron));
    // Vertex 6 in the level below: it stays and vertex 0 goes, leaving the octahedron with its
    // top moved 0.01 to vertex 6.
    mesh = splitOctahedron(split);
    EXPECT_EQ(collapseNeedleEdges(mesh, 0.02, {split}), 1);
    want = rim;
    want.push_back(split);
    EXPECT_EQ(mesh.vertices, want);
    EXPECT_EQ(measureQuality(mesh).degenerate, 0);
    EXPECT_LT(measureQuality(mesh).largestAspect, 2.0);
    // Both in the level below: both stay, needles and all.
    mesh = splitOctahedron(split);
    EXPECT_EQ(collapseNeedleEdges(mesh, 0.02, {top, split}), 0);
    EXPECT_EQ(mesh.vertices.size(), 7u);
    // An edge longer than the tolerance stays.
    EXPECT_EQ(collapseNeedleEdges(mesh, 0.005, {}), 0);
}

namespace {

// A cone over a hexagon of radius 1 (vertices 0-5, z = 0, closed below by vertex 10) whose tip is
// a contour a speck across (vertices 6-8, radius `speck` at z = 1) fanned around vertex 9 at its
// centre: a tube ending in a section far smaller than a voxel, as where two branches of a dense
// tree touch. Each band triangle on the speck's edges is a needle, and none of those edges can
// go: their two ends share the third speck vertex besides the two corners opposite (linkAllows).
TriangleMesh coneWithASpeckTip(double speck)
{
    TriangleMesh mesh;
    for (int i = 0; i < 6; ++i) mesh.vertices.push_back({std::cos(i * M_PI / 3.0), std::sin(i * M_PI / 3.0), 0.0});
    for (int j = 0; j < 3; ++j)
        mesh.vertices.push_back({speck * std::cos(j * 2.0 * M_PI / 3.0), speck * std::sin(j * 2.0 * M_PI / 3.0), 1.0});
    mesh.vertices.push_back({0, 0, 1});
    mesh.vertices.push_back({0, 0, -1});
    for (std::uint32_t i = 0; i < 6; ++i) {
        const std::uint32_t next = (i + 1) % 6, tip = 6 + i / 2;
        mesh.triangles.push_back({i, next, tip});
        mesh.triangles.push_back({next, i, 10});
    }
    for (std::uint32_t j = 0; j < 3; ++j) {
        const std::uint32_t next = 6 + (j + 1) % 3;
        mesh.triangles.push_back({6 + j, (2 * j + 2) % 6, next});
        mesh.triangles.push_back({6 + j, next, 9});
    }
    return mesh;
}

} // namespace

TEST(Quality, ASpeckOfATipCollapsesIntoOnePoint)
{
    TriangleMesh mesh = coneWithASpeckTip(0.001);
    const Topology before = checkTopology(mesh);
    ASSERT_TRUE(before.closed() && before.manifold() && before.oriented());
    ASSERT_EQ(before.euler, 2);
    ASSERT_GT(measureQuality(mesh).largestAspect, 100.0);
    // The speck's own triangles, all three edges within the tolerance, go whatever their shape:
    // the speck and its centre become one point, the cone's tip (8 vertices: 6 + tip + bottom).
    EXPECT_EQ(collapseNeedleEdges(mesh, 0.01, {}, {kShortEdgeAspect}), 3);
    ASSERT_EQ(mesh.vertices.size(), 8u);
    const Topology after = checkTopology(mesh);
    EXPECT_TRUE(after.closed() && after.manifold() && after.oriented() && after.outward());
    EXPECT_EQ(after.euler, 2);
    EXPECT_EQ(mesh.triangles.size(), 12u);
    // The cone's sides: edges 1, sqrt 2, sqrt 2 (aspect 2 sqrt 3 / (2 sqrt 1.75) = 1.31).
    EXPECT_LT(measureQuality(mesh).largestAspect, 1.32);
    // A speck wider than the tolerance stays as it is.
    mesh = coneWithASpeckTip(0.1);
    EXPECT_EQ(collapseNeedleEdges(mesh, 0.01, {}, {kShortEdgeAspect}), 0);
}

namespace {

// An octahedron (rim 0 to 3, bottom 4) whose top is a speck of three vertices (5, 6 and 7) a few
// thousandths apart, joined to the rim by the triangles `top`.
TriangleMesh octahedronWithASpeck(const std::array<glm::dvec3, 3>& speck, const std::vector<Triangle>& top)
{
    TriangleMesh mesh;
    mesh.vertices = {{1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}, speck[0], speck[1], speck[2]};
    mesh.triangles = top;
    mesh.triangles.insert(mesh.triangles.end(), {{4, 1, 0}, {4, 2, 1}, {4, 3, 2}, {4, 0, 3}});
    return mesh;
}

// Two of the speck's corners go into the third in one step, which leaves the octahedron, its
// faces equilateral (aspect 1) but for the top moved by a few thousandths.
void expectTheSpeckToGoIntoOnePoint(TriangleMesh& mesh)
{
    const Topology before = checkTopology(mesh);
    ASSERT_TRUE(before.closed() && before.manifold() && before.oriented());
    EXPECT_EQ(collapseNeedleEdges(mesh, 0.01, {}, {kShortEdgeAspect}), 2);
    ASSERT_EQ(mesh.vertices.size(), 6u);
    const Topology after = checkTopology(mesh);
    EXPECT_TRUE(after.closed() && after.manifold() && after.oriented() && after.outward());
    EXPECT_EQ(after.euler, 2);
    EXPECT_LT(measureQuality(mesh).largestAspect, 1.01);
}

} // namespace

// The speck's three corners each join the rim vertices around them (as where the isosurface passes
// a voxel's corner: a point on each of its three edges). Every collapse of one speck edge makes a
// needle worse than the worst it takes away (475 before, 479 to 792 after: offsets found by a
// search), so none may go alone; both corners into the third at once may.
TEST(Quality, ASpecksCornersThatCannotGoOneByOneGoTogether)
{
    TriangleMesh mesh =
        octahedronWithASpeck({glm::dvec3(0.001527, -0.000571, 1.001203), glm::dvec3(-0.001051, -0.000275, 1.000777),
                              glm::dvec3(0.000286, -0.002451, 0.999914)},
                             {{5, 0, 1}, {5, 1, 6}, {6, 1, 2}, {6, 2, 7}, {7, 2, 3}, {7, 3, 0}, {7, 0, 5}, {5, 6, 7}});
    ASSERT_GT(measureQuality(mesh).largestAspect, 470.0);
    expectTheSpeckToGoIntoOnePoint(mesh);
}

// The speck's corner V (vertex 6) meets one rim vertex only (1): the other two corners, P and Q (5
// and 7), share that rim vertex besides the two corners opposite their edge, so P and Q cannot go
// into one another first (the collapse would pinch the surface), and each edge collapse at V
// makes a needle worse than the worst it takes away or turns a triangle over (offsets found by a
// search). V goes into P first, then Q (a crop of the smoke: three points a ten-thousandth of a
// voxel apart at a voxel's corner, 1530 at every level).
TEST(Quality, ASpecksCornersGoInTheOrderTheirLinksAllow)
{
    const glm::dvec3 p(-0.002472, 0.001165, 1.002081);
    TriangleMesh mesh =
        octahedronWithASpeck({p, glm::dvec3(0.002125, 0.001394, 0.998197), glm::dvec3(-0.001565, 0.00194, 1.001733)},
                             {{5, 0, 1}, {7, 1, 2}, {7, 2, 3}, {7, 3, 0}, {5, 1, 6}, {6, 1, 7}, {7, 0, 5}, {5, 6, 7}});
    ASSERT_GT(measureQuality(mesh).largestAspect, 1400.0);
    expectTheSpeckToGoIntoOnePoint(mesh);
    // P, the first by position, stays.
    EXPECT_EQ(mesh.vertices[5], p);
}

TEST(Quality, JunctionsLeaveNoDegenerateTriangles)
{
    // A junction part's ray, from the partner's central point, met the single contour's polygon
    // where that contour's own ray did (the Y's centres lie on one line with the point): two
    // vertices at one point and triangles of no area at every level (ybranch 8, tree 48, hollow
    // Y 28). No level has any now, and each stays closed, manifold and oriented.
    expectEveryLevel({"ybranch", "tree", "hollow-y"}, [](const TriangleQuality& q) { EXPECT_EQ(q.degenerate, 0); });
}

TEST(Quality, FlippingAgainChangesNothing)
{
    // The pass ends where no flip lowers the larger aspect ratio of a pair: run again, it flips none.
    const Volume& volume = test::cachedSample("ybranch");
    LevelMesh level = Reconstruction(volume, MeshOptions{}).buildLevel(2);
    EXPECT_GT(level.flips, 0);
    const std::vector<Triangle> before = level.mesh.triangles;
    EXPECT_EQ(flipNeedles(level.mesh, volume, 2), 0);
    EXPECT_EQ(level.mesh.triangles, before);
}

// A triangle of no area on a contour edge: its third corner c lies on the edge ab (to 1e-5 of its
// length), and the triangle across it leaves the plane. A contour edge stays, but flipping this
// one keeps the contour's line, through c. Once the smoke along x got such a triangle (aspect 2.4
// million at its top level, where coarse levels took longer edges: Assembly::build).
TEST(Quality, AFlatTriangleOnAContourEdgeIsFlippedAway)
{
    const Volume& volume = test::cachedSample("ybranch");
    TriangleMesh mesh;
    for (const glm::dvec3& index :
         {glm::dvec3(0, 0, 5), glm::dvec3(4, 0, 5), glm::dvec3(2, 1e-5, 5), glm::dvec3(2, -1, 6)})
        mesh.vertices.push_back(volume.indexToWorld(index));
    mesh.triangles = {{0, 1, 2}, {1, 0, 3}}; // abc in the plane z = 5, bad across to z = 6
    ASSERT_GT(measureQuality(mesh).largestAspect, 1e5);
    EXPECT_EQ(flipNeedles(mesh, volume, 2), 1);
    EXPECT_EQ(mesh.triangles, (std::vector<Triangle>{{2, 0, 3}, {3, 1, 2}}));
    EXPECT_LT(measureQuality(mesh).largestAspect, 2.0);
}

namespace {

// Every level of `volume` (4 levels): no triangle of no area, and (with `boundAspect`) none over
// aspect 100.
void expectNoNeedlesOnFourLevels(const Volume& volume, bool boundAspect, Axis axis)
{
    MeshOptions options;
    options.levels = 4;
    options.slicing.axis = axis;
    const Reconstruction reconstruction(volume, options);
    Refinement refinement(reconstruction);
    while (true) {
        const TriangleQuality q = measureQuality(refinement.mesh().mesh);
        EXPECT_EQ(q.degenerate, 0) << "level " << refinement.level();
        if (boundAspect) {
            EXPECT_LE(q.largestAspect, 100.0) << "level " << refinement.level();
        }
        if (!refinement.canRefine()) break;
        refinement.refine();
    }
}

// The same for a shared real volume, read at `iso` (none: the grid's default).
void expectNoNeedlesOnRealData(const char* file, bool boundAspect = true, Axis axis = Axis::Auto,
                               std::optional<double> iso = std::nullopt)
{
    SCOPED_TRACE(file);
    VolumeOptions read;
    read.iso = iso;
    expectNoNeedlesOnFourLevels(readVolume(test::realData(file), read), boundAspect, axis);
}

} // namespace

TEST(Quality, NoNeedlesOnTheRealData)
{
    // The vmtk aorta's contours held crossings 0.001 mm apart (rays meeting the boundary at
    // nearly one point, next to the central point), and its junction parts crossings next to the
    // single contour's: aspect up to 23870. The collapses take those vertices out.
    expectNoNeedlesOnRealData("vmtk_aorta_ls.vdb");
    expectNoNeedlesOnRealData("ts_common_carotid_artery_left_ls.vdb");
    // Gaffer's sphere, as a level set and as a density fog: smooth, one tube capped at both ends.
    expectNoNeedlesOnRealData("gaffer_sphere_levelset.vdb");
    expectNoNeedlesOnRealData("gaffer_sphere_density_fog.vdb");
    // Gaffer's smoke, a noisy fog. Its last needle (aspect 139 at level 1, flat in the plane y = 32
    // under a merge) went with the waists (n:m pieces are meshed from their cells where those close:
    // Graph.AnNmPieceWhoseCellsCloseTakesNoWaist). Before: two collapses that moved a vertex onto
    // the line through two others (aspect 4.5e14 and 7.7e13 at levels 2 and 3); short edges between
    // vertices of the level below that no collapse may take (levels nest); a speck of a keyhole's
    // branch owning a sliver of the contour (README, triangle quality).
    expectNoNeedlesOnRealData("gaffer_smoke_fog.vdb");
}

// The same along every axis, not only the one the grid's shape picks: a vessel sliced across its
// length has sections many voxels long whose walls rays meet far apart (the cone's, below).
TEST(Quality, NoNeedlesOnTheRealVesselsAndSpheresAlongEveryAxis)
{
    for (const char* file : {"vmtk_aorta_ls.vdb", "ts_common_carotid_artery_left_ls.vdb", "gaffer_sphere_levelset.vdb",
                             "gaffer_sphere_density_fog.vdb"})
        for (const Axis axis : {Axis::X, Axis::Y, Axis::Z}) {
            SCOPED_TRACE(axis == Axis::X ? "along x" : axis == Axis::Y ? "along y" : "along z");
            expectNoNeedlesOnRealData(file, true, axis);
        }
}

TEST(Quality, NoNeedlesOnTheSmokeAtTheIsovalueItsReadmeGives)
{
    // Gaffer's smoke at iso 0.1 (data/README's value), along its longest side (y, the default):
    // tendrils thinner than a tenth of a voxel end in tips whose needles no collapse or flip could
    // take (aspect 133 at level 2, 256 at level 3): a ring of three points with a short edge, fanned
    // to a tip (a collapse would pinch the surface), and three points a thousandth of a voxel apart
    // at a voxel's corner. Removing their corners and tiling the hole anew takes them
    // (removeNeedleCorners): 78 and 98 now.
    expectNoNeedlesOnRealData("gaffer_smoke_fog.vdb", true, Axis::Auto, 0.1);
}

// A crop of the smoke (crop survey seed 121, run 3) at iso 0.1, sliced along z: at its top level
// three points within a thousandth of a voxel at a voxel's corner, the one the level below has
// a corner of only three triangles, held a needle of aspect 1697 on the short edge between those two.
// The passes after the collapses (corner removal, flips, fans tiled anew) had made that shape,
// which no collapse then looked at. The short edges now go once more at the end, where that
// lowers the worst aspect ratio around: 63.7 (the speck's three points become one).
TEST(Quality, AVoxelCornersSpeckLeftByTheLastPassesGoes)
{
    expectNoNeedlesOnFourLevels(test::realCrop("gaffer_smoke_fog.vdb", {44, 117, 30}, {79, 150, 77}, 0.1), true,
                                Axis::Z);
}

TEST(Quality, ANeedleOnAContourEdgeIsFlippedAway)
{
    // Gaffer's smoke along x: at its top level three points of one contour, nearly in line, made a
    // triangle of aspect 104.5 whose two short edges are contour edges, which no flip took. A
    // contour edge with a triangle past kLargestAspect on it may now flip (flipNeedles), where the
    // surface moves no more than any flip may: 78 there. Before, levels 2 and 3 held 110.
    expectNoNeedlesOnRealData("gaffer_smoke_fog.vdb", true, Axis::X);
}

TEST(Quality, PatchesThatMeetAtALoopLeaveNoTriangleOfNoArea)
{
    // Gaffer's smoke along z: two pieces meshed from their cells meet at a loop, one either side of
    // its plane. Each had its own copy of the loop's points, and each patch's edges on the loop were
    // split through the other's copies too: triangles of no area, which let a collapse past its
    // guard, and two of them stayed at levels 1 to 3. The patches share the points now. Its last
    // needle, 106 at levels 2 and 3 (a new vertex 0.008 voxel from one of level 1's, which it
    // cannot go into), went with its corner (removeNeedleCorners): 93 and 54.
    expectNoNeedlesOnRealData("gaffer_smoke_fog.vdb", true, Axis::Z);
}

TEST(Quality, NoNeedlesAtAConesTip)
{
    // The ChestImagingPlatform cone's tip ends in an end contour of radius 0.03 voxel; at level 0
    // its band reaches the next contour the slice choice keeps, 304 voxels away: edges of 0.02
    // voxel facing 304 voxels, aspect 1.4e4. The contour and its apex made a tetrahedron whose
    // edges no collapse could take (the link condition: it would pinch the tube); after the flips
    // rearrange it, the collapses that follow them take the tip into one of its points, which
    // moves the surface by less than the contour's radius: level 0 stays 1.15 voxels from the
    // isosurface, as it was.
    expectNoNeedlesOnRealData("cip_cone_vessel_density.vdb");
}

namespace {

// A pillow along z from `a`, one unit long, its third corner a thousandth below and beside the top: two
// triangles over the same three vertices (aspect about 870), ids in the order given.
TriangleMesh pillowAt(const glm::dvec3& a, const std::array<std::uint32_t, 3>& order = {0, 1, 2})
{
    const std::array<glm::dvec3, 3> corners{a, a + glm::dvec3(0.0, 0.0, 1.0), a + glm::dvec3(0.001, 0.0, 0.999)};
    TriangleMesh mesh;
    for (const std::uint32_t k : order) mesh.vertices.push_back(corners[k]);
    const auto id = [&](std::uint32_t k) {
        return static_cast<std::uint32_t>(std::find(order.begin(), order.end(), k) - order.begin());
    };
    mesh.triangles = {{id(0), id(1), id(2)}, {id(0), id(2), id(1)}};
    return mesh;
}

std::vector<glm::dvec3> sortedVertices(std::vector<glm::dvec3> vertices)
{
    std::sort(vertices.begin(), vertices.end(), [](const glm::dvec3& p, const glm::dvec3& q) {
        return p.x != q.x ? p.x < q.x : p.y != q.y ? p.y < q.y : p.z < q.z;
    });
    return vertices;
}

} // namespace

// What the collapses leave of a speck far thinner than a voxel (the smoke at iso 0.1 along y:
// aspect 541 at every level) becomes a spindle: the pillow's two corners farthest apart as its
// tips, three vertices around the middle, six equilateral triangles: a closed sphere still. Its
// side comes from the field's curvature: inside the straight capsule's wall (1.5 voxels in, where
// the narrow band holds distances) it faces outward; in the tank's cavity (1.5 voxels from its
// wall) it faces into the cavity, as the void's own wall does.
TEST(Quality, APillowOfNeedlesBecomesASpindle)
{
    for (const bool inVoid : {false, true}) {
        SCOPED_TRACE(inVoid ? "tank's cavity" : "capsule's wall");
        const Volume& volume = test::cachedSample(inVoid ? "tank" : "straight");
        const glm::dvec3 a = inVoid ? glm::dvec3(32.0 + 14.5, 32.0, 56.0) : glm::dvec3(32.0 + 8.5, 32.0, 64.0);
        TriangleMesh mesh = pillowAt(a);
        ASSERT_GT(measureQuality(mesh).largestAspect, kLargestAspect);
        EXPECT_EQ(inflatePillows(mesh, volume, {}), 1);
        const Topology t = checkTopology(mesh);
        EXPECT_TRUE(t.closed() && t.manifold() && t.oriented());
        EXPECT_EQ(t.euler, 2);
        EXPECT_EQ(t.components, 1);
        EXPECT_EQ(t.outward(), !inVoid);
        EXPECT_EQ(mesh.vertices.size(), 5u);
        EXPECT_EQ(mesh.triangles.size(), 6u);
        EXPECT_NEAR(measureQuality(mesh).largestAspect, 1.0, 1e-9);
        // The tips are the corners farthest apart; the third goes.
        EXPECT_EQ(mesh.vertices[0], a);
        EXPECT_EQ(mesh.vertices[1], a + glm::dvec3(0.0, 0.0, 1.0));
        // The same spindle, bit for bit, whatever the ids: so the levels nest.
        TriangleMesh permuted = pillowAt(a, {2, 0, 1});
        inflatePillows(permuted, volume, {});
        EXPECT_EQ(sortedVertices(permuted.vertices), sortedVertices(mesh.vertices));
    }
    const Volume& volume = test::cachedSample("straight");
    const glm::dvec3 a(32.0 + 8.5, 32.0, 64.0);
    // A vertex the coarser level has stays: with the third corner there, the bottom goes.
    TriangleMesh mesh = pillowAt(a);
    const glm::dvec3 third = mesh.vertices[2], top = mesh.vertices[1];
    EXPECT_EQ(inflatePillows(mesh, volume, {third, top}), 1);
    EXPECT_EQ(std::count(mesh.vertices.begin(), mesh.vertices.end(), a), 0);
    EXPECT_EQ(std::count(mesh.vertices.begin(), mesh.vertices.end(), third), 1);
    // A pillow of no needle is left alone, as is one whose three corners the coarser level has.
    TriangleMesh fat;
    fat.vertices = {a, a + glm::dvec3(0.0, 0.0, 1.0), a + glm::dvec3(0.0, 1.0, 0.0)};
    fat.triangles = {{0, 1, 2}, {0, 2, 1}};
    EXPECT_EQ(inflatePillows(fat, volume, {}), 0);
    TriangleMesh kept = pillowAt(a);
    EXPECT_EQ(inflatePillows(kept, volume, kept.vertices), 0);
    EXPECT_EQ(kept.triangles.size(), 2u);
}

namespace {

// A tendril's tip: a ring of three vertices (0 to 2, in the plane z = 0), its edge 0-1 two
// thousandths long, fanned to a tip below (3) and one above (4) on the axis through its centroid.
// The triangles on edge 0-1 are needles (aspect 435 and 137) that no collapse may take: 0 and 1
// share vertex 2 besides the two tips (linkAllows: the collapse would pinch the surface).
TriangleMesh bipyramidWithAShortRingEdge()
{
    TriangleMesh mesh;
    mesh.vertices = {{0.0, 0.0, 0.0}, {0.002, 0.0, 0.0}, {0.001, 0.3, 0.0}, {0.001, 0.1, -0.3}, {0.001, 0.1, 1.0}};
    mesh.triangles = {{0, 1, 4}, {1, 2, 4}, {2, 0, 4}, {1, 0, 3}, {2, 1, 3}, {0, 2, 3}};
    return mesh;
}

} // namespace

TEST(Quality, ANeedlesCornerThatNoCollapseTakesIsRemoved)
{
    TriangleMesh mesh = bipyramidWithAShortRingEdge();
    ASSERT_GT(measureQuality(mesh).largestAspect, 400.0);
    TriangleMesh collapsed = mesh;
    ASSERT_EQ(collapseNeedleEdges(collapsed, 0.01, {}, {kShortEdgeAspect}), 0);
    // Vertex 0 goes (the first by position), and its polygon (1, 4, 2, 3) is tiled by the diagonal
    // 3-4, as 1-2 exists: a tetrahedron. Its worst triangle is 1-4-3: the axis 3-4, 1.3 long, lies
    // 0.1 from vertex 1, aspect 1.3 / 0.1 * sqrt(3) / 2 = 11.26.
    const std::vector<glm::dvec3> before = mesh.vertices;
    EXPECT_EQ(removeNeedleCorners(mesh, {}, 0.05), 1);
    const Topology t = checkTopology(mesh);
    EXPECT_TRUE(t.closed() && t.manifold() && t.oriented() && t.outward());
    EXPECT_EQ(t.euler, 2);
    EXPECT_EQ(t.components, 1);
    ASSERT_EQ(mesh.vertices.size(), 4u);
    EXPECT_EQ(mesh.triangles.size(), 4u);
    EXPECT_EQ(mesh.vertices, std::vector<glm::dvec3>(before.begin() + 1, before.end()));
    EXPECT_NEAR(measureQuality(mesh).largestAspect, 1.3 / 0.1 * std::sqrt(3.0) / 2.0, 0.01);
    // A vertex the coarser level has stays, so levels still nest: with vertex 0 there, 1 goes.
    mesh = bipyramidWithAShortRingEdge();
    EXPECT_EQ(removeNeedleCorners(mesh, {before[0]}, 0.05), 1);
    EXPECT_EQ(mesh.vertices.front(), before[0]);
    EXPECT_EQ(mesh.vertices.size(), 4u);
    // Nothing goes where the coarser level has every corner, or where the surface would move
    // farther than the reach (vertex 0 lies a thousandth from the new triangles).
    mesh = bipyramidWithAShortRingEdge();
    EXPECT_EQ(removeNeedleCorners(mesh, before, 0.05), 0);
    EXPECT_EQ(removeNeedleCorners(mesh, {}, 0.0005), 0);
    EXPECT_EQ(mesh.triangles.size(), 6u);
}

namespace {

// A speck's spindle, as the gaffer smoke at iso 0.1 along x has one at level 2: its axis from
// vertex 0 to vertex 1, a unit long, through a ring of three points a hundredth apart (2 to 4),
// where the level below had a pillow of 0, 2 and 3. The triangles from vertex 4 to 2 and an end
// are needles (aspect 106 and 105).
TriangleMesh spindleOverAPillow()
{
    TriangleMesh mesh;
    mesh.vertices = {
        {0.005, -0.5, 0.0005}, {0.005, 0.5, 0.0005}, {0.0, 0.0, 0.0}, {0.012, 0.0, 0.0}, {0.004, -0.02, 0.0015}};
    mesh.triangles = {{1, 3, 2}, {0, 2, 3}, {1, 4, 3}, {0, 3, 4}, {1, 2, 4}, {0, 4, 2}};
    return mesh;
}

} // namespace

TEST(Quality, ASpindlesNewCornersGoInRoundsDownToThePillowBelow)
{
    TriangleMesh mesh = spindleOverAPillow();
    ASSERT_GT(measureQuality(mesh).largestAspect, 100.0);
    const std::vector<glm::dvec3> before = mesh.vertices, pillow(before.begin(), before.begin() + 3);
    // Vertex 4 alone cannot go (its polygon's diagonal 0-1 would pass 0.005 from vertex 2, aspect
    // 173); the end 1 can, leaving a tetrahedron whose needle 0-4-2 a second round takes: 4 goes,
    // and its polygon 0, 2, 3 closes against the triangle 0-2-3 (reversed) into the pillow.
    EXPECT_EQ(removeNeedleCorners(mesh, {before[0], before[2], before[3]}, 0.6), 2);
    const Topology t = checkTopology(mesh);
    EXPECT_TRUE(t.closed() && t.manifold() && t.oriented());
    EXPECT_EQ(t.euler, 2);
    EXPECT_EQ(t.components, 1);
    EXPECT_EQ(mesh.vertices, std::vector<glm::dvec3>({before[0], before[2], before[3]}));
    EXPECT_EQ(mesh.triangles.size(), 2u);
    // The pillow's aspect: its longest edge 0-3 squared over twice its area (base 0.012, height
    // the distance from vertex 0 to the x axis), times sqrt(3) / 2.
    const double longest = 0.007 * 0.007 + 0.25 + 0.0005 * 0.0005, height = std::sqrt(0.25 + 0.0005 * 0.0005);
    EXPECT_NEAR(measureQuality(mesh).largestAspect, longest / (0.012 * height) * std::sqrt(3.0) / 2.0, 1e-6);
    // The end lies half a unit from what is left: within a reach of 0.1 nothing goes.
    mesh = spindleOverAPillow();
    EXPECT_EQ(removeNeedleCorners(mesh, {before[0], before[2], before[3]}, 0.1), 0);
    EXPECT_EQ(mesh.triangles.size(), 6u);
}

namespace {

// A flat fan of needles: vertex 0 at (0, 0.2, 0) fanned in the plane z = 0 over a chain of six
// points a pixel apart a tenth below its line (1 to 6, y = 0.1) and another a voxel above (7 to
// 12, y = 1.1, x = 10 to 15), as a band fans a contour's vertex across a slab to a contour a vertex
// per pixel; a vertex below (13) closes it. The fan's worst triangles: a base of 1, a tenth off a
// line 15 long (aspect 15^2 / 0.1 * sqrt(3) / 2 = 1949).
TriangleMesh fanOverTwoChains()
{
    TriangleMesh mesh;
    mesh.vertices.push_back({0.0, 0.2, 0.0});
    for (const double y : {0.1, 1.1})
        for (int k = 0; k < 6; ++k) mesh.vertices.push_back({10.0 + k, y, 0.0});
    mesh.vertices.push_back({12.0, 0.6, -3.0});
    // The polygon v, a0..a5, b5..b0 runs counterclockwise seen from +z; the vertex below closes
    // each of its edges.
    std::vector<std::uint32_t> polygon{0, 1, 2, 3, 4, 5, 6, 12, 11, 10, 9, 8, 7};
    for (std::size_t k = 1; k + 1 < polygon.size(); ++k) mesh.triangles.push_back({0, polygon[k], polygon[k + 1]});
    for (std::size_t k = 0; k < polygon.size(); ++k)
        mesh.triangles.push_back({13, polygon[(k + 1) % polygon.size()], polygon[k]});
    return mesh;
}

} // namespace

TEST(Quality, AFanOfNeedlesWhoseCornersAllStayIsTiledAnew)
{
    TriangleMesh mesh = fanOverTwoChains();
    ASSERT_NEAR(measureQuality(mesh).largestAspect, 15.0 * 15.0 / 0.1 * std::sqrt(3.0) / 2.0, 15.0);
    const std::vector<glm::dvec3> before = mesh.vertices;
    // The part of vertex 0's fan over the chains becomes a strip between them and one triangle
    // from vertex 0 to their first points (0, 1, 7): its longest edge, sqrt(100.81), over twice
    // its area, 10, gives 8.73; no triangle of the fan's polygon that holds edge 0-1 is better.
    EXPECT_GE(retileNeedleFans(mesh, 1e-6), 1);
    EXPECT_EQ(mesh.vertices, before);
    const Topology t = checkTopology(mesh);
    EXPECT_TRUE(t.closed() && t.manifold() && t.oriented());
    EXPECT_EQ(t.euler, 2);
    EXPECT_EQ(t.components, 1);
    EXPECT_EQ(mesh.triangles.size(), fanOverTwoChains().triangles.size());
    EXPECT_NE(std::find(mesh.triangles.begin(), mesh.triangles.end(), Triangle{0, 1, 7}), mesh.triangles.end());
    const TriangleQuality q = measureQuality(mesh);
    EXPECT_LT(q.largestAspect, 100.0);
    // Retiling again finds no needle, and changes nothing.
    const std::vector<Triangle> tiled = mesh.triangles;
    EXPECT_EQ(retileNeedleFans(mesh, 1e-6), 0);
    EXPECT_EQ(mesh.triangles, tiled);
}

// A fan is tiled anew only where the surface moves no farther than the reach. Flat, it takes
// none (above); with vertex 0 lifted 0.5 out of the chains' plane (the fan still needles, 0.51 off
// the line), the fan's triangles over a chain lie in one plane, over which no better tiling exists
// (its other triangles hold three points of the chain, in line), and any part that holds both
// chains bends, so that its tiling anew moves the surface.
TEST(Quality, AFanIsTiledAnewOnlyWithinTheReach)
{
    TriangleMesh mesh = fanOverTwoChains();
    mesh.vertices[0].z = 0.5;
    const std::vector<Triangle> fan = mesh.triangles;
    EXPECT_EQ(retileNeedleFans(mesh, 1e-6), 0);
    EXPECT_EQ(mesh.triangles, fan);
    EXPECT_GE(retileNeedleFans(mesh, 0.5), 1);
    EXPECT_LT(measureQuality(mesh).largestAspect, 100.0);
}

// The serpentine and the parting tree sliced along x kept 107 and 179 at level 3: flips had made
// needles of three vertices the level below has, where the needles they replaced could still go
// with their new corners, and once made no pass could take them. Such flips now wait until the
// other passes are done (flipNeedles).
TEST(Quality, NoNeedlesOnTheSerpentineAndThePartingTreeSlicedAlongX)
{
    expectNoNeedlesAlong({"serpentine", "parting"}, Axis::X);
}

// The phantom sliced along y kept 133 and 104 at levels 2 and 3, each a band some 70 voxels long
// fanned from a crossing over a few points of the next contour a voxel or two apart, where the
// phantom's flat top meets its wall: those bands, in slabs thicker than the events', had been
// asked from their own two contours, which strayed where the level's tiling did not, and took
// their cells; the cells met the long band triangles. Asked as the top level tiles them, they keep
// their triangles, and the largest aspect ratios are 97 and 96.
TEST(Quality, NoNeedlesOnThePhantomSlicedAcrossItsLength)
{
    expectNoNeedlesAlong({"phantom"}, Axis::Y);
}

TEST(Quality, ACornerCollapseMovesTheSurfaceNoFartherThanItsReach)
{
    // The standing torus sliced along y: below the top level a needle's corner may go along its
    // other edges where the surface moves no farther than the level's reach (kNeedleReachVoxels,
    // twice as far each level coarser: 1.2 voxels at level 1 of 4). Measured at each new
    // triangle's centroid and two edge midpoints, a fan 33 voxels long passed, and level 1 went
    // from 0.83 voxel off the isosurface to 4.5; measured over the whole triangle it stays
    // within the reach of where it was.
    const Volume& volume = test::cachedSample("torus-standing");
    MeshOptions options;
    options.levels = 4;
    options.slicing.axis = Axis::Y;
    const Reconstruction reconstruction(volume, options);
    const Validation v = Validator(volume).validate(reconstruction.buildLevel(1).mesh);
    EXPECT_LE(v.symmetric.max, (0.83 + 4 * kNeedleReachVoxels) * v.voxel);
}

namespace {

// The speck the smoke at iso 0.1 sliced along x keeps at its top level (in voxels, about its
// middle): a void a fiftieth of a voxel thick meshed as a bipyramid. Tip 0 and ring vertices
// 2 and 3 come from the level below, a pillow there; tip 1 and ring vertex 4 are new. Vertex 4 lies
// 0.006 off the tips' line, so both triangles on ring edge 2-4 are needles (aspect 154 and 153).
TriangleMesh smokeSpeck()
{
    TriangleMesh mesh;
    mesh.vertices = {
        {0.0, -1.1055, 0.0}, {0.0, 1.0059, 0.0}, {-0.003, 0.0, 0.0}, {0.0211, 0.0, 0.0}, {0.0, -0.0559, -0.0055}};
    mesh.triangles = {{4, 2, 0}, {1, 2, 4}, {1, 3, 2}, {2, 3, 0}, {0, 3, 4}, {4, 3, 1}};
    return mesh;
}

} // namespace

TEST(Quality, ANeedlesNewCornerMovesAsLittleAsItMust)
{
    TriangleMesh mesh = smokeSpeck();
    ASSERT_GT(measureQuality(mesh).largestAspect, 150.0);
    const TriangleMesh before = mesh;
    const std::vector<glm::dvec3> coarser = {before.vertices[0], before.vertices[2], before.vertices[3]};
    // No collapse or corner removal may take it: 2 and 4 share vertex 3 besides the tips, and
    // without 4 or 1 the tips' line runs 0.003 from vertex 2 (aspect 609).
    EXPECT_GE(moveNeedleCorners(mesh, coarser, 0.3), 1);
    EXPECT_EQ(mesh.triangles, before.triangles);
    for (const std::uint32_t kept : {0u, 2u, 3u}) EXPECT_EQ(mesh.vertices[kept], before.vertices[kept]);
    // A tip triangle's aspect ratio is about sqrt(3)/2 of the tip's distance (1.05) over the ring
    // vertex's distance from the tips' line: kCollapseAspect takes 0.018, so vertex 4 moves about
    // a fiftieth of a voxel, where the lowest worst aspect ratio lies as far as the reach allows.
    EXPECT_LE(measureQuality(mesh).largestAspect, kCollapseAspect);
    EXPECT_LT(glm::distance(mesh.vertices[4], before.vertices[4]), 0.05);
    EXPECT_LT(glm::distance(mesh.vertices[1], before.vertices[1]), 0.05);
    // No triangle turns over, and the speck stays a closed surface facing into itself: it is a
    // void's (the field is 0.098 there, over 0.6 a voxel either side across the filament).
    for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
        const Triangle& t = mesh.triangles[f];
        const auto normal = [&](const TriangleMesh& m) {
            return glm::cross(m.vertices[t[1]] - m.vertices[t[0]], m.vertices[t[2]] - m.vertices[t[0]]);
        };
        EXPECT_GT(glm::dot(normal(mesh), normal(before)), 0.0) << "triangle " << f;
    }
    const Topology t = checkTopology(mesh);
    EXPECT_TRUE(t.closed() && t.manifold() && t.oriented() && !t.outward());
    // Nothing is left to move; and where the coarser level has every corner, nothing moves.
    EXPECT_EQ(moveNeedleCorners(mesh, coarser, 0.3), 0);
    mesh = before;
    EXPECT_EQ(moveNeedleCorners(mesh, before.vertices, 0.3), 0);
    EXPECT_EQ(mesh.vertices, before.vertices);
}

namespace {

// The same void sliced along z, at the top level (in voxels, about its middle): it lies in the
// slicing plane, its section a sliver (0 to 8) with the level below's apexes either side (9 and
// 10, 0.005 apart) fanned to it. Its far end (2), new at this level, shares a triangle with both
// apexes: aspect 170 on their short edge.
TriangleMesh speckInTheSlicingPlane()
{
    TriangleMesh mesh;
    mesh.vertices = {{0.0211, 0.0, 0.0},      {0.0295, 0.3, 0.0},      {0.0, 1.0059, 0.0},     {-0.0032, -0.0032, 0.0},
                     {-0.0041, -0.0205, 0.0}, {-0.0066, -0.0666, 0.0}, {0.2008, -1.0093, 0.0}, {0.1417, -0.4672, 0.0},
                     {0.0789, -0.1905, 0.0},  {0.0, 0.0, -0.0028},     {0.0, 0.0, 0.0023}};
    mesh.triangles = {{1, 9, 0},  {2, 9, 1},  {10, 9, 2}, {3, 9, 10}, {4, 9, 3},  {4, 5, 0},
                      {5, 6, 7},  {5, 7, 8},  {5, 8, 0},  {0, 9, 4},  {0, 10, 1}, {1, 10, 2},
                      {3, 10, 4}, {4, 10, 5}, {5, 10, 6}, {6, 10, 7}, {7, 10, 8}, {8, 10, 0}};
    return mesh;
}

} // namespace

TEST(Quality, ANeedleNoMoveTakesIsSplitAlongItsLongestEdge)
{
    TriangleMesh mesh = speckInTheSlicingPlane();
    const TriangleMesh before = mesh;
    ASSERT_GT(measureQuality(mesh).largestAspect, 150.0);
    const Topology was = checkTopology(mesh);
    ASSERT_TRUE(was.closed() && was.manifold() && was.oriented());
    // A tip triangle on the apexes' edge needs its tip within 0.59 of them for aspect 100 (about
    // sqrt(3)/2 of the distance over 0.005); the far end lies 1.006 away, more than the reach
    // beyond, and no other corner of it may move (the level below has them).
    const std::vector<glm::dvec3> coarser = {before.vertices[0], before.vertices[3], before.vertices[4],
                                             before.vertices[8], before.vertices[9], before.vertices[10]};
    EXPECT_EQ(moveNeedleCorners(mesh, coarser, 0.3), 0);
    EXPECT_EQ(mesh.vertices, before.vertices);
    // Split at its midpoint, 0.5 from the apexes, the needle's longest edge leaves a half of 85 on
    // the short edge (and one of 342 on the far end, the midpoint being in line); the new vertex
    // then moves off the line and toward the apexes until its fan's worst is kCollapseAspect, the
    // other triangles' being under it.
    EXPECT_EQ(splitNeedleEdges(mesh, 0.3), 1);
    ASSERT_EQ(mesh.vertices.size(), before.vertices.size() + 1);
    EXPECT_EQ(std::vector<glm::dvec3>(mesh.vertices.begin(), mesh.vertices.end() - 1), before.vertices);
    EXPECT_EQ(mesh.triangles.size(), before.triangles.size() + 2);
    EXPECT_LE(measureQuality(mesh).largestAspect, kCollapseAspect);
    const glm::dvec3 midpoint = 0.5 * (before.vertices[2] + before.vertices[9]);
    EXPECT_LE(glm::distance(mesh.vertices.back(), midpoint), 0.3);
    const Topology t = checkTopology(mesh);
    EXPECT_TRUE(t.closed() && t.manifold() && t.oriented());
    EXPECT_EQ(t.outward(), was.outward());
    EXPECT_EQ(t.euler, 2);
    EXPECT_EQ(t.components, 1);
    // Nothing is left to split.
    EXPECT_EQ(splitNeedleEdges(mesh, 0.3), 0);
    // A pillow of needles stays: its two triangles share their third corner, and the edge from the
    // midpoint to it would hold four triangles.
    TriangleMesh pillow;
    pillow.vertices = {{0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}, {0.5, 0.001, 0.0}};
    pillow.triangles = {{0, 1, 2}, {1, 0, 2}};
    ASSERT_GT(measureQuality(pillow).largestAspect, kLargestAspect);
    EXPECT_EQ(splitNeedleEdges(pillow, 0.3), 0);
    EXPECT_EQ(pillow.vertices.size(), 3u);
    EXPECT_EQ(pillow.triangles.size(), 2u);
}

// The smoke at iso 0.1 (data/README's value) sliced along x kept 154 at its top level on the void
// of smokeSpeck: its new ring vertex now moves 0.016 voxel (moveNeedleCorners), and the level's
// largest aspect ratio is 91 (its distance to the isosurface does not change).
TEST(Quality, NoNeedlesOnTheSmokeAtItsReadmeIsovalueAlongX)
{
    expectNoNeedlesOnRealData("gaffer_smoke_fog.vdb", true, Axis::X, 0.1);
}

// The same sliced along z kept 174 at its top level on the void of speckInTheSlicingPlane: its
// needle's longest edge is split, and the new vertex moves 0.2 voxel toward the apexes, a hundredth
// of a voxel off the filament (splitNeedleEdges). The level's largest aspect ratio is 90.
TEST(Quality, NoNeedlesOnTheSmokeAtItsReadmeIsovalueAlongZ)
{
    expectNoNeedlesOnRealData("gaffer_smoke_fog.vdb", true, Axis::Z, 0.1);
}

// The CIP cone vessel sliced across its length, along x or y (along z, its default axis:
// NoNeedlesOnTheRealData). Its sections are wedges some 300 voxels long whose tip, at z = 35,
// recedes 7 voxels from one plane to the next half a voxel on. Rays from a section's central
// point meet its sides far from the tip, however often the sectors are halved: level 1 kept an edge
// of 112 voxels from the tip along a side, and a band across half a voxel on such an edge has
// needles whatever its tiling (174 and 113 at levels 1 and 2 along x, 113 at level 2 along y).
// Wall vertices now cut such edges at every level (longChordPoints): 49, 52, 93 at levels 1 to 3
// along x.
TEST(Quality, NoNeedlesOnTheConeVesselSlicedAcrossItsLength)
{
    expectNoNeedlesOnRealData("cip_cone_vessel_density.vdb", true, Axis::X);
    expectNoNeedlesOnRealData("cip_cone_vessel_density.vdb", true, Axis::Y);
}

// A coarse level's wall vertices stay at every finer level: the levels nest bit for bit (nestLevels
// finds each level's vertices among the next's), and each level built from scratch is the level
// refined to (buildLevel takes the coarser levels' vertices too).
TEST(Quality, ACoarseLevelsWallVerticesStayAtEveryFinerLevel)
{
    MeshOptions options;
    options.levels = 4;
    options.slicing.axis = Axis::X;
    const Reconstruction reconstruction(readVolume(test::realData("cip_cone_vessel_density.vdb")), options);
    Refinement refinement(reconstruction);
    std::vector<LevelMesh> levels{refinement.mesh()};
    while (refinement.canRefine()) levels.push_back(refinement.refine());
    EXPECT_GT(levels[1].wallVertices, 0);
    EXPECT_NO_THROW(nestLevels(levels));
    for (int level = 1; level < 4; ++level) {
        const LevelMesh scratch = reconstruction.buildLevel(level);
        EXPECT_EQ(scratch.mesh.vertices, levels[level].mesh.vertices) << "level " << level;
        EXPECT_EQ(scratch.mesh.triangles, levels[level].mesh.triangles) << "level " << level;
    }
}

// Known gaps of issue 17's bound (README, triangle quality) on a crop of a shared volume, strict
// and registered with ctest as expected failures (CMakeLists.txt): when one passes, ctest says so,
// and it joins the suite above.

// No needle over 100 on a crop of the smoke (crop survey 138/2: box 27,22,45..69,66,95, iso 0.2,
// sliced along z): 151.6 at level 2. Six points of a tendril lying in the slicing plane, within
// 0.05 voxel of a line, joined by triangles in the plane; the needle's short edge (0.018 voxel,
// one end new at level 2) cannot collapse, as both its ends share a neighbour off the plane (the
// link condition), and every other tiling of its fan is flatter (aspect 260).
TEST(KnownGap, ATendrilLyingInTheSlicingPlaneHasNoNeedles)
{
    expectNoNeedlesOnFourLevels(test::realCrop("gaffer_smoke_fog.vdb", {27, 22, 45}, {69, 66, 95}, 0.2), true, Axis::Z);
}
