#include <pipetile/error.h>
#include <pipetile/mesh_io.h>
#include <pipetile/validate.h>

#include "test_util.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>

using namespace pipetile;
using pipetile::test::MeshFile;
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
    for (const auto& [mesh, message] :
         {std::pair{nan, "vertex 4 is not finite"}, std::pair{dangling, "triangle 8 names vertex 6 of 6"}}) {
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
            back.push_back(
                {std::strtod(x.c_str(), nullptr), std::strtod(y.c_str(), nullptr), std::strtod(z.c_str(), nullptr)});
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
    EXPECT_EQ(writeMesh(far, dir.path("far_text.stl"), MeshWriteOptions{false, {}, {}, {}}), 0.0);
}

TEST(MeshIo, ReadingGarbageIsAnError)
{
    TempDir dir;
    std::ofstream(dir.path("junk.ply")) << "this is not a ply file\n";
    EXPECT_THROW(readMesh(dir.path("junk.ply")), Error);
    EXPECT_THROW(readMesh(dir.path("absent.obj")), Error);
}

// ---- Reading as written ----------------------------------------------------------------------

namespace {

using Faces = std::vector<std::vector<long long>>;

const std::vector<glm::dvec3> kOctahedronVertices = {{1, 0, 0},  {-1, 0, 0}, {0, 1, 0},
                                                     {0, -1, 0}, {0, 0, 1},  {0, 0, -1}};
const Faces kOctahedronFaces = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};

// The unit tetrahedron (outward, volume 1/6) and a second one glued to it: at the edge from
// (0,0,0) to (1,0,0) (the first turned half a turn about x), or at the origin alone (the first
// mirrored through the origin, faces reversed to stay outward).
const std::vector<glm::dvec3> kTetrahedraSharingAnEdge = {{0, 0, 0}, {1, 0, 0},  {0, 1, 0},
                                                          {0, 0, 1}, {0, -1, 0}, {0, 0, -1}};
const Faces kTetrahedraSharingAnEdgeFaces = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3},
                                             {0, 4, 1}, {0, 1, 5}, {0, 5, 4}, {1, 4, 5}};
const std::vector<glm::dvec3> kTetrahedraSharingAVertex = {{0, 0, 0},  {1, 0, 0},  {0, 1, 0}, {0, 0, 1},
                                                           {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
const Faces kTetrahedraSharingAVertexFaces = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3},
                                              {0, 4, 5}, {0, 6, 4}, {0, 5, 6}, {4, 6, 5}};

