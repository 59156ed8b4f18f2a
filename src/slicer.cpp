// pipetile — slicer: slicing axis, slice positions, and sampling the grid on one slice plane.

#include <pipetile/slicer.h>

#include <pipetile/detail/pixel_window.h>
#include <pipetile/error.h>
#include <pipetile/volume_grid.h>

#include <glm/common.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

namespace pipetile {

namespace {

constexpr int kLeafDim = 8; // openvdb::FloatTree leaf nodes are 8^3

int floorDiv(int a, int b)
{
    return a >= 0 ? a / b : -((-a + b - 1) / b);
}

} // namespace

glm::dvec3 planeToIndex(int axis, const glm::dvec2& uv, double w)
{
    glm::dvec3 p;
    p[axis] = w;
    p[(axis + 1) % 3] = uv.x;
    p[(axis + 2) % 3] = uv.y;
    return p;
}

SlicePlan planSlices(const Volume& volume, const SliceOptions& options)
{
    if (!std::isfinite(options.spacingVoxels) || options.spacingVoxels < 0.1 || options.spacingVoxels > 1000.0)
        throw UsageError("the slice spacing must be between 0.1 and 1000 voxels (got " +
                             std::to_string(options.spacingVoxels) + ")",
                         {Setting::Spacing});
    const glm::ivec3 lo = volume.bboxMin(), hi = volume.bboxMax();
    SlicePlan plan;
    if (options.axis == Axis::Auto) {
        // The longest side in world units: anisotropic voxels count at their real length.
        double best = -1.0;
        const glm::dvec3 origin = volume.indexToWorld(glm::dvec3(0.0));
        for (int a = 0; a < 3; ++a) {
            glm::dvec3 unit(0.0);
            unit[a] = 1.0;
            const glm::dvec3 step = volume.indexToWorld(unit) - origin;
            const double voxels = static_cast<double>(hi[a]) - lo[a] + 1.0; // in 64 bits: 3e9 voxels apart fit
            const double length = voxels * std::sqrt(step.x * step.x + step.y * step.y + step.z * step.z);
            if (length > best + 1e-9) {
                best = length;
                plan.axis = a;
            }
        }
    } else {
        plan.axis = static_cast<int>(options.axis);
    }
    const int a = plan.axis, ua = (a + 1) % 3, va = (a + 2) % 3;
    plan.pixelMin = glm::ivec2(lo[ua] - 1, lo[va] - 1);
    plan.pixelMax = glm::ivec2(hi[ua] + 1, hi[va] + 1);

    // Bucket the leaf nodes by their slab along w, so a plane finds its boundary seeds without
    // visiting the whole tree.
    const openvdb::FloatTree& tree = gridOf(volume).tree();
    const int slabMin = floorDiv(lo[a], kLeafDim) * kLeafDim;
    for (auto leaf = tree.cbeginLeaf(); leaf; ++leaf) {
        const openvdb::Coord o = leaf->origin();
        if (o[a] < slabMin || o[a] > hi[a]) continue;
        plan.leafFootprints[o[a]].push_back(glm::ivec2(o[ua], o[va]));
    }
    // Tree iteration order is deterministic, but sort anyway so seeds never depend on it.
    for (auto& [slab, footprints] : plan.leafFootprints)
        std::sort(footprints.begin(), footprints.end(),
                  [](const glm::ivec2& p, const glm::ivec2& q) { return p.y != q.y ? p.y < q.y : p.x < q.x; });

    // Planes every spacing from the low end, kept where leaves lie: a plane elsewhere reads
    // nothing but empty space (boundaries lie in leaf nodes, volume.h), and so does the slab
    // between two such planes. One plane of empty space is kept either side of each run of
    // slabs, so that every tube still ends in a slab between a plane of its own and an empty one.
    const double spacing = options.spacingVoxels, pad = spacing + 1.0;
    std::vector<std::pair<double, double>> occupied; // runs of slabs, padded, increasing in w
    for (const auto& [slab, footprints] : plan.leafFootprints) {
        const double from = slab - pad, to = slab + (kLeafDim - 1) + pad;
        if (!occupied.empty() && from <= occupied.back().second)
            occupied.back().second = to;
        else
            occupied.emplace_back(from, to);
    }
    const long long last = static_cast<long long>(std::floor((static_cast<double>(hi[a]) - lo[a]) / spacing));
    long long next = 0;
    for (const auto& [from, to] : occupied) {
        const long long first = std::max(next, static_cast<long long>(std::ceil((from - lo[a]) / spacing)));
        const long long end = std::min(last, static_cast<long long>(std::floor((to - lo[a]) / spacing)));
        for (long long i = first; i <= end; ++i) plan.positions.push_back(lo[a] + static_cast<double>(i) * spacing);
        next = std::max(next, end + 1);
    }
    return plan;
}

struct SlicePlane::Impl {
    const Volume* volume;
    const SlicePlan* plan;
    double w;
    int w0;      // voxel plane below (or at) w
    double frac; // w - w0, in [0, 1)
    double sign; // +1 level set, -1 fog: turns values into the signed field
    double iso;
    int ua, va; // grid axes of u and v
    // Unregistered: a registered accessor enters a concurrent hash map in the tree on every
    // construction and leaves it on destruction (a plane per slice and level). The grid is never
    // modified while a plane exists, so no cache can go stale.
    mutable openvdb::FloatGrid::ConstUnsafeAccessor accessor;
    struct Cell {
        bool valid = false;
        int u = 0, v = 0;
        double values[4] = {0.0, 0.0, 0.0, 0.0}; // (u, v), (u+1, v), (u, v+1), (u+1, v+1)
    };
    mutable Cell cell; // the last bilinear cell sampled
    // For the boundary walk: the plane's field over the leaf nodes it crosses and one block
    // around them, read once from the leaf buffers. The seed scan and the walk read each pixel
    // several times, and an accessor lookup per read cost more than the rest of the slicing
    // together. Ray casting reads few pixels and does not build it. Pixels outside are read
    // through the accessor.
    std::vector<glm::ivec2> leafOrigins; // (u, v) origins of the leaves the plane reads, sorted (v, u)
    std::unique_ptr<double[]> image;     // every pixel is written: no need to clear it first
    glm::ivec2 imageMin{0};
    int imageWidth = 0, imageHeight = 0;

