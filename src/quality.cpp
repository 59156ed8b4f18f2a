// pipetile — quality: vertex normals from the field, and needle removal by edge flips.
// Flips: C. L. Lawson, "Software for C1 surface interpolation" (1977): a triangulation whose
// smallest angle no flip raises; in space, with the flips that would fold the surface left out.

#include <pipetile/quality.h>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <deque>
#include <iterator>
#include <limits>
#include <map>

namespace pipetile {

namespace {

// Two index-space coordinates along the slicing axis this close lie in one slice plane. Planes lie
// far more than this apart (added planes halve a slab down to an eighth of the slice spacing at
// most, graph.cpp), and the round trip through world space moves a coordinate by far less.
constexpr double kSamePlane = 1e-6;

glm::dvec3 faceNormal(const TriangleMesh& mesh, const Triangle& t) // length: twice the area
{
    const glm::dvec3& a = mesh.vertices[t[0]];
    return glm::cross(mesh.vertices[t[1]] - a, mesh.vertices[t[2]] - a);
}

// Area-weighted normals of the triangles around each vertex, summed (not normalised).
std::vector<glm::dvec3> faceNormalSums(const TriangleMesh& mesh)
{
    std::vector<glm::dvec3> sums(mesh.vertices.size(), glm::dvec3(0.0));
    for (const Triangle& t : mesh.triangles) {
        const glm::dvec3 n = faceNormal(mesh, t);
        for (const std::uint32_t v : t) sums[v] += n;
    }
    return sums;
}

glm::dvec3 unitOrZero(const glm::dvec3& v)
{
    const double length = glm::length(v);
    return length > 0.0 && std::isfinite(length) ? v / length : glm::dvec3(0.0);
}

// Longest edge over shortest altitude, times sqrt(3)/2 so that an equilateral triangle has 1
// (validate.h's measure); infinite for a triangle of no area.
double aspectRatio(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c)
{
    const double longest2 = std::max(glm::dot(b - a, b - a), std::max(glm::dot(c - b, c - b), glm::dot(a - c, a - c)));
    const double twiceArea = glm::length(glm::cross(b - a, c - a));
    return twiceArea > 0.0 ? longest2 / twiceArea * (std::sqrt(3.0) / 2.0) : std::numeric_limits<double>::infinity();
}

// The distance between segments [p0, p1] and [q0, q1] (Ericson, Real-Time Collision Detection,
// 5.1.9): how far a flip from one diagonal of a quad to the other moves the surface, at most.
double segmentDistance(const glm::dvec3& p0, const glm::dvec3& p1, const glm::dvec3& q0, const glm::dvec3& q1)
{
    const glm::dvec3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
    const double a = glm::dot(d1, d1), e = glm::dot(d2, d2), f = glm::dot(d2, r);
    double s = 0.0, t = 0.0;
    if (a <= 0.0 && e <= 0.0) return glm::length(r);
    if (a <= 0.0) {
        t = std::clamp(f / e, 0.0, 1.0);
    } else {
        const double c = glm::dot(d1, r);
        if (e <= 0.0) {
            s = std::clamp(-c / a, 0.0, 1.0);
        } else {
            const double b = glm::dot(d1, d2), denominator = a * e - b * b;
            s = denominator > 0.0 ? std::clamp((b * f - c * e) / denominator, 0.0, 1.0) : 0.0;
            t = (b * s + f) / e;
            if (t < 0.0) {
                t = 0.0;
                s = std::clamp(-c / a, 0.0, 1.0);
            } else if (t > 1.0) {
                t = 1.0;
                s = std::clamp((b - c) / a, 0.0, 1.0);
            }
        }
    }
    return glm::length(p0 + d1 * s - (q0 + d2 * t));
}

// The corner of triangle t opposite the edge (a, b), which t runs a -> b; -1 if it does not.
int oppositeCorner(const Triangle& t, std::uint32_t a, std::uint32_t b)
{
    for (int k = 0; k < 3; ++k)
        if (t[k] == a && t[(k + 1) % 3] == b) return (k + 2) % 3;
    return -1;
}

bool holds(const Triangle& t, std::uint32_t v)
{
    return t[0] == v || t[1] == v || t[2] == v;
}

// Lexicographic order of positions (x, then y, then z): the same whichever level holds them.
bool before(const glm::dvec3& a, const glm::dvec3& b)
{
    return a.x != b.x ? a.x < b.x : a.y != b.y ? a.y < b.y : a.z < b.z;
}

// The coarser level's vertices, by position (levels nest by position): how many copies of a
// point it has. Two constructions can put a vertex on another bit for bit (a junction part's
// crossing on the single contour's), and each copy that level has must stay. Sorted on the first
// question: most meshes ask none.
class CoarserVertices {
public:
    explicit CoarserVertices(const std::vector<glm::dvec3>& coarser) : mCoarser(&coarser) {}

    std::ptrdiff_t copies(const glm::dvec3& q)
    {
        if (!mSorted) {
            mKept = *mCoarser;
            std::sort(mKept.begin(), mKept.end(), before);
            mSorted = true;
        }
        const auto [from, to] = std::equal_range(mKept.begin(), mKept.end(), q, before);
        return to - from;
    }

    bool has(const glm::dvec3& q) { return copies(q) > 0; }

private:
    const std::vector<glm::dvec3>* mCoarser;
    std::vector<glm::dvec3> mKept;
    bool mSorted = false;
};

class NeedleFlipper {
public:
    NeedleFlipper(TriangleMesh& mesh, const Volume& volume, int axis, const std::vector<glm::dvec3>& coarser)
        : mMesh(mesh),
          mMaxMove(kMaxMoveVoxels * volume.smallestVoxel()),
          mKept(coarser)
    {
        const std::vector<glm::dvec3>& p = mesh.vertices;
        mAspect.reserve(mesh.triangles.size());
        for (const Triangle& t : mesh.triangles) mAspect.push_back(aspectRatio(p[t[0]], p[t[1]], p[t[2]]));
        // Most meshes have no needle at all, and then nothing else is built.
        std::vector<std::uint32_t> needles;
        for (std::uint32_t f = 0; f < mAspect.size(); ++f)
            if (mAspect[f] > kNeedleAspect) needles.push_back(f);
        if (needles.empty()) return;

        mPlaneW.reserve(p.size());
        for (const glm::dvec3& q : p) mPlaneW.push_back(volume.worldToIndex(q)[axis]);
        // The triangles around each vertex, as they were before any flip (compressed rows).
        mFirst.assign(p.size() + 1, 0);
        for (const Triangle& t : mesh.triangles)
            for (const std::uint32_t v : t) ++mFirst[v + 1];
        for (std::size_t v = 0; v < p.size(); ++v) mFirst[v + 1] += mFirst[v];
        mAround.resize(mFirst.back());
        std::vector<std::uint32_t> fill(mFirst.begin(), mFirst.end() - 1);
        for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f)
            for (const std::uint32_t v : mesh.triangles[f]) mAround[fill[v]++] = f;
        // The needles' edges, in triangle order: deterministic.
        for (const std::uint32_t f : needles)
            for (int k = 0; k < 3; ++k) mQueue.push_back({mesh.triangles[f][k], mesh.triangles[f][(k + 1) % 3]});
    }

    long long run()
    {
        long long flips = 0;
        while (!mQueue.empty()) {
            const std::pair<std::uint32_t, std::uint32_t> edge = mQueue.front();
            mQueue.pop_front();
            flips += tryFlip(edge.first, edge.second) ? 1 : 0;
        }
        return flips;
    }

private:
    // How far a flip may move the surface, in voxels (segmentDistance).
    static constexpr double kMaxMoveVoxels = 0.1;

    // Only pairs holding a triangle worse than this are looked at: the aspect ratio of an
    // isosceles triangle with a 10 degree apex (sqrt(3) / (2 sin 10°)), twice as wide as the
    // kNeedleDegrees the reports count. The bands' own triangles lie well below it (a tube's
    // coarsest band, 8 rays against a slice spacing of 2, is about 3), so the paper's tiling stays
    // as it is wherever it has no needle, and the pass costs next to nothing there.
    static constexpr double kNeedleAspect = 5.0;
    // A triangle past this aspect ratio is flat: its middle corner lies within about a
    // ten-thousandth of the longest edge's length from that edge.
    static constexpr double kFlatAspect = 1e4;

    bool samePlane(std::uint32_t a, std::uint32_t b) const { return std::abs(mPlaneW[a] - mPlaneW[b]) < kSamePlane; }

    // A contour edge: both ends in one plane, and a triangle on it that leaves the plane.
    bool alongContour(std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d) const
    {
        return samePlane(a, b) && !(samePlane(a, c) && samePlane(a, d));
    }

    // The triangles holding both a and b now, each once; at most `limit` of them.
    int trianglesOn(std::uint32_t a, std::uint32_t b, std::uint32_t* out, int limit) const
    {
        int count = 0;
        const auto take = [&](std::uint32_t f) {
            const Triangle& t = mMesh.triangles[f];
            if (!holds(t, a) || !holds(t, b) ||
                std::find(out, out + std::min(count, limit), f) != out + std::min(count, limit))
                return;
            if (count < limit) out[count] = f;
            ++count;
        };
        for (std::uint32_t i = mFirst[a]; i < mFirst[a + 1]; ++i) take(mAround[i]);
        const auto [from, to] = mGained.equal_range(a);
        for (auto i = from; i != to; ++i) take(i->second);
        return count;
    }

