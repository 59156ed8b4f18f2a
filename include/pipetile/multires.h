// pipetile — multires: levels of detail, from a volume to closed triangle meshes.
//
// A Reconstruction does the level-independent work once (slices, boundary loops, central points,
// contour correspondence, end-cap apexes); each level then casts its own rays and tiles. Level L
// casts baseRays * 2^L rays, plus, in a tube whose sections fold, rays from the next levels'
// angles where a fold hides detail (addFoldRays); every ray of level L is a ray of level L+1, so
// level L's vertices are a subset of level L+1's, bit for bit.
//
// Coarse levels also skip slices. Level L's rays are sagitta(L) = r (1 - cos(pi / n_L)) from a
// circle of radius r between two rays; a slice whose shape the interpolation of its tube
// neighbours predicts within that is worth no triangles at that level. So each tube picks its
// slices by halving: the span between two kept contours keeps its middle one at level L when some
// contour inside deviates from the neighbours' interpolation by more than sagitta(L), measured
// on the loops' radial profiles (contour.h) along the finest level's directions. That depends on
// the loops alone, not the level's rays, and sagitta shrinks as L grows, so the slices of level L
// are slices of level L+1: levels nest in slices as in rays, and triangles go where the error is
// (at 8 rays a tube needs few slices; at 64 it needs them all). MeshOptions::everySlice turns it off.
#pragma once

#include <pipetile/contour.h>
#include <pipetile/graph.h>
#include <pipetile/mesh_io.h>
#include <pipetile/slicer.h>
#include <pipetile/tiler.h>
#include <pipetile/volume.h>

#include <glm/vec3.hpp>

#include <array>
#include <map>
#include <optional>
#include <set>
#include <vector>