    Impl(const Volume& vol, const SlicePlan& p, double wPlane)
        : volume(&vol),
          plan(&p),
          w(wPlane),
          w0(static_cast<int>(std::floor(wPlane))),
          frac(wPlane - std::floor(wPlane)),
          sign(vol.volumeClass() == VolumeClass::LevelSet ? 1.0 : -1.0),
          iso(vol.iso()),
          ua((p.axis + 1) % 3),
          va((p.axis + 2) % 3),
          accessor(gridOf(vol).getConstUnsafeAccessor())
    {
    }

    void readLeaves()
    {
        const SlicePlan& p = *plan;
        // The plane reads voxel planes w0 and, between planes, w0 + 1: their leaves hold the boundary.
        for (int wi : {w0, w0 + 1}) {
            if (wi == w0 + 1 && frac == 0.0) break;
            const auto slab = p.leafFootprints.find(floorDiv(wi, kLeafDim) * kLeafDim);
            if (slab == p.leafFootprints.end()) continue;
            leafOrigins.insert(leafOrigins.end(), slab->second.begin(), slab->second.end());
        }
        std::sort(leafOrigins.begin(), leafOrigins.end(),
                  [](const glm::ivec2& a, const glm::ivec2& b) { return a.y != b.y ? a.y < b.y : a.x < b.x; });
        leafOrigins.erase(std::unique(leafOrigins.begin(), leafOrigins.end()), leafOrigins.end());
        if (leafOrigins.empty()) return;
        glm::ivec2 lo = leafOrigins.front(), hi = lo;
        for (const glm::ivec2& o : leafOrigins) {
            lo = glm::min(lo, o);
            hi = glm::max(hi, o);
        }
        lo -= kLeafDim;
        hi += 2 * kLeafDim;
        // In 64 bits: leaves 2^31 voxels apart are possible.
        const double pixels = (static_cast<double>(hi.x) - lo.x) * (static_cast<double>(hi.y) - lo.y);
        // Leaves scattered far apart (two small objects) would make a huge, empty image: read
        // those through the accessor.
        if (pixels > std::max(double(1 << 20), 16.0 * kLeafDim * kLeafDim * static_cast<double>(leafOrigins.size())))
            return;
        imageMin = lo;
        imageWidth = hi.x - lo.x;
        imageHeight = hi.y - lo.y;
        const std::size_t count = static_cast<std::size_t>(imageWidth) * static_cast<std::size_t>(imageHeight);
        image.reset(new double[count]);
        readVoxelPlane(w0, lo, hi, image.get());
        if (frac == 0.0) return;
        // Between voxel planes: the interpolation, and the bridges that need both planes' own values.
        const std::vector<double> lower(image.get(), image.get() + count);
        std::vector<double> upper(count);
        readVoxelPlane(w0 + 1, lo, hi, upper.data());
        for (std::size_t k = 0; k < count; ++k) image[k] += frac * (upper[k] - image[k]);
        showContacts(lower, upper);
    }

