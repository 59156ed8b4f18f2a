// pipetile — mesh_io: writing mesh files, pipetile's own serialisers (reading: mesh_read.cpp).

#include <pipetile/error.h>
#include <pipetile/mesh_io.h>

#include <pipetile/detail/mesh_read.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <ostream>
#include <type_traits>

namespace pipetile {

namespace {

std::string lowerExtension(const std::string& path)
{
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    return ext;
}

// ---- Writing: pipetile's own serialisers, every byte through the OutputSet's checked stream --

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "binary PLY and STL are written in the host's byte order");

template <typename T>
void putBinary(std::ostream& out, T value)
{
    out.write(reinterpret_cast<const char*>(&value), sizeof value);
}

// The shortest decimal that reads back as the same double (or integer), then `end`.
template <typename T>
void putText(std::ostream& out, T value, char end)
{
    char text[32];
    char* last = std::to_chars(text, text + sizeof text - 1, value).ptr;
    *last++ = end;
    out.write(text, last - text);
}

void putPoint(std::ostream& out, const glm::dvec3& p, char end)
{
    putText(out, p.x, ' ');
    putText(out, p.y, ' ');
    putText(out, p.z, end);
}

std::array<std::uint8_t, 3> colorBytes(const glm::dvec3& color)
{
    const glm::dvec3 c = glm::clamp(color, 0.0, 1.0) * 255.0 + 0.5;
    return {static_cast<std::uint8_t>(c.x), static_cast<std::uint8_t>(c.y), static_cast<std::uint8_t>(c.z)};
}

// A file must never hold a NaN or a face that points nowhere: readers reject or, worse, drop them.
void checkWritable(const TriangleMesh& mesh, const std::string& path)
{
    for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
        const glm::dvec3& v = mesh.vertices[i];
        if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
            throw Error("'" + path + "': vertex " + std::to_string(i) + " is not finite; nothing written");
    }
    for (std::size_t f = 0; f < mesh.triangles.size(); ++f)
        for (const std::uint32_t id : mesh.triangles[f])
            if (id >= mesh.vertices.size())
                throw Error("'" + path + "': triangle " + std::to_string(f) + " names vertex " + std::to_string(id) +
                            " of " + std::to_string(mesh.vertices.size()) + "; nothing written");
}

// What a file holds per vertex besides its position: each empty, or one entry per vertex.
struct VertexData {
    const std::vector<glm::dvec3>& colors;
    const std::vector<glm::dvec3>& normals;
    const std::vector<double>& quality;
};

// PLY with double coordinates (binary little-endian, or text), then optional float normals, uchar
// colours and a float quality, in that order.
void writePly(std::ostream& out, const TriangleMesh& mesh, const VertexData& data, bool binary)
{
    out << "ply\nformat " << (binary ? "binary_little_endian" : "ascii") << " 1.0\ncomment written by pipetile\n"
        << "element vertex " << mesh.vertices.size() << "\nproperty double x\nproperty double y\nproperty double z\n";
    if (!data.normals.empty()) out << "property float nx\nproperty float ny\nproperty float nz\n";
    if (!data.colors.empty()) out << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    if (!data.quality.empty()) out << "property float quality\n";
    out << "element face " << mesh.triangles.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
    const bool normals = !data.normals.empty(), colors = !data.colors.empty(), quality = !data.quality.empty();
    for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
        const glm::dvec3& v = mesh.vertices[i];
        if (binary) {
            putBinary(out, v.x), putBinary(out, v.y), putBinary(out, v.z);
            if (normals)
                for (int axis = 0; axis < 3; ++axis) putBinary(out, static_cast<float>(data.normals[i][axis]));
            if (colors)
                for (const std::uint8_t byte : colorBytes(data.colors[i])) putBinary(out, byte);
            if (quality) putBinary(out, static_cast<float>(data.quality[i]));
            continue;
        }
        // Text: the values of a vertex on one line, floats as the shortest decimals of the float.
        putPoint(out, v, normals || colors || quality ? ' ' : '\n');
        if (normals)
            for (int axis = 0; axis < 3; ++axis)
                putText(out, static_cast<float>(data.normals[i][axis]), axis < 2 || colors || quality ? ' ' : '\n');
        if (colors) {
            const std::array<std::uint8_t, 3> c = colorBytes(data.colors[i]);
            putText(out, int(c[0]), ' '), putText(out, int(c[1]), ' '), putText(out, int(c[2]), quality ? ' ' : '\n');
        }
        if (quality) putText(out, static_cast<float>(data.quality[i]), '\n');
    }
    for (const Triangle& t : mesh.triangles) {
        if (binary) {
            putBinary(out, std::uint8_t(3));
            for (const std::uint32_t id : t) putBinary(out, static_cast<std::int32_t>(id));
        } else {
            out << "3 ";
            putText(out, t[0], ' '), putText(out, t[1], ' '), putText(out, t[2], '\n');
        }
    }
}