    bool tryFlip(std::uint32_t a, std::uint32_t b)
    {
        std::uint32_t face[3];
        if (trianglesOn(a, b, face, 3) != 2) return false; // a boundary or non-manifold edge stays
        std::uint32_t f1 = face[0], f2 = face[1];
        if (!(std::max(mAspect[f1], mAspect[f2]) > kNeedleAspect)) return false;
        // t1 runs a -> b, t2 b -> a (consistently oriented); c and d are their third corners.
        if (oppositeCorner(mMesh.triangles[f1], a, b) < 0) std::swap(a, b);
        Triangle& t1 = mMesh.triangles[f1];
        Triangle& t2 = mMesh.triangles[f2];
        const int k1 = oppositeCorner(t1, a, b), k2 = oppositeCorner(t2, b, a);
        if (k1 < 0 || k2 < 0) return false;
        const std::uint32_t c = t1[k1], d = t2[k2];
        // A contour edge stays, unless a triangle on it is flat with its third corner between
        // the edge's ends: then the flip keeps the contour's line, through that corner. Or unless
        // a triangle on it is a needle past kLargestAspect, which the flip must lower and may move
        // the surface no more than any flip: over the evaluation's 272 runs that took the levels
        // with a needle over 100 from 77 to 67, and the smoke along x's last (104.5 at its top
        // level, three points of one contour nearly in line), with no level worse and no level's
        // distance to the isosurface changed by more than 0.05 voxel.
        const std::vector<glm::dvec3>& p = mMesh.vertices;
        const auto between = [&](std::uint32_t corner) {
            const double along = glm::dot(p[corner] - p[a], p[b] - p[a]);
            return along > 0.0 && along < glm::dot(p[b] - p[a], p[b] - p[a]);
        };
        const double before = std::max(mAspect[f1], mAspect[f2]);
        const bool flat = (mAspect[f1] > kFlatAspect && between(c)) || (mAspect[f2] > kFlatAspect && between(d));
        if (c == d || (alongContour(a, b, c, d) && !flat && !(before > kLargestAspect)) ||
            trianglesOn(c, d, face, 1) > 0)
            return false;

        const double after1 = aspectRatio(p[c], p[a], p[d]), after2 = aspectRatio(p[d], p[b], p[c]);
        // A margin well above rounding: every flip then lowers the list of all aspect ratios
        // sorted from the largest, so the flips end (Lawson's argument), and rounding cannot make
        // two diagonals take turns.
        if (!(std::max(after1, after2) < before * (1.0 - 1e-9))) return false;
        // A needle of three vertices the level below has stays for good (no collapse or corner
        // removal may take them), where the one it would replace may still go with its new corner
        // (the phantom sliced along y: 621 at level 1 became 359 of three such vertices).
        const auto lasting = [&](double aspect, std::uint32_t x, std::uint32_t y, std::uint32_t z) {
            return aspect > kLargestAspect && mKept.has(p[x]) && mKept.has(p[y]) && mKept.has(p[z]);
        };
        if (lasting(after1, c, a, d) || lasting(after2, d, b, c)) return false;
        // The surface must stay where it was, within a fraction of a voxel: on a coarse level a
        // quad's diagonals can lie voxels apart (a cone's band spanning 300 slices), and taking
        // the other one moves the mesh off the isosurface.
        if (segmentDistance(p[a], p[b], p[c], p[d]) > mMaxMove) return false;
        const Triangle n1{c, a, d}, n2{d, b, c};
        const glm::dvec3 quad = faceNormal(mMesh, t1) + faceNormal(mMesh, t2);
        const glm::dvec3 m1 = faceNormal(mMesh, n1), m2 = faceNormal(mMesh, n2);
        if (!(glm::dot(m1, quad) > 0.0 && glm::dot(m2, quad) > 0.0 && glm::dot(m1, m2) > 0.0)) return false;

        // f1 gives up b and takes d; f2 gives up a and takes c. What a vertex gave up is left in
        // its rows: trianglesOn checks what each triangle holds now.
        t1 = n1;
        t2 = n2;
        mAspect[f1] = after1;
        mAspect[f2] = after2;
        mGained.emplace(d, f1);
        mGained.emplace(c, f2);
        for (const auto& side : {std::pair{c, a}, std::pair{a, d}, std::pair{d, b}, std::pair{b, c}})
            mQueue.push_back(side);
        return true;
    }

    TriangleMesh& mMesh;
    double mMaxMove;                            // world units
    CoarserVertices mKept;                      // the level below's vertices
    std::vector<double> mAspect;                // per triangle, kept current
    std::vector<double> mPlaneW;                // per vertex, index-space coordinate along the slicing axis
    std::vector<std::uint32_t> mFirst, mAround; // per vertex, its triangles before any flip
    std::unordered_multimap<std::uint32_t, std::uint32_t> mGained; // vertex -> triangle it joined by a flip
    std::deque<std::pair<std::uint32_t, std::uint32_t>> mQueue;    // edges to look at, in order: deterministic
};

// The vertex that v's collapses put it into. No path compression: a collapse always goes into a
// root, so paths stay a few steps long, and a speck's collapse tried and undone (collapsePairs)
// leaves no shortcut through the corner it put back.
std::uint32_t rootOf(const std::vector<std::uint32_t>& parent, std::uint32_t v)
{
    while (parent[v] != v) v = parent[v];
    return v;
}

// What a collapse must do besides keeping a closed manifold so and turning no triangle over.
struct Guard {
    bool lowerWorst = false; // lower the largest aspect ratio of the triangles around the vertex that goes
    double reach = 0.0; // world units: an edge longer than this goes only where the surface moves less (collapseMove)
    bool everywhere = false; // collapseMove samples the new triangles all over, not at a few points
    SurfaceBound bound;
};

using Corners = std::array<glm::dvec3, 3>;

// The distance from q to the nearest of `fan`'s triangles.
double fanDistance(const glm::dvec3& q, const std::vector<Corners>& fan)
{
    double nearest = std::numeric_limits<double>::infinity();
    for (const Corners& t : fan) nearest = std::min(nearest, glm::length(closestOnTriangle(q, t[0], t[1], t[2]) - q));
    return nearest;
}

// How far the surface moves when the triangles `before` around a vertex b become `after` (b
// moved onto a neighbour a, the two triangles on edge a-b gone): b's distance to the triangles
// after, and the distance of the points in between to those before, sampled at each new
// triangle's centroid and the midpoints of its two edges at a (a vertex's distance is 0, and the
// third edge is an edge before too). The samples matter where a lies off b's tangent plane: a
// cone's tip moved onto its base's rim keeps b near another tip vertex, but the side it drags
// along leaves the cone by voxels.
// `everywhere`, the samples cover each new triangle on a grid no coarser than the edge a-b: a
// triangle many times longer than the edge (a fan across a slab to a contour 30 voxels long)
// can leave the triangles before far from its centroid and midpoints (the standing torus sliced
// along y: 4.5 voxels off at level 1).
double collapseMove(const glm::dvec3& a, const glm::dvec3& b, const std::vector<Corners>& before,
                    const std::vector<Corners>& after, bool everywhere)
{
    double move = fanDistance(b, after);
    for (const Corners& t : after) {
        move = std::max(move, fanDistance((t[0] + t[1] + t[2]) / 3.0, before));
        for (int k = 0; k < 3; ++k)
            if (t[k] == a) {
                move = std::max(move, fanDistance((a + t[(k + 1) % 3]) / 2.0, before));
                move = std::max(move, fanDistance((a + t[(k + 2) % 3]) / 2.0, before));
            }
        if (!everywhere) continue;
        // At most 42 samples: 16 steps an edge (150) cost the tree sliced along y 6% of its time
        // where 8 cost 3%, and kept one more needle over 100 in the evaluation.
        constexpr int kMostSteps = 8;
        const double longest =
            std::max({glm::distance(t[0], t[1]), glm::distance(t[1], t[2]), glm::distance(t[2], t[0])});
        const int n = std::clamp(static_cast<int>(std::ceil(longest / glm::distance(a, b))), 2, kMostSteps);
        for (int i = 0; i <= n; ++i)
            for (int j = 0; i + j <= n; ++j)
                if (i < n && j < n && i + j > 0) // the corners lie on both surfaces
                    move = std::max(
                        move,
                        fanDistance(t[0] + (t[1] - t[0]) * (double(i) / n) + (t[2] - t[0]) * (double(j) / n), before));
    }
    return move;
}

// Whether moving the corners `goes` of the triangles `around` them to a (a triangle that would
// then hold a twice goes) turns none of them over, which would fold the surface, and passes
// `guard`. Several corners move together within the guard's reach only.
bool collapseImproves(const TriangleMesh& mesh, const std::vector<std::uint32_t>& around, const std::vector<bool>& gone,
                      const std::vector<std::uint32_t>& parent, std::uint32_t a, const std::vector<std::uint32_t>& goes,
                      const Guard& guard)
{
    const std::vector<glm::dvec3>& p = mesh.vertices;
    const std::uint32_t b = goes.front();
    // An edge within the reach moves the surface by its length at most; past it, by as much only
    // where collapseMove says so. Along a nearly straight contour that is far below the length.
    const bool far = glm::dot(p[a] - p[b], p[a] - p[b]) > guard.reach * guard.reach;
    if (far && goes.size() > 1) return false;
    const auto moves = [&](std::uint32_t w) { return std::find(goes.begin(), goes.end(), w) != goes.end(); };
    std::vector<Corners> before, after;
    const bool measured = far || guard.bound.volume;
    double worstBefore = 0.0, worstAfter = 0.0;
    for (const std::uint32_t f : around) {
        if (gone[f]) continue;
        Triangle t = mesh.triangles[f];
        for (std::uint32_t& w : t) w = rootOf(parent, w);
        if (!std::any_of(t.begin(), t.end(), moves)) continue;
        worstBefore = std::max(worstBefore, aspectRatio(p[t[0]], p[t[1]], p[t[2]]));
        if (far) before.push_back({p[t[0]], p[t[1]], p[t[2]]});
        const glm::dvec3 normal = faceNormal(mesh, t);
        for (std::uint32_t& w : t) w = moves(w) ? a : w;
        if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) continue;
        // A triangle of no area has no side to turn over (three copies of one point: the twisting
        // C's junctions leave 198 such triangles on each level unless they go).
        if (normal != glm::dvec3(0.0) && !(glm::dot(faceNormal(mesh, t), normal) > 0.0)) return false;
        worstAfter = std::max(worstAfter, aspectRatio(p[t[0]], p[t[1]], p[t[2]]));
        if (measured) after.push_back({p[t[0]], p[t[1]], p[t[2]]});
    }
    if (guard.lowerWorst && !(worstAfter < worstBefore)) return false;
    // Even a collapse of two vertices a hair apart makes no needle (past kLargestAspect) worse than
    // the worst it takes away: on Gaffer's smoke one moved a vertex onto the line through two
    // others, a triangle of aspect 4.5e14 at levels 2 and 3.
    if (worstAfter > kLargestAspect && !(worstAfter <= worstBefore)) return false;
    if (!std::all_of(after.begin(), after.end(), [&](const Corners& t) { return guard.bound.holds(t[0], t[1], t[2]); }))
        return false;
    return !far || collapseMove(p[a], p[b], before, after, guard.everywhere) <= guard.reach;
}