namespace pipetile {

struct EulerDifference; // validate.h

/// Which tiler joins adjacent contours.
enum class TilerKind {
    ContourTree, // the paper's: simultaneous traversal of contour trees, integer-only
    Optimal,     // baseline: minimum-area acceptable surface (Fuchs, Kedem & Uselton 1977)
    Greedy,      // baseline: shorter spanning edge first (Christiansen & Sederberg 1978)
};

struct MeshOptions {
    SliceOptions slicing;                     // axis and spacing of the slices
    int baseRays = 8;                         // n0: rays at level 0, in [3, 4096]
    int levels = 4;                           // levels of detail: 0 .. levels-1, in [1, 16]
    double minContourArea = 1.0;              // pixels^2: smaller cross-sections (below one pixel) are dropped
                                              // (and counted)
    int threads = 0;                          // 0: all cores; results do not depend on it
    TilerKind tiler = TilerKind::ContourTree; // what tiles the bands (caps are the same for all)
    bool everySlice = false;                  // tile every slice at every level, as the paper does; by
                                              // default a level skips the slices that its kept neighbours
                                              // predict within its rays' own error (Reconstruction)
};

/// One level of detail and what it took.
struct LevelMesh {
    int level = 0;
    int rays = 0;            // rays per contour at this level (the level's own)
    long long addedRays = 0; // rays the tubes added where folds hide detail, summed over
                             // tubes (each casts its added rays on all its contours)
    TriangleMesh mesh;
    double seconds = 0.0;           // ray casting and tiling of this level
    double castingSeconds = 0.0;    // of which casting rays (sampling, root finding, edge types);
                                    // for a refinement only the new rays', merged into the contours
    double tilingSeconds = 0.0;     // of which the tiler's: trees and traversal, or the DP / greedy
    double qualitySeconds = 0.0;    // of which the needle passes' (collapses, flips, spindles)
    std::size_t tilingBytes = 0;    // the tiler's working structures, summed over all bands
    int contours = 0;               // contours tiled
    int wallVertices = 0;           // boundary points added on contour edges no ray splits
                                    // (wallPoints, longChordPoints), the coarser levels' too;
                                    // their bands are tiled by least area
    int skippedContours = 0;        // contours of the tubes this level skips: their neighbours
                                    // predict them within the level's own error
    int ambiguousContours = 0;      // contours with more than one F edge in some sector
    long long ambiguousSectors = 0; // sectors with more than one F edge, over all contours
    long long crossings = 0;        // vertices on contours (the rest are end-cap apexes)
    int interpolationFallbacks = 0; // crossings left on the crack (no sign change nearby)
    int areaJunctionParts = 0;      // junction parts tiled by the minimum-area tiler: their polygon
                                    // gave no contour (it winds around no point inside it)
    int areaBands = 0;              // bands and junction parts tiled by the minimum-area tiler
                                    // where the contour trees paired points far out of register
                                    // (3 pixels farther than the other contour's nearest point)
    long long flips = 0;            // edges flipped to remove needles (quality.h, flipNeedles)
};

/// What the level-independent pass found; degenerate geometry is counted here, not thrown.
struct ReconstructionStats {
    int slices = 0;                // slice planes sampled
    int emptySlices = 0;           // planes that crossed nothing
    int contours = 0;              // contours kept, over all slices (end contours not included)
    int holes = 0;                 // of which bound a hole (inner walls of hollow pipes)
    int droppedSmall = 0;          // cross-sections below minContourArea
    int droppedUnwound = 0;        // loops that do not wind around their central point
    int droppedFlat = 0;           // lone contours with no apex either side: nothing to enclose
    int endContours = 0;           // contours added a quarter voxel inside where a tube ends
    int tubes = 0;                 // segments: chains of contours joined one to one (bands), each
                                   // closed at either end by a cap, a rim or a junction
    int addedPlanes = 0;           // planes added between slices where an event lies (bisection)
    int bandPlanes = 0;            // planes added inside a band alone, where the middle plane's loop
                                   // strays from the band (splitBand)
    int bandPatches = 0;           // bands meshed from their slab's cells, which stray from them
                                   // where the slab could not be halved (strayingBandPatch), or
                                   // whose top level strayed from the isosurface (strayingPieces)
    int endPatches = 0;            // tube ends meshed from their piece's cells: no end contour in
                                   // register, or a voxel plane shows more than the contours (closeEnd)
    int junctionPatches = 0;       // forks and merges meshed from their slab's cells: their parts
                                   // strayed from the isosurface at the top level (strayingPieces)
    int cellMatches = 0;           // ranges between voxel planes cut again where the cells' Euler
                                   // characteristic showed a handle (graph.h)
    int forks = 0, merges = 0;     // junctions: one contour joined to several (saddles)
    int saddles = 0;               // of which saddles: n - 1 per 1:n or n:1 junction
    int starts = 0, ends = 0;      // slab pieces where a tube begins (0:1) or ends (1:0)
    int rims = 0;                  // pieces where a wall and its hole end together
    int waists = 0;                // n:m pieces of walls (n, m >= 2) that bisection could not part:
                                   // a merge into a contour in the slab's middle, then a fork
    int keyholes = 0;              // forks and merges of a ring (a wall and its hole) cut open into
                                   // one contour, its hole being too small to share out (graph.h)
    int patches = 0;               // pieces meshed from their slab's cells (graph.h, SlabPatch): of
                                   // any other pattern (walls and holes n:m), or with handles the
                                   // pieces missed and the cells count
    int unresolvedEvents = 0;      // pieces of any other pattern: their contours are capped one by
                                   // one, so the mesh's topology differs from the isosurface there
    int unresolvedJunctions = 0;   // forks and merges whose contours could not be split into one
                                   // arc per partner: capped one by one as well
    long long eventEuler = 0;      // sum over the slab pieces of 2 - a - b (a patch's: its own
                                   // surface's): the isosurface's Euler characteristic as the slabs
                                   // see it
    int caps = 0;                  // tube ends closed by a cap (not a rim, a junction or a patch):
                                   // every level's Euler characteristic is caps - saddles + patchEuler
    long long patchEuler = 0;      // the patches' surfaces' Euler characteristics, summed
    int flatCaps = 0;              // caps with no apex found past the last slice (closed flat)
    int annularCaps = 0;           // hollow pipe rims: an outer and a hole contour ending in the
                                   // same plane, joined by an annulus (counted once, not as caps)
    int clippedCaps = 0;           // caps closed flat by ear clipping: no apex, or an end contour
                                   // that is not star-shaped
    long long longestBoundary = 0; // cracks in the longest boundary loop: rays beyond about this
                                   // many per contour meet the same pixels again and add no detail
    double seconds = 0.0;          // slicing, boundary walks and correspondence
};

/// The skeleton every level shares, as plain data (reports, and later centrelines and branch
/// labels): segments, the chains of contours joined by bands, and the junctions between them.
/// Positions are index-space w along the slicing axis.
struct Skeleton {
    struct Segment {
        bool hole = false; // the inner wall of a hollow pipe (or a void)
        double wFirst = 0.0, wLast = 0.0;
        int contours = 0;
        const char* bottom = "cap"; // "cap", "flat cap", "rim", "junction" or "patch"
        const char* top = "cap";
        int bottomJunction = -1, topJunction = -1;
    };
    struct Junction {
        EventKind kind = EventKind::Fork;
        double w = 0.0;       // the single contour's plane
        double crotchW = 0.0; // the hub's, on the surface where it got there
        int single = -1;      // segment ids
        std::vector<int> partners;
    };
    /// A slab piece whose pattern no construction handles: its contours are capped one by one.
    struct Unresolved {
        double wBelow = 0.0, wAbove = 0.0;
        int wallsBelow = 0, holesBelow = 0, wallsAbove = 0, holesAbove = 0;
    };
    /// A slab piece meshed from its cells (graph.h, SlabPatch).
    struct Patch {
        double wBelow = 0.0, wAbove = 0.0;
        int contours = 0; // the segment ends it joins
        int euler = 0;    // of its surface
    };
    std::vector<Segment> segments;
    std::vector<Junction> junctions;
    std::vector<Patch> patches;
    std::vector<Unresolved> unresolved;
};

/// Stateful: holds the slices' boundary loops and the tubes; builds any level on request.
class Reconstruction {
public:
    /// @throw UsageError for parameters out of range, or levels whose meshes would not fit in
    ///        memory (estimated from the contours found); Error if no slice crosses the object.
    Reconstruction(const Volume& volume, const MeshOptions& options);
    // Defined where the private state's types are complete (src/multires.cpp).
    ~Reconstruction();
    Reconstruction(const Reconstruction&);
    Reconstruction(Reconstruction&&) noexcept;
    Reconstruction& operator=(const Reconstruction&);
    Reconstruction& operator=(Reconstruction&&) noexcept;