// The message of the Error readMesh throws on a file, or "" when it reads it.
std::string readError(const std::string& path)
{
    try {
        readMesh(path);
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

// Each part in the message, and the message on one line.
::testing::AssertionResult mentions(const std::string& message, const std::vector<std::string>& parts)
{
    if (message.empty()) return ::testing::AssertionFailure() << "no error";
    if (message.find('\n') != std::string::npos) return ::testing::AssertionFailure() << "several lines: " << message;
    for (const std::string& part : parts)
        if (message.find(part) == std::string::npos)
            return ::testing::AssertionFailure() << "no '" << part << "' in: " << message;
    return ::testing::AssertionSuccess();
}

bool isStl(MeshFile kind)
{
    return kind == MeshFile::StlAscii || kind == MeshFile::StlBinary;
}

} // namespace

TEST(MeshIo, EveryFileKindReadsTheOctahedronExactly)
{
    // Coordinates 0 and +-1 are exact in every encoding: 6 vertices, 8 triangles, volume 4/3 exactly
    // (the determinant sum of 8 faces of volume 1/6 each).
    TempDir dir;
    for (MeshFile kind : test::allMeshFiles()) {
        SCOPED_TRACE(test::nameOf(kind));
        const std::string path = dir.path(test::nameOf(kind) + test::extensionOf(kind));
        test::writeMeshFile(path, kind, kOctahedronVertices, kOctahedronFaces);
        const TriangleMesh mesh = readMesh(path);
        EXPECT_EQ(mesh.vertices.size(), 6u);
        EXPECT_EQ(mesh.triangles.size(), 8u);
        const Topology t = checkTopology(mesh);
        EXPECT_TRUE(t.closed() && t.manifold() && t.oriented());
        EXPECT_EQ(t.signedVolume, 4.0 / 3.0);
        if (!isStl(kind)) {
            EXPECT_EQ(mesh.vertices, kOctahedronVertices); // file order kept
        }
    }
}

TEST(MeshIo, CoordinatesAreReadAsDoubles)
{
    // 10^6 + 10^-3 is 1000000.00099999993 as a double and 1000000 as a float: every file but a
    // binary STL (float32 by definition) gives back the double it holds.
    TempDir dir;
    const double x = 1e6 + 1e-3;
    std::vector<glm::dvec3> vertices = kOctahedronVertices;
    vertices[0].x = x;
    for (MeshFile kind : test::allMeshFiles()) {
        SCOPED_TRACE(test::nameOf(kind));
        const std::string path = dir.path(test::nameOf(kind) + test::extensionOf(kind));
        test::writeMeshFile(path, kind, vertices, kOctahedronFaces);
        const TriangleMesh mesh = readMesh(path);
        ASSERT_FALSE(mesh.vertices.empty());
        EXPECT_EQ(mesh.vertices[0].x, kind == MeshFile::StlBinary ? static_cast<double>(static_cast<float>(x)) : x);
    }
}

TEST(MeshIo, TwoTetrahedraSharingAnEdgeStayNonManifoldInEveryFormat)
{
    // The edge (0,0,0)-(1,0,0) has four triangles: one non-manifold edge, no boundary; V 6, E 11,
    // F 8, Euler 3, volume 2/6. A reader that split the shared vertices would report two
    // manifold tetrahedra (V 8, Euler 4).
    TempDir dir;
    for (MeshFile kind : test::allMeshFiles()) {
        SCOPED_TRACE(test::nameOf(kind));
        const std::string path = dir.path(test::nameOf(kind) + test::extensionOf(kind));
        test::writeMeshFile(path, kind, kTetrahedraSharingAnEdge, kTetrahedraSharingAnEdgeFaces);
        const TriangleMesh mesh = readMesh(path);
        const Topology t = checkTopology(mesh);
        EXPECT_EQ(t.vertices, 6);
        EXPECT_EQ(t.edges, 11);
        EXPECT_EQ(t.nonManifoldEdges, 1);
        EXPECT_EQ(t.nonManifoldVertices, 0);
        EXPECT_EQ(t.boundaryEdges, 0);
        EXPECT_EQ(t.euler, 3);
        EXPECT_FALSE(t.manifold());
        EXPECT_NEAR(t.signedVolume, 2.0 / 6.0, 1e-15);
        const glm::dvec3 a = mesh.vertices[static_cast<std::size_t>(t.firstNonManifoldEdge[0])];
        const glm::dvec3 b = mesh.vertices[static_cast<std::size_t>(t.firstNonManifoldEdge[1])];
        EXPECT_EQ(std::min(a.x, b.x) + std::max(a.x, b.x), 1.0); // the shared edge, (0,0,0)-(1,0,0)
        EXPECT_EQ(a.y + a.z + b.y + b.z, 0.0);
    }
}

TEST(MeshIo, TwoTetrahedraSharingAVertexStayNonManifoldInEveryFormat)
{
    // The origin joins two fans of three triangles: one non-manifold vertex, every edge in two
    // triangles; V 7, E 12, F 8, Euler 3, two components.
    TempDir dir;
    for (MeshFile kind : test::allMeshFiles()) {
        SCOPED_TRACE(test::nameOf(kind));
        const std::string path = dir.path(test::nameOf(kind) + test::extensionOf(kind));
        test::writeMeshFile(path, kind, kTetrahedraSharingAVertex, kTetrahedraSharingAVertexFaces);
        const TriangleMesh mesh = readMesh(path);
        const Topology t = checkTopology(mesh);
        EXPECT_EQ(t.vertices, 7);
        EXPECT_EQ(t.nonManifoldVertices, 1);
        EXPECT_EQ(t.nonManifoldEdges, 0);
        EXPECT_EQ(t.boundaryEdges, 0);
        EXPECT_EQ(t.misorientedEdges, 0);
        EXPECT_EQ(t.components, 2);
        EXPECT_EQ(t.euler, 3);
        EXPECT_EQ(mesh.vertices[static_cast<std::size_t>(t.firstNonManifoldVertex)], glm::dvec3(0.0));
    }
}

TEST(MeshIo, NonFiniteCoordinatesAreRefusedByVertex)
{
    // Vertex 3 (OBJ numbers it 4; STL has no vertex numbers, and its facet 2 is the first to use
    // it) set to NaN, +inf, -inf, and in text 1e400, which overflows a double to +inf.
    TempDir dir;
    const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
    for (const double bad : {nan, inf, -inf}) {
        std::vector<glm::dvec3> vertices = kOctahedronVertices;
        vertices[3].y = bad;
        const std::string spelled = std::isnan(bad) ? "nan" : bad > 0 ? "inf" : "-inf";
        for (MeshFile kind : test::allMeshFiles()) {
            SCOPED_TRACE(test::nameOf(kind) + " " + spelled);
            const std::string path = dir.path(test::nameOf(kind) + test::extensionOf(kind));
            test::writeMeshFile(path, kind, vertices, kOctahedronFaces);
            const std::string where = isStl(kind)             ? "facet 2"
                                      : kind == MeshFile::Obj ? "vertex 4 (line 4)"
                                                              : "vertex 3";
            EXPECT_TRUE(mentions(readError(path), {"'" + path + "'", where, spelled, "not a finite number"}));
        }
    }
    test::writeTextFile(dir.path("huge.obj"), "v 0 0 0\nv 1e400 0 0\nv 0 1 0\nf 1 2 3\n");
    EXPECT_TRUE(mentions(readError(dir.path("huge.obj")), {"vertex 2 (line 2)", "(inf, 0, 0)"}));
}

TEST(MeshIo, AllNanVerticesAreRefusedAtTheFirst)
{
    TempDir dir;
    const std::vector<glm::dvec3> vertices(6, glm::dvec3(std::numeric_limits<double>::quiet_NaN()));
    for (MeshFile kind : test::allMeshFiles()) {
        SCOPED_TRACE(test::nameOf(kind));
        const std::string path = dir.path(test::nameOf(kind) + test::extensionOf(kind));
        test::writeMeshFile(path, kind, vertices, kOctahedronFaces);
        const std::string where = isStl(kind) ? "facet 0" : kind == MeshFile::Obj ? "vertex 1 (line 1)" : "vertex 0";
        EXPECT_TRUE(mentions(readError(path), {where, "(nan, nan, nan)"}));
    }
}

TEST(MeshIo, IndicesOutOfRangeOrNegativeAreRefusedByFace)
{
    // Face 5 of the octahedron given index 6 (one past the last of 6) or -1. OBJ writes i + 1, so
    // 7 (past 1..6) and 0 (OBJ counts from 1). STL stores coordinates, not indices.
    TempDir dir;
    for (const long long bad : {6LL, -1LL}) {
        Faces faces = kOctahedronFaces;
        faces[5][1] = bad;
        for (MeshFile kind : test::allMeshFiles()) {
            if (isStl(kind)) continue;
            SCOPED_TRACE(test::nameOf(kind) + " " + std::to_string(bad));
            const std::string path = dir.path(test::nameOf(kind) + test::extensionOf(kind));
            test::writeMeshFile(path, kind, kOctahedronVertices, faces);
            const std::string message = readError(path);
            if (kind == MeshFile::Obj && bad < 0)
                EXPECT_TRUE(mentions(message, {"face 6 (line 12)", "vertex 0", "from 1"}));
            else if (kind == MeshFile::Obj)
                EXPECT_TRUE(mentions(message, {"face 6 (line 12)", "refers to vertex 7", "numbered 1 to 6"}));
            else
                EXPECT_TRUE(mentions(message, {"'" + path + "'", "face 5", "refers to vertex " + std::to_string(bad),
                                               "numbered 0 to 5"}));
        }
    }
}

TEST(MeshIo, ObjNegativeIndicesCountBackFromTheFace)
{
    // "f -3 -2 -1" after three vertices is "f 1 2 3"; texture and normal indices are ignored; a
    // face may name vertices that come after it; -5 with 4 vertices before it names none.
    TempDir dir;
    test::writeTextFile(dir.path("rel.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3/1/1 -2//2 -1/3\nf 1 3 4\nv 0 0 1\n");
    const TriangleMesh mesh = readMesh(dir.path("rel.obj"));
    ASSERT_EQ(mesh.triangles.size(), 2u);
    EXPECT_EQ(mesh.triangles[0], (Triangle{0, 1, 2}));
    EXPECT_EQ(mesh.triangles[1], (Triangle{0, 2, 3}));
    test::writeTextFile(dir.path("bad.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 -5\n");
    EXPECT_TRUE(
        mentions(readError(dir.path("bad.obj")), {"face 1 (line 5)", "vertex -5", "only 4 vertices precede it"}));
}

TEST(MeshIo, FacesOfFewerThanThreeVerticesAreRefused)
{
    TempDir dir;
    for (MeshFile kind : test::allMeshFiles()) {
        if (isStl(kind)) continue;
        SCOPED_TRACE(test::nameOf(kind));
        const std::string path = dir.path(test::nameOf(kind) + test::extensionOf(kind));
        Faces faces = kOctahedronFaces;
        faces[2] = {1, 3};
        test::writeMeshFile(path, kind, kOctahedronVertices, faces);
        EXPECT_TRUE(
            mentions(readError(path), {kind == MeshFile::Obj ? "face 3" : "face 2", "2 vertices", "at least 3"}));
    }
}

TEST(MeshIo, PolygonsBecomeFans)
{
    // A square and a pentagon: 2 + 3 triangles, fanned from each face's first vertex.
    TempDir dir;
    test::writeTextFile(dir.path("p.off"), "OFF\n# a comment\n6 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n-1 1 0\n-1 0 0\n"
                                           "4 0 1 2 3\n5 0 3 4 5 1  255 0 0\n");
    const TriangleMesh mesh = readMesh(dir.path("p.off"));
    const std::vector<Triangle> expected = {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}, {0, 4, 5}, {0, 5, 1}};
    EXPECT_EQ(mesh.triangles, expected);
}

TEST(MeshIo, TruncatedFilesAreRefused)
{
    TempDir dir;
    for (MeshFile kind :
         {MeshFile::PlyBinary, MeshFile::PlyAscii, MeshFile::Off, MeshFile::StlBinary, MeshFile::StlAscii}) {
        SCOPED_TRACE(test::nameOf(kind));
        const std::string path = dir.path(test::nameOf(kind) + test::extensionOf(kind));
        test::writeMeshFile(path, kind, kOctahedronVertices, kOctahedronFaces);
        // Into the last face (in an ASCII STL, past "endloop endfacet endsolid" into its last corner).
        std::filesystem::resize_file(path, std::filesystem::file_size(path) - (kind == MeshFile::StlAscii ? 40 : 9));
        EXPECT_TRUE(mentions(readError(path), {"'" + path + "'", "truncated"}));
    }
}

TEST(MeshIo, StlCornersWeldOnlyWhenExactlyEqual)
{
    // A unit square as two triangles sharing the diagonal (0,0,0)-(1,1,0): 4 vertices, 4 boundary
    // edges; -0 is 0. With one copy of (1,1,0) moved by one float step there are 5 vertices and
    // all 6 edges are boundary edges: a crack stays a crack.
    TempDir dir;
    const std::vector<glm::dvec3> vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {-0.0, 1, 0}, {-0.0, -0.0, 0}};
    test::writeMeshFile(dir.path("square.stl"), MeshFile::StlBinary, vertices, {{0, 1, 2}, {4, 2, 3}});
    Topology t = checkTopology(readMesh(dir.path("square.stl")));
    EXPECT_EQ(t.vertices, 4);
    EXPECT_EQ(t.boundaryEdges, 4);
    std::vector<glm::dvec3> cracked = vertices;
    cracked.push_back({std::nextafter(1.0f, 2.0f), 1, 0});
    test::writeMeshFile(dir.path("cracked.stl"), MeshFile::StlBinary, cracked, {{0, 1, 2}, {4, 5, 3}});
    t = checkTopology(readMesh(dir.path("cracked.stl")));
    EXPECT_EQ(t.vertices, 5);
    EXPECT_EQ(t.boundaryEdges, 6);
}

TEST(MeshIo, PlySkipsThePropertiesAndElementsItDoesNotUse)
{
    // Normals and colours around x, y, z; a face flag before the index list; an element before
    // and one after the faces; comments. One triangle with the corners given.
    TempDir dir;
    test::writeTextFile(dir.path("extra.ply"),
                        "ply\nformat ascii 1.0\ncomment made by hand\nelement camera 1\nproperty float view\n"
                        "element vertex 3\nproperty float nx\nproperty double x\nproperty uchar red\n"
                        "property double y\nproperty list uchar float uv\nproperty double z\n"
                        "element face 1\nproperty uchar flags\nproperty list uchar uint vertex_indices\n"
                        "element edge 1\nproperty list uchar int vertex\nend_header\n"
                        "0.5\n0 1 255 2 2 0.5 0.5 3\n0 4 0 5 0 6\n0 7 9 8 1 0 9\n7 3 2 1 0\n2 0 1\n");
    const TriangleMesh mesh = readMesh(dir.path("extra.ply"));
    EXPECT_EQ(mesh.vertices, (std::vector<glm::dvec3>{{1, 2, 3}, {4, 5, 6}, {7, 8, 9}}));
    EXPECT_EQ(mesh.triangles, (std::vector<Triangle>{{2, 1, 0}}));
}

TEST(MeshIo, MalformedFilesNameTheirFirstBadToken)
{
    TempDir dir;
    const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
        {"v 0 0 0\nv 1 zero 0\n", {"vertex 2 (line 2)", "'zero' is not a number"}},
        {"v 0 0 0\nv 1 0\n", {"vertex 2 (line 2)", "fewer than 3 coordinates"}},
        {"v 0 0 0\nf 1 x 1\n", {"face 1 (line 2)", "'x' is not a vertex index"}},
    };
    for (const auto& [text, parts] : cases) {
        test::writeTextFile(dir.path("m.obj"), text);
        EXPECT_TRUE(mentions(readError(dir.path("m.obj")), parts)) << text;
    }
    test::writeTextFile(dir.path("b.off"), "OFF BINARY\n");
    EXPECT_TRUE(mentions(readError(dir.path("b.off")), {"binary OFF is not supported"}));
    test::writeTextFile(dir.path("h.ply"),
                        "ply\nformat ascii 1.0\nelement vertex 1\nproperty double x\nend_header\n0\n");
    EXPECT_TRUE(mentions(readError(dir.path("h.ply")), {"no property 'y'"}));
    test::writeTextFile(dir.path("c.ply"),
                        "ply\nformat ascii 1.0\nelement vertex 1\n\x1b[2Jproperty double x\nend_header\n");
    EXPECT_TRUE(mentions(readError(dir.path("c.ply")), {"line 4"})); // the escape is not passed on
    EXPECT_EQ(readError(dir.path("c.ply")).find('\x1b'), std::string::npos);
}

