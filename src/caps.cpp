// pipetile — caps: closing where tubes end. The apex search and ear clipping (caps.h), and the
// reconstruction's stage that uses them (multires.h, Reconstruction::closeEnds): end contours past
// a tube's last slice, apexes, rims and annuli.

#include <pipetile/caps.h>
#include <pipetile/error.h>
#include <pipetile/multires.h>

#include "reconstruction_state.h"

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace pipetile {

namespace {

constexpr double kApexStep = 0.25; // voxels between the march's samples

// The march of findApex: the first sample k (at k quarter voxels from the plane) outside the
// region, 0 if `point` is not in it on the plane, -1 if it goes on past `reach`.
int apexStep(const SlicePlane& plane, const glm::dvec2& point, double direction, double reach, double sign)
{
    const double w0 = plane.w();
    if (!(sign * plane.sampleAt(point, w0) < 0.0)) return 0;
    for (int k = 1; k * kApexStep <= reach + 1e-9; ++k)
        if (!(sign * plane.sampleAt(point, w0 + direction * k * kApexStep) < 0.0)) return k;
    return -1;
}

// The bisection of findApex: where, between samples k - 1 (inside) and k (outside), the region ends.
double apexBetween(const SlicePlane& plane, const glm::dvec2& point, double direction, int k, double sign)
{
    const double w0 = plane.w();
    double lo = (k - 1) * kApexStep, hi = k * kApexStep;
    for (int i = 0; i < 40; ++i) {
        const double mid = 0.5 * (lo + hi);
        (sign * plane.sampleAt(point, w0 + direction * mid) < 0.0 ? lo : hi) = mid;
    }
    return w0 + direction * 0.5 * (lo + hi);
}

// Lawson's flips inside the polygon: a diagonal shared by two triangles that form a convex
// quadrilateral gives way to the other diagonal where that makes the thinner of the two
// triangles fatter (longest edge squared over area, as the reports' aspect ratio). Ear clipping
// takes the first ear along the ring, and where points lie nearly on a line (a patch's along a
// loop, crossings along a straight contour) those ears are needles that flips turn into fans
// from the far side (aspect 130 in the smoke's plane y = 63). The polygon's own edges stay, and
// so does the orientation (`orientation` signs a counterclockwise turn), so the triangles still
// tile the same polygon. Each flip lowers the sorted list of thinnesses, so they end.
void fattenDiagonals(const std::vector<glm::dvec2>& p, double orientation, std::vector<Triangle>& triangles)
{
    const std::size_t m = p.size();
    auto turn = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
        const glm::dvec2 u = p[b] - p[a], v = p[c] - p[b];
        return orientation * (u.x * v.y - u.y * v.x);
    };
    auto thinness = [&](const Triangle& t) {
        const glm::dvec2 u = p[t[1]] - p[t[0]], v = p[t[2]] - p[t[1]], w = p[t[0]] - p[t[2]];
        const double longest = std::max({glm::dot(u, u), glm::dot(v, v), glm::dot(w, w)});
        const double twiceArea = std::abs(u.x * v.y - u.y * v.x);
        return twiceArea > 0.0 ? longest / twiceArea : std::numeric_limits<double>::infinity();
    };
    auto onRing = [&](std::uint32_t a, std::uint32_t b) { return (a + 1) % m == b || (b + 1) % m == a; };
    std::vector<std::vector<std::uint32_t>> around(m);
    for (std::uint32_t f = 0; f < triangles.size(); ++f)
        for (const std::uint32_t v : triangles[f]) around[v].push_back(f);
    auto holds = [&](std::uint32_t f, std::uint32_t v) {
        const Triangle& t = triangles[f];
        return t[0] == v || t[1] == v || t[2] == v;
    };
    std::deque<std::pair<std::uint32_t, std::uint32_t>> queue;
    for (const Triangle& t : triangles)
        for (int k = 0; k < 3; ++k)
            if (!onRing(t[k], t[(k + 1) % 3])) queue.emplace_back(t[k], t[(k + 1) % 3]);
    while (!queue.empty()) {
        auto [a, b] = queue.front();
        queue.pop_front();
        std::uint32_t on[2], count = 0;
        for (const std::uint32_t f : around[a])
            if (holds(f, b) && count < 2) on[count++] = f;
        if (count != 2) continue;
        // t1 runs a -> b with c opposite, t2 b -> a with d opposite.
        const auto opposite = [&](std::uint32_t f, std::uint32_t from, std::uint32_t to) -> std::int64_t {
            const Triangle& t = triangles[f];
            for (int k = 0; k < 3; ++k)
                if (t[k] == from && t[(k + 1) % 3] == to) return t[(k + 2) % 3];
            return -1;
        };
        std::uint32_t f1 = on[0], f2 = on[1];
        if (opposite(f1, a, b) < 0) std::swap(f1, f2);
        const std::int64_t c64 = opposite(f1, a, b), d64 = opposite(f2, b, a);
        if (c64 < 0 || d64 < 0 || c64 == d64) continue;
        const auto c = static_cast<std::uint32_t>(c64), d = static_cast<std::uint32_t>(d64);
        const Triangle n1{c, a, d}, n2{d, b, c};
        if (!(turn(c, a, d) > 0.0 && turn(d, b, c) > 0.0)) continue; // not convex
        if (std::any_of(around[c].begin(), around[c].end(), [&](std::uint32_t f) { return holds(f, d); })) continue;
        const double before = std::max(thinness(triangles[f1]), thinness(triangles[f2]));
        if (!(std::max(thinness(n1), thinness(n2)) < before * (1.0 - 1e-9))) continue;
        triangles[f1] = n1;
        triangles[f2] = n2;
        around[b].erase(std::find(around[b].begin(), around[b].end(), f1));
        around[d].push_back(f1);
        around[a].erase(std::find(around[a].begin(), around[a].end(), f2));
        around[c].push_back(f2);
        for (const auto& side : {std::pair{c, a}, std::pair{a, d}, std::pair{d, b}, std::pair{b, c}})
            if (!onRing(side.first, side.second)) queue.push_back(side);
    }
}

} // namespace

bool findApex(const SlicePlane& plane, const glm::dvec2& center, double direction, double reach, double& wApex,
              double sign)
{
    const int k = apexStep(plane, center, direction, reach, sign);
    if (k <= 0) return false;
    wApex = apexBetween(plane, center, direction, k, sign);
    return true;
}