    /// The finest level whose rays are still no denser than the boundary's pixels (levels above it
    /// add vertices but no detail), or levelCount() - 1 if all are.
    int finestUsefulLevel() const;

    int levelCount() const { return mOptions.levels; }
    const SlicePlan& plan() const { return mPlan; }
    const ReconstructionStats& stats() const { return mStats; }
    const MeshOptions& options() const { return mOptions; }

    /// The contour graph: planes (the plan's slices, then added ones) and the pieces joining them.
    const ContourGraph& graph() const { return mGraph; }
    Skeleton skeleton() const;
    /// Index-space w of every plane of the graph.
    const std::vector<double>& planePositions() const { return mPositions; }
    /// The isosurface's Euler characteristic layer by layer along the slicing axis (validate.h,
    /// isosurfaceEulerProfile): the one the graph compared its pieces with, else counted now.
    EulerProfile cellProfile() const;

    /// Casts the rays of `level` on the contours it keeps and tiles all tubes, from scratch.
    /// Thread-safe.
    LevelMesh buildLevel(int level) const;

private:
    friend class Refinement;
    using Contours = std::vector<std::vector<Contour>>; // per plane, per loop
    /// Pieces whose top level strays more than a voxel from the isosurface in an earlier build.
    struct StrayingPieces {
        std::set<std::array<int, 3>> junctions; // forks and merges: kind, single contour's plane and loop
        std::set<std::pair<int, int>> bands;    // bands: the lower contour's plane and loop
        // Forks and merges whose cells do not close: their slabs (index space along the axis),
        // halved to an eighth of the events' thickness (buildContourGraph's thinJunctions).
        std::vector<std::pair<double, double>> thinJunctions;
        // Bands whose own cells do not close, or in slabs as thin as the events': the voxel planes
        // around them (index space), whose whole range is meshed from its cells where that keeps
        // its pieces' count (patchWholeRanges).
        std::vector<std::pair<double, double>> bandRanges;
        // Tube ends whose end contours' bands strayed, meshed from their cells (patchEnd): 1 for a
        // top end, 0 for a bottom one, and the plane and loop of the tube's end member on the graph.
        std::set<std::array<int, 3>> ends;
        bool empty() const
        {
            return junctions.empty() && bands.empty() && thinJunctions.empty() && bandRanges.empty() && ends.empty();
        }
        /// Adds `more`'s pieces; whether any of them was new.
        bool add(const StrayingPieces& more);
    };
    /// The stages below, with the pieces `cellPieces` names meshed from their slab's cells where
    /// those close (resolveEvents).
    Reconstruction(const Volume& volume, const MeshOptions& options, StrayingPieces cellPieces);