TEST(MeshIo, NormalsAndQualityReadBackAsTheSameMesh)
{
    // An octahedron's vertices are unit vectors from its centre: their own outward normals. Every
    // format and encoding with normals (and a PLY quality) reads back as the same vertices and
    // faces, and the files name the normals as their readers expect.
    const TriangleMesh mesh = octahedron();
    MeshWriteOptions options;
    options.normals = mesh.vertices;
    options.quality = {0.0, 0.5, 1.0, 1.5, 2.0, 2.5};
    test::TempDir dir;
    for (const bool binary : {true, false})
        for (const char* ext : {".ply", ".obj", ".stl", ".off"}) {
            const std::string path = dir.path(std::string(binary ? "binary" : "text") + ext);
            SCOPED_TRACE(path);
            options.binary = binary;
            writeMesh(mesh, path, options);
            const TriangleMesh back = readMesh(path);
            // STL numbers its distinct corners in the order the triangles meet them.
            if (std::string(ext) != ".stl") {
                EXPECT_EQ(back.vertices, mesh.vertices);
                EXPECT_EQ(back.triangles, mesh.triangles);
            }
            EXPECT_EQ(back.triangles.size(), mesh.triangles.size());
            std::ifstream in(path, std::ios::binary);
            const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
            if (std::string(ext) == ".ply") {
                EXPECT_NE(bytes.find("property float nx\nproperty float ny\nproperty float nz\n"), std::string::npos);
                EXPECT_NE(bytes.find("property float quality\n"), std::string::npos);
            }
            if (std::string(ext) == ".obj") {
                EXPECT_NE(bytes.find("\nvn 0 0 1\n"), std::string::npos);
                EXPECT_NE(bytes.find("\nf 1//1 "), std::string::npos);
            }
        }
}
