// pipetile — graph: which contours of adjacent planes belong together, decided from the volume
// (TOPOLOGY.md). The isosurface inside the slab between two planes falls into connected pieces;
// each piece meets some loops of the plane below and some of the plane above, and its pattern
// (a loops below, b above) names the event there: a band (1:1), an end (1:0, 0:1), a fork (1:n),
// a merge (n:1), a rim (a wall and its hole ending together). A genus-0 piece with a + b
// boundary loops has Euler characteristic 2 - a - b, so the events' contributions add up to the
// isosurface's.
//
// Pieces are found by labelling the slab's voxels: the inside voxels (8-connected within a plane,
// as the boundary walk joins inside pixels, and joined across planes) and the outside voxels
// (4-connected within a plane, joined across planes). A loop separates one inside and one outside
// component of the slab; loops that separate the same two components lie on one piece. A slab
// where a loop of each plane simply overlaps one loop of the other (a tube between two slices)
// skips the labelling. Events are then refined by adding planes at dyadic positions inside the
// slab (bisect), so that a fork's saddle lies within a fraction of a voxel of a plane.
//
// graph.cpp also defines the reconstruction's correspond and resolveEvents stages (multires.h),
// which build its skeleton on this graph: junctions, waists, patches, a band's own planes.
//
// Nothing here throws, besides std::bad_alloc and what buildContourGraph's callbacks throw (passed
// through). Loops, centres and profiles are in the planes' pixel units; w is index space.
#pragma once

#include <pipetile/contour.h>
#include <pipetile/slicer.h>
#include <pipetile/volume.h>

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <utility>
#include <vector>

