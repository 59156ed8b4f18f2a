#include <pipetile/error.h>
#include <pipetile/multires.h>
#include <pipetile/validate.h>
#include <pipetile/volume.h>

#include "phantoms.h"
#include "test_util.h"

#include <glm/geometric.hpp>

#include <cmath>
#include <map>
#include <set>
#include <tuple>

using namespace pipetile;
using pipetile::test::cachedSample;

namespace {

void expectClosedSphere(const TriangleMesh& mesh, int components)
{
    const Topology topo = checkTopology(mesh);
    EXPECT_TRUE(topo.closed()) << topo.boundaryEdges << " boundary edges";
    EXPECT_TRUE(topo.manifold()) << topo.nonManifoldEdges << " edges, " << topo.nonManifoldVertices << " vertices";
    EXPECT_TRUE(topo.oriented()) << topo.misorientedEdges << " misoriented edges";
    EXPECT_TRUE(topo.outward()) << "signed volume " << topo.signedVolume;
    EXPECT_EQ(topo.components, components);
    EXPECT_EQ(topo.euler, 2 * components); // each component a sphere
}

std::set<std::tuple<double, double, double>> vertexSet(const TriangleMesh& mesh)
{
    std::set<std::tuple<double, double, double>> s;
    for (const glm::dvec3& p : mesh.vertices) s.insert({p.x, p.y, p.z});
    return s;
}

} // namespace

TEST(Multires, StraightCapsuleHasTheExactTriangleCount)
{
    // Capsule: axis (32, 32), z in [16, 112], radius 10, so the surface spans z in (6, 122). The
    // band is active where |phi| < 3 voxels: z from 4 to 124, so slices sit at z = 4, 6, ..., 124.
    // Slices at z = 6 and 122 touch only the tips (radius 0, nothing strictly inside), those
    // beyond are empty, and z = 8 .. 120 (radius >= 6) each hold one circle: 57 contours. The
    // axis meets the tips at z = 6 and 122, so end contours go a quarter voxel inside each
    // (z = 6.25 and 121.75, radius sqrt(100 - 9.75^2) = 2.22). From the last circle's radius 6
    // that band would change by 3.78 pixels, over the bands' 3, so it is halved: an end contour at
    // z = 7.125 (radius 4.61, 1.39 from 6), then one at 6.25 (2.39 from 4.61); 61 in one tube.
    // Circles are star-shaped: n crossings each, two triangles per crossing (bands of m_k + m_k+1,
    // caps of m around the tips): 2 * n * 61 triangles, n * 61 + 2 vertices (2 cap apexes).
    // On every slice (the paper's levels); by default levels skip slices (next test).
    const Volume& v = cachedSample("straight");
    MeshOptions options;
    options.slicing = {Axis::Auto, 2.0};
    options.levels = 4;
    options.everySlice = true;
    const Reconstruction r(v, options);
    EXPECT_EQ(r.plan().axis, 2);
    EXPECT_EQ(r.stats().contours, 57);
    EXPECT_EQ(r.stats().endContours, 4);
    EXPECT_EQ(r.stats().tubes, 1);
    for (int level = 0; level < 4; ++level) {
        const LevelMesh m = r.buildLevel(level);
        const std::size_t n = 8u << level;
        EXPECT_EQ(m.ambiguousContours, 0);
        EXPECT_EQ(m.contours, 61);
        EXPECT_EQ(m.mesh.triangles.size(), 2 * n * 61);
        EXPECT_EQ(m.mesh.vertices.size(), n * 61 + 2);
        expectClosedSphere(m.mesh, 1);
    }
}

