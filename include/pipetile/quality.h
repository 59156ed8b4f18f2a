// pipetile — quality: what the programs downstream demand of a mesh. Outward vertex normals taken
// from the field (VFX and 3D printing shade and offset with them), and no needle triangles (CFD
// meshers such as TetGen refuse slivers): edge flips that raise the smallest angle. Nothing here
// throws but std::bad_alloc; triangles must index their mesh's vertices (TriangleMesh).
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
/// A flip that would make a triangle past kLargestAspect of three vertices `coarser` has (the
/// level below's, as collapseNeedleEdges takes them) is not made: no collapse or corner removal
/// could take that one, where the needle it replaces may still go with its new corner.
/// Deterministic and single-threaded, so the result does not depend on threads.
/// @return the number of flips made.
long long flipNeedles(TriangleMesh& mesh, const Volume& volume, int axis, const std::vector<glm::dvec3>& coarser = {});

/// Slice planes beside a slab so thin that two vertices of one of them a little apart fan needles
/// across it whatever the tiling: a triangle on an edge e long to a vertex d away across a slab t
/// thick has an aspect ratio of up to sqrt(3)/2 d^2 / (e t).
struct ThinSlabPlanes {
    const Volume* volume = nullptr; // maps vertices into index space
    int axis = 2;                   // the slicing axis
    std::vector<double> positions;  // the planes' index-space coordinates along it, ascending
    double tolerance = 0.0;         // world units: the longest edge in one of them that goes
    /// Whether a and b both lie in one of the planes (to a millionth of a voxel).
    bool holdBoth(const glm::dvec3& a, const glm::dvec3& b) const;
};

/// How near the isosurface the triangles that collapses make must stay, whatever the triangles
/// they replace (the top level's bound, a voxel). The move measured against those adds up over
/// collapses, the field does not: the phantom sliced along y went from 0.98 voxel off as tiled to
/// 1.11 after its collapses. Without a volume, no bound.
struct SurfaceBound {
    const Volume* volume = nullptr;
    double voxels = 0.0;
    /// Whether triangle abc, its corners on the isosurface, keeps the isosurface within `voxels` of
    /// its point farthest from its corners: that point lies so near a corner, or the field shows
    /// the surface that near (Volume::surfaceWithin). Always, without a volume.
    bool holds(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) const;
};

/// Which edges collapseNeedleEdges looks at, and which collapses it makes, past the short ones.
struct NeedleCollapse {
    /// Only the edges of triangles whose aspect ratio exceeds this are looked at (0: every
    /// triangle's), and without measureMove those of specks (triangles whose three edges lie
    /// within the tolerance, whatever their shape: a speck's needles around it often cannot go,
    /// its own edges can).
    double needleAspect = 0.0;
    /// A collapse is made only where it lowers the largest aspect ratio of the triangles around
    /// the vertex that goes. Between two new ends, where the end that goes first cannot (a
    /// triangle would turn over, or the worst would not fall), the other goes instead.
    bool lowerWorst = false;
    /// The needles' edges longer than the tolerance go too where the surface moves by no more
    /// than the tolerance, as far as an edge within it may move it: measured as the distance from
    /// the vertex that goes to the triangles that take its place, and from points of those
    /// (centroids, midpoints of their edges at the kept end) to the triangles before.
    bool measureMove = false;
    /// An edge whose two ends lie in one of these planes goes as one within the tolerance does
    /// where it is no longer than thin->tolerance.
    const ThinSlabPlanes* thin = nullptr;
    /// With measureMove, a needle's corners that the coarser level lacks may also go along their
    /// other edges, and their neighbours into them, as the needles' own edges do.
    bool alongCorners = false;
    /// A collapse is made only where every triangle it makes keeps within this bound.
    SurfaceBound bound = {};
};