    Contours castLevel(int level) const;
    /// `coarse`'s contours refined to `level`; a contour it skipped is cast with its group's rays.
    Contours refineContours(const Contours& coarse, int level) const;
    /// Rays where folds hide detail (contour.h, hiddenFolds): each ray group (a tube, or the two
    /// walls of a hollow pipe joined by an annulus, which share one band) halves every sector
    /// that a fold of any of its contours flags, and its contours are refined with the new rays,
    /// until no fold is flagged or the sectors are halved RaySet::kFoldHalvings times. So are
    /// sectors whose chords are too long for the thinnest slab beside their plane (contour.h,
    /// longChords), up to RaySet::kFoldDepth times: no tiling of such a band keeps its triangles
    /// under kLargestAspect. A sector's flag depends on its two rays alone, so the rays added at
    /// level L are added again at L+1: levels still nest, and a refined level equals the level
    /// built from scratch. The top level also halves sectors whose edges cut corners (contour.h,
    /// strayingChords), up to RaySet::kFoldDepth times; no level is built from it, so nesting
    /// holds.
    void addFoldRays(Contours& contours, int level) const;
    // Per plane of mPositions: the distance to the nearest other plane (index units, as pixels).
    std::vector<double> thinnestSlabs() const;
    /// The level's mesh from its contours: bands, caps and junctions (Assembly, multires.cpp).
    /// The vertices of `coarser` (the level below's, empty for level 0) stay (quality.h,
    /// collapseNeedleEdges).
    LevelMesh assemble(const Contours& contours, int level, const std::vector<glm::dvec3>& coarser) const;
    class Assembly;

    static constexpr int kNever = 1 << 30; // a level no reconstruction reaches (levels <= 16)
    // Defined in src/reconstruction_state.h: the tubes' working state, which no caller needs.
    struct SliceLoop;
    struct TubeEnd;
    struct Tube;
    struct Junction;
    struct Patch;
    struct SliceCounts;
    struct BandMiddle;

