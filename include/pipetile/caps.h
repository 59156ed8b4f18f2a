// pipetile — caps: closing where tubes end. A tube's end is sought beyond its last slice along
// the slicing axis (the apex), so caps follow rounded ends instead of cutting them flat; an end
// contour that is not star-shaped is closed flat by ear clipping. Rims, annuli and the end
// contours themselves are placed with these by the reconstruction's closeEnds stage (multires.h),
// which caps.cpp defines too.
#pragma once

#include <pipetile/contour.h>
#include <pipetile/slicer.h>
#include <pipetile/tiler.h>

#include <glm/vec2.hpp>

#include <vector>

namespace pipetile {

/// Where the region around `point` ends along the slicing axis, beyond `plane`: marches from the
/// plane in `direction` (+1 or -1), a quarter voxel at a time up to `reach` voxels, until the
/// field leaves the region, then bisects. The region is the inside (`sign` +1) or, for a hole,
/// the outside (`sign` -1). Returns false, leaving `w` alone, if the point is not in the region
/// on the plane or the region goes on past `reach`. `point` is in the plane's pixels, `reach` in
/// voxels along the axis, and `w` (out) an index coordinate. Throws nothing.
bool findApex(const SlicePlane& plane, const glm::dvec2& point, double direction, double reach, double& w,
              double sign = 1.0);

/// How far the region inside `loop` reaches beyond `plane`: findApex from pixel and cell centres
/// in the loop (at most about 256 of each, evenly spread over its box), and the farthest of the places
/// they leave the region; false if none does within `reach`. A cap at an end contour leaves out
/// what lies beyond it, so this says how much a flat or twisted end would lose where the axis
/// through one central point ends early. Units as findApex's. Throws nothing.
bool farthestReach(const SlicePlane& plane, const BoundaryLoop& loop, double direction, double reach, double& w,
                   double sign = 1.0);

/// Triangulates a simple polygon by ear clipping: m - 2 triangles, turning as the polygon does
/// (counterclockwise, or clockwise for a hole's ring). Points that are copies of one another (a
/// junction's cut point on a crossing) may touch. Where rounding leaves no clean ear (a nearly
/// degenerate polygon), the most convex corner is clipped anyway, so the count, and the closed
/// mesh, never depend on it. The diagonals then flip where the other diagonal of their convex
/// quadrilateral makes the thinner triangle fatter (nearly straight corners make needle ears).
std::vector<Triangle> earClip(const std::vector<glm::dvec2>& polygon);

} // namespace pipetile