bool farthestReach(const SlicePlane& plane, const BoundaryLoop& loop, double direction, double reach, double& w,
                   double sign)
{
    if (loop.points.empty()) return false;
    glm::dvec2 lo = loop.points.front(), hi = lo;
    for (const glm::dvec2& p : loop.points) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    // Cells' centres (between pixels) and the pixels' own, or every k-th of each in a large loop:
    // probes far enough apart to be cheap, near enough to catch a twisted end's corner (a voxel or
    // two wide). Both: a cell's centre averages four pixels and misses a spike a pixel wide (the
    // smoke along x: a corner pixel reaching a voxel past a blob's end, whose neighbours lie just
    // below the isovalue), and a pixel's centre misses what reaches past between pixels.
    constexpr double kProbesPerSide = 16.0;
    const double step = std::max(1.0, std::ceil(std::max(hi.x - lo.x, hi.y - lo.y) / kProbesPerSide));
    // Every probe marches; only those whose march went farthest are bisected, as a probe that
    // left the region a sample sooner ends at least that much nearer.
    int farthest = 0;
    std::vector<glm::dvec2> leaders;
    for (const double offset : {0.5, 0.0}) {
        for (double y = std::floor(lo.y) + offset; y < hi.y; y += step) {
            for (double x = std::floor(lo.x) + offset; x < hi.x; x += step) {
                const glm::dvec2 probe(x, y);
                if (!encloses(loop, probe)) continue;
                const int k = apexStep(plane, probe, direction, reach, sign);
                if (k <= 0 || k < farthest) continue;
                if (k > farthest) leaders.clear();
                farthest = k;
                leaders.push_back(probe);
            }
        }
    }
    for (std::size_t i = 0; i < leaders.size(); ++i) {
        const double wProbe = apexBetween(plane, leaders[i], direction, farthest, sign);
        if (i == 0 || direction * (wProbe - w) > 0.0) w = wProbe;
    }
    return !leaders.empty();
}

std::vector<Triangle> earClip(const std::vector<glm::dvec2>& p)
{
    std::vector<std::uint32_t> ring(p.size());
    for (std::uint32_t i = 0; i < ring.size(); ++i) ring[i] = i;
    // A hole's ring runs clockwise: its turns are measured mirrored, so that its convex corners
    // are the ears (clipping its reflex ones laid triangles over the material around the hole).
    double twiceArea = 0.0;
    for (std::size_t k = 0; k < p.size(); ++k) {
        const glm::dvec2 &a = p[k], &b = p[(k + 1) % p.size()];
        twiceArea += a.x * b.y - a.y * b.x;
    }
    const double orientation = twiceArea < 0.0 ? -1.0 : 1.0;
    auto cross = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
        const glm::dvec2 u = p[b] - p[a], v = p[c] - p[b];
        return orientation * (u.x * v.y - u.y * v.x);
    };
    // A copy of a corner (a junction's cut point on a crossing) does not lie inside the ear.
    auto inside = [&](std::uint32_t q, std::uint32_t a, std::uint32_t b, std::uint32_t c) {
        if (p[q] == p[a] || p[q] == p[b] || p[q] == p[c]) return false;
        return cross(a, b, q) >= 0.0 && cross(b, c, q) >= 0.0 && cross(c, a, q) >= 0.0;
    };
    std::vector<Triangle> triangles;
    while (ring.size() > 3) {
        const std::size_t n = ring.size();
        std::size_t clip = n, convexmost = 0;
        double best = -std::numeric_limits<double>::infinity();
        for (std::size_t k = 0; k < n && clip == n; ++k) {
            const std::uint32_t a = ring[(k + n - 1) % n], b = ring[k], c = ring[(k + 1) % n];
            const double turn = cross(a, b, c);
            if (turn > best) {
                best = turn;
                convexmost = k;
            }
            // A corner with a copy beside it is clipped at once: its triangle has no area to
            // cover anything, and the ring goes on without the copy (whose zero-length edge
            // turns neither way, and left no clean ear on either side of it).
            const bool copy = p[a] == p[b] || p[b] == p[c];
            if (!copy && turn <= 0.0) continue;
            bool ear = true;
            for (std::size_t j = 0; j < n && ear && !copy; ++j) {
                const std::uint32_t q = ring[j];
                if (q != a && q != b && q != c && inside(q, a, b, c)) ear = false;
            }
            if (ear) clip = k;
        }
        if (clip == n) clip = convexmost;
        triangles.push_back({ring[(clip + n - 1) % n], ring[clip], ring[(clip + 1) % n]});
        ring.erase(ring.begin() + static_cast<std::ptrdiff_t>(clip));
    }
    if (ring.size() == 3) triangles.push_back({ring[0], ring[1], ring[2]});
    fattenDiagonals(p, orientation, triangles);
    return triangles;
}

// The closeEnds stage of the reconstruction: what the graph leaves open at tube ends.

namespace {

// End contours sit a quarter voxel inside where the object ends, and an end contour lies at least
// a quarter voxel past the contour before it (addEndContour).
constexpr double kEndInset = 0.25;
constexpr double kShortestEndStep = 0.25;

// Pixels apart, on average, that a band to an end contour may pair points (misregistration): the
// bands' own bound on shape change (correspond).
constexpr double kOutOfRegister = 3.0;

// A bound on end contours per end, against a region that somehow never ends (each adds at most a
// slice spacing; a twisted flat end needs one, a long oblique one two).
constexpr int kMostEndContours = 8;

// Whether a cap on the loop seen as `view` fans round its apex: the loop is star-shaped from its
// central point with the finest rays (a ray crossing it more than once would at every finer level
// too). Else the cap is ear-clipped, flat in the loop's plane.
bool fansRoundItsApex(const LoopView& view, const RaySet& finest, const SlicePlane& plane)
{
    const Contour c = castRays(view, finest, plane);
    return !c.crossings.empty() && countEdges(c, EdgeType::Forward) == static_cast<int>(c.edges.size());
}

// The graph ends a tube inside the slab up to the next plane: what the axis meets more than half a
// voxel past that plane is another piece's region (the labelling parts them where the field along
// one line does not), and end contours that followed it stacked 8 deep inside the smoke's blob.
// The half voxel lets an apex touch the next plane, or a flat end lie in it (with less, 16 of the
// phantoms' meshes changed).
constexpr double kPastNextPlane = 0.5;

// Pixels that a voxel plane between an end's last plane of the graph and the next one may show the
// end's region beyond every contour of that end before the end's cells mesh it: a voxel, as for
// a band (graph.cpp, kBandStray). A distance across the plane overstates the distance to a surface
// that leans toward it, and a margin of half a pixel more left an arm 1.47 pixels past its end's
// last contour in a random crop of the smoke (survey seed 120), 1.43 voxels off at the top level.
constexpr double kEndStray = 1.0;

// How far past a tube's last contour its end is sought: a slice spacing and two voxels.
double endReach(const MeshOptions& options)
{
    return options.slicing.spacingVoxels + 2.0;
}

// Index in [0, count) of the candidate that `accept` takes whose point is nearest `target` (the
// first of equals); -1 if it takes none.
template <class PointOf, class Accept>
int nearest(int count, const glm::dvec2& target, const PointOf& pointOf, const Accept& accept)
{
    int best = -1;
    double bestDistance2 = 0.0;
    for (int k = 0; k < count; ++k) {
        if (!accept(k)) continue;
        const glm::dvec2 d = pointOf(k) - target;
        const double distance2 = d.x * d.x + d.y * d.y;
        if (best < 0 || distance2 < bestDistance2) {
            best = k;
            bestDistance2 = distance2;
        }
    }
    return best;
}

} // namespace

