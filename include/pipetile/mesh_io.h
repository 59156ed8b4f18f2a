// pipetile — mesh_io: reading and writing mesh files (the mesh type is in mesh.h).
// Reading (mesh_read.cpp) and writing are pipetile's own: every byte written goes through a checked
// OutputSet stream, and positions keep double precision both ways (OpenMesh 9 reads and writes
// float32 and ignores failed writes). The extension of a path picks the format.
#pragma once

#include <pipetile/mesh.h>
#include <pipetile/output_set.h>

#include <glm/common.hpp>
#include <glm/vec3.hpp>

#include <string>
#include <vector>

namespace pipetile {

struct MeshWriteOptions {
    bool binary = true;              // PLY and STL in binary, else as text (OBJ and OFF are text)
    std::vector<glm::dvec3> colors;  // optional per-vertex RGB in [0, 1] (PLY, OFF, OBJ)
    std::vector<glm::dvec3> normals; // optional per-vertex unit normals, outward (PLY, OBJ; STL
                                     // keeps its facet normals, OFF holds none)
    std::vector<double> quality;     // optional per-vertex scalar, PLY's `quality` property
                                     // (MeshLab reads it): the distance to the isosurface
};

/// True for the extensions pipetile writes: .ply .obj .stl .off (any case).
bool isMeshExtension(const std::string& path);

/// Writes a mesh as `path`, one of the targets of `outputs` (it is in place once they commit);
/// the extension picks the format. Positions keep their double precision wherever the format can
/// hold it: binary PLY stores doubles, and text formats the shortest decimals that read back as
/// the same doubles. Binary STL can only hold float32.
/// @return the largest distance, in world units along one axis, between a coordinate in the file
/// and the mesh's: 0 except for binary STL, where it is float32's rounding (large far from the
/// origin: half a unit at 10^7).
/// @throw Error for an unknown extension, a vertex that is not finite, a triangle naming a vertex
/// the mesh does not have, or a write that fails (OutputSet::write).
double writeMesh(const TriangleMesh& mesh, OutputSet& outputs, const std::string& path,
                 const MeshWriteOptions& options = {});

/// Writes one mesh file on its own: an OutputSet of that one file, committed. A failure never
/// leaves half a file, and the file that was there stays as it was.
/// @return and @throw as above, and the OutputSet's own errors (a missing folder, a run holding the file).
double writeMesh(const TriangleMesh& mesh, const std::string& path, const MeshWriteOptions& options = {});

/// Reads a triangle or polygon mesh (.ply .obj .stl .off) as written: every vertex in file order,
/// in double precision, every face in file order, polygons split into triangle fans. Nothing is
/// dropped, merged or repaired, so a validation judges the file itself; STL, which stores each
/// triangle's own corners, gets one vertex per distinct corner position (exactly equal coordinates).
/// @throw Error naming the file, and the first bad element with its value, if the file is missing,
///        not a regular file, malformed or truncated, or has a NaN or infinite coordinate, a face
///        of fewer than three vertices, or a vertex index that is negative or out of range.
TriangleMesh readMesh(const std::string& path);

} // namespace pipetile
