// pipetile — gltf: every level of detail in one binary glTF 2.0 file (.glb), written with tinygltf.
//
// The levels nest (multires.h, NestedLevels), so the file holds one vertex array, coarse-first:
// level L's accessors cover the first vertexCounts[L] vertices of it, and each level has its own
// index accessor. One node per level; the finest node carries MSFT_lod naming the coarser ones,
// finest first, with MSFT_screencoverage hints, and the scene shows the finest node, so a viewer
// that ignores the extension (it is used, not required) shows the finest level.
#pragma once

#include <pipetile/multires.h>
#include <pipetile/output_set.h>

#include <glm/vec3.hpp>

#include <iosfwd>
#include <string>
#include <vector>

namespace pipetile {

struct GlbOptions {
    double metresPerUnit = 1.0;      // glTF positions are metres: one world unit of the grid in metres
    std::vector<glm::dvec3> normals; // optional per-vertex unit normals of NestedLevels::vertices (NORMAL)
    std::vector<double> vertexError; // optional per-vertex distance to the isosurface, world units (_ERROR)
};

/// True for a path ending in .glb (any case).
bool isGlbPath(const std::string& path);

/// The screen coverage below which a viewer drops from level L+1 to level L, per level, finest
/// first (MSFT_screencoverage): 1/2 for the finest level, halving per level down, since each
/// level has twice the rays of the one below it and so resolves detail half as large.
std::vector<double> screenCoverage(std::size_t levels);

/// Writes `levels` as a binary glTF 2.0 stream. Positions are float32, stored relative to the
/// centre of the vertices' bounding box; each node's translation (a double in the JSON) adds the
/// centre back, so float32 rounds at the scale of the object, not of its distance from the origin.
/// _ERROR is in metres too. Nothing is written if an argument is invalid.
/// @throw Error (naming `name`) if there are no levels, a vertex is not finite, a triangle names a
/// vertex beyond its level's prefix, metresPerUnit is not positive, or normals / vertexError are
/// given with a count other than the vertices'.
void writeGlb(std::ostream& out, const NestedLevels& levels, const GlbOptions& options = {},
              const std::string& name = "mesh.glb");

/// Writes `levels` as `path`, one of the targets of `outputs` (in place once they commit).
/// @throw as above, and OutputSet::write's errors.
void writeGlb(const NestedLevels& levels, OutputSet& outputs, const std::string& path, const GlbOptions& options = {});

/// Writes one .glb on its own: an OutputSet of that one file, committed. A failure leaves no half
/// file, and the file that was there stays as it was.
void writeGlb(const NestedLevels& levels, const std::string& path, const GlbOptions& options = {});

} // namespace pipetile