std::optional<Reconstruction::SliceLoop> Reconstruction::endContourAt(int s, int l, bool hole, double w,
                                                                      const std::pair<int, int>& onGraph, bool& parted)
{
    const SliceLoop& member = mLoops[s][l];
    std::vector<BoundaryLoop> loops = traceBoundaries(SlicePlane(mVolume, mPlan, w));
    // A loop that overlaps the member may be another object's, which the slab keeps apart from it
    // (the smoke: a speck of one voxel, capped, took the 168-pixel loop of the web around it half
    // a voxel on as its end contour, and its band fanned that whole loop to the speck, 2.5 voxels
    // inside the solid).
    // Each loop asked once: the pixel overlaps are the cost.
    std::vector<char> continues(loops.size());
    for (std::size_t k = 0; k < loops.size(); ++k) {
        const BoundaryLoop& candidate = loops[k];
        continues[k] = candidate.hole() == hole && std::abs(candidate.area) >= mOptions.minContourArea &&
                       (encloses(candidate, member.view.center) || encloses(member.loop, candidate.centroid) ||
                        overlapPixels(member.loop, candidate, glm::ivec2(0)) > 0) &&
                       !sharedWithOthers(onGraph.first, onGraph.second, candidate);
    }
    const int best = nearest(
        static_cast<int>(loops.size()), member.view.center, [&](int k) { return loops[k].centroid; },
        [&](int k) { return continues[static_cast<std::size_t>(k)] != 0; });
    if (best < 0) return std::nullopt;
    parted = std::count(continues.begin(), continues.end(), 1) > 1;
    // Its own central point, from which the apex is highest on a rounded end; but where
    // the band from the last contour to it would pair points more than 3 pixels apart on
    // average (as bands may change shape, correspond), the point that follows the last
    // contour's as along the tube (followCentres), if that pairs them closer: a C's own
    // point can lie elsewhere in it (the twisting C's end band turned a quarter turn, 13.9
    // pixels out of register and 6.2 voxels off the surface).
    SliceLoop endLoop{std::move(loops[best]), {}, {}};
    const glm::dvec2 center = centralPoint(endLoop.loop);
    endLoop.view = viewFrom(endLoop.loop, center);
    endLoop.profile = radialProfile(endLoop.view, profileDirections());
    const double own = endLoop.view.winding == 1
                           ? misregistration(member.view, member.profile, endLoop.view, endLoop.profile)
                           : std::numeric_limits<double>::infinity();
    const glm::dvec2 followed = followedCentre(member, endLoop);
    if (own > kOutOfRegister && followed != center) {
        LoopView view = viewFrom(endLoop.loop, followed);
        RadialProfile profile = view.winding == 1 ? radialProfile(view, profileDirections()) : RadialProfile{};
        if (view.winding == 1 && misregistration(member.view, member.profile, view, profile) < own) {
            endLoop.view = std::move(view);
            endLoop.profile = std::move(profile);
        }
    }
    if (endLoop.view.winding != 1) return std::nullopt;
    return endLoop;
}

bool Reconstruction::sharedWithOthers(int s, int l, const BoundaryLoop& candidate) const
{
    const std::vector<SliceLoop>& plane = mLoops[static_cast<std::size_t>(s)];
    for (std::size_t k = 0; k < plane.size(); ++k)
        if (static_cast<int>(k) != l && plane[k].loop.hole() == candidate.hole() &&
            overlapPixels(plane[k].loop, candidate, glm::ivec2(0)) > 0)
            return true;
    return false;
}

double Reconstruction::roomPast(double w, double direction) const
{
    double room = std::numeric_limits<double>::infinity();
    for (const int plane : mGraph.order) {
        const double ahead = direction * (mPositions[plane] - w);
        if (ahead > 0.0) room = std::min(room, ahead);
    }
    return room;
}

void Reconstruction::appendEndContour(Tube& tube, bool top, double w, SliceLoop loop)
{
    mPositions.push_back(w);
    mLoops.push_back({});
    mLoops.back().push_back(std::move(loop));
    const std::pair<int, int> added{static_cast<int>(mPositions.size()) - 1, 0};
    if (top)
        tube.members.push_back(added);
    else
        tube.members.insert(tube.members.begin(), added);
    ++mStats.endContours;
}

void Reconstruction::meetHalfway(Tube& tube, bool top)
{
    // An end where the object goes on: the contours on either side of the unresolved piece reach
    // to the slab's middle, unchanged (cut against their own polygon there), and are capped flat
    // where they meet. Capped on their own planes, they left the slab's layer of the object out
    // (the smoke at iso 0.1: 5.8 voxels of isosurface uncovered). The middle plane's own loops
    // are no end for them: which of them continues a contour is what the piece left unresolved
    // (an island in a blob's hole took the blob's wall, and the smoke's area grew sixfold).
    const double direction = top ? 1.0 : -1.0;
    const auto [s, l] = top ? tube.members.back() : tube.members.front();
    const double room = roomPast(mPositions[s], direction);
    if (!std::isfinite(room)) return;
    SliceLoop prism = mLoops[s][l];
    prism.onPolygon = true;
    appendEndContour(tube, top, mPositions[s] + direction * 0.5 * room, std::move(prism));
}

