// pipetile — the state a Reconstruction keeps between its stages: the slices' loops, the tubes
// and the junctions. Private to the library (not installed): multires.h only declares these types,
// so that embedding programs neither see nor depend on them; src/multires.cpp, src/graph.cpp (the
// correspond and resolveEvents stages) and src/caps.cpp (the closeEnds stage) use them.
#pragma once

#include <pipetile/contour.h>
#include <pipetile/graph.h>
#include <pipetile/multires.h>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <utility>
#include <vector>

namespace pipetile {

// Slabs holding an event are halved until at most this thick, in voxels (correspond()). A band's
// cells in a slab no thicker leave needles (strayingBandPatch).
constexpr double kEventThickness = 0.5;
// Pixels a band's contours may change shape by before its slab is halved (correspond()).
constexpr double kShapeChange = 3.0;

// Whether the slab from wBelow to wAbove overlaps one of `ranges` (of w, as thinJunctions).
inline bool overlapsAny(const std::vector<std::pair<double, double>>& ranges, double wBelow, double wAbove)
{
    return std::any_of(ranges.begin(), ranges.end(),
                       [&](const std::pair<double, double>& r) { return wBelow < r.second && wAbove > r.first; });
}

struct Reconstruction::SliceLoop {
    BoundaryLoop loop;
    LoopView view;          // from its central point: what every level's rays are cut against
    RadialProfile profile;  // along profileDirections(): the graph's shape test, slice choice
    int group = -1;         // its tube's ray group (contours tiled together share their rays); -1:
                            // in no tube
    int fromLevel = kNever; // the coarsest level that tiles it; every finer level does too
    bool onPolygon = false; // no field traced it (a waist, makeWaist; a contour carried to a
                            // slab's middle, meetHalfway): rays are cut against its polygon
};
/// A slab's middle plane as splitBand sees it: its loops, and the pieces of either half slab.
struct Reconstruction::BandMiddle {
    bool traced = false;
    double w = 0.0;
    std::vector<SliceLoop> loops;
    std::vector<SlabPiece> lowerHalf, upperHalf;
};
struct Reconstruction::TubeEnd {
    bool hasApex = false;      // false: the cap is flat, over the contour's own vertices
    bool fan = false;          // fan around the apex: the end contour is star-shaped at the
                               // finest level (then at every level, as rays nest)
    glm::dvec3 apexIndex{0.0}; // index-space apex of the cap
    int junction = -1;         // the fork or merge this end joins (no cap); -1: none
    int annulus = -1;          // an outer wall's end: the hole tube whose end, in the same
                               // plane, it joins by an annulus (a hollow pipe's rim); a hole
                               // tube's end: the outer tube that closes it so. -1: a cap
    int patch = -1;            // the patch this end joins (no cap); -1: none
    bool aroundWall = false;   // a rim whose hole lies around its wall (a post standing in a
                               // cavity, the slab says): no end contours; joinRims pairs it
    bool rim = false;          // a pipe's rim: its wall and the hole inside it end together, the
                               // slab says; no end contours, whatever the field past it
    bool goesOn = false;       // the object goes on past it: a piece of the slab that no
                               // construction resolved (its loops are capped one by one)
    double wBound = 0.0;       // how far its end contours and apex may go (closeEnds)
    bool unregistered = false; // an end contour was found but could not be brought into register
    bool joined() const { return junction >= 0 || patch >= 0; } // closed by another surface
};
struct Reconstruction::Tube {
    std::vector<std::pair<int, int>> members; // (slice, loop) from first to last slice
    TubeEnd bottom, top;
    bool hole = false;
};
/// A fork or merge: one contour (`single`) split into arcs by cut points on its polygon, one
/// arc per contour on the other side (`many`), each arc tiled to its partner. Decided once.
struct Reconstruction::Junction : JunctionArcs {
    EventKind kind = EventKind::Fork;      // Fork: `single` lies below `many`; Merge: above;
                                           // Rim: a wall and its holes in one plane, where
                                           // their tubes begin (bottom) or end (top)
    bool top = false;                      // a Rim at the tubes' top ends
    std::pair<int, int> single{-1, -1};    // (plane, loop)
    std::pair<int, int> inner{-1, -1};     // a ring's hole inside `single`, or none
    std::vector<std::pair<int, int>> many; // the partners: arc k goes to many[owner[k]]
    std::vector<int> chordArcs;            // the arcs a chord closes (a gap's, a bud's
                                           // arc; for a ring every arc, closed from cut
                                           // k + 1 of the wall to the hole's, and back)
    Keyhole keyhole;                       // a ring cut open: `cuts` index its composite
                                           // contour, which stands for `single` (graph.h)
    // Nodes: the junction's own vertices, the same at every level: first those on the single
    // contour or its hole (nodeOn), the cuts (node k), the hole's cuts (node n + k) or a
    // keyhole's slit ends not already cuts; then the chords' middles, in chordArcs' order, and
    // the hub if there is one (where the chords from the cuts between bodies meet: their mean).
    // Hub and middles start in the single contour's plane and move along the axis toward the
    // partners onto the surface (the crotch), if they get there; a chord never joins two cuts
    // directly, so no cap of the same contour can share its edge (a slit's crossings join a wall
    // and its hole, which no cap does).
    std::vector<glm::dvec2> nodePoints;      // in-plane
    std::vector<glm::dvec3> nodeIndex;       // index space
    std::vector<std::pair<int, int>> nodeOn; // per node on a contour: (0, point of `single`)
                                             // or (1, point of `inner`)
    int nodeAt(int member, int point) const; // the node there, or -1
    /// Partner k's side of the junction as one polygon, a composite contour (TOPOLOGY.md):
    /// its arcs of `single` (and of `inner`) closed through the hub or the chords' middles,
    /// counterclockwise. Cast with the partner's rays at every level, it is tiled to the
    /// partner by the same integer band as any two contours.
    struct Part {
        struct Corner {
            int member = -1; // 0: a point of `single`'s polygon, 1: of `inner`'s; -1: neither
            int point = -1;  // its index in that polygon
            int node = -1;   // the node it is, or -1
        };
        std::vector<Corner> corners;
        std::vector<glm::dvec2> polygon; // the corners' points
        LoopView view;                   // from the partner's central point, when the polygon winds once
                                         // around it (centreParts); else no polygon: the minimum-area tiler
    };
    std::vector<Part> parts; // per partner
};

/// A slab piece meshed from its cells (graph.h, SlabPatch): its loops end the tubes below it and
/// start those above. Its vertices are the same at every level; its points on the loops join
/// their rings as extras, so the bands on the loops' other side run through them.
struct Reconstruction::Patch {
    int below = -1, above = -1; // planes; -1: the empty plane past the grid's box (patchFace)
    SlabPatch surface;
};

struct Reconstruction::SliceCounts {
    int small = 0, unwound = 0;
};

} // namespace pipetile