constexpr std::uint32_t kNoVertex = std::numeric_limits<std::uint32_t>::max();

// One edge collapse to try: `go` into (the vertex that now stands for) `keep`; with `eitherWay`
// (neither end is a vertex of the coarser level), `keep` into `go` where that one cannot be made.
// With `also`, a speck's third corner goes into `keep` too, in the same step.
struct Collapse {
    std::uint32_t keep, go;
    bool eitherWay;
    std::uint32_t also = kNoVertex;
    bool alongCorner = false; // offered along a needle's corner, not its own edge: measured everywhere
    bool operator==(const Collapse& o) const
    {
        return keep == o.keep && go == o.go && eitherWay == o.eitherWay && also == o.also &&
               alongCorner == o.alongCorner;
    }
};

// The triangles around some of a mesh's vertices, by vertex id: a slot per vertex, so that
// gathering them costs one array read per corner (a hash map's lookups were most of the collapses'
// time on the hollow Y).
class VertexFans {
public:
    explicit VertexFans(std::size_t vertices) : mSlot(vertices, kNone) {}

    std::vector<std::uint32_t>& operator[](std::uint32_t v)
    {
        if (mSlot[v] == kNone) {
            mSlot[v] = static_cast<std::uint32_t>(mFans.size());
            mFans.emplace_back();
        }
        return mFans[mSlot[v]];
    }

    // Triangle f joins v's fan if v has one.
    void offer(std::uint32_t v, std::uint32_t f)
    {
        if (mSlot[v] != kNone) mFans[mSlot[v]].push_back(f);
    }

private:
    static constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
    std::vector<std::uint32_t> mSlot;
    std::deque<std::vector<std::uint32_t>> mFans; // a deque: a fan added keeps the others where they are
};

// Whether b may go into a: the edge has two triangles and the link condition holds (the
// neighbours a and b share are exactly the third corners of those two; otherwise the collapse
// would pinch the surface). Fills `on` with the two triangles.
bool linkAllows(const TriangleMesh& mesh, VertexFans& around, const std::vector<bool>& gone,
                const std::vector<std::uint32_t>& parent, std::uint32_t a, std::uint32_t b,
                std::vector<std::uint32_t>& on)
{
    std::vector<std::uint32_t> nearA, nearB, opposite;
    on.clear();
    for (const std::uint32_t end : {a, b})
        for (const std::uint32_t f : around[end]) {
            if (gone[f]) continue;
            Triangle t = mesh.triangles[f];
            for (std::uint32_t& w : t) w = rootOf(parent, w);
            const bool hasA = holds(t, a), hasB = holds(t, b);
            for (const std::uint32_t w : t)
                if (w != a && w != b) (hasA && hasB ? opposite : hasA ? nearA : nearB).push_back(w);
            if (hasA && hasB && end == a) on.push_back(f);
        }
    for (std::vector<std::uint32_t>* list : {&nearA, &nearB, &opposite}) {
        std::sort(list->begin(), list->end());
        list->erase(std::unique(list->begin(), list->end()), list->end());
    }
    std::vector<std::uint32_t> shared;
    std::set_intersection(nearA.begin(), nearA.end(), nearB.begin(), nearB.end(), std::back_inserter(shared));
    return on.size() == 2 && opposite.size() == 2 && shared == opposite;
}

// Keeps the vertices that stand for themselves (into[v] == v) in their order, drops the triangles
// `gone` marks, and moves every corner to the vertex it went into.
void keepVertices(TriangleMesh& mesh, const std::vector<std::uint32_t>& into, const std::vector<bool>& gone)
{
    std::vector<std::uint32_t> newId(mesh.vertices.size(), 0);
    std::vector<glm::dvec3> vertices;
    vertices.reserve(mesh.vertices.size());
    for (std::uint32_t v = 0; v < mesh.vertices.size(); ++v)
        if (into[v] == v) {
            newId[v] = static_cast<std::uint32_t>(vertices.size());
            vertices.push_back(mesh.vertices[v]);
        }
    std::vector<Triangle> kept;
    kept.reserve(mesh.triangles.size());
    for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f) {
        if (gone[f]) continue;
        Triangle t = mesh.triangles[f];
        for (std::uint32_t& w : t) w = newId[into[w]];
        kept.push_back(t);
    }
    mesh.vertices = std::move(vertices);
    mesh.triangles = std::move(kept);
}

// Makes the collapses in order, where the collapse keeps the mesh a closed manifold and passes
// `guard` (collapseImproves); a vertex already collapsed stays where it went. The vertices left
// keep their order.
long long collapsePairs(TriangleMesh& mesh, const std::vector<Collapse>& pairs, const Guard& guard)
{
    if (pairs.empty()) return 0; // the common case costs one pass over the triangles
    const std::vector<glm::dvec3>& p = mesh.vertices;

    // The triangles around the pairs' vertices; a collapse moves the gone end's into the kept one's.
    VertexFans around(p.size());
    for (const Collapse& c : pairs) {
        around[c.keep], around[c.go];
        if (c.also != kNoVertex) around[c.also];
    }
    for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f)
        for (const std::uint32_t v : mesh.triangles[f]) around.offer(v, f);
    std::vector<std::uint32_t> parent(p.size());
    for (std::uint32_t v = 0; v < parent.size(); ++v) parent[v] = v;
    std::vector<bool> gone(mesh.triangles.size(), false);
    std::vector<std::uint32_t> on;
    const auto apply = [&](std::uint32_t a, std::uint32_t b) {
        for (const std::uint32_t f : on) gone[f] = true;
        parent[b] = a;
        std::vector<std::uint32_t>& into = around[a];
        const std::vector<std::uint32_t>& from = around[b];
        into.insert(into.end(), from.begin(), from.end());
    };
    Guard cornerGuard = guard;
    cornerGuard.everywhere = true;
    const auto tryCollapse = [&](std::uint32_t a, std::uint32_t b, bool alongCorner) {
        if (a == b || parent[b] != b || !linkAllows(mesh, around, gone, parent, a, b, on) ||
            !collapseImproves(mesh, around[b], gone, parent, a, {b}, alongCorner ? cornerGuard : guard))
            return false;
        apply(a, b);
        return true;
    };
    // A speck's two corners b and c into a at once: one at a time, the first can make a needle
    // that only the second takes away (three points a few ten-thousandths of a voxel apart where
    // the isosurface passes a voxel's corner, each fanned to the vertices around).
    const auto trySpeck = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
        if (a == b || a == c || b == c || parent[b] != b || parent[c] != c) return false;
        std::vector<std::uint32_t> both = around[b];
        both.insert(both.end(), around[c].begin(), around[c].end());
        if (!collapseImproves(mesh, both, gone, parent, a, {b, c}, guard) ||
            !linkAllows(mesh, around, gone, parent, a, b, on))
            return false;
        const std::vector<std::uint32_t> first = on;
        const std::size_t had = around[a].size();
        apply(a, b);
        if (linkAllows(mesh, around, gone, parent, a, c, on)) {
            apply(a, c);
            return true;
        }
        for (const std::uint32_t f : first) gone[f] = false;
        parent[b] = b;
        around[a].resize(had);
        return false;
    };
    long long collapsed = 0;
    for (const Collapse& c : pairs) {
        const std::uint32_t a = rootOf(parent, c.keep);
        if (c.also != kNoVertex) {
            // Either corner first: a corner of three triangles (its only other neighbour shared
            // with both) keeps the other two from going into one another before it goes (a crop
            // of the smoke: three points a ten-thousandth of a voxel apart at a voxel's corner,
            // aspect 1530 at every level).
            if (a == c.keep && (trySpeck(a, c.go, c.also) || trySpeck(a, c.also, c.go))) collapsed += 2;
            continue;
        }
        // The other way round, where the first fails: a needle's short edge whose preferred end
        // cannot go (it would turn a triangle over, or raise the worst aspect around, as on the
        // gaffer smoke's 266 at level 0 that the other way lowers to 46) may still go the other.
        if (tryCollapse(a, c.go, c.alongCorner) || (c.eitherWay && a == c.keep && tryCollapse(c.go, a, c.alongCorner)))
            ++collapsed;
    }
    if (collapsed == 0) return 0;

    // The vertices that named their set stay; each corner moves to its set's.
    for (std::uint32_t v = 0; v < p.size(); ++v) parent[v] = rootOf(parent, v);
    keepVertices(mesh, parent, gone);
    return collapsed;
}