bool Reconstruction::addEndContour(Tube& tube, bool top, bool probeAnyway)
{
    // A tube end that no junction joins. Where the axis through the end contour's central point
    // leaves the object, an end contour a quarter voxel inside that point is added, so caps sit
    // within a quarter voxel of flat ends and follow rounded ones; the apex is then sought again
    // from it. (Closer in, the field's rounding at the rim of a flat end shrinks the end contour:
    // the bean's top level is 0.75 voxels off with 0.1, 0.53 with 0.25, 0.62 with 0.5.) Where the
    // region inside the contour reaches farther than that axis (a flat end twisted, so the axis
    // leaves through the side: the twisting C's cap was 1.65 voxels below its end), the end
    // contour goes a quarter voxel inside the farthest reach instead, at most a slice spacing on.
    // The next call goes on from it: a twisted end gets two, the first from the axis.
    TubeEnd& end = top ? tube.top : tube.bottom;
    const double direction = top ? 1.0 : -1.0;
    const auto [s, l] = top ? tube.members.back() : tube.members.front();
    const SliceLoop& member = mLoops[s][l];
    const SlicePlane plane(mVolume, mPlan, mPositions[s]);
    const double reach = std::min(endReach(mOptions), direction * (end.wBound - plane.w()));
    double wApex = plane.w();
    const double sign = tube.hole ? -1.0 : 1.0;
    end.hasApex = findApex(plane, member.view.center, direction, reach, wApex, sign);
    end.apexIndex = planeToIndex(mPlan.axis, member.view.center, wApex);
    // Without one (the axis starts at a pinch, or in a hole), a hole's end looks further at once:
    // if its outside ends (a cavity's lid) it is no pipe's opening; a wall's end only if no rim
    // joins it (probeAnyway), as a pipe's wall around its opening reaches past the plane too.
    double wFar = wApex;
    const bool reaches =
        (end.hasApex || tube.hole || probeAnyway) && farthestReach(plane, member.loop, direction, reach, wFar, sign);
    if (!end.hasApex && !reaches) return false;
    if (!end.hasApex) wApex = wFar;
    end.hasApex = true;
    end.apexIndex = planeToIndex(mPlan.axis, member.view.center, wApex);
    // A cap leaves out what the region reaches past its apex. On a rounded end that is little
    // (the bean's tilted domes: 0.12 voxel); half a voxel or more is an end the axis left early
    // (the C twisting 15 degrees per voxel: its top apex 0.33 voxel past the last slice, its flat
    // end 1.0, capped at the slice without an end contour).
    // Half a voxel of the smallest edge, the unit of the top level's bound: along an axis whose
    // voxels are longer, fewer of its own (the vmtk aorta sliced along z, voxels 1.5 long and 0.88
    // across: a crop's floor reaching 0.45 voxel of z past the apex was capped 1.25 voxels off).
    constexpr double kCapSlack = 0.5;
    const double axisVoxel = mVolume.smallestVoxel() / mVolume.voxelSize()[static_cast<int>(mPlan.axis)];
    const double slack = kCapSlack * axisVoxel;
    // A contour that is not star-shaped from its central point would be capped flat in its plane
    // by ear clipping, and so, most likely, would its end contour: no apex reaches past that cap,
    // and the end contour goes to the farthest reach whatever the slack (an aorta crop's top end
    // was capped flat 0.54 voxel of z under where the region reached, 1.36 voxels off; 0.86 now).
    const bool flat = !fansRoundItsApex(member.view, RaySet{mOptions.baseRays, mOptions.levels - 1}, plane);
    const double wTarget = reaches && (flat || direction * (wFar - wApex) > slack) ? wFar : wApex;
    // The end band is held to the bands' rule (correspond): halved, until a quarter voxel or less,
    // while it pairs points more than 3 pixels apart on average (the twisting C's end band, 17.5
    // degrees of turn in one step, was 1.07 voxels off), or would fan a part of the last contour
    // more than 3 pixels from the end contour across a gap of it wider than that (a U-shaped
    // contour at a crop's face whose end contour keeps one arm: in register on average, 2.25
    // pixels, but the other arm fanned across 14 pixels of air, 4.05 voxels off), or a part of
    // the end contour across such a gap of it toward the last contour (the smoke at iso 0.1 along
    // x: a lobe of the end contour, which the last contour lacks, fanned to one point of it 5
    // voxels away, 1.01 voxels off; 0.92 now). Still out of register there, the end contour is
    // another shape than the last contour's, and no end of it: the last contour is capped
    // instead (a crop of the smoke: an arm of a contour of 235 pixels ends within a quarter voxel,
    // and the band to an end contour of 56 fanned the arm's crossings across air to one point,
    // 2.30 voxels off; capped at the contour, 0.76).
    // The inset and the shortest step are quarter voxels of the smallest edge too (another crop
    // of the aorta: a sliver along a face of its box reaching 0.4 voxel of z past its last slice,
    // too close for an end contour a quarter voxel of z inside, was capped flat at the slice, 1.12
    // voxels off).
    const double inset = kEndInset * axisVoxel, shortest = kShortestEndStep * axisVoxel;
    double step = std::min(direction * (wTarget - plane.w()) - inset, mOptions.slicing.spacingVoxels);
    // From a voxel plane, the first end contour goes no farther than the next voxel plane, which
    // the end's band would otherwise pass by: a crop of the smoke starts a tube at y = 100 whose
    // region at 99 reaches 4 voxels past its contour, a ledge barely past the isovalue that
    // neither 100 nor an end contour at 98.6 shows (2.48 voxels off at the top level, now 0.83).
    if (plane.w() == std::floor(plane.w())) step = std::min(step, 1.0);
    if (step < shortest) return false;
    // An end contour's plane holds it alone: the loops it must keep off are those of the tube's
    // last plane of the graph (the smoke at iso 0.1: a speck's second end contour took a ring of
    // 1698 pixels around another object's hole, capped flat 5.7 voxels off the surface).
    const std::pair<int, int> onGraph = tube.members[graphEnd(tube, top)];
    const auto outOfRegister = [&](const SliceLoop& end) {
        return misregistration(member.view, member.profile, end.view, end.profile) > kOutOfRegister ||
               widestGapToward(member.view, end.view, kOutOfRegister) > kOutOfRegister ||
               widestGapToward(end.view, member.view, kOutOfRegister) > kOutOfRegister;
    };
    // Where the end's region has parted into several summits by the end contour's plane, the
    // contour keeps one and the band to it cuts the others off: halved too, down to the shortest
    // step, the end contour holds them all where a plane closer in still joins them (a crop of
    // the vmtk aorta at a corner of its box: a summit 0.2 voxel of z higher than the end contour
    // at 21.55, cut off from z = 21 up, 1.18 voxels off at the top level).
    bool parted = false;
    std::optional<SliceLoop> endLoop = endContourAt(s, l, tube.hole, plane.w() + direction * step, onGraph, parted);
    bool apart = endLoop && outOfRegister(*endLoop);
    while (endLoop && step > shortest && (apart || parted)) {
        bool closerParted = false;
        std::optional<SliceLoop> closer =
            endContourAt(s, l, tube.hole, plane.w() + direction * 0.5 * step, onGraph, closerParted);
        if (!closer) break;
        endLoop = std::move(closer);
        apart = outOfRegister(*endLoop);
        parted = closerParted;
        step *= 0.5;
    }
    end.unregistered = endLoop && apart;
    if (!endLoop || apart) return false;
    const double wEnd = plane.w() + direction * step;
    const glm::dvec2 center = endLoop->view.center;
    appendEndContour(tube, top, wEnd, std::move(*endLoop)); // `member` dangles from here on
    double wAgain = wEnd;
    end.hasApex = findApex(SlicePlane(mVolume, mPlan, wEnd), center, direction,
                           std::min(2.0 * kEndInset + 1.0, direction * (end.wBound - wEnd)), wAgain, sign);
    end.apexIndex = planeToIndex(mPlan.axis, center, wAgain);
    return true;
}

