// pipetile — contour: central point, ray casting, crossings, chain-code walk, edge classification
// (paper §3). Geometry is in pixel units of one slice plane; see slicer.h for the (u, v) axes.
// Functions throw only what their @throw says (besides std::bad_alloc); the others throw nothing.
#pragma once

#include <glm/common.hpp>
#include <glm/vec2.hpp>

#include <cstdint>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

namespace pipetile {

class SlicePlane;

/// The crack boundary of one connected set of inside pixels, walked with the inside on the left
/// (the paper's chain code, modified to follow pixel borders). Corner (i, j) of the lattice is the
/// point (i - 0.5, j - 0.5), the lower-left corner of pixel (i, j). Inside pixels are 8-connected.
struct BoundaryLoop {
    std::vector<glm::ivec2> corners; // one per unit crack, in walk order; the polygon closes
    std::vector<glm::dvec2> points;  // per crack, the zero of the field interpolated between its
                                     // inside and outside pixel centres: the marching-squares
                                     // polygon of the boundary, in walk order. Rays are cut
                                     // against it, so pixel staircases make no false folds.
    double area = 0.0;               // signed, pixels^2: > 0 counterclockwise (outer boundary),
                                     // < 0 clockwise (the boundary of a hole)
    glm::dvec2 centroid{0.0};        // area centroid of the polygon
    bool hole() const { return area < 0.0; }
};

/// Rays a tube adds between its level's own, where a fold hides the boundary from them
/// (see hiddenFolds) or, at the top level, where a chord cuts a corner (strayingChords). They
/// come from the same dyadic family: a sector is halved at most RaySet::kFoldDepth times, so
/// every ray lies on the grid of baseRays * 2^(level + kFoldDepth) evenly spaced angles, and the
/// rays of one level stay rays of the next.
struct AddedRays {
    std::vector<long> fine;             // every ray of the set: its index on that grid, ascending
    std::vector<int> rank;              // per grid index: its ray index in `fine`, or -1
    std::vector<glm::dvec2> directions; // per ray: unit direction
};

/// Which rays a contour is cast with: level L uses baseRays * 2^L rays at angles 2*pi*x / count,
/// so every ray of level L is also a ray of level L+1 (DESIGN.md, Rays), plus the rays its tube
/// added where folds hide detail (`added`; then ray indices count those too).
struct RaySet {
    static constexpr int kFoldHalvings = 2; // a sector is halved at most twice for a fold
    static constexpr int kFoldDepth = 3;    // and once more for a straying chord (top level) or a
                                            // chord too long for its slab (every level)

    RaySet(int baseRays = 8, int level = 0, std::shared_ptr<const AddedRays> added = nullptr)
        : baseRays(baseRays),
          level(level),
          added(std::move(added))
    {
    }

    int baseRays; // n0, at least 3 (with 2 rays, F and B could not be told apart)
    int level;
    std::shared_ptr<const AddedRays> added; // null: the level's own rays only

    int count() const { return added ? static_cast<int>(added->fine.size()) : baseRays << level; }
    int uniformCount() const { return baseRays << level; }
    /// The grid every ray lies on: the level's own rays, or with added rays kFoldDepth levels finer.
    long gridCount() const { return static_cast<long>(baseRays) << (level + (added ? kFoldDepth : 0)); }
    /// Grid index of ray `ray` (an index into this set).
    long gridIndex(int ray) const { return added ? added->fine[ray] : ray; }