// The six triangles of a spindle with tips a and b (a first by position): three vertices, added
// to the mesh, ring the middle of ab at the radius that makes every triangle equilateral. They
// face away from ab, or toward it where the field is higher there than on the ring: the field is
// lowest inside, so a speck's segment lies lower than its ring, a void's higher.
std::array<Triangle, 6> spindleBetween(TriangleMesh& mesh, const Volume& volume, std::uint32_t a, std::uint32_t b)
{
    std::vector<glm::dvec3>& p = mesh.vertices;
    const double length = glm::distance(p[a], p[b]);
    const glm::dvec3 axis = (p[b] - p[a]) / length, middle = 0.5 * (p[a] + p[b]);
    // A side of the axis: across the coordinate axis it leans least along.
    glm::dvec3 across(0.0);
    const glm::dvec3 lean = glm::abs(axis);
    across[lean.x <= lean.y && lean.x <= lean.z ? 0 : lean.y <= lean.z ? 1 : 2] = 1.0;
    const glm::dvec3 side = glm::normalize(glm::cross(axis, across)), other = glm::cross(axis, side);
    const double radius = length / (2.0 * std::sqrt(2.0));
    const std::uint32_t first = static_cast<std::uint32_t>(p.size());
    double around = 0.0;
    const double half = 0.5, sine = 0.5 * std::sqrt(3.0); // the ring at 0, 120 and 240 degrees
    for (const glm::dvec2 at : {glm::dvec2(1.0, 0.0), glm::dvec2(-half, sine), glm::dvec2(-half, -sine)}) {
        p.push_back(middle + radius * (at.x * side + at.y * other));
        around += volume.signedField(p.back()) / 3.0;
    }
    const bool intoVoid = volume.signedField(middle) > around;
    std::array<Triangle, 6> spindle;
    for (std::uint32_t i = 0; i < 3; ++i) {
        const std::uint32_t r = first + i, s = first + (i + 1) % 3;
        spindle[2 * i] = {a, s, r};
        spindle[2 * i + 1] = {b, r, s};
    }
    for (Triangle& t : spindle) {
        const glm::dvec3 centre = (p[t[0]] + p[t[1]] + p[t[2]]) / 3.0;
        if ((glm::dot(faceNormal(mesh, t), centre - middle) < 0.0) != intoVoid) std::swap(t[1], t[2]);
    }
    return spindle;
}

} // namespace

glm::dvec3 closestOnTriangle(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c)
{
    const glm::dvec3 ab = b - a, ac = c - a, ap = p - a;
    const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
    if (d1 <= 0.0 && d2 <= 0.0) return a;
    const glm::dvec3 bp = p - b;
    const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
    if (d3 >= 0.0 && d4 <= d3) return b;
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return a + (d1 / (d1 - d3)) * ab;
    const glm::dvec3 cp = p - c;
    const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
    if (d6 >= 0.0 && d5 <= d6) return c;
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return a + (d2 / (d2 - d6)) * ac;
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
    const double sum = va + vb + vc;
    if (!(sum > 0.0)) return a; // no area: its corners are as near as it gets
    const double denom = 1.0 / sum;
    return a + ab * (vb * denom) + ac * (vc * denom);
}

bool SurfaceBound::holds(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) const
{
    if (!volume) return true;
    // The corners lie on the surface, so a small triangle is near it throughout without asking
    // the field, which misses a speck thinner than the spacing of its samples.
    const glm::dvec3 q = farthestFromCorners(a, b, c);
    const double nearest = std::min({glm::distance(q, a), glm::distance(q, b), glm::distance(q, c)});
    return nearest <= voxels * volume->smallestVoxel() || volume->surfaceWithin(q, voxels);
}

glm::dvec3 farthestFromCorners(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c)
{
    const glm::dvec3 ab = b - a, ac = c - a, bc = c - b;
    const double ab2 = glm::dot(ab, ab), ac2 = glm::dot(ac, ac), bc2 = glm::dot(bc, bc);
    if (ab2 >= ac2 + bc2) return 0.5 * (a + b);
    if (ac2 >= ab2 + bc2) return 0.5 * (a + c);
    if (bc2 >= ab2 + ac2) return 0.5 * (b + c);
    const glm::dvec3 n = glm::cross(ab, ac);
    return a + (ab2 * glm::cross(ac, n) + ac2 * glm::cross(n, ab)) / (2.0 * glm::dot(n, n));
}

std::vector<glm::dvec3> vertexNormals(const Volume& volume, const TriangleMesh& mesh)
{
    std::vector<glm::dvec3> normals(mesh.vertices.size());
    std::vector<glm::dvec3> faceSums; // built on the first vertex that needs it
    for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
        normals[i] = unitOrZero(volume.fieldGradient(mesh.vertices[i]));
        if (normals[i] != glm::dvec3(0.0)) continue;
        if (faceSums.empty()) faceSums = faceNormalSums(mesh);
        normals[i] = unitOrZero(faceSums[i]);
    }
    return normals;
}

bool ThinSlabPlanes::holdBoth(const glm::dvec3& a, const glm::dvec3& b) const
{
    const double wa = volume->worldToIndex(a)[axis];
    if (std::abs(volume->worldToIndex(b)[axis] - wa) >= kSamePlane) return false;
    const auto at = std::lower_bound(positions.begin(), positions.end(), wa - kSamePlane);
    return at != positions.end() && std::abs(*at - wa) < kSamePlane;
}

long long collapseNeedleEdges(TriangleMesh& mesh, double tolerance, const std::vector<glm::dvec3>& coarser,
                              const NeedleCollapse& how)
{
    CoarserVertices kept(coarser);
    const auto copies = [&](const glm::dvec3& q) { return kept.copies(q); };
    const double tolerance2 = tolerance * tolerance;
    long long collapsed = 0;
    // A collapse can make a new short edge (between two vertices that each kept a third between
    // them); rounds go on until none is left that may go.
    for (long long round = 1; round > 0; collapsed += round) {
        const std::vector<glm::dvec3>& p = mesh.vertices;
        std::vector<Collapse> pairs;
        // Only short edges may go, unless the move is measured: most triangles have none, which is
        // cheaper to see than their aspect ratio.
        const auto mayGo = [&](std::uint32_t a, std::uint32_t b) {
            if (how.measureMove) return true;
            const double squared = glm::dot(p[a] - p[b], p[a] - p[b]);
            return squared <= tolerance2 ||
                   (how.thin && squared <= how.thin->tolerance * how.thin->tolerance && how.thin->holdBoth(p[a], p[b]));
        };
        const auto offer = [&](std::uint32_t a, std::uint32_t b, bool alongCorner) {
            bool keepA = copies(p[a]) > 0, keepB = copies(p[b]) > 0;
            if (keepA && keepB) {
                if (p[a] != p[b] || copies(p[a]) > 1) return;
                keepB = false; // one copy stays
            }
            // A vertex of the coarser level stays; between two new ones, the first by position (by id
            // between copies of one point, which both ways of building a level number alike).
            const bool first = before(p[a], p[b]) || (p[a] == p[b] && a < b);
            const bool eitherWay = !keepA && !keepB;
            pairs.push_back(keepA || (!keepB && first) ? Collapse{a, b, eitherWay, kNoVertex, alongCorner}
                                                       : Collapse{b, a, eitherWay, kNoVertex, alongCorner});
        };
        std::vector<bool> needleCorner; // with how.alongCorners: the needles' corners the coarser level lacks
        for (const Triangle& t : mesh.triangles) {
            const int shortEdges =
                (mayGo(t[0], t[1]) ? 1 : 0) + (mayGo(t[1], t[2]) ? 1 : 0) + (mayGo(t[2], t[0]) ? 1 : 0);
            if (shortEdges == 0) continue;
            // A speck, all three edges short, goes whatever its shape: a section far smaller than a
            // voxel fanned around its centre leaves needles on its own edges that cannot go (their
            // ends share the third speck vertex: linkAllows), while the fan's edges can (seed 11 of
            // the dense trees: 534 at every level).
            const bool speck = !how.measureMove && shortEdges == 3;
            if (!speck && how.needleAspect > 0.0 && !(aspectRatio(p[t[0]], p[t[1]], p[t[2]]) > how.needleAspect))
                continue;
            for (int k = 0; k < 3; ++k) {
                const std::uint32_t a = t[k], b = t[(k + 1) % 3];
                // Each edge once (from either triangle on it when only needles count).
                if ((a < b || how.needleAspect > 0.0) && mayGo(a, b)) offer(a, b, false);
                if (how.alongCorners && copies(p[a]) == 0) {
                    needleCorner.resize(p.size(), false);
                    needleCorner[a] = true;
                }
            }
            if (speck) {
                // Kept: the corner the coarser level has, else the first by position.
                std::array<std::uint32_t, 3> corners = t;
                std::sort(corners.begin(), corners.end(), [&](std::uint32_t x, std::uint32_t y) {
                    const bool keepX = copies(p[x]) > 0, keepY = copies(p[y]) > 0;
                    return keepX != keepY ? keepX : before(p[x], p[y]) || (p[x] == p[y] && x < y);
                });
                if (copies(p[corners[1]]) == 0) pairs.push_back({corners[0], corners[1], false, corners[2]});
            }
        }
        // A needle's new corner may go along its other edges too, where its own cannot (it would
        // turn a triangle over) and a short edge beside it can (Assembly::build says where). One
        // more pass over the triangles, only where a needle has such a corner.
        if (!needleCorner.empty())
            for (const Triangle& t : mesh.triangles)
                for (int k = 0; k < 3; ++k) {
                    const std::uint32_t a = t[k], b = t[(k + 1) % 3];
                    if (needleCorner[a] || needleCorner[b]) offer(a, b, true);
                }
        // The shortest edges first: a longer collapse can leave a shorter edge beside it unable
        // to go (a crop of the smoke: 3140 at its top level where a contour thinner than a voxel
        // goes into a patch's point, 41 now; over the evaluation's 944 levels, 67 needles over
        // 100 where there were 85). Then by position, not id: the same collapses whichever way
        // the level was built. A speck's collapse after its edges'.
        const auto length2 = [&](const Collapse& c) { return glm::dot(p[c.go] - p[c.keep], p[c.go] - p[c.keep]); };
        std::sort(pairs.begin(), pairs.end(), [&](const Collapse& x, const Collapse& y) {
            const double lx = length2(x), ly = length2(y);
            if (lx != ly) return lx < ly;
            if (p[x.go] != p[y.go]) return before(p[x.go], p[y.go]);
            if (p[x.keep] != p[y.keep]) return before(p[x.keep], p[y.keep]);
            if (x.alongCorner != y.alongCorner) return y.alongCorner; // the looser measure first
            if ((x.also != kNoVertex) != (y.also != kNoVertex)) return y.also != kNoVertex;
            return x.also != kNoVertex && before(p[x.also], p[y.also]);
        });
        pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
        round = collapsePairs(mesh, pairs, Guard{how.lowerWorst, tolerance, false, how.bound});
    }
    return collapsed;
}

