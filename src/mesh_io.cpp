// pipetile — mesh_io: writing mesh files through OpenMesh (reading: mesh_read.cpp).

#include <pipetile/error.h>
#include <pipetile/mesh_io.h>

#include <pipetile/detail/atomic_file.h>
#include <pipetile/detail/mesh_read.h>

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <algorithm>
#include <cctype>
#include <filesystem>

namespace pipetile {

namespace {

using WriteMesh = OpenMesh::TriMesh_ArrayKernelT<>;

std::string lowerExtension(const std::string& path)
{
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    return ext;
}

// OpenMesh logs on stderr ("[OBJWriter] : write file" for every OBJ) and puts its complaints
// there too; the library never prints, and reports failures by throwing Error instead.
void silenceOpenMesh()
{
    static const bool silenced = [] {
        ::omlog().disable();
        ::omout().disable();
        ::omerr().disable();
        return true;
    }();
    (void)silenced;
}

} // namespace

bool isMeshExtension(const std::string& path)
{
    return detail::meshFormatOf(path).has_value();
}

void writeMesh(const TriangleMesh& mesh, const std::string& path, const MeshWriteOptions& options)
{
    if (!isMeshExtension(path))
        throw Error("'" + path + "': unknown mesh format '" + lowerExtension(path) +
                    "'; use one of .ply .obj .stl .off");
    const std::filesystem::path folder = std::filesystem::path(path).parent_path();
    std::error_code ec;
    if (!folder.empty() && !std::filesystem::is_directory(folder, ec))
        throw Error("'" + path + "': the folder '" + folder.string() + "' does not exist; create it first");

    WriteMesh out;
    const bool withColors = !options.colors.empty() && options.colors.size() == mesh.vertices.size();
    if (withColors) out.request_vertex_colors();
    std::vector<WriteMesh::VertexHandle> handles;
    handles.reserve(mesh.vertices.size());
    for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
        const glm::dvec3& v = mesh.vertices[i];
        handles.push_back(out.add_vertex(WriteMesh::Point(static_cast<float>(v.x), static_cast<float>(v.y),
                                                          static_cast<float>(v.z))));
        if (withColors) {
            const glm::dvec3 c = glm::clamp(options.colors[i], 0.0, 1.0) * 255.0 + 0.5;
            out.set_color(handles.back(), WriteMesh::Color(static_cast<unsigned char>(c.x),
                                                           static_cast<unsigned char>(c.y),
                                                           static_cast<unsigned char>(c.z)));
        }
    }
    for (const Triangle& t : mesh.triangles) {
        const WriteMesh::FaceHandle f = out.add_face(handles[t[0]], handles[t[1]], handles[t[2]]);
        if (!f.is_valid())
            throw Error("'" + path + "': the mesh is not a 2-manifold (OpenMesh refused a face); nothing written");
    }

    OpenMesh::IO::Options ioOptions;
    const std::string ext = lowerExtension(path);
    if (options.binary && (ext == ".ply" || ext == ".stl")) ioOptions += OpenMesh::IO::Options::Binary;
    if (withColors) ioOptions += OpenMesh::IO::Options::VertexColor;
    silenceOpenMesh();
    detail::writeAtomically(path, [&](const std::string& tmp) {
        if (!OpenMesh::IO::write_mesh(out, tmp, ioOptions, 9))
            throw Error("'" + path + "': OpenMesh could not write the file; check that the folder is writable");
    });
}

} // namespace pipetile
