// pipetile — sample volumes with known geometry (phantoms).
//
// The 2D and 3D distance primitives (capsule, arc, rounded extrusion) follow Inigo Quilez,
// "Distance functions", https://iquilezles.org/articles/distfunctions/ and .../distfunctions2d/.
// The phantom has the size of the test volumes of Min & Lee §5 (256 x 256 x 512); the paper does
// not describe its shape, so the wandering, breathing tube here is ours.
#include "phantoms.h"

#include <pipetile/error.h>
#include <pipetile/volume_grid.h>

#include <openvdb/tools/SignedFloodFill.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>
#include <utility>

namespace pipetile::samples {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2.0 * kPi;

/// Narrow band of every sample: half-width and background, in voxels.
constexpr double kHalfWidthVoxels = 3.0;
/// Half of the diagonal of an 8^3 block, 4 sqrt(3) voxels: no voxel is farther from its centre.
constexpr double kBlockHalfDiagonalVoxels = 6.928203230275509;
/// Extra reach when deciding whether a block can hold band voxels, in voxels.
constexpr double kBlockSafetyVoxels = 2.0;

// ---------------------------------------------------------------------------------------------
// Exact distance primitives

} // namespace

double capsuleDistance(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b, double radius)
{
    const glm::dvec3 ab = b - a;
    const double t = glm::clamp(glm::dot(p - a, ab) / glm::dot(ab, ab), 0.0, 1.0);
    return glm::length(p - (a + t * ab)) - radius;
}

namespace {

/// Exact 2D signed distance to the points within `thickness` of a circular arc of radius
/// `arcRadius` centred at the origin, symmetric about +y and spanning +-halfAngle from it
/// (Quilez's sdArc). `sinCos` = (sin halfAngle, cos halfAngle). Exact for 0 < halfAngle < pi.
double arcDistance2d(glm::dvec2 q, const glm::dvec2& sinCos, double arcRadius, double thickness)
{
    q.x = std::abs(q.x);
    // Beyond the arc's angular span the nearest arc point is the end on the same side.
    const bool beyondEnd = sinCos.y * q.x > sinCos.x * q.y;
    const double toArc = beyondEnd ? glm::length(q - sinCos * arcRadius) : std::abs(glm::length(q) - arcRadius);
    return toArc - thickness;
}

/// Signed distance to a 2D shape extruded over |z| <= halfHeight with all its edges rounded by
/// `rounding` (Quilez's opExtrusion of the shape eroded by `rounding`, then dilated back).
/// Exact when `d2` is exact and the shape is a curve thickened by at least `rounding` (no sharp
/// corners), with holes and gaps wider than 2 * rounding: erosion and dilation then undo each
/// other, and only the edges between the sides and the end faces get rounded.
double roundedExtrusionDistance(double d2, double z, double halfHeight, double rounding)
{
    const glm::dvec2 w(d2 + rounding, std::abs(z) - halfHeight + rounding);
    return std::min(std::max(w.x, w.y), 0.0) + glm::length(glm::max(w, glm::dvec2(0.0))) - rounding;
}

/// Exact signed distance to a ring around the z axis through `centre`: the points within `radius`
/// of the vertical segment at distance `ringRadius` from the axis, z in centre.z +- halfHeight,
/// swept around the axis. halfHeight 0 gives the torus (tube radius `radius` around a circle of
/// radius `ringRadius`); a positive one stretches the tube's section into a vertical 2D capsule.
/// Exact for ringRadius > radius: the distance in the (distance from the axis, z) half-plane to
/// the 2D capsule, which is exact there, is the distance in space.
double ringDistance(const glm::dvec3& p, const glm::dvec3& centre, double ringRadius, double radius,
                    double halfHeight = 0.0)
{
    const glm::dvec3 q = p - centre;
    const double z = q.z - glm::clamp(q.z, -halfHeight, halfHeight);
    return glm::length(glm::dvec2(glm::length(glm::dvec2(q.x, q.y)) - ringRadius, z)) - radius;
}

/// Exact signed distance to a tube of radius `radius` around a racetrack (stadium curve) in the
/// plane x = centre.x: two straight sides along z at y = centre.y +- ringRadius, z in
/// centre.z +- halfLength, joined above and below by half circles of radius `ringRadius`. This is
/// the torus with axis x elongated along z (Quilez's opElongate): for |q.z| <= halfLength the
/// nearest centre-line point is on a straight side at the same z, beyond it on the half circle;
/// exact for ringRadius > radius.
double racetrackDistance(const glm::dvec3& p, const glm::dvec3& centre, double ringRadius, double radius,
                         double halfLength)
{
    const glm::dvec3 q = p - centre;
    const double z = q.z - glm::clamp(q.z, -halfLength, halfLength);
    return glm::length(glm::dvec2(glm::length(glm::dvec2(q.y, z)) - ringRadius, q.x)) - radius;
}

/// Exact signed distance to a tube of radius `radius` around a half circle of radius `ringRadius`
/// in the plane y = centre.y: the upper half (z >= centre.z) if `upper`, else the lower half. Its
/// ends are centre +- (ringRadius, 0, 0). For points on the half's side of the diameter the
/// nearest point of the full circle lies on the half; on the other side, an end is nearest.
double halfRingDistance(const glm::dvec3& p, const glm::dvec3& centre, double ringRadius, double radius, bool upper)
{
    const glm::dvec3 q = p - centre;
    if ((upper ? q.z : -q.z) >= 0.0) {
        return glm::length(glm::dvec2(glm::length(glm::dvec2(q.x, q.z)) - ringRadius, q.y)) - radius;
    }
    const glm::dvec3 end(ringRadius, 0.0, 0.0);
    return std::min(glm::length(q - end), glm::length(q + end)) - radius;
}

// ---------------------------------------------------------------------------------------------
// Tubes around curved centre lines: distance to a union of balls, found numerically

/// A point of a centre line and the tube radius there, with first and second derivatives in s.
struct CentreLinePoint {
    glm::dvec3 c, dc, ddc;
    double r = 0.0, dr = 0.0, ddr = 0.0;
};

/// Distance to a canal surface: the union of the balls B(c(s), r(s)), s in [sMin, sMax],
///     phi(p) = min_s F(s),  F(s) = |p - c(s)| - r(s).
/// This is the exact distance outside the union; inside it is minus the depth inside the deepest
/// ball, a close approximation where the radius changes slowly.
///
/// `Line` provides sMin, sMax, maxRadius (>= r(s)), maxSlope (>= |c'(s)| + |r'(s)|, a Lipschitz
/// bound of F) and at(s). The line must be parametrised by z (c(s).z == s): then
/// |p - c(s)| >= |p.z - s|, which bounds the window of s worth searching.
template <typename Line>
class TubeDistance {
public:
    /// `step`: spacing of the table of centre-line samples the search starts from. It must be
    /// well below the distance along s between two local minima of F, so that each minimum gets
    /// a sample bracket of its own.
    TubeDistance(const Line& line, double step) : mLine(line)
    {
        const double length = line.sMax - line.sMin;
        const int intervals = std::max(1, static_cast<int>(std::ceil(length / step)));
        mStep = length / intervals;
        mTable.reserve(static_cast<std::size_t>(intervals) + 1);
        for (int i = 0; i <= intervals; ++i) {
            const CentreLinePoint q = mLine.at(sampleS(i));
            mTable.push_back({q.c, q.dc, q.r, q.dr});
        }
    }