long long inflatePillows(TriangleMesh& mesh, const Volume& volume, const std::vector<glm::dvec3>& coarser)
{
    // A pillow's three vertices lie on two triangles each, and those two are the same triangle
    // twice; most meshes have no vertex on fewer than three.
    std::vector<int> valence(mesh.vertices.size(), 0);
    for (const Triangle& t : mesh.triangles)
        for (const std::uint32_t v : t) ++valence[v];
    std::map<std::array<std::uint32_t, 3>, std::vector<std::uint32_t>> byCorners;
    for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f) {
        std::array<std::uint32_t, 3> corners = mesh.triangles[f];
        if (valence[corners[0]] != 2 || valence[corners[1]] != 2 || valence[corners[2]] != 2) continue;
        std::sort(corners.begin(), corners.end());
        byCorners[corners].push_back(f);
    }
    if (byCorners.empty()) return 0;
    CoarserVertices kept(coarser);
    const auto inCoarser = [&](const glm::dvec3& q) { return kept.has(q); };

    std::vector<glm::dvec3>& p = mesh.vertices;
    std::vector<bool> dropped(p.size(), false);
    long long inflated = 0;
    for (const auto& [corners, faces] : byCorners) {
        if (faces.size() != 2 || !(aspectRatio(p[corners[0]], p[corners[1]], p[corners[2]]) > kLargestAspect)) continue;
        // The vertex that goes: one the coarser level lacks, leaving the longest segment (then the
        // later by position), so that every level picks the same tips.
        int drop = -1;
        double longest = 0.0;
        for (int k = 0; k < 3; ++k) {
            const glm::dvec3 &x = p[corners[(k + 1) % 3]], &y = p[corners[(k + 2) % 3]];
            const double length = glm::length(y - x);
            if (inCoarser(p[corners[k]]) || length < longest) continue;
            if (drop >= 0 && length == longest && before(p[corners[k]], p[corners[drop]])) continue;
            drop = k;
            longest = length;
        }
        if (drop < 0 || !(longest > 0.0)) continue;
        std::uint32_t a = corners[(drop + 1) % 3], b = corners[(drop + 2) % 3];
        if (before(p[b], p[a])) std::swap(a, b);
        const std::array<Triangle, 6> spindle = spindleBetween(mesh, volume, a, b);
        mesh.triangles[faces[0]] = spindle[0];
        mesh.triangles[faces[1]] = spindle[1];
        mesh.triangles.insert(mesh.triangles.end(), spindle.begin() + 2, spindle.end());
        dropped[corners[drop]] = true;
        ++inflated;
    }
    if (inflated == 0) return 0;
    // The vertices that go leave no gap (no triangle holds them): the others keep their order.
    std::vector<std::uint32_t> into(p.size());
    for (std::uint32_t v = 0; v < into.size(); ++v) into[v] = v < dropped.size() && dropped[v] ? kNoVertex : v;
    keepVertices(mesh, into, std::vector<bool>(mesh.triangles.size(), false));
    return inflated;
}

namespace {

// A hole's triangles: how many of them face against the part of the fan they cover, then the
// largest aspect ratio among them, then the sum of their aspect ratios.
struct HoleTiling {
    int against = std::numeric_limits<int>::max();
    double worst = std::numeric_limits<double>::infinity();
    double sum = std::numeric_limits<double>::infinity();
    bool operator<(const HoleTiling& o) const
    {
        return against != o.against ? against < o.against : worst != o.worst ? worst < o.worst : sum < o.sum;
    }
};

// Fills the polygon `ring` (the link of the vertices that go, in the order their triangles run)
// with the triangles that face against the fan they cover least often (`wedge`: the normals of
// the fan's triangles between ring[a] and ring[a + 1], summed), then with the smallest largest
// aspect ratio, then the smallest sum: Klincsek's dynamic programme over sub-polygons, O(n^3). A
// diagonal the mesh already has (`joined`) would make an edge of four triangles, so none is made.
// Each ring edge ends up in one triangle that runs it the same way, so the mesh stays closed,
// manifold and oriented. Empty where no such tiling exists.
std::vector<Triangle> tileHole(const std::vector<glm::dvec3>& p, const std::vector<std::uint32_t>& ring,
                               const std::vector<glm::dvec3>& wedge, const std::vector<std::vector<bool>>& joined,
                               double& worst)
{
    const std::size_t n = ring.size();
    std::vector<glm::dvec3> facing(n + 1, glm::dvec3(0.0)); // prefix sums of the wedges
    for (std::size_t a = 0; a < n; ++a) facing[a + 1] = facing[a] + wedge[a];
    std::vector<HoleTiling> best(n * n);
    std::vector<std::size_t> split(n * n, 0);
    for (std::size_t i = 0; i + 1 < n; ++i) best[i * n + i + 1] = {0, 0.0, 0.0};
    for (std::size_t span = 2; span < n; ++span)
        for (std::size_t i = 0; i + span < n; ++i) {
            const std::size_t j = i + span;
            if (span < n - 1 && joined[i][j]) continue; // the diagonal i-j exists: no tiling under it
            const glm::dvec3 &a = p[ring[i]], &c = p[ring[j]];
            for (std::size_t k = i + 1; k < j; ++k) {
                const HoleTiling &left = best[i * n + k], &right = best[k * n + j];
                if (!std::isfinite(left.worst) || !std::isfinite(right.worst)) continue;
                const glm::dvec3& b = p[ring[k]];
                const double aspect = aspectRatio(a, b, c);
                const bool against = !(glm::dot(glm::cross(b - a, c - a), facing[j] - facing[i]) > 0.0);
                const HoleTiling here{left.against + right.against + (against ? 1 : 0),
                                      std::max({left.worst, right.worst, aspect}), left.sum + right.sum + aspect};
                if (here < best[i * n + j]) {
                    best[i * n + j] = here;
                    split[i * n + j] = k;
                }
            }
        }
    worst = best[n - 1].worst;
    std::vector<Triangle> triangles;
    if (!std::isfinite(worst)) return triangles;
    std::vector<std::pair<std::size_t, std::size_t>> open{{0, n - 1}};
    while (!open.empty()) {
        const auto [i, j] = open.back();
        open.pop_back();
        if (j - i < 2) continue;
        const std::size_t k = split[i * n + j];
        triangles.push_back({ring[i], ring[k], ring[j]});
        open.push_back({i, k});
        open.push_back({k, j});
    }
    return triangles;
}

// The sharpest crease among `triangles` and the triangles `outside` them that share an edge: the
// smallest cosine of the angle between two such triangles' normals (1 where none is bent).
double sharpestCrease(const TriangleMesh& mesh, const std::vector<Triangle>& triangles,
                      const std::vector<Triangle>& outside)
{
    double cosine = 1.0;
    const auto bend = [&](const Triangle& s, const Triangle& t) {
        for (int k = 0; k < 3; ++k)
            if (oppositeCorner(t, s[(k + 1) % 3], s[k]) >= 0) {
                const glm::dvec3 m = unitOrZero(faceNormal(mesh, s)), n = unitOrZero(faceNormal(mesh, t));
                cosine = std::min(cosine, glm::dot(m, n));
                return;
            }
    };
    for (std::size_t i = 0; i < triangles.size(); ++i) {
        for (std::size_t j = i + 1; j < triangles.size(); ++j) bend(triangles[i], triangles[j]);
        for (const Triangle& t : outside) bend(triangles[i], t);
    }
    return cosine;
}

// The farthest a point of `after`'s triangles (on a grid of a quarter of each edge) lies from
// `before`'s, and a vertex that goes (`gone`) from `after`'s: how far tiling a fan's polygon anew
// moves the surface.
double holeMove(const std::vector<glm::dvec3>& gone, const std::vector<Corners>& before,
                const std::vector<Corners>& after)
{
    double move = 0.0;
    for (const glm::dvec3& q : gone) move = std::max(move, fanDistance(q, after));
    constexpr int kSteps = 4;
    for (const Corners& t : after)
        for (int i = 0; i <= kSteps; ++i)
            for (int j = 0; i + j <= kSteps; ++j)
                move = std::max(move, fanDistance(t[0] + (t[1] - t[0]) * (double(i) / kSteps) +
                                                      (t[2] - t[0]) * (double(j) / kSteps),
                                                  before));
    return move;
}

// Tiles anew the polygon around a fan of triangles: the whole fans of a set of vertices, which go
// (removeNeedleCorners), or part of one vertex's fan, whose vertices all stay (retileNeedleFans).
class FanRetiler {
public:
    // `watched`: the vertices whose fans may be tiled anew.
    FanRetiler(TriangleMesh& mesh, const std::vector<std::uint32_t>& watched, double reach,
               const SurfaceBound& bound = {})
        : mMesh(mesh),
          mReach(reach),
          mBound(bound),
          mAround(mesh.vertices.size()),
          mGone(mesh.triangles.size(), false),
          mInto(mesh.vertices.size())
    {
        // The triangles around the watched vertices and around their neighbours (a ring's
        // diagonals are checked against its vertices' triangles); a new tiling only joins such
        // vertices.
        std::vector<bool> near(mesh.vertices.size(), false);
        for (const std::uint32_t v : watched) near[v] = true;
        for (const Triangle& t : mesh.triangles)
            if (near[t[0]] || near[t[1]] || near[t[2]])
                for (const std::uint32_t v : t) mAround[v];
        for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f)
            for (const std::uint32_t v : mesh.triangles[f]) mAround.offer(v, f);
        for (std::uint32_t v = 0; v < mInto.size(); ++v) mInto[v] = v;
    }

