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

/// Exact signed distance to the capsule of radius `radius` around the segment [a, b].
double capsuleDistance(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b, double radius)
{
    const glm::dvec3 ab = b - a;
    const double t = glm::clamp(glm::dot(p - a, ab) / glm::dot(ab, ab), 0.0, 1.0);
    return glm::length(p - (a + t * ab)) - radius;
}

/// Exact 2D signed distance to the points within `thickness` of a circular arc of radius
/// `arcRadius` centred at the origin, symmetric about +y and spanning +-halfAngle from it
/// (Quilez's sdArc). `sinCos` = (sin halfAngle, cos halfAngle). Exact for 0 < halfAngle < pi.
double arcDistance2d(glm::dvec2 q, const glm::dvec2& sinCos, double arcRadius, double thickness)
{
    q.x = std::abs(q.x);
    // Beyond the arc's angular span the nearest arc point is the end on the same side.
    const bool beyondEnd = sinCos.y * q.x > sinCos.x * q.y;
    const double toArc = beyondEnd ? glm::length(q - sinCos * arcRadius)
                                   : std::abs(glm::length(q) - arcRadius);
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
    double sampledF(const glm::dvec3& p, int i) const
    {
        return glm::length(p - mTable[i].c) - mTable[i].r;
    }

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
        ddf = (glm::dot(q.dc, q.dc) + glm::dot(v, q.ddc)) / length
              - along * along / (length * length * length) - q.ddr;
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

/// Step of the centre-line tables, in voxels of s. Separate local minima of F lie tens of voxels
/// apart along s, except near the lines' centres of curvature (about 100 voxels from the phantom's
/// line, 25 from the helix's), where two minima merge with nearly equal values.
constexpr double kTubeTableStep = 1.0;

// ---------------------------------------------------------------------------------------------
// The samples

DistanceFunction phantomDistance()
{
    auto tube = std::make_shared<const TubeDistance<PhantomLine>>(PhantomLine{}, kTubeTableStep);
    return [tube](const glm::dvec3& p) { return (*tube)(p); };
}

DistanceFunction straightDistance()
{
    // Capsule along z through (32, 32), z in [16, 112], radius 10: exact.
    return [](const glm::dvec3& p) {
        return capsuleDistance(p, {32.0, 32.0, 16.0}, {32.0, 32.0, 112.0}, 10.0);
    };
}

DistanceFunction helixDistance()
{
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
    return [](const glm::dvec3& p) {
        const double a = capsuleDistance(p, {28.0, 32.0, 16.0}, {28.0, 32.0, 112.0}, 10.0);
        const double b = capsuleDistance(p, {68.0, 32.0, 16.0}, {68.0, 32.0, 112.0}, 10.0);
        return std::min(a, b);
    };
}

struct SampleEntry {
    SampleInfo info;
    DistanceFunction (*makeDistance)();
};

const std::vector<SampleEntry>& sampleTable()
{
    static const std::vector<SampleEntry> table = {
        {{"phantom",
          "256x256x512 tube, centre line wandering in x and y, radius breathing 21-31 "
          "(the paper's phantom; default input)",
          {256, 256, 512}, 1.0},
         &phantomDistance},
        {{"straight", "64x64x128 capsule of radius 10 along z: circular contours, round end caps",
          {64, 64, 128}, 1.0},
         &straightDistance},
        {{"helix", "96x96x160 tube of radius 6 along two helix turns: contours moving between slices",
          {96, 96, 160}, 1.0},
         &helixDistance},
        {{"bean", "96x96x96 extruded C shape: centroid inside, but rays from it cross three times",
          {96, 96, 96}, 1.0},
         &beanDistance},
        {{"hollow", "96x96x128 annular tube (radii 14 and 26): a hole in every cross-section",
          {96, 96, 128}, 1.0},
         &hollowDistance},
        {{"ybranch", "128x128x160 trunk forking into two branches: one contour becomes two",
          {128, 128, 160}, 1.0},
         &ybranchDistance},
        {{"two-tubes", "96x64x128 two parallel capsules of radius 10: two contours per slice",
          {96, 64, 128}, 1.0},
         &twoTubesDistance},
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
    return levelSetFromDistance(entry.makeDistance(), entry.info.dims, entry.info.voxelSize,
                                "sample:" + name);
}

Volume levelSetFromDistance(const DistanceFunction& distance, const glm::ivec3& dims,
                            double voxelSize, const std::string& source)
{
    using LeafT = openvdb::FloatTree::LeafNodeType;
    constexpr int kBlock = static_cast<int>(LeafT::DIM);

    if (!distance) throw Error(source + ": no distance function to sample");
    if (dims.x <= 0 || dims.y <= 0 || dims.z <= 0) {
        std::ostringstream message;
        message << source << ": grid dimensions must be positive, got " << dims.x << 'x' << dims.y
                << 'x' << dims.z;
        throw Error(message.str());
    }
    if (!(voxelSize > 0.0) || !std::isfinite(voxelSize)) {
        throw Error(source + ": voxel size must be positive and finite, got "
                    + std::to_string(voxelSize));
    }

    const double background = kHalfWidthVoxels * voxelSize;
    const float backgroundValue = static_cast<float>(background);
    // phi is 1-Lipschitz, so a block whose centre is farther than this from the surface holds no
    // band voxel, and all its voxels share the centre's sign.
    const double blockReach =
        (kHalfWidthVoxels + kBlockHalfDiagonalVoxels + kBlockSafetyVoxels) * voxelSize;
    const glm::ivec3 blocks = (dims + (kBlock - 1)) / kBlock;
    const std::size_t blocksY = static_cast<std::size_t>(blocks.y);
    const std::size_t blocksZ = static_cast<std::size_t>(blocks.z);
    const std::size_t blockCount = static_cast<std::size_t>(blocks.x) * blocksY * blocksZ;

    const auto checked = [&](const glm::dvec3& world) {
        const double d = distance(world);
        if (std::isnan(d)) {
            std::ostringstream message;
            message << source << ": the distance function is NaN at world point (" << world.x
                    << ", " << world.y << ", " << world.z << ")";
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