    /// Whether sector x (from ray x to ray x+1) has been halved fewer than `halvings` times.
    bool canHalve(int sector, int halvings = kFoldDepth) const;
    /// These rays plus one in the middle of each listed sector that can still be halved.
    RaySet withMidpoints(const std::vector<int>& sectors) const;
    /// The next level: its own rays and the rays added here.
    RaySet next() const;
};

/// Crossing of a ray with the boundary (paper §3).
enum class CrossingKind : std::uint8_t {
    InOut, // the ray passes out of the object; the counterclockwise walk moves forward in angle
    OutIn, // the ray comes into the object; the walk moves backward in angle
};

/// Types of contour edges (paper §3). An edge joins two crossings that follow each other on the
/// boundary walk; its type depends only on ray indices and crossing kinds, never on coordinates.
enum class EdgeType : std::uint8_t {
    Forward,  // F: from ray x to ray x+1 (InOut -> InOut)
    Backward, // B: from ray x+1 to ray x (OutIn -> OutIn)
    DownIn,   // D_I: same ray, toward the centre, InOut -> OutIn
    DownOut,  // D_O: same ray, toward the centre, OutIn -> InOut
    UpIn,     // U_I: same ray, away from the centre, InOut -> OutIn
    UpOut,    // U_O: same ray, away from the centre, OutIn -> InOut
};

struct Crossing {
    int ray = 0; // ray index in [0, RaySet::count())
    CrossingKind kind = CrossingKind::InOut;
    int depth = 0;         // order along its ray, 0 = nearest the centre (integer, for the tree)
    double crackT = 0.0;   // distance from the centre to the loop's polygon: fixes order
    double t = 0.0;        // distance from the centre to the interpolated surface: fixes position
    glm::dvec2 point{0.0}; // in-plane position, pixel units
    int segment = 0;       // walk position: the loop polygon's segment the ray crosses, and
    long long along = 0;   // the order along it, in grid units of the ray set (refinement
                           // merges new crossings into old ones by it)
};

/// A contour: the crossings of one boundary loop in walk order, starting at the outermost InOut
/// crossing of ray 0, and the typed edges between them (edges[i] joins crossings[i] and
/// crossings[i+1], cyclically). A hole's loop is walked reversed, so that every contour winds
/// counterclockwise around its centre; `hole` tells the tiler to turn its triangles outward.
struct Contour {
    glm::dvec2 center{0.0};
    bool hole = false;
    RaySet rays;
    std::vector<Crossing> crossings;
    std::vector<EdgeType> edges;
    int interpolationFallbacks = 0; // crossings placed on the crack: no sign change found nearby
};

/// Walks every boundary loop of the plane, seeded from its east-facing cracks. The loops are in
/// the plane's pixel units and own their data (the plane may go once this returns).
/// @throw InternalError if a walk does not close (a broken invariant: a bug).
std::vector<BoundaryLoop> traceBoundaries(const SlicePlane& plane);

/// A point inside the region a loop encloses, and inside its marching-squares polygon (what rays
/// are cut against, and off it): its centroid when that lies inside, else the enclosed pixel farthest from the
/// boundary (chamfer distance; C-shaped sections) that lies inside the polygon; with `near`, the
/// one nearest `near` of those about as deep (a C's ridge: so a tube's central points follow it).
glm::dvec2 centralPoint(const BoundaryLoop& loop, const glm::dvec2* near = nullptr);

/// The enclosed pixel nearest `near`, inside the polygon, among those at least two pixels from the
/// boundary (chamfer distance), or about as deep as the deepest where none is.
glm::dvec2 clearPixelNear(const BoundaryLoop& loop, const glm::dvec2& near);

/// Whether a point lies inside the region a loop encloses and inside its polygon.
bool liesInside(const BoundaryLoop& loop, const glm::dvec2& point);

/// Whether the loop's centroid lies inside it (and its polygon): centralPoint() is the centroid.
bool centroidInside(const BoundaryLoop& loop);

/// How many pixels both loops enclose, `b` moved by `shift` pixels: how much of one section's
/// shape the next one continues, for a given motion between them.
long long overlapPixels(const BoundaryLoop& a, const BoundaryLoop& b, const glm::ivec2& shift);

/// Distance from a point to the loop's marching-squares polygon.
double boundaryClearance(const BoundaryLoop& loop, const glm::dvec2& point);

/// Even-odd test: does the loop's polygon enclose the point?
bool encloses(const BoundaryLoop& loop, const glm::dvec2& point);

/// A loop as seen from its central point, which is what rays are cut against at every level. The
/// angles are computed once here rather than once per level (an atan2 per polygon point).
struct LoopView {
    glm::dvec2 center{0.0};
    bool hole = false;
    std::vector<glm::dvec2> polygon; // the loop's points in contour order: a hole's reversed, so
                                     // that every contour winds counterclockwise around its centre
    std::vector<double> turns;       // angle of each polygon point around the centre, in turns,
                                     // in [0, 1)
    int winding = 0;                 // turns the polygon makes around the centre (0 for a centre
                                     // on it); rays give a contour only when it is 1
};

LoopView viewFrom(const BoundaryLoop& loop, const glm::dvec2& center);

/// The view of a polygon that no walk traced (a junction's part, graph.h: arcs of a contour
/// closed through its hub), given in contour order, counterclockwise around `center`.
LoopView viewOfPolygon(std::vector<glm::dvec2> polygon, const glm::dvec2& center);

/// A waist: one loop around several walls of one plane's (u, v) (an n:m slab piece's contours,
/// both planes; graph.h), for the piece to pass through where its saddles lie too close together
/// for planes to part them. The boundary of the union of their insides, traced from the signed
/// distance to them at the pixel centres, grown by half a pixel at a time until it is one region
/// (at most `maxGrowth` pixels); holes in it are filled. Empty (no corners) if the walls stay
/// apart.
BoundaryLoop waistAround(const std::vector<const std::vector<glm::dvec2>*>& walls, double maxGrowth);

/// Signed area of a polygon, pixels^2: > 0 counterclockwise.
double polygonArea(const std::vector<glm::dvec2>& polygon);

/// A polygon's centroid by area; std::nullopt where its signed area is 0.
std::optional<glm::dvec2> polygonCentroid(const std::vector<glm::dvec2>& polygon);

/// How deep a point lies inside the loop and every polygon at once: its distance to the nearest
/// of their edges, or -1 if it lies outside any.
double commonDepth(const BoundaryLoop& loop, const std::vector<const std::vector<glm::dvec2>*>& polygons,
                   const glm::dvec2& p);

/// The point of largest commonDepth, sought on a 64 x 64 grid over the box they share; returns its
/// depth (-1 where no point of the grid lies inside them all, and `point` is left as it was).
double deepestCommonPoint(const BoundaryLoop& loop, const std::vector<const std::vector<glm::dvec2>*>& polygons,
                          glm::dvec2& point);

/// Distance from a point to a closed polygon.
double polygonClearance(const std::vector<glm::dvec2>& polygon, const glm::dvec2& point);

/// Whether the point lies at least `clearance` from every segment of the closed polygon: as
/// polygonClearance(polygon, point) >= clearance, but segments whose box is farther are skipped.
bool clearOfPolygon(const std::vector<glm::dvec2>& polygon, const glm::dvec2& point, double clearance);

/// Where `directions` evenly spaced rays from the view's centre (angles 2*pi*k / directions) meet
/// the loop's polygon first and last: distances from the centre, pixel units. The loop's shape as
/// such rays see it, from the polygon alone (no root finding: far cheaper than castRays). Levels
/// compare neighbouring slices' profiles to find the slices they can skip (multires.h).
struct RadialProfile {
    std::vector<double> nearest, farthest; // per direction
};
RadialProfile radialProfile(const LoopView& view, int directions);
/// How much two loops' shapes differ: the largest difference of their profiles' nearest or
/// farthest crossing over the directions both have (pixels; infinite where a direction meets
/// one loop only, 0 with either profile empty).
double profileChange(const RadialProfile& p, const RadialProfile& q);

/// How far apart a band between two loops puts the points that rays of one direction meet, each
/// from its own loop's central point: the mean distance between the two profiles' nearest and
/// farthest crossings, in-plane, over the directions both have (pixels); infinite where no
/// direction has both.
double misregistration(const LoopView& a, const RadialProfile& p, const LoopView& b, const RadialProfile& q);

/// How wide a gap of a the band from a to b would fan across: for each point of a's polygon more
/// than `far` pixels from b's points, the segment to the nearest of them; the longest stretch of
/// such a segment that lies outside a's polygon between two stretches inside it (an arm of a that
/// b lacks, with air between it and b), in pixels; 0 for none.
double widestGapToward(const LoopView& a, const LoopView& b, double far);

/// Casts `rays` from the view's centre (pixels) against the loop and classifies the edges. `plane`
/// is only read during the call. The loop's points fix which crossings exist and their order; each
/// position is then refined to the root of the field interpolated along the ray, between the
/// neighbouring crossings of the same ray.
/// Returns an empty contour if the loop does not wind once around the centre.
/// @throw InternalError if an edge breaks the edge-type rules (a broken invariant: a bug).
Contour castRays(const LoopView& view, const RaySet& rays, const SlicePlane& plane);

/// Casts `rays` against a polygon of the skeleton (viewOfPolygon): every crossing lies on the
/// polygon itself (there is no field to refine it against). Empty if it does not wind once.
/// @throw InternalError as castRays.
Contour castPolygon(const LoopView& view, const RaySet& rays);

/// Refinement (paper §4.3): the same loop's contour with more rays, `rays` (which must hold every
/// ray of the coarse contour), or by default the next level's. Only the new rays are cast; the
/// coarse crossings are kept as they are and the new ones inserted by walk position. Identical to
/// casting every ray from scratch. `view` is the one the coarse contour was cast from.
/// @throw UsageError if `rays` lacks a ray of the coarse contour; InternalError as castRays.
Contour refineContour(const Contour& coarse, const LoopView& view, const SlicePlane& plane);
Contour refineContour(const Contour& coarse, const LoopView& view, const RaySet& rays, const SlicePlane& plane);

/// Folds that hide detail: where the walk leaves a ray and comes back to it without reaching the
/// next ray, the contour joins the two crossings by a chord along the ray, and the boundary
/// between (an arm's tip, a bulge) lies in the sector beside it, unseen. Returns, ascending and
/// once each, the sectors (x: from ray x to x+1) where that boundary lies farther than
/// `tolerance` pixels from its chord; a ray in the middle of each would see it.
std::vector<int> hiddenFolds(const Contour& contour, const LoopView& view, double tolerance);

/// Chords that cut corners: sectors (ascending, once each) where the walk between crossings of
/// two neighbouring rays strays farther than `tolerance` pixels from the edge joining them (a
/// branch's rounded tip far from the central point, seen by rays a few voxels apart there).
std::vector<int> strayingChords(const Contour& contour, const LoopView& view, double tolerance);

/// The polygon points that bring each contour edge that strays farther than `reach` pixels from
/// its walk within `tolerance` of it, where the rays cannot: per crossing k, the indices into
/// view.polygon (in walk order) that the Douglas-Peucker simplification of the walk from crossing
/// k to crossing k + 1 keeps. A wall that points at the central point is met by no ray between
/// its ends, however the sectors are halved (a trifurcation sliced along y: a 50-voxel chord
/// along the trunk, 1.3 voxels off).
std::vector<std::vector<int>> wallPoints(const Contour& contour, const LoopView& view, double reach, double tolerance);

/// The polygon points that cut contour edges into pieces about pieces[k] pixels long along their
/// walk (none where pieces[k] is 0): per crossing k, indices into view.polygon (walk order). A band
/// on an edge L long whose triangles stand h high has needles whatever its tiling once L is long
/// against h (longChords), and where the edge runs along a wall that points at the central point
/// no halving of its sector meets the wall between its ends (a cone sliced along its length:
/// edges of 112 voxels from a section's tip after three halvings).
std::vector<std::vector<int>> longChordPoints(const Contour& contour, const LoopView& view,
                                              const std::vector<double>& pieces);

/// Chords longer than `length` pixels between crossings of two neighbouring rays: sectors
/// (ascending, once each). A band across a thin slab has triangles as long as its chords and about
/// as high as the slab: needles where the chords are long (a straight wall seen from a central
/// point far along it).
std::vector<int> longChords(const Contour& contour, double length);

/// Edge type from two consecutive crossings (DESIGN.md, Edge types): integers only.
/// @throw InternalError if their rays and kinds fit no edge type: the walk that ordered them is
///        broken (a bug).
EdgeType classifyEdge(const Crossing& from, const Crossing& to, int rayCount);

/// Number of edges of a type; for a contour winding once, #F - #B equals the ray count.
int countEdges(const Contour& contour, EdgeType type);

/// True when every sector holds exactly one F edge (#F == ray count): paper §4.1.
bool isUnambiguous(const Contour& contour);

const char* toString(EdgeType type); // "F", "B", "D_I", "D_O", "U_I", "U_O"

} // namespace pipetile