    bool gone(std::uint32_t f) const { return mGone[f]; }

    // Removes `set` where that takes a needle away: see removeNeedleCorners.
    bool tryRemove(const std::vector<std::uint32_t>& set)
    {
        if (std::any_of(set.begin(), set.end(), [&](std::uint32_t v) { return mInto[v] != v; })) return false;
        if (!gatherRing(set)) return false;
        std::vector<glm::dvec3> goneAt;
        for (const std::uint32_t v : set) goneAt.push_back(mMesh.vertices[v]);
        double worst = 0.0;
        const std::vector<Triangle> tiles = tileByShape(worst);
        if (!keepsSurface(goneAt, tiles)) return false;
        commit(tiles);
        for (const std::uint32_t v : set) mInto[v] = kNoVertex;
        return true;
    }

    // Tiles anew the part of a corner's fan around `needle` (see retileNeedleFans) that leaves the
    // smallest largest aspect ratio, the fewest triangles on a tie. The parts are ranked by their
    // tilings first; only then is the surface measured, from the best down until one keeps it.
    bool tryRetileAround(std::uint32_t needle)
    {
        // Parts of up to 25 triangles, 12 either side of the needle: a needle's corner fanned
        // across a slab to a contour a vertex per pixel (the phantom sliced along y: 10 needles
        // over 100 from one vertex at level 1) needs the fan's triangles on the other contour too.
        static constexpr int kSides[] = {0, 1, 2, 3, 4, 6, 8, 12};
        struct Part {
            double worst;
            std::vector<Triangle> tiles;
            std::size_t corner; // of the needle
            int before, after;
        };
        std::vector<Part> parts;
        const Triangle corners = mMesh.triangles[needle];
        std::vector<std::vector<std::uint32_t>> fans;
        for (std::size_t k = 0; k < corners.size(); ++k) {
            fans.push_back(fanFrom(corners[k], needle));
            const int size = static_cast<int>(fans.back().size());
            for (const int before : kSides)
                for (const int after : kSides) {
                    // One triangle stays, so the corner stays on the polygon and is none inside it.
                    if (before + after + 2 > size) continue;
                    gatherPart(corners[k], fans.back(), before, after);
                    double worst = 0.0;
                    std::vector<Triangle> tiles = tileByShape(worst);
                    if (!tiles.empty()) parts.push_back({worst, std::move(tiles), k, before, after});
                }
        }
        std::stable_sort(parts.begin(), parts.end(), [](const Part& x, const Part& y) {
            return x.worst != y.worst ? x.worst < y.worst : x.tiles.size() < y.tiles.size();
        });
        for (const Part& part : parts) {
            gatherPart(corners[part.corner], fans[part.corner], part.before, part.after);
            if (keepsSurface({}, part.tiles)) {
                commit(part.tiles);
                return true;
            }
        }
        return false;
    }

    // Drops the removed vertices and triangles; the others keep their order.
    void finish() { keepVertices(mMesh, mInto, mGone); }

private:
    bool inSet(const std::vector<std::uint32_t>& set, std::uint32_t v) const
    {
        return std::find(set.begin(), set.end(), v) != set.end();
    }

    // The triangles holding a vertex of `set` (mFan) and the polygon around them (mRing, in the
    // order they run; mWedge: the normal of the triangle on each of its edges). False unless they
    // make a disk: one simple cycle, and as many triangles as a disk with `set` inside has.
    bool gatherRing(const std::vector<std::uint32_t>& set)
    {
        mFan.clear();
        mRing.clear();
        mWedge.clear();
        std::map<std::uint32_t, std::pair<std::uint32_t, std::uint32_t>> next; // x -> (y, triangle)
        for (const std::uint32_t v : set)
            for (const std::uint32_t f : mAround[v]) {
                const Triangle& t = mMesh.triangles[f];
                if (mGone[f] || !holds(t, v) || std::find(mFan.begin(), mFan.end(), f) != mFan.end()) continue;
                mFan.push_back(f);
                for (int k = 0; k < 3; ++k) {
                    const std::uint32_t x = t[k], y = t[(k + 1) % 3];
                    if (!inSet(set, x) && !inSet(set, y) && !next.emplace(x, std::pair{y, f}).second) return false;
                }
            }
        if (next.size() + 2 * set.size() - 2 != mFan.size()) return false;
        for (std::uint32_t x = next.begin()->first; mRing.size() < next.size();) {
            mRing.push_back(x);
            const auto step = next.find(x);
            if (step == next.end()) return false;
            mWedge.push_back(faceNormal(mMesh, mMesh.triangles[step->second.second]));
            x = step->second.first;
            if (x == mRing.front()) break;
        }
        return mRing.size() == next.size() && mRing.size() >= 3;
    }

    // v's triangles in the order they run around it, from `first`; empty unless they make a disk.
    std::vector<std::uint32_t> fanFrom(std::uint32_t v, std::uint32_t first)
    {
        std::map<std::uint32_t, std::uint32_t> from; // a -> the triangle (v, a, b)
        for (const std::uint32_t f : mAround[v])
            if (!mGone[f] && holds(mMesh.triangles[f], v) &&
                !from.emplace(mMesh.triangles[f][(cornerOf(mMesh.triangles[f], v) + 1) % 3], f).second)
                return {};
        std::vector<std::uint32_t> fan{first};
        for (;;) {
            const Triangle& t = mMesh.triangles[fan.back()];
            const auto step = from.find(t[(cornerOf(t, v) + 2) % 3]);
            if (step == from.end() || fan.size() > from.size()) return {};
            if (step->second == first) break;
            fan.push_back(step->second);
        }
        return fan.size() == from.size() ? fan : std::vector<std::uint32_t>{};
    }

    static int cornerOf(const Triangle& t, std::uint32_t v) { return t[0] == v ? 0 : t[1] == v ? 1 : 2; }

    // The part of v's fan (from fanFrom) from `before` triangles ahead of the needle (fan[0]) to
    // `after` past it, as mFan, and its polygon: v, then the fan's far corners in order.
    void gatherPart(std::uint32_t v, const std::vector<std::uint32_t>& fan, int before, int after)
    {
        mFan.clear();
        mRing.assign(1, v);
        mWedge.clear();
        const int size = static_cast<int>(fan.size());
        for (int k = -before; k <= after; ++k) mFan.push_back(fan[static_cast<std::size_t>((k + size) % size)]);
        for (const std::uint32_t f : mFan) {
            const Triangle& t = mMesh.triangles[f];
            const int c = cornerOf(t, v);
            if (mRing.size() == 1) {
                mRing.push_back(t[(c + 1) % 3]);
                mWedge.push_back(faceNormal(mMesh, t)); // v to the first far corner
            }
            mRing.push_back(t[(c + 2) % 3]);
            mWedge.push_back(faceNormal(mMesh, t));
        }
        mWedge.push_back(mWedge.back()); // the last far corner back to v
    }