    double operator()(const glm::dvec3& p) const
    {
        const int last = static_cast<int>(mTable.size()) - 1;
        const auto sampled = [&](int i) { return sampledF(p, i); };

        // Any F value bounds the minimum from above; F(s) >= |p.z - s| - maxRadius then rules out
        // every s farther than bound + maxRadius from p.z. Two more samples on each side give a
        // minimum near the window's edge its full bracket.
        const auto index = [&](double s) { return (s - mLine.sMin) / mStep; };
        const int start = std::clamp(static_cast<int>(std::lround(index(p.z))), 0, last);
        const double reach = sampled(start) + mLine.maxRadius;
        const int lo = std::max(0, static_cast<int>(std::floor(index(p.z - reach))) - 2);
        const int hi = std::min(last, static_cast<int>(std::ceil(index(p.z + reach))) + 2);

        // Local minima of the samples, each the centre of a bracket [i-1, i+1] around a local
        // minimum of F. The window's edges are not candidates unless they end the line: the
        // margin above keeps the global minimum's bracket inside the window.
        struct Candidate {
            int index;
            double value;
        };
        std::array<Candidate, 16> candidates{};
        std::size_t count = 0;
        double best = sampled(start);
        double previous = sampled(lo);
        double current = previous;
        for (int i = lo; i <= hi; ++i) {
            const double next = i < hi ? sampled(i + 1) : current;
            const bool downToHere = i == lo ? i == 0 : previous >= current;
            const bool upFromHere = i == hi ? i == last : next >= current;
            if (downToHere && upFromHere) {
                if (count < candidates.size()) {
                    candidates[count++] = {i, current};
                } else {
                    best = std::min(best, refine(p, i));
                }
            }
            best = std::min(best, current);
            previous = current;
            current = next;
        }

        // Refine the most promising brackets first. F is maxSlope-Lipschitz, so a bracket whose
        // centre sample is more than maxSlope * step above the best value cannot beat it.
        std::sort(candidates.begin(), candidates.begin() + count,
                  [](const Candidate& a, const Candidate& b) { return a.value < b.value; });
        for (std::size_t k = 0; k < count; ++k) {
            if (candidates[k].value - mLine.maxSlope * mStep >= best) break;
            best = std::min(best, refine(p, candidates[k].index));
        }
        return best;
    }

private:
    double sampleS(int i) const { return mLine.sMin + i * mStep; }

    /// F at the table's sample i.
    double sampledF(const glm::dvec3& p, int i) const { return glm::length(p - mTable[i].c) - mTable[i].r; }

    /// F' at the table's sample i; 0 on the centre line, where F has its kink.
    double sampledSlope(const glm::dvec3& p, int i) const
    {
        const glm::dvec3 v = mTable[i].c - p;
        const double length = glm::length(v);
        return length < 1e-12 ? 0.0 : glm::dot(v, mTable[i].dc) / length - mTable[i].dr;
    }

    /// F(s), F'(s) and F''(s).
    void evaluate(const glm::dvec3& p, double s, double& f, double& df, double& ddf) const
    {
        const CentreLinePoint q = mLine.at(s);
        const glm::dvec3 v = q.c - p;
        const double length = glm::length(v);
        f = length - q.r;
        if (length < 1e-12) {
            // p on the centre line: F has a kink there, and since |r'| < |c'| it is the minimum.
            df = 0.0;
            ddf = 0.0;
            return;
        }
        const double along = glm::dot(v, q.dc);
        df = along / length - q.dr;
        ddf = (glm::dot(q.dc, q.dc) + glm::dot(v, q.ddc)) / length - along * along / (length * length * length) - q.ddr;
    }

    /// The minimum of F in the bracket of sample i: Newton's method on F' = 0, kept inside a
    /// sign-change bracket [F' < 0, F' > 0] by bisection, so it can only converge to a minimum.
    double refine(const glm::dvec3& p, int i) const
    {
        const int last = static_cast<int>(mTable.size()) - 1;
        const int iLo = std::max(i - 1, 0), iHi = std::min(i + 1, last);
        double lo = sampleS(iLo), hi = sampleS(iHi);
        const double dfLo = sampledSlope(p, iLo), dfHi = sampledSlope(p, iHi);
        // A minimum at an end of the line: the point is nearest to the end's ball.
        if (i == 0 && dfLo >= 0.0) return sampledF(p, 0);
        if (i == last && dfHi <= 0.0) return sampledF(p, last);
        if (!(dfLo < 0.0 && dfHi > 0.0)) return goldenSection(p, lo, hi);

        // Start at the vertex of the parabola through the three samples: a few Newton steps left.
        double s = sampleS(i);
        if (i > 0 && i < last) {
            const double before = sampledF(p, i - 1), here = sampledF(p, i);
            const double after = sampledF(p, i + 1);
            const double curvature = before - 2.0 * here + after;
            if (curvature > 0.0) s += 0.5 * mStep * (before - after) / curvature;
        }
        if (!(s > lo && s < hi)) s = 0.5 * (lo + hi);
        // Stop when the step falls below 1e-7: s is then that close to the minimum, and F(s)
        // within F''/2 * 1e-14 of the minimum value.
        double f = 0.0;
        for (int iteration = 0; iteration < 200; ++iteration) {
            double df = 0.0, ddf = 0.0;
            evaluate(p, s, f, df, ddf);
            if (df == 0.0) break;
            (df < 0.0 ? lo : hi) = s;
            double next = s - df / ddf;
            if (!(ddf > 0.0) || !(next > lo && next < hi)) next = 0.5 * (lo + hi);
            if (std::abs(next - s) < 1e-7 || hi - lo < 1e-7) break;
            s = next;
        }
        return f;
    }

