#include <pipetile/error.h>
#include <pipetile/gltf.h>
#include <pipetile/multires.h>

#include "test_util.h"

#include <glm/geometric.hpp>
#include <tiny_gltf.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>

using namespace pipetile;
using pipetile::test::cachedSample;
using pipetile::test::TempDir;

namespace {

std::vector<LevelMesh> allLevels(const std::string& sample)
{
    const Reconstruction r(cachedSample(sample), MeshOptions{});
    Refinement refinement(r);
    std::vector<LevelMesh> levels{refinement.mesh()};
    while (refinement.canRefine()) levels.push_back(refinement.refine());
    return levels;
}

tinygltf::Model readGlb(const std::string& path)
{
    tinygltf::TinyGLTF loader;
    tinygltf::Model model;
    std::string error, warning;
    EXPECT_TRUE(loader.LoadBinaryFromFile(&model, &error, &warning, path)) << error;
    EXPECT_EQ(error, "");
    return model;
}

// The floats of an accessor (non-interleaved, as pipetile writes them), component by component.
std::vector<float> floatsOf(const tinygltf::Model& model, int accessor)
{
    const tinygltf::Accessor& a = model.accessors[accessor];
    EXPECT_EQ(a.componentType, TINYGLTF_COMPONENT_TYPE_FLOAT);
    const tinygltf::BufferView& view = model.bufferViews[a.bufferView];
    std::vector<float> out(a.count * tinygltf::GetNumComponentsInType(a.type));
    std::memcpy(out.data(), model.buffers[view.buffer].data.data() + view.byteOffset + a.byteOffset,
                out.size() * sizeof(float));
    return out;
}

std::vector<std::uint32_t> indicesOf(const tinygltf::Model& model, int accessor)
{
    const tinygltf::Accessor& a = model.accessors[accessor];
    EXPECT_EQ(a.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
    const tinygltf::BufferView& view = model.bufferViews[a.bufferView];
    std::vector<std::uint32_t> out(a.count);
    std::memcpy(out.data(), model.buffers[view.buffer].data.data() + view.byteOffset + a.byteOffset,
                out.size() * sizeof(std::uint32_t));
    return out;
}

double extentOf(const std::vector<glm::dvec3>& points)
{
    glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi = -lo;
    for (const glm::dvec3& p : points) lo = glm::min(lo, p), hi = glm::max(hi, p);
    return glm::length(hi - lo);
}

} // namespace

TEST(Gltf, ScreenCoverageHalvesPerLevelFromTheFinest)
{
    EXPECT_EQ(screenCoverage(4), (std::vector<double>{0.5, 0.25, 0.125, 0.0625}));
    EXPECT_EQ(screenCoverage(1), (std::vector<double>{0.5}));
}

TEST(Gltf, EveryLevelIsAPrefixOfOneVertexArray)
{
    // Far from the origin, as real scanner coordinates are: float32 positions are stored around the
    // box centre, so they round at the scale of the object (not of 10^7).
    for (const glm::dvec3 offset : {glm::dvec3(0.0), glm::dvec3(1e7, -3e6, 5e5)}) {
        SCOPED_TRACE("offset " + std::to_string(offset.x));
        std::vector<LevelMesh> levels = allLevels("helix");
        ASSERT_EQ(levels.size(), 4u);
        for (LevelMesh& level : levels)
            for (glm::dvec3& v : level.mesh.vertices) v += offset; // equal coordinates stay equal: levels still nest
        const NestedLevels nested = nestLevels(levels);
        const std::size_t n = nested.vertices.size();
        GlbOptions options;
        options.metresPerUnit = 0.001;
        for (std::size_t i = 0; i < n; ++i) {
            options.normals.push_back(glm::normalize(glm::dvec3(std::cos(0.1 * i), std::sin(0.1 * i), 0.5)));
            options.vertexError.push_back(0.25 * static_cast<double>(i % 7));
        }
        TempDir dir;
        const std::string path = dir.path("levels.glb");
        writeGlb(nested, path, options);
        const tinygltf::Model model = readGlb(path);

        // MSFT_lod on the finest node, used and not required; the scene shows the finest node.
        EXPECT_EQ(model.extensionsUsed, std::vector<std::string>{"MSFT_lod"});
        EXPECT_TRUE(model.extensionsRequired.empty());
        ASSERT_EQ(model.meshes.size(), 4u);
        ASSERT_EQ(model.nodes.size(), 4u);
        ASSERT_EQ(model.scenes.size(), 1u);
        EXPECT_EQ(model.scenes[0].nodes, std::vector<int>{3});
        const tinygltf::Node& finest = model.nodes[3];
        ASSERT_TRUE(finest.extensions.count("MSFT_lod"));
        const tinygltf::Value& ids = finest.extensions.at("MSFT_lod").Get("ids");
        ASSERT_EQ(ids.ArrayLen(), 3u);
        for (int k = 0; k < 3; ++k) EXPECT_EQ(ids.Get(k).GetNumberAsInt(), 2 - k); // coarser nodes, finest first
        const tinygltf::Value& coverage = finest.extras.Get("MSFT_screencoverage");
        ASSERT_EQ(coverage.ArrayLen(), 4u);
        for (int k = 0; k < 4; ++k) EXPECT_EQ(coverage.Get(k).GetNumberAsDouble(), screenCoverage(4)[k]);

        // float32 keeps 24 bits: a coordinate within half the extent of the centre rounds by at
        // most 2^-24 of it; in metres, as glTF wants.
        const double tolerance = std::ldexp(extentOf(nested.vertices), -24) * options.metresPerUnit;
        int positionView = -1;
        for (std::size_t L = 0; L < levels.size(); ++L) {
            SCOPED_TRACE("level " + std::to_string(L));
            const TriangleMesh& mesh = levels[L].mesh;
            const tinygltf::Primitive& primitive = model.meshes[L].primitives.at(0);
            EXPECT_EQ(primitive.mode, TINYGLTF_MODE_TRIANGLES);
            EXPECT_EQ(model.nodes[L].mesh, static_cast<int>(L));
            const tinygltf::Accessor& positions = model.accessors[primitive.attributes.at("POSITION")];
            // One array, the level's prefix of it: the same view from its start, the level's vertex count.
            if (L == 0) positionView = positions.bufferView;
            EXPECT_EQ(positions.bufferView, positionView);
            EXPECT_EQ(positions.byteOffset, 0u);
            ASSERT_EQ(positions.count, mesh.vertices.size());
            const std::vector<float> p = floatsOf(model, primitive.attributes.at("POSITION"));
            const std::vector<double>& t = model.nodes[L].translation;
            ASSERT_EQ(t.size(), 3u);
            auto position = [&](std::size_t v) {
                return glm::dvec3(p[3 * v] + t[0], p[3 * v + 1] + t[1], p[3 * v + 2] + t[2]);
            };
            // min and max: exactly those of the stored floats, as the spec requires.
            for (int c = 0; c < 3; ++c) {
                float lo = p[c], hi = p[c];
                for (std::size_t v = 0; v < positions.count; ++v)
                    lo = std::min(lo, p[3 * v + c]), hi = std::max(hi, p[3 * v + c]);
                EXPECT_EQ(positions.minValues.at(c), lo);
                EXPECT_EQ(positions.maxValues.at(c), hi);
            }
            // Each triangle of the level, in order, has the corners Refinement gave it.
            const std::vector<std::uint32_t> indices = indicesOf(model, primitive.indices);
            ASSERT_EQ(indices.size(), 3 * mesh.triangles.size());
            double worst = 0.0;
            for (std::size_t f = 0; f < mesh.triangles.size(); ++f)
                for (int c = 0; c < 3; ++c) {
                    ASSERT_LT(indices[3 * f + c], positions.count);
                    const glm::dvec3 expected = mesh.vertices[mesh.triangles[f][c]] * options.metresPerUnit;
                    worst = std::max(worst, glm::length(position(indices[3 * f + c]) - expected));
                }
            EXPECT_LE(worst, tolerance * std::sqrt(3.0));
            // The attributes follow the same numbering: normals as given, errors in metres.
            const std::vector<float> normals = floatsOf(model, primitive.attributes.at("NORMAL"));
            const std::vector<float> errors = floatsOf(model, primitive.attributes.at("_ERROR"));
            ASSERT_EQ(errors.size(), mesh.vertices.size());
            for (std::size_t v = 0; v < errors.size(); ++v) {
                EXPECT_EQ(errors[v], static_cast<float>(options.vertexError[v] * options.metresPerUnit));
                for (int c = 0; c < 3; ++c) EXPECT_EQ(normals[3 * v + c], static_cast<float>(options.normals[v][c]));
            }
        }
    }
}

TEST(Gltf, RefusesBadInputAndWritesNothing)
{
    std::vector<LevelMesh> levels = allLevels("phantom");
    const NestedLevels nested = nestLevels(levels);
    TempDir dir;
    const std::string path = dir.path("bad.glb");
    GlbOptions wrongNormals;
    wrongNormals.normals.assign(nested.vertices.size() - 1, glm::dvec3(0, 0, 1));
    EXPECT_THROW(writeGlb(nested, path, wrongNormals), Error);
    GlbOptions wrongErrors;
    wrongErrors.vertexError.assign(nested.vertices.size() + 1, 0.0);
    EXPECT_THROW(writeGlb(nested, path, wrongErrors), Error);
    GlbOptions noUnit;
    noUnit.metresPerUnit = 0.0;
    EXPECT_THROW(writeGlb(nested, path, noUnit), Error);
    NestedLevels outOfPrefix = nested;
    outOfPrefix.triangles[0][0][0] = static_cast<std::uint32_t>(nested.vertexCounts[0]); // a level 1 vertex
    EXPECT_THROW(writeGlb(outOfPrefix, path), Error);
    NestedLevels notFinite = nested;
    notFinite.vertices[5].y = std::nan("");
    EXPECT_THROW(writeGlb(notFinite, path), Error);
    EXPECT_THROW(writeGlb(NestedLevels{}, path), Error);
    EXPECT_TRUE(dir.files().empty());
}

// ---- The command line: -o NAME.glb, --units, --html ------------------------------------------

namespace {

nlohmann::json readJsonFile(const std::string& path)
{
    std::ifstream in(path);
    return nlohmann::json::parse(in);
}

std::string readText(const std::string& path)
{
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

// The data a report page shows: the JSON of its script element "pipetile-data".
nlohmann::json pageData(const std::string& path)
{
    const std::string page = readText(path);
    const std::string open = "<script id=\"pipetile-data\" type=\"application/json\">";
    const std::size_t begin = page.find(open);
    EXPECT_NE(begin, std::string::npos) << path;
    if (begin == std::string::npos) return {};
    const std::size_t end = page.find("</script>", begin);
    return nlohmann::json::parse(page.substr(begin + open.size(), end - begin - open.size()));
}

} // namespace

TEST(Cli, GlbHoldsEveryLevelInOneFile)
{
    TempDir dir;
    const std::string glb = dir.path("vessel.glb");
    const test::CliResult r =
        test::runCli("mesh -o '" + glb + "' --validate --units mm --report '" + dir.path("r.json") + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(dir.files(), (std::vector<std::string>{"r.json", "vessel.glb"})); // no per-level files
    const nlohmann::json report = readJsonFile(dir.path("r.json"));
    const tinygltf::Model model = readGlb(glb);
    ASSERT_EQ(report["levels"].size(), 4u);
    ASSERT_EQ(model.meshes.size(), 4u);
    for (std::size_t k = 0; k < 4; ++k) {
        SCOPED_TRACE("level " + std::to_string(k));
        const nlohmann::json& level = report["levels"][k];
        EXPECT_EQ(level["file"].get<std::string>(), glb);
        const tinygltf::Primitive& primitive = model.meshes[k].primitives.at(0);
        EXPECT_EQ(model.accessors[primitive.attributes.at("POSITION")].count, level["vertices"].get<std::size_t>());
        EXPECT_EQ(model.accessors[primitive.indices].count, 3 * level["triangles"].get<std::size_t>());
        // _ERROR: each vertex's distance to the isosurface, in metres (--units mm: a unit is 1/1000 m).
        // The validation's largest distance covers every vertex, and face samples besides.
        const std::vector<float> errors = floatsOf(model, primitive.attributes.at("_ERROR"));
        const float largest = *std::max_element(errors.begin(), errors.end());
        EXPECT_GT(largest, 0.0f);
        EXPECT_LE(largest, static_cast<float>(level["validation"]["mesh_to_reference"]["max"].get<double>() * 0.001));
    }
}

TEST(Cli, UnitsScaleAGlbOnly)
{
    TempDir dir;
    const test::CliResult r = test::runCli("mesh -o '" + dir.path("p.ply") + "' --units mm");
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("--units scales a .glb"), std::string::npos) << r.err;
    EXPECT_EQ(test::runCli("mesh -o '" + dir.path("p.glb") + "' --units furlong").exitCode, 2);
    EXPECT_TRUE(dir.files().empty());
    // Metres and millimetres: the same floats but for the factor 1000 (each rounded once, to float).
    ASSERT_EQ(test::runCli("mesh -o '" + dir.path("m.glb") + "' --levels 1").exitCode, 0);
    ASSERT_EQ(test::runCli("mesh -o '" + dir.path("mm.glb") + "' --levels 1 --units mm").exitCode, 0);
    const tinygltf::Model m = readGlb(dir.path("m.glb")), mm = readGlb(dir.path("mm.glb"));
    const std::vector<float> a = floatsOf(m, m.meshes[0].primitives[0].attributes.at("POSITION"));
    const std::vector<float> b = floatsOf(mm, mm.meshes[0].primitives[0].attributes.at("POSITION"));
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(b[i], a[i] * 0.001, 1e-6 * std::abs(a[i] * 0.001) + 1e-12);
    for (int c = 0; c < 3; ++c) EXPECT_DOUBLE_EQ(mm.nodes[0].translation[c], 0.001 * m.nodes[0].translation[c]);
}

TEST(Cli, HtmlReportsOfMeshAndValidateHoldTheirData)
{
    TempDir dir;
    const test::CliResult r = test::runCli("mesh -o '" + dir.path("p.ply") + "' --validate --html '" +
                                           dir.path("mesh.html") + "' --report '" + dir.path("r.json") + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json report = readJsonFile(dir.path("r.json"));
    const nlohmann::json page = pageData(dir.path("mesh.html"));
    ASSERT_EQ(page["levels"].size(), 4u);
    for (std::size_t k = 0; k < 4; ++k) {
        EXPECT_EQ(page["levels"][k]["triangles"], report["levels"][k]["triangles"]);
        EXPECT_EQ(page["levels"][k]["validation"]["hausdorff_voxels"],
                  report["levels"][k]["validation"]["hausdorff_voxels"]);
    }
    EXPECT_TRUE(page["peers"].is_null());
    // One file: its script and the .glb inside it, nothing beside it.
    const std::string html = readText(dir.path("mesh.html"));
    EXPECT_NE(html.find("<script id=\"pipetile-glb\" type=\"application/octet-stream\">Z2xURg"), std::string::npos)
        << "the base64 of the GLB magic 'glTF'";
    EXPECT_EQ(html.find("<script src"), std::string::npos);
    EXPECT_EQ(html.find("<link"), std::string::npos);

    ASSERT_EQ(test::runCli("sample phantom -o '" + dir.path("phantom.vdb") + "'").exitCode, 0);
    const test::CliResult v = test::runCli("validate '" + dir.path("phantom.vdb") + "' '" + dir.path("p_L2.ply") +
                                           "' --html '" + dir.path("v.html") + "'");
    ASSERT_EQ(v.exitCode, 0) << v.err;
    const nlohmann::json one = pageData(dir.path("v.html"));
    ASSERT_EQ(one["levels"].size(), 1u);
    EXPECT_EQ(one["levels"][0]["triangles"], report["levels"][2]["triangles"]);
    EXPECT_EQ(one["levels"][0]["name"], "p_L2.ply");
}

TEST(Cli, BenchHtmlPlotsEveryPeerAndShowsEveryLevel)
{
    TempDir dir;
    ASSERT_EQ(test::runCli("sample straight -o '" + dir.path("s.vdb") + "'").exitCode, 0);
    const test::CliResult r = test::runCli("bench '" + dir.path("s.vdb") + "' --repeat 1 --report '" +
                                           dir.path("b.json") + "' --html '" + dir.path("b.html") + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json report = readJsonFile(dir.path("b.json"));
    const nlohmann::json page = pageData(dir.path("b.html"));
    EXPECT_EQ(page["peers"], report["peers"]);
    // The levels shown are the peers' "pipetile Lk (level alone)" rows, validated as those were.
    ASSERT_EQ(page["levels"].size(), 4u);
    for (std::size_t k = 0; k < 4; ++k) {
        const std::string method = "pipetile L" + std::to_string(k) + " (level alone)";
        const auto peer = std::find_if(report["peers"].begin(), report["peers"].end(),
                                       [&](const nlohmann::json& p) { return p["method"] == method; });
        ASSERT_NE(peer, report["peers"].end()) << method;
        EXPECT_EQ(page["levels"][k]["triangles"], (*peer)["triangles"]);
        EXPECT_EQ(page["levels"][k]["validation"]["hausdorff_voxels"], (*peer)["hausdorff_voxels"]);
    }
}

TEST(Cli, AnHtmlReportInAMissingFolderFailsBeforeAnyWork)
{
    TempDir dir;
    const test::CliResult r =
        test::runCli("mesh -o '" + dir.path("p.glb") + "' --html '" + dir.path("nowhere/r.html") + "'");
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("nowhere"), std::string::npos) << r.err;
    EXPECT_TRUE(dir.files().empty());
}
