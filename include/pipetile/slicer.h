// pipetile — slicer: slicing axis, slice positions, and sampling the grid on one slice plane.
//
// A slice is an index-space plane w = const, where (u, v, w) is a cyclic permutation of the grid's
// (x, y, z) with w the slicing axis: axis z gives (x, y, z), axis x gives (y, z, x), axis y gives
// (z, x, y). Cyclic permutations keep (u, v, w) right-handed, so a counterclockwise walk in (u, v)
// seen from +w stays counterclockwise in the grid. Pixel (u, v) is the voxel column at integer u, v.
// The grid is read through OpenVDB accessors; no dense copy of the volume is made.
#pragma once

#include <pipetile/volume.h>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <map>
#include <memory>
#include <vector>

namespace pipetile {

class SlicePlane;

namespace detail {
struct PixelWindow;                               // detail/pixel_window.h
PixelWindow pixelWindow(const SlicePlane& plane); // the boundary walk's fast path
} // namespace detail

enum class Axis { X = 0, Y = 1, Z = 2, Auto = 3 };

struct SliceOptions {
    Axis axis = Axis::Auto;     // Auto: the longest world-space side of the active bounding box
    double spacingVoxels = 2.0; // distance between slices, in voxels along the slicing axis
};

/// Where the slices go. Plain data: cheap to copy, no OpenVDB types.
struct SlicePlan {
    int axis = 2;                                          // 0, 1, 2 for x, y, z (never Auto)
    std::vector<double> positions;                         // index coordinate w of each slice, increasing
    glm::ivec2 pixelMin{0}, pixelMax{0};                   // in-plane pixel box (inclusive): the active bounding box
                                                           // padded by one pixel; everything outside reads as outside
    std::map<int, std::vector<glm::ivec2>> leafFootprints; // per 8-voxel slab along w that holds
        // leaf nodes, by its w origin: the (u, v) origins of its leaves
};

/// Index-space point of in-plane coordinates (u, v) on the plane w of `axis`.
glm::dvec3 planeToIndex(int axis, const glm::dvec2& uv, double w);

/// Chooses the axis and slice positions: from the low to the high end of the active bounding box
/// along the axis, every `spacingVoxels`, where leaf nodes lie (with one plane of empty space
/// either side): far-apart objects in one sparse grid cost their own slices, not the gap's.
/// @throw UsageError if the spacing is not a finite number in [0.1, 1000].
SlicePlan planSlices(const Volume& volume, const SliceOptions& options);

/// A saddle face of four voxels: two diagonal corners inside, the other two outside. Whether the
/// inside pair is one region, as volumeToMesh's cell tables decide it from the two faces beside
/// it (the same four positions shifted one voxel either way along the face's normal):
/// `beside[s]` holds, on side s, whether the inside pair's two positions and then the outside
/// pair's two are inside. The tables join the pair below the iso value (the inside of a level
/// set, the outside of a fog volume) unless neither side holds one of the other pair's positions
/// below it nor both of its own: a contact along one voxel edge only, left open; the other pair is
/// then the joined one. (Found on all 256 configurations of the two sides.)
bool saddleJoinsInside(bool levelSet, const bool beside[2][4]);

/// A contact across two voxel planes: `a` inside on the lower plane and its neighbour `b` inside on
/// the upper one, `b` below and `a` above outside. Whether volumeToMesh joins a and b
/// (saddleJoinsInside, with the faces beside this one along its normal); `inside(plane, pixel)`
/// reads plane 0 (lower) or 1 (upper), false outside what it holds.
template <class InsideFn>
bool contactJoins(bool levelSet, const InsideFn& inside, const glm::ivec2& a, const glm::ivec2& b)
{
    const glm::ivec2 step = b - a, normal(step.y, step.x);
    bool beside[2][4];
    for (int s = 0; s < 2; ++s) {
        const glm::ivec2 shift = s == 0 ? -normal : normal;
        beside[s][0] = inside(0, a + shift);
        beside[s][1] = inside(1, b + shift);
        beside[s][2] = inside(0, b + shift);
        beside[s][3] = inside(1, a + shift);
    }
    return saddleJoinsInside(levelSet, beside);
}

/// The signed field (negative inside) on one slice plane. Stateful: it owns an OpenVDB accessor,
/// so use one object per thread. It keeps references to the Volume and the SlicePlan it was made
/// from: both must outlive it. Coordinates are in-plane pixels (u, v), index space (see above);
/// nothing here is in world units. Reads throw nothing. Values between voxel planes are
/// interpolated linearly along w, except in the image eastCracks() reads, where a contact across
/// the two voxel planes is shown as volumeToMesh decides it (saddleJoinsInside), which the
/// interpolation, an average of inside and outside, may not show: both pixels of a contact it joins
/// are made barely inside (a bridge), and both of one whose outside pair it joins, through a voxel
/// its own plane encloses, are made outside.
class SlicePlane {
public:
    /// @param volume [in] the grid to read; must be valid() and outlive the plane
    /// @param plan [in] from planSlices(volume, ...); must outlive the plane
    /// @param w index coordinate along plan.axis, usually one of plan.positions (any finite value)
    SlicePlane(const Volume& volume, const SlicePlan& plan, double w);
    ~SlicePlane();
    SlicePlane(SlicePlane&&) noexcept;
    SlicePlane& operator=(SlicePlane&&) noexcept;

    /// Field at pixel (u, v). Pixels outside the plan's pixel box read as the background.
    double value(int u, int v) const;
    /// Inside test of the chain-code walk: false outside the plan's pixel box, so every walk closes.
    bool inside(int u, int v) const;
    /// Bilinear field at a continuous in-plane point, in pixel units.
    double sample(const glm::dvec2& uv) const;
    /// The four pixels of the bilinear cell at (u, v): value(u, v), value(u + 1, v),
    /// value(u, v + 1), value(u + 1, v + 1), read together (one leaf lookup, not four).
    void cell(int u, int v, double values[4]) const;
    /// Trilinear field at (u, v) on another plane w; end caps look past the last slice with it.
    double sampleAt(const glm::dvec2& uv, double w) const;
    /// At a saddle, where the four pixels around `corner` (corner - (1, 1) to corner) are inside
    /// on one diagonal and outside on the other: whether the two inside pixels are one region.
    /// On a voxel plane, as volumeToMesh decides it (saddleJoinsInside, with the voxel planes on
    /// either side); between voxel planes there is no such rule: joined, as the 8-connected walk
    /// always did.
    bool saddleJoins(const glm::ivec2& corner) const;
    /// Pixels p inside whose neighbour p + (1, 0) is outside: every boundary loop has at least one
    /// such east-facing crack. Only the leaf nodes crossing the plane are scanned. Sorted (v, u).
    std::vector<glm::ivec2> eastCracks() const;
    double w() const;
    const SlicePlan& plan() const;

private:
    friend detail::PixelWindow detail::pixelWindow(const SlicePlane& plane);
    struct Impl;
    std::unique_ptr<Impl> mImpl;
};

} // namespace pipetile
