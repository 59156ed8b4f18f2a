// pipetile — gltf: the levels of detail as one binary glTF 2.0 file, through tinygltf (Debian's
// shared library: its JSON and image code stay inside it, this file only fills its Model).

#include <pipetile/error.h>
#include <pipetile/gltf.h>

#include <tiny_gltf.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <limits>
#include <ostream>

namespace pipetile {

namespace {

// glTF's numbers for component types, buffer targets and primitive modes (glTF 2.0, 3.6 and 5.24).
constexpr int kFloat = TINYGLTF_COMPONENT_TYPE_FLOAT;
constexpr int kUnsignedInt = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;

// The binary chunk, growing one buffer view at a time, each 4-byte aligned as accessors require.
// A vertex view is shared by every level's accessor, so it states its stride (the spec requires
// it when accessors share a view); index views are one accessor's each and have none.
class BinaryChunk {
public:
    explicit BinaryChunk(tinygltf::Model& model) : mModel(model) { mModel.buffers.emplace_back(); }

    template <typename T>
    int addView(const std::vector<T>& values, int target, int stride = 0)
    {
        std::vector<unsigned char>& data = mModel.buffers[0].data;
        data.resize((data.size() + 3) / 4 * 4, 0);
        tinygltf::BufferView view;
        view.buffer = 0;
        view.byteOffset = data.size();
        view.byteLength = values.size() * sizeof(T);
        view.target = target;
        view.byteStride = static_cast<std::size_t>(stride);
        const auto* bytes = reinterpret_cast<const unsigned char*>(values.data());
        data.insert(data.end(), bytes, bytes + view.byteLength);
        mModel.bufferViews.push_back(view);
        return static_cast<int>(mModel.bufferViews.size() - 1);
    }

private:
    tinygltf::Model& mModel;
};

// An accessor over the first `count` elements of `view`, with the min and max of those elements
// (float components of `width` per element), which glTF requires for POSITION.
int addAccessor(tinygltf::Model& model, int view, int componentType, int type, std::size_t count,
                const std::vector<float>* values = nullptr, int width = 1)
{
    tinygltf::Accessor a;
    a.bufferView = view;
    a.componentType = componentType;
    a.type = type;
    a.count = count;
    if (values) {
        a.minValues.assign(width, std::numeric_limits<double>::infinity());
        a.maxValues.assign(width, -std::numeric_limits<double>::infinity());
        for (std::size_t i = 0; i < count; ++i)
            for (int c = 0; c < width; ++c) {
                const double v = (*values)[i * width + c];
                a.minValues[c] = std::min(a.minValues[c], v);
                a.maxValues[c] = std::max(a.maxValues[c], v);
            }
    }
    model.accessors.push_back(a);
    return static_cast<int>(model.accessors.size() - 1);
}

void checkLevels(const NestedLevels& levels, const GlbOptions& options, const std::string& name)
{
    const std::size_t n = levels.vertices.size();
    if (levels.triangles.empty() || levels.vertexCounts.size() != levels.triangles.size())
        throw Error("'" + name + "': no levels to write; nothing written");
    if (!(options.metresPerUnit > 0.0) || !std::isfinite(options.metresPerUnit))
        throw Error("'" + name + "': the unit must be a positive number of metres; nothing written");
    for (std::size_t i = 0; i < n; ++i) {
        const glm::dvec3& v = levels.vertices[i];
        if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
            throw Error("'" + name + "': vertex " + std::to_string(i) + " is not finite; nothing written");
    }
    for (std::size_t L = 0; L < levels.triangles.size(); ++L) {
        if (levels.triangles[L].empty())
            throw Error("'" + name + "': level " + std::to_string(L) + " has no triangles; nothing written");
        for (const Triangle& t : levels.triangles[L])
            for (const std::uint32_t id : t)
                if (id >= levels.vertexCounts[L] || levels.vertexCounts[L] > n)
                    throw Error("'" + name + "': a triangle of level " + std::to_string(L) + " names vertex " +
                                std::to_string(id) + " beyond the level's " + std::to_string(levels.vertexCounts[L]) +
                                "; nothing written");
    }
    if (!options.normals.empty() && options.normals.size() != n)
        throw Error("'" + name + "': " + std::to_string(options.normals.size()) + " normals for " + std::to_string(n) +
                    " vertices; nothing written");
    if (!options.vertexError.empty() && options.vertexError.size() != n)
        throw Error("'" + name + "': " + std::to_string(options.vertexError.size()) + " vertex errors for " +
                    std::to_string(n) + " vertices; nothing written");
}

glm::dvec3 boxCentre(const std::vector<glm::dvec3>& points)
{
    glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (const glm::dvec3& p : points) lo = glm::min(lo, p), hi = glm::max(hi, p);
    return points.empty() ? glm::dvec3(0.0) : 0.5 * (lo + hi);
}

template <typename F>
std::vector<float> floats(std::size_t count, int width, F value)
{
    std::vector<float> out(count * width);
    for (std::size_t i = 0; i < count; ++i)
        for (int c = 0; c < width; ++c) out[i * width + c] = static_cast<float>(value(i, c));
    return out;
}

// The vertex attributes, each one view over every vertex, as glTF stores them (float32, metres).
struct VertexViews {
    std::vector<float> positions, errors; // kept for the accessors' min and max
    int position = -1, normal = -1, error = -1;
};

VertexViews addVertexViews(BinaryChunk& chunk, const NestedLevels& levels, const GlbOptions& options,
                           const glm::dvec3& centre)
{
    const std::size_t n = levels.vertices.size();
    const double scale = options.metresPerUnit;
    VertexViews views;
    views.positions = floats(n, 3, [&](std::size_t i, int c) { return (levels.vertices[i][c] - centre[c]) * scale; });
    views.position = chunk.addView(views.positions, TINYGLTF_TARGET_ARRAY_BUFFER, 3 * sizeof(float));
    if (!options.normals.empty())
        views.normal = chunk.addView(floats(n, 3, [&](std::size_t i, int c) { return options.normals[i][c]; }),
                                     TINYGLTF_TARGET_ARRAY_BUFFER, 3 * sizeof(float));
    if (!options.vertexError.empty()) {
        views.errors = floats(n, 1, [&](std::size_t i, int) { return options.vertexError[i] * scale; });
        views.error = chunk.addView(views.errors, TINYGLTF_TARGET_ARRAY_BUFFER, sizeof(float));
    }
    return views;
}

// Level L: a mesh whose attributes are the first vertexCounts[L] vertices of the shared views and
// whose indices are its own, and a node placing it (the centre the positions are relative to).
void addLevel(tinygltf::Model& model, BinaryChunk& chunk, const NestedLevels& levels, std::size_t L,
              const VertexViews& views, const std::vector<double>& translation)
{
    const std::size_t count = levels.vertexCounts[L];
    tinygltf::Primitive primitive;
    primitive.mode = TINYGLTF_MODE_TRIANGLES;
    primitive.attributes["POSITION"] =
        addAccessor(model, views.position, kFloat, TINYGLTF_TYPE_VEC3, count, &views.positions, 3);
    if (views.normal >= 0)
        primitive.attributes["NORMAL"] = addAccessor(model, views.normal, kFloat, TINYGLTF_TYPE_VEC3, count);
    if (views.error >= 0)
        primitive.attributes["_ERROR"] =
            addAccessor(model, views.error, kFloat, TINYGLTF_TYPE_SCALAR, count, &views.errors);
    std::vector<std::uint32_t> indices;
    indices.reserve(3 * levels.triangles[L].size());
    for (const Triangle& t : levels.triangles[L]) indices.insert(indices.end(), t.begin(), t.end());
    primitive.indices = addAccessor(model, chunk.addView(indices, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER), kUnsignedInt,
                                    TINYGLTF_TYPE_SCALAR, indices.size());
    tinygltf::Mesh mesh;
    mesh.name = "L" + std::to_string(L);
    mesh.primitives.push_back(primitive);
    model.meshes.push_back(mesh);

    tinygltf::Node node;
    node.name = mesh.name;
    node.mesh = static_cast<int>(L);
    node.translation = translation;
    model.nodes.push_back(node);
}

// MSFT_lod on the finest node (the last): the coarser nodes, finest first, and one screen
// coverage per level; the scene shows the finest node.
void addLevelsOfDetail(tinygltf::Model& model)
{
    const std::size_t levelCount = model.nodes.size();
    tinygltf::Node& finest = model.nodes.back();
    tinygltf::Value::Array ids, coverage;
    for (std::size_t L = levelCount - 1; L-- > 0;) ids.emplace_back(static_cast<int>(L));
    for (const double c : screenCoverage(levelCount)) coverage.emplace_back(c);
    if (levelCount > 1) {
        finest.extensions["MSFT_lod"] = tinygltf::Value(tinygltf::Value::Object{{"ids", tinygltf::Value(ids)}});
        finest.extras = tinygltf::Value(tinygltf::Value::Object{{"MSFT_screencoverage", tinygltf::Value(coverage)}});
        model.extensionsUsed.push_back("MSFT_lod");
    }
    tinygltf::Scene scene;
    scene.nodes.push_back(static_cast<int>(levelCount - 1));
    model.scenes.push_back(scene);
    model.defaultScene = 0;
}

tinygltf::Model buildModel(const NestedLevels& levels, const GlbOptions& options)
{
    tinygltf::Model model;
    model.asset.version = "2.0";
    model.asset.generator = "pipetile";
    BinaryChunk chunk(model);
    const glm::dvec3 centre = boxCentre(levels.vertices);
    const VertexViews views = addVertexViews(chunk, levels, options, centre);
    const glm::dvec3 translation = centre * options.metresPerUnit;
    for (std::size_t L = 0; L < levels.triangles.size(); ++L)
        addLevel(model, chunk, levels, L, views, {translation.x, translation.y, translation.z});
    addLevelsOfDetail(model);
    return model;
}

} // namespace

bool isGlbPath(const std::string& path)
{
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    return ext == ".glb";
}

std::vector<double> screenCoverage(std::size_t levels)
{
    std::vector<double> coverage;
    for (std::size_t k = 0; k < levels; ++k) coverage.push_back(std::ldexp(0.5, -static_cast<int>(k)));
    return coverage;
}

void writeGlb(std::ostream& out, const NestedLevels& levels, const GlbOptions& options, const std::string& name)
{
    checkLevels(levels, options, name);
    const tinygltf::Model model = buildModel(levels, options);
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToStream(&model, out, /*prettyPrint=*/false, /*writeBinary=*/true))
        throw Error("'" + name + "': tinygltf could not serialise the levels");
}

void writeGlb(const NestedLevels& levels, OutputSet& outputs, const std::string& path, const GlbOptions& options)
{
    checkLevels(levels, options, path); // before the temporary file is opened
    outputs.write(path, [&](std::ostream& out) { writeGlb(out, levels, options, path); });
}

void writeGlb(const NestedLevels& levels, const std::string& path, const GlbOptions& options)
{
    checkLevels(levels, options, path); // before the output is locked
    OutputSet outputs({path});
    writeGlb(levels, outputs, path, options);
    outputs.commit();
}

} // namespace pipetile