    static std::array<int, 3> keyOf(const Junction& junction);
    /// Whether a fork's or merge's part may fan across its slab: one tiled by the minimum-area
    /// tiler, or whose shape, from its partner's centre, differs from the partner's by more than
    /// kShapeChange pixels (a fan joins contours that differ by about its reach).
    bool partsMayFan(const Junction& junction) const;
    /// Whether a band may stray from the isosurface at its top level: one whose contours change
    /// shape by more than kShapeChange pixels (a fan joins contours that differ by about its
    /// reach), or lie farther apart than the smaller one's radius (the band leans across its
    /// slab, through whatever lies between: a crop of the smoke, a void a voxel across drifting
    /// two in one slab, 1.04 voxels off).
    static bool shapeMayStray(const SliceLoop& lower, const SliceLoop& upper);
    /// The forks and merges, and the bands that may stray (shapeMayStray), whose triangles at the
    /// top level, as it tiles them, stray more than a voxel from the isosurface as far as the
    /// field shows (Volume::surfaceWithin). Those whose cells close take them; a band's only in a
    /// slab thicker than the events' (the cells of a thinner one leave needles: two capsule trees
    /// sliced along x, up to 734 where such bands took them).
    /// Straying forks and merges whose cells do not close give their slabs' ranges instead
    /// (thinJunctions), and bands their ranges between voxel planes (bandRanges). Only the
    /// pieces whose slabs overlap one of `ranges` (of w) are asked.
    StrayingPieces strayingPieces(const std::vector<std::pair<double, double>>& ranges) const;

    /// A loop's contour with `rays`: cut against the plane's field, a waist's against its polygon
    /// (no field traced it); refined from `coarse` likewise.
    static Contour cut(const SliceLoop& loop, const RaySet& rays, const SlicePlane& plane);
    static Contour refine(const Contour& coarse, const SliceLoop& loop, const RaySet& rays, const SlicePlane& plane);