std::size_t Reconstruction::graphEnd(const Tube& tube, bool top) const
{
    for (std::size_t k = 0; k < tube.members.size(); ++k) {
        const std::size_t m = top ? tube.members.size() - 1 - k : k;
        if (std::find(mGraph.order.begin(), mGraph.order.end(), tube.members[m].first) != mGraph.order.end()) return m;
    }
    return top ? tube.members.size() - 1 : 0;
}

void Reconstruction::closeEnd(Tube& tube, bool top, bool probeAnyway,
                              std::map<double, std::vector<BoundaryLoop>>& voxelPlanes)
{
    const std::size_t planes = mPositions.size();
    for (int added = 0; added < kMostEndContours && addEndContour(tube, top, probeAnyway); ++added) {
    }
    // An end whose end contour could not be brought into register is another shape past the
    // plane than the contour, and its cap at the contour can lie far from the surface (a crop of
    // the smoke: 1.16 voxels; another, 2.08). So is one that a voxel plane before its cap shows
    // reaching farther than its contours (a blob's flat top in one voxel plane, barely past the
    // isovalue: its end contour a quarter voxel below was a sliver of it, 2.40 voxels off). Where
    // the cells of the graph's piece that ends it close it with the piece's Euler characteristic,
    // they mesh it instead of its end contours, as for a fork or merge. So is one whose band to
    // its end contours strayed from the surface at the top level of a first build
    // (strayingPieces: a crop of the smoke, a band fanned across a bay of its last contour).
    // The end contours of this pass are the last planes; an end with end contours from an earlier
    // pass (the first found no apex past its end contour) keeps them.
    const std::size_t added = mPositions.size() - planes, last = graphEnd(tube, top);
    if ((top ? tube.members.size() - 1 - last : last) != added) return;
    TubeEnd& end = top ? tube.top : tube.bottom;
    const auto [s, l] = tube.members[last];
    const bool strayed = mCellPieces.ends.count({top ? 1 : 0, s, l}) > 0;
    if (!(end.unregistered || strayed || reachesPastContours(tube, top, voxelPlanes)) || !patchEnd(tube, top)) return;
    end.hasApex = false;
    ++mStats.endPatches;
    mPositions.resize(planes);
    mLoops.resize(planes);
    if (top)
        tube.members.resize(tube.members.size() - added);
    else
        tube.members.erase(tube.members.begin(), tube.members.begin() + static_cast<std::ptrdiff_t>(added));
    mStats.endContours -= static_cast<int>(added);
}

bool Reconstruction::reachesPastContours(const Tube& tube, bool top,
                                         std::map<double, std::vector<BoundaryLoop>>& voxelPlanes) const
{
    // The end's contours, with their planes: its last on the graph, then its end contours.
    const std::size_t last = graphEnd(tube, top);
    std::vector<std::pair<double, const BoundaryLoop*>> contours;
    for (std::size_t k = top ? last : 0; k <= (top ? tube.members.size() - 1 : last); ++k) {
        const auto [s, l] = tube.members[k];
        contours.emplace_back(mPositions[s], &mLoops[s][l].loop);
    }
    const auto [s, l] = tube.members[last];
    const BoundaryLoop& member = mLoops[s][l].loop;
    const double direction = top ? 1.0 : -1.0, w0 = mPositions[s];
    const double room = std::min(roomPast(w0, direction), endReach(mOptions));
    // The voxel planes between the end's plane and the graph's next one, whatever the cap's apex
    // (a blob's end whose axis leaves it early: its apex half a voxel short of where it reaches on
    // at its side). There the field is the voxels' own, as volumeToMesh's isosurface meets it.
    for (double w = top ? std::floor(w0) + 1.0 : std::ceil(w0) - 1.0; direction * (w - w0) < room; w += direction) {
        auto traced = voxelPlanes.find(w);
        if (traced == voxelPlanes.end())
            traced = voxelPlanes.emplace(w, traceBoundaries(SlicePlane(mVolume, mPlan, w))).first;
        for (const BoundaryLoop& loop : traced->second) {
            if (loop.hole() != tube.hole || overlapPixels(member, loop, glm::ivec2(0)) == 0 ||
                sharedWithOthers(s, l, loop))
                continue;
            // A loop of the end that no contour within half a voxel overlaps is a part the end
            // contours did not follow (each follows one loop: an end that parts in two before it
            // ends left one part a voxel below its flat cap, 1.40 voxels off).
            const auto follows = [&](const std::pair<double, const BoundaryLoop*>& c) {
                return std::abs(c.first - w) <= 0.5 && overlapPixels(*c.second, loop, glm::ivec2(0)) > 0;
            };
            if (std::none_of(contours.begin(), contours.end(), follows)) return true;
            for (const glm::dvec2& p : loop.points) {
                const auto beyond = [&](const std::pair<double, const BoundaryLoop*>& c) {
                    return !encloses(*c.second, p) && boundaryClearance(*c.second, p) > kEndStray;
                };
                if (std::all_of(contours.begin(), contours.end(), beyond)) return true;
            }
        }
    }
    return false;
}

bool Reconstruction::patchEnd(Tube& tube, bool top)
{
    // The piece whose one loop is the tube's end member on the graph and that has none on the
    // other side: on a slab of the graph, or out to the empty plane past the box.
    const auto [s, l] = tube.members[graphEnd(tube, top)];
    const auto ends = [&, l = l](const SlabPiece& p) {
        return (top ? p.below : p.above) == std::vector<int>{l} && (top ? p.above : p.below).empty();
    };
    int below = -1, above = -1;
    const SlabPiece* piece = nullptr;
    if (s == (top ? mGraph.order.back() : mGraph.order.front())) {
        const std::vector<SlabPiece>& past = top ? mGraph.afterLast : mGraph.beforeFirst;
        const auto it = std::find_if(past.begin(), past.end(), ends);
        piece = it != past.end() ? &*it : nullptr;
        (top ? below : above) = s;
    } else {
        for (const ContourGraph::Slab& slab : mGraph.slabs) {
            if ((top ? slab.below : slab.above) != s) continue;
            const auto it = std::find_if(slab.pieces.begin(), slab.pieces.end(), ends);
            if (it == slab.pieces.end()) continue;
            piece = &*it;
            below = slab.below;
            above = slab.above;
        }
    }
    if (!piece) return false;
    std::optional<SlabPatch> surface = std::move(patchesOf(below, above, {piece}).front());
    if (!surface || surface->euler != piece->euler()) return false;
    SlabPiece counted = *piece; // its count stays the graph's: the patch has its Euler characteristic
    (top ? tube.top : tube.bottom).patch = addPatch(below, above, counted, std::move(*surface));
    return true;
}