    /// Fallback for a bracket where F' does not change sign as expected (never seen in the
    /// samples, kept for robustness): golden-section search, then the better of it and the ends.
    double goldenSection(const glm::dvec3& p, double lo, double hi) const
    {
        const double ratio = 0.5 * (std::sqrt(5.0) - 1.0);
        const auto value = [&](double s) {
            const CentreLinePoint q = mLine.at(s);
            return glm::length(q.c - p) - q.r;
        };
        const double fEnds = std::min(value(lo), value(hi));
        double a = hi - ratio * (hi - lo), b = lo + ratio * (hi - lo);
        double fa = value(a), fb = value(b);
        while (hi - lo > 1e-10) {
            if (fa < fb) {
                hi = b;
                b = a;
                fb = fa;
                a = hi - ratio * (hi - lo);
                fa = value(a);
            } else {
                lo = a;
                a = b;
                fa = fb;
                b = lo + ratio * (hi - lo);
                fb = value(b);
            }
        }
        return std::min({fEnds, fa, fb});
    }

    Line mLine;
    double mStep = 1.0;
    struct Sample {
        glm::dvec3 c, dc;
        double r, dr;
    };
    std::vector<Sample> mTable; // at s_i = sMin + i * mStep
};

/// The phantom's centre line: over its 432 slices it wanders 1.5 periods of +-30 voxels in x and
/// one period of +-20 in y, and its radius breathes between 21 and 31 with period 256.
/// s stops 40 voxels short of both ends of the 512-voxel grid: the end balls (radius up to 30.2
/// at s = 40) and the band around them then stay inside the grid.
struct PhantomLine {
    double sMin = 40.0, sMax = 472.0;
    double maxRadius = 31.0;
    // |c'| <= sqrt(1 + (30 kx)^2 + (20 ky)^2) = 1.169 and |r'| <= 5 kr = 0.123.
    double maxSlope = 1.3;

    static constexpr double kx = kTwoPi * 1.5 / 512.0;
    static constexpr double ky = kTwoPi / 512.0;
    static constexpr double kr = kTwoPi / 256.0;

    CentreLinePoint at(double s) const
    {
        const double sx = std::sin(kx * s), cx = std::cos(kx * s);
        const double sy = std::sin(ky * s + 0.7), cy = std::cos(ky * s + 0.7);
        const double sr = std::sin(kr * s), cr = std::cos(kr * s);
        CentreLinePoint q;
        q.c = {128.0 + 30.0 * sx, 128.0 + 20.0 * sy, s};
        q.dc = {30.0 * kx * cx, 20.0 * ky * cy, 1.0};
        q.ddc = {-30.0 * kx * kx * sx, -20.0 * ky * ky * sy, 0.0};
        q.r = 26.0 + 5.0 * sr;
        q.dr = 5.0 * kr * cr;
        q.ddr = -5.0 * kr * kr * sr;
        return q;
    }
};

/// The helix sample's centre line: radius 20 around (48, 48), pitch 64, two turns over
/// s in [16, 144], tube radius 6.
struct HelixLine {
    double sMin = 16.0, sMax = 144.0;
    double maxRadius = 6.0;
    // |c'| = sqrt(1 + (20 w)^2) = 2.203; the radius is constant.
    double maxSlope = 2.21;

    static constexpr double w = kTwoPi / 64.0;

    CentreLinePoint at(double s) const
    {
        const double sn = std::sin(w * s), cs = std::cos(w * s);
        CentreLinePoint q;
        q.c = {48.0 + 20.0 * cs, 48.0 + 20.0 * sn, s};
        q.dc = {-20.0 * w * sn, 20.0 * w * cs, 1.0};
        q.ddc = {-20.0 * w * w * cs, -20.0 * w * w * sn, 0.0};
        q.r = 6.0;
        return q;
    }
};

/// The oblique sample's centre line: a tight helix of radius 10 around (20, 20), pitch 16, four
/// turns over s in [8, 72], tube radius 1.5. The centre moves 2 pi 10 / 16 = 3.93 voxels
/// sideways per voxel of z: the line is 75.7 degrees from the z axis.
struct ObliqueLine {
    double sMin = 8.0, sMax = 72.0;
    double maxRadius = 1.5;
    // |c'| = sqrt(1 + (10 w)^2) = 4.052; the radius is constant.
    double maxSlope = 4.06;

    static constexpr double w = kTwoPi / 16.0;