    // The stages of the constructor, in order.
    std::vector<SliceLoop> traceContours(double w, SliceCounts& counts) const;
    /// The finest level's ray count, at most 256 (the cost of comparing profiles grows with it).
    int profileDirections() const;
    void traceSlices();
    // The correspond and resolveEvents stages and their helpers, down to composeParts: graph.cpp.
    void correspond();
    void resolveEvents();
    /// Marks the ends, at plane s (`top`: the tubes' top ends), of a Rim piece's loops there (a
    /// wall and holes): aroundWall where its one hole lies around the wall, rim where its holes
    /// lie inside the wall (a pipe's rim, a face the grid's box cuts).
    void markRim(int s, const std::vector<int>& loops, bool top, const std::vector<std::vector<int>>& tubeOf);
    /// Joins the first plane's (`top`: the last plane's) contours that a piece past it holds by
    /// that piece's patch, meshed from its cells out to the empty plane past the grid's box; they
    /// stay capped one by one where its cells do not close.
    void patchPastTheBox(SlabPiece& piece, bool top, const std::vector<std::vector<int>>& tubeOf);
    bool makeJunction(const ContourGraph::Slab& slab, const SlabPiece& piece, Junction& junction) const;
    /// Whether the cells of the graph's piece that holds loop l of plane s, on its lower side
    /// (`lowerSide`) or its upper side, close with the piece's Euler characteristic.
    bool cellsClose(int s, int l, bool lowerSide) const;
    /// An n:m piece of walls (n, m >= 2) as a merge into a waist contour in the slab's middle
    /// plane (contour.h, waistAround), then a fork out of it: a genus-0 piece with n + m loops,
    /// as the slab's labelling counts it. Adds that plane; false (and the plane removed) if the
    /// loops make no waist or either junction does not split.
    bool makeWaist(const ContourGraph::Slab& slab, const SlabPiece& piece, Junction& merge, Junction& fork);
    /// The patch of a band piece whose slab stayed thicker than the events' thickness though its
    /// shape change asks for less (or whatever its shape change, with `anyShape`), where its cells
    /// close as an annulus and stray from the band's straight triangles; none otherwise.
    std::optional<SlabPatch> strayingBandPatch(const ContourGraph::Slab& slab, const SlabPiece& piece,
                                               bool anyShape) const;
    /// Planes for the band from loop `lowerLoop` of plane `below` to `upperLoop` of `above` alone,
    /// down to a quarter of the events' thickness: the middle plane's loop, where it joins the two
    /// one to one through either half and strays from the band's straight triangles, each added
    /// as a plane holding that loop alone. `middle` is the slab's middle plane, traced on first
    /// use and shared by the slab's bands. Appends the planes, in order of w, to `steps`. False
    /// where the middle plane's loops join the band otherwise than one to one (no plane added).
    bool splitBand(int below, int lowerLoop, int above, int upperLoop, BandMiddle& middle, std::vector<int>& steps);
    /// The graph's view of `loops`, a plane at w.
    static PlaneLoops planeLoopsOf(const std::vector<SliceLoop>& loops, double w);
    /// The pieces of the slab between planes `below` and `above` meshed from its cells (graph.h,
    /// patchPieces); -1 for either is the empty plane past the grid's box on that side.
    std::vector<std::optional<SlabPatch>> patchesOf(int below, int above,
                                                    const std::vector<const SlabPiece*>& pieces) const;
    /// Plane s's loops as the graph sees them.
    PlaneLoops planeLoops(int s) const;
    /// Each range between voxel planes in `missed` (the cells count fewer there than the slabs'
    /// pieces), or holding a piece whose patch has handles the range's cells do not count
    /// (patchFindsHandles), whose pieces, taken across the whole range and patched from their
    /// cells, add up to the cells' count: its slabs become one, the planes added between are
    /// dropped from the graph. Only once the cells are counted (mCells).
    void patchWholeRanges(const std::vector<EulerDifference>& missed);
    /// Whether a piece of the slab, patched from its cells, has handles: one that no construction
    /// fits (Unresolved), or a fork or merge that strayed in a first build with cells that did not
    /// close, which halving its slab could not resolve (in a range of thinJunctions).
    bool patchFindsHandles(const ContourGraph::Slab& slab) const;
    /// Appends the patch of `piece` between those planes and counts it, with the handles it finds
    /// (SlabPiece::handles); returns its index.
    int addPatch(int below, int above, SlabPiece& piece, SlabPatch&& surface);
    bool splitJunction(Junction& junction) const;
    /// Appends a split junction and counts it (its kind, keyhole and saddles); returns its index.
    int addJunction(Junction&& junction);
    /// The junction's parts, from its arcs and nodes (see Junction::Part).
    void composeParts(Junction& junction) const;
    void followCentres();
    /// Each part's view from its partner's central point, the partner moved where need be; for
    /// the junctions from `first` on.
    void centreParts(std::size_t first = 0);
    /// The central point of `loop` that follows `before`'s along their tube (see followCentres);
    /// `followed` (out) says whether it is `before`'s moved with the section, not a clear point
    /// found near it. `spacing`, the planes' distance apart, tells a section that changed from
    /// one that travelled (sectionChanged); 0 where unknown.
    static glm::dvec2 followedCentre(const SliceLoop& before, const SliceLoop& loop, bool* followed = nullptr,
                                     double spacing = 0.0);
    /// Whether `loop`'s centroid moved from `before`'s too far for the planes' `spacing` to be a
    /// tube travelling, and standing keeps the centre as deep as moving to `travelled` would.
    static bool sectionChanged(const SliceLoop& before, const SliceLoop& loop, const glm::dvec2& travelled,
                               double spacing);
    /// The distance between the planes of `tube`'s members i and k.
    double spacingBetween(const Tube& tube, std::size_t i, std::size_t k) const;
    /// Moves `loop`'s central point (view and profile) to followedCentre's; whether it moved.
    bool followCentre(const SliceLoop& from, SliceLoop& loop, bool& followed, double spacing,
                      bool onlyFollowed = false) const;
    /// The centres before the tube's member k follow its centre back, where that puts the bands
    /// in better register (see followCentres).
    void followBack(const Tube& tube, std::size_t k);
    SliceLoop& memberLoop(const Tube& tube, std::size_t k);
    // The ends' stage and its helpers, down to addRimContours: caps.cpp.
    void closeEnds();
    /// Moves a lone contour's central point (its view's) to the middle of its finest crossings
    /// where the one it has lies within a tenth of a pixel of one of them (closeEnds).
    void centreLoneContour(SliceLoop& member, const SlicePlane& plane) const;
    /// How far the next plane of the graph lies past plane w (toward +w for direction 1, -w for
    /// -1): the slab that holds an end there; infinite past the last plane.
    double roomPast(double w, double direction) const;
    /// Adds `loop`, traced on plane w, as the tube's new last (top) or first member.
    void appendEndContour(Tube& tube, bool top, double w, SliceLoop loop);
    /// Where the object goes on past the tube's end: its end contour, carried unchanged to the
    /// middle of the slab ahead, where the tubes on the other side meet it, becomes its end.
    void meetHalfway(Tube& tube, bool top);
    /// Adds one end contour past the tube's end on that side, if the object reaches on there;
    /// false if it added none (and marks the end unregistered where one was found out of register).
    bool addEndContour(Tube& tube, bool top, bool probeAnyway);
    /// The tube's end on that side: end contours, or the cells of the graph's piece that ends it
    /// where end contours leave out what the field shows (`voxelPlanes`: the loops of voxel planes
    /// traced so far, by w).
    void closeEnd(Tube& tube, bool top, bool probeAnyway, std::map<double, std::vector<BoundaryLoop>>& voxelPlanes);
    /// Index in tube.members of the tube's end member on that side that lies on a plane of the
    /// graph (end contours lie past it).
    std::size_t graphEnd(const Tube& tube, bool top) const;
    /// Whether a voxel plane between that end's plane of the graph and the graph's next plane shows
    /// a loop of the end's region more than kEndStray pixels beyond every contour of the end, or
    /// one that no contour of the end within half a voxel overlaps.
    bool reachesPastContours(const Tube& tube, bool top,
                             std::map<double, std::vector<BoundaryLoop>>& voxelPlanes) const;
    /// Closes the tube's end on that side by the cells of the graph's piece that ends it there,
    /// where they close it; false, with the end left as it was, if they do not.
    bool patchEnd(Tube& tube, bool top);
    /// A lone contour with no apex either side whose region the field fills to the middle of the
    /// slab past it: that end fans round an apex there, so its object is not dropped.
    void fanPastTheNextPlane(Tube& tube) const;
    /// Hollow pipes' rims: a hole and the wall around it ending in one plane, joined by an annulus;
    /// a wall around several such holes, by a face with those holes (joinRimFace).
    void joinRims();
    /// The ends markRim marked, each hole's with the wall it encloses, by an annulus.
    void joinHolesAroundWalls();
    /// Joins the two tubes' ends on that side by an annulus (TubeEnd::annulus).
    void joinAnnulus(int wall, int hole, bool top);
    /// Joins the wall tube's end and its holes' ends on that side by a Rim junction in their
    /// plane; false (nothing changed) if the wall's polygon does not split among them.
    bool joinRimFace(int wall, const std::vector<int>& holes, bool top);
    /// Joins them by the patch of the piece past the first or last plane that they alone bound,
    /// meshed from its cells out to empty space; false (nothing changed) where no such piece is, or
    /// its cells do not close.
    bool patchFace(int wall, const std::vector<int>& holes, bool top);
    /// Whether the wall `outer` and `hole` end in one plane on that side as a pipe's open rim.
    bool formRim(const Tube& outer, const Tube& hole, bool top) const;
    /// The contour on plane w that continues loop l of plane s past its tube's end, centred as a
    /// band to it pairs best; none if no loop there overlaps it and no other loop of the plane of
    /// `onGraph` (the tube's end contour on a plane of the graph: s and l, or those of an end
    /// contour before). `parted`: whether other loops there overlap it too (the end's region has
    /// parted into several summits by w, and the contour keeps one).
    std::optional<SliceLoop> endContourAt(int s, int l, bool hole, double w, const std::pair<int, int>& onGraph,
                                          bool& parted);
    /// Whether `candidate` overlaps a loop of plane s other than l (of its kind): the slab keeps
    /// those on other pieces than l's, so it is no end contour of l's tube.
    bool sharedWithOthers(int s, int l, const BoundaryLoop& candidate) const;
    /// A hollow pipe's rim: end contours of both walls where the wall ends, past their last slice.
    void addRimContours(Tube& outer, Tube& hole, bool top, double reach, double inset);
    void groupRays();
    /// Sets each tube member's fromLevel (see the top of this header).
    void chooseSlices();