void Reconstruction::centreLoneContour(SliceLoop& member, const SlicePlane& plane) const
{
    constexpr double kClearance = 0.1; // pixels from the apex's foot to the nearest crossing
    const RaySet finest{mOptions.baseRays, mOptions.levels - 1};
    const auto nearest = [](const Contour& c) {
        double t = std::numeric_limits<double>::infinity();
        for (const Crossing& x : c.crossings) t = std::min(t, x.t);
        return t;
    };
    const Contour from = castRays(member.view, finest, plane);
    if (from.crossings.empty() || nearest(from) >= kClearance) return;
    // The middle of the finest crossings' polygon.
    std::vector<glm::dvec2> points;
    for (const Crossing& x : from.crossings) points.push_back(x.point);
    const std::optional<glm::dvec2> middle = polygonCentroid(points);
    if (!middle || !liesInside(member.loop, *middle)) return;
    LoopView view = viewFrom(member.loop, *middle);
    if (view.winding != 1) return;
    const Contour again = castRays(view, finest, plane);
    // A sliver thinner than that everywhere keeps its point: no other would do better.
    if (again.crossings.empty() || !(nearest(again) >= kClearance)) return;
    member.view = std::move(view);
}

void Reconstruction::closeEnds()
{
    // A contour alone in its tube, with no event at either end, is a speck the caps close by
    // themselves. Its central point can lie a hair from its boundary as the field has it, though
    // well inside its polygon (the smoke at iso 0.1 along x: a crossing 0.007 pixel from it,
    // where the polygon lies 0.1 away); fanned round an apex over it, its triangles were needles
    // of aspect 167 at every level. Its rays go out from the middle of its finest crossings
    // instead, where those lie a tenth of a pixel away or more.
    for (const Tube& tube : mTubes)
        if (tube.members.size() == 1 && !tube.bottom.joined() && !tube.top.joined()) {
            const auto [s, l] = tube.members.front();
            centreLoneContour(mLoops[s][l], SlicePlane(mVolume, mPlan, mPositions[s]));
        }
    for (Tube& tube : mTubes) {
        for (const bool top : {false, true}) {
            const double direction = top ? 1.0 : -1.0;
            const double w = mPositions[(top ? tube.members.back() : tube.members.front()).first];
            (top ? tube.top : tube.bottom).wBound = w + direction * (roomPast(w, direction) + kPastNextPlane);
        }
    }
    std::map<double, std::vector<BoundaryLoop>> voxelPlanes; // traced once for every end they lie past
    // Holes first: a wall whose end plane holds a hole that stays open past it (no lid found)
    // is that hole's rim, whatever its own end does at its central point.
    for (const bool holes : {true, false})
        for (Tube& tube : mTubes) {
            if (tube.hole != holes) continue;
            for (const bool top : {false, true}) {
                // Where the object goes on, the region past the plane is another tube's, and end
                // contours sought in it would stack inside the solid (the smoke at iso 0.1: walls
                // capped at unresolved pieces ran 8 end contours, 16 voxels, into the blob, and the
                // mesh's volume was 40 times the isosurface's); the contour meets the other side's
                // halfway instead, under a flat cap.
                const TubeEnd& end = top ? tube.top : tube.bottom;
                if (end.goesOn) meetHalfway(tube, top);
                if (end.joined() || end.goesOn || end.aroundWall || end.rim) continue;
                const auto rim = [&](const Tube& hole) { return formRim(tube, hole, top); };
                if (!holes && std::any_of(mTubes.begin(), mTubes.end(), rim)) continue;
                closeEnd(tube, top, false, voxelPlanes);
            }
        }
    // A wall's end that the axis through its central point does not meet and no rim joins (a
    // block around cavities, whose centre lies in them) is sought from points all over it.
    for (Tube& tube : mTubes) {
        for (const bool top : {false, true}) {
            const TubeEnd& end = top ? tube.top : tube.bottom;
            const auto rim = [&](const Tube& hole) { return formRim(tube, hole, top); };
            if (tube.hole || end.hasApex || end.joined() || end.goesOn || end.aroundWall || end.rim ||
                std::any_of(mTubes.begin(), mTubes.end(), rim))
                continue;
            closeEnd(tube, top, true, voxelPlanes);
        }
    }
    // One cap style for every level, so that levels nest: an apex fan where the end contour is
    // star-shaped with the finest rays (a ray crossing it more than once would at every finer
    // level too), ear clipping otherwise.
    const RaySet finest{mOptions.baseRays, mOptions.levels - 1};
    for (Tube& tube : mTubes) {
        for (const bool top : {false, true}) {
            TubeEnd& end = top ? tube.top : tube.bottom;
            if (!end.hasApex) continue;
            const auto [s, l] = top ? tube.members.back() : tube.members.front();
            const SlicePlane plane(mVolume, mPlan, mPositions[s]);
            end.fan = fansRoundItsApex(mLoops[s][l].view, finest, plane);
        }
    }
    // A lone contour closed flat on both sides would get the same triangles twice. It is a speck
    // within a voxel of one plane (the smoke at iso 0.1: 3-voxel blobs and voids in one voxel
    // plane, L-shaped, so no point of theirs sees all of them), and the isosurface has it as a
    // component of its own: where either end found how far it reaches, that end fans round its
    // apex anyway. A fold there is smaller than the speck; leaving it out costs a component.
    const auto lone = [](const Tube& t) {
        return t.members.size() == 1 && !t.bottom.fan && !t.top.fan && !t.bottom.joined() && !t.top.joined() &&
               !t.bottom.aroundWall && !t.top.aroundWall && !t.bottom.rim && !t.top.rim;
    };
    for (Tube& tube : mTubes) {
        if (!lone(tube)) continue;
        const double w = mPositions[tube.members.front().first];
        const auto reach = [&](const TubeEnd& end) {
            return end.hasApex ? std::abs(end.apexIndex[mPlan.axis] - w) : -1.0;
        };
        TubeEnd& farther = reach(tube.top) >= reach(tube.bottom) ? tube.top : tube.bottom;
        farther.fan = farther.hasApex;
        if (!farther.fan) fanPastTheNextPlane(tube);
    }
    // Any lone contour left without a fan encloses nothing that was found: it is dropped (and
    // counted) rather than meshed as a flat pillow.
    mStats.droppedFlat = static_cast<int>(std::count_if(mTubes.begin(), mTubes.end(), lone));
    mTubes.erase(std::remove_if(mTubes.begin(), mTubes.end(), lone), mTubes.end());
    if (mTubes.empty())
        throw Error("'" + mVolume.source() + "', grid '" + printableName(mVolume.gridName()) +
                        "': every cross-section lies in a single slice and cannot be closed; lower the spacing",
                    {Setting::Spacing});
    joinRims();
    joinHolesAroundWalls();
}

