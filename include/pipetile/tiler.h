// pipetile — tiler: the triangle band between two corresponding contours, and end caps.
//
// Integer-only: a band is computed from the contours' edge-type strings alone, never from
// coordinates (paper §4; DESIGN.md, Integer-only claim). src/tiler.cpp is compiled without
// floating-point registers on x86-64 to prove it.
#pragma once

#include <pipetile/contour.h>

#include <array>
#include <cstdint>
#include <vector>

namespace pipetile {

/// Three vertex ids, counterclockwise seen from outside.
using Triangle = std::array<std::uint32_t, 3>;

/// Tiles the band between contour A (slice k, m crossings) and contour B (slice k+1, n crossings),
/// both starting at their outermost InOut crossing of ray 0 and winding counterclockwise seen from
/// +w. Vertex ids: A's crossing i is i, B's crossing j is m + j.
///
/// Each contour is read as its main path through the sectors: an F edge moves it one sector on,
/// a B edge one back, U and D edges stay on their ray. Both contours are advanced together by
/// sector, so crossing x of A meets crossing x of B: for unambiguous star-shaped contours each
/// pair of F edges becomes one quad, split into two triangles.
///
/// Always returns exactly m + n triangles forming a closed strip: every contour edge lies in one
/// triangle, and consecutive triangles share a spanning edge (an acceptable surface).
std::vector<Triangle> tileBand(const std::vector<EdgeType>& a, const std::vector<EdgeType>& b);

/// Closes a contour of m crossings (ids 0..m-1) with a fan around an apex (id m): m triangles.
/// `top` caps the last contour of a tube (normals toward +w); otherwise the first (toward -w).
std::vector<Triangle> tileCap(std::uint32_t m, bool top);

/// Closes a contour of m >= 3 crossings without an apex: a fan from crossing 0, m - 2 triangles.
/// For caps whose apex was not found beyond the last slice (a tube ending inside another).
std::vector<Triangle> tileFlatCap(std::uint32_t m, bool top);

} // namespace pipetile
