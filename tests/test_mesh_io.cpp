#include <pipetile/error.h>
#include <pipetile/mesh_io.h>
#include <pipetile/validate.h>

#include "test_util.h"

#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>

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

TEST(MeshIo, BrokenMeshIsRefusedAndTheOldFileKept)
{
    // A NaN vertex or a triangle naming a missing vertex would make a file readers reject or
    // misread: refused, and the file that was there stays as it was.
    TempDir dir;
    writeMesh(octahedron(), dir.path("keep.ply"));
    TriangleMesh nan = octahedron(), dangling = octahedron();
    nan.vertices[4].z = std::numeric_limits<double>::quiet_NaN();
    dangling.triangles.push_back({0, 2, 6}); // 6 vertices: ids 0-5
    for (const auto& [mesh, message] : {std::pair{nan, "vertex 4 is not finite"}, std::pair{dangling, "triangle 8 names vertex 6 of 6"}}) {
        try {
            writeMesh(mesh, dir.path("keep.ply"));
            ADD_FAILURE() << message << ": no error";
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
        }
        EXPECT_EQ(readMesh(dir.path("keep.ply")).triangles.size(), 8u);
        EXPECT_EQ(dir.files(), (std::vector<std::string>{"keep.ply"}));
    }
}

TEST(MeshIo, NonManifoldMeshesAreWrittenAsGiven)
{
    // Two tetrahedra sharing an edge (vertices 0 and 1): 5 vertices, 8 triangles, an edge in four
    // triangles. The file holds the arrays as they are, so validate can judge them.
    TempDir dir;
    TriangleMesh m;
    m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, -1, 0}};
    m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}, {0, 1, 4}, {0, 3, 1}, {0, 4, 3}, {1, 4, 3}};
    writeMesh(m, dir.path("two.off"));
    std::ifstream in(dir.path("two.off"));
    std::string magic;
    std::size_t vertices = 0, faces = 0;
    in >> magic >> vertices >> faces;
    EXPECT_EQ(magic, "OFF");
    EXPECT_EQ(vertices, 5u);
    EXPECT_EQ(faces, 8u);
}

TEST(MeshIo, PositionsFarFromTheOriginKeepTheirDoublePrecision)
{
    // At x = 10^6 float32 steps by 1/16; the octahedron scaled to 0.01 sits between its steps.
    // Binary PLY stores doubles, text formats the shortest decimal of each double: both read
    // back bit for bit (the text ones parsed here with strtod, as a reader of doubles would).
    TempDir dir;
    TriangleMesh far = octahedron();
    for (glm::dvec3& v : far.vertices) v = glm::dvec3(1e6, -2e6, 3e6) + 0.01 * v + glm::dvec3(0.003, 0.0, 0.0);
    EXPECT_EQ(writeMesh(far, dir.path("far.ply")), 0.0);
    EXPECT_EQ(test::plyDoubleVertices(dir.path("far.ply")), far.vertices);
    for (const std::string ext : {"obj", "off"}) {
        SCOPED_TRACE(ext);
        EXPECT_EQ(writeMesh(far, dir.path("far." + ext)), 0.0);
        std::ifstream in(dir.path("far." + ext));
        std::string line;
        if (ext == "off") std::getline(in, line), std::getline(in, line); // "OFF", then the counts
        std::vector<glm::dvec3> back;
        while (back.size() < far.vertices.size() && std::getline(in, line)) {
            std::istringstream words(line);
            std::string tag, x, y, z;
            if (ext == "obj" && !(words >> tag && tag == "v")) continue;
            words >> x >> y >> z;
            back.push_back({std::strtod(x.c_str(), nullptr), std::strtod(y.c_str(), nullptr), std::strtod(z.c_str(), nullptr)});
        }
        EXPECT_EQ(back, far.vertices);
    }
}

TEST(MeshIo, BinaryStlSaysHowMuchFloat32Rounded)
{
    // STL holds float32 only. Near the origin the octahedron's 0 and +-1 are exact: 0. At
    // x = 10^6 + 0.02 float32's nearest value is 10^6 (its step there is 1/16): 0.02 off.
    TempDir dir;
    EXPECT_EQ(writeMesh(octahedron(), dir.path("near.stl")), 0.0);
    TriangleMesh far = octahedron();
    for (glm::dvec3& v : far.vertices) v.x = 1e6 + 0.02;
    EXPECT_NEAR(writeMesh(far, dir.path("far.stl")), 0.02, 1e-9);
    // Text STL writes doubles.
    EXPECT_EQ(writeMesh(far, dir.path("far_text.stl"), MeshWriteOptions{false, {}}), 0.0);
}

TEST(MeshIo, ReadingGarbageIsAnError)
{
    TempDir dir;
    std::ofstream(dir.path("junk.ply")) << "this is not a ply file\n";
    EXPECT_THROW(readMesh(dir.path("junk.ply")), Error);
    EXPECT_THROW(readMesh(dir.path("absent.obj")), Error);
}