void Reconstruction::fanPastTheNextPlane(Tube& tube) const
{
    // The graph counts the lone contour as an object of its own, ending within the slabs on
    // either side, but the field can go on past the next plane where that plane's image closes
    // the region (a bridge, slicer.h): a void of one voxel beside a contact volumeToMesh parts,
    // whose ends the search for an apex did not find within its reach. Dropped, the mesh lost
    // the component its events count; its apex goes to the middle of a slab the field fills.
    const auto [s, l] = tube.members.front();
    const SliceLoop& member = mLoops[s][l];
    const SlicePlane plane(mVolume, mPlan, mPositions[s]);
    const double sign = tube.hole ? -1.0 : 1.0;
    if (!(sign * plane.sampleAt(member.view.center, plane.w()) < 0.0)) return;
    for (const bool top : {false, true}) {
        const double direction = top ? 1.0 : -1.0;
        const double room = roomPast(plane.w(), direction);
        if (!std::isfinite(room)) continue;
        const double wMiddle = plane.w() + direction * 0.5 * room;
        if (!(sign * plane.sampleAt(member.view.center, wMiddle) < 0.0)) continue;
        TubeEnd& end = top ? tube.top : tube.bottom;
        end.hasApex = end.fan = true;
        end.apexIndex = planeToIndex(mPlan.axis, member.view.center, wMiddle);
        return;
    }
}

bool Reconstruction::formRim(const Tube& outer, const Tube& hole, bool top) const
{
    const TubeEnd &outerEnd = top ? outer.top : outer.bottom, &holeEnd = top ? hole.top : hole.bottom;
    const auto [os, ol] = top ? outer.members.back() : outer.members.front();
    const auto [hs, hl] = top ? hole.members.back() : hole.members.front();
    // A hole whose outside ends just past it (a cavity's lid) is no pipe's opening.
    return !outer.hole && hole.hole && !outerEnd.hasApex && !holeEnd.hasApex && outerEnd.annulus < 0 &&
           !outerEnd.joined() && !holeEnd.joined() && !outerEnd.aroundWall && !holeEnd.aroundWall && os == hs &&
           encloses(mLoops[os][ol].loop, mLoops[hs][hl].view.center);
}

void Reconstruction::joinRims()
{
    // Hollow pipes: where a hole tube ends in the same plane as the outer tube around it, the two
    // end contours are joined by an annulus, the pipe's rim, instead of closing each wall by a
    // cap of its own (two caps over the hollow, far from any surface). A wall around several such
    // holes (dimples in a face the grid's box cuts) is the rim of them all.
    struct Rim {
        int wall;
        bool top;
        std::vector<int> holes;
    };
    std::vector<Rim> rims; // in the order of their first hole, as the annuli were always made
    for (int h = 0; h < static_cast<int>(mTubes.size()); ++h) {
        if (!mTubes[h].hole) continue;
        for (const bool top : {false, true}) {
            if ((top ? mTubes[h].top : mTubes[h].bottom).joined()) continue;
            // The innermost wall around its boundary: a pipe inside a pipe, both ending here, is
            // two rims (the inner wall may enclose the outer hole's central point, not its edge).
            const auto [hs, hl] = top ? mTubes[h].members.back() : mTubes[h].members.front();
            const glm::dvec2 edge = mLoops[hs][hl].loop.points.front();
            int best = -1;
            double bestArea = 0.0;
            for (int o = 0; o < static_cast<int>(mTubes.size()); ++o) {
                if (!formRim(mTubes[o], mTubes[h], top)) continue;
                const auto [os, ol] = top ? mTubes[o].members.back() : mTubes[o].members.front();
                if (!encloses(mLoops[os][ol].loop, edge)) continue;
                const double area = std::abs(polygonArea(mLoops[os][ol].view.polygon));
                if (best >= 0 && area >= bestArea) continue;
                best = o;
                bestArea = area;
            }
            if (best < 0) continue;
            const auto same = [&](const Rim& r) { return r.wall == best && r.top == top; };
            const auto rim = std::find_if(rims.begin(), rims.end(), same);
            if (rim != rims.end())
                rim->holes.push_back(h);
            else
                rims.push_back({best, top, {h}});
        }
    }
    // A face the grid's box cuts, at its first or last plane, is meshed from its cells out to the
    // empty plane past the box, as volumeToMesh closes it (patchFace). Tiled in the plane, from
    // each hole to the arc of the wall nearest it, it lay over the bays of a wall its holes do
    // not see whole (a crop of the smoke: 2.4 voxels off at the top level); and where a keyhole's
    // slit behind a ring lay in the same plane, no triangulation of the slit avoided all of the
    // annulus's diagonals (an edge with four triangles).
    for (const auto& [wall, top, holes] : rims) {
        if (patchFace(wall, holes, top)) continue;
        if (holes.size() > 1 && joinRimFace(wall, holes, top)) continue;
        const int h = holes.front();
        joinAnnulus(wall, h, top);
        const double w = mPositions[(top ? mTubes[h].members.back() : mTubes[h].members.front()).first];
        const double room = (top ? 1.0 : -1.0) * ((top ? mTubes[h].top : mTubes[h].bottom).wBound - w);
        addRimContours(mTubes[wall], mTubes[h], top, std::min(endReach(mOptions), room), kEndInset);
    }
}