    // Voxel plane wi's signed values over the pixels [lo, hi), row-major, read from the leaf
    // buffers (tiles and empty space through the accessor, once per leaf-sized block).
    void readVoxelPlane(int wi, const glm::ivec2& lo, const glm::ivec2& hi, double* out) const
    {
        // Offset of voxel (x, y, z) in a leaf's buffer: (x & 7) * 64 + (y & 7) * 8 + (z & 7).
        constexpr int kStride[3] = {kLeafDim * kLeafDim, kLeafDim, 1};
        const int wOffset = (wi & (kLeafDim - 1)) * kStride[plan->axis];
        for (int bv = lo.y; bv < hi.y; bv += kLeafDim)
            for (int bu = lo.x; bu < hi.x; bu += kLeafDim) {
                openvdb::Coord c;
                c[plan->axis] = wi;
                c[ua] = bu;
                c[va] = bv;
                const openvdb::FloatTree::LeafNodeType* leaf = accessor.probeConstLeaf(c);
                const float* data = leaf ? leaf->buffer().data() : nullptr;
                const double tile = leaf ? 0.0 : signedValue(accessor.getValue(c));
                for (int dv = 0; dv < kLeafDim; ++dv) {
                    double* row = &out[static_cast<std::size_t>(bv + dv - lo.y) * imageWidth + (bu - lo.x)];
                    const float* column = data ? data + wOffset + dv * kStride[va] : nullptr;
                    if (column) {
                        for (int du = 0; du < kLeafDim; ++du) {
                            row[du] = signedValue(column[du * kStride[ua]]);
                            if (row[du] == 0.0) row[du] = settled(bu + du, bv + dv, wi);
                        }
                    } else {
                        std::fill(row, row + kLeafDim, tile);
                    }
                }
            }
    }

    // Voxels of planes w0 and w0 + 1 that touch along an edge across them (a saddle on the face
    // between them) are one region or not as volumeToMesh decides (saddleJoinsInside), but a plane
    // between them shows an average of inside and outside, which may decide the other way:
    // - where volumeToMesh joins the inside pair and the plane shows them apart, both pixels are
    //   made inside (barely), so that the walk and the slab see the bridge at every plane between;
    // - where it joins the outside pair and one of them is a voxel its own plane encloses (in a
    //   pocket of a few outside pixels there), the plane must show that voxel's way out, else it
    //   is a void of its own (the gaffer smoke along z had two): unless the plane shows both
    //   pixels outside already, both are made as far outside as their outside voxels are.
    //   (Barely outside, they made holes of no area, which the slices drop; parting such pixels
    //   where neither voxel is enclosed, and the face only decides which side closes a loop, lost
    //   components along x and z.)
    void showContacts(const std::vector<double>& low, const std::vector<double>& high)
    {
        auto at = [&](const glm::ivec2& q) { return static_cast<std::size_t>(q.y) * imageWidth + q.x; };
        auto inside = [&](int plane, const glm::ivec2& q) {
            const bool held = q.x >= 0 && q.y >= 0 && q.x < imageWidth && q.y < imageHeight;
            return held && (plane == 0 ? low : high)[at(q)] < 0.0;
        };
        // An outside pixel of a pocket of its plane: at most kPocket outside pixels, joined along
        // their edges, that inside pixels there close in (diagonal neighbours aside, as for one
        // voxel alone). A void of two voxels in each plane, the pairs joined across the planes
        // along voxel edges, is a void of its own without its way out as much as one voxel is (a
        // crop of the smoke had three such; pockets joined at corners too parted other crops').
        constexpr std::size_t kPocket = 4;
        auto enclosed = [&](int plane, const glm::ivec2& q) {
            std::vector<glm::ivec2> pocket{q};
            for (std::size_t k = 0; k < pocket.size(); ++k)
                for (const glm::ivec2 step :
                     {glm::ivec2(1, 0), glm::ivec2(-1, 0), glm::ivec2(0, 1), glm::ivec2(0, -1)}) {
                    const glm::ivec2 r = pocket[k] + step;
                    if (inside(plane, r) || std::find(pocket.begin(), pocket.end(), r) != pocket.end()) continue;
                    if (pocket.size() == kPocket) return false;
                    pocket.push_back(r);
                }
            return true;
        };
        constexpr double kBarelyInside = -1e-9;
        const bool levelSet = sign > 0.0;
        std::vector<std::size_t> bridged;
        std::vector<std::pair<std::size_t, double>> parted; // with the value each takes
        for (int y = 1; y + 1 < imageHeight; ++y)
            for (int x = 1; x + 1 < imageWidth; ++x) {
                const glm::ivec2 a(x, y);
                if (!inside(0, a) || inside(1, a)) continue; // inside below, outside above
                for (const glm::ivec2 step :
                     {glm::ivec2(1, 0), glm::ivec2(-1, 0), glm::ivec2(0, 1), glm::ivec2(0, -1)}) {
                    const glm::ivec2 b = a + step;
                    if (inside(0, b) || !inside(1, b)) continue; // outside below, inside above
                    const bool shownInside = image[at(a)] < 0.0 && image[at(b)] < 0.0;
                    const bool shownOutside = !(image[at(a)] < 0.0) && !(image[at(b)] < 0.0);
                    if (contactJoins(levelSet, inside, a, b)) {
                        if (shownInside) continue; // the plane shows it already
                        bridged.push_back(at(a));
                        bridged.push_back(at(b));
                    } else if (!shownOutside && (enclosed(0, b) || enclosed(1, a))) {
                        parted.emplace_back(at(a), high[at(a)]);
                        parted.emplace_back(at(b), low[at(b)]);
                    }
                }
            }
        // A pixel parted by one face and bridged by another stays inside, as before parting.
        for (const auto& [k, value] : parted) image[k] = std::max(image[k], value);
        for (std::size_t k : bridged) image[k] = std::min(image[k], kBarelyInside);
    }

