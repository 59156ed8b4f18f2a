// pipetile — internal (namespace detail, not part of the API): parsing mesh files exactly as
// written, for readMesh, its tests and the fuzz harness.
//
// pipetile parses the four formats itself rather than through OpenMesh's readers, because those
// do not give back what is in the file: they store every coordinate as a float, skip a vertex
// they cannot parse (OBJ) or read the rest of the file as zeros after it (PLY and OFF in text),
// drop faces with bad or repeated indices, split the vertices of non-manifold faces apart, and
// loop over a face count read from the file without checking the stream.
#pragma once

#include <pipetile/mesh_io.h>

#include <optional>
#include <string>
#include <string_view>

namespace pipetile::detail {

enum class MeshFormat {
    Ply, // ascii, binary_little_endian or binary_big_endian; element "vertex" (x, y, z), "face" (vertex_indices)
    Obj, // "v" and "f" lines; indices from 1, negative ones relative to the vertices before them
    Stl, // binary or ascii triangle soup; corners with equal coordinates are one vertex
    Off, // text OFF, with or without colours, normals or texture coordinates
};

/// The format a path's extension names (.ply .obj .stl .off, any case), or nothing.
std::optional<MeshFormat> meshFormatOf(const std::string& path);

/// Parses the bytes of a mesh file as written: vertices in file order, as doubles; faces in file
/// order, a polygon (a, b, c, d, ...) split into the fan (a, b, c), (a, c, d), ... Nothing is
/// dropped, merged or repaired, except that STL, which stores each triangle's corners, gets one
/// vertex per distinct corner position (exactly equal coordinates, -0 equal to 0; no tolerance,
/// so a crack stays a crack), numbered in order of first appearance.
/// @param name the file's name, for messages.
/// @throw Error naming `name` and the first bad element (its number and value, and its line in a
///        text file): a syntax error, a file cut short, a NaN or infinite coordinate, a face of
///        fewer than three vertices, or an index that is negative or past the last vertex.
TriangleMesh parseMesh(std::string_view bytes, MeshFormat format, const std::string& name);

} // namespace pipetile::detail
