#include <pipetile/error.h>
#include <pipetile/mesh_io.h>
#include <pipetile/validate.h>

#include "test_util.h"

#include <fstream>

using namespace pipetile;
using pipetile::test::TempDir;

namespace {

TriangleMesh octahedron()
{
    TriangleMesh m;
    m.vertices = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    m.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
    return m;
}

} // namespace

TEST(MeshIo, EveryFormatRoundTripsAClosedOctahedron)
{
    // 6 vertices, 8 triangles, volume 4/3; STL stores triangle soups, and the reader welds them.
    TempDir dir;
    for (const char* name : {"o.ply", "o.obj", "o.stl", "o.off", "O.PLY"}) {
        SCOPED_TRACE(name);
        writeMesh(octahedron(), dir.path(name));
        const TriangleMesh back = readMesh(dir.path(name));
        EXPECT_EQ(back.vertices.size(), 6u);
        EXPECT_EQ(back.triangles.size(), 8u);
        const Topology t = checkTopology(back);
        EXPECT_TRUE(t.closed() && t.oriented());
        EXPECT_NEAR(t.signedVolume, 4.0 / 3.0, 1e-6);
    }
    EXPECT_EQ(dir.files().size(), 5u); // no temporary file left behind
}

TEST(MeshIo, UnknownExtensionWritesNothing)
{
    TempDir dir;
    EXPECT_THROW(writeMesh(octahedron(), dir.path("mesh.xyz")), Error);
    EXPECT_TRUE(dir.files().empty());
}

TEST(MeshIo, MissingFolderIsNamed)
{
    TempDir dir;
    try {
        writeMesh(octahedron(), dir.path("no/such/mesh.ply"));
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
    }
    EXPECT_TRUE(dir.files().empty());
}

TEST(MeshIo, NonManifoldMeshIsRefusedAndTheOldFileKept)
{
    // A failed write must not damage the file that was there.
    TempDir dir;
    writeMesh(octahedron(), dir.path("keep.ply"));
    TriangleMesh bad = octahedron();
    bad.triangles.push_back({0, 2, 1}); // edge (0, 2) in three triangles
    bad.triangles.push_back({0, 2, 3});
    EXPECT_THROW(writeMesh(bad, dir.path("keep.ply")), Error);
    EXPECT_EQ(readMesh(dir.path("keep.ply")).triangles.size(), 8u);
    EXPECT_EQ(dir.files().size(), 1u);
}

TEST(MeshIo, ReadingGarbageIsAnError)
{
    TempDir dir;
    std::ofstream(dir.path("junk.ply")) << "this is not a ply file\n";
    EXPECT_THROW(readMesh(dir.path("junk.ply")), Error);
    EXPECT_THROW(readMesh(dir.path("absent.obj")), Error);
}