    // A fog voxel at the isovalue itself lies inside, a hair from the surface: volumeToMesh parts
    // the two sides by value < iso, which is a fog's outside, so it takes such a voxel for the
    // dense side (the gaffer smoke's default isovalue is the value of 19 of its voxels).
    double signedValue(float value) const
    {
        const double f = sign * (static_cast<double>(value) - iso);
        return f == 0.0 && sign < 0.0 ? -std::numeric_limits<double>::min() : f;
    }

    // A level set's voxel at the isovalue itself lies on the surface, and volumeToMesh takes it
    // for outside. Where none of its four neighbours in its plane lies outside and one lies
    // inside, it is taken for inside, a hair from the surface: such voxels line a void's tangent
    // plane (the hollow Y's channel sliced along y, at y = 38 on the voxel grid), where as outside
    // they cut slits and pinholes of no area into the wall, which no contour keeps but the cells
    // count (a merge there could not be patched, and its junction fanned across the crotch: 2.86
    // voxels off). A solid's tangent plane (a ridge, outside on both sides) and the surface
    // passing through a voxel (outside on one side) stay as volumeToMesh has them. The voxel
    // decides alone, from its own plane: the same wherever it is read.
    double settled(int u, int v, int wi) const
    {
        int inside = 0, outside = 0;
        for (const glm::ivec2 step : {glm::ivec2(1, 0), glm::ivec2(-1, 0), glm::ivec2(0, 1), glm::ivec2(0, -1)}) {
            const double f = rawVoxel(u + step.x, v + step.y, wi);
            inside += f < 0.0 ? 1 : 0;
            outside += f > 0.0 ? 1 : 0;
        }
        return inside > 0 && outside == 0 ? -std::numeric_limits<double>::min() : 0.0;
    }

    double rawVoxel(int u, int v, int wi) const
    {
        openvdb::Coord c;
        c[plan->axis] = wi;
        c[ua] = u;
        c[va] = v;
        return signedValue(accessor.getValue(c));
    }

    double voxel(int u, int v, int wi) const
    {
        const double f = rawVoxel(u, v, wi);
        return f == 0.0 ? settled(u, v, wi) : f;
    }

