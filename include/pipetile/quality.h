// pipetile — quality: what the programs downstream demand of a mesh. Outward vertex normals taken
// from the field (VFX and 3D printing shade and offset with them), and no needle triangles (CFD
// meshers such as TetGen refuse slivers): edge flips that raise the smallest angle.
#pragma once

#include <pipetile/mesh_io.h>
#include <pipetile/volume.h>

#include <glm/vec3.hpp>

#include <vector>

namespace pipetile {

/// Outward unit normal at every vertex of `mesh` (world space): the normalised gradient of the
/// volume's signed field (Volume::fieldGradient), which is exact on an implicit surface where face
/// averages are not. Where the gradient vanishes (a vertex half a voxel from any other value), the
/// area-weighted normal of the vertex's triangles stands in; a vertex of no triangle gets (0, 0, 0).
/// Linear in the vertices; deterministic.
std::vector<glm::dvec3> vertexNormals(const Volume& volume, const TriangleMesh& mesh);

/// Removes needles by edge flips (Lawson's, with the max-min criterion in space, on aspect
/// ratios): an edge shared by two triangles, one of them a needle (aspect ratio over 5, about a
/// 10 degree angle), is replaced by the quad's other diagonal when that lowers the larger of the
/// two triangles' aspect ratios, until no flip does. Triangles that are no needle stay as tiled. Vertices never move and triangles
/// keep their number, so a closed, manifold, oriented mesh stays so, and levels still nest.
/// An edge lying along a contour stays: one whose two ends lie in the same slice plane (index-space
/// coordinate along `axis`) and one of whose triangles leaves the plane. In-plane edges between two
/// in-plane triangles (the chords of a flat cap) may flip. A flip that would fold the surface
/// (a new triangle facing against the quad) or create an edge the mesh already has is not made.
/// Deterministic and single-threaded, so the result does not depend on threads.
/// @return the number of flips made.
long long flipNeedles(TriangleMesh& mesh, const Volume& volume, int axis);

/// Collapses each edge no longer than `tolerance` (world units) into its lower-numbered end, where
/// the collapse keeps a closed manifold so (the edge has two triangles, and its ends share no
/// neighbour but those triangles' third corners): the two triangles go, and so does the other end,
/// after which the vertices are renumbered in their order. Two constructions can put a vertex at
/// one point up to rounding: a junction part's ray, cast from the partner's central point, meets
/// the single contour's polygon where that contour's own ray does when both centres lie on one
/// line with the point; each gave a triangle of no area. Positions are not moved, so levels still
/// nest; linear in the mesh, deterministic.
/// @return the number of edges collapsed.
long long collapseShortEdges(TriangleMesh& mesh, double tolerance);

/// Removes the vertices that make needles: each end of an edge no longer than `tolerance` (world
/// units) goes into the other end, unless it is a vertex of the coarser level (`coarser`, its
/// positions: empty for level 0), so that each level's vertices stay a subset of the next's
/// whatever this level removes (a vertex this level keeps is one the next keeps too). Between two
/// new ends the one that comes later by position (x, then y, then z) goes. Each collapse is made
/// where it keeps a closed manifold so (collapseShortEdges' link condition), so a section thinner
/// than the tolerance keeps the vertices that would pinch it. Such edges lie in slice planes: the
/// partner's ray of a junction part meets the single contour's polygon next to where that
/// contour's own ray does, or two rays meet a contour thinner than a voxel. Every triangle on one
/// is a needle whatever the diagonals (its aspect ratio is about the edge's distance to the third
/// corner over its length), so no flip removes it. The surface moves by at most the edges' length;
/// positions are not moved; deterministic, and the same for a level refined or built from scratch.
/// With `needleAspect` > 0, only the edges of triangles whose aspect ratio exceeds it, and only
/// where a collapse lowers the largest aspect ratio of the triangles around the vertex that goes.
/// @return the number of edges collapsed.
long long collapseNeedleEdges(TriangleMesh& mesh, double tolerance, const std::vector<glm::dvec3>& coarser,
                              double needleAspect = 0.0);

/// The edges the reconstruction collapses (collapseNeedleEdges), in voxels: the needles' short
/// edges lie mostly far below (tree, aorta: under 0.01 voxel), the rays' own spacing on a tube of
/// a few voxels far above. Every such edge goes where no triangle turns over; twice this, the
/// collapses folded the surface (aspect 1e9 on the aorta's top level).
constexpr double kNeedleEdgeVoxels = 0.1;

/// Then the edges of the triangles over kCollapseAspect, up to this many voxels at the top level
/// (twice as far each level coarser, at most 8 times), go where that lowers the largest aspect
/// ratio around (the hollow Y's and the bean's are 0.1 to 0.3 voxel). Half the bound of issue 17,
/// so that a collapse also takes the triangles next to a needle down with it. The top level stays
/// within the voxel of the isosurface it was (hollow Y 0.71, bean 0.53 voxel).
constexpr double kNeedleReachVoxels = 0.3;
constexpr double kCollapseAspect = 50.0;

/// Triangles with an angle below this many degrees are counted as needles in reports.
constexpr double kNeedleDegrees = 5.0;

} // namespace pipetile
