// pipetile — contour_tree: the paper's contour trees (§4.1), built from integers only.
// Integer-only translation unit (see CMakeLists.txt): no floating point may appear here.

#include <pipetile/contour_tree.h>
#include <pipetile/error.h>

#include <algorithm>

namespace pipetile {

namespace {

bool isUp(EdgeType t)
{
    return t == EdgeType::UpIn || t == EdgeType::UpOut;
}
bool isIn(EdgeType t)
{
    return t == EdgeType::UpIn || t == EdgeType::DownIn;
}
bool sameRay(EdgeType t)
{
    return t != EdgeType::Forward && t != EdgeType::Backward;
}

// What rules [5]-[8] look at in an item of an excursion.
enum class Io { In, Out, Paired };

} // namespace

bool TraversalKey::operator<(const TraversalKey& o) const
{
    if (sector != o.sector) return sector < o.sector;
    if (slot != o.slot) return slot < o.slot;
    if (item != o.item) return item < o.item;
    return sub < o.sub;
}

ContourString contourString(const Contour& contour)
{
    ContourString s;
    s.rays = contour.rays.count();
    s.edges = contour.edges;
    s.ray.reserve(contour.crossings.size());
    s.depth.reserve(contour.crossings.size());
    for (const Crossing& c : contour.crossings) {
        s.ray.push_back(c.ray);
        s.depth.push_back(c.depth);
    }
    return s;
}

std::vector<std::vector<int>> ContourTree::forwardEdges(const ContourString& c)
{
    std::vector<std::vector<int>> f(c.rays);
    for (std::size_t i = 0; i < c.edges.size(); ++i)
        if (c.edges[i] == EdgeType::Forward) f[c.ray[i]].push_back(static_cast<int>(i));
    return f;
}

ContourTree::ContourTree(const ContourString& c, const std::vector<std::vector<int>>& rank)
    : mRays(c.rays),
      mCrossingRays(c.ray)
{
    const int m = static_cast<int>(c.edges.size());
    int winding = 0;
    for (EdgeType t : c.edges) winding += t == EdgeType::Forward ? 1 : t == EdgeType::Backward ? -1 : 0;
    if (m == 0 || c.rays < 1 || winding != c.rays || static_cast<int>(c.ray.size()) != m ||
        (!c.depth.empty() && static_cast<int>(c.depth.size()) != m))
        throw UsageError("ContourTree: the contour does not wind once around its centre (#F - #B != n)");

    // Rules [1] / [1']: one F edge per sector, in walk order, each crossing its own sector level.
    // Count the sectors the walk crosses from F_0 (F +1, B -1): it ends one turn on, at n. A
    // section that spirals (an arm curling more than a turn around the centre, as noise makes)
    // crosses sector x also at levels x - n, x + n, ...; an F edge a turn away would leave an
    // excursion that does not come back to its ray. So F_x must cross level x. The preferred
    // candidate of sector 0 fixes F_0; each later sector takes its preferred candidate of level x
    // if it comes after F_{x-1} on the walk, else the first one that does. One always does: after
    // its last crossing of level x - 1 the walk stays above x - 1 and still has to cross x.
    // The F edges of sector x, in walk order: edges[first[x]] .. edges[first[x + 1] - 1]
    // (forwardEdges() without a vector per sector: this runs for every contour of every level).
    std::vector<int> first(c.rays + 1, 0), forward(static_cast<std::size_t>(m));
    for (int i = 0; i < m; ++i)
        if (c.edges[i] == EdgeType::Forward) ++first[c.ray[i] + 1];
    for (int x = 0; x < c.rays; ++x) first[x + 1] += first[x];
    {
        std::vector<int> next(first.begin(), first.end() - 1);
        for (int i = 0; i < m; ++i)
            if (c.edges[i] == EdgeType::Forward) forward[next[c.ray[i]]++] = i;
    }
    auto candidate = [&](int x, int k) { return forward[first[x] + k]; };
    auto candidateCount = [&](int x) { return first[x + 1] - first[x]; };
    auto preferred = [&](int x, auto&& eligible) {
        int best = -1;
        for (int k = 0; k < candidateCount(x); ++k) {
            if (!eligible(candidate(x, k))) continue;
            const bool better = best < 0 ? true
                                : rank.empty()
                                    ? c.depth.empty() ? false : c.depth[candidate(x, k)] > c.depth[candidate(x, best)]
                                    : rank[x][k] < rank[x][best];
            if (better) best = k;
        }
        return best < 0 ? -1 : candidate(x, best);
    };
    for (int x = 0; x < c.rays; ++x) {
        PIPETILE_ASSERT(candidateCount(x) > 0, "ContourTree: a sector without an F edge");
        mAmbiguous += candidateCount(x) > 1 ? 1 : 0;
    }
    mStart = preferred(0, [](int) { return true; });
    auto rotated = [&](int edge) { return (edge - mStart + m) % m; }; // position on the walk from F_0
    std::vector<int> level(static_cast<std::size_t>(m));              // sector level each edge starts at, from F_0
    for (int i = 0, lifted = 0; i < m; ++i) {
        const int edge = (mStart + i) % m;
        level[edge] = lifted;
        lifted += c.edges[edge] == EdgeType::Forward ? 1 : c.edges[edge] == EdgeType::Backward ? -1 : 0;
    }
    std::vector<int> mainPath(c.rays + 1);
    mainPath[0] = 0;
    for (int x = 1; x < c.rays; ++x) {
        int chosen = rotated(preferred(x, [&](int edge) { return level[edge] == x; }));
        if (chosen <= mainPath[x - 1]) {
            chosen = m;
            for (int k = 0; k < candidateCount(x); ++k)
                if (level[candidate(x, k)] == x && rotated(candidate(x, k)) > mainPath[x - 1])
                    chosen = std::min(chosen, rotated(candidate(x, k)));
        }
        mainPath[x] = chosen;
    }
    mainPath[c.rays] = m;

    // Nodes: root, then the n level-1 nodes (rule [1]), then excursions.
    mNodes.resize(1 + c.rays);
    mNodes[0].kind = NodeKind::Root;
    mNodes[0].rule = 1;
    mNodes[0].firstEdge = mStart;
    mNodes[0].edgeCount = m;
    mNodes[0].children.reserve(c.rays);
    for (int x = 0; x < c.rays; ++x) {
        TreeNode& n = mNodes[levelOne(x)];
        n.kind = NodeKind::LevelOne;
        n.rule = 1;
        n.edge = (mStart + mainPath[x]) % m;
        n.firstEdge = n.edge;
        n.edgeCount = 1;
        mNodes[0].children.push_back(levelOne(x));
    }

    mKeys.assign(m, TraversalKey{});
    for (int x = 0; x < c.rays; ++x) {
        const int crossing = (mStart + mainPath[x]) % m;
        mKeys[crossing] = {x, 3, 0, 0};
    }
    for (int x = 0; x < c.rays; ++x) {
        // The excursion on ray x+1: edges strictly between F_x and F_{x+1}.
        const int from = mainPath[x] + 1, to = mainPath[x + 1];
        if (from >= to) continue;
        const int ray = (x + 1) % c.rays;
        const int node = parseExcursion(c, from, to);
        const bool up = mNodes[node].kind == NodeKind::Up;
        // Rule [2]: U hangs left of level-1 node `ray`, D right of level-1 node x (= ray - 1).
        if (up)
            mNodes[levelOne(ray)].left = node;
        else
            mNodes[levelOne(x)].right = node;
        // Keys: the end of F_x, then the excursion's crossings by child and position; the last
        // excursion edge ends where F_{x+1} starts, which keeps its main-path key.
        mKeys[(mStart + from) % m] = {x + 1, 0, 0, 0};
        const std::vector<int>& items = mNodes[node].children;
        for (int j = 0; j < static_cast<int>(items.size()); ++j) {
            const TreeNode& item = mNodes[items[j]];
            for (int s = 0; s < item.edgeCount; ++s) {
                const int edgePosition = rotated(item.firstEdge) + s;
                if (edgePosition + 1 >= to) continue;
                mKeys[(mStart + edgePosition + 1) % m] = {x + 1, up ? 2 : 1, j, s};
            }
        }
    }
}

// Items of edges [from, to) (walk positions from F_0): leaves (rule [3]) and rule-[9] composites.
int ContourTree::parseItems(const ContourString& c, int from, int to, std::vector<int>& items)
{
    const int m = static_cast<int>(c.edges.size());
    auto edgeAt = [&](int position) { return (mStart + position) % m; };
    auto leaf = [&](int position) {
        TreeNode n;
        n.kind = NodeKind::Edge;
        n.type = c.edges[edgeAt(position)];
        n.rule = 3;
        n.edge = n.firstEdge = edgeAt(position);
        n.edgeCount = 1;
        mNodes.push_back(n);
        return static_cast<int>(mNodes.size()) - 1;
    };
    for (int k = from; k < to;) {
        const EdgeType t = c.edges[edgeAt(k)];
        if (sameRay(t)) {
            items.push_back(leaf(k));
            ++k;
            continue;
        }
        // Rule [9]: leave by F (B), come back by the matching B (F) onto the same ray.
        int level = 0, close = -1;
        for (int j = k; j < to; ++j) {
            const EdgeType u = c.edges[edgeAt(j)];
            level += u == EdgeType::Forward ? 1 : u == EdgeType::Backward ? -1 : 0;
            if (level == 0) {
                close = j;
                break;
            }
        }
        PIPETILE_ASSERT(close >= 0, "ContourTree: unbalanced excursion");
        std::vector<int> inner;
        const int open = leaf(k);
        parseItems(c, k + 1, close, inner);
        const int shut = leaf(close);
        TreeNode n;
        n.rule = 9;
        n.firstEdge = edgeAt(k);
        n.edgeCount = close - k + 1;
        // The composite runs InOut -> OutIn when it leaves forward (F ... B), else OutIn -> InOut;
        // its direction is that of its first inner item.
        const bool in = t == EdgeType::Forward;
        const bool up = inner.empty()                                  ? true
                        : mNodes[inner.front()].kind == NodeKind::Edge ? isUp(mNodes[inner.front()].type)
                                                                       : mNodes[inner.front()].kind == NodeKind::Up;
        n.kind = up ? NodeKind::Up : NodeKind::Down;
        n.type = up ? (in ? EdgeType::UpIn : EdgeType::UpOut) : (in ? EdgeType::DownIn : EdgeType::DownOut);
        n.children.push_back(open);
        n.children.insert(n.children.end(), inner.begin(), inner.end());
        n.children.push_back(shut);
        mNodes.push_back(n);
        items.push_back(static_cast<int>(mNodes.size()) - 1);
        k = close + 1;
    }
    return static_cast<int>(items.size());
}

// One excursion: its items reduced by rules [5] and [8], then gathered by [6]/[7].
int ContourTree::parseExcursion(const ContourString& c, int from, int to)
{
    std::vector<int> items;
    parseItems(c, from, to, items);
    auto io = [&](int id) {
        const TreeNode& n = mNodes[id];
        if (n.kind == NodeKind::Edge || n.rule == 9) return isIn(n.type) ? Io::In : Io::Out;
        return Io::Paired;
    };
    auto up = [&](int id) {
        const TreeNode& n = mNodes[id];
        return n.kind == NodeKind::Edge ? isUp(n.type) : n.kind == NodeKind::Up;
    };
    auto combine = [&](int rule, bool isUpNode, std::vector<int> children) {
        TreeNode n;
        n.kind = isUpNode ? NodeKind::Up : NodeKind::Down;
        n.type = isUpNode ? EdgeType::UpIn : EdgeType::DownIn;
        n.rule = rule;
        n.firstEdge = mNodes[children.front()].firstEdge;
        for (int child : children) n.edgeCount += mNodes[child].edgeCount;
        n.children = std::move(children);
        mNodes.push_back(n);
        return static_cast<int>(mNodes.size()) - 1;
    };
    for (bool changed = true; changed;) {
        changed = false;
        // Rule [5]: an In and an Out item of one direction, next to each other.
        for (std::size_t i = 0; i + 1 < items.size() && !changed; ++i) {
            const Io a = io(items[i]), b = io(items[i + 1]);
            if (a != Io::Paired && b != Io::Paired && a != b && up(items[i]) == up(items[i + 1])) {
                items[i] = combine(5, up(items[i]), {items[i], items[i + 1]});
                items.erase(items.begin() + static_cast<std::ptrdiff_t>(i) + 1);
                changed = true;
            }
        }
        // Rule [8]: X_I, a node of the other direction, X_O.
        for (std::size_t i = 0; i + 2 < items.size() && !changed; ++i) {
            if (io(items[i]) == Io::In && io(items[i + 1]) == Io::Paired && io(items[i + 2]) == Io::Out &&
                up(items[i]) == up(items[i + 2]) && up(items[i + 1]) != up(items[i])) {
                items[i] = combine(8, up(items[i]), {items[i], items[i + 1], items[i + 2]});
                items.erase(items.begin() + static_cast<std::ptrdiff_t>(i) + 1,
                            items.begin() + static_cast<std::ptrdiff_t>(i) + 3);
                changed = true;
            }
        }
    }
    // Rules [6]/[7]: gather what is left under one node (its children are what the traversal
    // pairs); a single paired node is the excursion itself.
    if (items.size() == 1 && io(items[0]) == Io::Paired) return items[0];
    bool allSame = true;
    for (int id : items) allSame = allSame && up(id) == up(items.front());
    return combine(allSame ? 6 : 7, up(items.front()), items);
}

std::size_t ContourTree::bytes() const
{
    std::size_t total = sizeof(*this) + mNodes.capacity() * sizeof(TreeNode) + mKeys.capacity() * sizeof(TraversalKey) +
                        mCrossingRays.capacity() * sizeof(int);
    for (const TreeNode& n : mNodes) total += n.children.capacity() * sizeof(int);
    return total;
}

std::string ContourTree::toString() const
{
    std::string s;
    auto write = [&](auto&& self, int id) -> void {
        const TreeNode& n = mNodes[id];
        switch (n.kind) {
        case NodeKind::Root:
            s += "(R";
            for (int child : n.children) {
                s += ' ';
                self(self, child);
            }
            s += ')';
            return;
        case NodeKind::LevelOne:
            s += "(1 F";
            if (n.left >= 0) {
                s += " U:";
                self(self, n.left);
            }
            if (n.right >= 0) {
                s += " D:";
                self(self, n.right);
            }
            s += ')';
            return;
        case NodeKind::Edge: s += pipetile::toString(n.type); return;
        case NodeKind::Up:
        case NodeKind::Down:
            s += '(' + std::to_string(n.rule) +
                 (n.rule == 9 ? std::string(pipetile::toString(n.type))
                              : std::string(n.kind == NodeKind::Up ? "U" : "D"));
            for (int child : n.children) {
                s += ' ';
                self(self, child);
            }
            s += ')';
            return;
        }
    };
    write(write, 0);
    return s;
}

} // namespace pipetile