    // The tiling of the polygon around mFan (tileHole) where it lowers the fan's worst aspect ratio
    // past kLargestAspect, with no triangle the mesh has already; else nothing.
    std::vector<Triangle> tileByShape(double& worst)
    {
        const std::vector<glm::dvec3>& p = mMesh.vertices;
        double worstBefore = 0.0;
        for (const std::uint32_t f : mFan) {
            const Triangle& t = mMesh.triangles[f];
            worstBefore = std::max(worstBefore, aspectRatio(p[t[0]], p[t[1]], p[t[2]]));
        }
        if (!(worstBefore > kLargestAspect)) return {};
        std::vector<Triangle> tiles = tileHole(p, mRing, mWedge, joinedOutside(), worst);
        // A margin well above rounding, as the flips': the same triangles, their corners rotated,
        // may measure a hair lower, and two tilings could then take turns.
        if (tiles.empty() || !(worst < worstBefore * (1.0 - 1e-9)) ||
            std::any_of(tiles.begin(), tiles.end(), [&](const Triangle& t) { return outsideHas(t); }))
            return {};
        return tiles;
    }

    // Whether `tiles`, in place of mFan, move the surface by no more than the reach (`gone`: the
    // vertices inside the polygon, which go), keep within the bound, and make no crease past a
    // right angle where the fan had none.
    bool keepsSurface(const std::vector<glm::dvec3>& gone, const std::vector<Triangle>& tiles)
    {
        if (tiles.empty()) return false;
        const std::vector<glm::dvec3>& p = mMesh.vertices;
        std::vector<Triangle> old;
        std::vector<Corners> before, after;
        for (const std::uint32_t f : mFan) {
            const Triangle& t = old.emplace_back(mMesh.triangles[f]);
            before.push_back({p[t[0]], p[t[1]], p[t[2]]});
        }
        for (const Triangle& t : tiles) {
            after.push_back({p[t[0]], p[t[1]], p[t[2]]});
            if (!mBound.holds(p[t[0]], p[t[1]], p[t[2]])) return false;
        }
        if (holeMove(gone, before, after) > mReach) return false;
        // No crease past a right angle, unless the fan had one already (a tendril's tip, whose
        // sides meet at a knife's edge whichever way it is tiled).
        const std::vector<Triangle> outside = acrossRing();
        return !(sharpestCrease(mMesh, tiles, outside) < 0.0) || sharpestCrease(mMesh, old, outside) < 0.0;
    }

    // mFan's triangles go and `tiles` take their place.
    void commit(const std::vector<Triangle>& tiles)
    {
        for (const std::uint32_t f : mFan) mGone[f] = true;
        for (const Triangle& t : tiles) {
            const std::uint32_t f = static_cast<std::uint32_t>(mMesh.triangles.size());
            mMesh.triangles.push_back(t);
            mGone.push_back(false);
            for (const std::uint32_t v : t) mAround.offer(v, f);
        }
    }

    // Whether a triangle outside the fan has t's three corners the same way round: two triangles
    // over one. The other way round, the two close a pillow (a speck's shape at the coarser
    // levels, when a tetrahedron's vertex goes).
    bool outsideHas(const Triangle& t)
    {
        for (const std::uint32_t f : mAround[t[0]]) {
            const Triangle& s = mMesh.triangles[f];
            if (!mGone[f] && std::find(mFan.begin(), mFan.end(), f) == mFan.end() && holds(s, t[0]) && holds(s, t[1]) &&
                holds(s, t[2]) && oppositeCorner(s, t[1], t[0]) < 0)
                return true;
        }
        return false;
    }

    // Calls visit(t) for each triangle t at the i-th ring vertex outside the fan.
    template <class Visit>
    void forEachOutside(std::size_t i, Visit visit)
    {
        for (const std::uint32_t f : mAround[mRing[i]]) {
            const Triangle& t = mMesh.triangles[f];
            if (!mGone[f] && holds(t, mRing[i]) && std::find(mFan.begin(), mFan.end(), f) == mFan.end()) visit(t);
        }
    }

    // Which ring vertices the mesh joins already, outside the fan.
    std::vector<std::vector<bool>> joinedOutside()
    {
        const std::size_t n = mRing.size();
        std::vector<std::vector<bool>> joined(n, std::vector<bool>(n, false));
        for (std::size_t i = 0; i < n; ++i)
            forEachOutside(i, [&](const Triangle& t) {
                for (std::size_t j = 0; j < n; ++j) joined[i][j] = joined[i][j] || (j != i && holds(t, mRing[j]));
            });
        return joined;
    }

    // The triangles across the ring's edges, outside the fan.
    std::vector<Triangle> acrossRing()
    {
        std::vector<Triangle> across;
        for (std::size_t i = 0; i < mRing.size(); ++i)
            forEachOutside(i, [&](const Triangle& t) {
                if (oppositeCorner(t, mRing[(i + 1) % mRing.size()], mRing[i]) >= 0) across.push_back(t);
            });
        return across;
    }

    TriangleMesh& mMesh;
    double mReach;
    SurfaceBound mBound;
    VertexFans mAround;
    std::vector<bool> mGone;          // per triangle
    std::vector<std::uint32_t> mInto; // per vertex: itself, or kNoVertex once removed
    std::vector<std::uint32_t> mFan, mRing;
    std::vector<glm::dvec3> mWedge;
};

// One round of removeNeedleCorners: the needles the mesh has now.
long long removeNeedleCornersOnce(TriangleMesh& mesh, CoarserVertices& kept, double reach)
{
    const std::vector<glm::dvec3>& p = mesh.vertices;
    // Most meshes have no needle, and then nothing else is done.
    std::vector<Triangle> needles;
    for (const Triangle& t : mesh.triangles)
        if (aspectRatio(p[t[0]], p[t[1]], p[t[2]]) > kLargestAspect) needles.push_back(t);
    if (needles.empty()) return 0;
    const auto inCoarser = [&](const glm::dvec3& q) { return kept.has(q); };
    const auto first = [&](std::uint32_t x, std::uint32_t y) { return before(p[x], p[y]) || (p[x] == p[y] && x < y); };
    // Each needle's corners the coarser level lacks, one at a time, then together (three points
    // a thousandth of a voxel apart at a voxel's corner, where neither alone lowers the worst); by
    // position, so that the same go whichever way the level was built.
    std::vector<std::vector<std::uint32_t>> singles, sets;
    for (const Triangle& t : needles) {
        std::vector<std::uint32_t> set;
        for (const std::uint32_t v : t)
            if (!inCoarser(p[v])) set.push_back(v);
        std::sort(set.begin(), set.end(), first);
        for (const std::uint32_t v : set) singles.push_back({v});
        if (set.size() > 1) sets.push_back(set);
    }
    if (singles.empty()) return 0;
    const auto order = [&](const std::vector<std::uint32_t>& x, const std::vector<std::uint32_t>& y) {
        return std::lexicographical_compare(x.begin(), x.end(), y.begin(), y.end(), first);
    };
    for (std::vector<std::vector<std::uint32_t>>* list : {&singles, &sets}) {
        std::sort(list->begin(), list->end(), order);
        list->erase(std::unique(list->begin(), list->end()), list->end());
    }
    singles.insert(singles.end(), sets.begin(), sets.end());
    std::vector<std::uint32_t> corners;
    for (const std::vector<std::uint32_t>& set : singles) corners.insert(corners.end(), set.begin(), set.end());
    FanRetiler remover(mesh, corners, reach);
    long long removed = 0;
    for (const std::vector<std::uint32_t>& set : singles)
        if (remover.tryRemove(set)) removed += static_cast<long long>(set.size());
    if (removed > 0) remover.finish();
    return removed;
}

} // namespace

long long removeNeedleCorners(TriangleMesh& mesh, const std::vector<glm::dvec3>& coarser, double reach)
{
    // Each round looks again at the needles the one before left: a bipyramid's vertex may go,
    // leaving a tetrahedron whose needle only another vertex's removal takes away. Each round
    // removes a vertex or ends the rounds.
    CoarserVertices kept(coarser);
    long long removed = 0, round = 0;
    while ((round = removeNeedleCornersOnce(mesh, kept, reach)) > 0) removed += round;
    return removed;
}

long long retileNeedleFans(TriangleMesh& mesh, double reach, const SurfaceBound& bound)
{
    const std::vector<glm::dvec3>& p = mesh.vertices;
    long long retiled = 0;
    // Each round looks again at the needles the one before left, its own new ones included; a
    // tiling is taken only where it lowers its fan's worst aspect ratio, so the rounds end.
    for (bool again = true; again;) {
        std::vector<std::uint32_t> needles, corners;
        for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f) {
            const Triangle& t = mesh.triangles[f];
            if (!(aspectRatio(p[t[0]], p[t[1]], p[t[2]]) > kLargestAspect)) continue;
            needles.push_back(f);
            corners.insert(corners.end(), t.begin(), t.end());
        }
        if (needles.empty()) break;
        // Worst first; then by triangle, as tiled: the same whichever way the level was built.
        std::stable_sort(needles.begin(), needles.end(), [&](std::uint32_t a, std::uint32_t b) {
            const Triangle &s = mesh.triangles[a], &t = mesh.triangles[b];
            return aspectRatio(p[s[0]], p[s[1]], p[s[2]]) > aspectRatio(p[t[0]], p[t[1]], p[t[2]]);
        });
        FanRetiler retiler(mesh, corners, reach, bound);
        again = false;
        for (const std::uint32_t f : needles)
            if (!retiler.gone(f) && retiler.tryRetileAround(f)) {
                ++retiled;
                again = true;
            }
        retiler.finish();
    }
    return retiled;
}