void Reconstruction::joinHolesAroundWalls()
{
    // A hole around a wall (markRim): the wall in its plane that it encloses.
    for (int h = 0; h < static_cast<int>(mTubes.size()); ++h)
        for (const bool top : {false, true}) {
            const auto endOf = [&](int t) { return top ? mTubes[t].members.back() : mTubes[t].members.front(); };
            if (!mTubes[h].hole || !(top ? mTubes[h].top : mTubes[h].bottom).aroundWall) continue;
            const auto [hs, hl] = endOf(h);
            for (int o = 0; o < static_cast<int>(mTubes.size()); ++o) {
                const TubeEnd& wallEnd = top ? mTubes[o].top : mTubes[o].bottom;
                const auto [os, ol] = endOf(o);
                if (mTubes[o].hole || !wallEnd.aroundWall || wallEnd.annulus >= 0 || os != hs ||
                    !encloses(mLoops[hs][hl].loop, mLoops[os][ol].loop.points.front()))
                    continue;
                joinAnnulus(o, h, top);
                break;
            }
        }
}

void Reconstruction::joinAnnulus(int wall, int hole, bool top)
{
    (top ? mTubes[wall].top : mTubes[wall].bottom).annulus = hole;
    (top ? mTubes[hole].top : mTubes[hole].bottom).annulus = wall;
    ++mStats.annularCaps;
}

bool Reconstruction::joinRimFace(int wall, const std::vector<int>& holes, bool top)
{
    // The slab's Rim junction (makeJunction) with no slab: the wall's polygon split into one arc
    // per hole through a hub, each arc tiled to its hole, in the plane.
    const auto endOf = [&](const Tube& tube) { return top ? tube.members.back() : tube.members.front(); };
    Junction junction;
    junction.kind = EventKind::Rim;
    junction.top = top;
    junction.single = endOf(mTubes[wall]);
    for (int h : holes) junction.many.push_back(endOf(mTubes[h]));
    if (!splitJunction(junction)) return false;
    const int id = addJunction(std::move(junction));
    (top ? mTubes[wall].top : mTubes[wall].bottom).junction = id;
    for (int h : holes) (top ? mTubes[h].top : mTubes[h].bottom).junction = id;
    centreParts(static_cast<std::size_t>(id));
    return true;
}

bool Reconstruction::patchFace(int wall, const std::vector<int>& holes, bool top)
{
    // A hole that no nearest wall point sees (inside, behind others: a face of the smoke's crop
    // with six dimples) owns no arc of the wall, and the face would have been an annulus for one
    // hole, the others closed flat as voids of their own. Past the first or last plane, the
    // cells out to empty space give that face, with all its holes.
    const auto endOf = [&](const Tube& tube) { return top ? tube.members.back() : tube.members.front(); };
    const int s = endOf(mTubes[wall]).first;
    if (s != (top ? mGraph.order.back() : mGraph.order.front())) return false;
    std::vector<int> loops{endOf(mTubes[wall]).second};
    for (int h : holes) loops.push_back(endOf(mTubes[h]).second);
    std::sort(loops.begin(), loops.end());
    std::vector<SlabPiece>& past = top ? mGraph.afterLast : mGraph.beforeFirst;
    const auto piece =
        std::find_if(past.begin(), past.end(), [&](const SlabPiece& p) { return (top ? p.below : p.above) == loops; });
    if (piece == past.end()) return false;
    const int below = top ? s : -1, above = top ? -1 : s;
    std::optional<SlabPatch> surface = std::move(patchesOf(below, above, {&*piece}).front());
    if (!surface) return false;
    const int id = addPatch(below, above, *piece, std::move(*surface));
    (top ? mTubes[wall].top : mTubes[wall].bottom).patch = id;
    for (int h : holes) (top ? mTubes[h].top : mTubes[h].bottom).patch = id;
    return true;
}

void Reconstruction::addRimContours(Tube& outer, Tube& hole, bool top, double reach, double inset)
{
    // Where the wall itself ends: from a point in the middle of the wall (halfway from a point of
    // the hole's loop to the nearest point of the outer loop), along the slicing axis.
    const double direction = top ? 1.0 : -1.0;
    const auto [s, ol] = top ? outer.members.back() : outer.members.front();
    const int hl = (top ? hole.members.back() : hole.members.front()).second;
    const BoundaryLoop& outerLoop = mLoops[s][ol].loop;
    const BoundaryLoop& holeLoop = mLoops[s][hl].loop;
    if (outerLoop.points.empty() || holeLoop.points.empty()) return;
    const glm::dvec2 h = holeLoop.points.front();
    glm::dvec2 o = outerLoop.points.front();
    for (const glm::dvec2& p : outerLoop.points)
        if (glm::dot(p - h, p - h) < glm::dot(o - h, o - h)) o = p;
    const glm::dvec2 wall = 0.5 * (h + o);
    const SlicePlane plane(mVolume, mPlan, mPositions[s]);
    double wEnd = plane.w();
    if (!findApex(plane, wall, direction, reach, wEnd)) return;
    wEnd -= direction * inset;
    if (direction * (wEnd - plane.w()) < 0.25) return;
    // The two walls' loops on that plane: the outer one around the hole's centre, and the hole
    // nearest to it; both must still wind once around their central points.
    const SlicePlane endPlane(mVolume, mPlan, wEnd);
    std::vector<BoundaryLoop> loops = traceBoundaries(endPlane);
    const glm::dvec2 holeCenter = mLoops[s][hl].view.center;
    auto nearestAround = [&](bool holeLoop) {
        return nearest(
            static_cast<int>(loops.size()), holeCenter, [&](int k) { return loops[k].centroid; },
            [&](int k) {
                return loops[k].hole() == holeLoop && std::abs(loops[k].area) >= mOptions.minContourArea &&
                       encloses(loops[k], holeCenter);
            });
    };
    const int bestOuter = nearestAround(false), bestHole = nearestAround(true);
    if (bestOuter < 0 || bestHole < 0) return;
    LoopView outerView = viewFrom(loops[bestOuter], centralPoint(loops[bestOuter]));
    LoopView holeView = viewFrom(loops[bestHole], centralPoint(loops[bestHole]));
    if (outerView.winding != 1 || holeView.winding != 1) return;
    mPositions.push_back(wEnd);
    mLoops.push_back({});
    RadialProfile outerProfile = radialProfile(outerView, profileDirections());
    RadialProfile holeProfile = radialProfile(holeView, profileDirections());
    mLoops.back().push_back({std::move(loops[bestOuter]), std::move(outerView), std::move(outerProfile)});
    mLoops.back().push_back({std::move(loops[bestHole]), std::move(holeView), std::move(holeProfile)});
    const int plane2 = static_cast<int>(mPositions.size()) - 1;
    for (const auto& [tube, loop] : {std::pair<Tube*, int>{&outer, 0}, std::pair<Tube*, int>{&hole, 1}}) {
        if (top)
            tube->members.push_back({plane2, loop});
        else
            tube->members.insert(tube->members.begin(), {plane2, loop});
    }
    mStats.endContours += 2;
}

} // namespace pipetile