TEST(Multires, SkippedSlicesLieWithinTheLevelsSagittaOfTheirNeighbours)
{
    // A level skips a slice only where the straight interpolation of the contours it keeps on
    // either side predicts it within the level's sagitta, r (1 - cos(pi / n)), r the farthest
    // crossing of the larger end loop: at most the section's largest radius. That is 10 on the
    // straight capsule; the helix's tube (radius 6, helix radius 20, pitch 64) meets the slices
    // at sin(a) = 64 / hypot(64, 2 pi 20), in ellipses of semi-major axis 6 / sin(a) = 13.2.
    // Checked against the same level built on every slice, ray by ray, in the plane: these
    // contours are star-shaped, so a contour's k-th vertex is ray k's crossing. The level decides
    // on the loops' polygons (the field interpolated linearly between pixel centres, h = 1) and
    // the vertices are roots of the bilinear field along the rays (h <= sqrt(2)); on these level
    // sets each lies within h^2 / (8 rho) of the surface, rho >= 2.2 the smallest radius of
    // curvature of a section (the capsule's end contours; the helix's ellipses have 36 / 13.2):
    // 3 / 17.6 for a polygon point and a vertex together, twice that for the interpolation of
    // three contours, whose weights sum to 2 in absolute value: a slack of 0.34 voxel.
    // Levels also nest in slices: each level's planes are planes of the next.
    const double helixSection = 6.0 / (64.0 / std::hypot(64.0, 2.0 * 3.14159265358979323846 * 20.0));
    for (const auto& [name, radius] : {std::pair<const char*, double>{"straight", 10.0}, {"helix", helixSection}}) {
        SCOPED_TRACE(name);
        const Volume& v = cachedSample(name);
        MeshOptions everyOptions;
        everyOptions.everySlice = true;
        const Reconstruction thin(v, MeshOptions{}), every(v, everyOptions);
        const int axis = thin.plan().axis;
        std::set<double> previous;
        int skippedSomewhere = 0;
        for (int level = 0; level < 4; ++level) {
            SCOPED_TRACE("level " + std::to_string(level));
            const std::size_t n = 8u << level;
            // Contours by plane: runs of n consecutive vertices in one plane (apexes stand alone).
            auto contoursOf = [&](const TriangleMesh& mesh) {
                std::map<double, std::vector<glm::dvec3>> planes;
                std::size_t i = 0;
                while (i < mesh.vertices.size()) {
                    std::size_t j = i;
                    while (j < mesh.vertices.size() && mesh.vertices[j][axis] == mesh.vertices[i][axis]) ++j;
                    if (j - i > 1) {
                        EXPECT_EQ(j - i, n);
                        EXPECT_EQ(planes.count(mesh.vertices[i][axis]), 0u) << "one tube: one contour per plane";
                        planes[mesh.vertices[i][axis]].assign(mesh.vertices.begin() + i, mesh.vertices.begin() + j);
                    }
                    i = j;
                }
                return planes;
            };
            const LevelMesh thinMesh = thin.buildLevel(level), everyMesh = every.buildLevel(level);
            const auto kept = contoursOf(thinMesh.mesh), all = contoursOf(everyMesh.mesh);
            EXPECT_EQ(thinMesh.contours, static_cast<int>(kept.size()));
            EXPECT_EQ(thinMesh.contours + thinMesh.skippedContours, static_cast<int>(all.size()));
            EXPECT_EQ(thinMesh.mesh.triangles.size(), 2 * n * kept.size());
            expectClosedSphere(thinMesh.mesh, 1);
            std::set<double> planes;
            for (const auto& [w, contour] : kept) {
                ASSERT_EQ(all.count(w), 1u);
                EXPECT_EQ(all.at(w), contour); // the same contour, bit for bit
                planes.insert(w);
            }
            for (double w : previous) EXPECT_EQ(planes.count(w), 1u);
            previous = planes;
            const double sagitta = radius * (1.0 - std::cos(3.14159265358979323846 / static_cast<double>(n)));
            const double slack = 2.0 * 3.0 / (8.0 * 2.2);
            for (const auto& [w, contour] : all) {
                if (planes.count(w)) continue;
                ++skippedSomewhere;
                const auto above = kept.upper_bound(w), below = std::prev(above);
                const double t = (w - below->first) / (above->first - below->first);
                double worst = 0.0;
                for (std::size_t k = 0; k < n; ++k) {
                    glm::dvec3 miss = contour[k] - (below->second[k] + t * (above->second[k] - below->second[k]));
                    miss[axis] = 0.0;
                    worst = std::max(worst, glm::length(miss));
                }
                EXPECT_LE(worst, sagitta + slack) << "plane " << w;
            }
        }
        EXPECT_GT(skippedSomewhere, 0); // the test has something to check
    }
}

TEST(Multires, VerticesLieOnTheIsosurfaceFromLevelTwo)
{
    // Crossings are roots of the interpolated field, and cap apexes too: within 0.25 voxel.
    for (const char* name : {"straight", "helix"}) {
        SCOPED_TRACE(name);
        const Reconstruction r(cachedSample(name), MeshOptions{});
        for (int level = 2; level < 4; ++level) {
            const LevelMesh m = r.buildLevel(level);
            EXPECT_LE(levelSetDistanceAtVertices(cachedSample(name), m.mesh).max, 0.25);
            expectClosedSphere(m.mesh, 1);
        }
    }
}

