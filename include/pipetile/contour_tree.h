// pipetile — contour_tree: the paper's contour trees (§4.1), built from integers only.
//
// How this project reads the paper's rules (its figures are missing; DESIGN.md, worked example):
// a contour tree is a parse of the contour's cyclic string of edge types.
//  [1]  Level-1 node x stores one F edge of sector x: the main path crosses every sector once.
//  [1'] In an ambiguous sector (t > 1 F edges) the caller ranks the candidates (geometrically:
//       closest to the neighbour contour's F edge of the sector) and the builder takes the best
//       ranked one that keeps the main path in walk order. Without ranks, the outermost F edge.
//       multires ranks per band: the lower contour against the upper one's tree, then the upper
//       against that choice, so a contour may keep different F edges towards its two neighbours.
//  [2]  What lies between two consecutive main-path F edges is an excursion on one ray x. An
//       excursion that starts upward (away from the centre) hangs as the left child of level-1
//       node x; one that starts downward as the right child of level-1 node x-1.
//  [3]  Every non-F edge of an excursion is a leaf edge node.
//  [9]  An excursion that leaves its ray by F and comes back by B (or leaves by B and comes back
//       by F) encapsulates a sub-excursion on the next ray: it becomes one internal node of the
//       type the encapsulated part has (`F U_I B` is a composite U_I), with the F/B leaves and
//       the sub-excursion's nodes as children. Its direction is that of its first inner item.
//  [5]  An _I item and an _O item of the same direction next to each other (either order; the
//       O-then-I order is the paper's U_R / D_R) make a U or D node.
//  [8]  X_I, a node of the opposite direction, X_O (X is U or D) make an X node of three children.
//  [6][7] The nodes left on one excursion are gathered under one node, typed by the first of them.
// The numbering skips [4], as the paper's does.
#pragma once

#include <pipetile/contour.h>

#include <cstdint>
#include <string>
#include <vector>

namespace pipetile {

enum class NodeKind : std::uint8_t {
    Root,     // n level-1 children
    LevelOne, // stores a main-path F edge; children: [U excursion, D excursion] (either may be absent)
    Edge,     // a leaf: one contour edge of the given type (rule [3]; F or B inside rule [9])
    Up,       // internal node of direction U (rules [5]-[9])
    Down,     // internal node of direction D
};

struct TreeNode {
    NodeKind kind = NodeKind::Edge;
    EdgeType type = EdgeType::Forward; // Edge: its type; Up/Down made by rule [9]: the composite's
                                       // type (U_I, U_O, D_I, D_O); otherwise UpIn/DownIn
    int rule = 0;                      // building rule that made the node (1, 2, 3, 5, 6, 7, 8, 9)
    int edge = -1;                     // Edge and LevelOne: the contour edge (edge i joins crossings
                                       // i and i+1)
    int left = -1, right = -1;         // LevelOne: U child and D child (node ids), or -1
    int firstEdge = -1, edgeCount = 0; // the run of contour edges below the node (cyclic)
    std::vector<int> children;         // Root, Up, Down: node ids in walk order
};

/// Integer description of a contour: what the tree builder and the traversal may look at.
struct ContourString {
    int rays = 0;                // n
    std::vector<EdgeType> edges; // edges[i] joins crossing i and crossing i+1 (cyclically)
    std::vector<int> ray;        // ray index of each crossing
    std::vector<int> depth;      // order of each crossing along its ray, 0 = nearest the centre
};

/// The integer description of a contour (its geometry left out).
ContourString contourString(const Contour& contour);

/// Sort key of a crossing in the simultaneous traversal: crossings of two contours are met in
/// increasing key order, so equal positions in the two trees meet.
struct TraversalKey {
    int sector = 0; // main-path position: crossings up to and including the start of F_x have x
    int slot = 0;   // 0: end of F_{x-1}; 1: D excursion; 2: U excursion; 3: start of F_x
    int item = 0;   // child of the excursion node (traversal rules 2-3: children by position)
    int sub = 0;    // crossing within that child
    bool operator<(const TraversalKey& o) const;
    bool operator<=(const TraversalKey& o) const { return !(o < *this); }
};

/// Stateful: a contour's tree, with the traversal keys of its crossings.
class ContourTree {
public:
    /// @param rank optional rule [1'] preference per sector: rank[x][k] for the k-th F edge of
    ///        sector x in walk order from crossing 0, lower is better; empty: outermost first.
    /// @throw UsageError if the string does not wind once (#F - #B != n), or its ray and depth
    ///        lists do not match its edges in length.
    explicit ContourTree(const ContourString& contour, const std::vector<std::vector<int>>& rank = {});

    int rays() const { return mRays; }
    const std::vector<TreeNode>& nodes() const { return mNodes; }
    int root() const { return 0; }
    int levelOne(int x) const { return 1 + x; }
    /// The F edge stored in level-1 node x.
    int mainEdge(int x) const { return mNodes[levelOne(x)].edge; }
    /// Traversal key of every crossing.
    const std::vector<TraversalKey>& keys() const { return mKeys; }
    /// Ray index of every crossing (what the tiler aligns excursions that parse differently by).
    const std::vector<int>& crossingRays() const { return mCrossingRays; }
    /// Index of the crossing where F_0 starts: the traversal begins there.
    int startCrossing() const { return mStart; }
    /// Number of sectors holding more than one F edge.
    int ambiguousSectors() const { return mAmbiguous; }
    /// Bytes of the tree's working structures (nodes, their child lists, traversal keys).
    std::size_t bytes() const;
    /// The tree as an S-expression, e.g. "(R (1 F) (1 F U:(5 U_I U_O)) ...)", for tests and debugging.
    std::string toString() const;

    /// F edges of each sector, in walk order from crossing 0.
    static std::vector<std::vector<int>> forwardEdges(const ContourString& contour);

private:
    int parseExcursion(const ContourString& c, int from, int to);
    int parseItems(const ContourString& c, int from, int to, std::vector<int>& items);

    int mRays = 0;
    int mStart = 0;
    int mAmbiguous = 0;
    std::vector<TreeNode> mNodes;
    std::vector<TraversalKey> mKeys;
    std::vector<int> mCrossingRays;
};

} // namespace pipetile
