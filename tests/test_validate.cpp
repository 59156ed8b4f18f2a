#include <pipetile/validate.h>

#include <gtest/gtest.h>

using namespace pipetile;

namespace {

// The unit tetrahedron, outward: volume 1/6.
TriangleMesh tetrahedron(glm::dvec3 offset = glm::dvec3(0.0))
{
    TriangleMesh m;
    m.vertices = {offset + glm::dvec3(0, 0, 0), offset + glm::dvec3(1, 0, 0), offset + glm::dvec3(0, 1, 0),
                  offset + glm::dvec3(0, 0, 1)};
    m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    return m;
}

TriangleMesh merged(const TriangleMesh& a, const TriangleMesh& b, std::vector<std::pair<std::uint32_t, std::uint32_t>> glue = {})
{
    TriangleMesh m = a;
    const std::uint32_t base = static_cast<std::uint32_t>(a.vertices.size());
    m.vertices.insert(m.vertices.end(), b.vertices.begin(), b.vertices.end());
    for (Triangle t : b.triangles) {
        for (std::uint32_t& v : t) {
            v += base;
            for (auto [from, to] : glue)
                if (v == from + base) v = to;
        }
        m.triangles.push_back(t);
    }
    return m;
}

} // namespace

TEST(Validate, TetrahedronIsAClosedOrientedSphere)
{
    const Topology t = checkTopology(tetrahedron());
    EXPECT_EQ(t.vertices, 4);
    EXPECT_EQ(t.edges, 6);
    EXPECT_EQ(t.euler, 2); // 4 - 6 + 4
    EXPECT_TRUE(t.closed() && t.manifold() && t.oriented() && t.outward());
    EXPECT_NEAR(t.signedVolume, 1.0 / 6.0, 1e-15);
    EXPECT_EQ(t.components, 1);
}

TEST(Validate, MissingFaceLeavesThreeBoundaryEdges)
{
    TriangleMesh m = tetrahedron();
    m.triangles.pop_back();
    const Topology t = checkTopology(m);
    EXPECT_FALSE(t.closed());
    EXPECT_EQ(t.boundaryEdges, 3);
}

TEST(Validate, FlippedFaceMisorientsItsThreeEdges)
{
    TriangleMesh m = tetrahedron();
    std::swap(m.triangles[3][1], m.triangles[3][2]);
    const Topology t = checkTopology(m);
    EXPECT_TRUE(t.closed());
    EXPECT_EQ(t.misorientedEdges, 3);
}

TEST(Validate, InsideOutMeshHasNegativeVolume)
{
    TriangleMesh m = tetrahedron();
    for (Triangle& tri : m.triangles) std::swap(tri[1], tri[2]);
    const Topology t = checkTopology(m);
    EXPECT_TRUE(t.oriented());
    EXPECT_FALSE(t.outward());
    EXPECT_NEAR(t.signedVolume, -1.0 / 6.0, 1e-15);
}

TEST(Validate, TwoTetrahedraGluedAtAnEdgeAreNotManifold)
{
    // The second copy's vertices 0 and 1 are the first's: edge (0, 1) has four triangles.
    const TriangleMesh m = merged(tetrahedron(), tetrahedron(glm::dvec3(0, 0, 0)), {{0, 0}, {1, 1}});
    const Topology t = checkTopology(m);
    EXPECT_EQ(t.nonManifoldEdges, 1);
    EXPECT_FALSE(t.manifold());
}

TEST(Validate, TwoTetrahedraSharingAVertexAreNotManifold)
{
    const TriangleMesh m = merged(tetrahedron(), tetrahedron(glm::dvec3(-1, -1, -1)), {{3, 0}});
    const Topology t = checkTopology(m);
    EXPECT_EQ(t.nonManifoldEdges, 0);
    EXPECT_EQ(t.nonManifoldVertices, 1);
    EXPECT_EQ(t.components, 2);
}
