// pipetile — libFuzzer harness: arbitrary bytes read as a mesh file in each of the four formats
// (.ply .obj .stl .off), then judged as validate judges it (topology and triangle quality).
//
// The bytes go to detail::parseMesh, which is what readMesh runs on a file's contents, so no file
// is written. pipetile::Error is the documented answer to a bad file; any other exception escapes
// to libFuzzer, which reports it like a crash. A mesh that is read must keep readMesh's promises
// (every coordinate finite, every index a vertex), and its topology must add up; a broken promise
// traps, so libFuzzer keeps the input. Run with -rss_limit_mb=2048 (see .ci/fuzz.sh): running out
// of memory on a small file is a finding too.

#include <pipetile/detail/mesh_read.h>
#include <pipetile/error.h>
#include <pipetile/validate.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string_view>

using namespace pipetile;

namespace {

[[noreturn]] void fail(const char* what, int line)
{
    std::fprintf(stderr, "fuzz_mesh: invariant broken at line %d: %s\n", line, what);
    __builtin_trap();
}

#define FUZZ_CHECK(condition)                                                                                          \
    do {                                                                                                               \
        if (!(condition)) fail(#condition, __LINE__);                                                                  \
    } while (false)

void checkMesh(const TriangleMesh& mesh)
{
    for (const glm::dvec3& p : mesh.vertices)
        FUZZ_CHECK(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z));
    for (const Triangle& t : mesh.triangles)
        for (std::uint32_t v : t) FUZZ_CHECK(v < mesh.vertices.size());
    const Topology topology = checkTopology(mesh);
    FUZZ_CHECK(topology.triangles == static_cast<long long>(mesh.triangles.size()));
    FUZZ_CHECK(topology.vertices <= static_cast<long long>(mesh.vertices.size()));
    FUZZ_CHECK(topology.euler == topology.vertices - topology.edges + topology.triangles);
    FUZZ_CHECK(topology.boundaryEdges + topology.nonManifoldEdges + topology.misorientedEdges <= topology.edges);
    FUZZ_CHECK((topology.nonManifoldEdges > 0) == (topology.firstNonManifoldEdge[0] >= 0));
    FUZZ_CHECK((topology.nonManifoldVertices > 0) == (topology.firstNonManifoldVertex >= 0));
    FUZZ_CHECK(topology.firstNonManifoldVertex < static_cast<long long>(mesh.vertices.size()));
    const TriangleQuality quality = measureQuality(mesh);
    FUZZ_CHECK(quality.degenerate <= static_cast<long long>(mesh.triangles.size()));
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    for (const detail::MeshFormat format :
         {detail::MeshFormat::Ply, detail::MeshFormat::Obj, detail::MeshFormat::Stl, detail::MeshFormat::Off}) {
        try {
            checkMesh(detail::parseMesh(bytes, format, "fuzz"));
        } catch (const Error&) {
            // A bad file, reported as such.
        }
    }
    return 0;
}