    CentreLinePoint at(double s) const
    {
        const double sn = std::sin(w * s), cs = std::cos(w * s);
        CentreLinePoint q;
        q.c = {20.0 + 10.0 * cs, 20.0 + 10.0 * sn, s};
        q.dc = {-10.0 * w * sn, 10.0 * w * cs, 1.0};
        q.ddc = {-10.0 * w * w * cs, -10.0 * w * w * sn, 0.0};
        q.r = 1.5;
        return q;
    }
};

/// Step of the centre-line tables, in voxels of s. Separate local minima of F lie tens of voxels
/// apart along s (16 for the oblique helix's turns), except near the lines' centres of curvature
/// (about 100 voxels from the phantom's line, 25 from the helix's, 10.6 from the oblique's), where
/// two minima merge with nearly equal values.
constexpr double kTubeTableStep = 1.0;

// ---------------------------------------------------------------------------------------------
// The samples

// Topology of each sample: genus g of each closed surface of the isosurface, euler = sum of
// (2 - 2 g) over the surfaces; a void inside a solid is a surface of its own (facing inward).

DistanceFunction phantomDistance()
{
    // One tube with round ends, nowhere touching itself: a sphere. Euler 2, 1 component.
    auto tube = std::make_shared<const TubeDistance<PhantomLine>>(PhantomLine{}, kTubeTableStep);
    return [tube](const glm::dvec3& p) { return (*tube)(p); };
}

DistanceFunction straightDistance()
{
    // Capsule along z through (32, 32), z in [16, 112], radius 10: exact.
    // A sphere: euler 2, 1 component.
    return [](const glm::dvec3& p) { return capsuleDistance(p, {32.0, 32.0, 16.0}, {32.0, 32.0, 112.0}, 10.0); };
}

DistanceFunction helixDistance()
{
    // Two turns of a tube of radius 6 whose turns are 64 apart (52 voxels of gap): a bent
    // capsule, a sphere. Euler 2, 1 component.
    auto tube = std::make_shared<const TubeDistance<HelixLine>>(HelixLine{}, kTubeTableStep);
    return [tube](const glm::dvec3& p) { return (*tube)(p); };
}

/// Half-angle of the bean's arc. Chosen so that the area centroid of the C lies inside it, 2.97
/// voxels from the boundary at (48, 59.97), while the rays leaving the centroid at 221-229
/// degrees (and 311-319) cross the boundary three times: in through the hole, out into an arm.
/// The margin drops below 2 voxels past about 77 degrees (at 91 the centroid falls into the
/// hole), and below about 52 degrees no ray crosses three times.
constexpr double kBeanHalfAngle = 70.0 * kPi / 180.0;

DistanceFunction beanDistance()
{
    // Arc of radius 18 around (48, 48), thickness 9 (inner radius 9, outer 27); extruded over
    // z in [16, 80] with edges rounded by 4. Exact: the hole (radius 9) and the gap between the
    // arms are wider than 8.
    // The C is open (its arms do not meet), so the solid is a bent slab: a sphere. Euler 2,
    // 1 component.
    const glm::dvec2 sinCos(std::sin(kBeanHalfAngle), std::cos(kBeanHalfAngle));
    return [sinCos](const glm::dvec3& p) {
        const double d2 = arcDistance2d(glm::dvec2(p.x - 48.0, p.y - 48.0), sinCos, 18.0, 9.0);
        return roundedExtrusionDistance(d2, p.z - 48.0, 32.0, 4.0);
    };
}

DistanceFunction hollowDistance()
{
    // Annulus of inner radius 14 and outer 26 around (48, 48), extruded over z in [16, 112] with
    // edges rounded by 3. Exact: the hole (radius 14) is wider than 6.
    // The hole goes through from end to end and the rims close the wall between the inner and
    // outer sides: one closed surface of genus 1 (a torus). Euler 0, 1 component.
    return [](const glm::dvec3& p) {
        const double d2 = std::abs(glm::length(glm::dvec2(p.x - 48.0, p.y - 48.0)) - 20.0) - 6.0;
        return roundedExtrusionDistance(d2, p.z - 64.0, 48.0, 3.0);
    };
}

DistanceFunction ybranchDistance()
{
    // Trunk (64,64,16)-(64,64,80) of radius 12 forking into two branches of radius 9 that reach
    // x = 34 and x = 94 at z = 144. The union's distance is exact outside; inside, near the fork,
    // it underestimates the depth.
    // Three capsules fused at one point form a tree-shaped solid without loops: a sphere. Euler 2,
    // 1 component.
    return [](const glm::dvec3& p) {
        const glm::dvec3 fork(64.0, 64.0, 80.0);
        const double trunk = capsuleDistance(p, {64.0, 64.0, 16.0}, fork, 12.0);
        const double left = capsuleDistance(p, fork, {34.0, 64.0, 144.0}, 9.0);
        const double right = capsuleDistance(p, fork, {94.0, 64.0, 144.0}, 9.0);
        return std::min({trunk, left, right});
    };
}

DistanceFunction twoTubesDistance()
{
    // Two capsules along z through (28, 32) and (68, 32), z in [16, 112], radius 10. Exact: the
    // tubes are 20 voxels apart, farther than any depth inside them.
    // Two disjoint spheres (gap 20): euler 2 + 2 = 4, 2 components.
    return [](const glm::dvec3& p) {
        const double a = capsuleDistance(p, {28.0, 32.0, 16.0}, {28.0, 32.0, 112.0}, 10.0);
        const double b = capsuleDistance(p, {68.0, 32.0, 16.0}, {68.0, 32.0, 112.0}, 10.0);
        return std::min(a, b);
    };
}

// ---------------------------------------------------------------------------------------------
// Samples of known topology: each is a shape a cross-section tiler must get right (branches in
// and across slice planes, loops, holes, voids, thin fast-moving tubes). Unions are min and
// differences max(a, -b) of exact distances: exact outside a union and inside a difference's
// wall where the removed part lies wholly inside the other (lumen-rod, tank); elsewhere a
// 1-Lipschitz bound with the right zero set, which is all the band and the flood fill need. All
// lie with z the longest side of the active bounding box, so the automatic slicing axis is z.

DistanceFunction tbranchDistance()
{
    // Main tube (32, 32, 16)-(32, 32, 112) of radius 8 and a side branch along x from its axis
    // at mid-height to (66, 32, 64), radius 6. The side branch's axis lies in the plane z = 64,
    // a slice plane of the default slicing: the active box starts at z = 6 (the band 2 below the
    // bottom cap at z = 8) and slices come every 2 voxels from there.
    // Two capsules fused along the branch's root, no loop: a sphere. Euler 2, 1 component.
    return [](const glm::dvec3& p) {
        const double main = capsuleDistance(p, {32.0, 32.0, 16.0}, {32.0, 32.0, 112.0}, 8.0);
        const double side = capsuleDistance(p, {32.0, 32.0, 64.0}, {66.0, 32.0, 64.0}, 6.0);
        return std::min(main, side);
    };
}

/// End points of the trifurcation's branches: 28 voxels from the trunk's axis at 90, 210 and 330
/// degrees, z = 112. Three directions 48 degrees apart, not in one plane.
glm::dvec3 trifurcationEnd(int k)
{
    const double angle = (90.0 + 120.0 * k) * kPi / 180.0;
    return {48.0 + 28.0 * std::cos(angle), 48.0 + 28.0 * std::sin(angle), 112.0};
}

DistanceFunction trifurcationDistance()
{
    // Trunk (48, 48, 16)-(48, 48, 60) of radius 9 forking at its top into three branches of
    // radius 6 to trifurcationEnd(0..2); their ends are 48.5 apart (gap 36.5).
    // Four capsules fused at one point, no loop: a sphere. Euler 2, 1 component.
    return [](const glm::dvec3& p) {
        const glm::dvec3 fork(48.0, 48.0, 60.0);
        double d = capsuleDistance(p, {48.0, 48.0, 16.0}, fork, 9.0);
        for (int k = 0; k < 3; ++k) d = std::min(d, capsuleDistance(p, fork, trifurcationEnd(k), 6.0));
        return d;
    };
}

DistanceFunction partingDistance()
{
    // Six capsules, each starting where an earlier one ends (a random tree, written out): at
    // z = 23 the trunk's first two branches touch along a seam that leaves a one-pixel hole
    // between them before they part, a ring breaking open into two walls around a hole too small
    // for each wall to be nearest part of it.
    // A tree of capsules without a loop: a sphere. Euler 2, 1 component.
    struct Segment {
        glm::dvec3 a, b;
        double radius;
    };
    static const Segment segments[] = {
        {{48.0, 48.0, 10.0}, {67.962, 33.125, 47.977}, 5.396},
        {{48.0, 48.0, 10.0}, {65.422, 54.790, 31.637}, 6.677},
        {{48.0, 48.0, 10.0}, {37.183, 45.738, 35.736}, 6.022},
        {{37.183, 45.738, 35.736}, {54.748, 42.966, 59.453}, 5.622},
        {{37.183, 45.738, 35.736}, {37.909, 29.450, 69.819}, 5.778},
        {{54.748, 42.966, 59.453}, {37.118, 33.888, 94.341}, 5.066},
    };
    return [](const glm::dvec3& p) {
        double d = std::numeric_limits<double>::infinity();
        for (const Segment& s : segments) d = std::min(d, capsuleDistance(p, s.a, s.b, s.radius));
        return d;
    };
}

/// Signed distance to the box [lo, hi] (exact: Euclidean outside, to the nearest face inside).
double boxDistance(const glm::dvec3& p, const glm::dvec3& lo, const glm::dvec3& hi)
{
    const glm::dvec3 q = glm::max(lo - p, p - hi);
    return glm::length(glm::max(q, 0.0)) + std::min(std::max(q.x, std::max(q.y, q.z)), 0.0);
}

DistanceFunction touchingBlocksDistance()
{
    // Voxels (x, y, z) in [10, 15] x [10, 15] x [10, 16] and in [16, 21] x [16, 21] x [16, 22]:
    // on the voxel plane z = 16, voxels (15, 15) and (16, 16) touch along one voxel edge, and on
    // the planes beside it only one of them is inside. volumeToMesh's cell tables leave such a
    // contact open: two boxes, Euler 4, 2 components.
    return [](const glm::dvec3& p) {
        return std::min(boxDistance(p, {9.5, 9.5, 9.5}, {15.5, 15.5, 16.5}),
                        boxDistance(p, {15.5, 15.5, 15.5}, {21.5, 21.5, 22.5}));
    };
}

DistanceFunction stepsDistance()
{
    // Four steps k = 0..3, voxels [8 + 3k, 10 + 3k] x [8, 13] x [8 + 4k, 11 + 4k]: each touches the
    // next only along voxel edges, across a voxel plane ((10 + 3k, y, 11 + 4k) and
    // (11 + 3k, y, 12 + 4k)), six voxels deep along y. volumeToMesh's cell tables join such a
    // contact: one staircase, Euler 2, 1 component.
    return [](const glm::dvec3& p) {
        double d = std::numeric_limits<double>::infinity();
        for (int k = 0; k < 4; ++k)
            d = std::min(d, boxDistance(p, {7.5 + 3 * k, 7.5, 7.5 + 4 * k}, {10.5 + 3 * k, 13.5, 11.5 + 4 * k}));
        return d;
    };
}

DistanceFunction pillarsDistance()
{
    // Two pillars side by side, voxels y in [8, 13], z in [8, 24]: one at x in [8, 10] up to z = 14
    // and [8, 9] above, the other at x in [12, 14] up to z = 14 and [11, 14] above. Voxels
    // (10, y, 14) and (11, y, 15) touch along an edge across the voxel planes 14 and 15, six voxels
    // deep along y, and nowhere else. volumeToMesh joins them: one surface, Euler 2.
    return [](const glm::dvec3& p) {
        return std::min({boxDistance(p, {7.5, 7.5, 7.5}, {10.5, 13.5, 14.5}),
                         boxDistance(p, {7.5, 7.5, 14.5}, {9.5, 13.5, 24.5}),
                         boxDistance(p, {11.5, 7.5, 7.5}, {14.5, 13.5, 14.5}),
                         boxDistance(p, {10.5, 7.5, 14.5}, {14.5, 13.5, 24.5})});
    };
}

DistanceFunction ubendDistance()
{
    // Arms along z through (32, 32) and (64, 32), z in [16, 88], radius 7 (gap 18), joined at the
    // top by the upper half of a ring of radius 16 around (48, 32, 88) in the plane y = 32: a U
    // standing across the slices, two sections low down merging into one at the bend.
    // One bent tube with round ends: a sphere. Euler 2, 1 component.
    return [](const glm::dvec3& p) {
        const double left = capsuleDistance(p, {32.0, 32.0, 16.0}, {32.0, 32.0, 88.0}, 7.0);
        const double right = capsuleDistance(p, {64.0, 32.0, 16.0}, {64.0, 32.0, 88.0}, 7.0);
        const double bend = halfRingDistance(p, {48.0, 32.0, 88.0}, 16.0, 7.0, true);
        return std::min({left, right, bend});
    };
}

DistanceFunction xcrossDistance()
{
    // Capsules (16, 24, 16)-(48, 24, 112) and (48, 24, 16)-(16, 24, 112) of radius 7, crossing at
    // (32, 24, 64) at 37 degrees. In a plane z = c their sections are ellipses 7 / cos(18.4 deg) =
    // 7.38 long along x, centres 32 |1 - (z - 16) / 48| apart: they overlap for z in about
    // (42, 86), so two sections fuse into one and part again; at the ends they are 32 apart
    // (gap 18).
    // Two straight capsules crossing once make a solid X without a loop: a sphere. Euler 2,
    // 1 component.
    return [](const glm::dvec3& p) {
        const double a = capsuleDistance(p, {16.0, 24.0, 16.0}, {48.0, 24.0, 112.0}, 7.0);
        const double b = capsuleDistance(p, {48.0, 24.0, 16.0}, {16.0, 24.0, 112.0}, 7.0);
        return std::min(a, b);
    };
}

DistanceFunction torusFlatDistance()
{
    // A ring around the z axis through (28, 28, 32) lying flat in the slices: tube radius 6 at
    // distance 14 from the axis (hole radius 8). A round torus would be 40 wide and 12 tall, and
    // the automatic axis would slice it along x; its section is stretched instead into a vertical
    // 2D capsule of half-height 17 (z in [9, 55], 46 tall), so z stays the longest side.
    // The hole goes through: one surface of genus 1. Euler 0, 1 component.
    return [](const glm::dvec3& p) { return ringDistance(p, {28.0, 28.0, 32.0}, 14.0, 6.0, 17.0); };
}

DistanceFunction torusStandingDistance()
{
    // A ring with axis x standing across the slices: a tube of radius 6 around a racetrack in the
    // plane x = 24, straight sides at y = 32 +- 16 for z in 56 +- 24 joined by half circles of
    // radius 16 (z in [10, 102]; the hole is 20 wide and 68 tall). Slices see two sections that
    // merge at the top and bottom bends.
    // One surface of genus 1. Euler 0, 1 component.
    return [](const glm::dvec3& p) { return racetrackDistance(p, {24.0, 32.0, 56.0}, 16.0, 6.0, 24.0); };
}

DistanceFunction twoToriDistance()
{
    // Two rings like torus-flat's (axis z, ring radius 12, tube radius 5, section stretched to a
    // vertical capsule of half-height 28, z in [7, 73]) around (28, 28) and (52, 28): their centre
    // circles touch at (40, 28), where the walls fuse over their full thickness 10. Each keeps
    // its own hole (radius 7); the lens between the circles is only the touching point, so no
    // third hole opens. Lying flat: every slice is a figure eight, one outer contour around two
    // holes. Stretched so that z (66 tall) is longer than x (58 wide).
    // Two tori joined along a disc: one surface of genus 2. Euler 2 - 2 * 2 = -2, 1 component.
    return [](const glm::dvec3& p) {
        return std::min(ringDistance(p, {28.0, 28.0, 40.0}, 12.0, 5.0, 28.0),
                        ringDistance(p, {52.0, 28.0, 40.0}, 12.0, 5.0, 28.0));
    };
}

/// The hollow Y's skeleton: trunk from (48, 32, 16) up to the fork (48, 32, 56), branches from the
/// fork to (24, 32, 104) and (72, 32, 104), all in the plane y = 32.
constexpr double kHollowYOuterRadius = 11.0, kHollowYInnerRadius = 6.0;
/// How far the inner Y's segments run past the outer's ends: beyond the outer caps (11).
constexpr double kHollowYOverrun = 20.0;

DistanceFunction hollowYDistance()
{
    // Outer Y of radius 11 minus inner Y of radius 6 on the same skeleton, the inner segments
    // continued 20 voxels past the three ends: wall 5 thick, a channel 12 wide that pierces all
    // three end caps (the rim of each end is where the channel's cylinder cuts the outer cap,
    // 9.2 past the end point along the axis).
    // A Y-shaped pipe open at three ends: the solid is a thickened pair of pants, a handlebody of
    // genus 2 (three openings = a sphere with three discs removed, doubled by the wall). One
    // surface of genus 2: euler -2, 1 component.
    return [](const glm::dvec3& p) {
        const glm::dvec3 bottom(48.0, 32.0, 16.0), fork(48.0, 32.0, 56.0);
        const glm::dvec3 left(24.0, 32.0, 104.0), right(72.0, 32.0, 104.0);
        const auto past = [&](const glm::dvec3& from, const glm::dvec3& end) {
            return end + kHollowYOverrun * glm::normalize(end - from);
        };
        const auto y = [&](double radius, double overrun) {
            const glm::dvec3 b = overrun > 0.0 ? past(fork, bottom) : bottom;
            const glm::dvec3 l = overrun > 0.0 ? past(fork, left) : left;
            const glm::dvec3 r = overrun > 0.0 ? past(fork, right) : right;
            return std::min({capsuleDistance(p, b, fork, radius), capsuleDistance(p, fork, l, radius),
                             capsuleDistance(p, fork, r, radius)});
        };
        return std::max(y(kHollowYOuterRadius, 0.0), -y(kHollowYInnerRadius, kHollowYOverrun));
    };
}

DistanceFunction lumenRodDistance()
{
    // Solid rod (32, 32, 16)-(32, 32, 112) of radius 12 holding a closed channel
    // (32, 32, 44)-(32, 32, 84) of radius 4: the wall around it is 8 thick at the sides and 24 at
    // its ends. Exact: rod minus a cavity wholly inside it.
    // Two surfaces, each a sphere: the rod's outer shell and the channel's wall facing inward.
    // Euler 2 + 2 = 4, 2 components.
    return [](const glm::dvec3& p) {
        const double rod = capsuleDistance(p, {32.0, 32.0, 16.0}, {32.0, 32.0, 112.0}, 12.0);
        const double channel = capsuleDistance(p, {32.0, 32.0, 44.0}, {32.0, 32.0, 84.0}, 4.0);
        return std::max(rod, -channel);
    };
}

DistanceFunction tankDistance()
{
    // Closed cylinder around (32, 32), radius 24, z in 56 +- 44, edges rounded by 6, minus a void
    // of radius 16, z in 56 +- 36, edges rounded by 3: walls and lids 8 thick. Exact: a void wholly
    // inside the solid.
    // Two spheres: the outer shell and the void's inward-facing wall. Euler 4, 2 components.
    return [](const glm::dvec3& p) {
        const double r = glm::length(glm::dvec2(p.x - 32.0, p.y - 32.0));
        const double outer = roundedExtrusionDistance(r - 24.0, p.z - 56.0, 44.0, 6.0);
        const double cavity = roundedExtrusionDistance(r - 16.0, p.z - 56.0, 36.0, 3.0);
        return std::max(outer, -cavity);
    };
}

DistanceFunction treeDistance()
{
    // Three generations: trunk (48, 48, 16)-(48, 48, 46) of radius 9; two branches of radius 7 in
    // the plane y = 48 to (30, 48, 78) and (66, 48, 78); each forks again into two leaves of
    // radius 5 ending at z = 114, 18 voxels off its fork point: the first in the plane x = 30
    // (to y = 30 and 66), the second in a plane at 45 degrees to it (to (66 +- 12.7, 48 +- 12.7)).
    // The nearest leaves, (30, 30) and (53.3, 35.3) at the top, are 23.9 apart (gap 13.9).
    // Seven capsules joined at three fork points, a tree without loops: a sphere. Euler 2,
    // 1 component.
    return [](const glm::dvec3& p) {
        const glm::dvec3 fork1(48.0, 48.0, 46.0), forkA(30.0, 48.0, 78.0), forkB(66.0, 48.0, 78.0);
        const double spread = 18.0 / std::sqrt(2.0);
        double d = capsuleDistance(p, {48.0, 48.0, 16.0}, fork1, 9.0);
        d = std::min(d, capsuleDistance(p, fork1, forkA, 7.0));
        d = std::min(d, capsuleDistance(p, fork1, forkB, 7.0));
        d = std::min(d, capsuleDistance(p, forkA, {30.0, 30.0, 114.0}, 5.0));
        d = std::min(d, capsuleDistance(p, forkA, {30.0, 66.0, 114.0}, 5.0));
        d = std::min(d, capsuleDistance(p, forkB, {66.0 + spread, 48.0 + spread, 114.0}, 5.0));
        d = std::min(d, capsuleDistance(p, forkB, {66.0 - spread, 48.0 - spread, 114.0}, 5.0));
        return d;
    };
}

DistanceFunction serpentineDistance()
{
    // Four arms along z at x = 14, 36, 58, 80 (y = 16, z in [26, 102], radius 6, gaps 10), joined
    // by half rings of radius 11: on top between the first two and the last two, below between
    // the middle two. The centre line goes up, down, up, down across the slices: three U-turns.
    // One tube with two round ends, not touching itself: a sphere. Euler 2, 1 component.
    return [](const glm::dvec3& p) {
        double d = halfRingDistance(p, {25.0, 16.0, 102.0}, 11.0, 6.0, true);
        d = std::min(d, halfRingDistance(p, {47.0, 16.0, 26.0}, 11.0, 6.0, false));
        d = std::min(d, halfRingDistance(p, {69.0, 16.0, 102.0}, 11.0, 6.0, true));
        for (const double x : {14.0, 36.0, 58.0, 80.0}) {
            d = std::min(d, capsuleDistance(p, {x, 16.0, 26.0}, {x, 16.0, 102.0}, 6.0));
        }
        return d;
    };
}

DistanceFunction obliqueDistance()
{
    // A thin tube (radius 1.5) at 75.7 degrees from z, wound into a tight helix (ObliqueLine) so
    // that z stays the longest side (23 wide, 67 tall): a straight line that steep would be
    // longer in x. Per 2 voxels of z the centre moves 7.85 voxels, 2.6 tube diameters. The
    // sections, 12.2 long along the motion, still overlap in a lens about 4.3 x 2.3 voxels (in the
    // grid, 24% of the section pixels lie over the previous slice's section): no tube of radius
    // above 1 voxel can avoid that at a spacing of 2, since a vertical chord through its axis,
    // 2 r / sin(slant) >= 2 r, then crosses two slice planes.
    // The turns are 16 apart (gap 13). One tube with round ends: a sphere. Euler 2, 1 component.
    auto tube = std::make_shared<const TubeDistance<ObliqueLine>>(ObliqueLine{}, kTubeTableStep);
    return [tube](const glm::dvec3& p) { return (*tube)(p); };
}

struct SampleEntry {
    SampleInfo info;
    DistanceFunction (*makeDistance)();
};

const std::vector<SampleEntry>& sampleTable()
{
    // {name, description, dims, voxel size, euler, components}; the functions' comments give the
    // reasons for the topology.
    static const std::vector<SampleEntry> table = {
        {{"phantom",
          "256x256x512 tube, centre line wandering in x and y, radius breathing 21-31 "
          "(the paper's phantom; default input)",
          {256, 256, 512},
          1.0,
          2,
          1},
         &phantomDistance},
        {{"straight",
          "64x64x128 capsule of radius 10 along z: circular contours, round end caps",
          {64, 64, 128},
          1.0,
          2,
          1},
         &straightDistance},
        {{"helix",
          "96x96x160 tube of radius 6 along two helix turns: contours moving between slices",
          {96, 96, 160},
          1.0,
          2,
          1},
         &helixDistance},
        {{"bean",
          "96x96x96 extruded C shape: centroid inside, but rays from it cross three times",
          {96, 96, 96},
          1.0,
          2,
          1},
         &beanDistance},
        {{"hollow",
          "96x96x128 annular tube (radii 14 and 26): a hole in every cross-section",
          {96, 96, 128},
          1.0,
          0,
          1},
         &hollowDistance},
        {{"ybranch",
          "128x128x160 trunk forking into two branches: one contour becomes two",
          {128, 128, 160},
          1.0,
          2,
          1},
         &ybranchDistance},
        {{"two-tubes",
          "96x64x128 two parallel capsules of radius 10: two contours per slice",
          {96, 64, 128},
          1.0,
          4,
          2},
         &twoTubesDistance},
        {{"tbranch",
          "80x64x128 tube along z with a side branch along x lying in the slice z = 64",
          {80, 64, 128},
          1.0,
          2,
          1},
         &tbranchDistance},
        {{"trifurcation", "96x96x128 trunk forking into three branches, not in one plane", {96, 96, 128}, 1.0, 2, 1},
         &trifurcationDistance},
        {{"ubend",
          "96x64x128 two arms along z joined on top by a half ring: a U across the slices",
          {96, 64, 128},
          1.0,
          2,
          1},
         &ubendDistance},
        {{"xcross",
          "64x48x128 two capsules crossing at 37 degrees: two sections fuse, then part",
          {64, 48, 128},
          1.0,
          2,
          1},
         &xcrossDistance},
        {{"torus-flat",
          "56x56x64 ring around z lying flat (section stretched along z): genus 1",
          {56, 56, 64},
          1.0,
          0,
          1},
         &torusFlatDistance},
        {{"torus-standing",
          "48x64x112 ring with axis x, a racetrack standing across the slices: genus 1",
          {48, 64, 112},
          1.0,
          0,
          1},
         &torusStandingDistance},
        {{"two-tori", "80x56x80 two flat rings fused at one side, a figure eight: genus 2", {80, 56, 80}, 1.0, -2, 1},
         &twoToriDistance},
        {{"hollow-y", "96x64x128 Y-shaped pipe open at its three ends: genus 2", {96, 64, 128}, 1.0, -2, 1},
         &hollowYDistance},
        {{"lumen-rod",
          "64x64x128 solid rod holding a closed channel: outer shell and a void",
          {64, 64, 128},
          1.0,
          4,
          2},
         &lumenRodDistance},
        {{"tank", "64x64x112 closed thick-walled cylinder around a void: two shells", {64, 64, 112}, 1.0, 4, 2},
         &tankDistance},
        {{"tree", "96x96x128 vessel tree, trunk -> 2 -> 4 leaves, forks in different planes", {96, 96, 128}, 1.0, 2, 1},
         &treeDistance},
        {{"serpentine", "96x32x128 tube going up and down across the slices, three U-turns", {96, 32, 128}, 1.0, 2, 1},
         &serpentineDistance},
        {{"oblique",
          "40x40x80 thin tube (radius 1.5) at 76 degrees from z, wound in a tight helix",
          {40, 40, 80},
          1.0,
          2,
          1},
         &obliqueDistance},
        {{"parting",
          "96x96x128 tree of six capsules; two branches part through one-pixel holes",
          {96, 96, 128},
          1.0,
          2,
          1},
         &partingDistance},
        {{"touching-blocks",
          "32x32x32 two boxes touching along one voxel edge in a voxel plane: two surfaces",
          {32, 32, 32},
          1.0,
          4,
          2},
         &touchingBlocksDistance},
        {{"steps",
          "32x24x32 four box steps, each touching the next along voxel edges across a voxel plane",
          {32, 24, 32},
          1.0,
          2,
          1},
         &stepsDistance},
        {{"pillars",
          "24x24x32 two box pillars side by side, touching along voxel edges across a voxel plane",
          {24, 24, 32},
          1.0,
          2,
          1},
         &pillarsDistance},
    };
    return table;
}

const SampleEntry& findSample(const std::string& name)
{
    for (const SampleEntry& entry : sampleTable()) {
        if (entry.info.name == name) return entry;
    }
    std::ostringstream message;
    message << "unknown sample '" << name << "'; the samples are:";
    for (const SampleEntry& entry : sampleTable()) message << ' ' << entry.info.name;
    message << " (pipetile sample --list describes them)";
    throw Error(message.str());
}

} // namespace