TEST(Multires, LevelsNestBitForBit)
{
    // Every ray of level L is a ray of level L+1: its crossing, hence its vertex, is identical.
    const Reconstruction r(cachedSample("helix"), MeshOptions{});
    std::set<std::tuple<double, double, double>> previous;
    for (int level = 0; level < 4; ++level) {
        const auto current = vertexSet(r.buildLevel(level).mesh);
        for (const auto& p : previous) EXPECT_EQ(current.count(p), 1u);
        previous = current;
    }
}

TEST(Multires, OutputDoesNotDependOnThreadCount)
{
    MeshOptions one, all;
    one.threads = 1;
    all.threads = 0;
    const LevelMesh a = Reconstruction(cachedSample("helix"), one).buildLevel(3);
    const LevelMesh b = Reconstruction(cachedSample("helix"), all).buildLevel(3);
    EXPECT_EQ(a.mesh.vertices, b.mesh.vertices);
    EXPECT_EQ(a.mesh.triangles, b.mesh.triangles);
}

TEST(Multires, TwoTubesGiveTwoClosedComponents)
{
    const Reconstruction r(cachedSample("two-tubes"), MeshOptions{});
    EXPECT_EQ(r.stats().tubes, 2);
    expectClosedSphere(r.buildLevel(2).mesh, 2);
}

TEST(Multires, BeanIsClosedAndCrossesRaysMoreThanOnce)
{
    // The C-shaped bean is not star-shaped from its centre: some rays cross it three times, yet
    // every contour winds once and every level is a closed sphere.
    const Reconstruction r(cachedSample("bean"), MeshOptions{});
    const LevelMesh top = r.buildLevel(3);
    EXPECT_GT(top.crossings, static_cast<long long>(top.contours) * top.rays);
    expectClosedSphere(top.mesh, 1);
    // Where a ray crosses an arm tip twice in a row, the tip beyond it hides in the sector beside
    // it: the tube adds rays there at every level. The phantom is star-shaped and adds none.
    for (int level = 0; level < 4; ++level) EXPECT_GT(r.buildLevel(level).addedRays, 0);
    EXPECT_EQ(Reconstruction(cachedSample("phantom"), MeshOptions{}).buildLevel(3).addedRays, 0);
}

TEST(Multires, HollowPipeIsOneClosedSurfaceWithAnnularRims)
{
    // An annulus: each slice holds an outer loop and a hole loop; the hole tube's triangles turn
    // to face the hollow. At each end the outer and the hole contour end in the same plane and are
    // joined by an annulus: one closed surface around a tunnel, a torus (Euler characteristic 0),
    // whose enclosed volume is the outer minus the inner one (> 0).
    const Reconstruction r(cachedSample("hollow"), MeshOptions{});
    EXPECT_EQ(r.stats().tubes, 2);
    EXPECT_EQ(r.stats().holes * 2, r.stats().contours);
    EXPECT_EQ(r.stats().annularCaps, 2);
    EXPECT_EQ(r.stats().flatCaps, 0);
    for (int level = 0; level < r.levelCount(); ++level) {
        const Topology topo = checkTopology(r.buildLevel(level).mesh);
        EXPECT_TRUE(topo.closed()) << topo.boundaryEdges << " boundary edges";
        EXPECT_TRUE(topo.manifold());
        EXPECT_TRUE(topo.oriented()) << topo.misorientedEdges << " misoriented edges";
        EXPECT_TRUE(topo.outward()) << "signed volume " << topo.signedVolume;
        EXPECT_EQ(topo.components, 1);
        EXPECT_EQ(topo.euler, 0);
    }
}

TEST(Multires, AbsurdParametersAreUsageErrors)
{
    MeshOptions o;
    o.baseRays = 0;
    EXPECT_THROW(checkMeshOptions(o), UsageError);
    o.baseRays = 8;
    o.levels = 60;
    EXPECT_THROW(checkMeshOptions(o), UsageError);
    o.levels = 14; // 8 * 2^13 = 65536 rays: the largest allowed
    EXPECT_NO_THROW(checkMeshOptions(o));
    o.levels = 15;
    EXPECT_THROW(checkMeshOptions(o), UsageError);
}