    void readCell(int u, int v, double f[4]) const
    {
        const int x = u - imageMin.x, y = v - imageMin.y;
        if (x >= 0 && y >= 0 && x + 1 < imageWidth && y + 1 < imageHeight) {
            const double* row = &image[static_cast<std::size_t>(y) * imageWidth + x];
            f[0] = row[0];
            f[1] = row[1];
            f[2] = row[imageWidth];
            f[3] = row[imageWidth + 1];
            return;
        }
        if ((u & (kLeafDim - 1)) == kLeafDim - 1 || (v & (kLeafDim - 1)) == kLeafDim - 1) {
            f[0] = pixel(u, v);
            f[1] = pixel(u + 1, v);
            f[2] = pixel(u, v + 1);
            f[3] = pixel(u + 1, v + 1);
            return;
        }
        // All four pixels lie in one leaf per voxel plane: read its buffer directly, at
        // (x & 7) * 64 + (y & 7) * 8 + (z & 7).
        constexpr int kStride[3] = {kLeafDim * kLeafDim, kLeafDim, 1};
        for (int plane = 0; plane < (frac == 0.0 ? 1 : 2); ++plane) {
            openvdb::Coord c;
            c[plan->axis] = w0 + plane;
            c[ua] = u;
            c[va] = v;
            double g[4];
            if (const openvdb::FloatTree::LeafNodeType* leaf = accessor.probeConstLeaf(c)) {
                const float* at = leaf->buffer().data() + openvdb::FloatTree::LeafNodeType::coordToOffset(c);
                const int du = kStride[ua], dv = kStride[va];
                g[0] = signedValue(at[0]);
                g[1] = signedValue(at[du]);
                g[2] = signedValue(at[dv]);
                g[3] = signedValue(at[du + dv]);
                const glm::ivec2 corner[4] = {{u, v}, {u + 1, v}, {u, v + 1}, {u + 1, v + 1}};
                for (int k = 0; k < 4; ++k)
                    if (g[k] == 0.0) g[k] = settled(corner[k].x, corner[k].y, w0 + plane);
            } else {
                g[0] = g[1] = g[2] = g[3] = signedValue(accessor.getValue(c)); // one tile holds all four
            }
            for (int k = 0; k < 4; ++k) f[k] = plane == 0 ? g[k] : f[k] + frac * (g[k] - f[k]);
        }
    }