/// Removes the vertices that make needles. Each end of an edge no longer than `tolerance` (world
/// units) goes into the other end, the edge's two triangles with it, unless it is a vertex of the
/// level below (`coarser`: its positions, one entry per copy; empty for level 0). So each level's
/// vertices stay a subset of the next's whatever this level removes: a vertex the level below
/// kept, this level keeps. Between two new ends, the one later by position (x, then y, then z)
/// goes; between copies of one point, the higher-numbered. A collapse is made where it keeps a
/// closed manifold so (the edge has two triangles, and its ends share no neighbour but their
/// third corners) and turns no triangle over; rounds go on until none is left to make. The
/// vertices left keep their order and positions. Shorter edges go first, then by position.
/// Such edges lie in slice planes: a junction part's ray, cast from the partner's central point,
/// meets the single contour's polygon next to where that contour's own ray does (or at the same
/// point, a triangle of no area), or two rays meet a contour thinner than a voxel. Every triangle
/// on such an edge is a needle whatever the diagonals (its aspect ratio is about the distance to
/// its third corner over the edge's length), so no flip removes it.
/// `how` (NeedleCollapse) widens the edges that go past the short ones. Deterministic; the
/// surface moves by at most the edges' length, or the tolerance past it.
/// @return the number of edges collapsed.
long long collapseNeedleEdges(TriangleMesh& mesh, double tolerance, const std::vector<glm::dvec3>& coarser,
                              const NeedleCollapse& how = {});

/// Rebuilds each pillow whose triangles are needles as a spindle. A pillow is a component of two
/// triangles over the same three vertices: a closed surface of no volume, what the collapses leave
/// of a speck thinner than they may go (the smoke at iso 0.1: a sliver of field one voxel long
/// and a ten-thousandth across, which the isosurface meshes as 20 needles). Two of its vertices,
/// the farthest apart that the coarser level (`coarser`, as collapseNeedleEdges takes it) does not
/// lack, stay as the spindle's tips; the third goes. Three new vertices ring the middle of the
/// tips' segment, at the radius that makes the six triangles equilateral (0.35 of the segment's
/// length): the same from the same tips, so levels still nest. The spindle faces away from its
/// segment, or toward it where the field is higher there than around it (a void). The mesh stays
/// closed, manifold and oriented, with the same components and Euler characteristic; vertices
/// keep their order, the new ones last. Deterministic.
/// @return the number of pillows rebuilt.
long long inflatePillows(TriangleMesh& mesh, const Volume& volume, const std::vector<glm::dvec3>& coarser);

/// Removes the needles' corners that no collapse or flip could take: a tendril's tip or neck
/// thinner than a tenth of a voxel, where a ring of three points with one short edge is fanned to
/// a tip (a collapse would pinch the surface), or three points a thousandth of a voxel apart at a
/// voxel's corner (the smoke at iso 0.1 along y). The corners of a triangle past kLargestAspect
/// that the coarser level lacks (`coarser`, as collapseNeedleEdges takes it) go, one at a time and
/// then all of one needle's together, and the polygon around them is tiled anew: the tiling with
/// the fewest triangles facing against the part of the fan they cover, then the smallest largest
/// aspect ratio, with no edge or triangle the mesh has already. It is made where that lowers the
/// fan's worst aspect ratio, moves the surface by no more than `reach` (world units), and makes no
/// crease past a right angle where the fan had none; a tetrahedron's corner may go, and the two
/// triangles left over its other three make a pillow, a speck's shape at the coarser levels. Rounds
/// go on while a corner goes. The mesh stays closed, manifold and oriented, with the same
/// components and Euler characteristic, and levels still nest; vertices keep their order.
/// Deterministic: corners go in order of position.
/// @return the number of corners removed.
long long removeNeedleCorners(TriangleMesh& mesh, const std::vector<glm::dvec3>& coarser, double reach);

/// Tiles anew the fans that hold the needles the other passes leave, mostly where the three corners
/// of a triangle past kLargestAspect all stay (a coarser level has them): a corner fanned across a
/// slab over a contour a vertex per pixel, collinear with it, stays a needle under any flip. For
/// each needle, worst first, and each of its corners, parts of the corner's fan around the needle
/// (up to 12 triangles either side, one left) are tiled anew as removeNeedleCorners tiles its
/// holes, the corner staying on the polygon: the part and tiling with the smallest largest aspect
/// ratio is taken where that lowers the part's, moves the surface by no more than `reach` (world
/// units), keeps every new triangle within `bound`, and makes no crease past a right angle where
/// the part had none. Vertices stay as they are, so levels still nest; the mesh stays closed,
/// manifold and oriented, with the same components and Euler characteristic. Rounds go on while
/// one retiles a fan. Deterministic.
/// @return the number of fans tiled anew.
long long retileNeedleFans(TriangleMesh& mesh, double reach, const SurfaceBound& bound = {});