namespace {

// Moves v, within `reach` of where it is, to where the largest aspect ratio of its triangles
// `fan` falls to kCollapseAspect with the least move, or is lowest: a compass search (Torczon's
// pattern search) over the 26 directions to a cube's neighbours, as that largest ratio has a kink
// wherever its worst triangle changes. No triangle turns over, and each keeps within `bound`; the
// surface moves no farther than v does. v stays unless the fan's worst falls to `enough`. Whether
// v moved.
bool relaxCorner(TriangleMesh& mesh, std::uint32_t v, const std::vector<std::uint32_t>& fan, double reach,
                 const SurfaceBound& bound, double enough)
{
    static const std::vector<glm::dvec3> directions = [] {
        std::vector<glm::dvec3> d;
        for (int x = -1; x <= 1; ++x)
            for (int y = -1; y <= 1; ++y)
                for (int z = -1; z <= 1; ++z)
                    if (x != 0 || y != 0 || z != 0) d.push_back(glm::normalize(glm::dvec3(x, y, z)));
        return d;
    }();
    std::vector<glm::dvec3>& p = mesh.vertices;
    const glm::dvec3 start = p[v];
    std::vector<glm::dvec3> facing;
    for (const std::uint32_t f : fan) facing.push_back(faceNormal(mesh, mesh.triangles[f]));
    // The fan's worst aspect ratio with v at q; infinite where a triangle would turn over.
    const auto worstAt = [&](const glm::dvec3& q) {
        p[v] = q;
        double worst = 0.0;
        for (std::size_t i = 0; i < fan.size(); ++i) {
            const Triangle& t = mesh.triangles[fan[i]];
            if (!(glm::dot(faceNormal(mesh, t), facing[i]) > 0.0)) {
                worst = std::numeric_limits<double>::infinity();
                break;
            }
            worst = std::max(worst, aspectRatio(p[t[0]], p[t[1]], p[t[2]]));
        }
        p[v] = start;
        return worst;
    };
    // Better: a lower worst aspect ratio down to kCollapseAspect, then a shorter move. So the
    // corner goes as little as it must.
    const double was = worstAt(start);
    double best = std::max(was, kCollapseAspect), bestMove = 0.0;
    glm::dvec3 at = start;
    for (double step = 0.5 * reach; step > reach / 4096.0;) {
        glm::dvec3 next = at;
        for (const glm::dvec3& d : directions) {
            const glm::dvec3 q = at + step * d;
            const double move = glm::distance(q, start);
            if (move > reach) continue;
            const double worst = std::max(worstAt(q), kCollapseAspect);
            if (worst < best * (1.0 - 1e-9) || (worst == best && move < bestMove)) {
                best = worst;
                bestMove = move;
                next = q;
            }
        }
        if (next == at) step *= 0.5;
        at = next;
    }
    if (!(best < was) || !(worstAt(at) <= enough)) return false;
    p[v] = at;
    for (const std::uint32_t f : fan) {
        const Triangle& t = mesh.triangles[f];
        if (!bound.holds(p[t[0]], p[t[1]], p[t[2]])) {
            p[v] = start;
            return false;
        }
    }
    return true;
}

} // namespace

long long moveNeedleCorners(TriangleMesh& mesh, const std::vector<glm::dvec3>& coarser, double reach,
                            const SurfaceBound& bound)
{
    std::vector<glm::dvec3>& p = mesh.vertices;
    CoarserVertices kept(coarser);
    std::vector<std::uint32_t> corners;
    for (const Triangle& t : mesh.triangles)
        if (aspectRatio(p[t[0]], p[t[1]], p[t[2]]) > kLargestAspect)
            for (const std::uint32_t v : t)
                if (!kept.has(p[v])) corners.push_back(v);
    if (corners.empty()) return 0;
    // By position: the same moves whichever way the level was built.
    std::sort(corners.begin(), corners.end(),
              [&](std::uint32_t x, std::uint32_t y) { return before(p[x], p[y]) || (p[x] == p[y] && x < y); });
    corners.erase(std::unique(corners.begin(), corners.end()), corners.end());
    VertexFans around(p.size());
    for (const std::uint32_t v : corners) around[v];
    for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f)
        for (const std::uint32_t v : mesh.triangles[f]) around.offer(v, f);
    long long moved = 0;
    // A corner moves only where that takes its fan's needles away: the edge splits after take
    // those left, with a smaller move (a needle's far corner, its short edge between two vertices
    // of the coarser level, went the whole reach for 174 -> 122).
    for (const std::uint32_t v : corners)
        moved += relaxCorner(mesh, v, around[v], reach, bound, kLargestAspect) ? 1 : 0;
    return moved;
}

long long splitNeedleEdges(TriangleMesh& mesh, double reach, const SurfaceBound& bound)
{
    std::vector<glm::dvec3>& p = mesh.vertices;
    const auto aspectOf = [&](const Triangle& t) { return aspectRatio(p[t[0]], p[t[1]], p[t[2]]); };
    std::vector<std::uint32_t> needles;
    for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f)
        if (aspectOf(mesh.triangles[f]) > kLargestAspect) needles.push_back(f);
    if (needles.empty()) return 0;
    // Worst first; then by triangle, as tiled: the same whichever way the level was built.
    std::stable_sort(needles.begin(), needles.end(), [&](std::uint32_t x, std::uint32_t y) {
        return aspectOf(mesh.triangles[x]) > aspectOf(mesh.triangles[y]);
    });
    // The triangles around the needles' corners and the new vertices (one per split at most). An
    // entry may be stale (a split took the triangle off the vertex, or was undone): the edge's
    // triangle is looked up by what the triangles hold now.
    VertexFans around(p.size() + needles.size());
    for (const std::uint32_t f : needles)
        for (const std::uint32_t v : mesh.triangles[f]) around[v];
    for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f)
        for (const std::uint32_t v : mesh.triangles[f]) around.offer(v, f);
    long long split = 0;
    for (const std::uint32_t f : needles) {
        const Triangle needle = mesh.triangles[f];
        const double was = aspectOf(needle);
        if (!(was > kLargestAspect)) continue; // an earlier split took it
        // The needle runs a -> b along its longest edge; the triangle across runs b -> a.
        int k = 0;
        for (int i = 1; i < 3; ++i)
            if (glm::distance(p[needle[i]], p[needle[(i + 1) % 3]]) >
                glm::distance(p[needle[k]], p[needle[(k + 1) % 3]]))
                k = i;
        const std::uint32_t a = needle[k], b = needle[(k + 1) % 3], c = needle[(k + 2) % 3];
        std::vector<std::uint32_t> on;
        for (const std::uint32_t h : around[a])
            if (h != f && h < mesh.triangles.size() && oppositeCorner(mesh.triangles[h], b, a) >= 0) on.push_back(h);
        std::sort(on.begin(), on.end());
        on.erase(std::unique(on.begin(), on.end()), on.end());
        if (on.size() != 1) continue; // a boundary or non-manifold edge stays
        const std::uint32_t g = on.front();
        const Triangle other = mesh.triangles[g];
        const std::uint32_t d = other[oppositeCorner(other, b, a)];
        if (d == c) continue; // a pillow: the edge from the midpoint to c would hold four triangles
        const double worstBefore = std::max(was, aspectOf(other));
        // The midpoint leaves the surface where it was; then it moves as little as it must.
        const std::uint32_t m = static_cast<std::uint32_t>(p.size());
        p.push_back(0.5 * (p[a] + p[b]));
        const std::uint32_t f2 = static_cast<std::uint32_t>(mesh.triangles.size()), g2 = f2 + 1;
        mesh.triangles[f] = {a, m, c};
        mesh.triangles[g] = {b, m, d};
        mesh.triangles.push_back({m, b, c});
        mesh.triangles.push_back({m, a, d});
        const std::vector<std::uint32_t> fan = {f, f2, g, g2};
        relaxCorner(mesh, m, fan, reach, bound, std::numeric_limits<double>::infinity());
        double worstAfter = 0.0;
        for (const std::uint32_t h : fan) worstAfter = std::max(worstAfter, aspectOf(mesh.triangles[h]));
        if (worstAfter < worstBefore) {
            around[m] = fan;
            for (const std::uint32_t v : {b, c}) around.offer(v, f2);
            for (const std::uint32_t v : {a, d}) around.offer(v, g2);
            ++split;
            continue;
        }
        mesh.triangles.resize(f2);
        mesh.triangles[f] = needle;
        mesh.triangles[g] = other;
        p.pop_back();
    }
    return split;
}

long long flipNeedles(TriangleMesh& mesh, const Volume& volume, int axis, const std::vector<glm::dvec3>& coarser)
{
    return NeedleFlipper(mesh, volume, axis, coarser).run();
}

} // namespace pipetile
