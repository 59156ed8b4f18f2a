// pipetile — mesh_io: the triangle mesh type, and reading and writing mesh files.
// The only module that includes OpenMesh (to write); the extension of a path picks the format.
#pragma once

#include <pipetile/tiler.h>

#include <glm/common.hpp>
#include <glm/vec3.hpp>

#include <string>
#include <vector>

namespace pipetile {

/// A triangle mesh in world space, triangles counterclockwise seen from outside.
struct TriangleMesh {
    std::vector<glm::dvec3> vertices;
    std::vector<Triangle> triangles; // ids into `vertices`
};

struct MeshWriteOptions {
    bool binary = true;               // PLY and STL in binary (smaller, exact floats); OBJ and OFF
                                      // are text formats, written with 9 significant digits
    std::vector<glm::dvec3> colors;   // optional per-vertex RGB in [0, 1] (PLY, OFF, OBJ)
};

/// True for the extensions pipetile writes: .ply .obj .stl .off (any case).
bool isMeshExtension(const std::string& path);

/// Writes a mesh through a temporary file and a rename: a failure never leaves half a file.
/// @throw Error for an unknown extension, or a folder that is missing or not writable.
void writeMesh(const TriangleMesh& mesh, const std::string& path, const MeshWriteOptions& options = {});

/// Reads a triangle or polygon mesh (.ply .obj .stl .off) as written: every vertex in file order,
/// in double precision, every face in file order, polygons split into triangle fans. Nothing is
/// dropped, merged or repaired, so a validation judges the file itself; STL, which stores each
/// triangle's own corners, gets one vertex per distinct corner position (exactly equal coordinates).
/// @throw Error naming the file, and the first bad element with its value, if the file is missing,
///        not a regular file, malformed or truncated, or has a NaN or infinite coordinate, a face
///        of fewer than three vertices, or a vertex index that is negative or out of range.
TriangleMesh readMesh(const std::string& path);

} // namespace pipetile