// OBJ: "v x y z" (with "r g b" in [0, 1] when coloured, as MeshLab and Blender read it), then
// "vn" per vertex when there are normals, so that face corners read "v//v"; faces 1-based.
void writeObj(std::ostream& out, const TriangleMesh& mesh, const VertexData& data)
{
    out << "# written by pipetile\n";
    for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
        out << "v ";
        putPoint(out, mesh.vertices[i], data.colors.empty() ? '\n' : ' ');
        if (!data.colors.empty()) putPoint(out, glm::clamp(data.colors[i], 0.0, 1.0), '\n');
    }
    for (const glm::dvec3& n : data.normals) {
        out << "vn ";
        putText(out, static_cast<float>(n.x), ' '), putText(out, static_cast<float>(n.y), ' ');
        putText(out, static_cast<float>(n.z), '\n');
    }
    const bool normals = !data.normals.empty();
    for (const Triangle& t : mesh.triangles) {
        out << 'f';
        for (int k = 0; k < 3; ++k) {
            const char end = k == 2 ? '\n' : ' ';
            out << ' ';
            if (normals) {
                putText(out, t[k] + 1ULL, '/');
                out << '/';
            }
            putText(out, t[k] + 1ULL, end);
        }
    }
}

// OFF, or COFF with RGBA bytes per vertex.
void writeOff(std::ostream& out, const TriangleMesh& mesh, const std::vector<glm::dvec3>& colors)
{
    out << (colors.empty() ? "OFF\n" : "COFF\n") << mesh.vertices.size() << ' ' << mesh.triangles.size() << " 0\n";
    for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
        putPoint(out, mesh.vertices[i], colors.empty() ? '\n' : ' ');
        if (colors.empty()) continue;
        const std::array<std::uint8_t, 3> c = colorBytes(colors[i]);
        putText(out, int(c[0]), ' '), putText(out, int(c[1]), ' '), putText(out, int(c[2]), ' ');
        out << "255\n";
    }
    for (const Triangle& t : mesh.triangles) {
        out << "3 ";
        putText(out, t[0], ' '), putText(out, t[1], ' '), putText(out, t[2], '\n');
    }
}

glm::dvec3 unitNormal(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c)
{
    const glm::dvec3 n = glm::cross(b - a, c - a);
    const double length = glm::length(n);
    return length > 0.0 ? n / length : glm::dvec3(0.0);
}

// STL: a triangle soup with facet normals. Binary STL holds float32 only; returns the largest
// rounding that caused (text STL keeps doubles).
double writeStl(std::ostream& out, const TriangleMesh& mesh, bool binary)
{
    double rounding = 0.0;
    auto putFloats = [&](const glm::dvec3& p) {
        for (int axis = 0; axis < 3; ++axis) {
            const float f = static_cast<float>(p[axis]);
            rounding = std::max(rounding, std::abs(static_cast<double>(f) - p[axis]));
            putBinary(out, f);
        }
    };
    if (binary) {
        // 80 header bytes, which must not start with "solid" (that announces text STL).
        std::string header = "binary STL written by pipetile";
        header.resize(80, ' ');
        out.write(header.data(), 80);
        putBinary(out, static_cast<std::uint32_t>(mesh.triangles.size()));
    } else {
        out << "solid pipetile\n";
    }
    for (const Triangle& t : mesh.triangles) {
        const glm::dvec3 &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
        const glm::dvec3 normal = unitNormal(a, b, c);
        if (binary) {
            for (int axis = 0; axis < 3; ++axis) putBinary(out, static_cast<float>(normal[axis]));
            putFloats(a), putFloats(b), putFloats(c);
            putBinary(out, std::uint16_t(0));
        } else {
            out << "facet normal ";
            putPoint(out, normal, '\n');
            out << " outer loop\n";
            for (const glm::dvec3* p : {&a, &b, &c}) {
                out << "  vertex ";
                putPoint(out, *p, '\n');
            }
            out << " endloop\nendfacet\n";
        }
    }
    if (!binary) out << "endsolid pipetile\n";
    return rounding;
}

} // namespace

bool isMeshExtension(const std::string& path)
{
    return detail::meshFormatOf(path).has_value();
}

double writeMesh(const TriangleMesh& mesh, OutputSet& outputs, const std::string& path, const MeshWriteOptions& options)
{
    const std::string ext = lowerExtension(path);
    if (!isMeshExtension(path))
        throw Error("'" + path + "': unknown mesh format '" + ext + "'; use one of .ply .obj .stl .off");
    checkWritable(mesh, path);
    // Per-vertex data that does not match the vertices is left out, as the options say (optional).
    auto perVertex = [&](const auto& values) -> decltype(values) {
        static const std::remove_reference_t<decltype(values)> kNone;
        return values.size() == mesh.vertices.size() && !mesh.vertices.empty() ? values : kNone;
    };
    const VertexData data{perVertex(options.colors), perVertex(options.normals), perVertex(options.quality)};
    double rounding = 0.0;
    outputs.write(path, [&](std::ostream& out) {
        if (ext == ".ply") writePly(out, mesh, data, options.binary);
        if (ext == ".obj") writeObj(out, mesh, data);
        if (ext == ".off") writeOff(out, mesh, data.colors);
        if (ext == ".stl") rounding = writeStl(out, mesh, options.binary);
    });
    return rounding;
}

double writeMesh(const TriangleMesh& mesh, const std::string& path, const MeshWriteOptions& options)
{
    if (!isMeshExtension(path))
        throw Error("'" + path + "': unknown mesh format '" + lowerExtension(path) +
                    "'; use one of .ply .obj .stl .off");
    OutputSet outputs({path});
    const double rounding = writeMesh(mesh, outputs, path, options);
    outputs.commit();
    return rounding;
}

} // namespace pipetile