    Volume mVolume;
    MeshOptions mOptions;
    SlicePlan mPlan;
    std::vector<double> mPositions;             // the plan's slices, then the end contours' planes
    std::vector<std::vector<SliceLoop>> mLoops; // per plane of mPositions
    std::vector<Tube> mTubes;
    std::vector<Junction> mJunctions;
    std::vector<Patch> mPatches;
    std::vector<Skeleton::Unresolved> mUnresolved;
    ContourGraph mGraph;
    std::optional<EulerProfile> mCells; // counted where the graph needed it (correspond())
    ReconstructionStats mStats;
    StrayingPieces mCellPieces;
    // Bands whose middle plane's loop splitBand measured more than half a pixel from them, under
    // the pixel that splits them: the top level's own tiling settles it (strayingPieces). The
    // lower contour's plane and loop.
    std::set<std::pair<int, int>> mNearBands;
};

/// Stateful: the contours of the current level, refined in place to the next (paper §4.3). Each
/// refinement casts only the rays between the current ones, inserts their crossings into the
/// contours, rebuilds the contour trees (linear in the contour) and tiles; the slices the level
/// newly keeps are cast in full. Level L's vertices are level L+1's, bit for bit, and every level
/// equals Reconstruction::buildLevel of it.
class Refinement {
public:
    /// Builds level 0. The reconstruction must outlive this object.
    explicit Refinement(const Reconstruction& reconstruction);