TEST(Multires, TubeCutByTheVolumeEdgeIsStillClosed)
{
    // An endless cylinder (radius 8 about (16, 16)) sampled on z in [0, 40): the level set stops at
    // the grid's faces, where the background (outside) closes the object. The mesh must close too.
    const Volume v = samples::levelSetFromDistance(
        [](const glm::dvec3& p) { return std::hypot(p.x - 16.0, p.y - 16.0) - 8.0; }, {32, 32, 40}, 1.0, "cut tube");
    const Reconstruction r(v, MeshOptions{});
    EXPECT_EQ(r.stats().tubes, 1);
    expectClosedSphere(r.buildLevel(3).mesh, 1);
}

TEST(Multires, EmptySlicesBetweenPiecesStartNewTubes)
{
    // Two coaxial capsules with a 10-voxel gap: the slices in the gap hold nothing; each piece is
    // its own closed tube.
    const Volume v = samples::levelSetFromDistance(
        [](const glm::dvec3& p) {
            auto capsule = [&](double z0, double z1) {
                const double z = std::clamp(p.z, z0, z1);
                return std::sqrt((p.x - 16) * (p.x - 16) + (p.y - 16) * (p.y - 16) + (p.z - z) * (p.z - z)) - 6.0;
            };
            return std::min(capsule(10.0, 30.0), capsule(50.0, 70.0));
        },
        {32, 32, 80}, 1.0, "two pieces");
    const Reconstruction r(v, MeshOptions{});
    EXPECT_GT(r.stats().emptySlices, 0);
    EXPECT_EQ(r.stats().tubes, 2);
    expectClosedSphere(r.buildLevel(2).mesh, 2);
}

TEST(Multires, RefinementEqualsBuildingFromScratch)
{
    // Refining casts only the new rays and reuses the coarse crossings; the result must be the
    // level built from scratch, vertex for vertex and triangle for triangle, and nest the level
    // below bit for bit. On analytic phantoms and the real data (the hollow Y and the T branch:
    // needle collapses past the reach, and either end of an edge).
    std::vector<Volume> volumes = {cachedSample("helix"),
                                   cachedSample("bean"),
                                   cachedSample("hollow"),
                                   cachedSample("hollow-y"),
                                   cachedSample("tbranch"),
                                   readVolume(test::realData("vmtk_aorta_ls.vdb")),
                                   readVolume(test::realData("ts_common_carotid_artery_left_ls.vdb")),
                                   readVolume(test::realData("cip_cone_vessel_density.vdb"))};
    for (const Volume& v : volumes) {
        SCOPED_TRACE(v.source());
        const Reconstruction r(v, MeshOptions{});
        Refinement refinement(r);
        EXPECT_EQ(refinement.mesh().mesh.triangles, r.buildLevel(0).mesh.triangles);
        while (refinement.canRefine()) {
            const auto coarse = vertexSet(refinement.mesh().mesh);
            const LevelMesh& fine = refinement.refine();
            const LevelMesh scratch = r.buildLevel(refinement.level());
            EXPECT_EQ(fine.mesh.vertices, scratch.mesh.vertices);
            EXPECT_EQ(fine.mesh.triangles, scratch.mesh.triangles);
            const auto fineSet = vertexSet(fine.mesh);
            for (const auto& p : coarse) EXPECT_EQ(fineSet.count(p), 1u);
        }
        EXPECT_THROW(refinement.refine(), UsageError);
    }
}

TEST(Multires, EachLevelDoublesTheTrianglesAndDoesNotMoveAway)
{
    // Twice the rays: every contour gains as many crossings as it had (or more, where new rays
    // meet folds), so triangles at least double, less the caps' constant share; and the distance
    // to the isosurface does not grow.
    for (const char* name : {"phantom", "helix"}) {
        SCOPED_TRACE(name);
        const Volume& v = cachedSample(name);
        const Reconstruction r(v, MeshOptions{});
        const Validator validator(v);
        Refinement refinement(r);
        Validation previous = validator.validate(refinement.mesh().mesh);
        std::size_t triangles = refinement.mesh().mesh.triangles.size();
        while (refinement.canRefine()) {
            const LevelMesh& next = refinement.refine();
            EXPECT_GE(next.mesh.triangles.size(), 2 * triangles - 4 * static_cast<std::size_t>(r.stats().tubes));
            const Validation v2 = validator.validate(next.mesh);
            EXPECT_LE(v2.symmetric.rms, previous.symmetric.rms);
            EXPECT_LE(v2.symmetric.max, previous.symmetric.max);
            previous = v2;
            triangles = next.mesh.triangles.size();
        }
    }
}