namespace pipetile {

/// What a slab's surface piece is, from its loops below and above.
enum class EventKind {
    Band,       // 1:1, the paper's band
    Start,      // 0:1, a tube begins (a minimum of the height on the surface): a cap
    End,        // 1:0, a tube ends (a maximum): a cap
    Fork,       // 1:n, n >= 2: n - 1 saddles (walls or holes; or a wall and its hole against one
                // wall: a lumen opening into a C, a ring breaking open); or a ring (a wall and
                // its hole) breaking into n walls: n saddles
    Merge,      // n:1, n >= 2: n - 1 saddles
    Rim,        // a wall and the holes inside it begin or end together (0:k+1, k+1:0): an annulus
                // for one hole, a face with k holes (k - 1 saddles) for more
    Unresolved, // any other pattern; its loops are closed by caps of their own (wrong topology)
};

const char* toString(EventKind kind); // "band", "start", "end", "fork", "merge", "rim", "unresolved"

/// One connected piece of the isosurface inside a slab: the loops it meets on either plane.
struct SlabPiece {
    std::vector<int> below, above; // loop indices in the lower and upper plane, ascending
    EventKind kind = EventKind::Unresolved;
    int handles = 0; // that its patch found (SlabPatch); a patch of k parts counts k - 1 fewer
    /// Its surface's share of the mesh's Euler characteristic: a sphere with a hole per loop (its
    /// loops add nothing), less 2 per handle.
    int euler() const { return 2 - static_cast<int>(below.size() + above.size()) - 2 * handles; }
};

/// The loops of one plane as the graph sees them.
struct PlaneLoops {
    double w = 0.0;                             // index-space position along the slicing axis
    std::vector<const BoundaryLoop*> loops;     // the plane's contours (dropped loops excluded)
    std::vector<glm::dvec2> centers;            // their central points
    std::vector<const RadialProfile*> profiles; // their radial profiles, all along the same
                                                // directions (or none: no shape test)
};

/// The empty plane a voxel past the grid's active box, below it or above it (`after`): the graph's
/// pieces past its first and last planes reach out to it (ContourGraph::beforeFirst, afterLast).
PlaneLoops pastTheBox(const Volume& volume, const SlicePlan& plan, bool after);

/// The pieces of the slab between `below` and `above` (below.w < above.w), each with its kind.
/// Every loop of either plane lies on exactly one piece.
std::vector<SlabPiece> connectThroughSlab(const Volume& volume, const SlicePlan& plan, const PlaneLoops& below,
                                          const PlaneLoops& above);

/// The kind of a piece from its pattern and which of its loops bound holes.
EventKind classify(const SlabPiece& piece, const PlaneLoops& below, const PlaneLoops& above);

/// A piece meshed from the slab's cells, where no construction from its contours fits it (an n:m
/// piece of walls and holes: fog voxels meeting along edges and corners within one slab), or where
/// the cells count handles that its loops do not show (multires.cpp, resolveEvents). Marching
/// cubes between the slab's layers (its two planes and the voxel planes between), on the planes'
/// pixels, with every saddle face decided as the slab's labelling joins it: so its surface
/// separates exactly the piece's inside region from its outside region, has the piece's topology
/// (handles included), and meets each plane in the piece's loops' own marching-squares polygons.
struct SlabPatch {
    struct Vertex {
        int plane = -1;            // 0: a point of a loop below, 1: above; -1: inside the slab
        int loop = -1, point = -1; // the loop (index into that plane's loops) and its point
        glm::dvec3 index{0.0};     // index-space position (a loop's point's too)
    };
    std::vector<Vertex> vertices;
    std::vector<std::array<std::uint32_t, 3>> triangles; // facing the outside, in index space
    int euler = 0; // of its surface: the piece's share of the mesh's Euler characteristic
};

/// The patch of each of `pieces` (of the slab between `below` and `above`), from one labelling
/// and one pass over the slab's cells; nothing for a piece whose cells do not close into one: a
/// cell's surface that touches two inside or two outside regions the labelling keeps apart (a
/// saddle face between a plane and a voxel plane, which no rule decides, joins its outside pair
/// unless only its inside pair is one region already, so it fails only where both pairs are
/// apart), or a loop the patch does not follow all round.
std::vector<std::optional<SlabPatch>> patchPieces(const Volume& volume, const SlicePlan& plan, const PlaneLoops& below,
                                                  const PlaneLoops& above, const std::vector<const SlabPiece*>& pieces);

/// The contour graph of a stack of planes: nodes are (plane, loop), and each slab between planes
/// adjacent in w holds the pieces that join them.
struct ContourGraph {
    struct Slab {
        int below = -1, above = -1; // plane indices
        std::vector<SlabPiece> pieces;
    };
    std::vector<int> order;  // plane indices by increasing w
    std::vector<Slab> slabs; // between order[k] and order[k + 1]
    // The pieces past the first and the last plane, out to empty space: each loop a disc of its
    // own, but where the grid's box cuts the object a wall and the holes open past its plane
    // are one piece (a face with holes). Empty where those planes hold no loops.
    std::vector<SlabPiece> beforeFirst, afterLast;
    int addedPlanes = 0; // planes added by bisection
    int cellMatches = 0; // ranges between voxel planes cut again to match the cells' Euler characteristic
};

/// The Euler characteristic of volumeToMesh's isosurface, layer by layer along the slicing axis
/// (validate.h's isosurfaceEulerProfile counts it from the cells): layers[k] is the share of the
/// cells whose origin lies at first + k (an edge between two layers counts in the higher). The sum
/// of layers[0..k] is the Euler characteristic of the isosurface's part below the voxel plane
/// first + k + 1, up to critical points within a cell of it.
struct EulerProfile {
    int first = 0;
    std::vector<long long> layers;
    /// Per voxel plane first + k: its voxels whose two neighbours along the axis both lie on the
    /// other side of the isosurface. A speck or void lying wholly between two voxel planes two
    /// apart is made of such voxels on the plane between.
    std::vector<long long> lone;
    long long total() const;
    long long between(double wBelow, double wAbove) const; // the layers whose origin is in [wBelow, wAbove)
    bool loneOn(double w) const;                           // whether voxel plane w has lone voxels
};

/// How far a band's two contours differ in shape, each seen from its own central point: the
/// largest change of the nearest or farthest crossing along any profile direction (pixels). A
/// tube that only moves or leans keeps its shape, and the band's straight triangles follow it;
/// where the shape changes fast (a tube's end collapsing, an arm growing out of a section), they
/// cut across the surface. Infinite where a direction meets one contour only, 0 without profiles.
double shapeChange(const PlaneLoops& below, int a, const PlaneLoops& above, int b);

/// Builds the graph of `planes` (the slicing plan's planes, in increasing w), adding planes where
/// a slab holds an event that is not a band or an end (until it is at most `minThickness` thick;
/// a fork or merge overlapping one of the `thinJunctions` ranges of w, down to an eighth of it),
/// or a band whose contours change shape by more than `maxShapeChange` pixels (down to a quarter of
/// `minThickness`): `addPlane(w)` traces a new plane and returns its index into `planes` (which it
/// appends to). A plane added below `minThickness` for a band's shape alone must leave bands on
/// both sides; if it does not, `dropLastPlane()` removes it again (from `planes` too) and the
/// slab stays whole. Added planes sit at dyadic fractions of their slab, so they never depend on
/// a level.
///
/// The pieces past the first and last planes (ContourGraph::beforeFirst, afterLast) are labelled
/// out to the first voxel plane past the grid's active box.
///
/// Then, where the graph holds a junction (a fork, a merge, a rim or an unresolved piece) and
/// `cells` is given, its profile (called once) is compared with the pieces between each two voxel
/// planes of the graph. Where they differ (a pinhole through a one-voxel wall joins two sides that
/// both planes show joined elsewhere: a handle inside a band's slab), the slabs there are cut by
/// planes every half, quarter, ... of the range (down to an eighth of `minThickness`) until their
/// pieces add up to the cells' and join the loops at the range's ends as the range did (a
/// component of their own between them may come in: a speck the slices missed), and then refined
/// as above; if they never do, the planes are dropped again and the slabs stay as they
/// were. A graph of bands and ends alone is not compared: counting
/// the cells would cost a single tube most of its time.
ContourGraph buildContourGraph(const Volume& volume, const SlicePlan& plan, std::vector<PlaneLoops>& planes,
                               double minThickness, double maxShapeChange, const std::function<int(double w)>& addPlane,
                               const std::function<void()>& dropLastPlane,
                               const std::function<EulerProfile()>& cells = {},
                               const std::vector<std::pair<double, double>>& thinJunctions = {});

/// How a junction's single contour is cut into arcs by its partners (decided once, on the
/// polygons, so every level has the same cuts). Each point of the polygon goes to the partner
/// whose polygon passes nearest (the planes share (u, v)); near a saddle the partners are its
/// lobes, so the owners form arcs, and a few points owned across a narrow gap are given to their
/// neighbours. Arc k runs from cuts[k] to cuts[k + 1] (polygon point indices, ascending,
/// cyclically) and goes to partner owner[k].
struct JunctionArcs {
    std::vector<int> cuts, owner;
    bool hubbed = true;         // every partner owns one arc (buds aside): the arcs close through
                                // a hub (a fork); else one partner owns several arcs and the others one
                                // each (a C whose gaps close around holes, lobes budding from a
                                // body): chords across the others' arcs close them and join the
                                // several's
    std::vector<int> innerCuts; // a ring's hole, split the same way: its arc k (from innerCuts[k]
                                // to innerCuts[k + 1]) also goes to owner[k]
    std::vector<int> buds;      // hubbed: the arcs of specks budding from a body beside the hub
                                // (a partner's one arc between two of another's); each closes by
                                // its own chord, and the body's arcs join across it
};

/// Splits `single` (and, for a ring, the hole `inner` inside it; null otherwise) into arcs by
/// `partners`. False if the arcs do not close any of the ways JunctionArcs describes. A ring's
/// hole that one partner is nearest all of is cut where it is nearest the wall's cuts (a gap
/// about to part), unless a chord to it crosses more than a pixel where `blocked` holds (the
/// partners' plane is inside: the hole opens elsewhere, and a keyhole cuts the ring open there).
bool splitIntoArcs(const std::vector<glm::dvec2>& single, const std::vector<glm::dvec2>* inner,
                   const std::vector<const std::vector<glm::dvec2>*>& partners, JunctionArcs& arcs,
                   const std::function<bool(const glm::dvec2&)>& blocked = {});

/// A ring (a wall and its hole, both counterclockwise) cut open into one composite contour
/// (TOPOLOGY.md's bridge, for a lumen that opens or closes): a slit from the wall's segment
/// (wall - 1, wall) to the hole's segment (hole, hole + 1). The composite runs along the wall
/// from point `wall` to point wall - 1, crosses to point `hole`, runs back along the hole to
/// point hole + 1 and crosses back: counterclockwise, the ring's material on its left. The slit
/// between the two crossings, a flat quadrilateral of that material, is left out of it (the
/// reconstruction tiles it flat, facing the partners).
struct Keyhole {
    int wall = -1, hole = -1;
    int wallSize = 0, holeSize = 0;
    double blocked = 0.0; // pixels of the slit's middle line where the partners' plane is inside
    bool open() const { return wall >= 0; }
    /// Point q of the composite as (0, wall point) or (1, hole point).
    std::pair<int, int> at(int q) const;
    int size() const { return wallSize + holeSize; }
};

/// Where to cut a ring open when its hole is too small for every partner to own a part of it (a
/// C closing around a new lumen while another branch joins it; a ring breaking where a thin hole
/// meets its wall): the slit, inside the ring's material (its two crossings cross neither
/// polygon), along which `blocked` (the partners' plane is inside there) holds over the least
/// length, then the shortest: the partners' gap that the ring's material closes. False if no
/// slit crosses neither polygon. A slit is kept clear of `apart` (another junction's keyhole of
/// the same ring, on its other side), whose flat face in the plane it would otherwise cover.
bool chooseKeyhole(const std::vector<glm::dvec2>& wall, const std::vector<glm::dvec2>& hole,
                   const std::function<bool(const glm::dvec2&)>& blocked, Keyhole& keyhole,
                   const Keyhole* apart = nullptr);

/// The keyhole's composite contour, point q being keyhole.at(q)'s.
std::vector<glm::dvec2> keyholePolygon(const std::vector<glm::dvec2>& wall, const std::vector<glm::dvec2>& hole,
                                       const Keyhole& keyhole);

} // namespace pipetile
