// pipetile — caps: closing where tubes end.

#include <pipetile/caps.h>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
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

} // namespace pipetile