/// Moves the corners of the needles the other passes leave that the coarser level lacks
/// (`coarser`, as collapseNeedleEdges takes it), each no farther than `reach` (world units), to
/// where the largest aspect ratio of its triangles falls to kCollapseAspect with the least move,
/// or is lowest (a compass search), where that is kLargestAspect or less: a move that leaves a
/// needle is not made (splitNeedleEdges takes those). A void thinner than a hundredth of a voxel
/// meshed as a bipyramid whose ring is nearly in line (the smoke at iso 0.1 along x: 154) needs
/// its new ring vertex moved a fiftieth of a voxel. No triangle turns over, each keeps within
/// `bound`, and the surface moves no farther than the corner does. Triangles stay as they are, and
/// so do the coarser level's vertices; but a finer level would not have the corner where it went,
/// so only the top level may move its corners (a coarser level's moves, carried up, turned over
/// triangles that the finer levels add beside the corner). Deterministic: corners move in order
/// of position.
/// @return the number of corners moved.
long long moveNeedleCorners(TriangleMesh& mesh, const std::vector<glm::dvec3>& coarser, double reach,
                            const SurfaceBound& bound = {});

/// Splits the longest edge of each needle the other passes leave, worst first, at its midpoint (the
/// surface stays where it was), and moves the new vertex as moveNeedleCorners moves a corner: where
/// a short edge joins two vertices of the coarser level and its needle's third corner lies too far
/// for any move within `reach` (world units) (a void in the smoke at iso 0.1 sliced along z, 174),
/// the triangle on that edge halves and the new vertex, off the line, keeps the halves' neighbours
/// no needles. A split is kept where it lowers the worse of the two triangles on the edge. For the
/// top level only: a finer level would not have the new vertex. The mesh stays closed, manifold and
/// oriented; the new vertices come last. Deterministic.
/// @return the number of edges split.
long long splitNeedleEdges(TriangleMesh& mesh, double reach, const SurfaceBound& bound = {});

/// The edges the reconstruction collapses (collapseNeedleEdges), in voxels: the needles' short
/// edges lie mostly far below (tree, aorta: under 0.01 voxel), the rays' own spacing on a tube of a
/// few voxels far above. Every such edge of a triangle over kShortEdgeAspect, or of a speck (all
/// three edges that short), goes where no triangle turns over; twice this, the collapses folded the
/// surface (aspect 1e9 on the aorta's top level). The bands of smooth tubes lie under
/// kShortEdgeAspect (the phantom's worst is 9) and stay as tiled: collapsing their short edges near
/// a cap's apex left 44 angles under 5 degrees on the phantom's top level where there were none.
constexpr double kNeedleEdgeVoxels = 0.1;
constexpr double kShortEdgeAspect = 10.0;

/// Then the edges of the triangles over kCollapseAspect, up to this many voxels at the top level
/// (twice as far each level coarser, at most 8 times), go where that lowers the largest aspect
/// ratio around (the hollow Y's and the bean's are 0.1 to 0.3 voxel). Half the bound of issue 17,
/// so that a collapse also takes the triangles next to a needle down with it. The top level stays
/// within the voxel of the isosurface it was (hollow Y 0.71, bean 0.53 voxel). Longer edges of
/// such triangles go where the surface moves no farther than this reach (the needles left past
/// it have their short edge along a contour that is nearly straight there: the hollow Y's 0.33
/// voxel at the top level, the T branch's 0.66 at level 2, the twisting C's 0.31; the cone's tip
/// contour, 0.03 voxel across, against a band 304 voxels long at level 0).
constexpr double kNeedleReachVoxels = 0.3;
/// The largest aspect ratio a triangle may have (issue 17's bound): no collapse leaves a triangle
/// past it worse than the worst it takes away.
constexpr double kLargestAspect = 100.0;
constexpr double kCollapseAspect = kLargestAspect / 2.0;

/// The point of triangle abc nearest to p (Ericson, Real-Time Collision Detection, 5.1.5: by the
/// Voronoi regions of the corners, edges and face). A triangle of no area that none of the corner
/// and edge regions claims gives its corner a. Used by validation's distances and by the needle
/// collapses' measure of how far the surface moves.
glm::dvec3 closestOnTriangle(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c);

/// The point of triangle abc farthest from its corners: its circumcentre where that lies inside
/// (no angle is obtuse), else the middle of its longest edge. Where a triangle with its corners on
/// a smooth surface leaves it farthest, as far as one point tells.
glm::dvec3 farthestFromCorners(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c);

/// Triangles with an angle below this many degrees are counted as needles in reports.
constexpr double kNeedleDegrees = 5.0;

} // namespace pipetile