    int level() const { return mLevel; }
    const LevelMesh& mesh() const { return mMesh; }
    bool canRefine() const { return mLevel + 1 < mReconstruction->levelCount(); }

    /// Moves to the next level and returns its mesh; `seconds` is the refinement's time.
    /// @throw UsageError past the reconstruction's last level.
    const LevelMesh& refine();

private:
    const Reconstruction* mReconstruction;
    int mLevel = 0;
    Reconstruction::Contours mContours;
    LevelMesh mMesh;
};

/// Levels of detail over one vertex array, for programs that keep every level (a viewer, a
/// numpy caller): the finest level's vertices ordered coarse-first, so that level L's vertices
/// are the first vertexCounts[L] of them, and each level's triangles index that array.
struct NestedLevels {
    std::vector<glm::dvec3> vertices;             // the finest level's, world space
    std::vector<std::size_t> vertexCounts;        // per level, non-decreasing; the last is vertices.size()
    std::vector<std::vector<Triangle>> triangles; // per level, the level's own triangles renumbered
};

/// Renumbers `levels` (level 0 first, each the next one's coarser level, as Refinement builds
/// them) into NestedLevels. Levels nest bit for bit (multires above), so each vertex of level L is
/// found among level L+1's by its exact coordinates; equal positions are paired in order, which
/// keeps every level the same mesh up to renumbering. Linear-logarithmic in the vertices.
/// @throw InternalError if a vertex of a level is not a vertex of the next (an internal invariant).
NestedLevels nestLevels(const std::vector<LevelMesh>& levels);

/// Checks options against what the machine and the grid can support.
/// @throw UsageError naming the parameter and its allowed range.
void checkMeshOptions(const MeshOptions& options);

} // namespace pipetile