    double pixel(int u, int v) const
    {
        const int x = u - imageMin.x, y = v - imageMin.y;
        if (x >= 0 && y >= 0 && x < imageWidth && y < imageHeight)
            return image[static_cast<std::size_t>(y) * imageWidth + x];
        const double a = voxel(u, v, w0);
        return frac == 0.0 ? a : a + frac * (voxel(u, v, w0 + 1) - a);
    }
};

SlicePlane::SlicePlane(const Volume& volume, const SlicePlan& plan, double w)
    : mImpl(std::make_unique<Impl>(volume, plan, w))
{
}
SlicePlane::~SlicePlane() = default;
SlicePlane::SlicePlane(SlicePlane&&) noexcept = default;
SlicePlane& SlicePlane::operator=(SlicePlane&&) noexcept = default;

double SlicePlane::w() const
{
    return mImpl->w;
}
const SlicePlan& SlicePlane::plan() const
{
    return *mImpl->plan;
}

double SlicePlane::value(int u, int v) const
{
    return mImpl->pixel(u, v);
}

bool SlicePlane::inside(int u, int v) const
{
    const SlicePlan& p = *mImpl->plan;
    if (u < p.pixelMin.x || v < p.pixelMin.y || u > p.pixelMax.x || v > p.pixelMax.y) return false;
    return mImpl->pixel(u, v) < 0.0;
}

double SlicePlane::sample(const glm::dvec2& uv) const
{
    // floor, inline (std::floor is a library call without SSE4.1)
    int u = static_cast<int>(uv.x), v = static_cast<int>(uv.y);
    u -= uv.x < u ? 1 : 0;
    v -= uv.y < v ? 1 : 0;
    const double fu = u, fv = v;
    const double s = uv.x - fu, t = uv.y - fv;
    // Root finding along a ray samples the same pixel cell several times in a row.
    Impl::Cell& cell = mImpl->cell;
    if (!cell.valid || cell.u != u || cell.v != v) {
        cell.valid = true;
        cell.u = u;
        cell.v = v;
        mImpl->readCell(u, v, cell.values);
    }
    const double* f = cell.values;
    return (1.0 - t) * (f[0] + s * (f[1] - f[0])) + t * (f[2] + s * (f[3] - f[2]));
}

void SlicePlane::cell(int u, int v, double values[4]) const
{
    mImpl->readCell(u, v, values);
}

double SlicePlane::sampleAt(const glm::dvec2& uv, double w) const
{
    const double fw = std::floor(w);
    const int wi = static_cast<int>(fw);
    const double r = w - fw;
    const double fu = std::floor(uv.x), fv = std::floor(uv.y);
    const int u = static_cast<int>(fu), v = static_cast<int>(fv);
    const double s = uv.x - fu, t = uv.y - fv;
    auto bilinear = [&](int plane) {
        const double a = mImpl->voxel(u, v, plane), b = mImpl->voxel(u + 1, v, plane);
        const double c = mImpl->voxel(u, v + 1, plane), d = mImpl->voxel(u + 1, v + 1, plane);
        return (1.0 - t) * (a + s * (b - a)) + t * (c + s * (d - c));
    };
    const double lower = bilinear(wi);
    return r == 0.0 ? lower : lower + r * (bilinear(wi + 1) - lower);
}

bool saddleJoinsInside(bool levelSet, const bool beside[2][4])
{
    bool joined = false; // volumeToMesh's own pair: ours for a level set, the other for fog
    for (int s = 0; s < 2; ++s) {
        auto below = [&](int k) { return beside[s][k] == levelSet; };
        const int own = levelSet ? 0 : 2, other = levelSet ? 2 : 0;
        joined = joined || (below(own) && below(own + 1)) || below(other) || below(other + 1);
    }
    return levelSet ? joined : !joined;
}

bool SlicePlane::saddleJoins(const glm::ivec2& corner) const
{
    const Impl& im = *mImpl;
    if (im.frac != 0.0) return true;
    const SlicePlan& p = *im.plan;
    auto inside = [&](const glm::ivec2& q, int wi) {
        const bool boxed = q.x >= p.pixelMin.x && q.y >= p.pixelMin.y && q.x <= p.pixelMax.x && q.y <= p.pixelMax.y;
        return boxed && im.voxel(q.x, q.y, wi) < 0.0;
    };
    glm::ivec2 block[4] = {corner - 1, corner, {corner.x, corner.y - 1}, {corner.x - 1, corner.y}};
    if (!inside(block[0], im.w0)) std::swap(block[0], block[2]), std::swap(block[1], block[3]); // inside pair first
    bool beside[2][4];
    for (int s = 0; s < 2; ++s)
        for (int k = 0; k < 4; ++k) beside[s][k] = inside(block[k], im.w0 + (s == 0 ? -1 : 1));
    return saddleJoinsInside(im.sign > 0.0, beside);
}

detail::PixelWindow detail::pixelWindow(const SlicePlane& plane)
{
    const SlicePlane::Impl& im = *plane.mImpl;
    return {im.image.get(), im.imageMin, im.imageWidth, im.imageHeight};
}

std::vector<glm::ivec2> SlicePlane::eastCracks() const
{
    if (mImpl->leafOrigins.empty()) mImpl->readLeaves();
    const std::vector<glm::ivec2>& origins = mImpl->leafOrigins;
    const Impl& im = *mImpl;
    const SlicePlan& p = *im.plan;
    std::vector<glm::ivec2> cracks;
    for (const glm::ivec2& o : origins) {
        // Leaves inside the image and the pixel box (all but a few) are scanned row by row in place.
        const int x = o.x - im.imageMin.x, y = o.y - im.imageMin.y;
        const bool fast = x >= 0 && y >= 0 && x + kLeafDim < im.imageWidth && y + kLeafDim <= im.imageHeight &&
                          o.x >= p.pixelMin.x && o.y >= p.pixelMin.y && o.x + kLeafDim <= p.pixelMax.x &&
                          o.y + kLeafDim - 1 <= p.pixelMax.y;
        for (int v = o.y; v < o.y + kLeafDim; ++v) {
            // Bit i: pixel o.x + i is inside, for i in [0, 8]; a crack where bit i is set and bit
            // i + 1 is not.
            unsigned mask = 0;
            if (fast) {
                const double* row = &im.image[static_cast<std::size_t>(v - im.imageMin.y) * im.imageWidth + x];
                for (int i = 0; i <= kLeafDim; ++i) mask |= static_cast<unsigned>(row[i] < 0.0) << i;
            } else {
                for (int i = 0; i <= kLeafDim; ++i) mask |= static_cast<unsigned>(inside(o.x + i, v)) << i;
            }
            for (unsigned east = mask & ~(mask >> 1) & ((1u << kLeafDim) - 1); east != 0; east &= east - 1)
                cracks.push_back(glm::ivec2(o.x + __builtin_ctz(east), v));
        }
    }
    std::sort(cracks.begin(), cracks.end(),
              [](const glm::ivec2& a, const glm::ivec2& b) { return a.y != b.y ? a.y < b.y : a.x < b.x; });
    return cracks;
}

} // namespace pipetile