const std::vector<SampleInfo>& sampleList()
{
    static const std::vector<SampleInfo> list = [] {
        std::vector<SampleInfo> infos;
        for (const SampleEntry& entry : sampleTable()) infos.push_back(entry.info);
        return infos;
    }();
    return list;
}

DistanceFunction sampleDistance(const std::string& name)
{
    return findSample(name).makeDistance();
}

Volume makeSample(const std::string& name)
{
    const SampleEntry& entry = findSample(name);
    return levelSetFromDistance(entry.makeDistance(), entry.info.dims, entry.info.voxelSize, "sample:" + name);
}

Volume levelSetFromDistance(const DistanceFunction& distance, const glm::ivec3& dims, double voxelSize,
                            const std::string& source)
{
    using LeafT = openvdb::FloatTree::LeafNodeType;
    constexpr int kBlock = static_cast<int>(LeafT::DIM);

    if (!distance) throw Error(source + ": no distance function to sample");
    if (dims.x <= 0 || dims.y <= 0 || dims.z <= 0) {
        std::ostringstream message;
        message << source << ": grid dimensions must be positive, got " << dims.x << 'x' << dims.y << 'x' << dims.z;
        throw Error(message.str());
    }
    if (!(voxelSize > 0.0) || !std::isfinite(voxelSize)) {
        throw Error(source + ": voxel size must be positive and finite, got " + std::to_string(voxelSize));
    }

    const double background = kHalfWidthVoxels * voxelSize;
    const float backgroundValue = static_cast<float>(background);
    // phi is 1-Lipschitz, so a block whose centre is farther than this from the surface holds no
    // band voxel, and all its voxels share the centre's sign.
    const double blockReach = (kHalfWidthVoxels + kBlockHalfDiagonalVoxels + kBlockSafetyVoxels) * voxelSize;
    const glm::ivec3 blocks = (dims + (kBlock - 1)) / kBlock;
    const std::size_t blocksY = static_cast<std::size_t>(blocks.y);
    const std::size_t blocksZ = static_cast<std::size_t>(blocks.z);
    const std::size_t blockCount = static_cast<std::size_t>(blocks.x) * blocksY * blocksZ;

    const auto checked = [&](const glm::dvec3& world) {
        const double d = distance(world);
        if (std::isnan(d)) {
            std::ostringstream message;
            message << source << ": the distance function is NaN at world point (" << world.x << ", " << world.y << ", "
                    << world.z << ")";
            throw Error(message.str());
        }
        return d;
    };

    // One leaf per block that the band can reach, built in parallel; each depends on its block
    // alone, so the leaves are the same for any number of threads.
    std::vector<std::unique_ptr<LeafT>> leaves(blockCount);
    using BlockRange = tbb::blocked_range<std::size_t>;
    tbb::parallel_for(BlockRange(0, blockCount), [&](const BlockRange& range) {
        for (std::size_t b = range.begin(); b != range.end(); ++b) {
            // Blocks in x-major order, like the voxels of a leaf.
            const int bx = static_cast<int>(b / (blocksY * blocksZ));
            const int by = static_cast<int>(b / blocksZ % blocksY);
            const int bz = static_cast<int>(b % blocksZ);
            const openvdb::Coord origin(bx * kBlock, by * kBlock, bz * kBlock);
            const glm::dvec3 first(origin.x(), origin.y(), origin.z());
            const glm::dvec3 centre = (first + 0.5 * (kBlock - 1)) * voxelSize;
            if (std::abs(checked(centre)) > blockReach) continue;

            auto leaf = std::make_unique<LeafT>(origin, backgroundValue, false);
            for (int i = 0; i < kBlock; ++i) {
                for (int j = 0; j < kBlock; ++j) {
                    for (int k = 0; k < kBlock; ++k) {
                        const openvdb::Coord ijk = origin.offsetBy(i, j, k);
                        const double d = checked(glm::dvec3(ijk.x(), ijk.y(), ijk.z()) * voxelSize);
                        const bool inGrid = ijk.x() < dims.x && ijk.y() < dims.y && ijk.z() < dims.z;
                        const openvdb::Index offset = LeafT::coordToOffset(ijk);
                        // The band test is on the stored float: a distance just below the
                        // background can round to it, and no active voxel may hold it.
                        const float value = static_cast<float>(d);
                        if (inGrid && std::abs(value) < backgroundValue) {
                            leaf->setValueOn(offset, value);
                        } else {
                            // Outside the band, or past the grid in a partial block: the sign is
                            // kept so that the flood fill below reads it right.
                            leaf->setValueOff(offset, d < 0.0 ? -backgroundValue : backgroundValue);
                        }
                    }
                }
            }
            if (!leaf->isEmpty()) leaves[b] = std::move(leaf);
        }
    });

    openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(backgroundValue);
    grid->setTransform(openvdb::math::Transform::createLinearTransform(voxelSize));
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    grid->setName("levelset");
    openvdb::FloatTree& tree = grid->tree();
    for (std::unique_ptr<LeafT>& leaf : leaves) {
        if (leaf) tree.addLeaf(leaf.release());
    }
    // Blocks without a leaf hold no band voxel and one sign throughout (see blockReach), and band
    // voxels separate inside from outside: the scan-line fill gives the interior -background.
    openvdb::tools::signedFloodFill(tree);

    return volumeFromGrid(grid, VolumeOptions{}, source);
}

} // namespace pipetile::samples
